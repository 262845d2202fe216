"""``walkmon.batch`` on a real Dask LocalCluster: 10 recordings (2 corrupt), one worker killed mid-run, outputs
identical to ``walkmon analyze``, ``--resume``, and the command line."""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import time
from pathlib import Path
from types import SimpleNamespace

import pytest

pd = pytest.importorskip("pandas")
pytest.importorskip("distributed")

import walkmon  # noqa: E402
from walkmon.batching.tables import BOUT_COLUMNS, SUMMARY_COLUMNS  # noqa: E402
from walkmon.batching.worker import STATE_DIR  # noqa: E402
from walkmon.commands.cli import main as cli_main  # noqa: E402

#: the report's generation time ("generated (UTC)" or "generated (local time)"): the one line that may differ
_GENERATED = re.compile(r"generated \([^)]*\)</t[hd]>\s*<td>[^<]*</td>")


def _kill_when_started(out: Path, name: str, killed: list[int]):  # noqa: ANN202
    """An ``on_start`` hook: once ``name``'s task has started on a worker, SIGKILL that worker process."""
    def hook(client, tasks) -> None:  # noqa: ANN001, ARG001
        path = out / STATE_DIR / "attempts" / name
        deadline = time.monotonic() + 600
        while time.monotonic() < deadline:
            if path.is_file() and (line := path.read_text(encoding="utf-8").strip()):
                pid = int(line.split()[-1])
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
                return
            time.sleep(0.01)
        pytest.fail(f"task {name} never started")
    return hook


@pytest.fixture(scope="module")
def first_run(recordings: Path, dask_client, tmp_path_factory: pytest.TempPathFactory):  # noqa: ANN001, ANN201
    out = tmp_path_factory.mktemp("batch_out") / "out"
    killed: list[int] = []
    summary = walkmon.batch([recordings.root], out, client=dask_client, on_start=_kill_when_started(out, "s0_imu", killed))
    return out, summary, killed


def test_ten_recordings_two_corrupt_one_worker_killed(first_run, recordings: SimpleNamespace) -> None:  # noqa: ANN001
    out, summary, killed = first_run
    OK_NAMES, FAILED_NAMES, IMU_WALKS = recordings.ok_names, recordings.failed_names, recordings.imu_walks  # noqa: N806
    root = recordings.root
    assert killed, "no worker was killed"
    assert list(summary.columns) == list(SUMMARY_COLUMNS)
    assert sorted(summary["name"]) == sorted([*OK_NAMES, *FAILED_NAMES])
    by_name = summary.set_index("name")
    assert (by_name.loc[list(OK_NAMES), "status"] == "ok").all(), by_name[["status", "error"]]
    assert (by_name.loc[list(FAILED_NAMES), "status"] == "failed").all()
    assert (by_name.loc[list(OK_NAMES), "error"] == "").all()
    # the one-line reasons name the file and what is wrong with it
    broken = by_name.loc["broken", "error"]
    assert str(root / "broken.mp4") in broken
    assert "video" in broken
    assert "\n" not in broken
    bad = by_name.loc["bad_imu", "error"]
    assert str(root / "bad_imu.csv") in bad
    assert "missing column" in bad
    # the task whose worker was killed ran again (on the restarted or the other worker) and finished
    assert by_name.loc["s0_imu", "attempts"] == 2
    assert by_name.loc["s0_imu", "status"] == "ok"
    # a task that had finished on the killed worker but whose result the client had not fetched yet is run again
    # too (Dask recomputes lost results); nothing ran more than twice
    assert by_name["attempts"].between(1, 2).all()
    # pairing: walk_a fused with its IMU file, walk_b with its folder's camera.yaml, IMU files alone
    assert by_name.loc["walk_a", "kind"] == "video+imu"
    assert by_name.loc["walk_a", "imu"] == str(root / "walk_a_imu.csv")
    assert by_name.loc["walk_b", "kind"] == "video"
    assert by_name.loc["walk_b", "calib"] == str(root / "cam_only" / "camera.yaml")
    assert (by_name.loc[[f"s{i}_imu" for i in range(len(IMU_WALKS))], "kind"] == "imu").all()
    # every ok recording has the files of 'walkmon analyze'; no temporary folder is left over
    for name in OK_NAMES:
        assert {"angles.csv", "indicators.json", "report.html"} <= {p.name for p in (out / name).iterdir()}
    assert not (out / "broken").exists()
    assert not list((out / STATE_DIR).glob("tmp/*"))
    # the tables on disk hold the same rows as the returned DataFrame
    on_disk = pd.read_parquet(out / "summary.parquet")
    pd.testing.assert_frame_equal(on_disk, summary, check_dtype=False)
    csv = pd.read_csv(out / "summary.csv", keep_default_na=False)
    assert list(csv["name"]) == list(summary["name"])
    assert list(csv["status"]) == list(summary["status"])


def test_summary_values_come_from_each_recordings_indicators(first_run, recordings: SimpleNamespace) -> None:  # noqa: ANN001
    """Each row against the recording's own indicators.json, and the simulated walk type where the IMU-only
    analysis recognises it (the simulator's truth, not walkmon's output)."""
    out, summary, _ = first_run
    OK_NAMES, IMU_WALKS = recordings.ok_names, recordings.imu_walks  # noqa: N806
    for _, row in summary[summary["status"] == "ok"].iterrows():
        doc = json.loads((out / row["name"] / "indicators.json").read_text(encoding="utf-8"))
        assert row["label"] == doc["classification"]["label"]
        assert row["duration_s"] == pytest.approx(doc["duration_s"])
        assert row["walking_s"] == pytest.approx(doc["walking_s"])
        for axis in ("pitch", "yaw", "roll"):
            want = doc["axes"][axis]["swing_mean"]
            assert (pd.isna(row[f"{axis}_swing_mean"]) and want is None) or row[f"{axis}_swing_mean"] == pytest.approx(want)
        # time per posture: indicators.json's own per-label times (schema 2), else all the walking time under
        # the recording's one label
        posture = row[[c for c in SUMMARY_COLUMNS if c.startswith("time_")]]
        per_label = (doc.get("summary") or {}).get("posture_time_s")
        if per_label is None:
            assert posture.sum() == pytest.approx(row["walking_s"])
            assert posture[f"time_{row['label']}_s"] == pytest.approx(row["walking_s"])
        else:
            for lab, sec in per_label.items():
                assert posture[f"time_{lab}_s"] == pytest.approx(sec)
        assert row["n_bouts"] == len(doc.get("bouts") or [])
        assert row["walkmon_version"] == walkmon.__version__
    by_name = summary.set_index("name")
    truth = {f"s{i}_imu": walk for i, (walk, _) in enumerate(IMU_WALKS)}
    bends = [n for n, w in truth.items() if w == "bend"]
    assert (by_name.loc[bends, "label"] == "bend").all()  # a 15-20 deg forward lean is unmistakable
    assert (by_name.loc[list(truth), "duration_s"].between(11.5, 12.5)).all()  # 12 s simulated
    bouts = pd.read_parquet(out / "bouts.parquet")
    assert list(bouts.columns)[: len(BOUT_COLUMNS)] == list(BOUT_COLUMNS)
    assert set(bouts["name"]) <= set(OK_NAMES)
    assert len(bouts) == int(summary["n_bouts"].sum())


def _without_timestamp(html: str) -> str:
    return _GENERATED.sub("", html)


@pytest.mark.parametrize("name", ["walk_a", "s1_imu"])
def test_outputs_identical_to_walkmon_analyze(first_run, tmp_path: Path, name: str,  # noqa: ANN001
                                              capsys: pytest.CaptureFixture[str]) -> None:
    """The batch's OUT/<name>/ against 'walkmon analyze' run by hand on the same files: byte for byte, except the
    report's generation time."""
    out, summary, _ = first_run
    row = summary.set_index("name").loc[name]
    argv = ["analyze", *([row["video"]] if row["video"] else []), "--out", str(tmp_path / "ref"), "--no-progress"]
    if row["imu"]:
        argv += ["--imu", row["imu"]]
    assert cli_main(argv) == 0
    capsys.readouterr()
    ref = tmp_path / "ref"
    got = out / name
    assert sorted(p.name for p in got.iterdir()) == sorted(p.name for p in ref.iterdir())
    for p in ref.iterdir():
        if p.name == "report.html":
            a = _without_timestamp(p.read_text(encoding="utf-8"))
            b = _without_timestamp((got / p.name).read_text(encoding="utf-8"))
            assert "generated (" not in a and "generated (" not in b  # the time stamp row was taken out
            assert a == b
        else:
            assert (got / p.name).read_bytes() == p.read_bytes(), p.name


def test_resume_keeps_complete_outputs_and_redoes_changed_ones(first_run, recordings: SimpleNamespace,  # noqa: ANN001
                                                                dask_client, tmp_path: Path) -> None:  # noqa: ANN001
    out0, _, _ = first_run
    OK_NAMES, FAILED_NAMES = recordings.ok_names, recordings.failed_names  # noqa: N806
    out = tmp_path / "out"
    shutil.copytree(out0, out)  # a batch that finished; then an input changes and an output goes missing
    inputs = tmp_path / "in"
    shutil.copytree(recordings.root, inputs)
    # the manifest records absolute input paths: point the copy's entries at the copied inputs
    manifest = (out / "manifest.json").read_text(encoding="utf-8").replace(str(recordings.root), str(inputs))
    (out / "manifest.json").write_text(manifest, encoding="utf-8")
    shutil.copy(inputs / "s0_imu.csv", inputs / "s4_imu.csv")  # s4's input changed (now s0's walk)
    (out / "s2_imu" / "report.html").unlink()  # s2's outputs incomplete
    mtimes = {n: (out / n / "angles.csv").stat().st_mtime_ns for n in OK_NAMES}
    summary = walkmon.batch([inputs], out, client=dask_client, resume=True)
    by_name = summary.set_index("name")
    redone = {"s4_imu", "s2_imu"}
    kept = set(OK_NAMES) - redone
    assert by_name.loc[sorted(kept), "resumed"].all()
    assert not by_name.loc[sorted(redone | set(FAILED_NAMES)), "resumed"].any()
    assert (by_name.loc[list(OK_NAMES), "status"] == "ok").all()
    assert (by_name.loc[list(FAILED_NAMES), "status"] == "failed").all()  # failed ones are tried again
    for n in kept:
        assert (out / n / "angles.csv").stat().st_mtime_ns == mtimes[n]
    for n in redone:
        assert (out / n / "angles.csv").stat().st_mtime_ns != mtimes[n]
    assert (out / "s2_imu" / "report.html").is_file()
    # s4 now holds s0's walk: the same angles as s0
    assert (out / "s4_imu" / "angles.csv").read_bytes() == (out / "s0_imu" / "angles.csv").read_bytes()
    # and the kept rows carry the numbers of the first run
    first = pd.read_parquet(out0 / "summary.parquet").set_index("name")
    for n in kept:
        assert by_name.loc[n, "cadence_spm"] == pytest.approx(first.loc[n, "cadence_spm"], nan_ok=True)


def test_command_line_on_a_running_scheduler(first_run, recordings: SimpleNamespace, dask_client,  # noqa: ANN001
                                              tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """'walkmon batch --scheduler ADDRESS --resume' on a cluster that is already running (and stays running):
    a recording finished in the first run is kept, the corrupt one fails again and makes the exit code 1."""
    out0, _, _ = first_run
    out = tmp_path / "o"
    shutil.copytree(out0, out)
    address = dask_client.scheduler.address
    code = cli_main(["batch", str(recordings.root / "s3_imu.csv"), str(recordings.root / "bad_imu.csv"), "--out",
                     str(out), "--scheduler", address, "--resume", "--no-progress"])
    text = capsys.readouterr()
    assert code == 1
    assert "s3_imu: ok: " in text.out
    assert "(kept from the earlier run)" in text.out
    assert "bad_imu: failed: " in text.out and "missing column" in text.out
    assert "2 recordings: 1 ok (1 kept from the earlier run), 1 failed" in text.out
    assert "Traceback" not in text.err
    summary = pd.read_csv(out / "summary.csv", keep_default_na=False)
    assert sorted(summary["name"]) == ["bad_imu", "s3_imu"]  # the tables describe this batch's inputs
    assert dask_client.submit(len, "abc").result() == 3  # the cluster is still up


def test_output_folder_is_private(first_run) -> None:  # noqa: ANN001
    out, _, _ = first_run
    assert out.stat().st_mode & 0o077 == 0  # health data: the folder the batch created is the user's alone
    for name in ("summary.parquet", "summary.csv", "bouts.parquet", "manifest.json"):
        assert (out / name).stat().st_mode & 0o077 == 0
    # every folder under it too, the bookkeeping's (user review: .walkmon-batch/attempts, named after the
    # recordings, was 0755 under umask 022)
    folders = [p for p in out.rglob("*") if p.is_dir()]
    assert folders and all(p.stat().st_mode & 0o077 == 0 for p in folders), \
        [(str(p), oct(p.stat().st_mode)) for p in folders if p.stat().st_mode & 0o077]


def test_command_line_bad_inputs_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert cli_main(["batch", str(tmp_path / "nope.mp4"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "nope.mp4: no such file or folder" in err
    assert cli_main(["batch", str(tmp_path / "*.mp4"), "--out", str(tmp_path / "o")]) == 2
    assert "matches no files" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()  # nothing started, nothing written
