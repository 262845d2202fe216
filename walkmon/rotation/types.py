"""Types of the rotation stage: settings, the per-frame estimate and its status (no engine code here).

The engines (:mod:`walkmon.rotation.fast`, :mod:`walkmon.rotation.paper`) and the front
:class:`~walkmon.rotation.estimator.RotationEstimator` all import from here, so nothing imports the front.
"""

from __future__ import annotations

import enum
import logging
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from walkmon.consts import angles_deg_from_rotation
from walkmon.errors import ConfigError, InvalidInputError

__all__ = [
    "DEFAULT_ROTATION_SETTINGS",
    "FLAG_REASONS",
    "METHODS",
    "EstimateStatus",
    "RotationEstimate",
    "UNMEASURED_MODELS",
    "RotationSettings",
    "grey_from_frame",
]

_log = logging.getLogger(__name__)

#: The estimation methods :class:`RotationEstimator` offers.
METHODS = ("fast", "paper")


class EstimateStatus(enum.Enum):
    """How much to trust one :class:`RotationEstimate`."""

    #: A model was fitted with enough inliers.
    OK = "ok"
    #: The first frame (or the first after ``reset()``): identity by definition.
    FIRST_FRAME = "first_frame"
    #: Uniform/black frame or fewer matches than the minimum: the last orientation is held (lost tracks in a
    #: steady turn: carried on at the last rate, model ``coast``).
    TOO_FEW_FEATURES = "too_few_features"
    #: The frame is identical to the previous one: the last orientation is held.
    REPEATED_FRAME = "repeated_frame"
    #: A fit was made but failed its checks. Few inliers or an implausible jump: the last orientation is held (in
    #: a steady turn carried on at the last rate, model ``coast``).
    #: The essential fit strayed from the rotation-only fit beyond what the parallax explains: the rotation-only
    #: fit is used (``model == "rotation"``), since holding would turn the walker's motion into a jump.
    LOW_QUALITY = "low_quality"

    @property
    def is_measured(self) -> bool:
        """True when the rotation comes from the frame (not held)."""
        return self in (EstimateStatus.OK, EstimateStatus.FIRST_FRAME)


@dataclass(frozen=True, slots=True)
class RotationSettings:
    """Settings of :class:`RotationEstimator`; every length in pixels is at the video's full resolution.

    fast method
        ``tracking_scale``: track at this fraction of the input resolution (1.0 = full; 0.5 halves width and
        height, about 3x cheaper, see benchmarks/results/rotation.md), but never narrower than
        ``min_tracking_width_px`` (or the frame itself). ``max_features``: corners per keyframe.
        ``min_feature_distance_px``: spacing of detected corners in a 640 px wide video (scaled with the
        width, so a smaller video gets as many corners across its view). ``klt_window_px``/``klt_levels``: Lucas-Kanade
        window (at tracking resolution) and pyramid levels. ``keyframe_max_frames``,
        ``keyframe_min_track_fraction``, ``keyframe_max_rotation_deg``, ``keyframe_max_parallax_deg`` (the
        rotation-only fit's median residual as an angle: translation seen against near structure, a wall ahead):
        start a new keyframe when any is exceeded. ``keyframe_window``: keyframes kept for the sliding-window refinement of each new keyframe's
        orientation (1 = plain chaining). ``feature_noise_px``: tracking noise assumed by the GRIC model selection.
        ``max_ok_rate_deg_s``: a frame turning faster than this is still estimated but flagged LOW_QUALITY
        (``reason="fast_rotation"``), and so are the frames after it until the rate falls below half of it: at a
        fast torso turn tracking, motion blur and rolling shutter degrade the fit (walking itself turns a chest
        camera by a few tens of deg/s at most). A rolling-shutter camera's readout is a camera setting
        (``CameraModel.readout_s``), not a rotation setting.
        ``vertical_reference``: correct pitch/roll drift at keyframes from vertical lines (the vertical vanishing
        direction, :mod:`walkmon.rotation.vertical`); ``vertical_drift_deg_s``: how fast the odometry's tilt error
        is assumed to grow (the correction's process noise, deg after one second; each frame of a fast turn adds
        0.3 deg of doubt on top, which a clear view of vertical lines takes out at once after the turn, between
        keyframes if need be). ``heading_reference`` (needs
        ``vertical_reference``): correct yaw drift at keyframes from horizontal lines of a Manhattan world
        (streets, corridors: :mod:`walkmon.rotation.heading`), modulo 90 deg. ``ground_plane``: where the tracks lie
        on one plane, take the plane solution whose normal is the vertical as the ground's (a camera tilted down
        on the chest sees mostly ground) instead of flagging the frame ambiguous.
    both methods
        ``min_inliers``: fewer inliers than this holds the orientation. ``inlier_px``: inlier threshold.
        ``max_frame_rotation_deg``: a frame-to-frame change larger than this is rejected as implausible for a
        chest-worn camera (held, LOW_QUALITY).
    paper method
        ``akaze_threshold``: AKAZE detector response threshold. ``match_radius_px``: a FLANN match must land
        this close to where LK tracked the point. ``ratio_test``: Lowe's ratio. ``ransac_threshold_px``: 5-point
        RANSAC threshold. ``bundle_adjust``: refine each pair by two-view bundle adjustment. ``max_ba_points``:
        points used by that adjustment.
    """

    method: str = "fast"
    tracking_scale: float = 0.5
    min_tracking_width_px: int = 320
    max_features: int = 160
    min_feature_distance_px: float = 16.0
    klt_window_px: int = 9
    klt_levels: int = 2
    keyframe_max_frames: int = 30
    keyframe_min_track_fraction: float = 0.6
    keyframe_max_rotation_deg: float = 8.0
    keyframe_max_parallax_deg: float = 3.0
    keyframe_window: int = 4
    vertical_reference: bool = True
    vertical_drift_deg_s: float = 0.03
    heading_reference: bool = True
    ground_plane: bool = True
    feature_noise_px: float = 0.5
    min_inliers: int = 12
    inlier_px: float = 2.0
    max_frame_rotation_deg: float = 15.0
    max_ok_rate_deg_s: float = 90.0
    akaze_threshold: float = 0.001
    match_radius_px: float = 25.0
    ratio_test: float = 0.8
    ransac_threshold_px: float = 1.0
    bundle_adjust: bool = True
    max_ba_points: int = 150

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            msg = f"rotation method must be one of {', '.join(METHODS)}, got {self.method!r}"
            raise ConfigError(msg)
        checks = {
            "tracking_scale": 0.1 <= self.tracking_scale <= 1.0,
            "min_tracking_width_px": self.min_tracking_width_px >= 16,
            "max_features": self.max_features >= 10,
            "min_feature_distance_px": self.min_feature_distance_px > 0,
            "klt_window_px": self.klt_window_px >= 3,
            "klt_levels": 0 <= self.klt_levels <= 6,
            "keyframe_max_frames": self.keyframe_max_frames >= 1,
            "keyframe_min_track_fraction": 0.0 < self.keyframe_min_track_fraction <= 1.0,
            "keyframe_max_rotation_deg": self.keyframe_max_rotation_deg > 0,
            "keyframe_max_parallax_deg": self.keyframe_max_parallax_deg > 0,
            "keyframe_window": 1 <= self.keyframe_window <= 20,
            "vertical_drift_deg_s": self.vertical_drift_deg_s > 0,
            "feature_noise_px": self.feature_noise_px > 0,
            "min_inliers": self.min_inliers >= 5,
            "inlier_px": self.inlier_px > 0,
            "max_frame_rotation_deg": self.max_frame_rotation_deg > 0,
            "max_ok_rate_deg_s": self.max_ok_rate_deg_s > 0,
            "akaze_threshold": self.akaze_threshold > 0,
            "match_radius_px": self.match_radius_px > 0,
            "ratio_test": 0.0 < self.ratio_test <= 1.0,
            "ransac_threshold_px": self.ransac_threshold_px > 0,
            "max_ba_points": self.max_ba_points >= 5,
        }
        bad = [name for name, ok in checks.items() if not ok]
        if bad:
            msg = "invalid rotation setting(s): " + ", ".join(f"{b}={getattr(self, b)!r}" for b in bad)
            raise ConfigError(msg)


DEFAULT_ROTATION_SETTINGS = RotationSettings()

#: Why the fast method flags a frame (``RotationEstimate.reason``); the status says whether it was still
#: estimated (``low_quality``: mostly model ``rotation``, the rotation-only fit against the keyframe used in place
#: of the fit in doubt; ``fast_rotation``, ``keyframe_correction`` and ``ground_step`` frames keep their own fit
#: and model, only the claim changes) or held (model ``hold``; in a steady turn carried on at the last rate,
#: model ``coast``: :data:`UNMEASURED_MODELS`).
FLAG_REASONS = {
    "models_disagree": "the essential rotation strays from the rotation-only one beyond what the parallax explains",
    "planar_ambiguity": "the tracks lie on one plane whose two rotations (or the essential's) differ (held where"
    " that plane is the ground and the frame turns by less than 2 deg; in a steady turn carried on at the last"
    " rate)",
    "step_inconsistent": "the fit jumps away from the frame-to-frame tracking of the same points",
    "ground_step": "the ground plane's fit (kept) jumps away from the frame-to-frame tracking, which the near ground"
    " biases",
    "translation_ambiguity": "looking sideways to the walker's heading, a translation and a rotation fit alike",
    "fast_rotation": "turning faster than max_ok_rate_deg_s, or since, until the rate halved: tracking and blur degrade",
    "keyframe_correction": "a new keyframe's refinement (older keyframes, vertical lines) moved the orientation by"
    " more than 0.5 deg at once",
    "few_inliers": "fewer inliers than min_inliers: held (in a steady turn carried on at the last rate: model coast)",
    "implausible_step": "a frame-to-frame change above max_frame_rotation_deg, or a change of turning rate no torso"
    " makes: held (in a steady turn carried on at the last rate: model coast)",
    "tracking_lost": "fewer tracked points than min_inliers: held (in a steady turn carried on at the last rate:"
    " model coast), tracking restarts",
    "few_features": "fewer corners than min_inliers where tracking (re)starts: held",
    "featureless": "a uniform frame (lens cap, darkness): held",
    "repeated_frame": "the frame repeats the previous one: held",
}

#: The models of frames that measured nothing: the orientation held, or carried on through a steady turn at the
#: last measured rate (the session analysis and the live stage leave them out: walkmon.api.measured_rows).
UNMEASURED_MODELS = ("hold", "coast")


@dataclass(frozen=True, slots=True)
class RotationEstimate:
    """The camera orientation at ``t_s`` relative to the first frame.

    ``rotation`` maps this frame's directions into the first frame's; ``angles_deg`` is (pitch, yaw, roll).
    ``model`` is ``"rotation"`` (rotation-only/homography), ``"essential"``, ``"heading"`` (essential with the
    baseline fixed along the walker's heading: noisy tracks, little parallax), ``"hold"`` (orientation held,
    see ``status``), ``"coast"`` (a frame that would be held, in a turn: the orientation carried on at the last
    measured frame's rate) or ``"identity"`` (first frame). Neither ``hold`` nor ``coast`` measures anything
    (:data:`UNMEASURED_MODELS`). ``n_inliers`` counts matches that agree with the model,
    ``n_tracks`` the matches tried, ``residual_px`` their median error, ``keyframe`` whether this frame became
    a keyframe. ``reason`` says why a frame is not ok (empty when it is), one of :data:`FLAG_REASONS`.
    """

    t_s: float
    rotation: NDArray[np.float64]
    angles_deg: NDArray[np.float64]
    n_inliers: int
    model: str
    status: EstimateStatus
    n_tracks: int = 0
    residual_px: float = math.nan
    keyframe: bool = False
    reason: str = ""

    def __post_init__(self) -> None:
        R = np.array(self.rotation, dtype=float)
        a = np.array(self.angles_deg, dtype=float)
        R.setflags(write=False)
        a.setflags(write=False)
        object.__setattr__(self, "rotation", R)
        object.__setattr__(self, "angles_deg", a)


def grey_from_frame(frame: NDArray[np.uint8]) -> NDArray[np.uint8]:
    """An 8-bit grey image from a BGR, BGRA or grey frame; InvalidInputError for anything else."""
    import cv2  # noqa: PLC0415

    f = np.asarray(frame)
    if f.dtype != np.uint8:
        msg = f"frame must be uint8, got {f.dtype}"
        raise InvalidInputError(msg)
    if f.ndim == 2:
        return f
    if f.ndim == 3 and f.shape[2] == 1:
        return f[:, :, 0]
    if f.ndim == 3 and f.shape[2] == 3:
        return cv2.cvtColor(f, cv2.COLOR_BGR2GRAY)
    if f.ndim == 3 and f.shape[2] == 4:
        return cv2.cvtColor(f, cv2.COLOR_BGRA2GRAY)
    msg = f"frame must have shape (H, W), (H, W, 3) or (H, W, 4), got {f.shape}"
    raise InvalidInputError(msg)


def make_estimate(t_s: float, rotation: NDArray[np.float64], **kwargs: Any) -> RotationEstimate:
    """A :class:`RotationEstimate` with its angles computed from ``rotation``."""
    return RotationEstimate(t_s=float(t_s), rotation=rotation, angles_deg=angles_deg_from_rotation(rotation), **kwargs)
