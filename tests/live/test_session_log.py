"""Session log: contents, batching, kill -9 safety, and the sessions/report commands on it."""

from __future__ import annotations

import csv
import json
import os
import signal
import sqlite3
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from walkmon.commands.cli import main
from walkmon.gait.live import CalibrationEvent, LiveIndicatorStage
from walkmon.live.alerts import AlertEvent
from walkmon.live.session_log import (
    SessionLog,
    list_sessions,
    open_database,
    read_session_table,
)
from walkmon.simulate.gait import GaitModel

FPS = 30.0


@pytest.fixture(scope="module")
def logged_session(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, int, GaitModel]:
    """A 20 s scripted walk written through the indicator stage into a session (truth angles)."""
    data = tmp_path_factory.mktemp("data")
    model = GaitModel("normal:16", seed=5)
    t = np.arange(int(model.duration_s * FPS) + 1) / FPS
    a = model.truth_angles_deg(t)
    stage = LiveIndicatorStage()
    with SessionLog(data, camera="sim:normal:16", imu="file:imu.csv", config={"alerts": {"delay_s": 5.0}}) as log:
        for ti, ai in zip(t, a, strict=True):
            log.add_frame(ti, ai, 120, "rotation", "OK", 3.0)
            if (ind := stage.push(ti, ai)) is not None:
                log.add_hop(ind)
        log.add_imu(0.005, (0.1, 0.2, 0.3), (0.0, -9.81, 0.0))
        log.add_alert(AlertEvent(12.0, "lean_forward", "raised", 12.5, 10.0, "leaning forward 12 deg"))
        log.add_calibration(CalibrationEvent(30.0, (0.5, 0.0, -0.2), "request", 2.0))
        sid = log.session_id
    return data, sid, model


def test_everything_written_is_read_back(logged_session: tuple[Path, int, GaitModel]) -> None:
    data, sid, model = logged_session
    conn = open_database(data, create=False)
    assert conn.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    frames = read_session_table(conn, sid, "frames")
    t = np.asarray(frames["t_s"])
    assert len(t) == int(model.duration_s * FPS) + 1
    assert np.allclose(frames["roll"], model.truth_angles_deg(t)[:, 2])
    assert set(frames["model"]) == {"rotation"} and set(frames["n_inliers"]) == {120}
    hops = read_session_table(conn, sid, "hops")
    assert hops["t_s"] == [float(k) for k in range(1, 21)] and "normal" in hops["label"]
    assert json.loads(hops["json"][-1])["classification"]["label"] == hops["label"][-1]
    cal = read_session_table(conn, sid, "calibrations")
    assert cal["reason"] == ["start", "request"]  # the stage's start calibration, then the explicit one
    assert read_session_table(conn, sid, "imu")["ay"] == [-9.81]
    assert read_session_table(conn, sid, "alerts")["kind"] == ["lean_forward"]
    conn.close()
    (s,) = list_sessions(data)
    assert (s.id, s.kind, s.end_reason, s.camera, s.imu, s.n_alerts) == (sid, "live", "stopped", "sim:normal:16",
                                                                         "file:imu.csv", 1)
    assert s.duration_s == pytest.approx(model.duration_s)


def test_sessions_list_and_export_csv_roundtrip(logged_session: tuple[Path, int, GaitModel], tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    data, sid, model = logged_session
    assert main(["sessions", "list", "--data-dir", str(data)]) == 0
    assert "sim:normal:16" in capsys.readouterr().out
    assert main(["sessions", "export", str(sid), "--format", "csv", "--out", str(tmp_path), "--data-dir", str(data)]) == 0
    from walkmon.tables import read_table

    ang = read_table(tmp_path / "angles.csv", ("t", "pitch", "yaw", "roll"))
    assert np.allclose(np.column_stack([ang["pitch"], ang["yaw"], ang["roll"]]), model.truth_angles_deg(ang["t"]),
                       atol=1e-9)
    with (tmp_path / "alerts.csv").open() as fh:
        assert list(csv.DictReader(fh))[0]["message"] == "leaning forward 12 deg"
    assert json.loads((tmp_path / "session.json").read_text())["config"] == {"alerts": {"delay_s": 5.0}}


def test_export_parquet(logged_session: tuple[Path, int, GaitModel], tmp_path: Path) -> None:
    pq = pytest.importorskip("pyarrow.parquet")
    data, sid, _ = logged_session
    assert main(["sessions", "export", str(sid), "--format", "parquet", "--out", str(tmp_path), "--data-dir", str(data)]) == 0
    table = pq.read_table(tmp_path / "angles.parquet")
    assert table.column_names[:4] == ["t", "pitch", "yaw", "roll"] and table.num_rows > 500


def test_report_from_the_database(logged_session: tuple[Path, int, GaitModel], tmp_path: Path) -> None:
    data, sid, _ = logged_session
    assert main(["report", str(sid), "--out", str(tmp_path), "--data-dir", str(data)]) == 0
    doc = json.loads((tmp_path / "indicators.json").read_text())
    assert doc["classification"]["label"] == "normal"
    assert 80 < doc["cadence_spm"] < 140
    assert (tmp_path / "report.html").stat().st_size > 10_000


def test_report_from_the_database_plots_the_absolute_angles_of_a_fused_session(
        logged_session: tuple[Path, int, GaitModel], tmp_path: Path) -> None:
    data, camera_only, model = logged_session
    t = np.arange(int(model.duration_s * FPS) + 1) / FPS
    a = model.truth_angles_deg(t)
    absolute = np.column_stack([a[:, 0] - 4.0, a[:, 2] + 1.5])  # the wearer leans 4 deg forward, 1.5 deg right
    fused = t >= 1.0  # the first second camera-only (IMU warm-up): NULL absolute angles
    with SessionLog(data, camera="sim:normal:16", imu="file:imu.csv") as log:
        for ti, ai, bi, fi in zip(t, a, absolute, fused, strict=True):
            log.add_frame(ti, ai, 120, "rotation", "OK", 3.0, abs_angles_deg=bi if fi else None, fused=bool(fi))
        sid = log.session_id
    assert main(["report", str(sid), "--out", str(tmp_path / "fused"), "--data-dir", str(data)]) == 0
    html = (tmp_path / "fused" / "report.html").read_text()
    assert "<h2>Absolute pitch and roll (against gravity)</h2>" in html
    assert "alt='Absolute pitch and roll (against gravity)' src='data:image/png;base64," in html
    assert f"<tr><td>frames with absolute angles</td><td>{fused.sum()} of {t.size}</td></tr>" in html
    for name, col in (("pitch_abs", 0), ("roll_abs", 1)):
        v = absolute[fused, col]
        for stat, value in (("mean", v.mean()), ("min", v.min()), ("max", v.max())):
            assert f"<tr><td>{name} {stat} [deg]</td><td>{value:.3f}</td></tr>" in html
    # a camera-only session (no pitch_abs/roll_abs in its frames): the same report, no absolute section
    assert main(["report", str(camera_only), "--out", str(tmp_path / "camera"), "--data-dir", str(data)]) == 0
    html = (tmp_path / "camera" / "report.html").read_text()
    assert "Absolute pitch and roll" not in html and "pitch_abs" not in html
    assert "<h2>Figures</h2>" in html


def test_command_errors_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                     logged_session: tuple[Path, int, GaitModel]) -> None:
    assert main(["sessions", "list", "--data-dir", str(tmp_path / "none")]) == 2
    assert "no session database" in capsys.readouterr().err
    data, _, _ = logged_session
    assert main(["sessions", "export", "999", "--out", str(tmp_path), "--data-dir", str(data)]) == 2
    err = capsys.readouterr().err
    assert "no session 999" in err and err.count("\n") == 1
    assert main(["report", "999", "--data-dir", str(data)]) == 2


_WRITER = textwrap.dedent("""
    import sys, time
    from walkmon.live.session_log import SessionLog
    log = SessionLog(sys.argv[1], camera="test:kill", flush_interval_s=0.5)
    t0 = time.monotonic()
    while True:
        t = time.monotonic() - t0
        log.add_frame(t, (t, 0.0, 0.0))
        sys.stdout.write(f"{t:.6f}\\n"); sys.stdout.flush()
        log.maybe_flush()
        time.sleep(0.01)
""")


def test_kill_9_mid_session_keeps_the_database_intact_and_loses_at_most_a_second(tmp_path: Path) -> None:
    proc = subprocess.Popen([sys.executable, "-c", _WRITER, str(tmp_path)], stdout=subprocess.PIPE, text=True)
    produced = []
    assert proc.stdout is not None
    for line in proc.stdout:
        produced.append(float(line))
        if produced[-1] > 2.0:
            break
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(10)
    produced += [float(x) for x in proc.stdout.read().split()]
    conn = sqlite3.connect(tmp_path / "walkmon.sqlite")
    assert conn.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    (last,) = conn.execute("SELECT MAX(t_s) FROM frames").fetchone()
    n = conn.execute("SELECT COUNT(*) FROM frames").fetchone()[0]
    conn.close()
    assert last is not None and produced[-1] - last <= 1.0  # only the unflushed tail is lost
    assert n >= sum(1 for t in produced if t <= last)
    (s,) = list_sessions(tmp_path)
    assert s.ended_utc is None  # cut off: listed as such, still readable


def test_analyze_save_records_an_offline_session(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from walkmon.simulate import simulate
    from walkmon.tables import read_table

    sim = simulate(tmp_path / "clip", walk="normal:3", seed=4, width=160, height=120)
    data = tmp_path / "data"
    assert main(["analyze", str(sim.video_path), "--calib", str(sim.camera_path), "--out", str(tmp_path / "out"),
                 "--no-progress", "--save", "--data-dir", str(data)]) == 0
    assert "saved as session 1" in capsys.readouterr().out
    (s,) = list_sessions(data)
    assert (s.kind, s.n_frames, s.end_reason, s.camera) == ("analyze", sim.n_frames, "complete", str(sim.video_path))
    offline = read_table(tmp_path / "out" / "angles.csv", ("t", "pitch", "yaw", "roll"))
    conn = open_database(data, create=False)
    stored = read_session_table(conn, s.id, "frames")
    conn.close()
    assert np.allclose(stored["pitch"], offline["pitch"], atol=1e-4)  # angles.csv is rounded to 4 decimals
    # camera-only: the schema-2 IMU columns stay NULL, and the report has no absolute-angle section
    assert set(stored["pitch_abs"]) == {None} and set(stored["roll_abs"]) == {None} and set(stored["fused"]) == {None}
    assert main(["report", str(s.id), "--data-dir", str(data), "--out", str(tmp_path / "rep")]) == 0
    assert "Absolute pitch and roll" not in (tmp_path / "rep" / "report.html").read_text()


def test_analyze_imu_save_stores_the_absolute_angles_for_the_report(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from walkmon.simulate import simulate
    from walkmon.tables import read_table

    sim = simulate(tmp_path / "clip", walk="normal:3", seed=4, width=160, height=120)
    imu_csv = sim.video_path.parent / "imu.csv"
    data = tmp_path / "data"
    runs = {"fused": [str(sim.video_path), "--calib", str(sim.camera_path), "--no-progress"], "imu_only": []}
    for name, video in runs.items():
        assert main(["analyze", *video, "--imu", str(imu_csv), "--out", str(tmp_path / name), "--save",
                     "--data-dir", str(data)]) == 0
    capsys.readouterr()
    fused_session, imu_session = list_sessions(data)
    assert fused_session.imu == imu_session.imu == str(imu_csv)
    assert fused_session.camera == str(sim.video_path)
    assert imu_session.camera == f"IMU only: {imu_csv}"  # not the text 'None'
    for name, session in zip(runs, (fused_session, imu_session), strict=True):
        offline = read_table(tmp_path / name / "angles.csv", ("t", "pitch", "pitch_abs", "roll_abs"))
        conn = open_database(data, create=False)
        stored = read_session_table(conn, session.id, "frames")
        conn.close()
        assert len(stored["t_s"]) == len(offline["t"]) > 50
        for col in ("pitch_abs", "roll_abs"):
            values = np.array(stored[col], dtype=float)  # None (NULL) would become NaN
            assert np.all(np.isfinite(values)), (name, col)
            # angles.csv has 6 decimals for these columns with a video, 4 in IMU-only analysis; the log keeps all
            assert np.allclose(values, offline[col], rtol=0, atol=5.001e-7 if name == "fused" else 5.001e-5), (name, col)
        assert np.ptp(np.array(stored["pitch_abs"], dtype=float)) > 0.5  # a walk, not a constant
        # fused: 1 per frame the IMU covered when a video was fused; no camera in IMU-only analysis -> NULL
        assert set(stored["fused"]) == ({1} if name == "fused" else {None})
    assert main(["report", str(fused_session.id), "--data-dir", str(data), "--out", str(tmp_path / "rep")]) == 0
    html = (tmp_path / "rep" / "report.html").read_text()
    assert "<h2>Absolute pitch and roll (against gravity)</h2>" in html
    fused_abs = read_table(tmp_path / "fused" / "angles.csv", ("pitch_abs",))["pitch_abs"]
    assert f"<tr><td>pitch_abs mean [deg]</td><td>{np.mean(fused_abs):.3f}</td></tr>" in html


@pytest.mark.parametrize("kind", ["imu", "acc"])
def test_a_saved_imu_analysis_reports_as_analyzed_and_counts_in_the_history(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], kind: str) -> None:
    """'analyze --imu --save' of a simulated walk (IMU, or its accelerometer alone), then 'report ID' and
    'history' (user review). Before: the accelerometer's session had '0 frames with angles' (its yaw is NULL)
    and no report; the IMU's report analysed the angles alone (a real course saved at 98.9 steps/min reported
    71.6); the history counted no hops, 0 min recorded and 0 min walked. Now the report finds the true steps as
    the analysis does, and the history counts the recording's length and its walking seconds."""
    from walkmon.tables import read_table

    sim = tmp_path / "sim"
    assert main(["simulate", "--no-video", "--walk", "stand:3,normal:20,pause:4,normal:15,stand:3", "--seed", "2",
                 "--out", str(sim)]) == 0
    imu_csv = sim / "imu.csv"
    if kind == "acc":
        cols = read_table(imu_csv, ("t", "ax", "ay", "az"))
        write_lines = ["t,ax,ay,az", *(",".join(f"{v:.7f}" for v in row)
                                       for row in zip(*(cols[c] for c in ("t", "ax", "ay", "az")), strict=True))]
        imu_csv = tmp_path / "acc.csv"
        imu_csv.write_text("\n".join(write_lines) + "\n")
    data = tmp_path / "data"
    assert main(["analyze", "--imu", str(imu_csv), "--out", str(tmp_path / "out"), "--save",
                 "--data-dir", str(data)]) == 0
    assert main(["report", "1", "--data-dir", str(data), "--out", str(tmp_path / "rep")]) == 0
    capsys.readouterr()
    analysed = json.loads((tmp_path / "out" / "indicators.json").read_text())
    reported = json.loads((tmp_path / "rep" / "indicators.json").read_text())
    true_steps = read_table(sim / "truth_steps.csv", ("t",))["t"]
    for doc in (analysed, reported):
        assert len(doc["bouts"]) == 2
        assert sum(b["n_steps"] for b in doc["bouts"]) == pytest.approx(true_steps.size, abs=3)
    assert reported["cadence_spm"] == pytest.approx(analysed["cadence_spm"], rel=1e-6)
    # the dashboard's report page is the same report (it was a 404 for the accelerometer's session)
    from walkmon.serve.report_page import session_report_html
    from walkmon.serve.store import Store

    html = session_report_html(Store(data), 1)
    assert f"{reported['cadence_spm']:.1f}" in html and "Per second, from the gait analysis" in html
    # exported, the samples analyse again as they did (review: an accelerometer's gx,gy,gz exported empty, and
    # every row was refused as non-finite)
    assert main(["sessions", "export", "1", "--data-dir", str(data), "--out", str(tmp_path / "exp")]) == 0
    header = (tmp_path / "exp" / "imu.csv").read_text().splitlines()[0]
    assert header == ("t,gx,gy,gz,ax,ay,az" if kind == "imu" else "t,ax,ay,az")
    assert main(["analyze", "--imu", str(tmp_path / "exp" / "imu.csv"), "--out", str(tmp_path / "again")]) == 0
    capsys.readouterr()
    again = json.loads((tmp_path / "again" / "indicators.json").read_text())
    assert again["cadence_spm"] == pytest.approx(analysed["cadence_spm"], rel=1e-3)
    assert [b["n_steps"] for b in again["bouts"]] == [b["n_steps"] for b in analysed["bouts"]]
    # the history: the recording's length, and its walking seconds as the truth has them (turns: none here)
    truth = read_table(sim / "truth_timeline.csv", ("t",))
    activity = [line.split(",")[1] for line in (sim / "truth_timeline.csv").read_text().splitlines()[1:]]
    true_walking_s = float(np.mean(np.array(activity) == "walking") * (truth["t"][-1] - truth["t"][0]))
    assert main(["history", "--data-dir", str(data), "--out", str(tmp_path / "hist"), "--since", "1d"]) == 0
    capsys.readouterr()
    row = (tmp_path / "hist" / "history.csv").read_text().splitlines()[1].split(",")
    recorded_min, walking_min = float(row[2]), float(row[3])
    assert recorded_min * 60 == pytest.approx(truth["t"][-1], abs=1.5)
    assert walking_min * 60 == pytest.approx(true_walking_s, abs=4.0)


def test_a_saved_analysis_hops_carry_their_posture_segments_cadence(tmp_path: Path,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    """A normal then a bent stretch in one bout: each walking second's hop carries its own segment's cadence,
    which the simulator's truth sets apart (review: the bout's one cadence, 109.8, on every second of stretches
    walked at 113.4 and 105.8)."""
    import walkmon

    sim = tmp_path / "sim"
    assert main(["simulate", "--no-video", "--walk", "stand:3,normal:12,bend:12,stand:3", "--seed", "1",
                 "--out", str(sim)]) == 0
    capsys.readouterr()
    result = walkmon.analyze(imu=sim / "imu.csv")
    sid = result.save(tmp_path / "db")
    segs = [s for s in result.indicators["segments"] if s["activity"] == "walking"]
    assert len(segs) == 2 and abs(segs[0]["cadence_spm"] - segs[1]["cadence_spm"]) > 3.0  # bend walks slower
    hops = walkmon.load_session(sid, tmp_path / "db").hops
    for seg in segs:
        inside = (hops["walking"] == 1) & (hops["t_s"] > seg["start_s"] + 1) & (hops["t_s"] < seg["end_s"] - 1)
        assert inside.sum() >= 5
        assert np.allclose(hops["cadence_spm"][inside], seg["cadence_spm"])
