"""Camera-IMU fusion: the IMU attitude filter plus the visual rotation as a relative measurement.

The error-state Kalman filter of :mod:`walkmon.imu.attitude` runs in the **camera** frame (IMU samples are
rotated by the IMU-to-camera extrinsics and shifted by the time offset). It carries one clone of the
orientation at the last good video frame (stochastic cloning), so each new good frame measures the rotation
*between* the two frames: ``dR_visual ~ R_clone^T R``. Visual drift therefore never pulls the estimate; the
vision mainly refines the gyroscope bias on all three axes (gravity cannot see the vertical one) while the
gyroscope carries the fast motion and gravity keeps pitch/roll absolute.

Poor frames are tolerated three ways: frames the estimator flags (``ok=False``, e.g. too few inliers) are not
used and the next good frame only re-anchors the clone; increments that disagree with the gyroscope by more
than ``visual_outlier_deg`` are rejected and those beyond a chi-square gate down-weighted; and between good
frames the IMU alone carries the estimate.

Outputs per frame (:class:`FusedEstimate`): start-relative pitch, yaw, roll (relative to the camera at the first
frame) and the gravity-referenced ``pitch_abs, roll_abs``.
"""

from __future__ import annotations

import collections
import logging
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from walkmon.consts import (
    GRAVITY_MS2,
    angles_deg_from_rotation,
    gravity_angles_deg_from_gravity,
)
from walkmon.errors import ConfigError, InvalidInputError
from walkmon.imu.attitude import (
    DEFAULT_ATTITUDE_SETTINGS,
    DEFAULT_IMU_FILTER,
    AttitudeCore,
    AttitudeSettings,
    ImuAttitudeFilter,
    ImuFilterSettings,
    VisualWindows,
    exp_so3,
    initial_state_from_rest,
    log_so3,
    make_core,
    smooth_attitude,
    track_attitude,
)
from walkmon.imu.calibration import AccelerometerCalibration
from walkmon.sampling import longest_usual_interval_s, sampling_rate_hz

__all__ = [
    "DEFAULT_FUSION_SETTINGS",
    "CameraImuFusion",
    "FusedEstimate",
    "FusionSettings",
    "FusionTrack",
    "LiveFusedFrame",
    "LiveFusion",
    "LiveFusionSettings",
    "fuse_recording",
]

_log = logging.getLogger(__name__)

#: Chi-square 99.9 % quantile, 3 degrees of freedom.
_GATE_3DOF = 16.27

#: No IMU sample for this long (s, or max_imu_gap_s when longer) restarts the attitude core at the next one: a
#: fixed-rate filter does not know the time it missed, and its gravity would be off by what the sensor turned.
_CORE_RESTART_GAP_S = 0.1

#: Gyro bias std (rad/s, 0.05 deg/s) above which visual increments get ``visual_std_unknown_bias_deg``.
_BIAS_KNOWN_RAD_S = float(np.radians(0.05))


@dataclass(frozen=True, slots=True)
class FusionSettings:
    """Settings of :class:`CameraImuFusion`.

    ``attitude``: the noise model of the fusion's error-state filter (gyroscope propagation, bias, zero-rate
    updates at rest). ``imu_filter``: the IMU attitude core (default VQF, :class:`ImuFilterSettings`) that runs
    beside it on the same samples and gives it gravity: the core's gravity direction is a measurement of the
    filter's tilt, ``core_gravity_hz`` times a second, weighted as a core error of ``core_gravity_std_deg``
    that stays correlated over the core's accelerometer time constant (per update std
    ``core_gravity_std_deg * sqrt(tau_acc_s * core_gravity_hz)``): the gyroscope and the vision carry the
    fast motion and the core holds pitch and roll over tens of seconds. Gravity updates are gated
    (chi-square, 3 dof) but never starved: after ``gravity_reset_s`` of rejected updates the tilt is reset
    to the core's gravity (counted in ``gravity_resets``). ``core_warmup_s``: when the samples do not start still (or
    after a restart), the core's gravity is not used for this long: VQF starts from one accelerometer sample, up
    to ~10 deg off mid-walk, and that error decays with its 3 s time constant (12 s leave 2 % of it; 6 s left 1.2
    deg of fused pitch on walks cut to start mid-walk); meanwhile the filter keeps the gravity it started from
    (offline the recording's mean specific force, live the gravity the camera carried on). ``visual_std_deg``: std of one frame-to-frame visual rotation
    about the camera's x and y axes, ``visual_roll_std_factor`` times that about the optical axis (the fast
    estimator on simulated walks: 0.007-0.011 deg per frame, roll the worst, but with errors that do not average
    out: 0.3-0.8 % scale error and 0.005-0.015 deg/s drift against truth, so the increments are weighted as
    0.05 deg, and the filter also estimates the visual drift rate and scale per axis, priors
    ``visual_drift_std_deg_s`` and ``visual_scale_std``). ``visual_baseline_s``: 0 = every good frame is a
    measurement; > 0 = the rotation between good frames at least that far apart (std
    ``visual_window_std_deg``). ``visual_gate``: chi-square threshold (3 dof) beyond which a visual increment
    is down-weighted; ``visual_outlier_deg``: a disagreement with the gyroscope larger than this rejects it.
    ``visual_std_unknown_bias_deg``: the (smaller) std used while the gyro bias is uncertain (std > 0.05
    deg/s) and for recordings without a still start, where the vision is the bias's best source.
    ``offline_smoother`` (offline :func:`fuse_recording` only; default off, see benchmarks/results/fusion.md):
    forward filter + Rauch-Tung-Striebel backward pass, the vision entering as gyroscope-bias measurements over
    windows of ``smoother_window_s`` with std ``visual_window_std_deg``.
    ``camera_from_imu``: rotation taking IMU axes to camera axes (row-major 3x3; identity when the IMU is the
    camera's, as in the simulator). ``time_offset_s``: added to IMU timestamps to put them on the video clock.
    ``accelerometer_calibration``: the accelerometer's bias and scale (``walkmon calibrate-imu``), removed from
    every sample as it enters :func:`fuse_recording` or :class:`LiveFusion`; None: samples taken as they are.
    ``max_imu_gap_s``: frames more than this after the last IMU sample (a dropout, an IMU that stopped before the
    video) are carried by the vision alone, frame to frame (a held frame holds), each adding ``visual_std_deg``
    of doubt; the gyroscope's last rate is not extrapolated over them (it was: a 2 s dropout of a simulated
    walk's IMU left every later fused angle 7-20 deg off, the vision's increments rejected as outliers against
    the extrapolation). Offline (:func:`fuse_recording`) it is 1.5 of the IMU's longest usual intervals when
    that is shorter. The first IMU sample after a gap of 0.1 s or more restarts the attitude core (a
    fixed-rate filter knows nothing of the time it missed), whose gravity then waits ``core_warmup_s``.
    ``visual_guard_frames``: frames the estimator measured (``ok``) but within this many of a frame it flagged are
    no visual measurement (offline on both sides, live after the flag): beside a facade the estimator flags
    frames on and off, and the ok frames between carry a systematic error (0.06-0.09 deg a frame, up to 1.2 deg
    a second) that the filter, weighting them as 0.02 deg, learnt as a gyroscope bias and kept integrating
    (user review: a mid-walk 90 + 180 deg turning clip's fused pitch 1.3 deg RMS where the video alone had 0.4;
    with 3 guard frames 0.48, and lower on four other turning clips, helper measurement 2026-11-28). Offline the
    guard applies only while it leaves at least ``GUARD_MIN_KEPT`` (20 %) of the measured frames (that clip: 43 %);
    flags every few frames would leave none (review), and the vision is then used unguarded, with a warning.
    """

    attitude: AttitudeSettings = DEFAULT_ATTITUDE_SETTINGS
    imu_filter: ImuFilterSettings = DEFAULT_IMU_FILTER
    core_gravity_std_deg: float = 1.0
    core_gravity_hz: float = 10.0
    core_warmup_s: float = 12.0
    gravity_reset_s: float = 3.0
    visual_std_deg: float = 0.05
    visual_gate: float = _GATE_3DOF
    visual_outlier_deg: float = 1.0
    camera_from_imu: tuple[float, ...] = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    time_offset_s: float = 0.0
    offline_smoother: bool = False
    visual_baseline_s: float = 0.0
    visual_window_std_deg: float = 0.04
    visual_drift_std_deg_s: float = 0.02
    visual_scale_std: float = 0.01
    visual_roll_std_factor: float = 2.0
    smoother_window_s: float = 1.0
    visual_std_unknown_bias_deg: float = 0.02
    accelerometer_calibration: AccelerometerCalibration | None = None
    max_imu_gap_s: float = 0.1
    visual_guard_frames: int = 3

    def __post_init__(self) -> None:
        if not (isinstance(self.visual_guard_frames, int) and 0 <= self.visual_guard_frames <= 100):
            msg = f"visual_guard_frames must be a whole number 0-100, got {self.visual_guard_frames}"
            raise ConfigError(msg)
        if not (np.isfinite(self.visual_std_deg) and self.visual_std_deg > 0):
            msg = f"visual_std_deg must be positive, got {self.visual_std_deg}"
            raise ConfigError(msg)
        if not (np.isfinite(self.visual_gate) and self.visual_gate > 0 and self.visual_outlier_deg > 0):
            msg = f"visual_gate and visual_outlier_deg must be positive, got {self.visual_gate}, {self.visual_outlier_deg}"
            raise ConfigError(msg)
        R = np.asarray(self.camera_from_imu, dtype=float)
        if R.shape != (9,) or not np.allclose(R.reshape(3, 3) @ R.reshape(3, 3).T, np.eye(3), atol=1e-4):
            msg = f"camera_from_imu must be 9 numbers of a rotation matrix, got {self.camera_from_imu}"
            raise ConfigError(msg)
        if not (np.isfinite(self.visual_baseline_s) and self.visual_baseline_s >= 0):
            msg = f"visual_baseline_s must be >= 0 (0 = every frame), got {self.visual_baseline_s}"
            raise ConfigError(msg)
        for name in ("core_gravity_std_deg", "core_gravity_hz", "core_warmup_s", "gravity_reset_s", "visual_window_std_deg", "visual_std_unknown_bias_deg", "visual_drift_std_deg_s", "visual_scale_std", "visual_roll_std_factor",
                     "smoother_window_s", "max_imu_gap_s"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                msg = f"{name} must be positive, got {value}"
                raise ConfigError(msg)
        if not np.isfinite(self.time_offset_s):
            msg = f"time_offset_s must be finite, got {self.time_offset_s}"
            raise ConfigError(msg)

    @property
    def camera_from_imu_matrix(self) -> NDArray[np.float64]:
        return np.asarray(self.camera_from_imu, dtype=float).reshape(3, 3)


DEFAULT_FUSION_SETTINGS = FusionSettings()


@dataclass(frozen=True, slots=True)
class FusedEstimate:
    """The fused camera orientation at one video frame (angles in degrees, conventions of walkmon.consts).

    ``visual_used``: the frame's visual rotation corrected the filter; ``visual_rejected``: it was offered but
    flagged bad or rejected as an outlier.
    """

    t_s: float
    rotation: NDArray[np.float64]
    angles_deg: NDArray[np.float64]
    gravity_down: NDArray[np.float64]
    abs_angles_deg: NDArray[np.float64]
    gyroscope_bias_rad_s: NDArray[np.float64]
    visual_used: bool
    visual_rejected: bool

    def __post_init__(self) -> None:
        for name in ("rotation", "angles_deg", "gravity_down", "abs_angles_deg", "gyroscope_bias_rad_s"):
            getattr(self, name).setflags(write=False)


class CameraImuFusion:
    """Stage: ``push_imu(t_s, gyro, accel)`` for every IMU sample and ``push_frame(t_s, rotation, ok)`` for
    every video frame, in time order (IMU times in the IMU clock; the offset is applied here). ``reset()``.

    Two filters run on the same (camera-frame) samples: the attitude core (:class:`ImuFilterSettings`, VQF by
    default), which gives gravity, and the error-state filter, which propagates with the gyroscope, takes the
    core's gravity as a slow tilt measurement, the zero-rate updates while the core detects rest, and the visual
    increments. ``gravity_resets``, ``gravity_rejected``: recoveries and gated gravity updates so far."""

    def __init__(self, settings: FusionSettings = DEFAULT_FUSION_SETTINGS) -> None:
        self.settings = settings
        self._filter = ImuAttitudeFilter(settings.attitude, n_clones=1, n_extra=6)
        self._R_ci = settings.camera_from_imu_matrix
        self.reset()

    def reset(
        self,
        *,
        initial_accelerometer_m_s2: ArrayLike | None = None,
        initial_bias_rad_s: ArrayLike | None = None,
        initial_bias_std_rad_s: float | None = None,
        initial_tilt_std_deg: float | None = None,
        still_start: bool = False,
    ) -> None:
        """Forget everything; the optional initial values are in the IMU's axes (as the samples are).
        ``still_start``: the samples start still (the core's first gravity is good: no warm-up)."""
        a0 = None if initial_accelerometer_m_s2 is None else self._R_ci @ np.asarray(initial_accelerometer_m_s2, float)
        b0 = None if initial_bias_rad_s is None else self._R_ci @ np.asarray(initial_bias_rad_s, float)
        start = {"initial_accelerometer_m_s2": a0, "initial_bias_rad_s": b0,
                 "initial_bias_std_rad_s": initial_bias_std_rad_s, "initial_tilt_std_deg": initial_tilt_std_deg}
        self._filter.reset(**start)  # type: ignore[arg-type]
        s = self.settings
        self._core: AttitudeCore = make_core(s.imu_filter, s.attitude.rate_hz_nominal, **start)
        # the visual estimator's own drift rate (rad/s) and scale error, per camera axis
        self._filter.set_extra_prior(
            np.r_[np.full(3, np.radians(s.visual_drift_std_deg_s)), np.full(3, s.visual_scale_std)],
            np.r_[np.full(3, np.radians(s.visual_drift_std_deg_s) / 30.0), np.full(3, s.visual_scale_std / 30.0)],
        )
        self._gravity_std = np.radians(s.core_gravity_std_deg) * np.sqrt(s.imu_filter.tau_acc_s * s.core_gravity_hz)
        self._since_gravity_s = 0.0
        self._core_age_s = 0.0
        self._core_warmup_s = 0.0 if still_start else s.core_warmup_s
        self._rejected_s = 0.0
        self._last_imu_t: float | None = None
        self._has_reference = False
        self._last_visual: NDArray[np.float64] | None = None
        self._prev_visual: NDArray[np.float64] | None = None  # the last frame's visual orientation, when ok
        self._prev_rotation: NDArray[np.float64] | None = None  # the filter's orientation at the last frame
        self.frames_without_imu = 0
        self._anchor_t_s = -np.inf
        self.frames_used = 0
        self.frames_rejected = 0
        self.gravity_resets = 0
        self.gravity_rejected = 0

    @property
    def ready(self) -> bool:
        """True once the IMU has delivered its first samples (frames before that cannot be estimated)."""
        return self._filter.down_world is not None

    @property
    def bias_std_rad_s(self) -> float:
        """Uncertainty of the gyroscope bias estimate (largest axis, rad/s)."""
        return self._filter.bias_std_rad_s

    def push_imu(self, t_s: float, gyroscope_rad_s: ArrayLike, accelerometer_m_s2: ArrayLike) -> None:
        gyro = self._R_ci @ np.asarray(gyroscope_rad_s, dtype=float)
        accel = self._R_ci @ np.asarray(accelerometer_m_s2, dtype=float)
        tv = t_s + self.settings.time_offset_s
        f = self._filter
        restart_after_s = max(self.settings.max_imu_gap_s, _CORE_RESTART_GAP_S)
        if self._last_imu_t is not None and tv - self._last_imu_t > restart_after_s:
            self._after_gap(tv)
        # a frame may have taken the filter past this sample's time (live: an IMU a few ms late): its rate then
        # only becomes the rate from here on (advance_to raised 'time went backwards': the live fusion failed)
        f.advance_to(tv if f.t_s is None else max(tv, f.t_s), gyro)
        self._core.push(tv, gyro, accel)
        dt = 0.0 if self._last_imu_t is None else tv - self._last_imu_t
        self._last_imu_t = tv
        if f.down_world is None:
            f.correct(gyro, accel)  # the first accelerometer sample fixes the world's down
            return
        if self._core.at_rest:
            f.zero_rate_update(gyro)
        self._since_gravity_s += dt
        self._core_age_s += dt
        if self._core_age_s < self._core_warmup_s:
            self._since_gravity_s = 0.0
        elif self._since_gravity_s >= 1.0 / self.settings.core_gravity_hz - 1e-9:
            self._gravity_step(self._since_gravity_s)
            self._since_gravity_s = 0.0

    def _after_gap(self, tv: float) -> None:
        """The first IMU sample after a gap: a new attitude core, its gravity unused for ``core_warmup_s``."""
        s = self.settings
        _log.info("fusion: no IMU samples for %.2f s before t=%.3f s: attitude core restarted",
                  tv - (self._last_imu_t or tv), tv)
        self._core = make_core(s.imu_filter, s.attitude.rate_hz_nominal)
        self._core_age_s = 0.0
        self._core_warmup_s = s.core_warmup_s
        self._since_gravity_s = 0.0
        self._rejected_s = 0.0

    def _gravity_step(self, elapsed_s: float) -> None:
        """The core's gravity as a tilt measurement; after ``gravity_reset_s`` of gated updates, reset to it."""
        down = self._core.gravity_down
        if self._filter.gravity_update(down, self._gravity_std):
            self._rejected_s = 0.0
            return
        self.gravity_rejected += 1
        self._rejected_s += elapsed_s
        if self._rejected_s >= self.settings.gravity_reset_s:
            self._filter.align_to_gravity(down, tilt_std_deg=self.settings.core_gravity_std_deg)
            self._rejected_s = 0.0
            self.gravity_resets += 1
            _log.warning("fusion: gravity rejected for %.1f s: tilt reset to the IMU core's gravity", self.settings.gravity_reset_s)

    def _visual_update(self, residual: NDArray[np.float64], H: NDArray[np.float64]) -> bool:
        """Robust update: reject increments off by more than ``visual_outlier_deg``; beyond the chi-square
        gate, inflate the measurement noise so the normalised innovation sits at the gate (Huber-like), so an
        estimator noisier than ``visual_std_deg`` is down-weighted instead of thrown away."""
        s = self.settings
        if np.degrees(np.linalg.norm(residual)) > s.visual_outlier_deg:
            return False
        f = self._filter
        std = s.visual_window_std_deg if s.visual_baseline_s > 0 else s.visual_std_deg
        if f.bias_std_rad_s > _BIAS_KNOWN_RAD_S:
            std = min(std, s.visual_std_unknown_bias_deg)  # the bias is the larger error now: vision is its source
        R = np.diag([1.0, 1.0, s.visual_roll_std_factor**2]) * np.radians(std) ** 2
        d2 = f.normalised_innovation(residual, H, R)
        if d2 > s.visual_gate:
            R = R * (d2 / s.visual_gate)
        return f.update(residual, H, R)

    def _visual_increment(self, Rv: NDArray[np.float64], t_s: float) -> bool:
        """The rotation between the anchor frame and this one as a relative measurement (stochastic cloning),
        corrected for the visual drift rate and scale states; re-anchors the clone. True when it was used."""
        f = self._filter
        lay = f.layout
        assert self._last_visual is not None
        dR_vis = self._last_visual.T @ Rv
        dR_pred = f.clones[0].T @ f.rotation_world
        window_s = t_s - self._anchor_t_s
        phi = log_so3(dR_vis)
        extra = f.extra
        vis_err = window_s * extra[0:3] + phi * extra[3:6]
        residual = log_so3((dR_pred @ exp_so3(vis_err)).T @ dR_vis)
        H = np.zeros((3, lay.dim))
        H[:, lay.tilt] = np.eye(3)
        H[:, lay.clone(0)] = -dR_pred.T
        e0 = lay.extra.start
        H[:, e0 : e0 + 3] = np.eye(3) * window_s
        H[:, e0 + 3 : e0 + 6] = np.diag(phi)
        used = self._visual_update(residual, H)
        f.clone_current(0)
        self._last_visual, self._anchor_t_s = Rv, t_s
        return used

    def push_frame(self, t_s: float, visual_rotation: ArrayLike | None = None, ok: bool = True) -> FusedEstimate:
        """Propagate to the frame time and use its visual orientation (start-relative, as the rotation
        estimator reports it) when ``ok``; ``None`` means IMU only."""
        f = self._filter
        if f.t_s is None:
            msg = "push_frame before any IMU sample: the fusion needs IMU data up to the frame time"
            raise InvalidInputError(msg)
        Rv_ok = None if visual_rotation is None or not ok else np.asarray(visual_rotation, dtype=float)
        if self._last_imu_t is not None and t_s - self._last_imu_t > self.settings.max_imu_gap_s:
            return self._vision_only(t_s, Rv_ok)
        if t_s > f.t_s:
            f.advance_to(t_s)
        self._prev_visual = Rv_ok
        used = rejected = False
        if not self._has_reference:
            f.set_reference()
            self._has_reference = True
        if visual_rotation is not None and ok:
            Rv = np.asarray(visual_rotation, dtype=float)
            if self._last_visual is not None and t_s - self._anchor_t_s < self.settings.visual_baseline_s - 1e-9:
                pass  # inside the window: the clone stays at the anchor frame
            elif self._last_visual is not None:
                used = self._visual_increment(Rv, t_s)
                rejected = not used
            else:
                f.clone_current(0)
                self._last_visual, self._anchor_t_s = Rv, t_s
        elif visual_rotation is not None:
            rejected = True
            self._last_visual = None  # the chain is broken: the next good frame only re-anchors
        self.frames_used += used
        self.frames_rejected += rejected
        return self._estimate(t_s, used, rejected)

    def _vision_only(self, t_s: float, Rv: NDArray[np.float64] | None) -> FusedEstimate:
        """A frame with no IMU sample for ``max_imu_gap_s`` before it: the filter's orientation at the last frame
        turned by the vision's change since it (held when this frame or the last was not ok), with
        ``visual_std_deg`` more doubt. From the last frame, not from where the gyroscope took the filter after
        it: the vision's change covers that time too (turned on top, a dropout starting 25 ms after a frame
        counted 25 ms of rotation twice: 1.6 deg for good, found in review)."""
        f = self._filter
        prev, self._prev_visual = self._prev_visual, Rv
        self._last_visual = None  # the increments' chain re-anchors once the IMU is back
        if Rv is None or prev is None:  # held: as the gyroscope left it (its samples after the last frame count)
            turn, start = np.eye(3), f.rotation_world
        else:
            turn = prev.T @ Rv
            start = f.rotation_world if self._prev_rotation is None else self._prev_rotation
        f.rotate_by(f.rotation_world.T @ start @ turn, float(np.radians(self.settings.visual_std_deg)), t_s)
        if not self._has_reference:
            f.set_reference()
            self._has_reference = True
        self.frames_without_imu += 1
        return self._estimate(t_s, used=False, rejected=False)

    def _estimate(self, t_s: float, used: bool, rejected: bool) -> FusedEstimate:
        """The fused estimate at this frame (and the filter's orientation kept as the last frame's)."""
        f = self._filter
        self._prev_rotation = f.rotation_world.copy()
        R = f.reference.T @ f.rotation_world
        g = f.gravity_down
        g = np.array([0.0, 1.0, 0.0]) if g is None else g
        return FusedEstimate(
            t_s=float(t_s),
            rotation=R,
            angles_deg=angles_deg_from_rotation(R),
            gravity_down=g,
            abs_angles_deg=gravity_angles_deg_from_gravity(g),
            gyroscope_bias_rad_s=self._R_ci.T @ f.bias_rad_s,
            visual_used=used,
            visual_rejected=rejected,
        )


@dataclass(frozen=True, slots=True)
class FusionTrack:
    """Per-frame results of :func:`fuse_recording` (arrays of length N frames)."""

    t_s: NDArray[np.float64]
    angles_deg: NDArray[np.float64]
    abs_angles_deg: NDArray[np.float64]
    gravity_down: NDArray[np.float64]
    visual_used: NDArray[np.bool_]
    gyroscope_bias_rad_s: NDArray[np.float64]
    frames_rejected: int = 0
    method: str = field(default="imu")
    gravity_resets: int = 0
    #: frames with no IMU sample for ``max_imu_gap_s`` before them, carried by the vision alone
    frames_without_imu: int = 0

    def __post_init__(self) -> None:
        for name in ("t_s", "angles_deg", "abs_angles_deg", "gravity_down", "visual_used", "gyroscope_bias_rad_s"):
            getattr(self, name).setflags(write=False)


def fuse_recording(
    imu_t_s: ArrayLike,
    gyroscope_rad_s: ArrayLike,
    accelerometer_m_s2: ArrayLike,
    frame_t_s: ArrayLike,
    visual_rotations: ArrayLike | None = None,
    visual_ok: ArrayLike | None = None,
    settings: FusionSettings = DEFAULT_FUSION_SETTINGS,
) -> FusionTrack:
    """Offline fusion of a whole recording, estimates at ``frame_t_s`` (video clock).

    Without ``visual_rotations`` this is the IMU attitude core alone (:func:`track_attitude`, default VQF)
    sampled at the given times. With them, the causal fusion (:class:`CameraImuFusion`) starts from the IMU's
    still start (mean gravity; mean gyro as bias); when the recording does not start still, a second pass
    starts from the first pass's final bias estimate. Frames before the first IMU sample (an IMU started after
    the camera) are carried by the vision alone, back from the first frame the IMU covers, and every frame's
    angles are relative to the first frame (they were all given that first frame's estimate: zero angles and one
    gravity for seconds the camera measured).
    """
    t, g, a, ft, Rv, ok = _recording_arrays(imu_t_s, gyroscope_rad_s, accelerometer_m_s2, frame_t_s, visual_rotations, visual_ok)
    if Rv is not None:
        guarded = away_from_flags(ok, settings.visual_guard_frames)
        if guarded.sum() >= GUARD_MIN_KEPT * ok.sum():
            ok = guarded
        else:
            # flags so frequent (every few frames) that the guard would leave next to no vision (review: every 5th
            # frame flagged, none used, the fused yaw 2-5 deg off where the vision held it to 0.7-2.3): unguarded
            _log.warning("fusion: the estimator flagged frames so often that guarding their neighbours would leave "
                         "%d of %d measured frames: all %d used", int(guarded.sum()), int(ok.sum()), int(ok.sum()))
    if settings.accelerometer_calibration is not None:
        a = settings.accelerometer_calibration.correct(a)
    rate = sampling_rate_hz(t)  # gaps left out (walkmon.sampling)
    # offline every sample is known: a frame beyond 1.5 of the IMU's longest usual intervals after the last sample
    # has none coming (7.5 ms at 200 Hz), and the gyroscope's rate is not extrapolated to it
    settings = replace(settings, attitude=replace(settings.attitude, rate_hz_nominal=float(rate)),
                       max_imu_gap_s=min(settings.max_imu_gap_s, 1.5 * longest_usual_interval_s(t)))
    if Rv is None:
        return _core_recording(t, g, a, ft, settings)
    if settings.offline_smoother:
        tv = t + settings.time_offset_s
        last = np.clip(np.searchsorted(tv, ft, side="right") - 1, 0, len(tv) - 1)
        if np.any(ft - tv[last] > settings.max_imu_gap_s):
            # the smoother has no way to carry frames without IMU samples (a dropout gave 126 deg of error there:
            # review); the causal fusion has
            _log.warning("fusion: frames without IMU samples near them: the causal fusion, not the smoother")
        else:
            return _smoothed_recording(t, g, a, ft, Rv, ok, settings)
    a0, b0, b0_std, tilt_std = initial_state_from_rest(t, g, a)
    if b0 is None:
        # no still start: both passes weight the vision as while the bias is unknown (benchmarks: mid-walk
        # starts 0.17 vs 0.28 deg mean pitch error with the still-start weighting)
        settings = replace(settings, visual_std_deg=settings.visual_std_unknown_bias_deg)
    fusion = CameraImuFusion(settings)
    estimates = _causal_pass(fusion, t, g, a, ft, Rv, ok, (a0, b0, b0_std, tilt_std, b0 is not None))
    if b0 is None:
        # No still period at the start: the bias is only learnt while moving and the first second's mean
        # acceleration is a poor gravity reference, so the first seconds would keep both errors. Offline we can
        # do better: a second pass starts from the first pass's final bias estimate (with its uncertainty) and
        # from gravity as the mean specific force over the whole recording rotated into the first frame with
        # the first pass's orientations (walking accelerations average out over the recording).
        final_std = fusion.bias_std_rad_s
        start = (_mean_gravity_first_frame(estimates, t, a, ft, settings), np.asarray(estimates[-1].gyroscope_bias_rad_s),
                 max(final_std, 1e-4), 0.5, False)
        estimates = _causal_pass(fusion, t, g, a, ft, Rv, ok, start)
        _log.info("no still start: second pass from the first pass's bias (std %.4f deg/s)", np.degrees(final_std))
    estimates = _vision_before_imu(estimates, ft, Rv, float(t[0] + settings.time_offset_s))
    return FusionTrack(
        t_s=ft.copy(),
        angles_deg=np.array([e.angles_deg for e in estimates]),
        abs_angles_deg=np.array([e.abs_angles_deg for e in estimates]),
        gravity_down=np.array([e.gravity_down for e in estimates]),
        visual_used=np.array([e.visual_used for e in estimates]),
        gyroscope_bias_rad_s=np.array([e.gyroscope_bias_rad_s for e in estimates]),
        frames_rejected=fusion.frames_rejected,
        method="fused",
        gravity_resets=fusion.gravity_resets,
        frames_without_imu=fusion.frames_without_imu,
    )


#: The share of the measured frames the guard (``visual_guard_frames``) must leave for it to apply offline.
GUARD_MIN_KEPT = 0.2


def away_from_flags(ok: ArrayLike, guard: int) -> NDArray[np.bool_]:
    """``ok`` with every frame within ``guard`` frames (before or after) of a not-ok frame made not ok
    (:class:`FusionSettings` ``visual_guard_frames``)."""
    m = np.asarray(ok, dtype=bool).copy()
    if guard <= 0 or m.all():
        return m
    bad = ~m
    near = bad.copy()
    for k in range(1, guard + 1):
        near[k:] |= bad[:-k]
        near[:-k] |= bad[k:]
    return m & ~near


def _recording_arrays(
    imu_t_s: ArrayLike, gyroscope_rad_s: ArrayLike, accelerometer_m_s2: ArrayLike, frame_t_s: ArrayLike,
    visual_rotations: ArrayLike | None, visual_ok: ArrayLike | None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64] | None, NDArray[np.bool_]]:
    """The inputs of :func:`fuse_recording` as arrays, checked (one-line InvalidInputError)."""
    t = np.asarray(imu_t_s, dtype=float).reshape(-1)
    g = np.asarray(gyroscope_rad_s, dtype=float)
    a = np.asarray(accelerometer_m_s2, dtype=float)
    ft = np.asarray(frame_t_s, dtype=float).reshape(-1)
    if g.shape != (len(t), 3) or a.shape != (len(t), 3) or len(t) < 2:
        msg = f"IMU arrays must be t (N>=2,), gyro (N,3), accel (N,3); got {t.shape}, {g.shape}, {a.shape}"
        raise InvalidInputError(msg)
    if len(ft) == 0 or np.any(np.diff(ft) < 0):
        msg = "frame times must be non-empty and non-decreasing"
        raise InvalidInputError(msg)
    Rv = None
    if visual_rotations is not None:
        Rv = np.asarray(visual_rotations, dtype=float)
        if Rv.shape != (len(ft), 3, 3):
            msg = f"visual rotations must have shape ({len(ft)}, 3, 3), got {Rv.shape}"
            raise InvalidInputError(msg)
    ok = np.ones(len(ft), bool) if visual_ok is None else np.asarray(visual_ok, dtype=bool).reshape(-1)
    if len(ok) != len(ft):
        msg = f"visual_ok must have {len(ft)} entries, got {len(ok)}"
        raise InvalidInputError(msg)
    return t, g, a, ft, Rv, ok


def _causal_pass(
    fusion: CameraImuFusion, t: NDArray[np.float64], g: NDArray[np.float64], a: NDArray[np.float64],
    ft: NDArray[np.float64], Rv: NDArray[np.float64], ok: NDArray[np.bool_], start: tuple,
) -> list[FusedEstimate]:
    """One causal pass of ``fusion`` over the recording from ``start`` = (accel, bias, bias std, tilt std, still):
    every IMU sample up to a frame's time, then the frame."""
    accel0, bias, bias_std, tilt, still = start
    fusion.reset(initial_accelerometer_m_s2=accel0, initial_bias_rad_s=bias, initial_bias_std_rad_s=bias_std,
                 initial_tilt_std_deg=tilt, still_start=still)
    t_video = t + fusion.settings.time_offset_s
    estimates = []
    i = 0
    for k, tk in enumerate(ft):
        while i < len(t) and t_video[i] <= tk:
            fusion.push_imu(t[i], g[i], a[i])
            i += 1
        if i == 0:  # frame before the first IMU sample
            fusion.push_imu(t[0], g[0], a[0])
            i = 1
        estimates.append(fusion.push_frame(max(tk, t_video[0]), Rv[k], bool(ok[k])))
    return estimates


def _vision_before_imu(
    estimates: list[FusedEstimate], ft: NDArray[np.float64], Rv: NDArray[np.float64], imu_start_s: float
) -> list[FusedEstimate]:
    """The frames before ``imu_start_s`` (video clock) turned by the vision's own change from the first frame after
    it (its gravity with them), then every frame re-referenced to the first: start-relative as documented."""
    k0 = int(np.searchsorted(ft, imu_start_s - 1e-9))
    if k0 == 0 or k0 >= len(ft):
        return estimates
    _log.info("fusion: %d frames before the IMU's first sample carried by the vision alone", k0)
    first = estimates[k0]
    out: list[FusedEstimate] = []
    rel = np.eye(3)
    for k in range(k0 - 1, -1, -1):  # back from the first frame the IMU covers
        r = Rv[k0].T @ Rv[k]  # frame k's axes in frame k0's
        rel = r if np.all(np.isfinite(r)) else rel  # a frame the vision has no rotation for: held (review)
        down = rel.T @ first.gravity_down
        out.append(replace(first, t_s=float(ft[k]), rotation=first.rotation @ rel, gravity_down=down,
                           abs_angles_deg=gravity_angles_deg_from_gravity(down), visual_used=False,
                           visual_rejected=False))
    out.reverse()
    out += estimates[k0:]
    R0 = out[0].rotation
    return [replace(e, rotation=R0.T @ e.rotation, angles_deg=angles_deg_from_rotation(R0.T @ e.rotation))
            for e in out]


def _mean_gravity_first_frame(
    estimates: list[FusedEstimate], t: NDArray[np.float64], a: NDArray[np.float64], ft: NDArray[np.float64],
    settings: FusionSettings,
) -> NDArray[np.float64]:
    """Mean specific force over the recording rotated into the first frame with a pass's orientations, in the
    IMU's axes (walking accelerations average out: the second pass's gravity reference)."""
    R_ci = settings.camera_from_imu_matrix
    tv = t + settings.time_offset_s
    idx = np.clip(np.searchsorted(tv, ft), 0, len(t) - 1)
    # only frames with an IMU sample near them: a frame after the IMU's end or in a dropout would weigh one
    # sample's walking acceleration (up to 40 % of the weight: 1.3 deg of absolute tilt, found in review)
    near = np.abs(tv[idx] - ft) <= max(settings.max_imu_gap_s, 1.0 / max(sampling_rate_hz(t), 1e-9))
    if not near.any():
        near[:] = True
    rel = np.array([e.rotation for e in estimates])[near]
    mean_f0 = np.einsum("nij,nj->i", rel, a[idx[near]] @ R_ci.T) / int(near.sum())
    return R_ci.T @ mean_f0


def _core_recording(
    t: NDArray[np.float64], g: NDArray[np.float64], a: NDArray[np.float64], ft: NDArray[np.float64],
    settings: FusionSettings,
) -> FusionTrack:
    """IMU only: the attitude core over the recording in the camera frame, sampled at the frame times (the
    last IMU sample at or before each frame); angles relative to the first frame."""
    R_ci = settings.camera_from_imu_matrix
    tv = t + settings.time_offset_s
    track = track_attitude(tv, g @ R_ci.T, a @ R_ci.T, settings.imu_filter)
    idx = np.clip(np.searchsorted(tv, ft, side="right") - 1, 0, len(tv) - 1)
    R = track.rotations[idx]
    rel = np.einsum("ji,njk->nik", R[0], R)
    down = track.gravity_down[idx]
    return FusionTrack(
        t_s=ft.copy(), angles_deg=angles_deg_from_rotation(rel), abs_angles_deg=track.abs_angles_deg[idx],
        gravity_down=down, visual_used=np.zeros(len(ft), bool), gyroscope_bias_rad_s=track.gyroscope_bias_rad_s[idx] @ R_ci,
        method="imu",
    )


def _smoothed_recording(
    t: NDArray[np.float64],
    g: NDArray[np.float64],
    a: NDArray[np.float64],
    ft: NDArray[np.float64],
    Rv: NDArray[np.float64] | None,
    ok: NDArray[np.bool_],
    settings: FusionSettings,
) -> FusionTrack:
    """:func:`fuse_recording` with the offline smoother (``settings.offline_smoother``): IMU samples rotated
    into the camera frame and put on the video clock, :func:`walkmon.imu.attitude.smooth_attitude`, results
    sampled at the frame times. A recording that does not start still gets a second pass as the causal path
    does (bias from the first pass's smoothed start, gravity from the whole recording's mean specific force)."""
    R_ci = settings.camera_from_imu_matrix
    gc, ac = g @ R_ci.T, a @ R_ci.T
    tv = t + settings.time_offset_s
    visual = None
    if Rv is not None:
        visual = VisualWindows(
            t_s=ft, rotations=Rv, ok=ok, baseline_s=settings.smoother_window_s,
            std_deg=settings.visual_window_std_deg, outlier_deg=settings.visual_outlier_deg, gate=settings.visual_gate,
        )
    a0, b0, b0_std, tilt_std = initial_state_from_rest(tv, gc, ac)
    sm = smooth_attitude(
        tv, gc, ac, settings.attitude, initial_accelerometer_m_s2=a0, initial_bias_rad_s=b0,
        initial_bias_std_rad_s=b0_std, initial_tilt_std_deg=tilt_std, visual=visual,
    )
    if b0 is None:
        R_frames, _ = sm.at(ft)
        rel = np.einsum("ji,njk->nik", R_frames[0], R_frames)
        idx = np.clip(np.searchsorted(tv, ft), 0, len(tv) - 1)
        a0_second = np.einsum("nij,nj->i", rel, ac[idx]) / len(ft)
        sm = smooth_attitude(
            tv, gc, ac, settings.attitude, initial_accelerometer_m_s2=a0_second, initial_bias_rad_s=sm.bias_rad_s[0],
            initial_bias_std_rad_s=max(sm.bias_std_rad_s, 1e-4), initial_tilt_std_deg=0.5, visual=visual,
        )
        _log.info("no still start: second smoothed pass from the first pass's bias")
    R_frames, b_frames = sm.at(np.maximum(ft, tv[0]))
    rel = np.einsum("ji,njk->nik", R_frames[0], R_frames)
    down = np.einsum("nji,j->ni", R_frames, sm.down_world)
    used = sm.visual_used if Rv is not None else np.zeros(len(ft), bool)
    return FusionTrack(
        t_s=ft.copy(),
        angles_deg=angles_deg_from_rotation(rel),
        abs_angles_deg=gravity_angles_deg_from_gravity(down),
        gravity_down=down,
        visual_used=used.copy(),
        gyroscope_bias_rad_s=b_frames @ R_ci,
        frames_rejected=int(sm.visual_rejected.sum()) if Rv is not None else 0,
        method="imu" if Rv is None else "fused",
    )


# ------------------------------------------------------------------------------------------------ live stage


@dataclass(frozen=True, slots=True)
class LiveFusionSettings:
    """Settings of :class:`LiveFusion` (the ``[imu]`` section of the live config feeds them).

    ``fusion``: the filter (its ``camera_from_imu`` and ``time_offset_s`` come from ``[imu] extrinsics`` /
    ``rotation_deg`` and ``time_offset_s``). ``warmup_s``: IMU data collected before the filter starts, for its
    initial gravity and (when the sensor was still) gyroscope bias, as the offline start does with the still
    start; frames meanwhile are camera-only. ``max_lag_s``: a frame later than the newest IMU sample (on the
    video clock) by more than this is camera-only (extrapolating the last gyro reading through walking
    motion costs tenths of a degree within 0.1 s); the filter waits for the IMU. ``max_gap_s``: IMU samples
    this far apart are a gap: the filter restarts from the next one (keeping its bias and the gravity
    direction carried on by the camera). ``max_pending``: IMU samples held waiting for
    their frame (oldest dropped beyond it, counted).
    """

    fusion: FusionSettings = DEFAULT_FUSION_SETTINGS
    warmup_s: float = 1.0
    max_gap_s: float = 0.1
    max_lag_s: float = 0.02
    max_pending: int = 20000

    def __post_init__(self) -> None:
        if not (np.isfinite(self.warmup_s) and self.warmup_s >= 0):
            msg = f"warmup_s must be >= 0, got {self.warmup_s}"
            raise ConfigError(msg)
        if not (np.isfinite(self.max_gap_s) and self.max_gap_s > 0 and np.isfinite(self.max_lag_s) and self.max_lag_s >= 0):
            msg = f"max_gap_s must be > 0 and max_lag_s >= 0, got {self.max_gap_s}, {self.max_lag_s}"
            raise ConfigError(msg)
        if self.max_pending < 1:
            msg = f"max_pending must be >= 1, got {self.max_pending}"
            raise ConfigError(msg)


@dataclass(frozen=True, slots=True)
class LiveFusedFrame:
    """One frame out of :class:`LiveFusion`: start-relative ``angles_deg`` (pitch, yaw, roll) and
    ``abs_angles_deg`` (gravity-referenced pitch, roll; NaN when not fused). ``mode``: ``fused`` or
    ``camera`` (camera-only); ``reason`` for camera-only frames: ``no_imu`` (no sample yet), ``warmup``,
    ``imu_gap`` (IMU late, paused or disconnected)."""

    t_s: float
    rotation: NDArray[np.float64]
    angles_deg: tuple[float, float, float]
    abs_angles_deg: tuple[float, float]
    mode: str
    reason: str = ""


class LiveFusion:
    """Stage of the live pipeline: camera rotation estimates + IMU samples -> fused orientation per frame.

    ``push_imu(t_s, gyro, accel)`` in arrival order (IMU clock; samples not after the previous one are dropped
    and counted), ``push_frame(t_s, rotation, ok)`` per frame (video clock; ``rotation`` start-relative as the
    rotation estimator reports it). Samples wait until a frame at or after their time, so an IMU ahead of the
    video (file replay) is used in time order. The output is continuous across modes: camera-only frames chain
    the visual increments onto the last output, and a (re)started filter is anchored to the output at its
    first frame. ``counters()`` for status lines and logs. No I/O, no threads.
    """

    def __init__(self, settings: LiveFusionSettings = LiveFusionSettings()) -> None:  # noqa: B008 - frozen
        self.settings = settings
        self.reset()

    def reset(self) -> None:
        self._pending: collections.deque[tuple[float, NDArray[np.float64], NDArray[np.float64]]] = collections.deque()
        self._warmup: list[tuple[float, NDArray[np.float64], NDArray[np.float64]]] = []
        self._fusion: CameraImuFusion | None = None
        self._gravity_resets_before = 0  # of the filters before a restart
        self._rate_hz: float | None = None
        self._needs_restart = False
        self._last_imu_t: float | None = None  # video clock, last sample accepted
        self._filter_t: float | None = None  # video clock, last sample pushed into the filter
        self._bias: NDArray[np.float64] | None = None
        self._down: NDArray[np.float64] | None = None  # gravity (down) in the camera frame at the last output
        self._anchor: NDArray[np.float64] = np.eye(3)
        self._last_out: NDArray[np.float64] | None = None
        self._last_visual: NDArray[np.float64] | None = None
        self._fresh = False
        self._last_frame_t: float | None = None
        self._since_flag = 10**9  # frames since the estimator last flagged one (visual_guard_frames)
        self.n_fused = 0
        self.n_camera_only: dict[str, int] = {"no_imu": 0, "warmup": 0, "imu_gap": 0}
        self.n_restarts = 0
        self.n_imu_dropped = 0
        self.n_imu = 0

    def counters(self) -> dict[str, object]:
        """Counts for the status line / hop JSON: fused and camera-only frames (by reason), filter restarts,
        IMU samples used and dropped, tilt resets to the core's gravity after a long rejection."""
        resets = self._gravity_resets_before + (self._fusion.gravity_resets if self._fusion is not None else 0)
        return {"frames_fused": self.n_fused, "frames_camera_only": dict(self.n_camera_only),
                "filter_restarts": self.n_restarts, "imu_samples": self.n_imu, "imu_dropped": self.n_imu_dropped,
                "gravity_resets": resets}

    # -- input ------------------------------------------------------------------------------------------
    def push_imu(self, t_s: float, gyroscope_rad_s: ArrayLike | None, accelerometer_m_s2: ArrayLike) -> None:
        tv = float(t_s) + self.settings.fusion.time_offset_s
        if self._last_imu_t is not None and tv < self._last_imu_t - self.settings.max_gap_s:
            self._clock_restarted("IMU")
        if gyroscope_rad_s is None or not np.isfinite(tv) or (self._last_imu_t is not None and tv <= self._last_imu_t):
            self.n_imu_dropped += 1
            return
        g = np.asarray(gyroscope_rad_s, dtype=float)
        a = np.asarray(accelerometer_m_s2, dtype=float)
        if g.shape != (3,) or a.shape != (3,) or not (np.all(np.isfinite(g)) and np.all(np.isfinite(a))):
            self.n_imu_dropped += 1
            return
        if self.settings.fusion.accelerometer_calibration is not None:
            a = self.settings.fusion.accelerometer_calibration.correct(a)
        self._last_imu_t = tv
        if len(self._pending) >= self.settings.max_pending:
            self._pending.popleft()
            self.n_imu_dropped += 1
        self._pending.append((tv, g, a))

    def _clock_restarted(self, which: str) -> None:
        """A device clock that jumped back (an OAK re-opened after a reconnection): forget the samples and
        restart the filter on the new clock; the output stays continuous."""
        _log.warning("%s clock went back: fusion restarts on the new clock", which)
        self._pending.clear()
        self._warmup = []
        self._last_imu_t = self._filter_t = None
        self._needs_restart = self._fusion is not None

    def _feed(self, tv: float, g: NDArray[np.float64], a: NDArray[np.float64]) -> None:
        """One sample (video clock) into the warm-up buffer or the running filter."""
        s = self.settings
        if self._filter_t is not None and tv - self._filter_t > s.max_gap_s:
            if self._fusion is not None:
                self._needs_restart = True  # an IMU gap: the filter restarts from this sample, keeping its bias
            else:
                self._warmup = []  # a gap during the warm-up: start it again
        self._filter_t = tv
        self.n_imu += 1
        if self._needs_restart:
            self._start([(tv, g, a)], restart=True)
            return
        if self._fusion is None:
            self._warmup.append((tv, g, a))
            if tv - self._warmup[0][0] >= s.warmup_s and len(self._warmup) >= 2:
                self._start(self._warmup, restart=False)
                self._warmup = []
            return
        self._fusion.push_imu(tv - s.fusion.time_offset_s, g, a)

    def _start(self, samples: list[tuple[float, NDArray[np.float64], NDArray[np.float64]]], *, restart: bool) -> None:
        s = self.settings.fusion
        R_ci = s.camera_from_imu_matrix
        t = np.array([x[0] for x in samples])
        g = np.array([x[1] for x in samples])
        a = np.array([x[2] for x in samples])
        b0_std: float | None
        tilt: float | None
        if restart:
            # keep what the filter had learnt: the bias, and gravity from the last fused frame carried on by the
            # camera-only frames since (a single accelerometer sample while walking can be degrees off)
            b0 = self._bias
            if self._down is not None:
                a0, tilt = R_ci.T @ (-GRAVITY_MS2 * self._down), 1.0
            else:
                a0, tilt = a[0], 5.0
            b0_std = None if b0 is None else float(np.radians(0.1))
            self.n_restarts += 1
            _log.warning("IMU gap: fusion filter restarted at t=%.3f s", t[0])
        else:
            a0, b0, b0_std, tilt = initial_state_from_rest(t, g @ R_ci.T, a @ R_ci.T)
            a0 = R_ci.T @ a0
            b0 = None if b0 is None else R_ci.T @ b0
            if len(t) > 1 and t[-1] > t[0]:
                self._rate_hz = sampling_rate_hz(t)
            if b0 is None:  # not still: weight the vision as while the bias is unknown (as fuse_recording)
                s = replace(s, visual_std_deg=s.visual_std_unknown_bias_deg)
            _log.info("IMU warm-up done (%d samples): fusion starts at t=%.3f s", len(t), t[-1])
        if self._rate_hz is not None:  # the IMU rate measured in the warm-up (a restart keeps it)
            s = replace(s, attitude=replace(s.attitude, rate_hz_nominal=float(self._rate_hz)))
        if self._fusion is not None:
            self._gravity_resets_before += self._fusion.gravity_resets
        fusion = CameraImuFusion(s)
        fusion.reset(initial_accelerometer_m_s2=a0, initial_bias_rad_s=b0, initial_bias_std_rad_s=b0_std,
                     initial_tilt_std_deg=tilt, still_start=not restart and b0 is not None)
        for tv, gk, ak in samples:
            fusion.push_imu(tv - s.time_offset_s, gk, ak)
        self._fusion = fusion
        self._needs_restart = False
        self._fresh = True  # the next fused frame anchors the filter's reference to the output

    # -- per frame --------------------------------------------------------------------------------------
    def push_frame(self, t_s: float, visual_rotation: ArrayLike, ok: bool = True) -> LiveFusedFrame:
        t_s = float(t_s)
        if self._last_frame_t is not None and t_s < self._last_frame_t - self.settings.max_gap_s:
            self._clock_restarted("camera")
        self._last_frame_t = t_s
        while self._pending and self._pending[0][0] <= t_s:
            self._feed(*self._pending.popleft())
        Rv = np.asarray(visual_rotation, dtype=float)
        fused = self._fusion is not None and not self._needs_restart
        reason = ""
        if self._filter_t is None:
            reason = "no_imu"
        elif t_s - self._filter_t > self.settings.max_lag_s:
            reason = "imu_gap"
        elif not fused:
            reason = "imu_gap" if self._needs_restart else "warmup"
        self._since_flag = 0 if not ok else self._since_flag + 1  # camera-only frames count too (review)
        if reason:
            out = self._camera_only(Rv)
            self.n_camera_only[reason] += 1
            if self._down is not None and self._last_visual is not None:
                self._down = (self._last_visual.T @ Rv).T @ self._down
            self._last_out, self._last_visual = out, Rv
            return LiveFusedFrame(t_s, out, tuple(float(v) for v in angles_deg_from_rotation(out)),  # type: ignore[arg-type]
                                  (np.nan, np.nan), "camera", reason)
        assert self._fusion is not None
        # the ok frames just after a flagged one are no measurement (visual_guard_frames; offline the frames just
        # before one too, which live would need a delay for)
        guarded = ok and self._since_flag > self.settings.fusion.visual_guard_frames
        est = self._fusion.push_frame(max(t_s, self._filter_t or t_s), Rv, guarded)
        if self._fresh:
            self._fresh = False
            base = self._camera_only(Rv) if self._last_out is not None else np.eye(3)
            self._anchor = base @ est.rotation.T
        out = self._anchor @ est.rotation
        self._bias = np.asarray(est.gyroscope_bias_rad_s, dtype=float)  # in the IMU's axes, as reset() takes it
        self._down = np.asarray(est.gravity_down, dtype=float)
        self.n_fused += 1
        self._last_out, self._last_visual = out, Rv
        return LiveFusedFrame(t_s, out, tuple(float(v) for v in angles_deg_from_rotation(out)),  # type: ignore[arg-type]
                              (float(est.abs_angles_deg[0]), float(est.abs_angles_deg[1])), "fused")

    def _camera_only(self, Rv: NDArray[np.float64]) -> NDArray[np.float64]:
        """The last output moved on by the visual increment since the last frame (the visual rotation itself
        before any output)."""
        if self._last_out is None or self._last_visual is None:
            return Rv
        return self._last_out @ (self._last_visual.T @ Rv)
