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
