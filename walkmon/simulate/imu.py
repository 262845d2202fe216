"""A MEMS IMU rigidly attached to the simulated camera: gyroscope and accelerometer in the camera frame.

The sensor axes are the camera axes (x right, y down, z forward). The gyroscope measures the body rate
(``dR/dt = R skew(w)``) in rad/s; the accelerometer measures specific force ``R^T (a_world - g_world)`` in m/s²
with gravity ``g_world = (0, +9.81, 0)`` (the world y axis points down), so at rest it reads ay = -9.81.
Both come from the gait model's exact spline derivatives, plus a constant per-seed bias and white noise.
Samples are on the video clock: sample k at ``t = k / rate_hz``, frame i at ``t = i / fps``.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import NDArray

from walkmon.consts import GRAVITY_MS2
from walkmon.errors import ConfigError
from walkmon.simulate.gait import GaitModel

__all__ = ["DEFAULT_IMU_SETTINGS", "ImuSamples", "ImuSettings", "simulate_imu"]


@dataclass(frozen=True, slots=True)
class ImuSettings:
    """Noise and bias of the simulated IMU (roughly a consumer MEMS part, e.g. BMI088 / ICM-42688 class).

    ``gyroscope_noise_dps`` and ``accelerometer_noise_mps2`` are per-sample standard deviations of white noise
    at ``rate_hz``; the per-axis biases are drawn once per seed: gyroscope uniformly ±(0.3..0.7) °/s,
    accelerometer normal with ``accelerometer_bias_mps2`` standard deviation.
    """

    rate_hz: float = 200.0
    gyroscope_noise_dps: float = 0.1
    gyroscope_bias_min_dps: float = 0.3
    gyroscope_bias_max_dps: float = 0.7
    accelerometer_noise_mps2: float = 0.02
    accelerometer_bias_mps2: float = 0.03

    def __post_init__(self) -> None:
        if not (np.isfinite(self.rate_hz) and 1.0 <= self.rate_hz <= 10000.0):
            msg = f"IMU rate must be in [1, 10000] Hz, got {self.rate_hz}"
            raise ConfigError(msg)
        values = (
            self.gyroscope_noise_dps,
            self.gyroscope_bias_min_dps,
            self.gyroscope_bias_max_dps,
            self.accelerometer_noise_mps2,
            self.accelerometer_bias_mps2,
        )
        bad_range = self.gyroscope_bias_min_dps > self.gyroscope_bias_max_dps
        if any(not np.isfinite(v) or v < 0 for v in values) or bad_range:
            msg = f"IMU noise and bias settings must be finite, >= 0 and min <= max: {self}"
            raise ConfigError(msg)

    def to_dict(self) -> dict[str, float]:
        return asdict(self)


DEFAULT_IMU_SETTINGS = ImuSettings()


@dataclass(frozen=True, slots=True)
class ImuSamples:
    """Simulated IMU data: times (N,), gyroscope (N,3) rad/s, accelerometer (N,3) m/s², and the true biases."""

    t_s: NDArray[np.float64]
    gyroscope_rps: NDArray[np.float64]
    accelerometer_mps2: NDArray[np.float64]
    gyroscope_bias_rps: NDArray[np.float64]
    accelerometer_bias_mps2: NDArray[np.float64]

    def __post_init__(self) -> None:
        for name in ("t_s", "gyroscope_rps", "accelerometer_mps2", "gyroscope_bias_rps", "accelerometer_bias_mps2"):
            arr = np.array(getattr(self, name), dtype=float)
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


def simulate_imu(model: GaitModel, settings: ImuSettings = DEFAULT_IMU_SETTINGS, seed: int | None = None) -> ImuSamples:
    """IMU samples over the whole session at ``settings.rate_hz``, seeded by ``seed`` (default: the model's)."""
    rng = np.random.default_rng([model.seed if seed is None else seed, 0x1A0])
    n = int(np.floor(model.duration_s * settings.rate_hz + 1e-9))
    t = np.arange(n) / settings.rate_hz
    sign = rng.choice([-1.0, 1.0], size=3)
    gyro_bias = np.radians(sign * rng.uniform(settings.gyroscope_bias_min_dps, settings.gyroscope_bias_max_dps, 3))
    accel_bias = rng.normal(0.0, settings.accelerometer_bias_mps2, 3)
    gyro = model.angular_velocity_rps(t) + gyro_bias + rng.normal(0.0, np.radians(settings.gyroscope_noise_dps), (n, 3))
    accel_noise = rng.normal(0.0, settings.accelerometer_noise_mps2, (n, 3))
    accel = ideal_specific_force_mps2(model, t) + accel_bias + accel_noise
    return ImuSamples(t, gyro, accel, gyro_bias, accel_bias)
