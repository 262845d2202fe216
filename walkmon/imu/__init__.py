"""IMU attitude and camera-IMU fusion: the attitude cores (VQF, the default, or walkmon's own filter) and offline
smoother, the fusion (offline and the live stage), IMU-to-camera extrinsics, accelerometer calibration, and IMU
recordings as angle columns. No I/O: files are read in
:mod:`walkmon.tables` and the commands."""

from walkmon.imu.attitude import (
    DEFAULT_ATTITUDE_SETTINGS,
    DEFAULT_IMU_FILTER,
    HANDHELD_ATTITUDE_SETTINGS,
    AttitudeSettings,
    AttitudeTrack,
    ImuAttitudeFilter,
    ImuFilterSettings,
    estimate_attitude,
    smooth_attitude,
    track_attitude,
)
from walkmon.imu.calibration import AccelerometerCalibration, calibrate_accelerometer
from walkmon.imu.extrinsics import ExtrinsicsEstimate, estimate_extrinsics
from walkmon.imu.fusion import (
    DEFAULT_FUSION_SETTINGS,
    CameraImuFusion,
    FusionSettings,
    FusionTrack,
    LiveFusion,
    LiveFusionSettings,
    fuse_recording,
)
from walkmon.imu.recordings import (
    IMU_FILTERS,
    ImuRecording,
    fused_columns,
    imu_only_columns,
)

__all__ = [
    "DEFAULT_ATTITUDE_SETTINGS",
    "DEFAULT_FUSION_SETTINGS",
    "DEFAULT_IMU_FILTER",
    "HANDHELD_ATTITUDE_SETTINGS",
    "IMU_FILTERS",
    "AccelerometerCalibration",
    "AttitudeSettings",
    "AttitudeTrack",
    "CameraImuFusion",
    "ExtrinsicsEstimate",
    "FusionSettings",
    "FusionTrack",
    "ImuAttitudeFilter",
    "ImuFilterSettings",
    "ImuRecording",
    "LiveFusion",
    "LiveFusionSettings",
    "calibrate_accelerometer",
    "estimate_attitude",
    "estimate_extrinsics",
    "fuse_recording",
    "fused_columns",
    "imu_only_columns",
    "smooth_attitude",
    "track_attitude",
]
