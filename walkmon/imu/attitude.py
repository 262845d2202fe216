"""IMU attitude: an error-state Kalman filter (filterpy) on orientation and gyroscope bias.

The nominal state is the orientation ``R`` (sensor directions -> world; world = the sensor frame at the first
sample, with gravity's measured direction ``down_world``) and the gyroscope bias ``b``. The error state
``[dtheta (3, sensor frame), db (3)]`` lives in a :class:`filterpy.kalman.KalmanFilter`; after each update the
error is injected into the nominal state and reset to zero.

* **Predict** with every gyroscope sample: ``R <- R Exp((w - b) dt)``.
* **Gravity update** from the accelerometer direction, ``a/|a| ~ -R^T down_world``, skipped while the wearer
  accelerates hard (``| |a| - g |`` above ``acceleration_rejection_m_s2``) and weak while moving, so the
  periodic accelerations of walking average out instead of tilting the estimate.
* **Rest update**: while the sensor is still (gyro and accelerometer steady for ``rest_min_s``), the gyroscope
  reads its bias: a zero-rate measurement that pins ``b`` on all three axes (including the vertical one that
  gravity cannot see).

Outputs per sample (:class:`AttitudeEstimate`): the orientation, start-relative angles (pitch, yaw, roll of
:mod:`walkmon.consts`), gravity's direction in the sensor frame and the gravity-referenced
``pitch_abs, roll_abs``. :func:`estimate_attitude` runs the filter over a whole recording, initialised from its
first still period.
"""

from __future__ import annotations

import enum
import logging
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from walkmon.consts import (
    GRAVITY_MS2,
    angles_deg_from_rotation,
    gravity_angles_deg_from_gravity,
    skew,
)
from walkmon.errors import ConfigError, InvalidInputError
from walkmon.sampling import sampling_rate_hz

__all__ = [
    "DEFAULT_ATTITUDE_SETTINGS",
    "DEFAULT_IMU_FILTER",
    "GYROSCOPE_RULES",
    "HANDHELD_ATTITUDE_SETTINGS",
    "IMU_FILTERS",
    "WALKING_ATTITUDE_SETTINGS",
    "AttitudeCore",
    "AttitudeEstimate",
    "AttitudeSettings",
    "AttitudeStatus",
    "AttitudeTrack",
    "ErrorStateLayout",
    "EskfCore",
    "ImuAttitudeFilter",
    "ImuFilterSettings",
    "SmoothedAttitude",
    "VisualWindows",
    "VqfCore",
    "estimate_attitude",
    "exp_so3",
    "initial_state_from_rest",
    "log_so3",
    "make_core",
    "rotation_from_quaternion_wxyz",
    "smooth_attitude",
    "track_attitude",
]

_log = logging.getLogger(__name__)

#: Chi-square 99.9 % quantile with 3 degrees of freedom: measurements further out are rejected as outliers.
_GATE_3DOF = 16.27

#: Meanings of a gyroscope sample (:attr:`AttitudeSettings.gyroscope_rule`).
GYROSCOPE_RULES = ("trapezoid", "backward")


# ------------------------------------------------------------------------------------------------- SO(3)
def exp_so3(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation matrix of the rotation vector ``v`` (radians), Rodrigues' formula."""
    theta = float(np.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]))
    K = skew(v)
    if theta < 1e-8:
        return np.eye(3) + K + 0.5 * (K @ K)
    return np.eye(3) + (np.sin(theta) / theta) * K + ((1.0 - np.cos(theta)) / (theta * theta)) * (K @ K)


def log_so3(R: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation vector (radians) of the rotation matrix ``R``."""
    c = np.clip((np.trace(R) - 1.0) * 0.5, -1.0, 1.0)
    theta = float(np.arccos(c))
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if theta < 1e-6:
        return 0.5 * w
    if np.pi - theta < 1e-4:  # near pi: take the axis from the symmetric part
        axis = np.sqrt(np.clip((np.diag(R) + 1.0) * 0.5, 0.0, None))
        axis *= np.sign(w) + (w == 0)
        return theta * axis / np.linalg.norm(axis)
    return (theta / (2.0 * np.sin(theta))) * w


# --------------------------------------------------------------------------------------------- settings
@dataclass(frozen=True, slots=True)
class AttitudeSettings:
    """Noise model and gating of :class:`ImuAttitudeFilter` (defaults suit consumer MEMS IMUs at 100-400 Hz).

    ``gyroscope_noise_rad_s_sqrt_hz``: angle random walk (white rate noise density).
    ``gyroscope_bias_walk_rad_s_sqrt_s``: how fast the gyroscope bias may wander.
    ``gyroscope_scale_error``: relative scale-factor / misalignment error of the gyroscope, modelled as extra
    rate noise proportional to the rate (fast rotations make the filter lean more on gravity).
    ``initial_bias_std_rad_s`` / ``initial_tilt_std_deg``: prior uncertainty when the filter starts.
    ``gravity_std_rest`` / ``gravity_std_moving``: std of the accelerometer *direction* (unit vector, ~radians)
    per sample, at rest and while moving; ``gravity_std_per_m_s2`` adds to the moving value in proportion to
    the recent peak of ``| |a| - g |`` (a 0.5 s decaying envelope), so the accelerations of walking average out
    while slow hand-held motion keeps a firm gravity reference.
    ``acceleration_rejection_m_s2``: no gravity update when ``| |a| - g |`` exceeds this.
    ``rest_gyroscope_deg_s`` / ``rest_accelerometer_m_s2`` / ``rest_min_s``: rest detection thresholds on the
    deviation from a 0.2 s low-pass, held for ``rest_min_s``; once the bias is known, the low-passed rate minus
    the bias must also stay below ``rest_rate_deg_s`` (so the slow start of a movement is not taken for rest);
    ``rest_rate_std_rad_s``: per-sample std of the zero-rate update at rest.
    ``gravity_lowpass_s``: when > 0, gravity updates (while moving) use the accelerometer low-passed over this
    many seconds in the world frame, at ``gravity_update_hz`` with std ``gravity_std_lowpass`` (VQF's idea; see
    :data:`HANDHELD_ATTITUDE_SETTINGS`); 0 (default, best for walking) = per-sample updates as above.
    ``rate_hz_nominal``: the IMU rate (set from the data by the offline functions).
    ``gyroscope_rule``: what a gyroscope sample means, a property of the sensor: ``"backward"`` (default) for
    the mean rate over the interval ending at the sample (what real MEMS IMUs report, the simulator's IMU
    included, and what VQF and imufusion assume: on BROAD's real IMU it cuts the inclination error of fast
    rotations from 1.9 to 1.2 deg); ``"trapezoid"`` for instantaneous rates at the sample time, integrated with
    the trapezoidal rule (the old simulator's samples).
    """

    gyroscope_noise_rad_s_sqrt_hz: float = 3e-4
    gyroscope_bias_walk_rad_s_sqrt_s: float = 5e-5
    gyroscope_scale_error: float = 0.03
    initial_bias_std_rad_s: float = 0.02
    initial_tilt_std_deg: float = 1.0
    gravity_std_rest: float = 0.2
    gravity_std_moving: float = 0.2
    gravity_std_per_m_s2: float = 3.0
    gravity_lowpass_s: float = 0.0
    gravity_update_hz: float = 20.0
    gravity_std_lowpass: float = 0.05
    acceleration_rejection_m_s2: float = 3.0
    rest_gyroscope_deg_s: float = 2.0
    rest_accelerometer_m_s2: float = 0.2
    rest_min_s: float = 1.0
    rest_rate_deg_s: float = 0.2
    rest_rate_std_rad_s: float = 0.005
    rate_hz_nominal: float = 200.0
    gyroscope_rule: str = "backward"

    def __post_init__(self) -> None:
        for name in self.__slots__:  # type: ignore[attr-defined]
            value = getattr(self, name)
            if name == "gyroscope_rule":
                if value not in GYROSCOPE_RULES:
                    msg = f"gyroscope_rule must be one of {', '.join(GYROSCOPE_RULES)}, got {value!r}"
                    raise ConfigError(msg)
                continue
            if name == "gravity_lowpass_s" and value == 0:
                continue  # 0 = per-sample gravity updates
            if not (np.isfinite(value) and value > 0):
                msg = f"attitude setting {name} must be a positive number, got {value!r}"
                raise ConfigError(msg)


DEFAULT_ATTITUDE_SETTINGS = AttitudeSettings()

#: walkmon's filter as it shipped before VQF became the default (``--imu-filter eskf``): gyro samples taken as
#: instantaneous rates (the old simulator's), per-sample gravity updates; diverged on vigorous real motion.
WALKING_ATTITUDE_SETTINGS = AttitudeSettings(gyroscope_rule="trapezoid")

#: For hand-held or general motion (no sustained accelerations) with a real MEMS IMU (``--imu-filter
#: eskf-handheld``): gravity from the accelerometer low-passed over 2 s in the gyro-integrated frame (VQF's idea),
#: a firmer gravity reference (0.02), a faster-wandering bias (2e-4 rad/s/sqrt(s)), 1 % gyro scale error, gyro
#: samples as interval means. Chosen on BROAD trials 02 and 07; on all ten shared trials it beats VQF on seven
#: but loses on the fast translations and tapping (benchmarks/results/broad.md), so it is not the default.
HANDHELD_ATTITUDE_SETTINGS = AttitudeSettings(
    gravity_lowpass_s=2.0,
    gravity_std_lowpass=0.02,
    gyroscope_bias_walk_rad_s_sqrt_s=2e-4,
    gyroscope_scale_error=0.01,
    gyroscope_rule="backward",
)


class AttitudeStatus(enum.Enum):
    """What the filter did with a sample."""

    INITIALISING = "initialising"
    REST = "rest"
    GRAVITY = "gravity"  # moving, gravity update applied
    GYRO_ONLY = "gyro_only"  # accelerating hard: gravity update skipped


@dataclass(frozen=True, slots=True)
class AttitudeEstimate:
    """The filter's estimate after one sample.

    ``rotation``: sensor -> start frame (orientation relative to the reference, conventions of
    :mod:`walkmon.consts`); ``angles_deg``: its (pitch, yaw, roll); ``gravity_down``: unit gravity direction in
    the sensor frame; ``abs_angles_deg``: (pitch_abs, roll_abs); ``gyroscope_bias_rad_s``: the bias estimate.
    """

    t_s: float
    rotation: NDArray[np.float64]
    angles_deg: NDArray[np.float64]
    gravity_down: NDArray[np.float64]
    abs_angles_deg: NDArray[np.float64]
    gyroscope_bias_rad_s: NDArray[np.float64]
    status: AttitudeStatus

    def __post_init__(self) -> None:
        for name in ("rotation", "angles_deg", "gravity_down", "abs_angles_deg", "gyroscope_bias_rad_s"):
            getattr(self, name).setflags(write=False)


# ------------------------------------------------------------------------------------------------ filter
@dataclass(frozen=True, slots=True)
class ErrorStateLayout:
    """The error state of :class:`ImuAttitudeFilter`: tilt/orientation error (3, sensor frame), gyroscope bias
    (3), ``n_clones`` orientation clones (3 each), then ``n_extra`` additive states."""

    n_clones: int = 0
    n_extra: int = 0

    @property
    def dim(self) -> int:
        return 6 + 3 * self.n_clones + self.n_extra

    @property
    def tilt(self) -> slice:
        return slice(0, 3)

    @property
    def bias(self) -> slice:
        return slice(3, 6)

    def clone(self, index: int) -> slice:
        if not 0 <= index < self.n_clones:
            msg = f"clone index {index} out of range (n_clones={self.n_clones})"
            raise IndexError(msg)
        return slice(6 + 3 * index, 9 + 3 * index)

    @property
    def extra(self) -> slice:
        return slice(6 + 3 * self.n_clones, self.dim)


class _RestDetector:
    """Rest when gyro and accelerometer stay within thresholds of their 0.5 s low-pass for ``rest_min_s``."""

    def __init__(self, settings: AttitudeSettings) -> None:
        self._s = settings
        self.reset()

    def reset(self) -> None:
        self._gyro_lp: NDArray[np.float64] | None = None
        self._accel_lp: NDArray[np.float64] | None = None
        self._still_s = 0.0

    def push(
        self, gyro: NDArray[np.float64], accel: NDArray[np.float64], dt: float, bias: NDArray[np.float64] | None
    ) -> bool:
        """``bias``: the current bias estimate when it is trusted (then the low-passed rate minus the bias must
        be below the threshold too, so the slow start of a movement is not taken for rest)."""
        if self._gyro_lp is None or self._accel_lp is None:
            self._gyro_lp, self._accel_lp = gyro.copy(), accel.copy()
            return False
        k = min(1.0, dt / 0.2)
        self._gyro_lp += k * (gyro - self._gyro_lp)
        self._accel_lp += k * (accel - self._accel_lp)
        dg = gyro - self._gyro_lp
        da = accel - self._accel_lp
        th_g = np.radians(self._s.rest_gyroscope_deg_s)
        still = float(dg @ dg) < th_g * th_g and float(da @ da) < self._s.rest_accelerometer_m_s2**2
        if still and bias is not None:
            db = self._gyro_lp - bias
            still = float(db @ db) < np.radians(self._s.rest_rate_deg_s) ** 2
        if still:
            self._still_s += dt
        else:
            self._still_s = 0.0
        return self._still_s >= self._s.rest_min_s


class ImuAttitudeFilter:
    """Error-state Kalman filter on orientation and gyroscope bias (see the module docstring).

    ``push(t_s, gyroscope_rad_s, accelerometer_m_s2) -> AttitudeEstimate``; ``reset()`` forgets everything.
    ``n_clones`` extra 3-D error blocks (orientation clones) are carried for relative measurements
    (:mod:`walkmon.imu.fusion` uses one); ``n_extra`` additive, constant states after them (``self.extra``, prior
    variance set by the caller in ``kf.P``; the fusion models the visual estimator's drift rate and scale there).
    """

    def __init__(
        self, settings: AttitudeSettings = DEFAULT_ATTITUDE_SETTINGS, *, n_clones: int = 0, n_extra: int = 0
    ) -> None:
        self.settings = settings
        self.n_clones = n_clones
        self.n_extra = n_extra
        self._rest = _RestDetector(settings)
        self.reset()

    # -- state ------------------------------------------------------------------------------------------------
    def reset(
        self,
        *,
        initial_accelerometer_m_s2: ArrayLike | None = None,
        initial_bias_rad_s: ArrayLike | None = None,
        initial_bias_std_rad_s: float | None = None,
        initial_tilt_std_deg: float | None = None,
    ) -> None:
        """Forget everything; optionally start from a known gravity reading and bias (e.g. a still period,
        then ``initial_bias_std_rad_s`` / ``initial_tilt_std_deg`` say how well they are known)."""
        from filterpy.kalman import KalmanFilter  # noqa: PLC0415 - filterpy's import takes ~2 s (scipy.stats)

        s = self.settings
        dim = 6 + 3 * self.n_clones + self.n_extra
        self.kf = KalmanFilter(dim_x=dim, dim_z=3)
        self.kf.x = np.zeros((dim, 1))
        P = np.zeros((dim, dim))
        # Only the tilt is uncertain: the world frame is the sensor frame at the start, so the heading about
        # gravity is zero by definition (an isotropic prior would leak a fake heading error into pitch/roll).
        P[0:3, 0:3] = np.eye(3) * np.radians(s.initial_tilt_std_deg) ** 2
        bias_std = s.initial_bias_std_rad_s if initial_bias_std_rad_s is None else initial_bias_std_rad_s
        P[3:6, 3:6] = np.eye(3) * bias_std**2
        self.kf.P = P
        self.rotation_world = np.eye(3)
        self.clones = [np.eye(3) for _ in range(self.n_clones)]
        self.extra = np.zeros(self.n_extra)
        #: random-walk std per sqrt(s) of each extra state (0 = constant)
        self.extra_walk_per_sqrt_s = np.zeros(self.n_extra)
        self.bias = np.zeros(3) if initial_bias_rad_s is None else np.asarray(initial_bias_rad_s, float).copy()
        self.down_world: NDArray[np.float64] | None = None
        self._tilt_std_deg = s.initial_tilt_std_deg if initial_tilt_std_deg is None else initial_tilt_std_deg
        if initial_accelerometer_m_s2 is not None:
            a = np.asarray(initial_accelerometer_m_s2, dtype=float)
            self._set_down(-a / np.linalg.norm(a))
        self.reference = np.eye(3)
        self.t_s: float | None = None
        self._last_gyro = np.zeros(3)
        self._rate_unknown = False
        self._rest.reset()
        self.at_rest = False
        self._accel_envelope = 0.0
        self._accel_world_lp: NDArray[np.float64] | None = None
        self._rotation_gyro = np.eye(3)  # bias-corrected gyro integration, never corrected by gravity
        self._since_gravity_s = 0.0

    # -- read-only views of the state (callers never index the covariance) --------------------------------
    @property
    def layout(self) -> ErrorStateLayout:
        """Where each block of the error state lives (tilt, bias, clones, extra states)."""
        return ErrorStateLayout(self.n_clones, self.n_extra)

    @property
    def bias_rad_s(self) -> NDArray[np.float64]:
        """The gyroscope bias estimate (rad/s, filter axes; a copy)."""
        return self.bias.copy()

    @property
    def bias_std_rad_s(self) -> float:
        """Uncertainty of the bias estimate: the largest per-axis standard deviation (rad/s)."""
        return float(np.sqrt(np.max(np.diag(self.kf.P)[3:6])))

    @property
    def gravity_down(self) -> NDArray[np.float64] | None:
        """Gravity's direction in the sensor frame now (unit vector), None before the first accelerometer."""
        if self.down_world is None:
            return None
        return self.rotation_world.T @ self.down_world

    @property
    def extra_std(self) -> NDArray[np.float64]:
        """Standard deviations of the extra states (``n_extra``)."""
        return np.sqrt(np.diag(self.kf.P)[self.layout.extra])

    def set_extra_prior(self, std: ArrayLike, walk_per_sqrt_s: ArrayLike) -> None:
        """Prior std of the extra states (uncorrelated with the rest) and their random walk per sqrt(s)."""
        sl = self.layout.extra
        std = np.asarray(std, dtype=float).reshape(-1)
        if std.shape != (self.n_extra,):
            msg = f"set_extra_prior needs {self.n_extra} values, got {std.shape}"
            raise InvalidInputError(msg)
        P = self.kf.P
        P[sl, :] = 0.0
        P[:, sl] = 0.0
        P[sl, sl] = np.diag(std**2)
        self.extra = np.zeros(self.n_extra)
        self.extra_walk_per_sqrt_s = np.asarray(walk_per_sqrt_s, dtype=float).reshape(self.n_extra).copy()

    def _set_down(self, down: NDArray[np.float64]) -> None:
        """Fix gravity's direction in the world frame and drop the prior's heading part (about gravity)."""
        self.down_world = down
        tilt_var = np.radians(self._tilt_std_deg) ** 2
        self.kf.P[0:3, 0:3] = tilt_var * (np.eye(3) - np.outer(down, down)) + 1e-12 * np.outer(down, down)

    # -- predict / update ---------------------------------------------------------------------------------------
    def propagate(self, gyroscope_rad_s: NDArray[np.float64], dt: float) -> None:
        """Advance the nominal state and the error covariance by ``dt`` seconds with one gyro reading."""
        if dt <= 0:
            return
        s = self.settings
        w = gyroscope_rad_s - self.bias
        dR = exp_so3(w * dt)
        self.rotation_world = self.rotation_world @ dR
        self._rotation_gyro = self._rotation_gyro @ dR
        dim = self.kf.dim_x
        F = np.eye(dim)
        F[0:3, 0:3] = dR.T
        F[0:3, 3:6] = -np.eye(3) * dt
        Q = np.zeros((dim, dim))
        rate2 = float(w @ w)
        Q[0:3, 0:3] = np.eye(3) * (s.gyroscope_noise_rad_s_sqrt_hz**2 * dt + s.gyroscope_scale_error**2 * rate2 * dt * dt)
        Q[3:6, 3:6] = np.eye(3) * (s.gyroscope_bias_walk_rad_s_sqrt_s**2 * dt)
        if self.n_extra:
            k = 6 + 3 * self.n_clones
            Q[k:, k:] = np.diag(self.extra_walk_per_sqrt_s**2 * dt)
        P = self.kf.P
        self.kf.P = F @ P @ F.T + Q

    def normalised_innovation(self, residual: NDArray[np.float64], H: NDArray[np.float64], R: NDArray[np.float64]) -> float:
        """Squared Mahalanobis distance of a residual under the predicted innovation covariance ``H P H^T + R``."""
        S = H @ self.kf.P @ H.T + R
        return float(residual @ np.linalg.solve(S, residual))

    def update(self, residual: NDArray[np.float64], H: NDArray[np.float64], R: NDArray[np.float64], gate: float | None = None) -> bool:
        """Kalman update with the error-state residual; inject and reset. Returns False when gated out."""
        P = self.kf.P
        S = H @ P @ H.T + R
        if gate is not None:
            try:
                d2 = float(residual @ np.linalg.solve(S, residual))
            except np.linalg.LinAlgError:
                return False
            if d2 > gate:
                return False
        self.kf.update(residual.reshape(-1, 1), R=R, H=H)
        dx = self.kf.x[:, 0].copy()
        self.kf.x[:] = 0.0
        self.rotation_world = self.rotation_world @ exp_so3(dx[0:3])
        self.bias = self.bias + dx[3:6]
        for i in range(self.n_clones):
            self.clones[i] = self.clones[i] @ exp_so3(dx[6 + 3 * i : 9 + 3 * i])
        if self.n_extra:
            self.extra = self.extra + dx[6 + 3 * self.n_clones :]
        return True

    def rotate_by(self, rotation: NDArray[np.float64], std_rad: float, t_s: float) -> None:
        """Turn the nominal orientation by ``rotation`` (a body-frame rotation measured otherwise: the camera's
        between two frames while no gyroscope sample arrives), its error growing by ``std_rad`` per axis, and
        move the clock to ``t_s`` without propagating the gyroscope over the time between."""
        # the nearest rotation (polar decomposition): a product such as R.T @ R_start @ turn is a rotation only to
        # rounding, and taken as given each frame its error grew threefold per frame (NaN within 30 frames)
        r = np.asarray(rotation, dtype=float)
        u, _, vt = np.linalg.svd(r if np.all(np.isfinite(r)) else np.eye(3))  # not finite: held
        dR = u @ np.diag([1.0, 1.0, float(np.sign(np.linalg.det(u @ vt)))]) @ vt
        self._rate_unknown = True  # the rate before the gap is not the rate after it (advance_to)
        self.rotation_world = self.rotation_world @ dR
        self._rotation_gyro = self._rotation_gyro @ dR
        P = self.kf.P
        P[0:3, :] = dR.T @ P[0:3, :]
        P[:, 0:3] = P[:, 0:3] @ dR
        P[0:3, 0:3] += np.eye(3) * std_rad**2
        if self.t_s is None or t_s > self.t_s:
            self.t_s = float(t_s)

    def clone_current(self, index: int = 0) -> None:
        """Copy the current orientation (and its covariance) into clone ``index``."""
        k = 6 + 3 * index
        P = self.kf.P
        P[k : k + 3, :] = P[0:3, :]
        P[:, k : k + 3] = P[:, 0:3]
        self.clones[index] = self.rotation_world.copy()

    def push(self, t_s: float, gyroscope_rad_s: ArrayLike, accelerometer_m_s2: ArrayLike) -> AttitudeEstimate:
        """One IMU sample: propagate from the previous sample's time with the previous gyro reading, then
        correct with this sample's accelerometer (and zero rate at rest)."""
        gyro = np.asarray(gyroscope_rad_s, dtype=float)
        accel = np.asarray(accelerometer_m_s2, dtype=float)
        status = self.advance_to(t_s, gyro)
        if status is None:
            status = self.correct(gyro, accel)
        return self.estimate(status)

    def advance_to(self, t_s: float, gyro: NDArray[np.float64] | None = None) -> AttitudeStatus | None:
        """Propagate to ``t_s``: with the mean of the last and this gyro reading when ``gyro`` is given (then
        remember it), else with the last reading (a frame time between two IMU samples); after
        :meth:`rotate_by`, with this reading alone."""
        status = None
        if gyro is not None and self._rate_unknown:
            self._last_gyro, self._rate_unknown = np.asarray(gyro, dtype=float), False
        if self.t_s is None:
            self.t_s = t_s
            status = AttitudeStatus.INITIALISING
        else:
            dt = t_s - self.t_s
            if dt < 0:
                msg = f"IMU time went backwards: {t_s} after {self.t_s}"
                raise InvalidInputError(msg)
            # trapezoidal rule between samples; a frame time between samples extrapolates the last rate
            if gyro is None:
                rate = self._last_gyro
            elif self.settings.gyroscope_rule == "backward":
                rate = gyro
            else:
                rate = 0.5 * (self._last_gyro + gyro)
            self.propagate(rate, dt)
            self.t_s = t_s
        if gyro is not None:
            self._last_gyro = gyro
        return status

    def zero_rate_update(self, gyro: NDArray[np.float64]) -> bool:
        """At rest: the gyroscope reads its bias (a gated zero-rate measurement on all three axes)."""
        H = np.zeros((3, self.kf.dim_x))
        H[:, 3:6] = np.eye(3)
        return self.update(gyro - self.bias, H, np.eye(3) * self.settings.rest_rate_std_rad_s**2, gate=_GATE_3DOF)

    def gravity_update(self, measured_down: ArrayLike, std: float, gate: float | None = _GATE_3DOF) -> bool:
        """Gravity's direction in the sensor frame measured (unit vector, e.g. from an attitude core), with
        ``std`` (~radians) per axis; gated (chi-square, 3 dof) unless ``gate`` is None. False when gated out."""
        assert self.down_world is not None
        h0 = self.rotation_world.T @ self.down_world
        H = np.zeros((3, self.kf.dim_x))
        H[:, 0:3] = skew(h0)
        m = np.asarray(measured_down, dtype=float)
        return self.update(m / np.linalg.norm(m) - h0, H, np.eye(3) * std**2, gate=gate)

    def align_to_gravity(self, measured_down: ArrayLike, tilt_std_deg: float) -> None:
        """Reset the tilt: rotate the orientation by the smallest rotation that makes its gravity direction
        ``measured_down`` (sensor frame), keeping the heading; the tilt covariance restarts at ``tilt_std_deg``
        and its correlations with the other states are dropped (the recovery after a long rejection)."""
        assert self.down_world is not None
        m = np.asarray(measured_down, dtype=float)
        m = m / np.linalg.norm(m)
        h0 = self.rotation_world.T @ self.down_world
        axis = np.cross(m, h0)  # R Exp(phi): new gravity Exp(phi)^T h0 = m
        s_, c_ = float(np.linalg.norm(axis)), float(np.clip(h0 @ m, -1.0, 1.0))
        if s_ > 1e-12:
            self.rotation_world = self.rotation_world @ exp_so3(axis / s_ * np.arctan2(s_, c_))
        P = self.kf.P
        sl = self.layout.tilt
        P[sl, :] = 0.0
        P[:, sl] = 0.0
        down = self.rotation_world.T @ self.down_world
        tilt_var = np.radians(tilt_std_deg) ** 2
        P[sl, sl] = tilt_var * (np.eye(3) - np.outer(down, down)) + 1e-8 * np.outer(down, down)

    def correct(self, gyro: NDArray[np.float64], accel: NDArray[np.float64]) -> AttitudeStatus:
        s = self.settings
        norm = float(np.linalg.norm(accel))
        if self.down_world is None:
            if norm < 1e-6:
                return AttitudeStatus.INITIALISING
            self._set_down(-accel / norm)
            return AttitudeStatus.INITIALISING
        dt = 1.0 / s.rate_hz_nominal
        bias_std = self.bias_std_rad_s
        trusted = self.bias if bias_std < 0.1 * np.radians(s.rest_gyroscope_deg_s) else None
        self.at_rest = self._rest.push(gyro, accel, dt, trusted)
        status = AttitudeStatus.GRAVITY
        if self.at_rest and self.zero_rate_update(gyro):
            status = AttitudeStatus.REST
        if s.gravity_lowpass_s > 0 and not self.at_rest:
            return self._lowpass_gravity_update(accel, dt)
        if abs(norm - GRAVITY_MS2) > s.acceleration_rejection_m_s2 or norm < 1e-6:
            return AttitudeStatus.GYRO_ONLY
        h0 = -self.rotation_world.T @ self.down_world
        H = np.zeros((3, self.kf.dim_x))
        H[:, 0:3] = skew(h0)
        self._accel_envelope = max(abs(norm - GRAVITY_MS2), self._accel_envelope * np.exp(-dt / 0.5))
        std = s.gravity_std_rest if self.at_rest else s.gravity_std_moving + s.gravity_std_per_m_s2 * self._accel_envelope
        self.update(accel / norm - h0, H, np.eye(3) * std**2)
        return status

    def _lowpass_gravity_update(self, accel: NDArray[np.float64], dt: float) -> AttitudeStatus:
        """Gravity from the accelerometer low-passed in the world frame (``gravity_lowpass_s``), as VQF does:
        the accelerations of walking or hand motion average out over the low-pass window, while gravity, fixed
        in the world, stays. Updates at ``gravity_update_hz``; residual in the world frame."""
        s = self.settings
        assert self.down_world is not None
        # low-pass in the gyro-integrated (almost inertial) frame, which gravity corrections never rotate, so
        # the filter's own corrections do not leak into the low-pass state (VQF's design)
        a_world = self._rotation_gyro @ accel
        if self._accel_world_lp is None:
            self._accel_world_lp = a_world.copy()
        else:
            self._accel_world_lp += min(1.0, dt / s.gravity_lowpass_s) * (a_world - self._accel_world_lp)
        self._since_gravity_s += dt
        if self._since_gravity_s < 1.0 / s.gravity_update_hz:
            return AttitudeStatus.GYRO_ONLY
        self._since_gravity_s = 0.0
        lp = self._accel_world_lp
        norm = float(np.linalg.norm(lp))
        if norm < 1e-6 or abs(norm - GRAVITY_MS2) > s.acceleration_rejection_m_s2:
            return AttitudeStatus.GYRO_ONLY
        measured_down = -(self._rotation_gyro.T @ lp) / norm  # gravity's direction in the sensor frame now
        h0 = self.rotation_world.T @ self.down_world
        H = np.zeros((3, self.kf.dim_x))
        H[:, 0:3] = skew(h0)
        self.update(measured_down - h0, H, np.eye(3) * s.gravity_std_lowpass**2)
        return AttitudeStatus.GRAVITY

    def set_reference(self) -> None:
        """Make the current orientation the start-relative reference (angles 0, 0, 0 now)."""
        self.reference = self.rotation_world.copy()

    def estimate(self, status: AttitudeStatus) -> AttitudeEstimate:
        R = self.reference.T @ self.rotation_world
        down = self.down_world if self.down_world is not None else np.array([0.0, 1.0, 0.0])
        g = self.rotation_world.T @ down
        return AttitudeEstimate(
            t_s=float(self.t_s if self.t_s is not None else 0.0),
            rotation=R,
            angles_deg=angles_deg_from_rotation(R),
            gravity_down=g,
            abs_angles_deg=gravity_angles_deg_from_gravity(g),
            gyroscope_bias_rad_s=self.bias.copy(),
            status=status,
        )


# ---------------------------------------------------------------------------------- IMU attitude cores
#: IMU attitude filters (``--imu-filter`` and the live config's ``[imu] filter``): ``vqf`` (default) is VQF
#: (Laidig & Seel 2023, the ``vqf`` package, 6-D, online); ``eskf`` and ``eskf-handheld`` are walkmon's own
#: error-state filter with its walking defaults and its hand-held preset (kept for comparison).
IMU_FILTERS = ("vqf", "eskf", "eskf-handheld")


@dataclass(frozen=True, slots=True)
class ImuFilterSettings:
    """The IMU attitude core: which filter and its knobs.

    ``filter``: one of :data:`IMU_FILTERS`. Default ``vqf``: on all ten shared BROAD trials (real IMU, optical
    truth; rotation, translation, tapping, vibration) it is never worse than walkmon's own filter with any one
    setting, which diverged on vigorous combined motion (benchmarks/results/broad.md).
    ``tau_acc_s`` (vqf): time constant of its accelerometer low-pass in the inertial frame (VQF's 3 s default):
    longer = less tilt from sustained accelerations (the start and stop of walking), slower to correct gyro
    errors. ``rest_min_s`` (vqf): how long the sensor must be still before its rest bias estimation starts (VQF's
    1.5 s). Both defaults are VQF's own: no value was tuned on the benchmark trials.
    """

    filter: str = "vqf"
    tau_acc_s: float = 3.0
    rest_min_s: float = 1.5

    def __post_init__(self) -> None:
        if self.filter not in IMU_FILTERS:
            msg = f"unknown IMU filter {self.filter!r}; expected one of {', '.join(IMU_FILTERS)}"
            raise ConfigError(msg)
        for name in ("tau_acc_s", "rest_min_s"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and np.isfinite(value) and 0 < value <= 100):
                msg = f"IMU filter setting {name} must be in (0, 100] s, got {value!r}"
                raise ConfigError(msg)


DEFAULT_IMU_FILTER = ImuFilterSettings()


class AttitudeCore:
    """Common face of the IMU attitude cores: ``push(t_s, gyro, accel)`` per sample (in time order, at the
    nominal rate given at construction); read-only ``rotation_world`` (sensor -> a gravity-aligned world),
    ``gravity_down`` (unit, sensor frame), ``bias_rad_s``, ``bias_std_rad_s``, ``at_rest``."""

    rotation_world: NDArray[np.float64]
    gravity_down: NDArray[np.float64]
    bias_rad_s: NDArray[np.float64]
    bias_std_rad_s: float
    at_rest: bool

    def push(self, t_s: float, gyroscope_rad_s: NDArray[np.float64], accelerometer_m_s2: NDArray[np.float64]) -> None:
        raise NotImplementedError


class VqfCore(AttitudeCore):
    """VQF (6-D: gyroscope + accelerometer, no magnetometer) as the attitude core; needs the ``vqf`` package.
    VQF takes each gyroscope sample as the mean rate over the sample interval, as real MEMS IMUs report it."""

    def __init__(self, settings: ImuFilterSettings, rate_hz: float) -> None:
        try:
            import vqf  # noqa: PLC0415
        except ImportError as exc:  # pragma: no cover - vqf is a core dependency
            msg = "the vqf IMU filter needs the vqf package: pip install vqf"
            raise ConfigError(msg) from exc
        if not (np.isfinite(rate_hz) and rate_hz > 0):
            msg = f"IMU rate must be positive, got {rate_hz}"
            raise InvalidInputError(msg)
        self._vqf = vqf.VQF(1.0 / float(rate_hz), tauAcc=float(settings.tau_acc_s), restMinT=float(settings.rest_min_s))
        self.rotation_world = np.eye(3)
        self.gravity_down = np.array([0.0, 0.0, -1.0])
        self.bias_rad_s = np.zeros(3)
        self.bias_std_rad_s = float(np.radians(0.5))
        self.at_rest = False

    def push(self, t_s: float, gyroscope_rad_s: NDArray[np.float64], accelerometer_m_s2: NDArray[np.float64]) -> None:
        v = self._vqf
        v.update(np.ascontiguousarray(gyroscope_rad_s, dtype=float), np.ascontiguousarray(accelerometer_m_s2, dtype=float))
        R = rotation_from_quaternion_wxyz(v.getQuat6D())
        self.rotation_world = R
        self.gravity_down = -R[2, :]  # R^T (0, 0, -1): VQF's world z points up
        bias, sigma = v.getBiasEstimate()
        self.bias_rad_s = np.asarray(bias, dtype=float)
        self.bias_std_rad_s = float(sigma)
        self.at_rest = bool(v.getRestDetected())


class EskfCore(AttitudeCore):
    """walkmon's own :class:`ImuAttitudeFilter` as the attitude core (``eskf``: walking defaults with gyro
    samples as instantaneous rates, as the filter shipped before; ``eskf-handheld``: the hand-held preset)."""

    def __init__(self, settings: ImuFilterSettings, rate_hz: float, *, initial_accelerometer_m_s2: ArrayLike | None = None,
                 initial_bias_rad_s: ArrayLike | None = None, initial_bias_std_rad_s: float | None = None,
                 initial_tilt_std_deg: float | None = None) -> None:
        base = HANDHELD_ATTITUDE_SETTINGS if settings.filter == "eskf-handheld" else WALKING_ATTITUDE_SETTINGS
        self._filter = ImuAttitudeFilter(_with_rate(base, rate_hz))
        self._filter.reset(initial_accelerometer_m_s2=initial_accelerometer_m_s2, initial_bias_rad_s=initial_bias_rad_s,
                           initial_bias_std_rad_s=initial_bias_std_rad_s, initial_tilt_std_deg=initial_tilt_std_deg)
        self.rotation_world = np.eye(3)
        self.gravity_down = np.array([0.0, 1.0, 0.0])
        self.bias_rad_s = self._filter.bias_rad_s
        self.bias_std_rad_s = self._filter.bias_std_rad_s
        self.at_rest = False

    def push(self, t_s: float, gyroscope_rad_s: NDArray[np.float64], accelerometer_m_s2: NDArray[np.float64]) -> None:
        f = self._filter
        f.push(t_s, gyroscope_rad_s, accelerometer_m_s2)
        self.rotation_world = f.rotation_world
        down = f.gravity_down
        if down is not None:
            self.gravity_down = down
        self.bias_rad_s = f.bias_rad_s
        self.bias_std_rad_s = f.bias_std_rad_s
        self.at_rest = f.at_rest


def make_core(settings: ImuFilterSettings, rate_hz: float, **eskf_start: object) -> AttitudeCore:
    """The attitude core of ``settings.filter`` for an IMU at ``rate_hz``; ``eskf_start`` (the initial state of
    :meth:`ImuAttitudeFilter.reset`) only seeds walkmon's own filter: VQF starts as VQF does."""
    if settings.filter == "vqf":
        return VqfCore(settings, rate_hz)
    return EskfCore(settings, rate_hz, **eskf_start)  # type: ignore[arg-type]


def rotation_from_quaternion_wxyz(q: ArrayLike) -> NDArray[np.float64]:
    """Rotation matrix of one unit quaternion (w, x, y, z)."""
    w, x, y, z = (float(v) for v in np.asarray(q, dtype=float).reshape(4))
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def track_attitude(
    t_s: ArrayLike,
    gyroscope_rad_s: ArrayLike,
    accelerometer_m_s2: ArrayLike,
    settings: ImuFilterSettings = DEFAULT_IMU_FILTER,
) -> AttitudeTrack:
    """IMU-only attitude of a recording with the attitude core (default VQF), causal, sample by sample as the
    live path runs it; angles relative to the first sample. walkmon's own filters start from the recording's
    still start (:func:`initial_state_from_rest`); VQF starts as VQF does."""
    t, g, a = _check_imu_arrays(t_s, gyroscope_rad_s, accelerometer_m_s2)
    rate = sampling_rate_hz(t)  # gaps left out: VQF takes every sample as 1 / rate after the last
    start: dict[str, object] = {}
    if settings.filter != "vqf":
        a0, b0, b0_std, tilt_std = initial_state_from_rest(t, g, a)
        start = {"initial_accelerometer_m_s2": a0, "initial_bias_rad_s": b0, "initial_bias_std_rad_s": b0_std,
                 "initial_tilt_std_deg": tilt_std}
    core = make_core(settings, rate, **start)
    n = len(t)
    rotations = np.empty((n, 3, 3))
    down = np.empty((n, 3))
    bias = np.empty((n, 3))
    for i in range(n):
        core.push(float(t[i]), g[i], a[i])
        rotations[i], down[i], bias[i] = core.rotation_world, core.gravity_down, core.bias_rad_s
    rel = np.einsum("ji,njk->nik", rotations[0], rotations)
    return AttitudeTrack(
        t_s=t.copy(), angles_deg=angles_deg_from_rotation(rel), rotations=rel, gravity_down=down,
        abs_angles_deg=gravity_angles_deg_from_gravity(down), gyroscope_bias_rad_s=bias,
    )


# -------------------------------------------------------------------------------------------- offline
def initial_state_from_rest(
    t_s: NDArray[np.float64],
    gyro: NDArray[np.float64],
    accel: NDArray[np.float64],
    window_s: float = 1.0,
    max_window_s: float = 5.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64] | None, float | None, float | None]:
    """Mean accelerometer over the first ``window_s`` and, when the sensor was still then, the mean gyro as
    the initial bias (both over the whole still start, up to ``max_window_s``), with the bias and tilt uncertainties (rad/s, deg; all None when it moved: the filter then
    learns the bias itself and starts from the settings' priors)."""
    n = max(2, int(np.searchsorted(t_s, t_s[0] + window_s)))
    a0 = accel[:n].mean(axis=0)
    g_dev = np.degrees(np.abs(gyro[:n] - gyro[:n].mean(axis=0))).max()
    still = g_dev < 3.0 and np.abs(np.linalg.norm(accel[:n], axis=1) - np.linalg.norm(a0)).max() < 0.6
    if not still:
        return a0, None, None, None
    # extend over the whole still start (up to max_window_s) in 0.25 s blocks whose mean gyro and accelerometer
    # stay at the first window's: a 2 s still start halves the bias error of a 1 s window (the zero-rate
    # updates at rest only start after rest_min_s)
    g0 = gyro[:n].mean(axis=0)
    while t_s[n - 1] - t_s[0] < max_window_s:
        m = int(np.searchsorted(t_s, t_s[n - 1] + 0.25))
        if m >= len(t_s) or m - n < 5:
            break
        if np.degrees(np.abs(gyro[n:m].mean(axis=0) - g0)).max() > 0.05 or np.abs(accel[n:m].mean(axis=0) - a0).max() > 0.03:
            break
        n = m
        g0 = gyro[:n].mean(axis=0)
    a0 = accel[:n].mean(axis=0)
    std = float(np.max(gyro[:n].std(axis=0)) / np.sqrt(n))
    tilt_std_deg = float(np.degrees(np.max(accel[:n].std(axis=0)) / np.linalg.norm(a0) / np.sqrt(n)))
    return a0, gyro[:n].mean(axis=0), max(2.0 * std, 5e-5), max(2.0 * tilt_std_deg, 0.05)


@dataclass(frozen=True, slots=True)
class AttitudeTrack:
    """A whole recording's estimates: times (N,), start-relative angles (N,3) pitch,yaw,roll deg, rotations
    (N,3,3), gravity direction (N,3), (pitch_abs, roll_abs) (N,2) deg, gyroscope bias (N,3) rad/s."""

    t_s: NDArray[np.float64]
    angles_deg: NDArray[np.float64]
    rotations: NDArray[np.float64]
    gravity_down: NDArray[np.float64]
    abs_angles_deg: NDArray[np.float64]
    gyroscope_bias_rad_s: NDArray[np.float64]

    def __post_init__(self) -> None:
        for name in self.__slots__:  # type: ignore[attr-defined]
            getattr(self, name).setflags(write=False)


def _check_imu_arrays(t_s: ArrayLike, gyro: ArrayLike, accel: ArrayLike) -> tuple[NDArray[np.float64], ...]:
    t = np.asarray(t_s, dtype=float).reshape(-1)
    g = np.asarray(gyro, dtype=float)
    a = np.asarray(accel, dtype=float)
    if g.shape != (len(t), 3) or a.shape != (len(t), 3):
        msg = f"IMU arrays must be t (N,), gyro (N,3), accel (N,3); got {t.shape}, {g.shape}, {a.shape}"
        raise InvalidInputError(msg)
    if len(t) < 2:
        msg = "IMU recording needs at least 2 samples"
        raise InvalidInputError(msg)
    return t, g, a


def estimate_attitude(
    t_s: ArrayLike,
    gyroscope_rad_s: ArrayLike,
    accelerometer_m_s2: ArrayLike,
    settings: AttitudeSettings = DEFAULT_ATTITUDE_SETTINGS,
    *,
    smooth: bool = False,
) -> AttitudeTrack:
    """Run :class:`ImuAttitudeFilter` over a recording (initialised from its first second), angles relative
    to the first sample; ``smooth``: offline forward filter + RTS backward pass (:func:`smooth_attitude`)."""
    t, g, a = _check_imu_arrays(t_s, gyroscope_rad_s, accelerometer_m_s2)
    a0, b0, b0_std, tilt_std = initial_state_from_rest(t, g, a)
    rate = sampling_rate_hz(t)
    if smooth:
        sm = smooth_attitude(
            t, g, a, _with_rate(settings, rate), initial_accelerometer_m_s2=a0, initial_bias_rad_s=b0,
            initial_bias_std_rad_s=b0_std, initial_tilt_std_deg=tilt_std,
        )
        R = np.einsum("ji,njk->nik", sm.rotations_world[0], sm.rotations_world)
        down = np.einsum("nji,j->ni", sm.rotations_world, sm.down_world)
        return AttitudeTrack(
            t_s=t.copy(), angles_deg=angles_deg_from_rotation(R), rotations=R, gravity_down=down,
            abs_angles_deg=gravity_angles_deg_from_gravity(down), gyroscope_bias_rad_s=sm.bias_rad_s.copy(),
        )
    filt = ImuAttitudeFilter(_with_rate(settings, rate))
    filt.reset(
        initial_accelerometer_m_s2=a0, initial_bias_rad_s=b0, initial_bias_std_rad_s=b0_std, initial_tilt_std_deg=tilt_std
    )
    out = []
    for i in range(len(t)):
        out.append(filt.push(t[i], g[i], a[i]))
    return _track(out)


def _with_rate(settings: AttitudeSettings, rate_hz: float) -> AttitudeSettings:
    from dataclasses import replace

    return replace(settings, rate_hz_nominal=float(rate_hz))


def _track(estimates: list[AttitudeEstimate]) -> AttitudeTrack:
    return AttitudeTrack(
        t_s=np.array([e.t_s for e in estimates]),
        angles_deg=np.array([e.angles_deg for e in estimates]),
        rotations=np.array([e.rotation for e in estimates]),
        gravity_down=np.array([e.gravity_down for e in estimates]),
        abs_angles_deg=np.array([e.abs_angles_deg for e in estimates]),
        gyroscope_bias_rad_s=np.array([e.gyroscope_bias_rad_s for e in estimates]),
    )


# ------------------------------------------------------------------------------- offline RTS smoothing
@dataclass(frozen=True, slots=True)
class VisualWindows:
    """Visual rotations for :func:`smooth_attitude`, on the IMU's clock and in the IMU filter's axes.

    ``t_s`` (M,) frame times, ``rotations`` (M,3,3) the estimator's start-relative orientations, ``ok`` (M,)
    frames it measured. The rotation *between* two good frames ``baseline_s`` or more apart measures the
    gyroscope bias over that window (``std_deg`` per axis for the visual part; the gyroscope's own noise over
    the window is added). A window whose disagreement with the gyroscope exceeds ``outlier_deg`` is rejected;
    beyond the chi-square ``gate`` the noise is inflated (Huber-like).
    """

    t_s: NDArray[np.float64]
    rotations: NDArray[np.float64]
    ok: NDArray[np.bool_]
    baseline_s: float = 1.0
    std_deg: float = 0.04
    outlier_deg: float = 1.0
    gate: float = _GATE_3DOF


@dataclass(frozen=True, slots=True)
class SmoothedAttitude:
    """Result of :func:`smooth_attitude`: per IMU sample the smoothed orientation (sensor -> world, (N,3,3)) and
    gyroscope bias (N,3); ``down_world`` gravity's direction in the world frame; per visual frame whether its
    window corrected the filter (``visual_used``) or was refused (``visual_rejected``); ``bias_std_rad_s`` the
    final filtered bias uncertainty (largest axis)."""

    t_s: NDArray[np.float64]
    rotations_world: NDArray[np.float64]
    bias_rad_s: NDArray[np.float64]
    interval_rates_rad_s: NDArray[np.float64]
    down_world: NDArray[np.float64]
    visual_used: NDArray[np.bool_]
    visual_rejected: NDArray[np.bool_]
    bias_std_rad_s: float

    def at(self, times_s: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Orientations (M,3,3) and biases (M,3) at ``times_s``: from the last sample at or before each time,
        propagated with the rate of that sample interval (times before the first sample get it)."""
        tq = np.asarray(times_s, dtype=float).reshape(-1)
        t = self.t_s
        idx = np.clip(np.searchsorted(t, tq, side="right") - 1, 0, len(t) - 1)
        out = np.empty((len(tq), 3, 3))
        for m, (i, tm) in enumerate(zip(idx, tq, strict=True)):
            tau = max(0.0, float(tm - t[i]))
            rate = self.interval_rates_rad_s[i]
            out[m] = self.rotations_world[i] @ exp_so3((rate - self.bias_rad_s[i]) * tau)
        return out, self.bias_rad_s[idx]


def smooth_attitude(
    t_s: NDArray[np.float64],
    gyroscope_rad_s: NDArray[np.float64],
    accelerometer_m_s2: NDArray[np.float64],
    settings: AttitudeSettings = DEFAULT_ATTITUDE_SETTINGS,
    *,
    initial_accelerometer_m_s2: ArrayLike | None = None,
    initial_bias_rad_s: ArrayLike | None = None,
    initial_bias_std_rad_s: float | None = None,
    initial_tilt_std_deg: float | None = None,
    visual: VisualWindows | None = None,
) -> SmoothedAttitude:
    """Offline attitude: the forward :class:`ImuAttitudeFilter` (gravity, rest and, with ``visual``, visual
    bias windows) followed by a Rauch-Tung-Striebel backward pass on the error state.

    The forward filter alone only knows the past; the backward pass carries what is learnt later (the bias
    from a still period at the end or from visual windows, gravity seen later) back to every earlier sample,
    weighted by the filter's own covariances, so the smoothed estimate is never less informed than the
    forward one. Visual windows measure the bias only (``r = log(D^T V) ~ H db``, with ``D`` the bias-corrected
    gyro rotation over the window and ``V`` the visual one): per frame the gyroscope is ~10x more precise than
    the visual increment, over a second the vision's drift is smaller than the gyro bias's effect.
    """
    t, g, a = _check_imu_arrays(t_s, gyroscope_rad_s, accelerometer_m_s2)
    filt = ImuAttitudeFilter(settings)
    filt.reset(
        initial_accelerometer_m_s2=initial_accelerometer_m_s2,
        initial_bias_rad_s=initial_bias_rad_s,
        initial_bias_std_rad_s=initial_bias_std_rad_s,
        initial_tilt_std_deg=initial_tilt_std_deg,
    )
    # rates[i]: the rate over (t_i, t_i+1] as the filter integrates it (last one: extrapolation)
    if settings.gyroscope_rule == "backward":
        rates = np.vstack([g[1:], g[-1:]])
    else:
        rates = np.vstack([0.5 * (g[:-1] + g[1:]), g[-1:]])
    windows = _VisualWindowUpdates(visual, t[0], settings.gyroscope_noise_rad_s_sqrt_hz**2)
    Rf, bf, Rpred, gains = _forward_pass(filt, t, g, a, rates, windows)
    bias_std = filt.bias_std_rad_s
    Rs, bs = _rts_backward(Rf, bf, Rpred, gains)
    down = filt.down_world if filt.down_world is not None else np.array([0.0, 1.0, 0.0])
    return SmoothedAttitude(
        t_s=t, rotations_world=Rs, bias_rad_s=bs, interval_rates_rad_s=rates, down_world=np.asarray(down, float),
        visual_used=windows.used, visual_rejected=windows.rejected & ~windows.used, bias_std_rad_s=bias_std,
    )


def _forward_pass(
    filt: ImuAttitudeFilter, t: NDArray[np.float64], g: NDArray[np.float64], a: NDArray[np.float64],
    rates: NDArray[np.float64], windows: _VisualWindowUpdates,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The forward filter over the recording, keeping what the backward pass needs: filtered orientations and
    biases, predicted orientations and the RTS gains ``P_k F^T P_pred(k+1)^-1`` on the 6-D error state."""
    n = len(t)
    Rf = np.empty((n, 3, 3))
    bf = np.empty((n, 3))
    Rpred = np.empty((n, 3, 3))
    gains = np.zeros((n, 6, 6))
    for i in range(n):
        if i > 0:
            P_prev = filt.kf.P.copy()
            dt = t[i] - t[i - 1]
            dR = exp_so3((rates[i - 1] - filt.bias) * dt)
            status = filt.advance_to(t[i], g[i])
            F = np.eye(6)
            F[0:3, 0:3] = dR.T
            F[0:3, 3:6] = -np.eye(3) * dt
            P_pred = filt.kf.P
            try:
                gains[i - 1] = np.linalg.solve(P_pred, F @ P_prev).T
            except np.linalg.LinAlgError:
                gains[i - 1] = (np.linalg.pinv(P_pred) @ F @ P_prev).T
            Rpred[i] = filt.rotation_world
            windows.advance(dR, dt)
        else:
            status = filt.advance_to(t[0], g[0])
        if status is None or filt.down_world is None:
            filt.correct(g[i], a[i])
        windows.consume(filt, float(t[i]), t[i + 1] if i + 1 < n else np.inf, rates[i])
        Rf[i] = filt.rotation_world
        bf[i] = filt.bias
    return Rf, bf, Rpred, gains


def _rts_backward(
    Rf: NDArray[np.float64], bf: NDArray[np.float64], Rpred: NDArray[np.float64], gains: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Rauch-Tung-Striebel backward pass on the error state about the forward trajectory."""
    Rs = Rf.copy()
    bs = bf.copy()
    for k in range(len(Rf) - 2, -1, -1):
        d = np.concatenate([log_so3(Rpred[k + 1].T @ Rs[k + 1]), bs[k + 1] - bf[k]])
        dx = gains[k] @ d
        Rs[k] = Rf[k] @ exp_so3(dx[0:3])
        bs[k] = bf[k] + dx[3:6]
    return Rs, bs


class _VisualWindowUpdates:
    """The visual bias windows of :func:`smooth_attitude`: a gyro-only chain ``G`` (bias-corrected, no gravity
    corrections) and its bias Jacobian ``J``; the rotation between two good frames ``baseline_s`` apart,
    compared with the chain over the same window, measures the bias. ``used`` / ``rejected`` per frame."""

    def __init__(self, visual: VisualWindows | None, t0_s: float, gyro_var: float) -> None:
        self.visual = visual
        self.G, self.J = np.eye(3), np.zeros((3, 3))
        n_frames = 0 if visual is None else len(visual.t_s)
        self.used = np.zeros(n_frames, bool)
        self.rejected = np.zeros(n_frames, bool)
        if visual is not None:
            self.rejected |= ~np.asarray(visual.ok, bool)
        self.anchor: tuple[int, NDArray[np.float64], NDArray[np.float64]] | None = None
        self.frame = 0
        self.gyro_var = gyro_var
        while visual is not None and self.frame < n_frames and visual.t_s[self.frame] < t0_s:
            self.frame += 1

    def advance(self, dR: NDArray[np.float64], dt: float) -> None:
        self.G = self.G @ dR
        self.J = dR.T @ self.J - np.eye(3) * dt

    def consume(self, filt: ImuAttitudeFilter, t_i: float, t_next: float, rate_i: NDArray[np.float64]) -> None:
        """Visual frames in ``[t_i, t_next)``: anchor, or close a window and update the filter's bias."""
        v = self.visual
        while v is not None and self.frame < len(v.t_s) and v.t_s[self.frame] < t_next:
            frame = self.frame
            self.frame += 1
            if not v.ok[frame]:
                self.anchor = None
                continue
            tau = float(v.t_s[frame] - t_i)
            dRt = exp_so3((rate_i - filt.bias) * tau)
            Gf, Jf = self.G @ dRt, dRt.T @ self.J - np.eye(3) * tau
            if self.anchor is None:
                self.anchor = (frame, Gf, Jf)
            elif v.t_s[frame] - v.t_s[self.anchor[0]] >= v.baseline_s:
                self._window_update(filt, frame, Gf, Jf)
                # re-anchor on the gyro chain as it stands after the update (the bias moved)
                self.anchor = (frame, Gf, Jf)

    def _window_update(self, filt: ImuAttitudeFilter, frame: int, Gf: NDArray[np.float64], Jf: NDArray[np.float64]) -> None:
        v = self.visual
        assert v is not None and self.anchor is not None
        k0, Ga, Ja = self.anchor
        D = Ga.T @ Gf
        r = log_so3(D.T @ (v.rotations[k0].T @ v.rotations[frame]))
        H = np.zeros((3, 6))
        H[:, 3:6] = Jf - D.T @ Ja
        window_s = float(v.t_s[frame] - v.t_s[k0])
        if np.degrees(np.linalg.norm(r)) > v.outlier_deg:
            self.rejected[k0 + 1 : frame + 1] = True
            return
        Rm = np.eye(3) * (np.radians(v.std_deg) ** 2 + self.gyro_var * window_s)
        d2 = filt.normalised_innovation(r, H, Rm)
        if d2 > v.gate:
            Rm = Rm * (d2 / v.gate)
        filt.update(r, H, Rm)
        self.used[k0 : frame + 1] = True
