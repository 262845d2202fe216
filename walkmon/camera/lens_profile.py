"""Published lens profiles as walkmon cameras: a Gyroflow lens profile (JSON) -> :class:`CameraModel`.

Action cameras (GoPro, DJI, Insta360, Sony, RunCam, ...) have wide fisheye lenses that a pinhole model with a
guessed field of view gets badly wrong (rotation angles scale with the focal length error). Calibrating one
yourself: ``walkmon calibrate VIDEO --model equidistant --out camera.yaml`` (OpenCV's fisheye model, k1..k4).
Or use a published profile: the Gyroflow project's lens profile database (github.com/gyroflow/lens_profiles,
CC0) has thousands of camera/setting profiles in this JSON format::

    {"camera_brand": "GoPro", "camera_model": "HERO9 Black", "camera_setting": "Wide",
     "calib_dimension": {"w": 3840, "h": 2160},
     "fisheye_params": {"camera_matrix": [[fx, 0, cx], [0, fy, cy], [0, 0, 1]],
                        "distortion_coeffs": [k1, k2, k3, k4]},
     "distortion_model": "opencv_fisheye", ...}

``distortion_model`` ``opencv_fisheye`` (the default when absent, unless the older flag ``use_opencv_standard`` is
true) is walkmon's ``equidistant`` model; ``opencv_standard`` is ``plumb_bob`` (k1 k2 p1 p2 k3 ...). Other
Gyroflow models (``poly3``, ``poly5``, ``gopro_superview``, ``insta360``, ...) and stretched inputs are refused
with a one-line error. ``frame_readout_time`` (ms, the rolling-shutter readout some profiles carry) becomes the
camera's ``readout_s`` when its ``frame_readout_direction`` is absent or ``TopToBottom`` (other directions are
refused). The camera comes at the profile's ``calib_dimension``; ``walkmon analyze --calib
profile.json`` scales it to the video (same aspect ratio: the same lens mode), and ``walkmon calibrate
profile.json --out camera.yaml`` converts it to the ROS camera_info YAML walkmon's other commands read.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from walkmon.camera.model import DISTORTION_MODELS, CameraModel
from walkmon.errors import ConfigError

__all__ = ["camera_from_lens_profile", "read_camera_file", "read_lens_profile"]

#: Gyroflow distortion model names walkmon reads, and walkmon's name for each.
_MODELS = {"opencv_fisheye": "equidistant", "opencv_standard": "plumb_bob"}


def camera_from_lens_profile(profile: Any, *, source: str = "lens profile") -> CameraModel:
    """The camera of a parsed Gyroflow lens profile (see the module docstring); ConfigError naming ``source``."""
    if not isinstance(profile, dict):
        msg = f"{source}: expected a Gyroflow lens profile (a JSON object)"
        raise ConfigError(msg)
    try:
        dim = profile["calib_dimension"]
        width, height = _whole(dim["w"], "calib_dimension.w", source), _whole(dim["h"], "calib_dimension.h", source)
        params = profile["fisheye_params"]
        K = _numbers(params["camera_matrix"], "camera_matrix", source)
        coeffs = _numbers(params["distortion_coeffs"], "distortion_coeffs", source).ravel()
    except KeyError as exc:
        msg = f"{source}: missing {exc.args[0]!r} (not a Gyroflow lens profile?)"
        raise ConfigError(msg) from None
    except (TypeError, ValueError) as exc:
        msg = f"{source}: malformed lens profile ({exc})"
        raise ConfigError(msg) from None
    gyroflow_model = str(profile.get("distortion_model") or
                         ("opencv_standard" if profile.get("use_opencv_standard") else "opencv_fisheye"))
    if gyroflow_model not in _MODELS:
        msg = (f"{source}: distortion model {gyroflow_model!r} is not supported (walkmon reads "
               f"{', '.join(_MODELS)}); calibrate with 'walkmon calibrate --model equidistant' instead")
        raise ConfigError(msg)
    digital = profile.get("digital_lens")
    if digital not in (None, "", "None"):
        # SuperView, HyperView, Linear crops: a non-radial stretch or crop the camera applies after the lens; its
        # intrinsics alone are wrong for those frames (user review: silently taken as a plain fisheye)
        msg = (f"{source}: digital lens {digital!r} (a stretch or crop the camera applies after the lens) is not "
               f"supported: use a profile of a setting without one, or calibrate with 'walkmon calibrate --model "
               f"equidistant'")
        raise ConfigError(msg)
    if profile.get("interpolations"):
        msg = (f"{source}: a zoom lens profile (intrinsics interpolated over focal lengths) is not supported: use the "
               f"profile of one focal length")
        raise ConfigError(msg)
    for key in ("input_horizontal_stretch", "input_vertical_stretch"):
        stretch = profile.get(key)
        if stretch not in (None, 1, 1.0):
            msg = f"{source}: {key} = {stretch} (an anamorphic/stretched input) is not supported"
            raise ConfigError(msg)
    model = _MODELS[gyroflow_model]
    if K.shape != (3, 3):
        msg = f"{source}: camera_matrix must be 3x3, got shape {K.shape}"
        raise ConfigError(msg)
    if model == "equidistant":
        coeffs = coeffs[:4]
    elif coeffs.size not in DISTORTION_MODELS["plumb_bob"]:
        # Gyroflow pads opencv_standard to 8 or more coefficients; trailing zeros carry nothing
        keep = max((n for n in DISTORTION_MODELS["plumb_bob"] if n <= coeffs.size), default=4)
        if np.any(coeffs[keep:] != 0):
            msg = f"{source}: {coeffs.size} opencv_standard coefficients; walkmon reads 4, 5, 8, 12 or 14"
            raise ConfigError(msg)
        coeffs = coeffs[:keep]
    name = " ".join(str(profile.get(k) or "") for k in ("camera_brand", "camera_model", "camera_setting")).strip()
    readout_ms = profile.get("frame_readout_time") or 0.0
    direction = profile.get("frame_readout_direction") or "TopToBottom"
    if readout_ms and direction != "TopToBottom":
        msg = f"{source}: frame_readout_direction {direction!r} is not supported (walkmon reads TopToBottom)"
        raise ConfigError(msg)
    if isinstance(readout_ms, bool) or not isinstance(readout_ms, int | float):
        msg = f"{source}: frame_readout_time must be a number of milliseconds, got {readout_ms!r}"
        raise ConfigError(msg)
    try:
        return CameraModel(width, height, K, model, coeffs, name or "lens_profile", readout_ms / 1000.0)
    except ConfigError as exc:
        msg = f"{source}: {exc}"
        raise ConfigError(msg) from None


def _whole(v: Any, what: str, source: str) -> int:
    """A pixel count: a whole number (1920.7 was cut to 1920 without a word)."""
    if isinstance(v, bool) or not isinstance(v, int | float) or not float(v).is_integer():
        msg = f"{source}: {what} must be a whole number of pixels, got {v!r}"
        raise ConfigError(msg)
    return int(v)


def _numbers(v: Any, what: str, source: str) -> NDArray[np.float64]:
    """An array of finite numbers (a null read as NaN and got a contradictory message)."""
    try:
        a = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        a = None
    if a is None or not np.all(np.isfinite(a)):
        msg = f"{source}: {what} must hold numbers only, got {json.dumps(v)[:80]}"
        raise ConfigError(msg)
    return a


def read_lens_profile(path: str | Path) -> CameraModel:
    """Read a Gyroflow lens profile JSON file (ConfigError with one line when it cannot be used)."""
    p = Path(path)
    try:
        data = json.loads(p.read_text(encoding="utf-8-sig"))  # a BOM, as Windows editors save: still the profile
    except OSError as exc:
        msg = f"cannot read lens profile {p}: {exc.strerror or exc}"
        raise ConfigError(msg) from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        msg = f"lens profile {p} is not valid JSON: {str(exc).splitlines()[0]}"
        raise ConfigError(msg) from None
    return camera_from_lens_profile(data, source=str(p))


def read_camera_file(path: str | Path) -> CameraModel:
    """A camera from a ROS camera_info YAML, or from a Gyroflow lens profile when the name ends in .json."""
    if str(path).lower().endswith(".json"):
        return read_lens_profile(path)
    from walkmon.camera.model import read_camera_yaml  # noqa: PLC0415

    return read_camera_yaml(path)
