"""Shared test fixtures. Area-specific fixtures live in the test modules that use them."""

from __future__ import annotations

import random

import numpy as np
import pytest


@pytest.fixture(autouse=True)
def _reset_random_seed() -> None:
    """Seed the global RNGs before every test, so no test depends on another's draws."""
    random.seed(0)
    np.random.seed(0)  # noqa: NPY002  (legacy global RNG, for any library that still uses it)
