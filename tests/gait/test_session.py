"""Session analysis (walkmon.gait.session): posture segments, turns, upright reference, timeline, summary."""

from __future__ import annotations

import numpy as np
import pytest

from walkmon.consts import angles_deg_from_rotation, rot_y, rotation_from_angles_deg
from walkmon.gait.session import SessionSettings, analyze_session
from walkmon.simulate.gait import GaitModel

FPS = 30.0


def _turning(t: np.ndarray, body_deg: np.ndarray, turns: list[tuple[float, float, float]]) -> np.ndarray:
    """Start-relative camera angles of a wearer whose trunk moves as ``body_deg`` while turning about the
    world's vertical by ``(start, end, degrees)`` ramps: the physics that mixes Euler pitch and roll."""
    heading = np.zeros_like(t)
    for s, e, deg in turns:
        heading += deg * np.clip((t - s) / (e - s), 0, 1)
    c = rot_y(np.radians(heading)) @ rotation_from_angles_deg(body_deg[:, 0], body_deg[:, 1], body_deg[:, 2])
    return angles_deg_from_rotation(np.einsum("ji,njk->nik", c[0], c))


def test_posture_change_mid_walk_splits_the_bout_into_labelled_segments() -> None:
    model = GaitModel("normal:10,bend:10", seed=5)  # standing 0-2 s, normal 2-12 s, bend 12-22 s, standing
    t = np.arange(0.0, model.duration_s, 1 / FPS)
    res = analyze_session(t, model.truth_angles_deg(t))
    doc = res.indicators.to_dict()
    assert doc["schema_version"] == 2
    assert [s["label"] for s in doc["segments"]] == ["normal", "bend"]
    assert doc["segments"][0]["end_s"] == pytest.approx(12.0, abs=1.5)
    assert doc["segments"][1]["axes"]["pitch"]["inclination_mean"] == pytest.approx(
        model.segments[1].pitch_offset_deg, abs=1.0)
    assert len(doc["bouts"]) == 1 and doc["walking_s"] == pytest.approx(20.0, abs=2.0)
    summary = doc["summary"]
    assert set(summary["posture_time_s"]) == {"normal", "bend"}
    assert summary["dominant_label"] in ("normal", "bend") and 0.4 < summary["dominant_share"] < 0.6
    assert doc["upright_reference"]["source"].startswith("first standing phase")
    # timeline: 1 s rows, walking seconds labelled, standing ones not
    rows = {round(r[0]): r for r in res.timeline}
    assert rows[0][1] == "standing" and rows[0][2] == ""
    assert rows[7][1:3] == ("walking", "normal") and rows[18][1:3] == ("walking", "bend")
    assert rows[18][3] == pytest.approx(model.segments[1].pitch_offset_deg, abs=2.5)


@pytest.mark.parametrize("walk", ["normal", "bend"])
def test_turns_are_excluded_and_inclination_survives_a_u_turn(walk: str) -> None:
    model = GaitModel(walk, 30.0, seed=6)
    t = np.arange(0.0, model.duration_s, 1 / FPS)
    angles = _turning(t, model.truth_angles_deg(t), [(12.0, 14.5, 180.0)])
    doc = analyze_session(t, angles).indicators.to_dict()
    assert len(doc["turns"]) == 1 and abs(doc["turns"][0]["angle_deg"]) == pytest.approx(180, abs=20)
    assert doc["classification"]["label"] == walk  # no false alarm from the turn, no posture lost after it
    for seg in doc["segments"]:  # the turn is not inside any posture segment
        assert seg["end_s"] <= 12.0 or seg["start_s"] >= 14.5
        assert seg["label"] == walk
    if walk == "bend":  # start-relative Euler pitch reads about +offset after a U-turn; the tilt does not
        assert doc["axes"]["pitch"]["inclination_mean"] == pytest.approx(model.segments[0].pitch_offset_deg, abs=1.5)


def test_a_recording_that_starts_mid_walk_needs_no_standing_start() -> None:
    model = GaitModel("normal", 24.0, seed=7)
    t = np.arange(0.0, model.duration_s, 1 / FPS)
    a = model.truth_angles_deg(t)
    keep = t >= 6.0  # cut the standing start and the first steps away: the clip starts mid-walk
    c = rotation_from_angles_deg(a[keep, 0], a[keep, 1], a[keep, 2])
    rel = angles_deg_from_rotation(np.einsum("ji,njk->nik", c[0], c))
    res = analyze_session(t[keep] - 6.0, rel)
    doc = res.indicators.to_dict()
    assert res.timeline[1][1] == "walking"  # walking from the first step on (a bout runs from its first step)
    assert doc["bouts"][0]["start_s"] < 1.0
    assert doc["classification"]["label"] == "normal"
    assert "standing phase" in doc["upright_reference"]["source"]  # the stance at the end, found anywhere


def test_baseline_and_paper_keys_round_trip(tmp_path) -> None:
    from walkmon.tables import read_indicators, write_indicators

    model = GaitModel("left_shoulder_down", 16.0, seed=1)
    t = np.arange(0.0, model.duration_s, 1 / FPS)
    ind = analyze_session(t, model.truth_angles_deg(t)).indicators
    write_indicators(tmp_path / "i.json", ind)
    back = read_indicators(tmp_path / "i.json")
    assert back.to_dict() == ind.to_dict()
    assert back.session["summary"]["dominant_label"] == "left_shoulder_down"


# ------------------------------------------------------------------ unkind sessions through the IMU (issue 11)
def _imu_session(tmp_path, script: str, seed: int) -> tuple[dict, list[tuple], object]:
    """Simulate ``script`` (IMU only), run ``walkmon analyze --imu`` on it; (indicators.json, timeline rows
    (t, activity, label), model)."""
    import contextlib
    import io
    import json

    from walkmon.commands.cli import main
    from walkmon.simulate import simulate

    sim = simulate(tmp_path / "sim", walk=script, seed=seed, width=64, height=48, video=False, stand_s=0.0)
    out = tmp_path / "out"
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["analyze", "--imu", str(sim.imu_path), "--out", str(out)]) == 0
    doc = json.loads((out / "indicators.json").read_text())
    lines = (out / "timeline.csv").read_text().splitlines()[1:]
    rows = [(float(r.split(",")[0]), r.split(",")[1], r.split(",")[2]) for r in lines]
    return doc, rows, GaitModel(script, seed=seed, stand_s=0.0)


def test_a_dragged_foot_and_back_is_a_posture_change_with_its_labels(tmp_path) -> None:
    doc, rows, model = _imu_session(tmp_path, "stand:2,right_foot_drag:10,normal:10,pause:1.2,right_foot_drag:10,"
                                    "stand:2", seed=3)
    normal = [p for p in model.pieces if p.activity == "walking"][1]
    segs = doc["segments"]
    cuts = [b["start_s"] for a, b in zip(segs, segs[1:], strict=False) if a["label"] != b["label"] and
            b["start_s"] - a["end_s"] < 2.0]
    assert any(abs(c - normal.start_s) < 1.5 for c in cuts)  # the sway halves at the same inclination
    for p in (q for q in model.pieces if q.activity == "walking"):
        mid = 0.5 * (p.start_s + p.end_s)
        (seg,) = [s for s in segs if s["start_s"] <= mid <= s["end_s"]]
        assert seg["label"] == p.label
    drag_seg = next(s for s in segs if s["label"] == "right_foot_drag")
    assert drag_seg["asymmetry"]["step_time_ratio"] > 1.1  # on alternating-step evidence, not sway alone
    # the pause inside the second bout: standing in the timeline; the bout keeps it (pauses < 3 s join bouts)
    pause = next(p for p in model.pieces if p.activity == "standing" and 10 < p.start_s < model.duration_s - 5)
    inside = [a for t, a, _ in rows if pause.start_s + 0.6 < t < pause.end_s - 0.6]
    assert inside and set(inside) == {"standing"}
    assert any(b["start_s"] < pause.start_s and pause.end_s < b["end_s"] for b in doc["bouts"])
    # every bout carries its asymmetry (documented; it was missing): its segments', weighted by their durations,
    # so the dragged foot's bout shows the long right steps too
    for b in doc["bouts"]:
        inside = [s for s in segs if b["start_s"] <= s["start_s"] and s["end_s"] <= b["end_s"]]
        vals = [(s["end_s"] - s["start_s"], s["asymmetry"]["step_time_ratio"]) for s in inside
                if s["asymmetry"].get("step_time_ratio") is not None]
        want = sum(w * v for w, v in vals) / sum(w for w, _ in vals)
        assert b["asymmetry"]["step_time_ratio"] == pytest.approx(want, abs=1e-3)
    assert doc["bouts"][0]["asymmetry"]["step_time_ratio"] > 1.1  # the first bout: dragged foot, then normal


def test_the_stance_after_a_walk_measures_the_sensors_tilt_from_the_accelerometer(tmp_path) -> None:
    # Mid-walk start, a 3.5 s stop, walking on: the stop is the upright stance. The attitude filter's gravity lags
    # seconds behind the stop (its median over the stance read -3.0 deg where the still trunk and sensor were at
    # -0.4), and every inclination after it carried that: the second walk read +2.75 deg, truly -0.3.
    import csv

    doc, _, _ = _imu_session(tmp_path, "normal:10,pause:3.5,normal:15", seed=1)
    with (tmp_path / "sim" / "truth_timeline.csv").open() as fh:
        truth = [(float(r["t"]), float(r["trunk_pitch"])) for r in csv.DictReader(fh)]
    ref = doc["upright_reference"]
    assert ref["source"].startswith("first standing phase")
    t0, t1 = (float(v) for v in ref["source"].split()[3].split("-"))
    stance = [p for t, p in truth if t0 <= t <= t1]
    assert ref["pitch_deg"] == pytest.approx(float(np.mean(stance)), abs=0.6)  # + the accelerometer's bias
    last = doc["segments"][-1]
    walk = [p for t, p in truth if last["start_s"] <= t <= last["end_s"]]
    assert last["axes"]["pitch"]["inclination_mean"] == pytest.approx(float(np.mean(walk)), abs=0.75)
    # the saved analysis' report measures the stance the same way (review: it went back to -3.03 / +2.75 deg)
    import contextlib
    import io
    import json

    from walkmon.commands.cli import main

    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["analyze", "--imu", str(tmp_path / "sim" / "imu.csv"), "--out", str(tmp_path / "o2"), "--save",
                     "--data-dir", str(tmp_path / "db")]) == 0
        assert main(["report", "1", "--data-dir", str(tmp_path / "db"), "--out", str(tmp_path / "rep")]) == 0
    rep = json.loads((tmp_path / "rep" / "indicators.json").read_text())
    assert rep["upright_reference"]["pitch_deg"] == pytest.approx(ref["pitch_deg"], abs=0.05)
    assert rep["segments"][-1]["axes"]["pitch"]["inclination_mean"] == pytest.approx(
        last["axes"]["pitch"]["inclination_mean"], abs=0.1)


@pytest.mark.parametrize("seed", [1, 2])
def test_a_limp_seen_across_stops_is_labelled_on_the_bouts_evidence_together(tmp_path, seed: int) -> None:
    """Three short walks with a dragged foot, 4 s stops between them (three bouts): each has two steady pairs of
    alternating steps, under the 3 the classifier needs, so each alone stays ``unclassified``; the same posture
    across the stops is labelled on their pooled evidence (a limp is the walker's, not the bout's)."""
    doc, _, model = _imu_session(tmp_path, "stand:2,right_foot_drag:7,stand:4,right_foot_drag:7,stand:4,"
                                 "right_foot_drag:7,stand:2", seed=seed)
    assert len(doc["bouts"]) == 3
    walks = [p for p in model.pieces if p.activity == "walking"]
    for p in walks:
        mid = 0.5 * (p.start_s + p.end_s)
        (seg,) = [s for s in doc["segments"] if s["start_s"] <= mid <= s["end_s"]]
        assert seg["asymmetry"]["step_time_n_pairs"] < 3  # too few on its own
        assert seg["label"] == "right_foot_drag", seg["reasons"]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_normal_walks_across_stops_pooled_get_no_pathology_label(tmp_path, seed: int) -> None:
    """The same three short walks and stops, walked normally by a trunk that pitches differently on its left and
    right steps (lr:2): pooled across the bouts, still no pathology label. (Their swing, 8-13 deg, stays under the
    16 deg the foot-drag rule asks, so this guards the inclination labels; the step-time evidence's false alarms
    are the unit test's above.)"""
    doc, _, _ = _imu_session(tmp_path, "lr:2,stand:2,normal:7,stand:4,normal:7,stand:4,normal:7,stand:2", seed=seed)
    assert len(doc["bouts"]) == 3
    assert {s["label"] for s in doc["segments"]} <= {"normal", "unclassified"}


def _pooled_drag_rate(
    n_bouts: int, n_steps: int, long_s: float, short_s: float, trials: int = 400, *,
    interval_sd: float = 0.03, jitter_sd: float = 0.0,
) -> float:
    """How often :func:`walkmon.gait.session._pooled_alternation` gives the classifier's foot-drag evidence (ratio
    >= ``drag_step_time_ratio`` and a 95 % interval above 1) for ``n_bouts`` stretches of ``n_steps`` steps, one
    per bout (stops between: each bout's leading foot drawn at random), whose intervals alternate ``long_s`` and
    ``short_s`` with ``interval_sd`` of independent noise each (a walker's own variability) and whose step times
    then carry ``jitter_sd`` of independent noise each (where a detector places the step)."""
    from walkmon.gait.posture import PostureThresholds
    from walkmon.gait.session import _pooled_alternation

    rng = np.random.default_rng(7)
    th = PostureThresholds()
    hits = 0
    for _ in range(trials):
        spans, arrays, t0 = [], [], 0.0
        for _ in range(n_bouts):
            lead = int(rng.integers(2))
            d = np.array([long_s if (i + lead) % 2 == 0 else short_s for i in range(n_steps - 1)])
            st = t0 + np.concatenate([[0.0], np.cumsum(d + rng.normal(0.0, interval_sd, d.size))])
            st = st + rng.normal(0.0, jitter_sd, st.size)
            arrays.append(st)
            spans.append((st[0] - 0.01, st[-1] + 0.01))
            t0 = st[-1] + 5.0
        r = _pooled_alternation(spans, list(range(n_bouts)), arrays, np.concatenate(arrays))
        hits += bool(r["ratio"] >= th.drag_step_time_ratio and r["ratio_ci_low"] > 1.0)
    return hits / trials


def test_pooling_across_stops_keeps_the_false_alarm_rate_of_a_95_percent_interval() -> None:
    """Symmetric steps in three bouts of two pairs each: each bout's side is chosen to agree with the others, which
    can only favour a difference, so the interval is widened for those choices. Without that, 6.5 % of such
    symmetric walks had the evidence of a dragged foot; the bound is the interval's own 2.5 % (one-sided) with
    room for the 400 draws. A real limp (0.61 / 0.49 s, ratio 1.24) is still found in nearly every draw."""
    assert _pooled_drag_rate(3, 5, 0.55, 0.55) <= 0.04
    assert _pooled_drag_rate(3, 5, 0.61, 0.49) >= 0.9


def _single_drag_rate(n_steps: int, long_s: float, short_s: float, trials: int = 800) -> float:
    """How often the one-stretch evidence (:func:`walkmon.gait.session._steps_asymmetry`) says a foot drags, for
    steps whose durations alternate ``long_s`` / ``short_s`` with 15 ms of a walker's own variability each and
    whose detected times each carry 30 ms of timing error."""
    from walkmon.gait.posture import PostureThresholds
    from walkmon.gait.session import _steps_asymmetry

    rng = np.random.default_rng(11)
    th = PostureThresholds()
    hits = 0
    for _ in range(trials):
        d = np.array([long_s if i % 2 == 0 else short_s for i in range(n_steps - 1)])
        d = d + rng.normal(0.0, 0.015, d.size)
        r = _steps_asymmetry(np.concatenate([[0.0], np.cumsum(d)]) + rng.normal(0.0, 0.03, n_steps))
        hits += bool(r["ratio"] >= th.drag_step_time_ratio and r["ratio_ci_low"] > 1.0)
    return hits / trials


def test_a_detectors_timing_error_on_each_step_is_no_limp() -> None:
    """A detector's timing error on one step shortens one interval and lengthens the next (neighbouring intervals'
    errors correlate -0.5), which an interval fit taking them as independent reads as alternation: symmetric
    steps with 30 ms of such error passed the foot-drag evidence 11 % (one stretch of 12 steps) and 12 % (two
    bouts of 10) of the time, against the 95 % interval's 5 %. Fitted on the step times, within that 5 %
    (bounds with room for the draws); a real limp (ratio 1.2 and 1.24) is still found."""
    assert _single_drag_rate(12, 0.55, 0.55) <= 0.07
    assert _single_drag_rate(20, 0.60, 0.50) >= 0.8
    assert _pooled_drag_rate(2, 10, 0.55, 0.55, 600, interval_sd=0.01, jitter_sd=0.03) <= 0.075
    assert _pooled_drag_rate(2, 10, 0.61, 0.49, 300, interval_sd=0.01, jitter_sd=0.03) >= 0.9


def test_sitting_is_not_standing_and_not_the_upright_reference(tmp_path) -> None:
    doc, rows, model = _imu_session(tmp_path, "stand:1,sit:10,pause:1.5,normal:12,stand:2", seed=3)
    sit = next(p for p in model.pieces if p.activity == "unknown")
    # this seat reclines 27 deg: clear of the 20 deg still-tilt limit by more than the attitude error (~3 deg)
    assert abs(model.body_angles_deg([0.5 * (sit.start_s + sit.end_s)])[0, 0]) > 25.0
    seated = [a for t, a, _ in rows if sit.start_s + 2.5 < t < sit.end_s - 2.5]
    assert seated and set(seated) == {"unknown"}
    assert "first standing phase" in doc["upright_reference"]["source"]
    # no walking while seated (standing up, the last 1.5-2.5 s, can still be taken for the walk's first steps:
    # the bout assembly keeps irregular leading steps; see the report of issue 11)
    assert not any(s["start_s"] < sit.end_s - 2.5 and sit.start_s < s["end_s"] for s in doc["bouts"])
    assert {s["label"] for s in doc["segments"]} == {"normal"}  # the seat's 22-35 deg is not read as a bend


def test_bending_down_to_pick_something_up_is_no_walk(tmp_path) -> None:
    doc, rows, model = _imu_session(tmp_path, "stand:2,pickup:4,pause:2,normal:10,stand:2", seed=4)
    pick = next(p for p in model.pieces if p.activity == "unknown")
    assert not any(b["start_s"] < pick.end_s and pick.start_s < b["end_s"] for b in doc["bouts"])
    assert "walking" not in {a for t, a, _ in rows if pick.start_s + 0.5 < t < pick.end_s - 0.5}


# ------------------------------------------------- video drift across turns: re-reference or do not label
def _drifted_after_u_turn(walk: str, end_s: float | None) -> tuple[np.ndarray, np.ndarray, GaitModel]:
    """A walk with a U-turn at 12-14.5 s whose video orientation picks up a 5 deg error in the turn (what fast
    turns do to a 320x240 video estimate; it reads as a left tilt of the trunk afterwards); cut at ``end_s``
    (mid-walk, no standing after the turn) or, for None, ending with the model's 2 s of standing."""
    model = GaitModel(walk, 30.0, seed=6)
    t = np.arange(0.0, model.duration_s, 1 / FPS)
    a = _turning(t, model.truth_angles_deg(t), [(12.0, 14.5, 180.0)])
    a[:, 2] += 5.0 * np.clip((t - 12.0) / 2.5, 0, 1)  # camera roll error; heading-free it is a left tilt
    keep = t <= end_s if end_s is not None else np.ones(t.size, bool)
    return t[keep], a[keep], model


#: the drift model alone: the camera assumed level (gravity's direction from the turns is tested below and in
#: test_mount_tilt.py; from one turn it would take this drift for the camera's tilt on the trunk)
LEVEL = SessionSettings(turn_vertical=False)


def test_a_turn_without_standing_after_it_gives_no_label_that_its_drift_could_make() -> None:
    t, a, _ = _drifted_after_u_turn("normal", 26.0)
    doc = analyze_session(t, a, session_settings=LEVEL).indicators.to_dict()
    before, after = doc["segments"][0], doc["segments"][-1]
    assert before["end_s"] <= 12.0 and after["start_s"] >= 14.5
    assert before["label"] == "normal"
    assert after["axes"]["roll"]["inclination_mean"] < -3.0  # the drift reads as a left shoulder down ...
    assert after["label"] == "unclassified"  # ... but the reference is not trusted there
    assert "uncertain across the turn at t=1" in after["reasons"][0]
    assert "left_shoulder_down" not in {s["label"] for s in doc["segments"]}
    assert "uncertain" in doc["upright_reference"]["source"]


@pytest.mark.parametrize("walk", ["normal", "left_shoulder_down"])
def test_gravity_from_one_turn_takes_its_drift_for_the_mount_and_is_not_trusted(walk: str) -> None:
    t, a, _ = _drifted_after_u_turn(walk, 26.0)
    doc = analyze_session(t, a).indicators.to_dict()
    vert = doc["upright_reference"]["vertical"]
    # half the 5 deg drift tilts the turn's axis: within 3 deg of the camera-level assumption, which verifies it,
    # their disagreement the direction's uncertainty
    assert vert["source"].startswith("from 1 turn") and "camera-level assumption agrees" in vert["source"]
    assert vert["uncertainty_deg"] == pytest.approx(2.5, abs=1.0)
    after = doc["segments"][-1]
    assert after["start_s"] >= 14.5
    assert after["label"] == "unclassified"  # the turn's bound widened by twice that: no label either way
    assert "gravity's direction from the turns being uncertain" in after["reasons"][0]

def test_a_standing_phase_after_the_turn_re_references_the_video() -> None:
    t, a, model = _drifted_after_u_turn("normal", None)
    doc = analyze_session(t, a).indicators.to_dict()
    after = doc["segments"][-1]
    assert after["start_s"] >= 14.5 and after["label"] == "normal"
    assert after["axes"]["roll"]["inclination_mean"] == pytest.approx(model.segments[0].roll_offset_deg, abs=1.0)
    assert "re-referenced at 1 later still phase" in doc["upright_reference"]["source"]


@pytest.mark.parametrize("walk", ["bend", "left_shoulder_down"])
def test_after_an_unreferenced_turn_only_labels_that_no_drift_within_the_bound_could_change(walk: str) -> None:
    t, a, model = _drifted_after_u_turn(walk, 26.0)
    doc = analyze_session(t, a, session_settings=LEVEL).indicators.to_dict()
    assert doc["segments"][0]["label"] == walk  # before the turn the standing start holds
    after = doc["segments"][-1]
    roll = after["axes"]["roll"]["inclination_mean"]
    assert roll == pytest.approx(model.segments[0].roll_offset_deg - 5.0, abs=1.0)  # the drift is in it
    if walk == "bend":  # bent AND (by the drift) tilted left reads left_shoulder_down; +-4 deg could make it bend
        assert after["label"] == "unclassified"
    else:  # a left tilt of ~10 deg stays below -3 deg within +-4 deg: still left_shoulder_down
        assert after["label"] == "left_shoulder_down"


def _paused(t: np.ndarray, a: np.ndarray, at: float, pause_s: float, pitch_deg: float = 0.0):
    """``t``, ``a`` with the camera held still for ``pause_s`` at ``at`` (the stance of that moment, its pitch
    moved by ``pitch_deg``: bent forward when negative), the rest of the walk after it."""
    i = int(np.searchsorted(t, at))
    held = np.repeat(a[i : i + 1], int(round(pause_s * FPS)), axis=0)
    held[:, 0] += pitch_deg
    return (np.concatenate([t[:i], at + np.arange(held.shape[0]) / FPS, t[i:] + pause_s]),
            np.concatenate([a[:i], held, a[i:]]))


def test_a_short_pause_inside_a_bout_re_references_the_video_after_a_turn() -> None:
    """A pause shorter than a bout break (< 3 s: the bout goes on, the activity reads walking) is still standing:
    the stance it holds re-references the straight stretch it lies in, as a long standing phase would."""
    t, a, model = _drifted_after_u_turn("normal", 26.0)
    # standing still in the (normal, upright) walking stance; the still part of a pause is ~1 s shorter than it
    # (the closing and first steps move the trunk) and a re-reference needs 0.5 s of it: ~1.5 s is the shortest
    # pause that does, give or take a hop with the frame the angles are in (1.5 s did with the start-relative
    # angles, 1.6 s does in the level frame of gravity's direction from the turn)
    t2, a2 = _paused(t, a, 18.0, 1.6)
    doc = analyze_session(t2, a2).indicators.to_dict()
    assert len(doc["bouts"]) == 1  # the pause does not end the bout
    after = [s for s in doc["segments"] if s["start_s"] >= 14.5]
    assert after and all(s["label"] == "normal" for s in after)
    for s in after:  # the turn's 5 deg roll error is gone: the truth's roll offset
        assert s["axes"]["roll"]["inclination_mean"] == pytest.approx(model.segments[0].roll_offset_deg, abs=1.0)
    assert "re-referenced at 1 later still phase" in doc["upright_reference"]["source"]


def test_a_still_phase_bent_down_after_the_turn_is_no_re_reference() -> None:
    """Still, but 15 deg from the upright stance (bent down to look at something): not the same stance, so its
    angles are not taken for the video's drift and the stretch stays without a trusted reference."""
    t, a, _ = _drifted_after_u_turn("normal", 26.0)
    t2, a2 = _paused(t, a, 18.0, 1.5, pitch_deg=-15.0)
    doc = analyze_session(t2, a2).indicators.to_dict()
    assert "re-referenced" not in doc["upright_reference"]["source"]
    after = [s for s in doc["segments"] if s["start_s"] >= 14.5]
    assert after and all(s["label"] == "unclassified" for s in after)


@pytest.mark.parametrize("walk", ["left_shoulder_down", "bend", "normal"])
def test_a_short_video_walk_counts_its_detected_steps_for_the_label(walk: str) -> None:
    """Video: a segment's step count for the classifier's 8-step minimum counts its detected steps, as with an
    IMU, not only its complete pitch cycles (two fewer: the edge cycles are cut): a 6.5 s walk of 8-10 true steps
    is labelled, and its step count is the truth's."""
    model = GaitModel(f"{walk}:6.5", seed=1)
    t = np.arange(0.0, model.duration_s, 1 / FPS)
    doc = analyze_session(t, model.truth_angles_deg(t)).indicators.to_dict()
    (seg,) = doc["segments"]
    steps, _ = model.step_times_s()
    true_n = int(np.sum((steps >= seg["start_s"] - 0.3) & (steps <= seg["end_s"] + 0.3)))
    assert true_n >= 8
    assert seg["asymmetry"]["n_steps"] == pytest.approx(true_n, abs=1)
    assert seg["label"] == walk


def _mid_walk(model: GaitModel, t0: float, t1: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Time, start-relative angles and true trunk pitch/roll (gravity) of the model's walk between t0 and t1."""
    t = np.arange(0.0, model.duration_s, 1 / FPS)
    a = model.truth_angles_deg(t)
    keep = (t >= t0) & (t <= t1)
    c = rotation_from_angles_deg(a[keep, 0], a[keep, 1], a[keep, 2])
    rel = angles_deg_from_rotation(np.einsum("ji,njk->nik", c[0], c))
    return t[keep] - t0, rel, a[keep][:, [0, 2]]


def test_an_imu_tilted_on_the_trunk_gives_no_bend_label_without_a_standing_phase() -> None:
    # A healthy upright walk, recorded from mid-walk to mid-walk (no standing phase anywhere) by a sensor that
    # sits 12 deg pitched down on the trunk (a lower-back sensor on the pelvis, a camera hanging off its strap):
    # gravity reads the trunk 12 deg bent. Without a standing phase or baseline that tilt is unknown, so neither
    # bend (the measured pitch) nor normal (the truth) may be claimed: unclassified, with the reason.
    model = GaitModel("normal", 30.0, seed=11)
    t, rel, truth = _mid_walk(model, 4.0, 28.0)
    tilted = truth + np.array([-12.0, 0.0])
    doc = analyze_session(t, rel, abs_angles_deg=tilted).indicators.to_dict()
    assert doc["upright_reference"]["source"].startswith("gravity")
    assert doc["walking_s"] > 15.0
    labels = {s["label"] for s in doc["segments"]}
    assert labels == {"unclassified"}, labels
    assert any("tilt on the trunk" in r for s in doc["segments"] for r in s["reasons"])
    assert doc["summary"]["dominant_label"] != "bend"


def test_a_standing_phase_measures_the_sensors_tilt_on_the_trunk() -> None:
    # The same tilted sensor with the walk's standing start and end: the standing phase is the reference, the
    # tilt cancels and the walk is labelled what it truly is.
    model = GaitModel("normal", 24.0, seed=11)
    t = np.arange(0.0, model.duration_s, 1 / FPS)
    a = model.truth_angles_deg(t)
    doc = analyze_session(t, a, abs_angles_deg=a[:, [0, 2]] + np.array([-12.0, 0.0])).indicators.to_dict()
    assert doc["upright_reference"]["source"].startswith("first standing phase")
    assert doc["classification"]["label"] == "normal"
    assert doc["axes"]["pitch"]["inclination_mean"] == pytest.approx(0.0, abs=1.5)


def test_a_pause_mid_walk_measures_the_sensors_tilt_without_a_standing_phase() -> None:
    # Mid-walk to mid-walk with one 2 s pause, the sensor 12 deg pitched on the trunk: the still part of the
    # pause (shorter than a standing phase) is the wearer's upright stance, the tilt cancels and the walk is
    # labelled what it truly is.
    model = GaitModel("normal:12,pause:2,normal:12", seed=11)
    t, rel, truth = _mid_walk(model, 4.0, model.duration_s - 4.0)
    doc = analyze_session(t, rel, abs_angles_deg=truth + np.array([-12.0, 0.0])).indicators.to_dict()
    assert doc["upright_reference"]["source"].startswith("first still pause")
    assert {s["label"] for s in doc["segments"]} == {"normal"}
    assert doc["axes"]["pitch"]["inclination_mean"] == pytest.approx(0.0, abs=1.5)


def test_timeline_qualifies_a_pitch_the_turns_alone_carry() -> None:
    # Mid-walk to mid-walk, no standing phase: upright, then bent 15 deg, a U-turn, then upright again. Whether
    # the trunk straightened in the turn or the camera sits tilted on it, the one turn cannot tell (the
    # analysis withholds the labels after it). The timeline's pitch there is off by the turn's ambiguity, and
    # its ref_uncertainty_deg column says by about how much: on 10 seeds the true trunk pitch and roll (1 s
    # means, as the column's) lie within that bound plus 2 deg, the error of the reference itself. Before the
    # turn, where the column reads 0, the reference is the first stride's median pose: within 1.5 deg of the
    # truth. (The first frame alone caught the walk's sway: up to 3.0 deg off on 30 seeds, median 1.0; the
    # first stride's median: 1.3 and 0.37. After the turn 77 % of the seconds lie within the bound alone.)
    worst = -np.inf
    for seed in range(10):
        model = GaitModel("normal:8,bend:8,turn:-180,normal:14", seed=seed)
        t, rel, _ = _mid_walk(model, 3.0, model.duration_s - 1.0)
        res = analyze_session(t, rel)
        (turn,) = [u for u in res.segmentation.turns if abs(u.angle_deg) > 90]
        body = model.body_angles_deg(t + 3.0)
        after = before = 0
        for g, activity, label, pitch, roll, unc in res.timeline:
            if activity != "walking":
                continue
            m = (t >= g - 0.5) & (t < g + 0.5)
            if g < turn.start_s - 1.0:
                assert unc == 0.0
                err = max(abs(pitch - body[m, 0].mean()), abs(roll - body[m, 2].mean()))
                assert err <= 1.5, (seed, g, err)
                before += 1
            elif g > turn.end_s + 2.0:
                assert label == "unclassified"
                assert unc > 3.0  # more than the classifier's normal range: the pitch alone says nothing
                err = max(abs(pitch - body[m, 0].mean()), abs(roll - body[m, 2].mean()))
                worst = max(worst, err - unc)
                after += 1
        assert before >= 8 and after >= 8, seed
    assert worst <= 2.0


def test_a_recording_that_starts_with_a_pick_up_keeps_the_first_frame_as_upright() -> None:
    # No standing phase anywhere, and the recording starts as the wearer bends down to pick something up: the
    # first stride's median pose would be the bend (review: 37.6 deg off), so the first frame stays the
    # reference: every measured walking second within 1.5 deg of the simulator's true trunk posture.
    for seed in range(5):
        model = GaitModel("normal:5,pickup:3,normal:14", seed=seed)
        t, rel, _ = _mid_walk(model, 5.0, model.duration_s - 1.0)
        res = analyze_session(t, rel)
        assert res.indicators.to_dict()["upright_reference"]["source"].startswith("first frame")
        body = model.body_angles_deg(t + 5.0)
        for g, activity, _label, pitch, roll, unc in res.timeline:
            if activity != "walking" or unc > 0:
                continue
            m = (t >= g - 0.5) & (t < g + 0.5)
            assert max(abs(pitch - body[m, 0].mean()), abs(roll - body[m, 2].mean())) <= 1.5, (seed, g)


def test_a_pause_whose_stance_reads_far_off_makes_the_walk_around_it_uncertain() -> None:
    """The video's rotation error in turns comes and goes: on an unkind simulated session a 1.2 s pause after two
    turns read 6.7 / -8.5 deg off the upright stance and the standing 8 s later 1.9 / -0.3 deg, which alone
    re-referenced that stretch, so its bent walk read roll -9 deg: left shoulder down. Here the true angles of a
    walk are off by +6 / -10 deg (pitch / roll) from a turn until shortly before the final standing: the pause
    between reads so, too far for a drift to be taken (``max_drift_deg``), and the walk around it in that stretch
    must carry that much doubt (it carried none), with the reason; before the turn, none."""
    from walkmon.gait.activity import segment, signals_from_angles
    from walkmon.gait.session import DEFAULT_SESSION_SETTINGS, _reference_model

    model = GaitModel("stand:2,bend:6,turn:90,bend:6,pause:1.5,bend:6,stand:2", seed=3)
    t = np.arange(0.0, model.duration_s, 1 / FPS)
    a = model.truth_angles_deg(t)
    seg = segment(signals_from_angles(t, a))
    turn_end = next(s.end_s for s in model.segments if s.walk == "turn")
    off = (t > turn_end) & (t < model.segments[-1].start_s - 1.5)
    a[off, 0] += 6.0
    a[off, 2] -= 10.0
    _, unc, _ = _reference_model(t, a, seg, (0.0, 2.0), DEFAULT_SESSION_SETTINGS)
    walk_after = (t > turn_end + 1.0) & (t < model.segments[-1].start_s - 0.5)
    walk_before = (t > 2.5) & (t < turn_end - 1.5)
    assert np.all(unc.deg[walk_after] >= np.array([5.5, 9.5]))
    assert np.all(unc.deg[walk_before] == 0.0)
    assert any("pause at" in r and "+6.0 / -10.0" in r for r in unc.reasons)


def test_a_posture_between_two_stretches_of_another_is_its_own_segment() -> None:
    """An unkind session (held-out seed 10 of the benchmark): left shoulder down 7.2 s, normal 6.4 s, left shoulder
    down 7.3 s in one straight stretch. Every single split leaves each side's median in the outer posture, so
    binary segmentation read it as one 20 s left-shoulder-down segment and labelled the normal walk so; the
    circular binary segmentation's second look finds the normal walk between (on the true angles, so this is the
    segmentation alone)."""
    walk = ("mount:-16.9:0.7,lr:0.4,left_shoulder_down:6.5,pause:3.7,left_shoulder_down:7.2,normal:6.4,"
            "left_shoulder_down:7.3,turn:180,left_shoulder_down:4.8")
    model = GaitModel(walk, seed=10)
    t = np.arange(0.0, model.duration_s, 1 / FPS)
    doc = analyze_session(t, model.truth_angles_deg(t)).indicators.to_dict()
    normal = next(s for s in model.segments if s.walk == "normal")
    found = [s for s in doc["segments"] if s["label"] == "normal"]
    assert len(found) == 1
    assert found[0]["start_s"] == pytest.approx(normal.start_s, abs=1.5)
    assert found[0]["end_s"] == pytest.approx(normal.end_s, abs=1.5)
    for s in doc["segments"]:  # the left-shoulder-down walk either side keeps its label
        if s["end_s"] < normal.start_s - 1.0 or s["start_s"] > normal.end_s + 1.0:
            assert s["label"] in ("left_shoulder_down", "unclassified")


def test_the_search_for_a_segment_stays_small_on_a_long_straight_walk() -> None:
    """The second look searches pairs of split positions, whose number grows as the square of a piece's length:
    on a 10-minute straight walk every position 0.1 s apart took 5 GB. Candidates are thinned on long pieces and
    refined about the best pair: a 10 s normal walk between 200 s stretches of left shoulder down is still found
    to within 1.5 s, and the search holds little memory."""
    import tracemalloc

    from walkmon.gait.session import change_points

    model = GaitModel("left_shoulder_down:200,normal:10,left_shoulder_down:200", seed=2)
    t = np.arange(0.0, model.duration_s, 1 / FPS)
    a = model.truth_angles_deg(t)
    walk = (t > 5.0) & (t < model.duration_s - 5.0)
    tracemalloc.start()
    try:
        cps = change_points(t[walk], a[walk])
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    normal = next(s for s in model.segments if s.walk == "normal")
    assert len(cps) == 2
    assert cps[0] == pytest.approx(normal.start_s, abs=1.5) and cps[1] == pytest.approx(normal.end_s, abs=1.5)
    assert peak < 200e6


@pytest.mark.parametrize(("script", "seed", "walk"), [
    ("stand:2,normal:12,sit:8,normal:12,stand:2", 3, "normal"),
    ("stand:2,left_shoulder_down:12,pickup:3,left_shoulder_down:12,stand:2", 4, "left_shoulder_down"),
    ("stand:2,normal:8,turn:90,normal:8,sit:8,normal:8,stand:2", 5, "normal"),
])
def test_sitting_or_picking_up_between_walks_is_a_posture_not_the_videos_error(
        script: str, seed: int, walk: str) -> None:
    """A still phase far from upright beside walking is not a pause whose stance reads off: sitting reads 22-35
    deg and a pick-up 45-75 deg, a posture, and before any turn no turn's error can come and go. On the true
    angles (no video error at all) the walks either side keep their labels (the first form of the rule made them
    all unclassified, with 25-45 deg of doubt)."""
    model = GaitModel(script, seed=seed)
    t = np.arange(0.0, model.duration_s, 1 / FPS)
    doc = analyze_session(t, model.truth_angles_deg(t)).indicators.to_dict()
    labelled = [s for s in doc["segments"] if s["label"] != "unclassified"]
    assert {s["label"] for s in labelled} == {walk}
    assert not any("a pause at" in r for s in doc["segments"] for r in s["reasons"])


def test_the_standing_that_opens_and_closes_a_recording_is_reported(tmp_path) -> None:  # noqa: ANN001
    """A simulated walk with 3 s of standing before and after: indicators.json's standing_start_s and
    standing_end_s (null in the session analysis before; the report's 'standing at start' a dash) span the
    truth's standing within a step; a walk that starts mid-walk has no standing at its start."""
    import walkmon
    from walkmon.commands.cli import main
    from walkmon.tables import read_table

    for script, opens in (("stand:3,normal:10,stand:3", True), ("normal:6,pause:1,normal:4,stand:3", False)):
        sim = tmp_path / script.replace(":", "_").replace(",", "-")
        assert main(["simulate", "--no-video", "--walk", script, "--seed", "2", "--out", str(sim)]) == 0
        truth = read_table(sim / "truth_timeline.csv", ("t",))["t"]
        activity = [ln.split(",")[1] for ln in (sim / "truth_timeline.csv").read_text().splitlines()[1:]]
        walking = truth[[a == "walking" for a in activity]]
        ind = walkmon.analyze(imu=sim / "imu.csv").indicators
        if opens:
            assert ind["standing_start_s"][0] == pytest.approx(0.0, abs=0.05)
            assert ind["standing_start_s"][1] == pytest.approx(walking[0], abs=0.6)
        else:
            assert ind["standing_start_s"] is None
        assert ind["standing_end_s"][0] == pytest.approx(walking[-1], abs=0.6)
        assert ind["standing_end_s"][1] == pytest.approx(truth[-1], abs=0.1)
