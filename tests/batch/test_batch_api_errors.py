"""``walkmon.batch`` refuses bad arguments with a one-line WalkmonError before any cluster starts."""

from __future__ import annotations

from pathlib import Path

import pytest

import walkmon
from walkmon.errors import ConfigError, InvalidInputError

pytest.importorskip("distributed")


@pytest.fixture
def one_imu(tmp_path: Path) -> Path:
    p = tmp_path / "in" / "a_imu.csv"
    p.parent.mkdir()
    p.write_text("t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,-9.81,0\n", encoding="utf-8")
    return p


@pytest.mark.parametrize(("kwargs", "error", "match"), [
    ({"method": "slow"}, ConfigError, "method must be one of fast, paper"),
    ({"imu_filter": "kalman"}, ConfigError, "imu_filter must be one of"),
    ({"workers": 0}, ConfigError, "workers must be >= 1"),
    ({"workers": 2, "scheduler": "tcp://127.0.0.1:8786"}, ConfigError, "not both"),
    ({"baseline": "/nonexistent/indicators.json"}, InvalidInputError, "no such baseline file"),
])
def test_bad_arguments(one_imu: Path, tmp_path: Path, kwargs: dict, error: type, match: str) -> None:
    with pytest.raises(error, match=match):
        walkmon.batch([one_imu], tmp_path / "out", **kwargs)
    assert not (tmp_path / "out").exists()


def test_out_that_is_a_file(one_imu: Path, tmp_path: Path) -> None:
    (tmp_path / "out").write_text("x", encoding="utf-8")
    with pytest.raises(InvalidInputError, match="exists and is not a folder"):
        walkmon.batch([one_imu], tmp_path / "out")


def test_a_folder_emptied_under_the_worker_never_replaces_a_complete_result(tmp_path: Path) -> None:
    """User review: a Ctrl-C removed the batch's temporary folders while a worker was still writing, and the
    worker then moved its half-emptied folder (report.html alone) over the complete result of an earlier run.
    A folder missing any file the analysis wrote is refused, and the earlier result stays whole."""
    from walkmon.batching.worker import _replace_folder

    final, tmp, state = tmp_path / "out" / "walk", tmp_path / "state" / "tmp" / "walk-1", tmp_path / "state"
    final.mkdir(parents=True)
    tmp.mkdir(parents=True)
    names = ("angles.csv", "indicators.json", "report.html", "timeline.csv")
    for n in names:
        (final / n).write_text(f"earlier {n}")
    (tmp / "report.html").write_text("new")  # the others removed under the worker
    with pytest.raises(InvalidInputError, match="angles.csv, indicators.json, timeline.csv gone"):
        _replace_folder(tmp, final, state, names)
    assert sorted(p.name for p in final.iterdir()) == sorted(names)
    assert (final / "indicators.json").read_text() == "earlier indicators.json"
    for n in names:  # complete: it replaces the earlier result
        (tmp / n).write_text(f"new {n}")
    _replace_folder(tmp, final, state, names)
    assert (final / "indicators.json").read_text() == "new indicators.json"


def test_a_device_as_baseline_is_not_called_missing(one_imu: Path, tmp_path: Path) -> None:
    """'batch --baseline /dev/zero' said 'no such baseline file' of a file that exists (user review)."""
    with pytest.raises(InvalidInputError, match="not a regular file"):
        walkmon.batch([one_imu], tmp_path / "out", baseline="/dev/zero", workers=1)

