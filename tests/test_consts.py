"""The frame and angle conventions, checked against scipy and against their physical meaning."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from walkmon.consts import (
    angles_deg_from_rotation,
    gravity_angles_deg_from_gravity,
    orientation_from_point_transform,
    rot_x,
    rot_y,
    rot_z,
    rotation_from_angles_deg,
    skew,
)


def test_composition_matches_scipy_intrinsic_zxy() -> None:
    rng = np.random.default_rng(1)
    angles = rng.uniform(-60, 60, size=(200, 3))  # pitch, yaw, roll
    R = rotation_from_angles_deg(angles[:, 0], angles[:, 1], angles[:, 2])
    # R = Rz(roll) Rx(pitch) Ry(yaw) is scipy's intrinsic "ZXY" with angles (roll, pitch, yaw).
    ref = Rotation.from_euler("ZXY", angles[:, [2, 0, 1]], degrees=True).as_matrix()
    np.testing.assert_allclose(R, ref, atol=1e-12)


def test_decomposition_inverts_composition() -> None:
    rng = np.random.default_rng(2)
    angles = rng.uniform(-80, 80, size=(500, 3))
    back = angles_deg_from_rotation(rotation_from_angles_deg(*angles.T))
    np.testing.assert_allclose(back, angles, atol=1e-9)


def test_paper_eq7_elements() -> None:
    R = rotation_from_angles_deg(7.0, -3.0, 11.0)
    p, y, r = np.radians([7.0, -3.0, 11.0])
    assert R[2, 1] == pytest.approx(np.sin(p))
    assert -np.arctan2(R[2, 0], R[2, 2]) == pytest.approx(y)
    assert -np.arctan2(R[0, 1], R[1, 1]) == pytest.approx(r)


def test_physical_meaning_of_signs() -> None:
    forward, right = np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0])
    # pitch > 0: the optical axis points up (negative y, since y is down).
    assert (rotation_from_angles_deg(10, 0, 0) @ forward)[1] < 0
    # yaw > 0: the optical axis turns right (positive x).
    assert (rotation_from_angles_deg(0, 10, 0) @ forward)[0] > 0
    # roll > 0: clockwise seen from behind, the camera's right axis dips down (positive y).
    assert (rotation_from_angles_deg(0, 0, 10) @ right)[1] > 0


def test_single_axis_matrices_are_rotations() -> None:
    for f in (rot_x, rot_y, rot_z):
        R = f(np.radians(33.0))
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0)


def test_point_transform_is_transposed_orientation() -> None:
    R = rotation_from_angles_deg(4.0, -2.0, 1.5)
    # A world point seen from camera 0 and camera t (pure rotation): x_t = R.T x_0.
    x0 = np.array([0.3, -0.2, 5.0])
    R_cv = R.T
    np.testing.assert_allclose(orientation_from_point_transform(R_cv), R)
    np.testing.assert_allclose(R @ (R_cv @ x0), x0)


def test_skew_is_cross_product() -> None:
    rng = np.random.default_rng(3)
    a, b = rng.normal(size=(2, 3))
    np.testing.assert_allclose(skew(a) @ b, np.cross(a, b))


def test_gravity_angles_follow_orientation() -> None:
    for pitch, roll in [(0, 0), (12, 0), (-18, 0), (0, 6), (0, -5), (10, -4)]:
        # A heading change about the world vertical (applied on the left) must not matter.
        R = rot_y(np.radians(25.0)) @ rotation_from_angles_deg(pitch, 0.0, roll)
        g_cam = R.T @ np.array([0.0, 1.0, 0.0])  # gravity (down, +y in the level frame) seen by the camera
        np.testing.assert_allclose(gravity_angles_deg_from_gravity(g_cam), [pitch, roll], atol=1e-9)


def test_bad_shape_is_rejected() -> None:
    with pytest.raises(ValueError, match=r"\(\.\.\., 3, 3\)"):
        angles_deg_from_rotation(np.eye(2))
