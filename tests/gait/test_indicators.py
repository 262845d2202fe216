"""Indicator maths against independent computations on synthetic waveforms with known extremums."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from walkmon.errors import ConfigError, InvalidInputError
from walkmon.gait.indicators import (
    Indicators,
    IndicatorSettings,
    IndicatorStatus,
    analyze_gait,
    compute_indicators,
    indicators_from_dict,
    refined_extremum_values,
)
from walkmon.tables import read_indicators, write_indicators

FS = 30.0
STEP_HZ = 1.8


def _envelope(t: np.ndarray, start: float, end: float, ramp: float = 1.0) -> np.ndarray:
    """0 while standing, raised-cosine ramps of ``ramp`` s inside [start, end], 1 in between."""
    up = np.clip((t - start) / ramp, 0, 1)
    down = np.clip((end - t) / ramp, 0, 1)
    return (0.5 - 0.5 * np.cos(np.pi * up)) * (0.5 - 0.5 * np.cos(np.pi * down))


def synthetic_walk(
    *,
    seconds: float = 16.0,
    stand_s: float = 2.0,
    pitch_offset: float = 0.0,
    roll_offset: float = 0.0,
    amps: tuple[float, float, float] = (1.0, 1.5, 2.0),
    step_hz: float = STEP_HZ,
    drift_deg_per_s: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> tuple[np.ndarray, np.ndarray]:
    """Pitch at step frequency, yaw and roll at stride frequency, with offsets while walking and linear drift."""
    t = np.arange(0.0, seconds, 1.0 / FS)
    env = _envelope(t, stand_s, seconds - stand_s)
    pitch = env * (pitch_offset + amps[0] * np.cos(2 * np.pi * step_hz * t + 0.4))
    yaw = env * amps[1] * np.sin(np.pi * step_hz * t + 1.1)
    roll = env * (roll_offset + amps[2] * np.sin(np.pi * step_hz * t + 0.2))
    angles = np.column_stack([pitch, yaw, roll]) + np.outer(t, drift_deg_per_s)
    return t, angles


def test_sinusoids_give_their_known_extremums() -> None:
    t, a = synthetic_walk(pitch_offset=-2.0, roll_offset=1.0, amps=(1.0, 1.5, 2.0))
    ind = compute_indicators(t, a)
    assert ind.status is IndicatorStatus.OK
    assert ind.cadence_spm == pytest.approx(60 * STEP_HZ, rel=0.002)
    p, y, r = ind.axes["pitch"], ind.axes["yaw"], ind.axes["roll"]
    assert p.lmax_mean == pytest.approx(-1.0, abs=0.02)
    assert p.lmin_mean == pytest.approx(-3.0, abs=0.02)
    assert p.swing_mean == pytest.approx(2.0, rel=0.01)
    assert p.inclination_mean == pytest.approx(-2.0, abs=0.02)
    assert r.swing_mean == pytest.approx(4.0, rel=0.01)
    assert r.inclination_mean == pytest.approx(1.0, abs=0.03)
    assert y.swing_mean == pytest.approx(3.0, rel=0.01)
    assert y.inclination_mean == pytest.approx(0.0, abs=0.05)
    # cycles: steps for pitch, strides for yaw and roll, over ~9-10 s of steady walking
    walking = ind.walking_s
    assert 8.0 < walking < 11.0
    assert abs(p.n_cycles - walking * STEP_HZ) <= 2
    assert abs(r.n_cycles - walking * STEP_HZ / 2) <= 1.5
    # standing phases found where they are
    assert ind.standing_start_s[0] == 0.0 and ind.standing_start_s[1] == pytest.approx(2.0, abs=0.35)
    assert ind.standing_end_s[1] == pytest.approx(t[-1]) and ind.standing_end_s[0] == pytest.approx(14.0, abs=0.35)


def test_bend_inclination_is_kept_and_drift_removed() -> None:
    clean_t, clean = synthetic_walk(pitch_offset=-18.0, amps=(1.2, 1.5, 2.0))
    t, drifting = synthetic_walk(pitch_offset=-18.0, amps=(1.2, 1.5, 2.0), drift_deg_per_s=(0.25, 0.4, -0.2))
    ind = compute_indicators(t, drifting)
    ref = compute_indicators(clean_t, clean)
    assert ind.axes["pitch"].inclination_mean == pytest.approx(-18.0, abs=0.1)
    assert ref.axes["pitch"].inclination_mean == pytest.approx(-18.0, abs=0.1)
    assert ind.axes["roll"].inclination_mean == pytest.approx(0.0, abs=0.1)
    for axis in ("pitch", "yaw", "roll"):
        assert ind.axes[axis].swing_mean == pytest.approx(ref.axes[axis].swing_mean, rel=0.02)
    assert ind.drift_removed_deg["pitch"] == pytest.approx(0.25 * 14.0, abs=0.1)  # between the standing centres
    assert ind.classification.label == "bend"
    # the paper's least-squares detrend loses most of the offset: that is the flaw walkmon mode fixes
    paper = compute_indicators(t, drifting, IndicatorSettings(mode="paper"))
    assert paper.axes["pitch"].inclination_mean > -6.0


def test_paper_mode_matches_an_independent_implementation() -> None:
    t, a = synthetic_walk(pitch_offset=-1.0, roll_offset=-0.5, amps=(1.0, 0.8, 1.3), drift_deg_per_s=(0.1, 0, 0))
    ind = compute_indicators(t, a, IndicatorSettings(mode="paper"))
    assert ind.mode == "paper"
    keep = (t >= 3.0) & (t <= t[-1] - 3.0)
    for k, axis in enumerate(("pitch", "yaw", "roll")):
        d = a[:, k] - np.polyval(np.polyfit(t, a[:, k], 1), t)
        inner = np.arange(1, t.size - 1)
        is_max = inner[(d[inner] > d[inner - 1]) & (d[inner] >= d[inner + 1]) & keep[inner]]
        is_min = inner[(d[inner] < d[inner - 1]) & (d[inner] <= d[inner + 1]) & keep[inner]]
        pairs = [(i, is_min[is_min > i][0]) for i in is_max if np.any(is_min > i)]
        amax = np.array([d[i] for i, _ in pairs])
        bmin = np.array([d[j] for _, j in pairs])
        got = ind.axes[axis]
        assert got.n_cycles == len(pairs)
        assert got.lmax_mean == pytest.approx(amax.mean(), abs=1e-9)
        assert got.lmin_mean == pytest.approx(bmin.mean(), abs=1e-9)
        assert got.swing_mean == pytest.approx((amax - bmin).mean(), abs=1e-9)
        assert got.inclination_mean == pytest.approx(((amax + bmin) / 2).mean(), abs=1e-9)


def test_window_without_standing_uses_the_reference() -> None:
    t, a = synthetic_walk(seconds=30.0, pitch_offset=-18.0)
    sel = (t >= 6.0) & (t < 16.0)  # a 10 s live window, walking all along
    ind = compute_indicators(t[sel], a[sel])
    assert ind.standing_start_s is None and ind.standing_end_s is None
    assert ind.axes["pitch"].inclination_mean == pytest.approx(-18.0, abs=0.05)
    shifted = compute_indicators(t[sel], a[sel], reference_deg=(1.0, 0.0, 0.5))
    assert shifted.axes["pitch"].inclination_mean == pytest.approx(-19.0, abs=0.05)
    assert shifted.axes["roll"].inclination_mean == pytest.approx(-0.5, abs=0.05)
    assert shifted.cadence_spm == pytest.approx(60 * STEP_HZ, rel=0.005)


def test_alternating_steps_show_up_as_asymmetry() -> None:
    # steps alternate 0.50 s / 0.62 s and swing 2.0 / 3.0 deg: pitch = A_k (1 - cos 2 pi phase) within step k
    durations = np.tile([0.50, 0.62], 20)
    bounds = np.concatenate([[2.0], 2.0 + np.cumsum(durations)])
    t = np.arange(0.0, bounds[-1] + 2.0, 1.0 / FS)
    phase = np.interp(t, bounds, np.arange(bounds.size), left=0.0, right=float(bounds.size - 1))
    k = np.clip(np.floor(phase).astype(int), 0, durations.size - 1)
    amp = np.where(k % 2 == 0, 1.0, 1.5)
    walking = (t > bounds[0]) & (t < bounds[-1])
    pitch = np.where(walking, amp * (1 - np.cos(2 * np.pi * phase)), 0.0)
    roll = np.where(walking, 2.0 * np.sin(np.pi * phase), 0.0)
    a = np.column_stack([pitch, np.zeros_like(t), roll])
    ind = compute_indicators(t, a, IndicatorSettings(lowpass_factor=0.0))
    asym = ind.asymmetry
    assert asym["step_swing_ratio"] == pytest.approx(1.5, rel=0.03)
    assert asym["step_time_ratio"] == pytest.approx(0.62 / 0.50, rel=0.03)
    assert ind.cadence_spm == pytest.approx(60 / 0.56, rel=0.01)
    symmetric = compute_indicators(*synthetic_walk())
    assert symmetric.asymmetry["step_swing_ratio"] == pytest.approx(1.0, abs=0.03)
    assert symmetric.asymmetry["step_time_ratio"] == pytest.approx(1.0, abs=0.03)


def test_refined_extremum_values_recover_the_true_peak() -> None:
    t = np.arange(0, 2, 1 / FS)
    x = np.cos(2 * np.pi * 1.8 * t - 0.19)  # true max 1 at t = 0.0168 s, between samples
    i = np.array([int(np.argmax(x[:10]))])
    assert x[i][0] < 0.995
    assert refined_extremum_values(x, i)[0] == pytest.approx(1.0, abs=1e-3)


def test_degenerate_input_is_a_status_not_an_exception() -> None:
    t = np.arange(0, 10, 1 / FS)
    flat = compute_indicators(t, np.zeros((t.size, 3)))
    assert flat.status is IndicatorStatus.NO_GAIT
    assert flat.classification.label == "unclassified"
    short = compute_indicators(t[:30], np.zeros((30, 3)))
    assert short.status in (IndicatorStatus.TOO_SHORT, IndicatorStatus.NO_GAIT)
    tiny = compute_indicators(t[:5], np.zeros((5, 3)))
    assert tiny.status is IndicatorStatus.TOO_SHORT
    json.dumps(tiny.to_dict(), allow_nan=False)  # NaN never reaches the JSON


@pytest.mark.parametrize(
    ("t", "a"),
    [
        (np.arange(10.0), np.zeros((10, 2))),
        (np.arange(10.0), np.zeros((9, 3))),
        (np.r_[0.0, 0.0, np.arange(2.0, 10.0)], np.zeros((10, 3))),
        (np.arange(10.0), np.full((10, 3), np.nan)),
    ],
)
def test_malformed_arrays_raise(t: np.ndarray, a: np.ndarray) -> None:
    with pytest.raises(InvalidInputError):
        compute_indicators(t, a)


@pytest.mark.parametrize(
    "kwargs",
    [{"mode": "fancy"}, {"step_band_hz": (2.0, 1.0)}, {"pad_factor": 0}, {"transition_s": -1.0},
     {"min_cycle_fraction": 1.5}, {"standing_window_s": 0.0}, {"lowpass_factor": float("nan")}],
)
def test_settings_are_validated(kwargs: dict) -> None:
    with pytest.raises(ConfigError):
        IndicatorSettings(**kwargs)


def test_results_are_frozen_and_json_round_trips(tmp_path) -> None:  # noqa: ANN001
    t, a = synthetic_walk(roll_offset=-4.0)
    an = analyze_gait(t, a)
    ind = compute_indicators(t, a)
    with pytest.raises(dataclasses.FrozenInstanceError):
        ind.cadence_spm = 1.0  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        an.raw_deg[0, 0] = 1.0
    path = tmp_path / "sub" / "indicators.json"
    write_indicators(path, ind)
    doc = json.loads(path.read_text())
    for key in ("cadence_spm", "duration_s", "walking_s", "axes", "asymmetry", "classification"):
        assert key in doc
    for axis in ("pitch", "yaw", "roll"):
        assert set(doc["axes"][axis]) >= {"lmax_mean", "lmin_mean", "swing_mean", "inclination_mean", "n_cycles"}
    assert doc["classification"]["label"] == "left_shoulder_down"
    back = read_indicators(path)
    assert isinstance(back, Indicators)
    assert back.to_dict() == doc


@pytest.mark.parametrize(
    ("text", "match"),
    [("{", "not valid JSON"), ("[]", "JSON object"), ('{"cadence_spm": 1}', "missing"),
     ('{"cadence_spm": "x", "duration_s": 1, "walking_s": 1, "axes": {}}', "pitch, yaw and roll")],
)
def test_bad_indicators_json_is_one_clear_error(tmp_path, text: str, match: str) -> None:  # noqa: ANN001
    p = tmp_path / "indicators.json"
    p.write_text(text)
    with pytest.raises(InvalidInputError, match=match):
        read_indicators(p)
    with pytest.raises(InvalidInputError, match="missing.json: no such"):
        read_indicators(tmp_path / "missing.json")
    with pytest.raises(InvalidInputError, match="must be a number"):
        indicators_from_dict(
            {"cadence_spm": "x", "duration_s": 1, "walking_s": 1,
             "axes": {a: {"lmax_mean": 0, "lmin_mean": 0, "swing_mean": 0, "inclination_mean": 0}
                      for a in ("pitch", "yaw", "roll")}}
        )


def test_a_window_starting_mid_walk_gets_no_drift_line() -> None:
    # the window starts mid-walk, so its end stance cannot be checked against an upright start: not an anchor
    t, a = synthetic_walk(seconds=20.0, pitch_offset=-15.0, drift_deg_per_s=(0.1, 0.0, 0.0))
    sel = t >= 5.0
    ind = compute_indicators(t[sel], a[sel])
    assert ind.standing_start_s is None and ind.standing_end_s is not None
    assert ind.drift_removed_deg["pitch"] == 0.0
    # the end stance differs from a start stance by more than max_drift_deg: not taken as upright either
    t2, bent_end = synthetic_walk(seconds=20.0, pitch_offset=-15.0)
    bent_end[t2 > 17.0, 0] = -15.0
    assert compute_indicators(t2, bent_end).drift_removed_deg["pitch"] == 0.0
    # the whole session is (upright at both ends)
    full = compute_indicators(t, a)
    assert full.drift_removed_deg["pitch"] == pytest.approx(0.1 * 18.0, abs=0.2)
    assert full.axes["pitch"].inclination_mean == pytest.approx(-15.0, abs=0.1)


def test_edge_wiggles_and_partial_cycles_are_not_gait_cycles() -> None:
    from walkmon.gait.indicators import cycle_extremums  # noqa: PLC0415

    t = np.arange(0, 6, 1 / FS)
    x = np.where(t < 4.75, np.sin(2 * np.pi * t), -1.0)  # 5 cycles of swing 2, then still
    x = x + np.where(t > 4.9, 0.05 * np.sin(2 * np.pi * (t - 4.9) / 0.6) ** 2, 0.0)  # the trunk settling
    imax, imin = cycle_extremums(x, min_distance=int(0.6 * FS))
    assert imax.size == 5
    assert np.allclose(x[imax] - x[imin], 2.0, atol=0.02)
    # the span ends 0.15 cycles after the last maximum: that partial cycle is dropped, not read as a small swing
    imax, imin = cycle_extremums(x, min_distance=int(0.6 * FS), hi=int(4.4 * FS))
    assert imax.size == 4
    assert np.allclose(x[imax] - x[imin], 2.0, atol=0.02)
