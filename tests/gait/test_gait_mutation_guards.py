"""Gait tests written against mutations that slipped through (issue 12): each asserts a value known by
construction of the input, so dropping the low-pass, the cadence's 12 % axis-agreement gate, the spread and
asymmetry fields or the left-shoulder rule's pitch condition makes it fail."""

from __future__ import annotations

import numpy as np
import pytest

from walkmon.gait.indicators import compute_indicators
from walkmon.gait.posture import classify
from walkmon.gait.spectrum import step_frequency_hz

FS = 30.0
F_STEP = 1.8


def _walk(pitch_fn, noise_deg: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """2 s standing, 12 s walking, 2 s standing at 30 fps; roll and yaw sway once per stride."""
    t = np.arange(0.0, 16.0, 1.0 / FS)
    walking = (t >= 2.0) & (t < 14.0)
    ph = 2 * np.pi * F_STEP * (t - 2.0)
    noise = noise_deg * np.sin(2 * np.pi * 11.0 * t)  # 11 Hz: far above the 5.4 Hz low-pass (3 x step)
    pitch = np.where(walking, pitch_fn(ph) + noise, 0.0)
    yaw = np.where(walking, 1.0 * np.sin(ph / 2 + 0.5), 0.0)
    roll = np.where(walking, 1.5 * np.sin(ph / 2) + noise, 0.0)
    return t, np.column_stack([pitch, yaw, roll])


def test_offline_low_pass_removes_high_frequency_jitter_from_the_swings() -> None:
    """Swing of 2 sin(step) is 4.0 deg and of 1.5 sin(stride) 3.0 deg; 0.6 deg of 11 Hz jitter on top would add
    ~0.8 deg to each swing without the low-pass at 3 x the step frequency."""
    t, a = _walk(lambda ph: 2.0 * np.sin(ph), noise_deg=0.6)
    d = compute_indicators(t, a).to_dict()
    assert d["status"] == "ok"
    assert d["axes"]["pitch"]["swing_mean"] == pytest.approx(4.0, abs=0.25)
    assert d["axes"]["roll"]["swing_mean"] == pytest.approx(3.0, abs=0.25)


def test_spreads_and_step_asymmetry_of_alternating_steps() -> None:
    """Steps alternate amplitude 2.5 / 1.5 deg and offset +0.5 / -0.5 deg: per-cycle swings 5, 3, 5, ... (mean 4,
    population std 1, even/odd ratio 5/3, asymmetry 100 x 2 / 4 = 50 %), inclinations +0.5, -0.5, ... (std 0.5)."""

    def pitch(ph: np.ndarray) -> np.ndarray:
        k = np.floor(ph / (2 * np.pi))
        amp = np.where(k % 2 == 0, 2.5, 1.5)
        offset = np.where(k % 2 == 0, 0.5, -0.5)
        return amp * np.sin(ph) + offset * (1 - np.cos(ph))  # offset reached at both extremums, 0 at the joins

    t, a = _walk(pitch)
    d = compute_indicators(t, a).to_dict()
    p = d["axes"]["pitch"]
    assert p["swing_mean"] == pytest.approx(4.0, abs=0.25)
    assert p["swing_std"] == pytest.approx(1.0, abs=0.1)
    assert p["inclination_mean"] == pytest.approx(0.0, abs=0.05)
    assert p["inclination_std"] == pytest.approx(0.5, abs=0.05)
    assert d["axes"]["roll"]["swing_std"] == pytest.approx(0.0, abs=0.05)
    asym = d["asymmetry"]
    assert asym["step_swing_ratio"] == pytest.approx(5 / 3, abs=0.1)
    assert asym["swing_asymmetry_pct"] == pytest.approx(50.0, abs=5.0)


def test_cadence_drops_an_axis_disagreeing_by_more_than_12_percent() -> None:
    """Pitch at 1.80 Hz (strongest), roll at 2 x 0.86 = 1.72 Hz (4 % off: kept), yaw at 2 x 0.78 = 1.56 Hz (13 %
    off: dropped). The estimate is a weighted mean of 1.80 and 1.72 only."""
    t = np.arange(0, 20, 1 / FS)
    rng = np.random.default_rng(0)
    detrended = {
        "pitch": 3.0 * np.sin(2 * np.pi * 1.80 * t) + 0.05 * rng.standard_normal(t.size),
        "roll": 1.0 * np.sin(2 * np.pi * 0.86 * t) + 0.05 * rng.standard_normal(t.size),
        "yaw": 0.8 * np.sin(2 * np.pi * 0.78 * t) + 0.05 * rng.standard_normal(t.size),
    }
    step = step_frequency_hz(detrended, FS)
    assert step.found
    assert step.per_axis_hz["yaw"] == pytest.approx(1.56, abs=0.02)
    assert step.weights["yaw"] == 0.0 and step.weights["pitch"] > 0 and step.weights["roll"] > 0
    assert 1.72 - 0.01 <= step.frequency_hz <= 1.80 + 0.01


def _doc(pitch_incl: float, roll_incl: float, pitch_lmax: float, pitch_lmin: float) -> dict:
    axes = {"pitch": {"swing_mean": 1.0, "inclination_mean": pitch_incl, "lmax_mean": pitch_lmax,
                      "lmin_mean": pitch_lmin},
            "yaw": {"swing_mean": 1.0, "inclination_mean": 0.0},
            "roll": {"swing_mean": 1.0, "inclination_mean": roll_incl}}
    return {"status": "ok", "axes": axes}


def test_roll_drop_that_comes_with_a_much_larger_pitch_drop_is_a_bend_not_a_shoulder() -> None:
    """Bending forward by 6 deg also lowers the roll inclination a little (1 deg here): the left-shoulder rule
    needs the roll drop to be at least 0.3 x the pitch drop (1.8 deg), so this is a bend."""
    base = _doc(0.0, 0.0, 0.5, -0.5)
    bend = _doc(-6.0, -1.0, -5.5, -6.5)
    assert classify(bend, base).label == "bend"
    shoulder = _doc(-1.0, -1.0, -0.5, -1.5)  # roll drop 1.0 >= 0.3 x 1.0: the shoulder
    assert classify(shoulder, base).label == "left_shoulder_down"
