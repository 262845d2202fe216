"""Fault injection, signals at random times: SIGINT, SIGTERM and SIGUSR1 (``systemctl reload``) sent to
``walkmon live`` at seeded random moments, some counted from the process start (the interpreter's start-up, the
imports, the session being created, the camera opening), some from the first committed frames (a running
session); every run must end in a closed session or no session, never a traceback and never a session without
an end time (issue 12, item 6). Runs go a few at a time, each driven by its own thread."""

from __future__ import annotations

import signal
import sqlite3
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

SEED = 2026
CAMERA = "sim:normal:60?width=96&height=72&realtime=1"
BATCH = 4


def _schedule() -> list[tuple[signal.Signals, float, str]]:
    """(signal, delay s, counted from "start" or "frames")."""
    rng = np.random.default_rng(SEED)
    runs = [(signal.SIGINT, 0.25, "start"), (signal.SIGTERM, 0.25, "start")]  # the interpreter's start, imports
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGUSR1):
        runs += [(sig, float(d), "start") for d in rng.uniform(0.3, 4.0, 2)]
        runs += [(sig, float(d), "frames") for d in rng.uniform(0.0, 1.0, 1)]
    return runs


def _in_interpreter_start(rc: int | None, sig: signal.Signals, err: str) -> bool:
    """The signal arrived while the Python interpreter itself was starting (``site``, ``runpy``), before any
    walkmon code could install a handler: SIGTERM's default action ends it silently, SIGINT makes Python print
    its own KeyboardInterrupt. No session can exist yet; walkmon cannot act before its first line."""
    if rc == -sig and sig != signal.SIGINT:
        return True
    # runpy / site frames, or the package's own __init__ (the drivers mapping) that runs before the entry point
    # can install walkmon's handlers: a known gap of ~10 ms on an idle machine (README, Reliability)
    frames = [ln for ln in err.splitlines() if ln.strip().startswith("File ")]
    before_entry = all("/walkmon/" not in ln or ln.split('"')[1].endswith(("walkmon/__init__.py", "walkmon/_checkout.py"))
                       for ln in frames)
    python_only = "Traceback" in err and before_entry and "walkmon/commands/" not in err
    return (rc == 1 and "init_import_site" in err) or (rc == -signal.SIGINT and python_only)


def _has_frames(db: Path) -> bool:
    if not db.exists():
        return False
    try:
        conn = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
        try:
            return bool(conn.execute("SELECT COUNT(*) FROM frames").fetchone()[0])
        finally:
            conn.close()
    except sqlite3.Error:
        return False


def _drive(proc: subprocess.Popen[str], data: Path, sig: signal.Signals, delay: float, anchor: str) -> None:
    if anchor == "frames":
        deadline = time.monotonic() + 120
        while not _has_frames(data / "walkmon.sqlite") and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.1)
    time.sleep(delay)
    if proc.poll() is None:
        proc.send_signal(sig)
    if sig == signal.SIGUSR1:  # a calibration request: the session runs on; then stop it
        time.sleep(1.0)
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)


@pytest.fixture
def sigint_not_ignored() -> Iterator[None]:
    """Children inherit an ignored SIGINT (a test run started in the background of a shell without job
    control, nohup): the interpreter then keeps ignoring it until walkmon installs its handlers, and a SIGINT in
    the first moments is lost. A terminal or systemd starts walkmon with SIGINT at its default; so do these runs
    (a Python-level handler in this process is reset to the default in each child at exec)."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


@pytest.mark.usefixtures("sigint_not_ignored")
def test_signals_at_random_times_always_close_the_session(tmp_path: Path) -> None:
    runs = _schedule()
    results = []
    for batch in range(0, len(runs), BATCH):
        started = []
        for i in range(batch, min(batch + BATCH, len(runs))):
            data = tmp_path / f"run{i}"
            cmd = [sys.executable, "-m", "walkmon", "live", "--camera", CAMERA, "--duration", "60", "--data-dir",
                   str(data), "--status", "none"]
            proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            th = threading.Thread(target=_drive, args=(proc, data, *runs[i]), daemon=True)
            th.start()
            started.append((i, proc, data, th))
        for i, proc, data, th in started:
            try:
                out, err = proc.communicate(timeout=180)
            finally:
                if proc.poll() is None:
                    proc.kill()
                    proc.communicate()
            th.join(5)
            results.append((runs[i], proc.returncode, out, err, data))
    outcomes = []
    for (sig, delay, anchor), rc, out, err, data in results:
        what = f"{sig.name} {delay:.2f} s after {anchor}: rc {rc}\n{out}{err}"
        if _in_interpreter_start(rc, sig, err):  # before any walkmon code ran: Python's own
            assert not (data / "walkmon.sqlite").exists(), what
            outcomes.append("python start-up")
            continue
        assert "Traceback" not in err, what
        assert rc in (0, 128 + signal.SIGINT, 128 + signal.SIGTERM), what
        sessions = []
        if (data / "walkmon.sqlite").exists():
            conn = sqlite3.connect(data / "walkmon.sqlite")
            try:
                sessions = conn.execute("SELECT id, ended_utc, end_reason FROM sessions").fetchall()
            finally:
                conn.close()
        assert len(sessions) <= 1 and all(s[1] for s in sessions), what  # closed, or none at all
        if sessions:
            assert sessions[0][2].startswith("signal SIG"), what
        if rc != 0:  # interrupted before the session was created: one line, no session
            assert not sessions and len(err.strip().splitlines()) == 1 and "interrupted" in err, what
        outcomes.append("session" if sessions else "none")
    print("signal outcomes:", {k: outcomes.count(k) for k in sorted(set(outcomes))})  # noqa: T201 - for -s runs
    assert outcomes.count("session") >= 3  # the runs counted from the first frames hit running sessions


class _Stops:
    def __init__(self) -> None:
        self.reasons: list[str] = []

    def stop(self, reason: str = "stopped") -> None:
        self.reasons.append(reason)

    def request_calibration(self) -> None:  # pragma: no cover - not sent here
        pass


def test_a_signal_turned_into_another_error_by_library_code_still_ends_as_interrupted(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """A SIGTERM raised while a C extension is being imported comes back as an ImportError (pybind11 converts
    it; seen as 'generic_type: type "ObjSense" is already registered!' from SciPy on the next import): the
    command must still end as interrupted, one line and 128 + 15, not as an error with exit 2."""
    import argparse
    import os

    from walkmon.commands import _signals, cli
    from walkmon.errors import WalkmonError

    def run(_args: argparse.Namespace) -> int:
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(1.0)  # the handler runs here and raises Interrupted
        except BaseException as exc:  # what the extension's import machinery does with it
            raise ImportError("initialization failed") from exc
        return 0

    def failing_run(args: argparse.Namespace) -> int:
        try:
            return run(args)
        except ImportError as exc:
            raise WalkmonError(f"unexpected error: {exc!r}") from exc

    fake = argparse.Namespace(NAME="fake", HELP="a command whose library turns a signal into an error",
                              add_arguments=lambda p: None, run=failing_run)
    monkeypatch.setattr(cli, "_commands", lambda: [fake])
    assert cli.main(["fake"]) == 128 + signal.SIGTERM
    err = capsys.readouterr().err
    assert err == "walkmon: interrupted (SIGTERM)\n"
    assert _signals.received() is None  # main() put the handlers and the record back

    # swallowed on its way up: the next target (walkmon live's pending stop) is stopped at once
    previous = _signals.install()
    try:
        try:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(1.0)
        except _signals.Interrupted:
            pass  # a library that catches everything and goes on
        stops = _Stops()
        with _signals.deliver_to(stops):
            assert stops.reasons == ["signal SIGINT"]
    finally:
        _signals.restore(previous)


def test_a_signal_inside_the_import_machinery_waits_until_the_import_has_moved_on() -> None:
    """CI: a SIGTERM 1.61 s into 'walkmon live' arrived while the import system ran a callback of its module locks,
    whose exceptions Python prints and drops ('Exception ignored in: <function _get_module_lock.<locals>.cb>',
    a traceback on stderr; the session still closed). There the handler now sends the signal again a moment
    later instead of raising; anywhere else it raises as before."""
    import types

    from walkmon.commands import _signals

    in_import = types.SimpleNamespace(f_code=types.SimpleNamespace(co_filename="<frozen importlib._bootstrap>"))
    previous = _signals.install()
    try:
        _signals._on_stop(signal.SIGTERM, in_import)  # no exception here ...
        with pytest.raises(_signals.Interrupted):  # ... the signal comes again, outside, and raises
            deadline = time.monotonic() + 5.0
            while time.monotonic() < deadline:
                time.sleep(0.01)
        assert _signals.received() == signal.SIGTERM
        with pytest.raises(_signals.Interrupted):
            _signals._on_stop(signal.SIGINT, sys._getframe())
    finally:
        _signals.restore(previous)
