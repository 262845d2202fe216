"""Fixtures of the fault-injection suite: a short simulated walk (video, imu.csv, camera.yaml), a session
database with two ended sessions, and a helper that runs the CLI in-process and splits its outcome."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from walkmon.commands.cli import main

REPO = Path(__file__).resolve().parents[2]


@dataclass(frozen=True)
class CliResult:
    rc: int
    out: str
    err: str

    @property
    def err_lines(self) -> list[str]:
        return [ln for ln in self.err.splitlines() if ln.strip()]

    def one_line_error(self, *fragments: str) -> None:
        """Exit code 2, exactly one line on stderr, no traceback, and the line names the problem."""
        assert self.rc == 2, (self.rc, self.out, self.err)
        assert "Traceback" not in self.err and "Traceback" not in self.out, self.err
        assert len(self.err_lines) == 1, self.err
        for f in fragments:
            assert f in self.err, (f, self.err)


@pytest.fixture
def cli(capsys: pytest.CaptureFixture[str]):  # noqa: ANN201
    """``cli(*argv) -> CliResult``: ``walkmon ARGV`` in this process (fast: nothing re-imported)."""

    def run(*argv: object) -> CliResult:
        capsys.readouterr()
        try:
            rc = main([str(a) for a in argv])
        except SystemExit as exc:  # argparse usage errors
            rc = int(exc.code or 0)
        cap = capsys.readouterr()
        return CliResult(rc, cap.out, cap.err)

    return run


@pytest.fixture(scope="session")
def walk(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 6 s simulated walk (2 s standing, 2 s normal, 2 s standing) at 160x120: video.mp4, imu.csv (200 Hz), camera.yaml, truth.csv."""
    out = tmp_path_factory.mktemp("faults_walk")
    subprocess.run([sys.executable, "-m", "walkmon", "simulate", "--walk", "normal:2", "--width", "160",
                    "--height", "120", "--out", str(out)], check=True, capture_output=True, timeout=300)
    return out


@pytest.fixture
def sessions_db(tmp_path: Path) -> Path:
    """A data folder whose database holds two ended sessions (600 frames each) and returns its folder."""
    from walkmon.live.session_log import SessionLog

    data = tmp_path / "data"
    for sid in range(2):
        log = SessionLog(data, kind="live", camera=f"sim:normal:{sid}", flush_interval_s=1.0)
        for i in range(600):
            log.add_frame(i / 30.0, (0.1 * i % 7, 0.0, -1.0), 50, "rotation", "ok", 5.0)
        log.close("complete")
    return data


@pytest.fixture
def readonly_copy():  # noqa: ANN201
    """``readonly_copy(data_dir, user)``: a copy of the data folder that ``user`` (None: this user) can read but
    not write (folder 0555, files 0444) under a world-traversable temporary folder; removed afterwards."""
    import tempfile

    made: list[Path] = []

    def copy(path: Path, user: str | None) -> Path:
        base = Path(tempfile.mkdtemp(prefix="walkmon-ro-"))
        made.append(base)
        os.chmod(base, 0o755)
        dst = base / "data"
        shutil.copytree(path, dst)
        for f in dst.iterdir():
            os.chmod(f, 0o444)
        os.chmod(dst, 0o555)
        return dst

    yield copy
    for base in made:
        for p in (base / "data", base):
            if p.exists():
                os.chmod(p, 0o755)
        shutil.rmtree(base, ignore_errors=True)
