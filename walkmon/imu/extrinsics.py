"""IMU-to-camera rotation and time offset from a recording, by matching gyroscope and visual rotation rates.

The visual rotation between consecutive good frames gives the camera's mean angular rate over each frame
interval (camera axes); the gyroscope, integrated over the same interval shifted by a candidate offset, gives the
IMU's (IMU axes). The rate *magnitudes* do not depend on the mounting, so the time offset is the shift that
maximises their correlation (1 ms grid, refined with a parabola). With the offset fixed, the rotation is the
least-squares fit of the rate vectors (Wahba's problem, solved by SVD), done twice with outliers (visual
failures) removed after the first pass. The fit's residual (RMS rate disagreement, °/s) says how much to
trust the result: compare it with the visual rate noise (a few °/s for a good estimator at 30 fps), and
``well_conditioned`` says whether the camera turned about at least two axes (otherwise the rotation about the
one excited axis is all the data can tell).

Conventions: ``camera_from_imu`` maps IMU axes to camera axes (``w_camera = R @ w_imu``) and
``time_offset_s`` is added to IMU timestamps to put them on the video clock, as in
:class:`walkmon.imu.fusion.FusionSettings`.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from walkmon.errors import InvalidInputError
from walkmon.imu.attitude import log_so3

__all__ = ["MIN_AXIS_EXCITATION", "ExtrinsicsEstimate", "estimate_extrinsics", "visual_rates_rad_s"]

#: Second-largest over largest singular value of the rate cross-covariance below which the rotation is not
#: determined (the camera turned about essentially one axis): the estimate is then flagged, not trusted.
MIN_AXIS_EXCITATION = 0.1

_log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class ExtrinsicsEstimate:
    """Result of :func:`estimate_extrinsics`.

    ``camera_from_imu`` (3x3), ``time_offset_s`` (add to IMU times), ``residual_deg_s`` (RMS of
    ``w_camera - R w_imu`` over the inlier intervals), ``correlation`` (of the rate magnitudes at the chosen
    offset, 1 = perfect), ``n_intervals`` used, and ``rotation_deg``: the angle of ``camera_from_imu``.
    """

    camera_from_imu: NDArray[np.float64]
    time_offset_s: float
    residual_deg_s: float
    correlation: float
    n_intervals: int
    rotation_deg: float
    axis_excitation: float = 1.0

    @property
    def well_conditioned(self) -> bool:
        """True when the recording rotated about at least two axes enough to fix the rotation."""
        return self.axis_excitation >= MIN_AXIS_EXCITATION and self.correlation >= 0.5

    def __post_init__(self) -> None:
        self.camera_from_imu.setflags(write=False)

    def to_dict(self) -> dict[str, object]:
        return {
            "camera_from_imu": [[round(float(v), 6) for v in row] for row in self.camera_from_imu],
            "time_offset_s": round(self.time_offset_s, 5),
            "residual_deg_s": round(self.residual_deg_s, 4),
            "correlation": round(self.correlation, 4),
            "n_intervals": self.n_intervals,
            "rotation_deg": round(self.rotation_deg, 3),
            "axis_excitation": round(self.axis_excitation, 4),
            "well_conditioned": self.well_conditioned,
        }


def visual_rates_rad_s(
    frame_t_s: NDArray[np.float64], rotations: NDArray[np.float64], ok: NDArray[np.bool_] | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Mean angular rate (camera axes) over each interval between consecutive good frames.

    Returns (interval start times, interval end times, rates (M, 3) rad/s).
    """
    good = np.ones(len(frame_t_s), bool) if ok is None else np.asarray(ok, bool)
    idx = np.flatnonzero(good)
    starts, ends, rates = [], [], []
    for a, b in zip(idx[:-1], idx[1:], strict=True):
        if b != a + 1:
            continue  # only consecutive good frames: a gap may hide a visual failure
        dt = frame_t_s[b] - frame_t_s[a]
        if dt <= 0:
            continue
        starts.append(frame_t_s[a])
        ends.append(frame_t_s[b])
        rates.append(log_so3(rotations[a].T @ rotations[b]) / dt)
    return np.array(starts), np.array(ends), np.array(rates).reshape(-1, 3)


def _mean_gyro(imu_t: NDArray[np.float64], cumulative: NDArray[np.float64], a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    ga = np.stack([np.interp(a, imu_t, cumulative[:, j]) for j in range(3)], axis=1)
    gb = np.stack([np.interp(b, imu_t, cumulative[:, j]) for j in range(3)], axis=1)
    return (gb - ga) / (b - a)[:, None]


def _wahba(v_camera: NDArray[np.float64], v_imu: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation R minimising sum |v_camera - R v_imu|^2."""
    B = v_camera.T @ v_imu
    U, _, Vt = np.linalg.svd(B)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
    return U @ D @ Vt


def estimate_extrinsics(
    imu_t_s: ArrayLike,
    gyroscope_rad_s: ArrayLike,
    frame_t_s: ArrayLike,
    visual_rotations: ArrayLike,
    visual_ok: ArrayLike | None = None,
    *,
    max_offset_s: float = 0.5,
) -> ExtrinsicsEstimate:
    """Estimate the IMU-to-camera rotation and time offset (see the module docstring).

    Needs rotation on at least two axes during the recording (walking gives it); raises InvalidInputError when
    there are too few usable frame intervals or no rotation at all.
    """
    t = np.asarray(imu_t_s, float).reshape(-1)
    g = np.asarray(gyroscope_rad_s, float)
    ft = np.asarray(frame_t_s, float).reshape(-1)
    R = np.asarray(visual_rotations, float)
    if g.shape != (len(t), 3) or R.shape != (len(ft), 3, 3):
        msg = f"need gyro (N,3) for N IMU times and rotations (M,3,3) for M frames; got {g.shape}, {R.shape}"
        raise InvalidInputError(msg)
    a, b, w_cam = visual_rates_rad_s(ft, R, None if visual_ok is None else np.asarray(visual_ok, bool))
    if len(w_cam) < 20:
        msg = f"only {len(w_cam)} usable frame intervals; need at least 20 to estimate IMU-camera extrinsics"
        raise InvalidInputError(msg)
    cumulative = np.concatenate([np.zeros((1, 3)), np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(t)[:, None], axis=0)])
    if np.linalg.norm(w_cam, axis=1).std() < 1e-6:
        msg = "the camera hardly rotates in this recording: the IMU-camera extrinsics cannot be estimated"
        raise InvalidInputError(msg)
    offset, score = _time_offset(t, cumulative, a, b, w_cam, max_offset_s)
    lo, hi = a - offset, b - offset
    inside = (lo >= t[0]) & (hi <= t[-1])
    w_imu = _mean_gyro(t, cumulative, lo[inside], hi[inside])
    w_c = w_cam[inside]
    rot, bias, keep = _robust_rotation(w_c, w_imu)
    centred_c = w_c[keep] - w_c[keep].mean(0)
    centred_i = w_imu[keep] - w_imu[keep].mean(0)
    sv = np.linalg.svd(centred_c.T @ centred_i, compute_uv=False)
    excitation = float(sv[1] / sv[0]) if sv[0] > 0 else 0.0
    err = np.linalg.norm(w_c[keep] - ((w_imu[keep] - bias) @ rot.T), axis=1)
    result = ExtrinsicsEstimate(
        camera_from_imu=rot,
        time_offset_s=offset,
        residual_deg_s=float(np.degrees(np.sqrt(np.mean(err**2)))),
        correlation=score,
        n_intervals=int(keep.sum()),
        rotation_deg=float(np.degrees(np.linalg.norm(log_so3(rot)))),
        axis_excitation=excitation,
    )
    _log.info("IMU-camera extrinsics: %s", result.to_dict())
    return result


def _time_offset(
    t: NDArray[np.float64], cumulative: NDArray[np.float64], a: NDArray[np.float64], b: NDArray[np.float64],
    w_cam: NDArray[np.float64], max_offset_s: float,
) -> tuple[float, float]:
    """The offset (video time tv = IMU time + offset) maximising the correlation of the camera's and the
    gyroscope's rotation speeds over the frame intervals (1 ms grid, parabolic refinement), and that correlation."""
    speed_cam = np.linalg.norm(w_cam, axis=1)

    def correlation(offset: float) -> float:
        lo, hi = a - offset, b - offset
        inside = (lo >= t[0]) & (hi <= t[-1])
        if inside.sum() < 20:
            return -1.0
        speed_imu = np.linalg.norm(_mean_gyro(t, cumulative, lo[inside], hi[inside]), axis=1)
        c = np.corrcoef(speed_cam[inside], speed_imu)[0, 1]
        return float(c) if np.isfinite(c) else -1.0

    offsets = np.arange(-max_offset_s, max_offset_s + 1e-9, 1e-3)
    scores = np.array([correlation(o) for o in offsets])
    k = int(np.argmax(scores))
    offset = float(offsets[k])
    if 0 < k < len(offsets) - 1:
        y0, y1, y2 = scores[k - 1], scores[k], scores[k + 1]
        denom = y0 - 2 * y1 + y2
        if denom < 0:
            offset += float(0.5 * (y0 - y2) / denom) * 1e-3
    return offset, float(scores[k])


def _robust_rotation(
    w_c: NDArray[np.float64], w_imu: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """Rotation (Wahba) and gyroscope bias between matched camera and IMU rates, re-estimated three times
    without the intervals beyond 5 robust sigmas; returns (rotation, bias, intervals kept)."""
    keep = np.ones(len(w_c), bool)
    rot = np.eye(3)
    bias = np.zeros(3)
    for _ in range(3):
        rot = _wahba(w_c[keep] - w_c[keep].mean(0), w_imu[keep] - w_imu[keep].mean(0))
        bias = (w_imu[keep] - (rot.T @ w_c[keep].T).T).mean(axis=0)
        err = np.linalg.norm(w_c - ((w_imu - bias) @ rot.T), axis=1)
        med = np.median(err)
        mad = np.median(np.abs(err - med)) + 1e-9
        keep = err < med + 5.0 * 1.4826 * mad
    return rot, bias, keep
