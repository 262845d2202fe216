"""Packaging: one version, the example config inside the package, and what the sdist and the wheel ship."""

from __future__ import annotations

import shutil
import subprocess
import sys
import tarfile
import tomllib
import zipfile
from pathlib import Path

import pytest

import walkmon
from walkmon.commands.cli import main

REPO = Path(__file__).resolve().parents[1]


def test_packaged_example_config_is_the_deploy_one_and_walkmon_config_prints_it(capsys: pytest.CaptureFixture[str]) -> None:
    from walkmon.live.config import read_config

    packaged = REPO / "walkmon" / "live" / "example.toml"
    assert packaged.read_bytes() == (REPO / "deploy" / "walkmon.toml").read_bytes(), (
        "deploy/walkmon.toml and walkmon/live/example.toml must stay the same file: copy one onto the other")
    assert main(["config", "--example"]) == 0
    assert capsys.readouterr().out == packaged.read_text(encoding="utf-8")
    read_config(packaged)  # it parses
    assert main(["config", "--check", str(packaged)]) == 0


def test_walkmon_config_check_rejects_a_bad_file_in_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "walkmon.toml"
    bad.write_text("[camera]\nfps = 'fast'\n", encoding="utf-8")
    assert main(["config", "--check", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "walkmon.toml" in err


@pytest.mark.parametrize(("body", "needle"), [
    ('[camera]\ncalib = "{tmp}/none.yaml"\n', "none.yaml"),
    ('[imu]\ncalibration = "{tmp}/none.json"\n', "none.json"),
    ('[camera]\nurl = "ftp:x"\n', "unknown scheme 'ftp'"),
    ('[imu]\nurl = "serial:/dev/x?baud=fast"\n', "baud"),
])
def test_walkmon_config_check_refuses_what_live_refuses(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                       body: str, needle: str) -> None:
    """A calibration file that is not there, a URL 'walkmon live' cannot use: 'config --check' said ok, then the
    service exited 2 at every restart (user review). One line, exit 2, as live says it."""
    cfg = tmp_path / "walkmon.toml"
    cfg.write_text(body.format(tmp=tmp_path), encoding="utf-8")
    assert main(["config", "--check", str(cfg)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and needle in err


def test_version_is_written_once() -> None:
    project = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))
    assert "version" not in project["project"] and "version" in project["project"]["dynamic"]
    assert project["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "walkmon._version.__version__"}
    out = subprocess.run([sys.executable, "-m", "walkmon", "--version"], capture_output=True, text=True, timeout=120,
                         check=True)
    assert out.stdout.strip() == f"walkmon {walkmon.__version__}"
    assert project["project"]["license"] == "MIT"


def _copy_source(dst: Path) -> Path:
    ignore = shutil.ignore_patterns(".git", ".venv", "build", "dist", "*.egg-info", "__pycache__", ".pytest_cache",
                                    ".mypy_cache", ".ruff_cache", "results", "cache")
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy2(REPO / name, dst / name)
    for name in ("walkmon", "drivers"):
        shutil.copytree(REPO / name, dst / name, ignore=ignore)
    return dst


@pytest.mark.slow
def test_sdist_and_wheel_ship_license_typing_marker_and_example_config(tmp_path: Path) -> None:
    pytest.importorskip("build", reason="the 'build' package (test extra) builds the sdist and wheel")
    (tmp_path / "src").mkdir()
    src = _copy_source(tmp_path / "src")  # build writes egg-info next to the sources: not into the checkout
    out = subprocess.run([sys.executable, "-m", "build", "--no-isolation", "--outdir", str(tmp_path / "dist"),
                          str(src)], capture_output=True, text=True, timeout=300, check=False)
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-2000:]
    version = walkmon.__version__
    wheel = zipfile.ZipFile(tmp_path / "dist" / f"walkmon-{version}-py3-none-any.whl")
    names = set(wheel.namelist())
    assert f"walkmon-{version}.dist-info/licenses/LICENSE" in names
    assert {"walkmon/py.typed", "walkmon/live/example.toml", "walkmon/api.py", "walkmon/drivers/video_file.py"} <= names
    metadata = wheel.read(f"walkmon-{version}.dist-info/METADATA").decode()
    assert "License-Expression: MIT" in metadata and f"Version: {version}" in metadata
    assert "Classifier: Typing :: Typed" in metadata and "Project-URL: " in metadata
    with tarfile.open(tmp_path / "dist" / f"walkmon-{version}.tar.gz") as sdist:
        snames = set(sdist.getnames())
    for name in ("LICENSE", "walkmon/py.typed", "walkmon/live/example.toml"):
        assert f"walkmon-{version}/{name}" in snames, name


def test_slow_tests_run_by_default() -> None:
    """The real-time and end-to-end tests are marked slow so they can be deselected by hand (-m 'not slow'),
    but the default run (CI: the README's test command) runs them."""
    project = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))
    opts = project["tool"]["pytest"]["ini_options"]
    assert any(m.startswith("slow:") for m in opts["markers"])
    assert "slow" not in opts["addopts"]
    marked = [p for p in (REPO / "tests").rglob("test_*.py") if "mark.slow" in p.read_text(encoding="utf-8")]
    assert {"test_pipeline.py", "test_end_to_end.py", "test_live_cli.py"} <= {p.name for p in marked}
