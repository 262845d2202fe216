"""Accelerometer calibration from static poses (the "6-pose" procedure), no I/O.

Why: the gravity-referenced ``pitch_abs``/``roll_abs`` read gravity's direction from the accelerometer, so its
offset and scale/misalignment errors go straight into them (a 0.03 m/s² offset is ~0.2 deg; a datasheet's raw
+-20 mg offset is ~1 deg). The gyroscope and the fusion cannot see these errors: they must be calibrated.

Procedure (``walkmon calibrate-imu``): record the IMU (imu.csv) while it is put down still in at least six
orientations, e.g. each axis pointing up and then down, holding each for 2 s or more (a box edge or a table
corner helps; the poses need not be exact). Model: ``measured = M @ true + bias`` with ``M = I + diag(scale) +
S`` (``S``: symmetric cross-axis terms, only with ``misalignment=True``, which needs nine or more
orientations; gravity's magnitude cannot see a rotation of the whole sensor frame, so the antisymmetric part
of a real part's cross-axis coupling stays, as a small mounting rotation for the IMU-camera extrinsics); at rest the true specific force has the magnitude of gravity, so each still pose gives one
equation ``|M^-1 (a - bias)| = g``, solved by nonlinear least squares. The still poses are found
automatically (gyro and accelerometer steady for ``min_still_s``), poses closer than 20 deg are merged.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from walkmon.consts import GRAVITY_MS2
from walkmon.errors import InvalidInputError
from walkmon.sampling import sampling_rate_hz

__all__ = ["AccelerometerCalibration", "calibrate_accelerometer", "still_poses"]

#: poses whose gravity directions are closer than this are one pose
_MERGE_DEG = 20.0


@dataclass(frozen=True, slots=True)
class AccelerometerCalibration:
    """``measured = matrix @ true + bias_m_s2``; :meth:`correct` inverts it. ``residual_m_s2``: RMS of
    ``|corrected| - g`` over the poses (a sanity figure: sensor noise and imperfect stillness), ``n_poses`` the
    orientations used, ``misalignment``: whether the cross-axis terms were estimated."""

    bias_m_s2: tuple[float, float, float]
    matrix: tuple[float, ...]
    residual_m_s2: float
    n_poses: int
    misalignment: bool

    @property
    def matrix_3x3(self) -> NDArray[np.float64]:
        return np.asarray(self.matrix, dtype=float).reshape(3, 3)

    def correct(self, accelerometer_m_s2: ArrayLike) -> NDArray[np.float64]:
        """The true specific force of measured samples ((3,) or (N,3))."""
        a = np.asarray(accelerometer_m_s2, dtype=float)
        return np.linalg.solve(self.matrix_3x3, (a - np.asarray(self.bias_m_s2)).T).T

    def to_dict(self) -> dict[str, object]:
        return {"model": "measured = matrix @ true + bias", "bias_m_s2": list(self.bias_m_s2),
                "matrix": np.asarray(self.matrix).reshape(3, 3).round(8).tolist(), "residual_m_s2": self.residual_m_s2,
                "n_poses": self.n_poses, "misalignment": self.misalignment}

    @classmethod
    def from_dict(cls, data: dict[str, object]) -> AccelerometerCalibration:
        """From :meth:`to_dict`'s output (e.g. a calibrate-imu JSON file); InvalidInputError when malformed."""
        try:
            bias = np.asarray(data["bias_m_s2"], dtype=float).reshape(3)
            M = np.asarray(data["matrix"], dtype=float).reshape(3, 3)
        except (KeyError, TypeError, ValueError) as exc:
            msg = f"not an accelerometer calibration (needs bias_m_s2 [3] and matrix [3x3]): {exc}"
            raise InvalidInputError(msg) from None
        if not (np.all(np.isfinite(bias)) and np.all(np.isfinite(M))) or np.abs(bias).max() > 5.0 \
                or np.abs(M - np.eye(3)).max() > 0.2:
            msg = "accelerometer calibration out of range (|bias| <= 5 m/s2, matrix within 0.2 of identity)"
            raise InvalidInputError(msg)
        residual = data.get("residual_m_s2", np.nan)
        n_poses = data.get("n_poses", 0)
        return cls((float(bias[0]), float(bias[1]), float(bias[2])), tuple(float(v) for v in M.ravel()),
                   float(residual) if isinstance(residual, (int, float)) else float("nan"),
                   int(n_poses) if isinstance(n_poses, int) else 0, bool(data.get("misalignment", False)))


def still_poses(
    t_s: ArrayLike, gyroscope_rad_s: ArrayLike, accelerometer_m_s2: ArrayLike, *, min_still_s: float = 1.5,
    gyro_threshold_dps: float = 2.0, accel_threshold_m_s2: float = 0.15,
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Mean accelerometer (K,3) and sample count (K,) of each still orientation: stretches of ``min_still_s``
    or more where gyro and accelerometer stay within the thresholds of their 0.5 s moving mean (0.25 s trimmed
    at both ends); stretches in the same orientation (within 20 deg) are merged."""
    t = np.asarray(t_s, dtype=float).reshape(-1)
    g = np.asarray(gyroscope_rad_s, dtype=float)
    a = np.asarray(accelerometer_m_s2, dtype=float)
    if g.shape != (len(t), 3) or a.shape != (len(t), 3) or len(t) < 10:
        msg = f"IMU arrays must be t (N>=10,), gyro (N,3), accel (N,3); got {t.shape}, {g.shape}, {a.shape}"
        raise InvalidInputError(msg)
    rate = sampling_rate_hz(t)
    from scipy.ndimage import uniform_filter1d  # noqa: PLC0415

    w = max(3, int(round(0.5 * rate)))
    dg = np.degrees(np.linalg.norm(g - uniform_filter1d(g, w, axis=0, mode="nearest"), axis=1))
    da = np.linalg.norm(a - uniform_filter1d(a, w, axis=0, mode="nearest"), axis=1)
    still = uniform_filter1d(((dg < gyro_threshold_dps) & (da < accel_threshold_m_s2)).astype(float), w, mode="nearest") > 0.999
    trim = int(round(0.25 * rate))
    means: list[NDArray[np.float64]] = []
    counts: list[int] = []
    edges = np.flatnonzero(np.diff(np.r_[0, still.astype(int), 0]))
    for i0, i1 in zip(edges[::2], edges[1::2], strict=True):
        i0, i1 = i0 + trim, i1 - trim
        if i1 <= i0 or t[i1 - 1] - t[i0] < min_still_s - 2 * trim / rate:
            continue
        m = a[i0:i1].mean(axis=0)
        for k, other in enumerate(means):  # the same orientation again: merge
            cos = float(m @ other) / (np.linalg.norm(m) * np.linalg.norm(other))
            if cos > np.cos(np.radians(_MERGE_DEG)):
                n = counts[k] + (i1 - i0)
                means[k] = (other * counts[k] + m * (i1 - i0)) / n
                counts[k] = n
                break
        else:
            means.append(m)
            counts.append(i1 - i0)
    return np.array(means).reshape(-1, 3), np.array(counts, dtype=np.int64)


def calibrate_accelerometer(
    t_s: ArrayLike, gyroscope_rad_s: ArrayLike, accelerometer_m_s2: ArrayLike, *, misalignment: bool | None = None,
    min_still_s: float = 1.5, gravity_m_s2: float = GRAVITY_MS2,
) -> AccelerometerCalibration:
    """Accelerometer bias and scale (and, with ``misalignment``, cross-axis terms) from a recording of still
    poses (module docstring); ``misalignment`` None: estimated when there are nine orientations or more.
    InvalidInputError (one line) when the poses cannot determine them. Not observable from gravity alone: a
    rotation of the whole sensor frame (the mounting), which the IMU-camera extrinsics carry."""
    poses, counts = still_poses(t_s, gyroscope_rad_s, accelerometer_m_s2, min_still_s=min_still_s)
    if misalignment is None:
        misalignment = len(poses) >= 9
    needed = 9 if misalignment else 6
    if len(poses) < needed:
        msg = (f"found {len(poses)} still orientation(s); the calibration needs at least {needed}: hold the IMU "
               f"still for {min_still_s:g} s or more in each of {needed} orientations (each axis up and down)")
        raise InvalidInputError(msg)
    unit = poses / np.linalg.norm(poses, axis=1, keepdims=True)
    for axis in range(3):
        if unit[:, axis].max() < 0.5 or unit[:, axis].min() > -0.5:
            name = "xyz"[axis]
            msg = f"the still poses never point the {name} axis both up and down (needed to separate its offset from its scale)"
            raise InvalidInputError(msg)
    from scipy.optimize import least_squares  # noqa: PLC0415

    low = np.tril_indices(3, -1)
    weights = np.sqrt(counts / counts.max())

    def matrix(p: NDArray[np.float64]) -> NDArray[np.float64]:
        M = np.eye(3) + np.diag(p[3:6])
        if misalignment:  # symmetric: the cross-axis terms without a rotation of the frame (not observable)
            M[low] += p[6:9]
            M[low[1], low[0]] += p[6:9]
        return M

    def residuals(p: NDArray[np.float64]) -> NDArray[np.float64]:
        true = np.linalg.solve(matrix(p), (poses - p[0:3]).T).T
        return weights * (np.linalg.norm(true, axis=1) - gravity_m_s2)

    fit = least_squares(residuals, np.zeros(9 if misalignment else 6), method="lm")
    M = matrix(fit.x)
    J = np.asarray(fit.jac, dtype=float)
    if np.linalg.matrix_rank(J, tol=1e-6 * max(1.0, float(np.abs(J).max()))) < J.shape[1]:
        msg = "the still poses do not determine the calibration (too similar orientations): add more varied ones"
        raise InvalidInputError(msg)
    true = np.linalg.solve(M, (poses - fit.x[0:3]).T).T
    resid = float(np.sqrt(np.mean((np.linalg.norm(true, axis=1) - gravity_m_s2) ** 2)))
    return AccelerometerCalibration(
        bias_m_s2=tuple(float(v) for v in fit.x[0:3]),  # type: ignore[arg-type]
        matrix=tuple(float(v) for v in M.ravel()), residual_m_s2=resid, n_poses=len(poses), misalignment=misalignment,
    )
