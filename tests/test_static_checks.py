"""The linter and the type checker are part of the suite: `ruff check` and `mypy` (configured in pyproject.toml)
must report nothing. Skipped only where they are not installed (they are in the `test` extra)."""

from __future__ import annotations

import importlib.util
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def _require(module: str) -> None:
    if importlib.util.find_spec(module) is None:
        pytest.skip(f"{module} is not installed (pip install '.[test]')")


def test_ruff_check_is_clean() -> None:
    _require("ruff")
    out = subprocess.run([sys.executable, "-m", "ruff", "check", "--no-cache", "--output-format", "concise", "."],
                         cwd=REPO, capture_output=True, text=True, timeout=300, check=False)
    assert out.returncode == 0, out.stdout[-6000:] + out.stderr[-2000:]


@pytest.mark.slow
def test_mypy_is_clean_on_walkmon_and_drivers(tmp_path: Path) -> None:
    """drivers/ installs as walkmon.drivers (package-dir), which mypy cannot follow in a checkout: check a copy
    laid out as installed (walkmon/ with drivers/ as walkmon/drivers/), with the repository's configuration."""
    _require("mypy")
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    shutil.copytree(REPO / "walkmon", tmp_path / "walkmon", ignore=ignore)
    shutil.copytree(REPO / "drivers", tmp_path / "walkmon" / "drivers", ignore=ignore)
    shutil.copy2(REPO / "pyproject.toml", tmp_path / "pyproject.toml")
    out = subprocess.run([sys.executable, "-m", "mypy", "--cache-dir", str(tmp_path / ".mypy_cache")],
                         cwd=tmp_path, capture_output=True, text=True, timeout=600, check=False)
    report = out.stdout.replace("walkmon/drivers/", "drivers/")
    assert out.returncode == 0, report[-6000:] + out.stderr[-2000:]
    assert "Success: no issues found" in report
