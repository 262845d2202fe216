"""walkmon: walking-posture monitoring from a chest-worn camera (and an optional IMU).

Importing walkmon never touches hardware. Public names are listed once, here.
"""

from __future__ import annotations

from pathlib import Path as _Path

from walkmon._checkout import map_checkout_drivers as _map_checkout_drivers
from walkmon._version import __version__

_map_checkout_drivers(_Path(__file__).resolve().parent)  # `drivers/` is walkmon.drivers in a checkout too

from walkmon.camera.model import (
    CameraModel,
    default_camera,
    read_camera_yaml,
    write_camera_yaml,
)
from walkmon.consts import (
    AXES,
    GRAVITY_MS2,
    angles_deg_from_rotation,
    gravity_angles_deg_from_gravity,
    orientation_from_point_transform,
    rotation_from_angles_deg,
)
from walkmon.errors import (
    ConfigError,
    InvalidInputError,
    SourceDisconnected,
    SourceError,
    SourceTimeout,
    WalkmonError,
)
from walkmon.gait.indicators import (
    Indicators,
    IndicatorSettings,
    compute_indicators,
)
from walkmon.imu.attitude import AttitudeSettings, ImuAttitudeFilter
from walkmon.imu.fusion import CameraImuFusion, FusionSettings
from walkmon.rotation import (
    EstimateStatus,
    RotationEstimate,
    RotationEstimator,
    RotationSettings,
)
from walkmon.tables import read_indicators, write_indicators

from walkmon.api import (  # isort: skip  (the front door, on top of the packages above)
    Analysis,
    Session,
    analyze,
    analyze_angles,
    load_session,
    open_video,
)

__all__ = [
    "AXES",
    "Analysis",
    "Session",
    "analyze",
    "analyze_angles",
    "load_session",
    "open_video",
    "GRAVITY_MS2",
    "AttitudeSettings",
    "CameraImuFusion",
    "FusionSettings",
    "ImuAttitudeFilter",
    "CameraModel",
    "ConfigError",
    "EstimateStatus",
    "IndicatorSettings",
    "Indicators",
    "InvalidInputError",
    "RotationEstimate",
    "RotationEstimator",
    "RotationSettings",
    "SourceDisconnected",
    "SourceError",
    "SourceTimeout",
    "WalkmonError",
    "__version__",
    "angles_deg_from_rotation",
    "compute_indicators",
    "default_camera",
    "gravity_angles_deg_from_gravity",
    "orientation_from_point_transform",
    "read_camera_yaml",
    "read_indicators",
    "rotation_from_angles_deg",
    "write_camera_yaml",
    "write_indicators",
]
