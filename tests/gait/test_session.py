"""Session analysis (walkmon.gait.session): posture segments, turns, upright reference, timeline, summary."""

from __future__ import annotations

import numpy as np
import pytest

from walkmon.consts import angles_deg_from_rotation, rot_y, rotation_from_angles_deg
from walkmon.gait.session import analyze_session
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
