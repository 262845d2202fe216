"""Fault injection, bad files: every bad input file or option ends in exit code 2 and one line on stderr, never a
traceback, never exit 0 with wrong numbers (issue 12, items 1, 3, 5, 9, 12, 13)."""

from __future__ import annotations

import json
import math
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

CAMERA = """image_width: {w}
image_height: 120
camera_matrix: {{rows: 3, cols: 3, data: [{fx}, 0, 79.5, 0, {fx}, 59.5, 0, 0, 1]}}
distortion_model: plumb_bob
distortion_coefficients: {{rows: 1, cols: 5, data: [{k1}, 0, 0, 0, 0]}}
"""


@pytest.mark.parametrize(
    ("fields", "fragment"),
    [
        ({"fx": "1.0e+300"}, "not a lens focal length"),
        ({"fx": "1.0e-300"}, "not a lens focal length"),
        ({"w": "1.0e+23"}, "image_width"),
        ({"w": ".inf"}, "image_width"),
        ({"w": "-160"}, "image_width"),
        ({"k1": "1.0e+30"}, "distortion coefficient"),
        ({"k1": ".nan"}, "finite coefficients"),
    ],
)
def test_insane_calibration_is_refused(walk: Path, tmp_path: Path, cli, fields, fragment) -> None:
    calib = tmp_path / "cam.yaml"
    calib.write_text(CAMERA.format(**{"w": "160", "fx": "114.25", "k1": "0.0", **fields}))
    res = cli("analyze", walk / "video.mp4", "--calib", calib, "--out", tmp_path / "out", "--no-progress")
    res.one_line_error(fragment)
    assert not (tmp_path / "out" / "angles.csv").exists()


def test_the_simulator_calibration_itself_is_accepted(walk: Path) -> None:
    from walkmon.camera.model import read_camera_yaml

    cam = read_camera_yaml(walk / "camera.yaml")  # the sanity bounds do not refuse a real lens
    assert cam.width_px == 160 and 100 < cam.fx < 130


@pytest.mark.parametrize("kind", ["nested", "dev_zero", "huge"])
def test_hostile_calibration_files(walk: Path, tmp_path: Path, cli, kind: str) -> None:
    if kind == "dev_zero":
        calib = Path("/dev/zero")  # read until memory ran out before: now bounded to 1 MiB
    else:
        calib = tmp_path / "cam.yaml"
        calib.write_text("a: " + "[" * 50_000 + "]" * 50_000 + "\n" if kind == "nested" else "# x\n" * 400_000)
    res = cli("analyze", walk / "video.mp4", "--calib", calib, "--out", tmp_path / "out", "--no-progress")
    res.one_line_error("calibration file")


def test_imu_read_from_dev_zero_is_bounded(tmp_path: Path, cli) -> None:
    res = cli("analyze", "--imu", "/dev/zero", "--out", tmp_path / "out")
    res.one_line_error("/dev/zero", "larger than")


def test_angles_csv_from_dev_zero_is_bounded(tmp_path: Path, cli) -> None:
    res = cli("indicators", "/dev/zero", "--out", tmp_path / "out")
    res.one_line_error("/dev/zero")


def test_baseline_from_dev_zero_is_refused(sessions_db: Path, tmp_path: Path, cli) -> None:
    cli("report", "1", "--baseline", "/dev/zero", "--data-dir", sessions_db).one_line_error("not a regular file")
    res = cli("indicators", tmp_path / "a.csv", "--baseline", "/dev/zero", "--out", tmp_path / "o")
    res.one_line_error("not a regular file")


def test_imu_calibration_from_dev_zero_is_bounded(walk: Path, tmp_path: Path, cli) -> None:
    res = cli("analyze", "--imu", walk / "imu.csv", "--imu-calib", "/dev/zero", "--out", tmp_path / "o")
    res.one_line_error("/dev/zero", "larger than")


def test_dead_imu_file_is_refused_for_imu_only_analysis(tmp_path: Path, cli) -> None:
    imu = tmp_path / "zeros.csv"
    imu.write_text("t,gx,gy,gz,ax,ay,az\n" + "".join(f"{i / 100:.2f},0,0,0,0,0,0\n" for i in range(500)))
    res = cli("analyze", "--imu", imu, "--out", tmp_path / "out")
    res.one_line_error("0 plausible IMU rows of 500", "no_gravity 500")


@pytest.mark.parametrize("value", ["0", "0.0123"])
def test_a_dead_gyroscope_beside_a_live_accelerometer_is_refused(walk: Path, tmp_path: Path, cli, value: str) -> None:
    """A simulated walk's imu.csv whose gyroscope reads the same on every row (a logger writing zeros for a
    missing or dead one). Analysed, such a real course read no turn and a left_shoulder_down label where its own
    gyroscope gave none (user review); now one line naming the accelerometer-only way, with or without a video."""
    lines = (walk / "imu.csv").read_text().splitlines()
    rows = [line.split(",") for line in lines[1:]]
    imu = tmp_path / "gyro_dead.csv"
    imu.write_text(lines[0] + "\n" + "".join(",".join([r[0], value, value, value, *r[4:]]) + "\n" for r in rows))
    res = cli("analyze", "--imu", imu, "--out", tmp_path / "out")
    res.one_line_error("dead or missing gyroscope", "t,ax,ay,az")
    res = cli("analyze", walk / "video.mp4", "--imu", imu, "--out", tmp_path / "out2", "--no-progress")
    res.one_line_error("dead or missing gyroscope")


def _accelerometer_only(walk: Path, path: Path) -> Path:
    """The walk's imu.csv without its gyroscope: t,ax,ay,az."""
    lines = (walk / "imu.csv").read_text().splitlines()
    path.write_text("t,ax,ay,az\n" + "".join(",".join([r.split(",")[0], *r.split(",")[4:]]) + "\n"
                                               for r in lines[1:]))
    return path


def test_indicators_refuses_the_angles_of_an_accelerometer_alone(walk: Path, tmp_path: Path, cli) -> None:
    """'analyze --imu t,ax,ay,az' writes angles.csv with yaw nan on every row; 'indicators' read it as a damaged
    file ('nan' is not a finite number), against its help (user review). Its angles are gravity's low-passed
    pitch and roll, which hold no steps: one line saying so and what to run instead."""
    acc = _accelerometer_only(walk, tmp_path / "acc.csv")
    assert cli("analyze", "--imu", acc, "--out", tmp_path / "a").rc == 0
    res = cli("indicators", tmp_path / "a" / "angles.csv", "--out", tmp_path / "i")
    res.one_line_error("no yaw on any row", "walkmon analyze --imu")
    # a yaw missing on some rows only is still a damaged file, named by its line
    lines = (walk / "truth.csv").read_text().splitlines()
    header = lines[0].split(",")
    row = lines[5].split(",")
    row[header.index("yaw")] = "nan"
    lines[5] = ",".join(row)
    (tmp_path / "damaged.csv").write_text("\n".join(lines) + "\n")
    cli("indicators", tmp_path / "damaged.csv", "--out", tmp_path / "d").one_line_error("line 6, column yaw")


def test_angles_timed_in_milliseconds_are_refused(walk: Path, tmp_path: Path, cli) -> None:
    """truth.csv with t in milliseconds: 'indicators' read frames 33 s apart, 'no walking bout', a standing phase
    of hours, exit 0 (user review). One line, as the IMU's reader says it."""
    lines = (walk / "truth.csv").read_text().splitlines()
    rows = [line.split(",") for line in lines[1:]]
    (tmp_path / "ms.csv").write_text(lines[0] + "\n" + "".join(",".join([str(float(r[0]) * 1000), *r[1:]]) + "\n"
                                                                for r in rows))
    cli("indicators", tmp_path / "ms.csv", "--out", tmp_path / "o").one_line_error("is t in milliseconds?")


class _Pipes:
    """Named pipes, each fed once with a file's bytes by its own thread; a reader that opens one again gets its
    end at once (as a '<(...)' pipe gives it), not a wait forever."""

    def __init__(self, tmp_path: Path) -> None:
        import threading

        self.tmp_path, self.done, self.threads = tmp_path, threading.Event(), []

    def __call__(self, source: Path) -> Path:
        import threading

        fifo = self.tmp_path / f"{source.name}.pipe"
        os.mkfifo(fifo)

        def feed() -> None:
            with fifo.open("wb") as f:  # blocks until the reader opens the pipe
                f.write(source.read_bytes())
            while not self.done.wait(0.05):
                try:
                    os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
                except OSError:
                    pass  # no reader now

        self.threads.append(threading.Thread(target=feed, daemon=True))
        self.threads[-1].start()
        return fifo

    def close(self) -> None:
        self.done.set()
        for th in self.threads:
            th.join(timeout=10)


def test_inputs_through_pipes_read_as_the_files(walk: Path, tmp_path: Path, cli) -> None:
    """'--imu <(zcat imu.csv.gz)': a pipe, read once only, while an analysis reads its input twice (its columns,
    then its rows); the second read found it empty, 'empty file' (user review). Named pipes fed once: the same
    analyses as from the files: an accelerometer alone; an angles CSV through 'indicators' (review: its new
    check read it twice); an IMU and an accelerometer calibration both piped into a fused analysis (review: a
    cache of the last pipe alone lost the IMU to the calibration)."""
    acc = _accelerometer_only(walk, tmp_path / "acc.csv")
    cal = tmp_path / "cal.json"
    cal.write_text(json.dumps({"bias_m_s2": [0.0, 0.0, 0.0], "matrix": np.eye(3).tolist()}))
    video = [walk / "video.mp4", "--calib", walk / "camera.yaml", "--no-progress"]
    runs = {"acc": (["analyze", "--imu", "{acc}"], "indicators.json"),
            "angles": (["indicators", "{truth}"], "indicators.json"),
            "fused": (["analyze", *video, "--imu", "{imu}", "--imu-calib", "{cal}"], "indicators.json")}
    files = {"acc": acc, "truth": walk / "truth.csv", "imu": walk / "imu.csv", "cal": cal}
    for name, (argv, out_name) in runs.items():
        pipes = _Pipes(tmp_path / f"p_{name}")
        (tmp_path / f"p_{name}").mkdir()
        try:
            fed = {k: pipes(v) for k, v in files.items() if "{" + k + "}" in argv}
            piped = [a.format(**fed) if isinstance(a, str) and a.startswith("{") else a for a in argv]
            res = cli(*piped, "--out", tmp_path / f"{name}_piped")
            assert res.rc == 0, (name, res.err)
        finally:
            pipes.close()
        plain = [a.format(**files) if isinstance(a, str) and a.startswith("{") else a for a in argv]
        assert cli(*plain, "--out", tmp_path / f"{name}_file").rc == 0
        got = (tmp_path / f"{name}_piped" / out_name).read_text()
        assert got == (tmp_path / f"{name}_file" / out_name).read_text(), name


def test_a_threads_pipes_are_its_own() -> None:
    """The pipes' cache is per thread (review: one module-wide cache let one thread's exit empty another's)."""
    import threading

    from walkmon.safe_io import _PIPES, pipes_read_again

    seen = []

    def other() -> None:
        seen.append(_PIPES.get())  # a thread starts without the cache of the one that started it
        with pipes_read_again():
            seen.append(_PIPES.get())
        seen.append(_PIPES.get())

    with pipes_read_again():
        mine = _PIPES.get()
        assert mine is not None
        mine["x"] = b"1"
        th = threading.Thread(target=other)
        th.start()
        th.join()
        assert _PIPES.get() is mine and mine == {"x": b"1"}
        with pipes_read_again():  # nested: the outer one's pipes stay known
            assert _PIPES.get() is mine
        assert _PIPES.get() is mine
    assert seen[0] is None and seen[1] == {} and seen[1] is not mine and seen[2] is None
    assert _PIPES.get() is None


def test_an_empty_output_or_data_folder_is_refused(walk: Path, tmp_path: Path, cli, monkeypatch) -> None:
    """'--out ""' is the current folder to pathlib: analyze and history wrote their files there unasked (user
    review). One line, exit 2, nothing written."""
    monkeypatch.chdir(tmp_path)
    cli("analyze", "--imu", walk / "imu.csv", "--out", "").one_line_error("--out is empty")
    cli("sessions", "list", "--data-dir", " ").one_line_error("--data-dir is empty")
    assert list(tmp_path.iterdir()) == []


def test_a_slow_video_is_no_millisecond_clock(tmp_path: Path, cli) -> None:
    """A walk's angles at 4 a second: 'analyze' takes such a video, and 'indicators' refused its angles as timed
    in milliseconds with a first bound of 0.2 s (review); analysed."""
    assert cli("simulate", "--no-video", "--walk", "normal:10", "--fps", "4", "--out", tmp_path / "sim").rc == 0
    res = cli("indicators", tmp_path / "sim" / "truth.csv", "--out", tmp_path / "o")
    assert res.rc == 0, res.err


def test_a_csv_with_a_byte_order_mark_reads_as_without(walk: Path, tmp_path: Path, cli) -> None:
    """A spreadsheet's 'CSV UTF-8' starts with a byte-order mark; it read as 'missing column(s) t; header is t,..'
    (user review). The same analysis as without it."""
    plain = _accelerometer_only(walk, tmp_path / "acc.csv")
    bom = tmp_path / "bom.csv"
    bom.write_bytes(b"\xef\xbb\xbf" + plain.read_bytes())
    for name, path in (("plain", plain), ("bom", bom)):
        assert cli("analyze", "--imu", path, "--out", tmp_path / name).rc == 0
    assert (tmp_path / "bom" / "indicators.json").read_text() == (tmp_path / "plain" / "indicators.json").read_text()


def test_a_still_sensor_whose_gyroscope_reads_zero_at_rest_is_analysed(tmp_path: Path, cli) -> None:
    """A sensor lying still, its gyroscope reading exactly 0 (a quantised part at rest), its accelerometer only
    noise: no dead gyroscope (review: any noise counted as moving); analysed: no walk."""
    rng = np.random.default_rng(3)
    rows = "".join(f"{i / 100:.2f},0,0,0,{rng.normal(0, 0.02):.5f},{9.81 + rng.normal(0, 0.02):.5f},"
                   f"{rng.normal(0, 0.02):.5f}\n" for i in range(3000))
    imu = tmp_path / "still.csv"
    imu.write_text("t,gx,gy,gz,ax,ay,az\n" + rows)
    res = cli("analyze", "--imu", imu, "--out", tmp_path / "out")
    assert res.rc == 0, res.err
    assert "no walking bout" in res.out or "walking 0.0 s" in res.out


def test_one_row_timed_far_ahead_is_skipped_not_a_clock_reset(walk: Path, tmp_path: Path, cli, caplog) -> None:
    """One corrupted line whose time is 10 s ahead of the rows about it: every later row read as going back, and
    the whole file was refused as a clock reset, in analyze, live and batch (user review). Now that row is
    skipped and counted (time_jump), and the analysis is the clean file's."""
    lines = (walk / "imu.csv").read_text().splitlines()
    bad = list(lines)
    row = bad[5].split(",")
    row[0] = f"{float(row[0]) + 10.0:.6f}"
    bad[5] = ",".join(row)
    (tmp_path / "jump.csv").write_text("\n".join(bad) + "\n")
    (tmp_path / "clean.csv").write_text("\n".join(lines[:5] + lines[6:]) + "\n")
    res = cli("analyze", "--imu", tmp_path / "jump.csv", "--out", tmp_path / "j")
    assert res.rc == 0, res.err
    assert any("(time_jump 1)" in r.getMessage() for r in caplog.records)
    assert cli("analyze", "--imu", tmp_path / "clean.csv", "--out", tmp_path / "c").rc == 0
    got = json.loads((tmp_path / "j" / "indicators.json").read_text())
    want = json.loads((tmp_path / "c" / "indicators.json").read_text())
    assert [b["n_steps"] for b in got["bouts"]] == [b["n_steps"] for b in want["bouts"]]
    assert got["walking_s"] == pytest.approx(want["walking_s"], abs=0.05)
    incl = [doc["axes"]["pitch"]["inclination_mean"] for doc in (got, want)]
    assert incl[0] == pytest.approx(incl[1], abs=0.05)


def test_dead_accelerometer_only_file_is_refused(tmp_path: Path, cli) -> None:
    """The accelerometer-only reader applies the imu.csv reader's plausibility rules (it raised a confusing
    error about angles, with a numpy warning, before)."""
    acc = tmp_path / "zeros.csv"
    acc.write_text("t,ax,ay,az\n" + "".join(f"{i / 100:.2f},0,0,0\n" for i in range(500)))
    res = cli("analyze", "--imu", acc, "--out", tmp_path / "out")
    res.one_line_error("0 plausible accelerometer rows of 500", "no_gravity 500")
    assert "RuntimeWarning" not in res.err


def test_imu_that_does_not_overlap_the_video_is_an_error_not_zero_angles(walk: Path, tmp_path: Path, cli) -> None:
    out = tmp_path / "out"
    res = cli("analyze", walk / "video.mp4", "--imu", walk / "imu.csv", "--imu-offset-s", "1e9", "--out", out,
              "--no-progress")
    res.one_line_error("the IMU covers 0% of the video", "--imu-offset-s")
    assert not (out / "angles.csv").exists() and not (out / "imu.json").exists()


def test_imu_covering_part_of_the_video_fuses_and_writes_valid_json(walk: Path, tmp_path: Path, cli) -> None:
    import json

    out = tmp_path / "out"
    imu = _imu_part(walk, tmp_path / "late.csv", lambda t: t >= 2.0)
    res = cli("analyze", walk / "video.mp4", "--imu", imu, "--out", out, "--no-progress")
    assert res.rc == 0, res.err
    info = json.loads((out / "imu.json").read_text(), parse_constant=lambda c: pytest.fail(f"{c} in imu.json"))
    assert 0.5 <= info["imu_coverage"] < 0.8  # 6 s video, the IMU from 2 s on: 4/6 of it
    # the same IMU given a clock offset 2 s off: its rates do not follow the video's there (once fused all the
    # same; now refused, naming the offset)
    res = cli("analyze", walk / "video.mp4", "--imu", walk / "imu.csv", "--imu-offset-s", "2.0", "--out",
              tmp_path / "o2", "--no-progress")
    res.one_line_error("does not follow the video", "--imu-offset-s")


@pytest.fixture(scope="module")
def walk_10s(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """10 s (2 s standing, 6 s walking, 2 s standing) at 160x120: video.mp4, imu.csv."""
    import subprocess
    import sys

    out = tmp_path_factory.mktemp("walk_10s")
    subprocess.run([sys.executable, "-m", "walkmon", "simulate", "--seconds", "10", "--seed", "2", "--width", "160",
                    "--height", "120", "--out", str(out)], check=True, capture_output=True, timeout=300)
    return out


@pytest.mark.parametrize("offset", ["-1.5", "1"])
def test_a_clock_offset_a_few_steps_off_is_refused(walk_10s: Path, tmp_path: Path, cli, offset: str) -> None:
    """The video's own IMU with --imu-offset-s 1-1.5 s off: the walk's rhythm lines up again a few steps off
    (correlation 0.6-0.8), and it was fused with every frame 'ok' and up to 5 deg of error (user review); the rates
    agree without the offset (0.99). Refused, naming the offset they agree at."""
    res = cli("analyze", walk_10s / "video.mp4", "--imu", walk_10s / "imu.csv", f"--imu-offset-s={offset}",
              "--out", tmp_path / "out", "--no-progress")
    res.one_line_error("follows the video's at a clock offset of", "not at --imu-offset-s")
    assert not (tmp_path / "out" / "angles.csv").exists()


@pytest.mark.parametrize("offset", ["nan", "inf", "1e999"])
def test_non_finite_imu_offset_is_a_usage_error(walk: Path, tmp_path: Path, cli, offset: str) -> None:
    res = cli("analyze", walk / "video.mp4", "--imu", walk / "imu.csv", "--imu-offset-s", offset,
              "--out", tmp_path / "out")
    res.one_line_error("finite")


@pytest.mark.parametrize("offset", ["1e308", "-2e10"])
def test_absurd_imu_offset_is_named_as_such(walk: Path, tmp_path: Path, cli, offset: str) -> None:
    """1e308 read 'IMU rate must be positive, got 0.0' (user review): every IMU time became 1e308."""
    res = cli("analyze", walk / "video.mp4", "--imu", walk / "imu.csv", f"--imu-offset-s={offset}",
              "--out", tmp_path / "out")
    res.one_line_error("imu_offset_s must be within")


def test_video_damaged_mid_file_is_an_error_not_a_shorter_walk(walk: Path, tmp_path: Path, cli) -> None:
    data = bytearray((walk / "video.mp4").read_bytes())
    start = int(len(data) * 0.4)
    data[start : start + len(data) // 10] = bytes(len(data) // 10)  # a zeroed stretch in the middle
    video = tmp_path / "damaged.mp4"
    video.write_bytes(bytes(data))
    res = cli("analyze", video, "--out", tmp_path / "out", "--no-progress")
    res.one_line_error("damaged", "of 180")
    assert not (tmp_path / "out" / "angles.csv").exists()


def test_video_cut_in_half_is_refused(walk: Path, tmp_path: Path, cli) -> None:
    data = (walk / "video.mp4").read_bytes()
    video = tmp_path / "cut.mp4"
    video.write_bytes(data[: len(data) // 2])
    res = cli("analyze", video, "--out", tmp_path / "out", "--no-progress")
    res.one_line_error(str(video))


@pytest.mark.parametrize(("argv", "fragment"), [
    (["--board", "100000x100000"], "2..100 inner corners"),
    (["--board", "1x6"], "2..100 inner corners"),
    (["--square-mm", "-5"], "(0, 10000]"),
    (["--square-mm", "nan"], "(0, 10000]"),
    (["--every", "0"], "1..100000"),
])
def test_calibrate_options_are_bounded(tmp_path: Path, cli, argv, fragment) -> None:
    res = cli("calibrate", tmp_path, *argv, "--out", tmp_path / "cam.yaml")
    res.one_line_error(fragment)


@pytest.mark.parametrize(("toml", "fragment"), [
    ("[indicators]\nresample_hz = 1e7\n", "indicators.resample_hz must be in [5, 200]"),
    ("[sinks]\nhook_timeout_s = 1e9\n", "sinks.hook_timeout_s"),
    ("[session]\nretention_days = 1e12\n", "session.retention_days"),
    ("[session]\nretention_days = nan\n", "session.retention_days"),
    ("[indicators]\nwindow_s = 1e6\n", "indicators.window_s"),
    ("a = " + "[" * 5000 + "]" * 5000 + "\n", "walkmon config"),
])
def test_insane_config_is_refused_before_any_session_starts(tmp_path: Path, cli, toml: str, fragment: str) -> None:
    cfg = tmp_path / "walkmon.toml"
    cfg.write_text(toml)
    data = tmp_path / "data"
    res = cli("live", "--config", cfg, "--camera", "sim:normal:2?width=64&height=48", "--data-dir", data,
              "--status", "none")
    res.one_line_error(fragment)
    assert not data.exists()  # no session (and no database) was created


def test_config_from_dev_zero_is_bounded(tmp_path: Path, cli) -> None:
    res = cli("live", "--config", "/dev/zero", "--camera", "sim:normal:2", "--data-dir", tmp_path / "d")
    res.one_line_error("larger than")


def test_imu_csv_reader_skips_and_counts_implausible_rows(tmp_path: Path) -> None:
    from walkmon.tables import read_imu_csv

    g = 9.81
    rows = [(i / 100, 0.01, 0.0, 0.0, 0.0, -g, 0.0) for i in range(40)]
    rows[5] = (0.05, 0.01, 0, 0, 0, 0, 0)  # dead accelerometer: no gravity
    rows[9] = (0.09, 1e300, 0, 0, 0, -g, 0)  # gyro beyond any MEMS range
    rows[12] = (0.12, 0, 0, 0, 400.0, -g, 0)  # 41 g
    rows[20] = (0.05, 0, 0, 0, 0, -g, 0)  # time going back
    text = "t,gx,gy,gz,ax,ay,az\n" + "".join(",".join(map(str, r)) + "\n" for r in rows)
    text += "0.5,nan,0,0,0,-9.81,0\n0.51,1,2\n0.52,x,0,0,0,-9.81,0\n"  # non-finite, short, not a number
    path = tmp_path / "imu.csv"
    path.write_text(text)
    rec = read_imu_csv(path)
    kept = [r[0] for i, r in enumerate(rows) if i not in (5, 9, 12, 20)]
    np.testing.assert_array_equal(rec.t_s, kept)
    assert np.all(np.abs(rec.accelerometer_m_s2[:, 1] + g) < 1e-12)


def test_session_ids_beyond_sqlite_range_and_huge_prune_ages(sessions_db: Path, tmp_path: Path, cli) -> None:
    big = str(2**63)
    for argv in (["sessions", "export", big, "--out", tmp_path / "x"], ["report", big, "--out", tmp_path / "r"],
                 ["sessions", "delete", big], ["sessions", "delete", "0"], ["report", "-1"]):
        res = cli(*argv, "--data-dir", sessions_db)
        res.one_line_error("session id")
    res = cli("sessions", "prune", "--older-than", "1e12", "--data-dir", sessions_db)
    assert res.rc == 0 and "no session" in res.out, res.err
    res = cli("sessions", "prune", "--older-than", "inf", "--data-dir", sessions_db)
    res.one_line_error("DAYS")
    assert math.isfinite(1e12)


def test_missing_inputs_are_one_line(tmp_path: Path, cli) -> None:
    cli("analyze", tmp_path / "nope.mp4", "--out", tmp_path / "o").one_line_error("nope.mp4")
    cli("indicators", tmp_path / "nope.csv", "--out", tmp_path / "o").one_line_error("nope.csv")
    cli("analyze", "--imu", tmp_path, "--out", tmp_path / "o").one_line_error(str(tmp_path))
    shutil.rmtree(tmp_path / "o", ignore_errors=True)


def test_imu_whose_clock_jumps_by_months_is_one_line(tmp_path: Path, cli) -> None:
    """A clock reset 1e7 s into the future: the analysis grid would span it (a MemoryError after minutes)."""
    rows = [f"{i / 100 + (1e7 if i >= 1000 else 0):.2f},0.001,0,0,0,-9.81,0\n" for i in range(2000)]
    imu = tmp_path / "jump.csv"
    imu.write_text("t,gx,gy,gz,ax,ay,az\n" + "".join(rows))
    res = cli("analyze", "--imu", imu, "--out", tmp_path / "out")
    res.one_line_error("its longest gap, 1e+07 s after t=9.99 s", "a clock that jumped")


def _still_rows(n: int, gyro: bool = True) -> list[str]:
    rng = np.random.default_rng(0)
    rows = []
    for i in range(n):
        a = rng.normal(0.0, 0.02, 3) + [0.0, -9.81, 0.0]
        g = rng.normal(0.0, 0.002, 3)
        rows.append(",".join(f"{v:.5f}" for v in ([i / 100] + (list(g) if gyro else []) + list(a))) + "\n")
    return rows


@pytest.mark.parametrize("gyro", [True, False], ids=["imu", "accelerometer only"])
def test_a_few_nan_rows_are_skipped_and_counted_not_the_whole_file_refused(tmp_path: Path, cli, gyro: bool) -> None:
    """A logger's glitch: 10 rows of NaN in 20 s. The reader skips and counts such rows, but the file-kind check
    before it read the file strictly and refused it for the first NaN (and the accelerometer-only reader refused
    any non-finite value)."""
    rows = _still_rows(2000, gyro)
    cols = "gx,gy,gz," if gyro else ""
    for i in range(500, 510):
        rows[i] = f"{i / 100:.2f}," + ",".join(["nan"] * (6 if gyro else 3)) + "\n"
    imu = tmp_path / "glitch.csv"
    imu.write_text(f"t,{cols}ax,ay,az\n" + "".join(rows))
    res = cli("analyze", "--imu", imu, "--out", tmp_path / "out")
    assert res.rc == 0, res.err
    assert f"1990 {'IMU' if gyro else 'accelerometer'} samples" in res.out  # 2000 less the 10 skipped
    assert (tmp_path / "out" / "indicators.json").is_file()


@pytest.mark.parametrize("n_empty", [3, 11])
def test_empty_gyroscope_cells_skip_their_rows_not_the_gyroscope(tmp_path: Path, cli, n_empty: int) -> None:
    """User review: a few empty gx/gy/gz cells (pandas writes NaN as nothing) made the file-kind check drop the
    gyroscope columns as not numeric, and the whole file was analysed as an accelerometer's: no yaw, no turns for
    every row, said only in a note. The rows are skipped and counted; the gyroscope stays."""
    rows = _still_rows(2000, True)
    for i in range(500, 500 + n_empty):
        parts = rows[i].rstrip("\n").split(",")
        rows[i] = ",".join([parts[0], "", "", "", *parts[4:]]) + "\n"
    imu = tmp_path / "empty_cells.csv"
    imu.write_text("t,gx,gy,gz,ax,ay,az\n" + "".join(rows))
    res = cli("analyze", "--imu", imu, "--out", tmp_path / "out")
    assert res.rc == 0, res.err
    assert f"{2000 - n_empty} IMU samples" in res.out and "no gyroscope" not in res.out


@pytest.mark.parametrize("gyro", [True, False], ids=["imu", "accelerometer only"])
def test_a_clock_reset_mid_file_is_one_line_not_half_the_rows_dropped(tmp_path: Path, cli, gyro: bool) -> None:
    """The clock restarts from 0 at row 1000 (a logger restarted, two files joined): every later row is 'late'.
    Dropping them as a few late samples would lose half the recording with a warning; it is refused, naming where."""
    rows = _still_rows(2000, gyro)
    rows[1000:] = [f"{float(r.split(',', 1)[0]) - 10.0:.2f}," + r.split(",", 1)[1] for r in rows[1000:]]
    imu = tmp_path / "reset.csv"
    imu.write_text(f"t,{'gx,gy,gz,' if gyro else ''}ax,ay,az\n" + "".join(rows))
    res = cli("analyze", "--imu", imu, "--out", tmp_path / "out")
    res.one_line_error("the time goes back by 9.99 s after t=9.99 s", "split the file there")


def test_repeated_rows_and_a_corrupt_row_are_no_clock_reset(tmp_path: Path, cli) -> None:
    """Review of the clock-reset rule: 2.5 % of the rows written twice plus one late row, and one garbage row
    (a far-future time and an impossible acceleration), are rows to skip, not a reset to refuse."""
    rows = _still_rows(2000)
    rows = [r for i, r in enumerate(rows) for _ in range(2 if i % 40 == 0 else 1)]
    rows[1000] = "4.00," + rows[1000].split(",", 1)[1]  # one row 5 s late
    rows[1500] = "99999.0,0,0,0,1000000,0,0\n"
    imu = tmp_path / "dups.csv"
    imu.write_text("t,gx,gy,gz,ax,ay,az\n" + "".join(rows))
    res = cli("analyze", "--imu", imu, "--out", tmp_path / "out")
    assert res.rc == 0, res.err


def _imu_part(walk: Path, out: Path, keep) -> Path:  # noqa: ANN001
    from walkmon.tables import read_table, write_table

    cols = ("t", "gx", "gy", "gz", "ax", "ay", "az")
    imu = read_table(walk / "imu.csv", cols)
    m = keep(imu["t"])
    write_table(out, {k: imu[k][m] for k in cols})
    return out


def test_imu_starting_after_the_video_leaves_no_zero_angles_or_made_up_activity(walk: Path, tmp_path: Path,
                                                                                 cli) -> None:
    """An IMU switched on 2.9 s into a 6 s video: the frames before it are the vision's (they were all the first
    fused estimate: zero angles over 0.9 s of walking) and their seconds' activity is unknown, not the nearest
    second's."""
    from walkmon.consts import angles_deg_from_rotation, rotation_from_angles_deg
    from walkmon.tables import read_table

    imu = _imu_part(walk, tmp_path / "late.csv", lambda t: t >= 2.9)
    out = tmp_path / "out"
    res = cli("analyze", walk / "video.mp4", "--calib", walk / "camera.yaml", "--imu", imu, "--out", out,
              "--no-progress")
    assert res.rc == 0, res.err
    got = read_table(out / "angles.csv", ("t", "pitch", "yaw", "roll"))
    truth = read_table(walk / "truth.csv", ("t", "pitch", "yaw", "roll"))
    Rt = rotation_from_angles_deg(truth["pitch"], truth["yaw"], truth["roll"])
    true = angles_deg_from_rotation(Rt[0].T @ Rt)
    before = (got["t"] >= 2.0) & (got["t"] < 2.9)
    est = np.column_stack([got[k] for k in ("pitch", "yaw", "roll")])
    assert np.abs(true[before]).max() > 0.5  # the wearer walks there: zero angles would fail below
    assert np.abs(est[before] - true[before]).max() < 0.3
    assert np.abs(est - true).max() < 0.6  # and the frames after, relative to the same first frame
    rows = [r.split(",") for r in (out / "timeline.csv").read_text().splitlines()[1:]]
    assert [r[1] for r in rows[:3]] == ["unknown"] * 3
    doc = json.loads((out / "indicators.json").read_text())
    assert sum(doc["activity_s"].values()) == pytest.approx(6.0, abs=0.2)
    assert any("seconds outside it are unknown" in n for n in doc["input"]["notes"])


def test_imu_stopping_before_the_video_ends_leaves_its_last_seconds_unknown(walk: Path, tmp_path: Path, cli) -> None:
    imu = _imu_part(walk, tmp_path / "short.csv", lambda t: t <= 4.4)
    out = tmp_path / "out"
    res = cli("analyze", walk / "video.mp4", "--calib", walk / "camera.yaml", "--imu", imu, "--out", out,
              "--no-progress")
    assert res.rc == 0, res.err
    rows = [r.split(",") for r in (out / "timeline.csv").read_text().splitlines()[1:]]
    assert rows[-1][1] == "unknown"  # 5 s: the IMU had stopped (the second was its last one's, standing)


def test_calibrate_on_a_cut_video_prints_one_line_and_has_no_progress_option(walk: Path, tmp_path: Path) -> None:
    """User review: FFmpeg's own 'moov atom not found' came before walkmon's line (a fresh process: no earlier
    video open had quietened FFmpeg); and 'calibrate --no-progress' was an unknown option."""
    import subprocess
    import sys

    cut = tmp_path / "cut.mp4"
    cut.write_bytes((walk / "video.mp4").read_bytes()[:3000])
    env = {k: v for k, v in os.environ.items() if k != "OPENCV_FFMPEG_LOGLEVEL"}
    for extra in ([], ["--no-progress"]):
        res = subprocess.run([sys.executable, "-m", "walkmon", "calibrate", str(cut), "--out", str(tmp_path / "c.yaml"),
                              *extra], capture_output=True, text=True, timeout=120, env=env)
        assert res.returncode == 2
        assert len(res.stderr.strip().splitlines()) == 1, res.stderr
        assert "cannot open as a video" in res.stderr  # the video's fault, the option known


def test_an_image_given_as_a_video_is_named_too_short(tmp_path: Path, cli) -> None:
    """User review: 'need at least 10 samples, got 1', neither the file nor the problem named."""
    import cv2

    img = tmp_path / "photo.png"
    cv2.imwrite(str(img), np.random.default_rng(0).integers(0, 255, (120, 160, 3), dtype=np.uint8))  # textured
    res = cli("analyze", img, "--out", tmp_path / "out", "--no-progress")
    res.one_line_error(str(img), "too short to analyse: 1 sample(s) or frame(s)")


def test_a_repeated_time_in_an_angles_csv_is_named_with_its_row(tmp_path: Path, cli) -> None:
    """User review: 'times must be finite and strictly increasing', no file, no row."""
    rows = [f"{i / 10:.1f},0,0,0" for i in range(31)] + ["3.0,0,0,0"]
    path = tmp_path / "dup.csv"
    path.write_text("t,pitch,yaw,roll\n" + "\n".join(rows) + "\n")
    res = cli("indicators", path, "--out", tmp_path / "out")
    res.one_line_error(str(path), "sample 32 has t=3 after t=3")
