"""Shared test fixtures. Area-specific fixtures live in the test modules that use them."""

from __future__ import annotations

import os
import random
from pathlib import Path

import numpy as np
import pytest

#: The project's shared data (../shared/data beside the checkout, as CI lays it out); WALKMON_SHARED_DATA overrides.
SHARED_DATA = Path(os.environ.get("WALKMON_SHARED_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"))


@pytest.fixture(autouse=True)
def _reset_random_seed() -> None:
    """Seed the global RNGs before every test, so no test depends on another's draws."""
    random.seed(0)
    np.random.seed(0)  # noqa: NPY002  (legacy global RNG, for any library that still uses it)


@pytest.fixture
def broad_trial_7() -> Path:
    """BROAD trial 7 (fast rotations, optical truth; Laidig et al. 2021, CC BY 4.0) from the shared data."""
    path = SHARED_DATA / "broad" / "07_undisturbed_fast_rotation_B.hdf5"
    if not path.is_file():
        pytest.skip(f"BROAD data not present at {path}")
    return path


@pytest.fixture
def unit_settings() -> dict[str, list[str]]:
    """systemd/walkmon.service as ``{key: [values]}`` (comments and section headers left out)."""
    out: dict[str, list[str]] = {}
    unit = Path(__file__).resolve().parents[1] / "systemd" / "walkmon.service"
    for line in unit.read_text().splitlines():
        if "=" in line and not line.lstrip().startswith(("#", "[")):
            k, v = line.split("=", 1)
            out.setdefault(k.strip(), []).append(v.strip())
    return out
