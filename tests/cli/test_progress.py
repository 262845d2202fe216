"""Progress bars: an ETA on a terminal, nothing at all when the output is not a terminal."""

from __future__ import annotations

import io
import re
import subprocess
import sys

from walkmon.commands.progress import Progress


class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_bar_with_eta_on_a_terminal_and_none_elsewhere() -> None:
    tty = _Tty()
    with Progress(None, "rendering", "frame", stream=tty, delay_s=0.0) as p:
        for i in range(10):
            p.set(i + 1, 40)
    text = tty.getvalue()
    assert "rendering" in text and "10/40" in text
    assert re.search(r"\[\d\d:\d\d<\d\d:\d\d", text), text  # elapsed<remaining: the ETA
    pipe = io.StringIO()
    with Progress(40, "rendering", "frame", stream=pipe, delay_s=0.0) as p:
        p.update(10)
    assert pipe.getvalue() == "" and p.count == 10
    forced_off = _Tty()
    with Progress(40, "x", "frame", stream=forced_off, enabled=False, delay_s=0.0) as p:
        p.update(3)
    assert forced_off.getvalue() == ""


def test_simulate_prints_no_bar_into_a_pipe(tmp_path) -> None:  # noqa: ANN001
    r = subprocess.run([sys.executable, "-m", "walkmon", "simulate", "--walk", "normal", "--seconds", "4.5", "--width",
                        "64", "--height", "48", "--fps", "10", "--out", str(tmp_path)], capture_output=True, text=True,
                       timeout=120, check=False)
    assert r.returncode == 0, r.stderr
    assert r.stderr == "" and r.stdout.startswith("simulated 'normal'")
