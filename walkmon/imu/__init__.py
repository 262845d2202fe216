"""IMU attitude and camera-IMU fusion: the attitude filter and offline smoother, the fusion (offline and the live
stage), IMU-to-camera extrinsics, and IMU recordings as angle columns. No I/O: files are read in
:mod:`walkmon.tables` and the commands."""

from walkmon.imu.attitude import (
    DEFAULT_ATTITUDE_SETTINGS,
    HANDHELD_ATTITUDE_SETTINGS,
    AttitudeSettings,
    AttitudeTrack,
    ImuAttitudeFilter,
    estimate_attitude,
    smooth_attitude,
)
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
    "HANDHELD_ATTITUDE_SETTINGS",
    "IMU_FILTERS",
    "AttitudeSettings",
    "AttitudeTrack",
    "CameraImuFusion",
    "ExtrinsicsEstimate",
    "FusionSettings",
    "FusionTrack",
    "ImuAttitudeFilter",
    "ImuRecording",
    "LiveFusion",
    "LiveFusionSettings",
    "estimate_attitude",
    "estimate_extrinsics",
    "fuse_recording",
    "fused_columns",
    "imu_only_columns",
    "smooth_attitude",
]
