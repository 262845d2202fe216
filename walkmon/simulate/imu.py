"""A MEMS IMU rigidly attached to the simulated camera: gyroscope and accelerometer in the camera frame.

The sensor axes are the camera axes (x right, y down, z forward). The gyroscope measures the body rate
(``dR/dt = R skew(w)``) in rad/s; the accelerometer measures specific force ``R^T (a_world - g_world)`` in m/s²
with gravity ``g_world = (0, +9.81, 0)`` (the world y axis points down), so at rest it reads ay = -9.81.
Samples are on the video clock: sample k at ``t = k / rate_hz``, frame i at ``t = i / fps``.

The error model is a real MEMS part's (:class:`ImuSettings`, model version :data:`IMU_MODEL_VERSION`):

* **interval-mean sampling**: like a real IMU (internal sampling at kHz, digital low-pass, decimation), sample k
  reports the *mean* rate and specific force over the interval ``(t_k - 1/rate, t_k]``, not the value at
  ``t_k`` (integrate it with the backward rule: ``R_k = R_{k-1} Exp(w_k dt)``);
* **scale and misalignment**: per-axis scale-factor errors and cross-axis coupling (a fixed 3x3 matrix
  ``I + E`` per sensor and seed), gyroscope and accelerometer;
* **bias**: a constant turn-on bias per seed plus, for the gyroscope, a random walk (bias instability);
* **vibration**: while walking, footstep vibration on both sensors (a few sinusoids between 25 and 80 Hz,
  seen through the interval mean like everything else);
* white noise.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from walkmon.consts import GRAVITY_MS2
from walkmon.errors import ConfigError
from walkmon.simulate.gait import GaitModel

__all__ = ["DEFAULT_IMU_SETTINGS", "IMU_MODEL_VERSION", "ImuSamples", "ImuSettings", "simulate_imu", "simulate_static_poses"]


#: Version of the IMU error model: part of the simulator's parameters, so benchmark caches keyed on it are
#: regenerated when it changes (2: interval means, scale/misalignment, bias random walk, vibration).
IMU_MODEL_VERSION = 2


@dataclass(frozen=True, slots=True)
class ImuSettings:
    """Error model of the simulated IMU: a consumer MEMS part (BMI088 / ICM-42688 / LSM6DSO class); the
    datasheet orders of magnitude are given per parameter (Bosch BMI088 datasheet BST-BMI088-DS001, TDK
    ICM-42688-P datasheet DS-000347).

    ``gyroscope_noise_dps`` / ``accelerometer_noise_mps2``: per-sample white noise std at ``rate_hz`` (0.1 deg/s
    at 200 Hz = 0.01 deg/s/sqrt(Hz); datasheets: 0.004-0.014 deg/s/sqrt(Hz); 0.02 m/s² = 140 ug/sqrt(Hz),
    datasheets 70-190 ug/sqrt(Hz)).
    ``gyroscope_bias_min_dps`` .. ``gyroscope_bias_max_dps``: turn-on bias per axis, uniform in magnitude with a
    random sign (datasheets: zero-rate offset +-0.5 to +-1 deg/s). ``gyroscope_bias_walk_dps_sqrt_s``: random
    walk of the bias (bias instability / rate random walk; 0.001 deg/s/sqrt(s) moves it ~0.004 deg/s in
    16 s and ~0.06 deg/s in an hour, the order of consumer parts' 2-10 deg/h in-run stability plus temperature drift).
    ``accelerometer_bias_mps2``: std of the per-axis offset (0.03 m/s² = 3 mg: a part after a user calibration;
    raw datasheet offsets are up to +-20-40 mg, see ``walkmon calibrate-imu``).
    ``gyroscope_scale_std`` / ``accelerometer_scale_std``: std of the per-axis scale-factor error (datasheets:
    sensitivity tolerance +-0.5 to +-1 %). ``gyroscope_misalignment_std_rad`` / ``accelerometer_misalignment_std_rad``:
    std of each off-diagonal coupling term (cross-axis sensitivity +-1-2 %, i.e. ~0.5-1 deg of axis error).
    ``vibration_accelerometer_mps2`` / ``vibration_gyroscope_dps``: rms footstep vibration while walking (25-80
    Hz; body-worn sensors see 0.1-0.5 m/s² there), 0 outside walking.
    ``interval_mean``: True (default, real IMUs) = samples are interval means; False = instantaneous values at
    the sample times (the model before version 2).
    """

    rate_hz: float = 200.0
    gyroscope_noise_dps: float = 0.1
    gyroscope_bias_min_dps: float = 0.3
    gyroscope_bias_max_dps: float = 0.7
    gyroscope_bias_walk_dps_sqrt_s: float = 0.001
    gyroscope_scale_std: float = 0.005
    gyroscope_misalignment_std_rad: float = 0.005
    accelerometer_noise_mps2: float = 0.02
    accelerometer_bias_mps2: float = 0.03
    accelerometer_scale_std: float = 0.005
    accelerometer_misalignment_std_rad: float = 0.005
    vibration_accelerometer_mps2: float = 0.2
    vibration_gyroscope_dps: float = 0.2
    interval_mean: bool = True

    def __post_init__(self) -> None:
        if not (np.isfinite(self.rate_hz) and 1.0 <= self.rate_hz <= 10000.0):
            msg = f"IMU rate must be in [1, 10000] Hz, got {self.rate_hz}"
            raise ConfigError(msg)
        values = [getattr(self, name) for name in self.__slots__ if name not in ("rate_hz", "interval_mean")]  # type: ignore[attr-defined]
        bad_range = self.gyroscope_bias_min_dps > self.gyroscope_bias_max_dps
        if any(not np.isfinite(v) or v < 0 for v in values) or bad_range:
            msg = f"IMU noise and bias settings must be finite, >= 0 and min <= max: {self}"
            raise ConfigError(msg)

    def to_dict(self) -> dict[str, float]:
        return {"model_version": IMU_MODEL_VERSION, **asdict(self)}


DEFAULT_IMU_SETTINGS = ImuSettings()


@dataclass(frozen=True, slots=True)
class ImuSamples:
    """Simulated IMU data: times (N,), gyroscope (N,3) rad/s, accelerometer (N,3) m/s², and the true errors:
    the gyroscope's turn-on bias (3,) and its bias over time (N,3, with the random walk), the accelerometer's
    bias (3,), and the two sensors' scale/misalignment matrices (3,3): ``measured = M @ true + bias + ...``."""

    t_s: NDArray[np.float64]
    gyroscope_rps: NDArray[np.float64]
    accelerometer_mps2: NDArray[np.float64]
    gyroscope_bias_rps: NDArray[np.float64]
    accelerometer_bias_mps2: NDArray[np.float64]
    gyroscope_bias_track_rps: NDArray[np.float64] | None = None
    gyroscope_matrix: NDArray[np.float64] | None = None
    accelerometer_matrix: NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        for name in self.__slots__:  # type: ignore[attr-defined]
            value = getattr(self, name)
            if value is None:
                continue
            arr = np.array(value, dtype=float)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    def columns(self) -> dict[str, NDArray[np.float64]]:
        """``{t, gx, gy, gz, ax, ay, az}`` as imu.csv stores them."""
        g, a = self.gyroscope_rps, self.accelerometer_mps2
        return {"t": self.t_s, "gx": g[:, 0], "gy": g[:, 1], "gz": g[:, 2], "ax": a[:, 0], "ay": a[:, 1], "az": a[:, 2]}


def ideal_specific_force_mps2(model: GaitModel, t_s: NDArray[np.float64]) -> NDArray[np.float64]:
    """Noise-free accelerometer reading ``R^T (a_world - g_world)`` in the camera frame, shape (N, 3)."""
    R = model.rotation(t_s)
    a = model.acceleration_mps2(t_s) - np.array([0.0, GRAVITY_MS2, 0.0])
    return np.einsum("nji,nj->ni", R, a)


#: sub-samples per interval for the interval means (midpoint rule; the gait's content is below 10 Hz)
_SUBSAMPLES = 8


def _interval_means(fn, t: NDArray[np.float64], dt: float) -> NDArray[np.float64]:  # type: ignore[no-untyped-def]
    """Mean of ``fn`` (times -> (N,3)) over ``(t_k - dt, t_k]`` for each k (times before 0 clamp to 0)."""
    offsets = (np.arange(_SUBSAMPLES) + 0.5) / _SUBSAMPLES * dt - dt
    ts = np.maximum(t[:, None] + offsets[None, :], 0.0).reshape(-1)
    return fn(ts).reshape(len(t), _SUBSAMPLES, 3).mean(axis=1)


def _error_matrix(rng: np.random.Generator, scale_std: float, misalignment_std: float) -> NDArray[np.float64]:
    """``I + diag(scale errors) + off-diagonal couplings``."""
    M = np.eye(3) + np.diag(rng.normal(0.0, scale_std, 3))
    off = rng.normal(0.0, misalignment_std, (3, 3))
    np.fill_diagonal(off, 0.0)
    return M + off


def _vibration(rng: np.random.Generator, t: NDArray[np.float64], dt: float, rms: float, interval_mean: bool) -> NDArray[np.float64]:
    """Three sinusoids per axis between 25 and 80 Hz with ``rms`` in total, (interval-)sampled at ``t``."""
    f = rng.uniform(25.0, 80.0, (3, 3))
    phase = rng.uniform(0.0, 2.0 * np.pi, (3, 3))
    amp = rms * np.sqrt(2.0 / 3.0)
    w = 2.0 * np.pi * f  # (axis, component)
    arg = w[None] * t[:, None, None] + phase[None]
    if interval_mean:  # mean of sin over (t - dt, t]
        vib = (np.cos(arg - w[None] * dt) - np.cos(arg)) / (w[None] * dt)
    else:
        vib = np.sin(arg)
    return amp * vib.sum(axis=2)


def simulate_imu(model: GaitModel, settings: ImuSettings = DEFAULT_IMU_SETTINGS, seed: int | None = None) -> ImuSamples:
    """IMU samples over the whole session at ``settings.rate_hz``, seeded by ``seed`` (default: the model's)."""
    rng = np.random.default_rng([model.seed if seed is None else seed, 0x1A0])
    n = int(np.floor(model.duration_s * settings.rate_hz + 1e-9))
    dt = 1.0 / settings.rate_hz
    t: NDArray[np.float64] = np.arange(n, dtype=np.float64) * dt
    sign = rng.choice([-1.0, 1.0], size=3)
    gyro_bias = np.radians(sign * rng.uniform(settings.gyroscope_bias_min_dps, settings.gyroscope_bias_max_dps, 3))
    accel_bias = rng.normal(0.0, settings.accelerometer_bias_mps2, 3)
    gyro_noise = rng.normal(0.0, np.radians(settings.gyroscope_noise_dps), (n, 3))
    accel_noise = rng.normal(0.0, settings.accelerometer_noise_mps2, (n, 3))
    # errors added in version 2 draw from their own stream, so the bias and noise above stay those of version 1
    rng2 = np.random.default_rng([model.seed if seed is None else seed, 0x1A2])
    walk = np.cumsum(rng2.normal(0.0, np.radians(settings.gyroscope_bias_walk_dps_sqrt_s) * np.sqrt(dt), (n, 3)), axis=0)
    bias_track = gyro_bias + walk
    Mg = _error_matrix(rng2, settings.gyroscope_scale_std, settings.gyroscope_misalignment_std_rad)
    Ma = _error_matrix(rng2, settings.accelerometer_scale_std, settings.accelerometer_misalignment_std_rad)
    walking = (~model.is_standing(t)).astype(float)[:, None]
    vib_g = np.radians(_vibration(rng2, t, dt, settings.vibration_gyroscope_dps, settings.interval_mean)) * walking
    vib_a = _vibration(rng2, t, dt, settings.vibration_accelerometer_mps2, settings.interval_mean) * walking
    if settings.interval_mean:
        rate = _interval_means(model.angular_velocity_rps, t, dt)
        force = _interval_means(lambda ts: ideal_specific_force_mps2(model, ts), t, dt)
    else:
        rate = model.angular_velocity_rps(t)
        force = ideal_specific_force_mps2(model, t)
    gyro = rate @ Mg.T + bias_track + vib_g + gyro_noise
    accel = force @ Ma.T + accel_bias + vib_a + accel_noise
    return ImuSamples(t, gyro, accel, gyro_bias, accel_bias, bias_track, Mg, Ma)


def simulate_static_poses(
    rotations: ArrayLike,
    settings: ImuSettings = DEFAULT_IMU_SETTINGS,
    *,
    seed: int = 0,
    hold_s: float = 3.0,
    move_s: float = 1.5,
    accelerometer_matrix: ArrayLike | None = None,
    accelerometer_bias_mps2: ArrayLike | None = None,
) -> ImuSamples:
    """An IMU put down still in each orientation of ``rotations`` (K,3,3; sensor -> world, world y down) for
    ``hold_s``, turned between them about one axis over ``move_s`` (the accelerometer calibration's recording).
    The accelerometer's bias and scale/misalignment matrix are drawn as in :func:`simulate_imu` unless given
    (e.g. a simulated walk's, to calibrate that walk's sensor); gyro bias, noise as there; no vibration."""
    R = np.asarray(rotations, dtype=float).reshape(-1, 3, 3)
    rng = np.random.default_rng([seed, 0x1A5])
    dt = 1.0 / settings.rate_hz
    Ma = (_error_matrix(rng, settings.accelerometer_scale_std, settings.accelerometer_misalignment_std_rad)
          if accelerometer_matrix is None else np.asarray(accelerometer_matrix, dtype=float))
    ba = rng.normal(0.0, settings.accelerometer_bias_mps2, 3) if accelerometer_bias_mps2 is None \
        else np.asarray(accelerometer_bias_mps2, dtype=float)
    sign = rng.choice([-1.0, 1.0], size=3)
    bg = np.radians(sign * rng.uniform(settings.gyroscope_bias_min_dps, settings.gyroscope_bias_max_dps, 3))
    rot, rate = [], []
    for k in range(len(R)):
        n_hold = int(round(hold_s / dt))
        rot += [R[k]] * n_hold
        rate += [np.zeros(3)] * n_hold
        if k + 1 < len(R):
            v = _log_so3(R[k].T @ R[k + 1])  # body-frame rotation vector to the next pose
            n_move = max(1, int(round(move_s / dt)))
            for j in range(1, n_move + 1):
                rot.append(R[k] @ _exp_so3(v * j / n_move))
                rate.append(v / move_s)
    rot_arr, rate_arr = np.array(rot), np.array(rate)
    n = len(rot_arr)
    force = np.einsum("nji,j->ni", rot_arr, [0.0, -GRAVITY_MS2, 0.0])  # R^T (0 - g_world)
    gyro = rate_arr + bg + rng.normal(0.0, np.radians(settings.gyroscope_noise_dps), (n, 3))
    accel = force @ Ma.T + ba + rng.normal(0.0, settings.accelerometer_noise_mps2, (n, 3))
    return ImuSamples(np.arange(n, dtype=np.float64) * dt, gyro, accel, bg, ba, None, None, Ma)


def _exp_so3(v: NDArray[np.float64]) -> NDArray[np.float64]:
    th = float(np.linalg.norm(v))
    K = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    if th < 1e-12:
        return np.eye(3) + K
    return np.eye(3) + np.sin(th) / th * K + (1.0 - np.cos(th)) / th**2 * (K @ K)


def _log_so3(R: NDArray[np.float64]) -> NDArray[np.float64]:
    c = np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)
    th = float(np.arccos(c))
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if th < 1e-9:
        return 0.5 * w
    if np.pi - th < 1e-6:  # half turn: rotate about an axis from the symmetric part
        axis = np.sqrt(np.clip((np.diag(R) + 1.0) / 2.0, 0.0, None))
        return th * axis / np.linalg.norm(axis)
    return th / (2.0 * np.sin(th)) * w
