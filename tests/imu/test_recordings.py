"""``walkmon analyze --imu``: IMU-only and fused analysis through the CLI, against the simulator's truth."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from walkmon.commands.cli import main
from walkmon.consts import angles_deg_from_rotation, rotation_from_angles_deg
from walkmon.tables import read_table, write_table


def truth_at(truth: dict, t: np.ndarray) -> np.ndarray:
    R = rotation_from_angles_deg(truth["pitch"], truth["yaw"], truth["roll"])
    rel = angles_deg_from_rotation(R[0].T @ R)
    return np.column_stack([np.interp(t, truth["t"], rel[:, k]) for k in range(3)])


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A short simulated session with video (320x240), truth.csv and imu.csv."""
    from walkmon.simulate import simulate

    d = tmp_path_factory.mktemp("imu_session")
    simulate(d, walk="normal", seconds=7.0, seed=2, width=320, height=240)
    return d


def test_imu_only_analysis_writes_angles_close_to_truth(session: Path, tmp_path: Path) -> None:
    out = tmp_path / "imu_only"
    assert main(["analyze", "--imu", str(session / "imu.csv"), "--out", str(out)]) == 0
    cols = read_table(out / "angles.csv", ["t", "pitch", "yaw", "roll", "pitch_abs", "roll_abs"])
    truth = read_table(session / "truth.csv", ["t", "pitch", "yaw", "roll"])
    assert np.median(np.diff(cols["t"])) == pytest.approx(0.01, abs=1e-6)  # 200 Hz IMU decimated to 100 Hz
    est = np.column_stack([cols["pitch"], cols["yaw"], cols["roll"]])
    err = np.sqrt(np.mean((est - truth_at(truth, cols["t"])) ** 2, axis=0))
    # the default core (VQF): roll tight; pitch carries its walk-start/stop error, yaw the bias learnt from 0.5 s
    assert np.all(err < [2.5, 1.5, 0.3]), err
    assert np.abs(cols["pitch_abs"][:50]).max() < 1.0  # the simulated wearer starts upright and level
    info = json.loads((out / "imu.json").read_text())
    assert info["mode"] == "imu_only" and info["imu_filter"] == "vqf"
    assert (out / "indicators.json").is_file() and (out / "report.html").is_file()
    html = (out / "report.html").read_text()
    assert "<h2>Absolute pitch and roll (IMU fusion)</h2>" in html
    assert f"<tr><td>frames with absolute angles</td><td>{len(cols['t'])} of {len(cols['t'])}</td></tr>" in html


def test_fused_analysis_adds_gravity_angles_and_keeps_video_angles(session: Path, tmp_path: Path) -> None:
    out = tmp_path / "fused"
    argv = ["analyze", str(session / "video.mp4"), "--calib", str(session / "camera.yaml"),
            "--imu", str(session / "imu.csv"), "--out", str(out), "--no-progress"]
    assert main(argv) == 0
    cols = read_table(out / "angles.csv", ["t", "pitch", "yaw", "roll", "pitch_abs", "roll_abs", "pitch_video"])
    truth = read_table(session / "truth.csv", ["t", "pitch", "yaw", "roll"])
    assert len(cols["t"]) == len(truth["t"])
    est = np.column_stack([cols["pitch"], cols["yaw"], cols["roll"]])
    err = np.sqrt(np.mean((est - truth_at(truth, cols["t"])) ** 2, axis=0))
    assert np.all(err < [0.3, 0.5, 0.3]), err
    info = json.loads((out / "imu.json").read_text())
    assert info["mode"] == "fused"
    assert info["visual_increments_used"] > 0.8 * len(cols["t"])
    ext = info["extrinsics_estimate"]
    assert ext["well_conditioned"], ext
    # truth: identity, 0 s; 3 s of walking at 320x240 pins the rotation to ~2 deg (0.5 deg at 640x480, 8 s)
    assert ext["rotation_deg"] < 3.0 and abs(ext["time_offset_s"]) < 0.01, ext
    html = (out / "report.html").read_text()  # the report shows the fused absolute angles too
    fused = np.isfinite(cols["pitch_abs"])
    assert f"<tr><td>pitch_abs mean [deg]</td><td>{np.mean(cols['pitch_abs'][fused]):.3f}</td></tr>" in html


def test_imu_only_with_walkmons_own_filter(session: Path, tmp_path: Path) -> None:
    out = tmp_path / "eskf"
    assert main(["analyze", "--imu", str(session / "imu.csv"), "--imu-filter", "eskf", "--out", str(out)]) == 0
    cols = read_table(out / "angles.csv", ["t", "pitch", "yaw", "roll", "pitch_abs", "roll_abs"])
    truth = read_table(session / "truth.csv", ["t", "pitch", "yaw", "roll"])
    est = np.column_stack([cols["pitch"], cols["yaw"], cols["roll"]])
    err = np.sqrt(np.mean((est - truth_at(truth, cols["t"])) ** 2, axis=0))
    assert np.all(err < 0.2), err
    assert json.loads((out / "imu.json").read_text())["imu_filter"] == "eskf"


def test_bad_imu_input_is_one_line_and_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "imu.csv"
    write_table(bad, {"t": np.arange(20) / 100.0, "gx": np.zeros(20)})
    assert main(["analyze", "--imu", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "missing column" in err
    assert main(["analyze", "--out", str(tmp_path / "o")]) == 2  # neither VIDEO nor --imu
    assert "VIDEO" in capsys.readouterr().err
    good = tmp_path / "good.csv"
    n = 100
    write_table(good, {"t": np.arange(n) / 100.0, "gx": np.zeros(n), "gy": np.zeros(n), "gz": np.zeros(n),
                       "ax": np.zeros(n), "ay": -9.81 * np.ones(n), "az": np.zeros(n)})
    argv = ["analyze", "--imu", str(good), "--imu-extrinsics", "estimate", "--out", str(tmp_path / "o")]
    assert main(argv) == 2  # estimating extrinsics needs a video
    assert "needs a VIDEO" in capsys.readouterr().err
