"""The IMU options of ``walkmon analyze`` (the IMU analysis is in :func:`walkmon.api.analyze`, its maths in
:mod:`walkmon.imu.recordings`)."""

from __future__ import annotations

import argparse
import math

from walkmon.imu.recordings import IMU_FILTERS

__all__ = ["add_imu_arguments", "finite_float"]


def finite_float(text: str) -> float:
    """argparse type: a finite number (no nan, inf, 1e999)."""
    try:
        value = float(text)
    except ValueError:
        msg = f"expected a number, got {text!r}"
        raise argparse.ArgumentTypeError(msg) from None
    if not math.isfinite(value):
        msg = f"expected a finite number, got {text!r}"
        raise argparse.ArgumentTypeError(msg)
    return value


def add_imu_arguments(p: argparse.ArgumentParser) -> None:
    """The IMU options of ``walkmon analyze`` (VIDEO becomes optional when --imu is given)."""
    g = p.add_argument_group("IMU (optional)")
    g.add_argument("--imu", metavar="IMU", help="imu.csv (t,gx,gy,gz,ax,ay,az; s, rad/s, m/s2), or telemetry:FILE for "
                   "the IMU an action camera (GoPro, Sony, Insta360, DJI, ...) stored in FILE (e.g. telemetry:VIDEO; "
                   "needs walkmon[telemetry]; mapped to camera axes, clock offset estimated): fused with the video, "
                   "or IMU-only analysis when no VIDEO is given; adds pitch_abs,roll_abs to angles.csv")
    g.add_argument("--imu-filter", choices=IMU_FILTERS, default="vqf",
                   help="IMU attitude core, for IMU-only analysis and under the fusion (default vqf, chosen on the real "
                   "BROAD trials; eskf / eskf-handheld: walkmon's own filter, for comparison); the live config's [imu] filter")
    g.add_argument("--imu-calib", metavar="JSON",
                   help="accelerometer calibration from 'walkmon calibrate-imu' (bias and scale removed from every sample)")
    g.add_argument("--imu-offset-s", type=finite_float, default=None, metavar="S",
                   help="seconds added to IMU timestamps to put them on the video clock (default 0 for imu.csv; "
                   "for telemetry: estimated from gyro vs visual rates)")
    g.add_argument("--imu-extrinsics", choices=("identity", "estimate"), default="identity",
                   help="IMU-to-camera rotation: identity (IMU axes = camera axes) or estimate it and the time "
                   "offset from this recording (gyro vs visual rates; result and residual in OUT/imu.json)")
