"""Walk classification: the paper's own Table 3 (place A) and simulated walks of every type over several seeds."""

from __future__ import annotations

import numpy as np
import pytest

from walkmon.errors import ConfigError
from walkmon.gait.indicators import Classification, compute_indicators
from walkmon.gait.posture import LABELS, PostureThresholds, classify

# The paper's Table 3 (place A): P lmax, P lmin, Y lmax, Y lmin, R lmax, R lmin, swings p/y/r, inclinations p/y/r.
TABLE3 = {
    "normal": (0.927, -0.439, 1.032, 0.245, 0.337, -0.683, 1.366, 0.787, 1.020, 0.244, 0.639, -0.173),
    "motion1": (-0.844, -1.566, 1.527, -0.336, -0.808, -1.506, 0.722, 1.863, 0.698, -1.205, 0.600, -1.157),
    "motion2": (4.243, -4.630, 3.193, -1.037, 5.355, -6.465, 8.873, 4.230, 11.82, -0.194, 1.078, -0.555),
    "motion3": (-0.787, -1.621, -0.730, -1.780, 0.640, -1.271, 0.834, 1.050, 1.911, -1.204, -1.255, -0.316),
}


def table3_doc(column: str) -> dict:
    v = TABLE3[column]
    axes = {}
    for k, axis in enumerate(("pitch", "yaw", "roll")):
        axes[axis] = {
            "lmax_mean": v[2 * k],
            "lmin_mean": v[2 * k + 1],
            "swing_mean": v[6 + k],
            "inclination_mean": v[9 + k],
            "n_cycles": 10,
        }
    return {"cadence_spm": 110.0, "duration_s": 20.0, "walking_s": 14.0, "axes": axes, "asymmetry": {}, "status": "ok"}


def test_table3_is_self_consistent() -> None:
    # Eq. 9-12 hold in the paper's own table (to its rounding), so the transcription is right
    for column in TABLE3:
        doc = table3_doc(column)
        for axis in ("pitch", "yaw", "roll"):
            d = doc["axes"][axis]
            assert d["swing_mean"] == pytest.approx(d["lmax_mean"] - d["lmin_mean"], abs=0.011)
            assert d["inclination_mean"] == pytest.approx((d["lmax_mean"] + d["lmin_mean"]) / 2, abs=0.011)


@pytest.mark.parametrize(
    ("column", "label"),
    [("motion1", "left_shoulder_down"), ("motion2", "right_foot_drag"), ("motion3", "bend"), ("normal", "normal")],
)
def test_paper_table3_place_a_with_the_normal_walk_as_baseline(column: str, label: str) -> None:
    result = classify(table3_doc(column), table3_doc("normal"))
    assert isinstance(result, Classification)
    assert result.label == label
    assert result.reasons and all(isinstance(r, str) and r for r in result.reasons)


def test_relative_rules_are_not_fooled_by_a_uniform_shift() -> None:
    # a leaning-right walk (roll up) is none of the known patterns
    doc = table3_doc("normal")
    doc["axes"]["roll"]["inclination_mean"] += 2.0
    doc["axes"]["roll"]["lmax_mean"] += 2.0
    doc["axes"]["roll"]["lmin_mean"] += 2.0
    assert classify(doc, table3_doc("normal")).label == "unclassified"


def test_unusable_indicators_are_unclassified() -> None:
    doc = table3_doc("normal")
    doc["status"] = "no_gait"
    assert classify(doc).label == "unclassified"
    doc = table3_doc("normal")
    doc["axes"]["pitch"]["swing_mean"] = None
    assert classify(doc).label == "unclassified"
    assert set(LABELS) == {"normal", "left_shoulder_down", "right_foot_drag", "bend", "unclassified"}


def test_thresholds_are_validated() -> None:
    with pytest.raises(ConfigError):
        PostureThresholds(drag_swing_ratio=0.5)
    with pytest.raises(ConfigError):
        PostureThresholds(bend_pitch_drop_deg=float("nan"))


WALKS = ("normal", "left_shoulder_down", "right_foot_drag", "bend")
SEEDS = (0, 1, 2, 3, 4, 5)


@pytest.fixture(scope="module")
def simulated_truth() -> dict:
    """Truth angles of 16 s simulated sessions (30 fps), from the simulator's gait model (no rendering)."""
    simulate = pytest.importorskip("walkmon.simulate")
    out = {}
    for walk in WALKS:
        for seed in SEEDS:
            model = simulate.GaitModel(walk, 16.0, seed)
            t = np.arange(0.0, model.duration_s + 1e-9, 1 / 30)
            out[walk, seed] = (t, model.truth_angles_deg(t), model)
    return out


@pytest.mark.parametrize("walk", WALKS)
def test_simulated_walks_are_classified_without_baseline(simulated_truth: dict, walk: str) -> None:
    labels = [compute_indicators(*simulated_truth[walk, s][:2]).classification.label for s in SEEDS]
    assert labels == [walk] * len(SEEDS)


@pytest.mark.parametrize("walk", WALKS)
def test_simulated_walks_are_classified_against_a_normal_baseline(simulated_truth: dict, walk: str) -> None:
    labels = []
    for seed in SEEDS:
        # the baseline is another normal walk of the "same person" (a different seed)
        baseline = compute_indicators(*simulated_truth["normal", (seed + 1) % len(SEEDS)][:2])
        labels.append(compute_indicators(*simulated_truth[walk, seed][:2], baseline=baseline).classification.label)
    assert labels == [walk] * len(SEEDS)


def test_simulated_cadence_and_bend_offset_match_the_model(simulated_truth: dict) -> None:
    for (walk, _seed), (t, angles, model) in simulated_truth.items():
        ind = compute_indicators(t, angles)
        t0, t1 = ind.walking_interval_s
        phase = model.step_phase(np.array([t0, t1]))
        realised_spm = 60 * (phase[1] - phase[0]) / (t1 - t0)  # steps actually taken in the analysed span
        assert ind.cadence_spm == pytest.approx(realised_spm, rel=0.01), walk
        if walk == "bend":
            assert ind.axes["pitch"].inclination_mean == pytest.approx(model.segments[0].pitch_offset_deg, abs=0.5)
        if walk == "left_shoulder_down":
            assert ind.axes["roll"].inclination_mean == pytest.approx(model.segments[0].roll_offset_deg, abs=0.5)


def test_simulated_foot_drag_shows_alternating_step_times(simulated_truth: dict) -> None:
    def ratios(walk: str) -> list[float]:
        return [compute_indicators(*simulated_truth[walk, s][:2]).asymmetry["step_time_ratio"] for s in SEEDS]

    drag, normal = ratios("right_foot_drag"), ratios("normal")
    # the simulator alternates right/left step durations by +-10.5 % (true ratio ~1.2) for the dragged foot
    assert np.mean(drag) > 1.1
    assert max(normal) < 1.08
    assert np.mean(drag) > np.mean(normal) + 0.08
