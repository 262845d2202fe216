"""Camera and IMU drivers, installed as ``walkmon.drivers``. Importing this package probes no hardware."""
