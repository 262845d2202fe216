"""The Python API (walkmon.analyze, analyze_angles, open_video, load_session): the same numbers and files as the
commands, checked against the simulator's truth."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

import walkmon
from walkmon.commands.cli import main
from walkmon.errors import ConfigError, InvalidInputError
from walkmon.tables import read_table


@pytest.fixture(scope="module")
def clip(tmp_path_factory: pytest.TempPathFactory):  # noqa: ANN201
    from walkmon.simulate import simulate

    return simulate(tmp_path_factory.mktemp("api") / "clip", walk="bend:6", seed=2, width=160, height=120, fps=20)


@pytest.fixture(scope="module")
def cli_out(clip, tmp_path_factory: pytest.TempPathFactory) -> Path:  # noqa: ANN001
    out = tmp_path_factory.mktemp("api_cli") / "out"
    assert main(["analyze", str(clip.video_path), "--calib", str(clip.camera_path), "--imu",
                 str(clip.video_path.parent / "imu.csv"), "--out", str(out), "--no-progress"]) == 0
    return out


@pytest.fixture(scope="module")
def result(clip):  # noqa: ANN001, ANN201
    return walkmon.analyze(clip.video_path, calib=clip.camera_path, imu=clip.video_path.parent / "imu.csv")


def test_api_angles_are_the_cli_angles(result, cli_out: Path) -> None:  # noqa: ANN001
    lines = (cli_out / "angles.csv").read_text().splitlines()
    header = lines[0].split(",")
    assert list(result.angles.dtype.names) == header
    rows = [line.split(",") for line in lines[1:]]
    assert len(rows) == len(result.angles)
    for k, name in enumerate(header):
        cells = [r[k] for r in rows]
        values = result.angles[name]
        if values.dtype.kind == "f":
            digits = 4 if name in ("t", "pitch", "yaw", "roll") else 3 if name == "residual_px" else 6
            assert [f"{v:.{digits}f}" for v in values] == cells, name
        else:
            assert [str(v) for v in values] == cells, name
    assert result.indicators == json.loads((cli_out / "indicators.json").read_text())


def test_api_write_gives_the_cli_files(result, cli_out: Path, tmp_path: Path) -> None:  # noqa: ANN001
    files = result.write(tmp_path / "api")
    assert sorted(files) == sorted(p.name for p in cli_out.iterdir())
    for name in ("angles.csv", "indicators.json", "imu.json"):
        assert files[name].read_bytes() == (cli_out / name).read_bytes(), name
    assert files["report.html"].read_text().startswith("<!DOCTYPE html>")


def test_api_angles_follow_the_simulator_truth_and_load_into_pandas(result, clip) -> None:  # noqa: ANN001
    pd = pytest.importorskip("pandas")
    df = pd.DataFrame(result.angles)
    assert list(df.columns[:6]) == ["t", "pitch", "yaw", "roll", "pitch_abs", "roll_abs"]
    assert pd.api.types.is_string_dtype(df["model"]) and df["n_inliers"].dtype.kind == "i"
    truth = read_table(clip.video_path.parent / "truth.csv", ("t", "pitch", "yaw", "roll"))
    assert len(df) == len(truth["t"])
    for axis in ("pitch", "roll"):
        err = df[axis].to_numpy() - (truth[axis] - truth[axis][0])
        assert np.sqrt(np.mean(err**2)) < 1.5, axis
    # a bent walk: the classifier says so, with the truth's forward lean
    assert result.indicators["classification"]["label"] == "bend"


def test_result_is_frozen(result) -> None:  # noqa: ANN001
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.angles = None
    with pytest.raises(ValueError, match="read-only"):
        result.angles["pitch"][0] = 99.0
    doc = result.indicators
    doc["classification"]["label"] = "changed"
    assert result.indicators["classification"]["label"] == "bend"


def test_imu_only_and_baseline_from_another_result(clip) -> None:  # noqa: ANN001
    imu_only = walkmon.analyze(imu=clip.video_path.parent / "imu.csv")
    assert imu_only.estimates == ()
    assert imu_only.imu_info["mode"] == "imu_only"
    assert list(imu_only.angles.dtype.names)[:6] == ["t", "pitch", "yaw", "roll", "pitch_abs", "roll_abs"]
    assert imu_only.gait.classification.label == "bend"  # the simulator's walk, from the IMU alone
    # the same walk as its own baseline (an Analysis passed as baseline=), analysed the same way: nothing differs
    # from normal (against the fused result, the IMU alone (VQF) reads ~2 deg more pitch on this 6 s walk: VQF
    # takes the start of walking for tilt)
    again = walkmon.analyze(imu=clip.video_path.parent / "imu.csv", baseline=imu_only)
    assert again.gait.classification.label == "normal"


def test_analyze_angles_is_what_walkmon_indicators_writes(clip, tmp_path: Path) -> None:  # noqa: ANN001
    truth = clip.video_path.parent / "truth.csv"
    assert main(["indicators", str(truth), "--out", str(tmp_path / "cli")]) == 0
    table = read_table(truth, ("t", "pitch", "yaw", "roll"))
    res = walkmon.analyze_angles(table["t"], np.column_stack([table[c] for c in ("pitch", "yaw", "roll")]))
    assert res.indicators == json.loads((tmp_path / "cli" / "indicators.json").read_text())


def test_open_video_and_load_session(clip, result, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:  # noqa: ANN001
    with walkmon.open_video(clip.video_path) as video:
        frames = list(video)
        assert (video.width_px, video.height_px) == (160, 120)
    assert len(frames) == len(result.angles)
    assert frames[1][0] == pytest.approx(1 / video.fps)
    sid = result.save(tmp_path / "db")
    session = walkmon.load_session(sid, tmp_path / "db")
    assert session.record["kind"] == "analyze" and session.record["camera"] == str(clip.video_path)
    assert np.allclose(session.frames["pitch"], result.angles["pitch"])
    assert np.allclose(session.frames["pitch_abs"], result.angles["pitch_abs"])
    assert list(session.frames["model"]) == list(result.angles["model"])
    # the analysis' per-second timeline as hops (for the history): walking where it walked, with its label
    assert len(session.hops) == len(result.timeline) > 0 and session.hops.dtype.names[0] == "t_s"
    walking = np.array([row[1] == "walking" for row in result.timeline])
    assert np.array_equal(session.hops["walking"] == 1, walking)
    assert list(session.hops["label"][walking]) == [row[2] for row in result.timeline if row[1] == "walking"]
    # walkmon report ID is the session's analysis, written
    assert main(["report", str(sid), "--data-dir", str(tmp_path / "db"), "--out", str(tmp_path / "rep")]) == 0
    capsys.readouterr()
    assert session.analyze().indicators == json.loads((tmp_path / "rep" / "indicators.json").read_text())
    with pytest.raises(InvalidInputError, match="no session 99"):
        walkmon.load_session(99, tmp_path / "db")


def test_bad_input_is_one_clear_error(tmp_path: Path) -> None:
    with pytest.raises(InvalidInputError, match="give a VIDEO"):
        walkmon.analyze()
    with pytest.raises(ConfigError, match="unknown rotation method"):
        walkmon.analyze(tmp_path / "x.mp4", method="magic")
    with pytest.raises(InvalidInputError, match="no such video file"):
        walkmon.analyze(tmp_path / "x.mp4")
    with pytest.raises(InvalidInputError, match="shape"):
        walkmon.analyze_angles([0, 1, 2], np.zeros((2, 3)))


def test_writing_beside_an_earlier_runs_files_says_so(clip, tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:  # noqa: ANN001
    """An IMU analysis, then a video-only one into the same folder: the first run's imu.json stays (it may be all
    a user has of it) but no longer matches the new files; a warning names it (user review: nothing said so).
    Into a fresh folder, or 'indicators' into the folder its angles.csv came from (review: the command's own
    input was named), no warning."""
    import logging

    out = tmp_path / "out"
    walkmon.analyze(imu=clip.video_path.parent / "imu.csv").write(out)
    video_only = walkmon.analyze(clip.video_path)
    with caplog.at_level(logging.WARNING, logger="walkmon.api"):
        video_only.write(tmp_path / "fresh")
        video_only.write(tmp_path / "fresh", angles=False)
        assert not caplog.records
        video_only.write(out)
    (rec,) = caplog.records
    assert "imu.json from an earlier run" in rec.getMessage()
    assert (out / "imu.json").exists()  # said, not deleted


def test_an_accelerometer_session_saved_without_its_samples_is_refused(tmp_path: Path) -> None:
    """An accelerometer's analysis saved before its samples were stored: its angles are gravity's low-passed
    pitch and roll, yaw NULL. Its report read 'no walking bout', confidently (review; before that, '0 frames with
    angles'): one line saying what it is and what to run."""
    from walkmon.live.session_log import record_offline_session

    t = np.arange(0.0, 20.0, 0.01)
    angles = np.column_stack([np.sin(t), np.full(t.size, np.nan), np.cos(t)])
    sid = record_offline_session(tmp_path / "db", t, angles, source="IMU only: acc.csv", imu="acc.csv")
    with pytest.raises(InvalidInputError, match="saved without its samples"):
        walkmon.load_session(sid, tmp_path / "db").analyze()


def test_an_imu_file_in_another_sensors_axes_is_said(clip, tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:  # noqa: ANN001
    """The simulated walk's IMU with its axes turned so that x points up (as Mobilise-D's lower-back sensor):
    steps, bouts and cadence do not depend on the axes, but pitch and roll do (review: a real course read standing
    seconds at 87-159 deg of pitch, silently). A warning and imu.json's axes_warning say so; in camera axes,
    neither."""
    import logging

    lines = (clip.video_path.parent / "imu.csv").read_text().splitlines()
    turned = ["t,gx,gy,gz,ax,ay,az"]
    for line in lines[1:]:
        t, gx, gy, gz, ax, ay, az = line.split(",")
        turned.append(",".join([t, f"{-float(gy)}", gx, gz, f"{-float(ay)}", ax, az]))  # y up -> x up
    (tmp_path / "x_up.csv").write_text("\n".join(turned) + "\n")
    with caplog.at_level(logging.WARNING, logger="walkmon.api"):
        plain = walkmon.analyze(imu=clip.video_path.parent / "imu.csv")
        assert not caplog.records and "axes_warning" not in (plain.imu_info or {})
        x_up = walkmon.analyze(imu=tmp_path / "x_up.csv")
    assert any("90 deg from the camera axes' up" in r.getMessage() for r in caplog.records)
    assert "another sensor's own axes" in x_up.imu_info["axes_warning"]
    assert [b["n_steps"] for b in x_up.indicators["bouts"]] == [b["n_steps"] for b in plain.indicators["bouts"]]


def test_a_logged_sessions_report_does_not_keep_a_calibration_the_monitor_rejected(tmp_path: Path) -> None:
    """User review: the live monitor calibrated while the wearer sat (the chest 30 deg from upright), rejected that
    stance once the walking read far from it and retook the reference standing; 'walkmon report ID' kept the first
    one for the whole session and read every normal walk 'bend', where the live hops, 'analyze' and the truth say
    normal. The report now finds the session's own standing phases; the live calibration only where none."""
    from walkmon.gait.live import CalibrationEvent
    from walkmon.live.session_log import SessionLog
    from walkmon.simulate.gait import GaitModel

    model = GaitModel("sit:12,normal:14,pause:3,normal:6", seed=2)
    t = np.arange(0.0, model.duration_s, 1 / 30)
    a = model.truth_angles_deg(t) + np.random.default_rng(1).normal(0.0, 0.02, (t.size, 3))
    log = SessionLog(tmp_path / "db", kind="live", camera="test", flush_interval_s=1.0)
    for ti, ai in zip(t, a, strict=True):
        log.add_frame(float(ti), tuple(ai), 80, "rotation", "ok", 5.0)
    seated = model.truth_angles_deg(np.array([3.9]))[0]
    assert seated[0] > 20.0  # the simulator's seated chest
    log.add_calibration(CalibrationEvent(3.9, tuple(seated), "start", 2.0))
    pause = next(p for p in model.pieces if p.activity == "standing" and p.start_s > 14.0)
    upright = model.truth_angles_deg(np.array([pause.end_s - 0.5]))[0]
    log.add_calibration(CalibrationEvent(pause.end_s - 0.5, tuple(upright), "posture", 2.0))
    sid = log.session_id
    log.close("complete")
    doc = walkmon.load_session(sid, tmp_path / "db").analyze().indicators
    walks = [p for p in model.pieces if p.activity == "walking"]
    for p in walks:
        mid = 0.5 * (p.start_s + p.end_s)
        labels = {s["label"] for s in doc["segments"] if s["start_s"] <= mid <= s["end_s"]}
        assert labels == {"normal"}, (p, doc["segments"])


def test_the_live_reference_a_report_falls_back_on_is_the_monitors_last(tmp_path: Path) -> None:
    """Review: only a 'posture' retake replaced the first calibration, so a retake logged as the wearer's 'request'
    (the monitor keeps that name) went back to the rejected seated start; a 'pause' re-reference after a turn is a
    drifted video's pose, never the session's upright."""
    from walkmon.gait.live import CalibrationEvent
    from walkmon.live.session_log import SessionLog

    log = SessionLog(tmp_path / "db", kind="live", camera="test", flush_interval_s=1.0)
    for i in range(40):
        log.add_frame(i / 30, (0.0, 0.0, 0.0), 80, "rotation", "ok", 5.0)
    log.add_calibration(CalibrationEvent(0.5, (30.0, 0.0, 0.0), "start", 2.0))
    log.add_calibration(CalibrationEvent(0.8, (2.0, 0.0, 0.5), "request", 2.0))
    log.add_calibration(CalibrationEvent(1.0, (7.0, 40.0, 1.0), "pause", 1.0))
    sid = log.session_id
    log.close("complete")
    ref = walkmon.load_session(sid, tmp_path / "db")._live_reference()
    assert ref is not None and ref.tolist() == [2.0, 0.0, 0.5]


def test_a_sessions_hops_carry_their_activity(imu_walk, tmp_path: Path) -> None:  # noqa: ANN001
    """Review: Session.hops had no activity (only inside each hop's JSON), where 'sessions export' gives it."""
    _, a = imu_walk
    sid = a.save(tmp_path / "db")
    hops = walkmon.load_session(sid, tmp_path / "db").hops
    want = [str(act) for _t, act, *_ in a.timeline]
    assert list(hops["activity"]) == want and "walking" in want and "standing" in want


@pytest.fixture(scope="module")
def imu_walk(tmp_path_factory: pytest.TempPathFactory):  # noqa: ANN201
    """A 24 s IMU-only walk (2 s standing, normal 10 s, bent 10 s, 2 s standing) and its analysis."""
    from walkmon.simulate import simulate

    sim = simulate(tmp_path_factory.mktemp("api_imu") / "sim", walk="normal:10,bend:10", seed=2, video=False)
    return sim, walkmon.analyze(imu=sim.imu_path)


def test_a_given_reference_with_gravity_is_used_and_said(imu_walk) -> None:  # noqa: ANN001
    """Review of the Python API: analyze_angles(..., abs_angles_deg=..., reference_deg=X) gave the same figures for
    any X (the reference level), while saying 'given'. The standing pose given reads as the standing phase found;
    that pose pitched 5 deg down reads every inclination 5 deg higher."""
    _, a = imu_walk
    t, ang, ab = a.t_s, a.angles_deg, a.abs_angles_deg
    stance = ang[t < 1.5].mean(axis=0)
    found = walkmon.analyze_angles(t, ang, abs_angles_deg=ab).indicators
    same = walkmon.analyze_angles(t, ang, abs_angles_deg=ab, reference_deg=stance).indicators
    down5 = walkmon.analyze_angles(t, ang, abs_angles_deg=ab, reference_deg=dict(zip(
        ("pitch", "yaw", "roll"), stance + [-5.0, 0.0, 0.0], strict=True))).indicators  # as indicators.json has it
    assert same["upright_reference"]["source"].startswith("given")
    for f, g, h in zip(found["segments"], same["segments"], down5["segments"], strict=True):
        p = f["axes"]["pitch"]["inclination_mean"]
        assert g["axes"]["pitch"]["inclination_mean"] == pytest.approx(p, abs=0.3)
        assert h["axes"]["pitch"]["inclination_mean"] == pytest.approx(p + 5.0, abs=0.3)


def test_the_indicators_dict_is_a_fresh_copy(imu_walk, tmp_path: Path) -> None:  # noqa: ANN001
    """Review: editing a.indicators' nested bouts changed the analysis, its written indicators.json and save()."""
    _, a = imu_walk
    d = a.indicators
    n, cad = d["summary"]["n_steps"], d["bouts"][0]["cadence_spm"]
    d["summary"]["n_steps"] = -1
    d["bouts"][0]["cadence_spm"] = 0.0
    assert a.indicators["summary"]["n_steps"] == n and a.indicators["bouts"][0]["cadence_spm"] == cad
    a.write(tmp_path / "out", report=False)
    written = json.loads((tmp_path / "out" / "indicators.json").read_text())
    assert written["summary"]["n_steps"] == n


def test_write_expands_the_home_folder(imu_walk, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:  # noqa: ANN001
    """Review: write('~/out') made a folder named '~' in the current folder; save() and the readers expand it."""
    _, a = imu_walk
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.chdir(tmp_path)
    a.write("~/out", report=False)
    assert (tmp_path / "home" / "out" / "indicators.json").is_file() and not (tmp_path / "~").exists()


def test_an_accelerometer_file_takes_its_calibration_and_checks_the_filter(imu_walk, tmp_path: Path) -> None:  # noqa: ANN001
    """Review: for a t,ax,ay,az file imu_calib and imu_filter were silently ignored, a missing calibration file
    and a filter named 'bogus' included; a file missing one gyroscope column was read as an accelerometer's."""
    sim, _ = imu_walk
    cols = read_table(sim.imu_path, ("t", "gx", "gy", "gz", "ax", "ay", "az"))
    from walkmon.tables import write_table

    write_table(tmp_path / "acc.csv", {k: cols[k] for k in ("t", "ax", "ay", "az")})
    with pytest.raises(InvalidInputError, match="does-not-exist"):
        walkmon.analyze(imu=tmp_path / "acc.csv", imu_calib=tmp_path / "does-not-exist.json")
    with pytest.raises(ConfigError, match="bogus"):
        walkmon.analyze(imu=tmp_path / "acc.csv", imu_filter="bogus")
    write_table(tmp_path / "nogz.csv", {k: cols[k] for k in ("t", "gx", "gy", "ax", "ay", "az")})
    with pytest.raises(InvalidInputError, match="no gz"):
        walkmon.analyze(imu=tmp_path / "nogz.csv")


@pytest.mark.parametrize(("call", "match"), [
    (lambda a, p: walkmon.analyze_angles(a.t_s, a.angles_deg, reference_deg=[1, 2]), "reference_deg must be 3"),
    (lambda a, p: walkmon.analyze_angles(a.t_s, a.angles_deg, reference_deg="abc"), "reference_deg must be 3"),
    (lambda a, p: walkmon.analyze_angles(a.t_s, a.angles_deg, reference_deg={"pitch": 1}), "reference_deg must be 3"),
    (lambda a, p: walkmon.analyze_angles(a.t_s, a.angles_deg, meta=[1, 2]), "meta must be a mapping"),
    (lambda a, p: a.save(p / "db", meta=[1, 2]), "meta must be a mapping"),
    (lambda a, p: walkmon.analyze(imu=p / "imu.csv", imu_offset_s="abc"), "imu_offset_s must be a finite"),
    (lambda a, p: walkmon.analyze(imu=np.zeros((10, 7))), "imu must be a path"),
    (lambda a, p: walkmon.load_session("abc", p / "db"), "session_id must be a whole number"),
    (lambda a, p: walkmon.load_session(1.7, p / "db"), "session_id must be a whole number"),
    (lambda a, p: a.save(p / "afile"), "not a folder"),
])
def test_bad_api_arguments_are_walkmon_errors(imu_walk, tmp_path: Path, call, match: str) -> None:  # noqa: ANN001
    """Review: these raised bare ValueError / TypeError / NotADirectoryError tracebacks (or, 1.7, loaded session 1)."""
    _, a = imu_walk
    (tmp_path / "afile").write_text("x")
    with pytest.raises(walkmon.WalkmonError, match=match):
        call(a, tmp_path)
