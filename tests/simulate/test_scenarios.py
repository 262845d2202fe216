"""The issue-14 scenarios of the simulator: exact truth under turns, the wall and movers where they should be."""

from __future__ import annotations

import numpy as np
import pytest

from walkmon.consts import angles_deg_from_rotation
from walkmon.errors import ConfigError, InvalidInputError
from walkmon.imu.attitude import log_so3
from walkmon.simulate.render import SURFACES, RenderSettings
from walkmon.simulate.scenarios import SCENARIOS, ScenarioSession


def test_turns_are_exact_in_truth_and_gyro() -> None:
    s = ScenarioSession("turns", seconds=8.0, seed=2, width=64, height=48)
    m = s.model
    t = np.linspace(0.0, m.duration_s, 8001)
    psi, _ = m.turn_deg(t)
    # +90, then -180 (the last turn back starts 0.1 s before it ends on an 8 s clip), back to 0
    assert psi.max() == pytest.approx(90.0) and -90.0 < psi.min() < -85.0 and abs(psi[-1]) < 1e-9
    # the body rate the IMU model uses is the derivative of the rendered/truth rotation (independent: log map)
    R = m.rotation(t)
    dt = t[1] - t[0]
    fd = np.array([log_so3(R[i].T @ R[i + 1]) / dt for i in range(len(t) - 1)])
    w = m.angular_velocity_rps(0.5 * (t[1:] + t[:-1]))
    assert np.abs(fd - w).max() < 2e-3 * max(1.0, np.abs(w).max())
    # truth.csv yaw follows the turn: +90 deg while turned right
    peak = t[np.argmax(psi)]
    truth = s.truth()
    k = int(np.argmin(np.abs(truth["t"] - peak)))
    assert truth["yaw"][k] == pytest.approx(90.0, abs=8.0)
    assert np.allclose(angles_deg_from_rotation(m.rotation(truth["t"])), np.c_[truth["pitch"], truth["yaw"], truth["roll"]])


def test_wall_ahead_ends_3_m_in_front_and_movers_cross() -> None:
    s = ScenarioSession("wall", seconds=8.0, seed=1, width=64, height=48)
    r = s.renderer
    R, p = s.model.pose([s.model.duration_s])
    dist, label, _ = r.cast(R[0], p[0])
    centre = (24 * 64) + 32
    assert SURFACES[label[centre]] == "wall_ahead"
    assert dist[centre] == pytest.approx(3.0, abs=0.15)  # straight ahead, the camera about level
    m = ScenarioSession("movers", seconds=8.0, seed=1, width=64, height=48)
    seen = 0
    for t in np.arange(2.0, 6.0, 0.25):
        m.renderer.set_time(t)
        R, p = m.model.pose([t])
        _, lab, _ = m.renderer.cast(R[0], p[0])
        seen += int(np.any(lab == SURFACES.index("mover")))
    assert seen >= 4  # movers cross the view several times during the walk
    frame = m.render(3.0, np.random.default_rng(0))
    assert frame.shape == (48, 64, 3) and frame.dtype == np.uint8


def test_every_scenario_renders_and_bad_options_are_refused() -> None:
    for name in SCENARIOS:
        s = ScenarioSession(name, seconds=5.0, seed=0, width=32, height=24)
        img = s.render(2.5, np.random.default_rng(1))
        assert img.shape == (24, 32, 3)
        assert s.meta()["scenario"]["name"] == name
    night = ScenarioSession("night", seconds=5.0, seed=0, width=32, height=24).render(2.5, np.random.default_rng(1))
    street = ScenarioSession("street", seconds=5.0, seed=0, width=32, height=24).render(2.5, np.random.default_rng(1))
    assert night.mean() < 0.5 * street.mean()
    with pytest.raises(InvalidInputError):
        ScenarioSession("moon")
    with pytest.raises(ConfigError):
        RenderSettings(light=0.0)
    with pytest.raises(ConfigError):
        RenderSettings(movers=((0.0, 1.0, 0.0, 0.0, -1.0, 1.0, 0.0),))
