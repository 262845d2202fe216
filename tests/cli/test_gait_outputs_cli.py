"""walkmon analyze/indicators gait outputs: timeline.csv, bouts/segments in indicators.json, accelerometer-only."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from walkmon.commands.cli import main
from walkmon.simulate.gait import GaitModel
from walkmon.tables import read_table, write_table

G = 9.80665


def _acc_walk(path: Path, *, seconds_walk: float = 20.0, step_s: float = 0.6) -> int:
    """t,ax,ay,az of a trunk accelerometer: 3 s standing, walking, 3 s standing; returns the true step count."""
    rng = np.random.default_rng(0)
    t = np.arange(0.0, seconds_walk + 6.0, 0.01)
    vert = np.zeros_like(t)
    steps = np.arange(3.0 + step_s / 2, 3.0 + seconds_walk, step_s)
    for s in steps:
        m = np.abs(t - s) < step_s / 2
        vert[m] += 2.0 * np.cos(2 * np.pi * (t[m] - s) / step_s)
    up = np.array([0.0, -np.cos(0.2), np.sin(0.2)])  # a neck pouch tilted ~11 deg
    acc = (G + vert)[:, None] * up + rng.normal(0, 0.1, (t.size, 3))
    write_table(path, {"t": t, "ax": acc[:, 0], "ay": acc[:, 1], "az": acc[:, 2]})
    return steps.size


def test_analyze_accelerometer_only(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    n_true = _acc_walk(tmp_path / "acc.csv")
    assert main(["analyze", "--imu", str(tmp_path / "acc.csv"), "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert "no yaw" in out and "timeline.csv" in out
    n_rows = len((tmp_path / "acc.csv").read_text().splitlines()) - 1
    # the file's samples counted as such (user review: it printed the output's rows as 'accelerometer rows')
    assert f"{n_rows} accelerometer samples (100 Hz" in out
    doc = json.loads((tmp_path / "out" / "indicators.json").read_text())
    assert doc["schema_version"] == 2
    assert doc["input"]["activity_from"] == "accelerometer only"
    assert doc["axes"]["yaw"]["swing_mean"] is None
    assert any("no yaw" in n for n in doc["input"]["notes"])
    assert doc["summary"]["n_bouts"] == 1
    assert doc["summary"]["n_steps"] == pytest.approx(n_true, abs=2)
    assert doc["cadence_spm"] == pytest.approx(100.0, rel=0.01)
    angles = read_table(tmp_path / "out" / "angles.csv", ("t", "pitch", "roll", "pitch_abs", "roll_abs"))
    assert np.all(np.isnan(angles["yaw"]))  # no yaw without a gyroscope, said as empty values, not zeros
    timeline = (tmp_path / "out" / "timeline.csv").read_text().splitlines()
    assert timeline[0] == "t,activity,label,pitch,roll,ref_uncertainty_deg"
    rows = [r.split(",") for r in timeline[1:]]
    assert rows[1][1] == "standing" and rows[10][1] == "walking"
    assert {float(r[5]) for r in rows} == {0.0}  # the standing start measured the sensor's tilt: nothing uncertain
    assert len(rows) == pytest.approx(26, abs=1)


def test_analyze_acc_file_with_a_video_or_bad_rows_is_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # a repeated row is skipped and counted as imu.csv's are (it was refused for it: 'must strictly increase');
    # t in whole seconds is not an IMU's: refused for that, one line
    (tmp_path / "bad.csv").write_text("t,ax,ay,az\n0,1,2,3\n0,1,2,3\n" + "".join(f"{i},1,2,3\n" for i in range(1, 12)))
    assert main(["analyze", "--imu", str(tmp_path / "bad.csv"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "sampled at 10 Hz or more" in err and len(err.strip().splitlines()) == 1, err


def test_indicators_writes_timeline_and_segments_and_paper_mode_keeps_the_whole_recording(tmp_path: Path) -> None:
    model = GaitModel("normal:8,bend:8", seed=2)
    t = np.arange(0.0, model.duration_s, 1 / 30)
    a = model.truth_angles_deg(t)
    write_table(tmp_path / "angles.csv", {"t": t, "pitch": a[:, 0], "yaw": a[:, 1], "roll": a[:, 2]})
    assert main(["indicators", str(tmp_path / "angles.csv"), "--out", str(tmp_path / "w")]) == 0
    doc = json.loads((tmp_path / "w" / "indicators.json").read_text())
    assert [s["label"] for s in doc["segments"]] == ["normal", "bend"]
    assert (tmp_path / "w" / "timeline.csv").is_file()
    assert main(["indicators", str(tmp_path / "angles.csv"), "--out", str(tmp_path / "p"), "--mode", "paper"]) == 0
    paper = json.loads((tmp_path / "p" / "indicators.json").read_text())
    assert paper["mode"] == "paper" and "segments" not in paper
    assert not (tmp_path / "p" / "timeline.csv").exists()


def test_accelerometer_only_inclinations_are_gravitys_against_truth(tmp_path: Path) -> None:
    """A phone's accelerometer alone has no swing to take cycles of: each segment's pitch inclination is the mean
    gravity pitch over it (it was null for a normal stretch and the session's was the bent stretch's alone)."""
    sim = tmp_path / "sim"
    assert main(["simulate", "--walk", "normal:8,bend:6", "--seed", "3", "--no-video", "--no-progress",
                 "--out", str(sim)]) == 0
    imu = read_table(sim / "imu.csv", ("t", "ax", "ay", "az"))
    write_table(tmp_path / "acc.csv", {k: imu[k] for k in ("t", "ax", "ay", "az")})
    assert main(["analyze", "--imu", str(tmp_path / "acc.csv"), "--out", str(tmp_path / "out")]) == 0
    doc = json.loads((tmp_path / "out" / "indicators.json").read_text())
    truth = read_table(sim / "truth.csv", ("t", "pitch"))
    still = truth["t"] < 1.5
    segs = doc["segments"]
    assert len(segs) == 2
    weights, incl = [], []
    for s in segs:
        m = (truth["t"] >= s["start_s"]) & (truth["t"] <= s["end_s"])
        true = float(np.mean(truth["pitch"][m]) - np.median(truth["pitch"][still]))
        got = s["axes"]["pitch"]["inclination_mean"]
        assert got == pytest.approx(true, abs=1.5), (s["start_s"], got, true)
        assert s["axes"]["pitch"]["swing_mean"] is None  # not measured from gravity, not made up
        assert s["label"] == "unclassified" and "nan" not in s["reasons"][0]
        weights.append(s["end_s"] - s["start_s"])
        incl.append(got)
    assert doc["axes"]["pitch"]["inclination_mean"] == pytest.approx(np.average(incl, weights=weights), abs=0.05)


def test_an_imu_in_another_sensors_axes_reports_no_posture(tmp_path: Path) -> None:
    """User review: files in another sensor's own axes (Mobilise-D's x up, a phone upside down in a neck pouch)
    were analysed for posture anyway: '6 % upright' in the report and the history, pitch wrapping past -180 deg in
    timeline.csv, the axes warning on stderr and in imu.json only. Their posture is withheld everywhere; the steps,
    bouts and cadence stay."""
    sim = tmp_path / "sim"
    assert main(["simulate", "--walk", "normal:12", "--seed", "2", "--no-video", "--no-progress",
                 "--out", str(sim)]) == 0
    imu = read_table(sim / "imu.csv", ("t", "gx", "gy", "gz", "ax", "ay", "az"))
    # camera axes -> a lower-back sensor's (x up = camera -y, y = camera x, z = camera z... a proper rotation)
    turned = {"t": imu["t"], "gx": -imu["gy"], "gy": imu["gx"], "gz": imu["gz"],
              "ax": -imu["ay"], "ay": imu["ax"], "az": imu["az"]}
    write_table(tmp_path / "lowback.csv", turned)
    assert main(["analyze", "--imu", str(tmp_path / "lowback.csv"), "--out", str(tmp_path / "out"), "--save",
                 "--data-dir", str(tmp_path / "db")]) == 0
    doc = json.loads((tmp_path / "out" / "indicators.json").read_text())
    assert doc["summary"]["n_bouts"] >= 1 and doc["cadence_spm"] is not None
    assert doc["classification"]["label"] == "unclassified" and "no posture" in doc["classification"]["reasons"][0]
    assert doc["axes"]["pitch"]["inclination_mean"] is None and doc["axes"]["roll"]["inclination_mean"] is None
    assert all(s["label"] == "unclassified" for s in doc["segments"])
    assert any("camera axes' up" in n for n in doc["input"]["notes"])
    rows = [r.split(",") for r in (tmp_path / "out" / "timeline.csv").read_text().splitlines()[1:]]
    assert {r[3] for r in rows} == {"nan"} and {r[4] for r in rows} == {"nan"}
    report = (tmp_path / "out" / "report.html").read_text()
    assert "% upright" not in report and "another sensor" in report
    assert "Absolute pitch and roll" not in report and "pitch_abs mean" not in report  # (review: -88 deg printed)
    # the saved session's report, which analyses its stored IMU again (review: it had posture back, 9 % upright)
    assert main(["report", "1", "--data-dir", str(tmp_path / "db"), "--out", str(tmp_path / "rep")]) == 0
    again = json.loads((tmp_path / "rep" / "indicators.json").read_text())
    assert again["axes"]["pitch"]["inclination_mean"] is None and again["classification"]["label"] == "unclassified"
    assert "% upright" not in (tmp_path / "rep" / "report.html").read_text()
    assert "pitch_abs mean" not in (tmp_path / "rep" / "report.html").read_text()


def test_indicators_on_an_imu_analysis_angles_says_where_its_steps_come_from(
        tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """User review: 'walkmon indicators' on analyze --imu's own angles.csv gave another cadence (130.7 against
    81.6 steps/min) without a word: its steps come from the pitch, as a camera's do, not the accelerometer."""
    sim = tmp_path / "sim"
    assert main(["simulate", "--walk", "normal:10", "--seed", "4", "--no-video", "--no-progress",
                 "--out", str(sim)]) == 0
    assert main(["analyze", "--imu", str(sim / "imu.csv"), "--out", str(tmp_path / "a"), "--save", "--data-dir",
                 str(tmp_path / "db")]) == 0
    with caplog.at_level("WARNING"):
        assert main(["indicators", str(tmp_path / "a" / "angles.csv"), "--out", str(tmp_path / "i")]) == 0
    assert any("the angles of an IMU analysis" in r.getMessage() for r in caplog.records)
    # the session's export too (its model column empty on every row: review)
    assert main(["sessions", "export", "1", "--data-dir", str(tmp_path / "db"), "--out", str(tmp_path / "x")]) == 0
    caplog.clear()
    with caplog.at_level("WARNING"):
        assert main(["indicators", str(tmp_path / "x" / "angles.csv"), "--out", str(tmp_path / "i2")]) == 0
    assert any("the angles of an IMU analysis" in r.getMessage() for r in caplog.records)
