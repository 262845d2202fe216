"""Helpers shared by the IMU tests, given as fixtures."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest


def _rmse(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per-axis RMSE of (N, 3) angle arrays in degrees, the yaw difference wrapped to [-180, 180)."""
    e = a - b
    e[:, 1] = (e[:, 1] + 180.0) % 360.0 - 180.0
    return np.sqrt(np.mean(e**2, axis=0))


@pytest.fixture
def rmse() -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """The per-axis angle RMSE (degrees, yaw wrapped)."""
    return _rmse
