"""Benchmark caches of simulated sessions are keyed by the simulator version and every parameter (issue 14)."""

from __future__ import annotations

import json

import pytest

from walkmon.simulate import ImuSettings, RenderSettings, _version
from walkmon.simulate import cache as cache_mod
from walkmon.simulate.cache import KEY_FILE, cached_simulation, simulation_key

BASE = {"walk": "normal", "seconds": 6.0, "seed": 1, "width": 64, "height": 48}


@pytest.mark.parametrize(
    "change",
    [
        {"walk": "bend"},
        {"walk": "normal:3,turn:90,normal:2"},
        {"seconds": 7.0},
        {"seed": 2},
        {"width": 80},
        {"height": 60},
        {"fps": 25.0},
        {"distortion": True},
        {"video": False},
        {"stand_s": 1.0},
        {"render_settings": RenderSettings(exposure_s=0.004)},
        {"render_settings": RenderSettings(rolling_shutter_s=0.02)},
        {"imu_settings": ImuSettings(gyroscope_noise_dps=0.2)},
    ],
)
def test_a_changed_parameter_changes_the_key(change) -> None:
    assert simulation_key(**BASE) == simulation_key(**BASE)
    assert simulation_key(**{**BASE, **change}) != simulation_key(**BASE)


def test_a_new_simulator_version_changes_the_key(monkeypatch) -> None:
    before = simulation_key(**BASE)
    monkeypatch.setattr(_version, "SIMULATOR_VERSION", _version.SIMULATOR_VERSION + 1)
    assert simulation_key(**BASE) != before


def test_cached_simulation_simulates_once_per_key(tmp_path, monkeypatch) -> None:
    calls = []
    from walkmon.simulate import session

    real = session.simulate

    def counting(out, **kwargs):
        calls.append(kwargs)
        return real(out, **kwargs)

    monkeypatch.setattr(session, "simulate", counting)
    a = cached_simulation(tmp_path, **BASE, video=False)
    b = cached_simulation(tmp_path, **BASE, video=False)
    assert a == b and len(calls) == 1
    assert (a / "truth.csv").is_file() and json.loads((a / KEY_FILE).read_text())["seed"] == 1
    c = cached_simulation(tmp_path, **{**BASE, "seed": 2}, video=False)
    assert c != a and len(calls) == 2
    # a folder without its key file (an interrupted run) is simulated again, not used
    (a / KEY_FILE).unlink()
    assert cached_simulation(tmp_path, **BASE, video=False) == a
    assert len(calls) == 3 and (a / KEY_FILE).is_file()
    monkeypatch.setattr(_version, "SIMULATOR_VERSION", _version.SIMULATOR_VERSION + 1)
    d = cached_simulation(tmp_path, **BASE, video=False)
    assert d != a and len(calls) == 4
    assert cache_mod.simulation_params(**BASE)["simulator_version"] == _version.SIMULATOR_VERSION
