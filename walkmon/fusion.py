"""Camera-IMU fusion: the IMU attitude filter plus the visual rotation as a relative measurement.

The error-state Kalman filter of :mod:`walkmon.imu_attitude` runs in the **camera** frame (IMU samples are
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

import logging
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from walkmon.consts import angles_deg_from_rotation, gravity_angles_deg_from_gravity
from walkmon.errors import ConfigError, InvalidInputError
from walkmon.imu_attitude import (
    DEFAULT_ATTITUDE_SETTINGS,
    AttitudeSettings,
    ImuAttitudeFilter,
    initial_state_from_rest,
    log_so3,
)

__all__ = [
    "DEFAULT_FUSION_SETTINGS",
    "CameraImuFusion",
    "FusedEstimate",
    "FusionSettings",
    "FusionTrack",
    "fuse_recording",
]

_log = logging.getLogger(__name__)

#: Chi-square 99.9 % quantile, 3 degrees of freedom.
_GATE_3DOF = 16.27


@dataclass(frozen=True, slots=True)
class FusionSettings:
    """Settings of :class:`CameraImuFusion`.

    ``attitude``: the IMU filter's noise model. ``visual_std_deg``: std of one frame-to-frame visual rotation,
    per axis (the fast estimator on simulated walks: ~0.01 deg). ``visual_gate``: chi-square threshold (3 dof)
    beyond which a visual increment is down-weighted; ``visual_outlier_deg``: a frame-to-frame disagreement with
    the gyroscope larger than this rejects the increment.
    ``camera_from_imu``: rotation taking IMU axes to camera axes (row-major 3x3; identity when the IMU is the
    camera's, as in the simulator). ``time_offset_s``: added to IMU timestamps to put them on the video clock.
    """

    attitude: AttitudeSettings = DEFAULT_ATTITUDE_SETTINGS
    visual_std_deg: float = 0.02
    visual_gate: float = _GATE_3DOF
    visual_outlier_deg: float = 1.0
    camera_from_imu: tuple[float, ...] = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    time_offset_s: float = 0.0

    def __post_init__(self) -> None:
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
    every video frame, in time order (IMU times in the IMU clock; the offset is applied here). ``reset()``."""

    def __init__(self, settings: FusionSettings = DEFAULT_FUSION_SETTINGS) -> None:
        self.settings = settings
        self._filter = ImuAttitudeFilter(settings.attitude, n_clones=1)
        self._R_ci = settings.camera_from_imu_matrix
        self.reset()

    def reset(
        self,
        *,
        initial_accelerometer_m_s2: ArrayLike | None = None,
        initial_bias_rad_s: ArrayLike | None = None,
        initial_bias_std_rad_s: float | None = None,
        initial_tilt_std_deg: float | None = None,
    ) -> None:
        """Forget everything; the optional initial values are in the IMU's axes (as the samples are)."""
        a0 = None if initial_accelerometer_m_s2 is None else self._R_ci @ np.asarray(initial_accelerometer_m_s2, float)
        b0 = None if initial_bias_rad_s is None else self._R_ci @ np.asarray(initial_bias_rad_s, float)
        self._filter.reset(
            initial_accelerometer_m_s2=a0,
            initial_bias_rad_s=b0,
            initial_bias_std_rad_s=initial_bias_std_rad_s,
            initial_tilt_std_deg=initial_tilt_std_deg,
        )
        self._has_reference = False
        self._last_visual: NDArray[np.float64] | None = None
        self.frames_used = 0
        self.frames_rejected = 0

    @property
    def ready(self) -> bool:
        """True once the IMU has delivered its first samples (frames before that cannot be estimated)."""
        return self._filter.down_world is not None

    def push_imu(self, t_s: float, gyroscope_rad_s: ArrayLike, accelerometer_m_s2: ArrayLike) -> None:
        gyro = self._R_ci @ np.asarray(gyroscope_rad_s, dtype=float)
        accel = self._R_ci @ np.asarray(accelerometer_m_s2, dtype=float)
        f = self._filter
        if f.advance_to(t_s + self.settings.time_offset_s, gyro) is None:
            f.correct(gyro, accel)
        elif f.down_world is None:
            f.correct(gyro, accel)

    def _visual_update(self, residual: NDArray[np.float64], H: NDArray[np.float64]) -> bool:
        """Robust update: reject increments off by more than ``visual_outlier_deg``; beyond the chi-square
        gate, inflate the measurement noise so the normalised innovation sits at the gate (Huber-like), so an
        estimator noisier than ``visual_std_deg`` is down-weighted instead of thrown away."""
        s = self.settings
        if np.degrees(np.linalg.norm(residual)) > s.visual_outlier_deg:
            return False
        f = self._filter
        R = np.eye(3) * np.radians(s.visual_std_deg) ** 2
        S = H @ f.kf.P @ H.T + R
        d2 = float(residual @ np.linalg.solve(S, residual))
        if d2 > s.visual_gate:
            R = R * (d2 / s.visual_gate)
        return f.update(residual, H, R)

    def push_frame(self, t_s: float, visual_rotation: ArrayLike | None = None, ok: bool = True) -> FusedEstimate:
        """Propagate to the frame time and use its visual orientation (start-relative, as the rotation
        estimator reports it) when ``ok``; ``None`` means IMU only."""
        f = self._filter
        if f.t_s is None:
            msg = "push_frame before any IMU sample: the fusion needs IMU data up to the frame time"
            raise InvalidInputError(msg)
        if t_s > f.t_s:
            f.advance_to(t_s)
        used = rejected = False
        if not self._has_reference:
            f.set_reference()
            self._has_reference = True
        if visual_rotation is not None and ok:
            Rv = np.asarray(visual_rotation, dtype=float)
            if self._last_visual is not None:
                dR_vis = self._last_visual.T @ Rv
                dR_pred = f.clones[0].T @ f.rotation_world
                residual = log_so3(dR_pred.T @ dR_vis)
                H = np.zeros((3, f.kf.dim_x))
                H[:, 0:3] = np.eye(3)
                H[:, 6:9] = -dR_pred.T
                used = self._visual_update(residual, H)
                rejected = not used
            f.clone_current(0)
            self._last_visual = Rv
        elif visual_rotation is not None:
            rejected = True
            self._last_visual = None  # the chain is broken: the next good frame only re-anchors
        self.frames_used += used
        self.frames_rejected += rejected
        R = f.reference.T @ f.rotation_world
        down = f.down_world if f.down_world is not None else np.array([0.0, 1.0, 0.0])
        g = f.rotation_world.T @ down
        return FusedEstimate(
            t_s=float(t_s),
            rotation=R,
            angles_deg=angles_deg_from_rotation(R),
            gravity_down=g,
            abs_angles_deg=gravity_angles_deg_from_gravity(g),
            gyroscope_bias_rad_s=self._R_ci.T @ f.bias,
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

    Without ``visual_rotations`` this is IMU-only attitude sampled at the given times. The filter starts from
    the IMU's first second (mean gravity; mean gyro as bias when still then). When the recording does not
    start still, a second pass starts from the first pass's final bias estimate. Frames before the first IMU
    sample get the first estimate (angles 0).
    """
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
    rate = (len(t) - 1) / max(t[-1] - t[0], 1e-9)
    settings = replace(settings, attitude=replace(settings.attitude, rate_hz_nominal=float(rate)))
    fusion = CameraImuFusion(settings)
    a0, b0, b0_std, tilt_std = initial_state_from_rest(t, g, a)
    t_video = t + settings.time_offset_s

    def one_pass(
        bias: NDArray[np.float64] | None, bias_std: float | None, accel0: NDArray[np.float64], tilt: float | None
    ) -> list[FusedEstimate]:
        fusion.reset(
            initial_accelerometer_m_s2=accel0, initial_bias_rad_s=bias, initial_bias_std_rad_s=bias_std,
            initial_tilt_std_deg=tilt,
        )
        estimates = []
        i = 0
        for k, tk in enumerate(ft):
            while i < len(t) and t_video[i] <= tk:
                fusion.push_imu(t[i], g[i], a[i])
                i += 1
            if i == 0:  # frame before the first IMU sample
                fusion.push_imu(t[0], g[0], a[0])
                i = 1
            estimates.append(fusion.push_frame(max(tk, t_video[0]), None if Rv is None else Rv[k], bool(ok[k])))
        return estimates

    estimates = one_pass(b0, b0_std, a0, tilt_std)
    if b0 is None:
        # No still period at the start: the bias is only learnt while moving and the first second's mean
        # acceleration is a poor gravity reference, so the first seconds would keep both errors. Offline we can
        # do better: a second pass starts from the first pass's final bias estimate (with its uncertainty) and
        # from gravity as the mean specific force over the whole recording rotated into the first frame with
        # the first pass's orientations (walking accelerations average out over the recording).
        final_std = float(np.sqrt(np.max(np.diag(fusion._filter.kf.P)[3:6])))
        R_ci = settings.camera_from_imu_matrix
        idx = np.clip(np.searchsorted(t_video, ft), 0, len(t) - 1)
        rel = np.array([e.rotation for e in estimates])
        mean_f0 = np.einsum("nij,nj->i", rel, a[idx] @ R_ci.T) / len(ft)
        a0_second = R_ci.T @ mean_f0
        estimates = one_pass(np.asarray(estimates[-1].gyroscope_bias_rad_s), max(final_std, 1e-4), a0_second, 0.5)
        _log.info("no still start: second pass from the first pass's bias (std %.4f deg/s)", np.degrees(final_std))
    return FusionTrack(
        t_s=ft.copy(),
        angles_deg=np.array([e.angles_deg for e in estimates]),
        abs_angles_deg=np.array([e.abs_angles_deg for e in estimates]),
        gravity_down=np.array([e.gravity_down for e in estimates]),
        visual_used=np.array([e.visual_used for e in estimates]),
        gyroscope_bias_rad_s=np.array([e.gyroscope_bias_rad_s for e in estimates]),
        frames_rejected=fusion.frames_rejected,
        method="imu" if Rv is None else "fused",
    )
