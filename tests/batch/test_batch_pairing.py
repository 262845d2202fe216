"""The pairing rule of ``walkmon batch``: which files make one recording, and its name (no cluster needed)."""

from __future__ import annotations

from pathlib import Path

import pytest

from walkmon.batching.pairing import find_recordings
from walkmon.errors import InvalidInputError


def _touch(root: Path, *names: str) -> None:
    for n in names:
        p = root / n
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(b"x")


def _by_name(recs):  # noqa: ANN001, ANN202
    return {r.name: r for r in recs}


def test_simulator_layout_folders_pair_video_imu_and_calibration(tmp_path: Path) -> None:
    _touch(tmp_path, "s1/video.mp4", "s1/imu.csv", "s1/camera.yaml", "s1/truth.csv",
           "s2/video.mp4", "s2/imu.csv", "s2/camera.yaml")
    recs = _by_name(find_recordings([tmp_path]))
    assert sorted(recs) == ["s1-video", "s2-video"]  # same stem: the folder names tell them apart
    r = recs["s1-video"]
    assert r.video == (tmp_path / "s1/video.mp4").resolve()
    assert r.imu == (tmp_path / "s1/imu.csv").resolve()
    assert r.calib == (tmp_path / "s1/camera.yaml").resolve()
    assert r.kind == "video+imu"


def test_stem_patterns_and_a_shared_folder(tmp_path: Path) -> None:
    _touch(tmp_path, "d/a.mp4", "d/a_imu.csv", "d/b.MOV", "d/b.imu.csv", "d/c.avi", "d/imu.csv", "d/camera.yaml",
           "d/c.yaml", "d/lone-imu.csv", "d/notes.txt", "d/angles.csv")
    recs = _by_name(find_recordings([tmp_path / "d"]))
    # three videos in one folder: imu.csv belongs to none of them and is analysed alone; camera.yaml is shared
    assert recs["a"].imu == (tmp_path / "d/a_imu.csv").resolve()
    assert recs["b"].imu == (tmp_path / "d/b.imu.csv").resolve()
    assert recs["c"].imu is None
    assert recs["a"].calib == recs["b"].calib == (tmp_path / "d/camera.yaml").resolve()
    assert recs["c"].calib == (tmp_path / "d/c.yaml").resolve()  # its own calibration first
    assert recs["imu"].kind == "imu"
    assert recs["lone-imu"].kind == "imu"
    # folder scans take *imu*.csv only (not angles.csv) and no other files
    assert sorted(recs) == ["a", "b", "c", "imu", "lone-imu"]


def test_a_cameras_upper_case_names_pair_as_the_lower_case_ones(tmp_path: Path) -> None:
    """User review: WALK.MP4 beside WALK_IMU.csv became two recordings, the video camera-only and the IMU alone,
    without a word: the IMU file is found case-insensitively, the stem patterns matched only literally."""
    _touch(tmp_path, "up/WALK.MP4", "up/WALK_IMU.csv", "up/WALK.YAML")
    recs = _by_name(find_recordings([tmp_path / "up"]))
    assert sorted(recs) == ["WALK"]
    assert recs["WALK"].imu == (tmp_path / "up/WALK_IMU.csv").resolve()
    assert recs["WALK"].calib == (tmp_path / "up/WALK.YAML").resolve()
    # review: two videos differing only by case took the same IMU; a pattern's folder was not looked in
    _touch(tmp_path, "two/walk.mp4", "two/WALK.MP4", "two/WALK_IMU.csv")
    recs = find_recordings([tmp_path / "two/walk.mp4", tmp_path / "two/WALK.MP4", tmp_path / "two/WALK_IMU.csv"])
    imus = [r.imu for r in recs if r.video is not None]
    assert imus.count((tmp_path / "two/WALK_IMU.csv").resolve()) == 1
    _touch(tmp_path, "s/walk.mp4", "s/walk_imu.csv", "s/imu/other.csv")
    (rec,) = [r for r in find_recordings([tmp_path / "s/walk.mp4"], imu_patterns=["imu/{stem}_imu.csv"])]
    assert rec.imu is None  # s/imu/walk_imu.csv does not exist; s/walk_imu.csv is not the pattern's
    # the patterns' order holds: {stem}_imu.csv by case before the folder's shared imu.csv (review)
    _touch(tmp_path, "o/WALK.MP4", "o/WALK_IMU.csv", "o/imu.csv")
    recs = _by_name(find_recordings([tmp_path / "o"]))
    assert recs["WALK"].imu == (tmp_path / "o/WALK_IMU.csv").resolve() and recs["imu"].kind == "imu"
    # a file another video names exactly but does not take stays free for this one (review: left unpaired)
    _touch(tmp_path, "q/Walk.mp4", "q/walk.mp4", "q/walk.imu.csv", "q/walk_imu.csv")
    recs = find_recordings([tmp_path / "q"])
    # walk.mp4 takes its exact {stem}.imu.csv (the first pattern), Walk.mp4 the next pattern's file by case
    assert sorted((r.video.name, r.imu.name) for r in recs if r.video is not None and r.imu is not None) == [
        ("Walk.mp4", "walk_imu.csv"), ("walk.mp4", "walk.imu.csv")]
    assert all(r.video is not None for r in recs)  # no IMU left over as a recording of its own


def test_explicit_calib_patterns_and_no_pairing(tmp_path: Path) -> None:
    _touch(tmp_path, "w/walk.mp4", "w/walk-imu.csv", "w/walk.yaml", "w/walk.gyro.csv", "cam.yaml")
    (r,) = find_recordings([tmp_path / "w" / "walk.mp4"], calib=tmp_path / "cam.yaml")
    assert r.calib == (tmp_path / "cam.yaml").resolve()  # --calib wins for every video
    assert r.imu == (tmp_path / "w/walk-imu.csv").resolve()  # paired although not among the inputs
    (r,) = find_recordings([tmp_path / "w" / "walk.mp4"], imu_patterns=["{stem}.gyro.csv"])
    assert r.imu == (tmp_path / "w/walk.gyro.csv").resolve()
    (r,) = find_recordings([tmp_path / "w" / "walk.mp4"], imu_patterns=["none"])
    assert r.imu is None and r.kind == "video"


def test_explicit_unknown_file_becomes_a_failed_recording(tmp_path: Path) -> None:
    _touch(tmp_path, "notes.txt", "v.mp4")
    recs = _by_name(find_recordings([tmp_path / "notes.txt", tmp_path / "v.mp4"]))
    assert recs["notes"].problem.startswith(f"{(tmp_path / 'notes.txt').resolve()}: not a video")
    assert recs["notes"].kind == "unknown"
    assert recs["v"].problem == ""


def test_globs_duplicates_and_the_output_folder(tmp_path: Path) -> None:
    _touch(tmp_path, "in/x.mp4", "in/y.mp4", "in/out/old.mp4", "in/.hidden/h.mp4")
    recs = find_recordings([str(tmp_path / "in" / "*.mp4"), tmp_path / "in", tmp_path / "in" / "x.mp4"],
                           exclude=tmp_path / "in" / "out")
    assert [r.name for r in recs] == ["x", "y"]  # each file once; out/ and hidden folders not searched


def test_inputs_that_do_not_exist_stop_the_batch(tmp_path: Path) -> None:
    with pytest.raises(InvalidInputError, match="no such file or folder"):
        find_recordings([tmp_path / "missing.mp4"])
    with pytest.raises(InvalidInputError, match="matches no files"):
        find_recordings([str(tmp_path / "*.mp4")])
    with pytest.raises(InvalidInputError, match="no recordings found"):
        find_recordings([tmp_path])
    _touch(tmp_path, "v.mp4")
    with pytest.raises(InvalidInputError, match="no such calibration file"):
        find_recordings([tmp_path], calib=tmp_path / "nope.yaml")


def test_names_are_safe_folder_names(tmp_path: Path) -> None:
    _touch(tmp_path, "a b/walk #1.mp4", "c/walk #1.mp4")
    names = sorted(r.name for r in find_recordings([tmp_path]))
    assert names == ["a_b-walk_1", "c-walk_1"]
