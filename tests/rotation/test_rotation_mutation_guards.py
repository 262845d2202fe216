"""Rotation tests written against mutations that slipped through (issue 12): the Kabsch/Wahba solution without
its reflection fix, and the nearest-rotation choice with a transposed prior."""

from __future__ import annotations

import numpy as np
import pytest

from walkmon.rotation.geometry import (
    rotation_angle_deg,
    rotation_from_bearings,
    rotation_from_rotvec,
    select_nearest_rotation,
)


def _is_rotation(R: np.ndarray) -> bool:
    return bool(np.allclose(R.T @ R, np.eye(3), atol=1e-9) and np.isclose(np.linalg.det(R), 1.0, atol=1e-9))


def test_kabsch_never_returns_a_reflection() -> None:
    """Bearings mirrored through the y-z plane: the unconstrained least-squares orthogonal matrix is that mirror
    (det -1); the best rotation is a proper one (det +1), which the reflection fix guarantees."""
    rng = np.random.default_rng(1)
    b1 = rng.normal(size=(40, 3)) + np.array([0.0, 0.0, 3.0])  # points ahead of the camera, spread in x
    mirror = np.diag([-1.0, 1.0, 1.0])
    R = rotation_from_bearings(b1 @ mirror.T, b1)
    assert _is_rotation(R)


def test_kabsch_recovers_a_known_rotation_from_exact_bearings() -> None:
    rng = np.random.default_rng(2)
    truth = rotation_from_rotvec(np.radians([3.0, -7.0, 2.0]))
    b1 = rng.normal(size=(30, 3)) + np.array([0.0, 0.0, 4.0])
    R = rotation_from_bearings(b1 @ truth.T, b1)
    assert rotation_angle_deg(truth.T @ R) < 1e-9


def test_nearest_rotation_compares_candidates_with_the_prior_not_its_transpose() -> None:
    """Prior P: 20 deg about y. Candidates P and P^T: P is 0 deg from the prior, P^T 40 deg. A transposed prior
    (P @ R instead of P^T @ R) would pick P^T."""
    P = rotation_from_rotvec(np.radians([0.0, 20.0, 0.0]))
    chosen = select_nearest_rotation([P.T, P], P)
    assert rotation_angle_deg(P.T @ chosen) == pytest.approx(0.0, abs=1e-9)
    Q = rotation_from_rotvec(np.radians([5.0, 0.0, 0.0])) @ P  # a prior near P, not P itself
    assert select_nearest_rotation([P.T, P], Q) is P
