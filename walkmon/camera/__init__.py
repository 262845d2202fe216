"""The camera model (intrinsics, distortion, ROS camera_info YAML) and chessboard calibration."""

from walkmon.camera.model import (
    DEFAULT_HFOV_DEG,
    DISTORTION_MODELS,
    CameraModel,
    default_camera,
    read_camera_yaml,
    write_camera_yaml,
)

__all__ = [
    "DEFAULT_HFOV_DEG",
    "DISTORTION_MODELS",
    "CameraModel",
    "default_camera",
    "read_camera_yaml",
    "write_camera_yaml",
]
