"""Signal handling of the ``walkmon`` command line, from its first line on.

SIGINT and SIGTERM must end every command cleanly at any moment, and ``walkmon live`` must never leave a
session without an end time; SIGUSR1 (what ``systemctl reload walkmon`` sends) must never kill the monitor.

* :func:`install` runs first in :func:`walkmon.cli.main`, before the subcommands (numpy, OpenCV) are imported.
  Until a command says otherwise, SIGINT/SIGTERM raise :class:`Interrupted` in the main thread: the command
  unwinds (a file being written is left as it was: :mod:`walkmon.safe_io`) and ``main`` prints one line and
  exits 128 + the signal number. SIGUSR1 is ignored while nothing can take a calibration.
* :func:`deliver_to` hands the signals to an object instead (``stop(reason)`` / ``request_calibration()``): from
  just before ``walkmon live`` creates its session to its end, a signal never raises, it asks the pipeline to
  stop, which closes the session. A :class:`PendingStop` holds what arrives before the pipeline exists and
  passes it on (:meth:`PendingStop.forward_to`).
"""

from __future__ import annotations

import contextlib
import signal
from collections.abc import Callable, Iterator
from typing import Any, Protocol, TypeVar

__all__ = ["Interrupted", "PendingStop", "deliver_to", "install", "received", "signal_name"]


class Interrupted(BaseException):  # noqa: N818 - like KeyboardInterrupt, not an error
    """SIGINT or SIGTERM arrived while the command could simply unwind."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal_name(signum))
        self.signum = signum


class StopTarget(Protocol):
    def stop(self, reason: str = ...) -> None: ...
    def request_calibration(self) -> None: ...


def signal_name(signum: int) -> str:
    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"


_target: StopTarget | None = None
_T = TypeVar("_T", bound=StopTarget)
#: the first SIGINT/SIGTERM raised as :class:`Interrupted` (until :func:`restore`): an exception raised inside
#: library code can come back as another one (a C extension being imported turns it into an ImportError, and
#: the half-imported module then fails differently) or be swallowed; see :func:`received`
_received: int | None = None


#: While a signal finds the interpreter in its import machinery it is delivered again this much later (s).
_IMPORT_RETRY_S = 0.01


def _on_stop(signum: int, frame: object) -> None:
    global _received  # noqa: PLW0603 - one process-wide signal disposition
    target = _target
    if target is None:
        if _in_import_machinery(frame):
            # raised here, Interrupted could land in a callback of the import system whose exceptions Python prints
            # and drops ('Exception ignored in: <function _get_module_lock.<locals>.cb>' and a traceback on stderr;
            # CI, SIGTERM 1.61 s into 'walkmon live'): the signal is sent again once the import has moved on
            _redeliver(signum)
            return
        if _received is None:
            _received = signum
        raise Interrupted(signum)
    target.stop(f"signal {signal_name(signum)}")


def _in_import_machinery(frame: object) -> bool:
    code = getattr(frame, "f_code", None)
    return str(getattr(code, "co_filename", "")).startswith("<frozen importlib")


def _redeliver(signum: int) -> None:
    import os  # noqa: PLC0415
    import threading  # noqa: PLC0415

    timer = threading.Timer(_IMPORT_RETRY_S, os.kill, (os.getpid(), signum))
    timer.daemon = True
    timer.start()


def received() -> int | None:
    """The stop signal raised as :class:`Interrupted` since :func:`install`, whatever became of the exception."""
    return _received


def _on_usr1(_signum: int, _frame: object) -> None:
    target = _target
    if target is not None:
        target.request_calibration()


def install() -> dict[int, Any]:
    """Install the handlers; the previous ones, for :func:`restore` (main thread only; elsewhere, e.g. a test
    calling main() from a thread: nothing is installed)."""
    previous: dict[int, Any] = {}
    handlers: dict[int, Callable[[int, Any], None]] = {signal.SIGINT: _on_stop, signal.SIGTERM: _on_stop}
    if hasattr(signal, "SIGUSR1"):
        handlers[signal.SIGUSR1] = _on_usr1
    try:
        for sig, fn in handlers.items():
            previous[sig] = signal.signal(sig, fn)
    except ValueError:
        restore(previous)
        return {}
    return previous


def restore(previous: dict[int, Any]) -> None:
    """Put back the handlers :func:`install` replaced (main() called in-process, e.g. by tests)."""
    global _received  # noqa: PLW0603 - one process-wide signal disposition
    _received = None
    for sig, fn in previous.items():
        signal.signal(sig, fn if fn is not None else signal.SIG_DFL)


@contextlib.contextmanager
def deliver_to(target: _T) -> Iterator[_T]:
    """Within the block SIGINT/SIGTERM call ``target.stop(reason)`` and SIGUSR1 ``target.request_calibration()``
    instead of raising; the previous target (or raising) comes back after it."""
    global _target  # noqa: PLW0603 - one process-wide signal disposition
    previous = _target
    _target = target
    if _received is not None:  # raised earlier but swallowed on its way up (library code): stop now
        target.stop(f"signal {signal_name(_received)}")
    try:
        yield target
    finally:
        _target = previous


class PendingStop:
    """A stand-in target while the real one is being built: remembers a stop (and a calibration request) and
    replays them on :meth:`forward_to`, after which it forwards every further signal."""

    def __init__(self) -> None:
        self.reason = ""
        self.calibrate = False
        self._to: Any = None

    def stop(self, reason: str = "stopped") -> None:
        if self._to is not None:
            self._to.stop(reason)
        elif not self.reason:
            self.reason = reason

    def request_calibration(self) -> None:
        if self._to is not None:
            self._to.request_calibration()
        else:
            self.calibrate = True

    def forward_to(self, target: StopTarget) -> None:
        self._to = target
        if self.reason:
            target.stop(self.reason)
        if self.calibrate:
            target.request_calibration()
