"""Rolling shutter: move each tracked point to where it would have been seen at the frame's time.

A rolling-shutter camera exposes its rows one after another over the readout time ``readout_s`` (top row first);
while it turns at ``w`` rad/s, a point on row ``v`` is seen from the orientation the camera had ``dt(v)`` later than
the frame's time, ``dt(v) = readout_s ((v + 0.5) / height - 0.5)`` (the middle row is the frame's time, as in the
simulator's truth). A yaw at 90 deg/s with a 30 ms readout shears the image by 2.7 deg from the top row to the
bottom, far more than the tracking noise, and a rotation-only or essential model has no term for it.

First order in the readout (the standard correction for video from a turning camera, e.g. Forssén & Ringaby 2010,
Karpenko et al. 2011 gyro stabilisation; translation during the readout is neglected: a walker moves ~2 cm in
15 ms): with the camera's orientation ``R(t + dt) = R(t) Exp(w dt)`` (``w`` in camera axes), a point seen at bearing
``b'`` on its row was at ``b = Exp(w dt) b'`` at the frame's time. :func:`to_frame_time` applies that,
:func:`from_frame_time` its inverse (where a frame-time bearing shows up in a rolling-shutter image). ``w`` comes
from the previous frames' estimates (:func:`rate_from_step`); no I/O, no state.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ["from_frame_time", "rate_from_step", "row_offsets_s", "skew_px", "to_frame_time"]


def row_offsets_s(rows_px: NDArray[np.float64], height_px: int, readout_s: float) -> NDArray[np.float64]:
    """When each pixel row was exposed, relative to the frame's time (the middle row's), s."""
    return readout_s * ((np.asarray(rows_px, dtype=np.float64) + 0.5) / float(height_px) - 0.5)


def rate_from_step(step: NDArray[np.float64], dt_s: float) -> NDArray[np.float64]:
    """The constant angular rate (rad/s, camera axes) that turns the camera by ``step`` (previous -> current
    orientation, ``R_prev.T @ R_cur``) in ``dt_s``."""
    if not dt_s > 0:
        return np.zeros(3)
    R = np.asarray(step, dtype=np.float64)
    cos = min(1.0, max(-1.0, 0.5 * (float(np.trace(R)) - 1.0)))
    angle = math.acos(cos)
    axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if angle < 1e-9:
        return 0.5 * axis / dt_s  # the skew part of a near-identity rotation is its rotation vector
    return axis * (angle / (2.0 * math.sin(angle))) / dt_s


def skew_px(rate_rps: NDArray[np.float64], readout_s: float, focal_px: float) -> float:
    """How far (px) the image of a camera turning at ``rate_rps`` moves between its first and last row."""
    return float(np.linalg.norm(rate_rps)) * readout_s * focal_px


def _rotate(q: NDArray[np.float64], angle_per_point: NDArray[np.float64], axis: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rodrigues: each row of ``q`` rotated about the unit ``axis`` by its own angle (rad)."""
    c, s = np.cos(angle_per_point)[:, None], np.sin(angle_per_point)[:, None]
    kxq = np.cross(axis, q)
    kdq = (q @ axis)[:, None]
    return q * c + kxq * s + axis[None, :] * kdq * (1.0 - c)


def _turned(q: NDArray[np.float64], dt_s: NDArray[np.float64], rate_rps: NDArray[np.float64]) -> NDArray[np.float64]:
    q = np.asarray(q, dtype=np.float64)
    speed = float(np.linalg.norm(rate_rps))
    if q.shape[0] == 0 or speed == 0.0:
        return q.copy()
    out = _rotate(q, speed * np.asarray(dt_s, dtype=np.float64), np.asarray(rate_rps, dtype=np.float64) / speed)
    return out / out[:, 2:3]  # back to normalised homogeneous coordinates (z = 1)


def to_frame_time(q: NDArray[np.float64], dt_s: NDArray[np.float64], rate_rps: NDArray[np.float64]) -> NDArray[np.float64]:
    """Bearings ``q`` (N, 3; normalised homogeneous, z = 1) seen ``dt_s`` (N,) after the frame's time by a camera
    turning at ``rate_rps`` (camera axes), as they were at the frame's time: ``Exp(w dt) q``."""
    return _turned(q, dt_s, rate_rps)


def from_frame_time(q: NDArray[np.float64], dt_s: NDArray[np.float64], rate_rps: NDArray[np.float64]) -> NDArray[np.float64]:
    """The inverse of :func:`to_frame_time`: where frame-time bearings show up on rows read ``dt_s`` later."""
    return _turned(q, -np.asarray(dt_s, dtype=np.float64), rate_rps)
