"""Camera intrinsics: the ROS ``camera_info`` YAML format, a documented default, and chessboard calibration.

The file format is the one ROS ``camera_calibration`` writes::

    image_width: 640
    image_height: 480
    camera_name: walkmon_sim
    camera_matrix: {rows: 3, cols: 3, data: [fx, 0, cx, 0, fy, cy, 0, 0, 1]}
    distortion_model: plumb_bob          # or equidistant (fisheye: k1..k4)
    distortion_coefficients: {rows: 1, cols: 5, data: [k1, k2, p1, p2, k3]}
    readout_s: 0.03                      # optional, walkmon's own: rolling-shutter readout (see below)

``readout_s`` (not a ROS key; ROS readers ignore it) is the rolling-shutter readout time: the time from the first
(top) row's exposure to the last's. Most phone, action and USB cameras read their rows out one after another over
5-30 ms at video frame rates; a global-shutter camera (and the default, 0) exposes every row at once. The fast
rotation method uses it to put every tracked point at the frame's time (the middle row's) before fitting
(:mod:`walkmon.rotation.shutter`). A camera's readout time comes from its lens profile (Gyroflow's
``frame_readout_time``), its datasheet (sensor line time x rows), or a measurement (a strobing LED's bands).

Extra keys ROS writes (``rectification_matrix``, ``projection_matrix``) are accepted and ignored on read, and
written on write so ROS tools can read walkmon's files.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from walkmon.errors import ConfigError

__all__ = [
    "DEFAULT_HFOV_DEG",
    "DISTORTION_MODELS",
    "CameraModel",
    "camera_for_frames",
    "default_camera",
    "turned_axes",
    "read_camera_yaml",
    "write_camera_yaml",
]

#: Horizontal field of view assumed for an unknown camera (a typical USB webcam / OAK colour camera at 4:3).
DEFAULT_HFOV_DEG = 70.0

#: Largest image side accepted, px (a 16K sensor is 15360 wide).
MAX_IMAGE_SIDE_PX = 20000
#: Largest |distortion coefficient| accepted (OpenCV's rational model reaches tens; 1e30 is a corrupted file).
MAX_DISTORTION_COEFFICIENT = 1000.0
#: Largest rolling-shutter readout accepted, s (a slow sensor at 10 fps; beyond it the file is wrong).
MAX_READOUT_S = 0.1

#: Largest ratio of two aspect ratios that are still the same image shape (codec padding: 1080 vs 1088 rows).
ASPECT_TOLERANCE = 1.02

#: Supported distortion models and how many coefficients each takes.
DISTORTION_MODELS = {"plumb_bob": (4, 5, 8, 12, 14), "equidistant": (4,)}


@dataclass(frozen=True, slots=True)
class CameraModel:
    """Pinhole intrinsics plus lens distortion, in pixels.

    ``camera_matrix`` is ``[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]``. ``distortion_model`` is ``plumb_bob``
    (OpenCV's radial-tangential ``k1 k2 p1 p2 [k3 ...]``) or ``equidistant`` (OpenCV fisheye ``k1..k4``).
    ``readout_s``: rolling-shutter readout time, top row to bottom row (0: global shutter; module docstring).
    """

    width_px: int
    height_px: int
    camera_matrix: NDArray[np.float64]
    distortion_model: str = "plumb_bob"
    distortion_coefficients: NDArray[np.float64] = field(default_factory=lambda: np.zeros(5))
    name: str = "camera"
    readout_s: float = 0.0

    def __post_init__(self) -> None:
        numeric = isinstance(self.readout_s, int | float | np.integer | np.floating) and not isinstance(self.readout_s, bool)
        readout = float(self.readout_s) if numeric else math.nan
        if not 0.0 <= readout <= MAX_READOUT_S:
            msg = f"readout_s (rolling-shutter readout) must be in [0, {MAX_READOUT_S:g}] s, got {self.readout_s!r}"
            raise ConfigError(msg)
        object.__setattr__(self, "readout_s", readout)
        K = np.array(self.camera_matrix, dtype=float)
        d = np.array(self.distortion_coefficients, dtype=float).ravel()
        if K.shape != (3, 3):
            msg = f"camera_matrix must be 3x3, got shape {K.shape}"
            raise ConfigError(msg)
        if not (np.all(np.isfinite(K)) and K[0, 0] > 0 and K[1, 1] > 0 and abs(K[2, 2] - 1.0) < 1e-9):
            msg = "camera_matrix must be finite with fx > 0, fy > 0 and K[2,2] == 1"
            raise ConfigError(msg)
        try:
            w_px, h_px = _pixels(self.width_px, "image width"), _pixels(self.height_px, "image height")
        except (TypeError, ValueError) as exc:
            raise ConfigError(str(exc)) from None
        object.__setattr__(self, "width_px", w_px)
        object.__setattr__(self, "height_px", h_px)
        side = max(self.width_px, self.height_px)
        for name, f in (("fx", K[0, 0]), ("fy", K[1, 1])):
            # 0.05 x the image side: a 170 deg fisheye's focal is ~0.2 x; 100 x: a 0.6 deg telephoto field of view
            if not 0.05 * side <= f <= 100.0 * side:
                msg = (f"{name} = {f:.6g} px is not a lens focal length for a {self.width_px}x{self.height_px} image "
                       f"(expected {0.05 * side:.4g}..{100.0 * side:.4g} px)")
                raise ConfigError(msg)
        if not (0.0 <= K[0, 2] <= self.width_px and 0.0 <= K[1, 2] <= self.height_px):
            msg = (f"principal point ({K[0, 2]:.6g}, {K[1, 2]:.6g}) lies outside the {self.width_px}x{self.height_px} "
                   "image")
            raise ConfigError(msg)
        if abs(K[0, 1]) > K[0, 0] or K[1, 0] != 0.0 or K[2, 0] != 0.0 or K[2, 1] != 0.0:
            msg = "camera_matrix must be upper triangular ([[fx, s, cx], [0, fy, cy], [0, 0, 1]]) with |s| <= fx"
            raise ConfigError(msg)
        if self.distortion_model not in DISTORTION_MODELS:
            msg = f"distortion_model must be one of {sorted(DISTORTION_MODELS)}, got {self.distortion_model!r}"
            raise ConfigError(msg)
        if d.size not in DISTORTION_MODELS[self.distortion_model] or not np.all(np.isfinite(d)):
            msg = (
                f"{self.distortion_model} takes {DISTORTION_MODELS[self.distortion_model]} finite coefficients, "
                f"got {d.size}"
            )
            raise ConfigError(msg)
        if np.any(np.abs(d) > MAX_DISTORTION_COEFFICIENT):
            msg = (f"distortion coefficient {float(d[np.argmax(np.abs(d))]):.6g} is beyond +-{MAX_DISTORTION_COEFFICIENT:g}: "
                   "not a lens (calibrate again)")
            raise ConfigError(msg)
        K.setflags(write=False)
        d.setflags(write=False)
        object.__setattr__(self, "camera_matrix", K)
        object.__setattr__(self, "distortion_coefficients", d)

    @property
    def fx(self) -> float:
        return float(self.camera_matrix[0, 0])

    @property
    def fy(self) -> float:
        return float(self.camera_matrix[1, 1])

    @property
    def cx(self) -> float:
        return float(self.camera_matrix[0, 2])

    @property
    def cy(self) -> float:
        return float(self.camera_matrix[1, 2])

    @property
    def has_distortion(self) -> bool:
        return bool(np.any(self.distortion_coefficients != 0.0))

    @property
    def hfov_deg(self) -> float:
        return math.degrees(2.0 * math.atan2(self.width_px / 2.0, self.fx))

    def scaled_to(self, width_px: int, height_px: int) -> CameraModel:
        """The same lens at another resolution (e.g. a camera streaming at a different size). Another aspect ratio
        is refused (InvalidInputError): no scaling makes a 16:9 calibration fit 4:3 frames (another sensor crop,
        or a portrait video: see :meth:`rotated`) or square pixels of anamorphic ones, and the stretched
        intrinsics gave silently wrong angles."""
        sx, sy = width_px / self.width_px, height_px / self.height_px
        if not 1.0 / ASPECT_TOLERANCE <= sx / sy <= ASPECT_TOLERANCE:
            from walkmon.errors import InvalidInputError  # noqa: PLC0415

            msg = (f"the calibration is for {self.width_px}x{self.height_px} images but the frames are "
                   f"{width_px}x{height_px}, another shape (a rotated, cropped or anamorphic video): calibrate on "
                   "these frames (walkmon calibrate) or give the calibration of this video mode")
            raise InvalidInputError(msg)
        K = self.camera_matrix.copy()
        K[0, :] *= sx
        K[1, :] *= sy
        return CameraModel(width_px, height_px, K, self.distortion_model, self.distortion_coefficients, self.name,
                           self.readout_s)

    def rotated(self, quarter_turns: int) -> CameraModel:
        """The same camera for its images turned ``quarter_turns`` x 90 deg clockwise (as a video player shows a
        phone's portrait video; OpenCV turns the frames by the file's display rotation): the image axes and the
        camera's x and y turn with them (z stays forward), so pixel ``(u, v)`` of a ``W x H`` image is
        ``(H - 1 - v, u)`` after one turn. fx and fy swap, the principal point moves, ``plumb_bob``'s
        tangential terms turn (``p1, p2 -> p2, -p1``), the radial terms and ``equidistant``'s stay. A skewed
        matrix, thin-prism or tilt terms (12 or 14 coefficients) and a rolling-shutter readout (its rows become
        columns) cannot be turned: InvalidInputError."""
        from walkmon.errors import InvalidInputError  # noqa: PLC0415

        k = int(quarter_turns) % 4
        if k == 0:
            return self
        d = np.array(self.distortion_coefficients, dtype=float)
        why = ("a skewed camera matrix" if self.camera_matrix[0, 1] != 0.0 else
               "thin-prism or tilt distortion terms" if self.distortion_model == "plumb_bob" and d.size > 8 else
               "a rolling-shutter readout (its rows would run across the turned frames)" if self.readout_s > 0 else "")
        if why:
            msg = f"the calibration has {why}: it cannot be turned to the video's orientation; calibrate on its frames"
            raise InvalidInputError(msg)
        w, h = self.width_px, self.height_px
        fx, fy, cx, cy = self.fx, self.fy, self.cx, self.cy
        for _ in range(k):
            fx, fy, cx, cy, w, h = fy, fx, h - 1 - cy, cx, h, w
            if self.distortion_model == "plumb_bob":
                d[2], d[3] = d[3], -d[2]
        K = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
        return CameraModel(w, h, K, self.distortion_model, d, self.name, self.readout_s)

    def normalized_from_pixels(self, points_px: ArrayLike) -> NDArray[np.float64]:
        """Undistorted normalised image coordinates (x/z, y/z) of pixel positions; shape (N, 2)."""
        import cv2  # noqa: PLC0415  (keep `import walkmon.camera.model` light)

        pts = np.asarray(points_px, dtype=np.float64).reshape(-1, 1, 2)
        if pts.shape[0] == 0:
            return np.zeros((0, 2))
        if self.distortion_model == "equidistant":
            out = cv2.fisheye.undistortPoints(pts, self.camera_matrix, self.distortion_coefficients)
        else:
            out = cv2.undistortPoints(pts, self.camera_matrix, self.distortion_coefficients)
        return out.reshape(-1, 2)

    def pixels_from_camera_points(self, points_cam: ArrayLike) -> NDArray[np.float64]:
        """Project 3-D points in the camera frame (z forward) to distorted pixel positions; shape (N, 2)."""
        import cv2  # noqa: PLC0415

        P = np.asarray(points_cam, dtype=np.float64).reshape(-1, 1, 3)
        if P.shape[0] == 0:
            return np.zeros((0, 2))
        zero = np.zeros(3)
        if self.distortion_model == "equidistant":
            out, _ = cv2.fisheye.projectPoints(P, zero, zero, self.camera_matrix, self.distortion_coefficients)
        else:
            out, _ = cv2.projectPoints(P, zero, zero, self.camera_matrix, self.distortion_coefficients)
        return out.reshape(-1, 2)

    def to_dict(self) -> dict[str, Any]:
        """The ROS camera_info YAML mapping."""
        d = [float(v) for v in self.distortion_coefficients]
        P = np.hstack([self.camera_matrix, np.zeros((3, 1))])
        out: dict[str, Any] = {
            "image_width": int(self.width_px),
            "image_height": int(self.height_px),
            "camera_name": self.name,
            "camera_matrix": {"rows": 3, "cols": 3, "data": [float(v) for v in self.camera_matrix.ravel()]},
            "distortion_model": self.distortion_model,
            "distortion_coefficients": {"rows": 1, "cols": len(d), "data": d},
            "rectification_matrix": {"rows": 3, "cols": 3, "data": [float(v) for v in np.eye(3).ravel()]},
            "projection_matrix": {"rows": 3, "cols": 4, "data": [float(v) for v in P.ravel()]},
        }
        if self.readout_s > 0:  # a global-shutter camera's file stays a plain camera_info
            out["readout_s"] = float(self.readout_s)
        return out

    @classmethod
    def from_dict(cls, data: Any, *, source: str = "calibration") -> CameraModel:
        """Parse a ROS camera_info mapping; every problem raises :class:`ConfigError` naming ``source``."""
        if not isinstance(data, dict):
            msg = f"{source}: expected a ROS camera_info mapping, got {type(data).__name__}"
            raise ConfigError(msg)
        try:
            width, height = _pixels(data["image_width"], "image_width"), _pixels(data["image_height"], "image_height")
            K = _matrix(data["camera_matrix"], 3, 3, "camera_matrix")
            model = str(data.get("distortion_model", "plumb_bob"))
            dist_entry = data.get("distortion_coefficients", {"data": [0.0] * 5})
            dist = np.asarray(_data_list(dist_entry, "distortion_coefficients"), dtype=float)
            name = str(data.get("camera_name", "camera"))
            readout = data.get("readout_s", 0.0)
        except KeyError as exc:
            msg = f"{source}: missing key {exc.args[0]!r}"
            raise ConfigError(msg) from None
        except (TypeError, ValueError, OverflowError) as exc:
            msg = f"{source}: {exc}"
            raise ConfigError(msg) from None
        try:
            return cls(width, height, K, model, dist, name, readout)
        except ConfigError as exc:
            msg = f"{source}: {exc}"
            raise ConfigError(msg) from None


def _pixels(value: Any, key: str) -> int:
    """A whole, finite pixel count (``.inf``, ``1e23``, ``640.5`` and text are refused)."""
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        msg = f"{key} must be a whole number of pixels, got {value!r}"
        raise TypeError(msg)
    if not (math.isfinite(value) and float(value).is_integer() and 1 <= value <= MAX_IMAGE_SIDE_PX):
        msg = f"{key} must be a whole number of pixels in 1..{MAX_IMAGE_SIDE_PX}, got {value!r}"
        raise ValueError(msg)
    return int(value)


def _data_list(entry: Any, key: str) -> list[float]:
    if isinstance(entry, dict):
        entry = entry.get("data")
    if not isinstance(entry, list):
        msg = f"{key} must be a list or a mapping with 'data'"
        raise TypeError(msg)
    return [float(v) for v in entry]


def _matrix(entry: Any, rows: int, cols: int, key: str) -> NDArray[np.float64]:
    values = _data_list(entry, key)
    if len(values) != rows * cols:
        msg = f"{key} needs {rows * cols} values, got {len(values)}"
        raise ValueError(msg)
    return np.asarray(values, dtype=float).reshape(rows, cols)


def turned_axes(quarter_turns: int) -> NDArray[np.float64]:
    """Coordinates in the camera of images turned ``quarter_turns`` x 90 deg clockwise (:meth:`CameraModel.rotated`)
    from the unturned camera's: ``p_turned = turned_axes(k) @ p`` (one turn: ``x' = -y, y' = x``, z forward)."""
    one = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    return np.linalg.matrix_power(one, int(quarter_turns) % 4)


def camera_for_frames(camera: CameraModel, width_px: int, height_px: int, rotation_deg: float = 0.0) -> CameraModel:
    """``camera`` fitted to frames of ``width_px x height_px`` that a video turned by ``rotation_deg`` clockwise
    (its display rotation, which OpenCV applies): turned (:meth:`CameraModel.rotated`) when the calibration is for
    the unturned frames (a phone calibrated as it records, the video portrait), then scaled to the frames' size
    (:meth:`CameraModel.scaled_to`: the same shape only). A half turn, or a quarter turn of square frames, cannot
    be told from a calibration made on the turned frames (same shape) and is taken as such (a calibration does not
    record the orientation it was made in). A turned video with a rolling-shutter readout is refused: the readout
    then runs across or up the frames, and :mod:`walkmon.rotation.shutter` models top to bottom only."""
    quarter = int(round(float(rotation_deg) / 90.0)) % 4
    if quarter and camera.readout_s > 0:
        from walkmon.errors import InvalidInputError  # noqa: PLC0415

        msg = (f"the video is shown turned {90 * quarter} deg, so the camera's rolling-shutter readout runs "
               f"{'across' if quarter % 2 else 'up'} its frames, which walkmon's correction cannot model: turn it off "
               "(analyze --readout-ms 0, or a calibration without readout_s)")
        raise InvalidInputError(msg)
    calib, frames = camera.width_px / camera.height_px, width_px / height_px

    def same_shape(a: float, b: float) -> bool:
        return abs(math.log(a / b)) <= math.log(ASPECT_TOLERANCE)

    if quarter % 2 == 1 and not same_shape(calib, frames) and same_shape(1.0 / calib, frames):
        camera = camera.rotated(quarter)
    if (camera.width_px, camera.height_px) == (width_px, height_px):
        return camera
    return camera.scaled_to(width_px, height_px)


def default_camera(width_px: int = 640, height_px: int = 480, hfov_deg: float = DEFAULT_HFOV_DEG) -> CameraModel:
    """Intrinsics for an unknown camera: square pixels, principal point at the centre, no distortion.

    ``fx = fy = (side / 2) / tan(hfov / 2)`` with ``side`` the image's longer side (the width of a landscape
    image), the horizontal field of view defaulting to :data:`DEFAULT_HFOV_DEG` (70°, typical of USB webcams and
    the OAK-D colour camera at 4:3). The longer side because a camera's field of view is across its sensor's width:
    a phone's portrait video (frames turned to 1080x1920) shows that width as its height, and 70° across its 1080
    columns made the focal length 1.8x too short, and every angle 1.8x too large. Rotation angles scale roughly
    with the focal length error, so a real calibration (``walkmon calibrate``) is better.
    """
    if not 1.0 < hfov_deg < 179.0:
        msg = f"horizontal field of view must be in (1, 179) degrees, got {hfov_deg}"
        raise ConfigError(msg)
    f = (max(width_px, height_px) / 2.0) / math.tan(math.radians(hfov_deg) / 2.0)
    K = np.array([[f, 0.0, (width_px - 1) / 2.0], [0.0, f, (height_px - 1) / 2.0], [0.0, 0.0, 1.0]])
    return CameraModel(width_px, height_px, K, "plumb_bob", np.zeros(5), "default")


def read_camera_yaml(path: str | Path) -> CameraModel:
    """Read a ROS camera_info YAML file. Missing, unreadable or malformed files raise :class:`ConfigError`."""
    import yaml  # noqa: PLC0415

    from walkmon.errors import InvalidInputError  # noqa: PLC0415
    from walkmon.safe_io import read_bounded  # noqa: PLC0415

    p = Path(path)
    try:
        raw = read_bounded(p, 1 << 20, "calibration file")  # a camera_info YAML is < 2 kB; /dev/zero is refused
    except InvalidInputError as exc:
        msg = f"cannot read calibration file: {exc}"
        raise ConfigError(msg) from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        msg = f"calibration file {p} is not text"
        raise ConfigError(msg) from None
    # ROS's camera_calibration writes OpenCV-style "%YAML:1.0" headers sometimes; tolerate them.
    text = "\n".join(line for line in text.splitlines() if not line.startswith("%YAML"))
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        msg = f"calibration file {p} is not valid YAML: {str(exc).splitlines()[0]}"
        raise ConfigError(msg) from None
    except RecursionError:
        msg = f"calibration file {p} is nested too deeply to be a camera_info YAML"
        raise ConfigError(msg) from None
    return CameraModel.from_dict(data, source=str(p))


def write_camera_yaml(camera: CameraModel, path: str | Path) -> None:
    """Write ``camera`` as a ROS camera_info YAML file."""
    import yaml  # noqa: PLC0415

    from walkmon.safe_io import write_text  # noqa: PLC0415

    write_text(path, yaml.safe_dump(camera.to_dict(), sort_keys=False))
