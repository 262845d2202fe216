"""Frame and angle conventions: the one place they are defined. Every module uses these functions.

Camera frame
    x right, y down, z forward (OpenCV's camera frame).

Orientation
    The orientation of camera *t* relative to camera *0* is the rotation matrix ``R`` whose columns are camera
    *t*'s axes expressed in camera *0*'s frame: a direction ``v_t`` seen in camera *t* is ``R @ v_t`` in
    camera *0*. (OpenCV's ``recoverPose`` returns the *point transform* ``x_t = R_cv @ x_0 + t``, which is
    ``R.T``; use :func:`orientation_from_point_transform`.)

Angles (the paper's Eq. 3-7, degrees in every output)
    ``R = Rz(roll) @ Rx(pitch) @ Ry(yaw)`` with
    ``pitch = asin(r32)``, ``yaw = -atan2(r31, r33)``, ``roll = -atan2(r12, r22)``.

    * pitch > 0: the camera tilts up (the trunk bends backward); pitch < 0: bent forward.
    * yaw > 0: the camera turns right.
    * roll > 0: clockwise seen from behind the wearer (the trunk leans right, right shoulder down);
      roll < 0: left shoulder down.

Angular rate
    Gyroscope readings are the body rate in the camera (or IMU) frame: ``dR/dt = R @ skew(omega)``.

Accelerometer
    Specific force in the sensor frame: at rest with y pointing down it reads ``ay = -GRAVITY_MS2``.

Gravity-referenced angles (with an IMU)
    With ``g`` the unit vector of gravity (pointing down) in the camera frame:
    ``pitch_abs = atan2(-g_z, g_y)``, ``roll_abs = asin(g_x)``; both 0 when the camera is level.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "ANGLE_COLUMNS",
    "AXES",
    "GRAVITY_MS2",
    "IMU_COLUMNS",
    "TRUTH_COLUMNS",
    "angle_between_deg",
    "angles_deg_from_rotation",
    "gravity_angles_deg_from_gravity",
    "gravity_from_angles_deg",
    "orientation_from_point_transform",
    "rot_x",
    "rot_y",
    "rot_z",
    "rotation_from_angles_deg",
    "skew",
]

#: Standard gravity used by the simulator and the IMU code, m/s².
GRAVITY_MS2 = 9.81

#: Axis names in the order used in every table and array: pitch (about x), yaw (about y), roll (about z).
AXES = ("pitch", "yaw", "roll")

#: Column headers of the files walkmon reads and writes.
ANGLE_COLUMNS = ("t", "pitch", "yaw", "roll")
TRUTH_COLUMNS = ("t", "pitch", "yaw", "roll", "x", "y", "z")
IMU_COLUMNS = ("t", "gx", "gy", "gz", "ax", "ay", "az")


def rot_x(angle_rad: ArrayLike) -> NDArray[np.float64]:
    """Rotation about x (the paper's Eq. 4, ``R_p``); shape (..., 3, 3)."""
    a = np.asarray(angle_rad, dtype=float)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2)


def rot_y(angle_rad: ArrayLike) -> NDArray[np.float64]:
    """Rotation about y (the paper's Eq. 5, ``R_y``); shape (..., 3, 3)."""
    a = np.asarray(angle_rad, dtype=float)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2)


def rot_z(angle_rad: ArrayLike) -> NDArray[np.float64]:
    """Rotation about z (the paper's Eq. 6, ``R_r``); shape (..., 3, 3)."""
    a = np.asarray(angle_rad, dtype=float)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def rotation_from_angles_deg(pitch_deg: ArrayLike, yaw_deg: ArrayLike, roll_deg: ArrayLike) -> NDArray[np.float64]:
    """``R = Rz(roll) @ Rx(pitch) @ Ry(yaw)`` from angles in degrees; broadcasts, shape (..., 3, 3)."""
    p, y, r = (np.radians(np.asarray(v, dtype=float)) for v in (pitch_deg, yaw_deg, roll_deg))
    return rot_z(r) @ rot_x(p) @ rot_y(y)


def angles_deg_from_rotation(rotation: ArrayLike) -> NDArray[np.float64]:
    """(pitch, yaw, roll) in degrees from ``R`` (the paper's Eq. 7); shape (..., 3) for input (..., 3, 3)."""
    R = np.asarray(rotation, dtype=float)
    if R.shape[-2:] != (3, 3):
        msg = f"rotation must have shape (..., 3, 3), got {R.shape}"
        raise ValueError(msg)
    pitch = np.arcsin(np.clip(R[..., 2, 1], -1.0, 1.0))
    yaw = -np.arctan2(R[..., 2, 0], R[..., 2, 2])
    roll = -np.arctan2(R[..., 0, 1], R[..., 1, 1])
    return np.degrees(np.stack([pitch, yaw, roll], axis=-1))


def orientation_from_point_transform(rotation_cv: ArrayLike) -> NDArray[np.float64]:
    """Orientation of camera *t* relative to camera *0* from OpenCV's point transform ``x_t = R_cv x_0 + t``."""
    return np.swapaxes(np.asarray(rotation_cv, dtype=float), -1, -2)


def skew(v: ArrayLike) -> NDArray[np.float64]:
    """Cross-product matrix ``[v]x`` so that ``skew(a) @ b == cross(a, b)``; shape (..., 3, 3)."""
    a = np.asarray(v, dtype=float)
    z = np.zeros_like(a[..., 0])
    return np.stack(
        [
            np.stack([z, -a[..., 2], a[..., 1]], -1),
            np.stack([a[..., 2], z, -a[..., 0]], -1),
            np.stack([-a[..., 1], a[..., 0], z], -1),
        ],
        -2,
    )


def gravity_angles_deg_from_gravity(gravity_down: ArrayLike) -> NDArray[np.float64]:
    """(pitch_abs, roll_abs) in degrees from gravity's direction (pointing down) in the camera frame.

    ``pitch_abs = atan2(-g_z, g_y)``, ``roll_abs = asin(g_x)`` with ``g`` normalised; shape (..., 2).
    """
    g = np.asarray(gravity_down, dtype=float)
    g = g / np.linalg.norm(g, axis=-1, keepdims=True)
    pitch_abs = np.arctan2(-g[..., 2], g[..., 1])
    roll_abs = np.arcsin(np.clip(g[..., 0], -1.0, 1.0))
    return np.degrees(np.stack([pitch_abs, roll_abs], axis=-1))


def gravity_from_angles_deg(pitch_abs_deg: ArrayLike, roll_abs_deg: ArrayLike) -> NDArray[np.float64]:
    """Gravity's unit direction (pointing down) in the camera frame from (pitch_abs, roll_abs) in degrees: the
    inverse of :func:`gravity_angles_deg_from_gravity`, ``g = (sin r, cos r cos p, -cos r sin p)``; shape (..., 3)."""
    p, r = np.radians(np.asarray(pitch_abs_deg, dtype=float)), np.radians(np.asarray(roll_abs_deg, dtype=float))
    return np.stack([np.sin(r), np.cos(r) * np.cos(p), -np.cos(r) * np.sin(p)], axis=-1)


def angle_between_deg(u: ArrayLike, v: ArrayLike) -> float:
    """The angle between two unit vectors (directions, signs counted), degrees."""
    c = float(np.dot(np.asarray(u, dtype=float), np.asarray(v, dtype=float)))
    return float(np.degrees(np.arccos(min(1.0, max(-1.0, c)))))
