"""walkmon: walking-posture monitoring from a chest-worn camera (and an optional IMU).

Importing walkmon never touches hardware. Public names are listed once, here.
"""

from __future__ import annotations

from pathlib import Path as _Path

from walkmon._checkout import map_checkout_drivers as _map_checkout_drivers
from walkmon._version import __version__

_map_checkout_drivers(_Path(__file__).resolve().parent)  # `drivers/` is walkmon.drivers in a checkout too

from typing import TYPE_CHECKING

from walkmon.errors import (
    ConfigError,
    InvalidInputError,
    SourceDisconnected,
    SourceError,
    SourceTimeout,
    WalkmonError,
)

if TYPE_CHECKING:
    from walkmon.api import Analysis, Session, analyze, analyze_angles, load_session, open_video
    from walkmon.batching.run import batch
    from walkmon.camera.model import CameraModel, default_camera, read_camera_yaml, write_camera_yaml
    from walkmon.consts import (
        AXES,
        GRAVITY_MS2,
        angles_deg_from_rotation,
        gravity_angles_deg_from_gravity,
        orientation_from_point_transform,
        rotation_from_angles_deg,
    )
    from walkmon.gait.indicators import Indicators, IndicatorSettings, compute_indicators
    from walkmon.imu.attitude import AttitudeSettings, ImuAttitudeFilter
    from walkmon.imu.fusion import CameraImuFusion, FusionSettings
    from walkmon.rotation import EstimateStatus, RotationEstimate, RotationEstimator, RotationSettings
    from walkmon.tables import read_indicators, write_indicators

#: Where each public name lives. They are imported on first use (PEP 562), so ``import walkmon`` (and with it
#: the ``walkmon`` command's start, before its signal handlers are installed) does not import numpy, OpenCV and
#: SciPy: a signal during start-up is then handled by walkmon, not by a half-imported library.
_LAZY = {
    **dict.fromkeys(("Analysis", "Session", "analyze", "analyze_angles", "load_session", "open_video"),
                    "walkmon.api"),
    "batch": "walkmon.batching.run",
    **dict.fromkeys(("CameraModel", "default_camera", "read_camera_yaml", "write_camera_yaml"),
                    "walkmon.camera.model"),
    **dict.fromkeys(("AXES", "GRAVITY_MS2", "angles_deg_from_rotation", "gravity_angles_deg_from_gravity",
                     "orientation_from_point_transform", "rotation_from_angles_deg"), "walkmon.consts"),
    **dict.fromkeys(("Indicators", "IndicatorSettings", "compute_indicators"), "walkmon.gait.indicators"),
    **dict.fromkeys(("AttitudeSettings", "ImuAttitudeFilter"), "walkmon.imu.attitude"),
    **dict.fromkeys(("CameraImuFusion", "FusionSettings"), "walkmon.imu.fusion"),
    **dict.fromkeys(("EstimateStatus", "RotationEstimate", "RotationEstimator", "RotationSettings"),
                    "walkmon.rotation"),
    **dict.fromkeys(("read_indicators", "write_indicators"), "walkmon.tables"),
}


def __getattr__(name: str) -> object:
    module = _LAZY.get(name)
    if module is None:
        msg = f"module 'walkmon' has no attribute {name!r}"
        raise AttributeError(msg)
    import importlib

    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})


__all__ = [
    "AXES",
    "Analysis",
    "Session",
    "analyze",
    "analyze_angles",
    "batch",
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
