"""The ``walkmon`` command line: one entry point, one subcommand per module in :mod:`walkmon.commands`.

Each command module defines ``NAME``, ``HELP``, ``add_arguments(parser)`` and ``run(args) -> int``. Errors
walkmon raises on purpose (:class:`~walkmon.errors.WalkmonError`), unreadable files and bad options all end
the same way: one line on stderr and exit code 2, never a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys
from collections.abc import Sequence
from types import ModuleType

from walkmon._version import __version__
from walkmon.errors import WalkmonError

__all__ = ["main"]

_log = logging.getLogger(__name__)

#: Subcommand modules, in the order ``walkmon --help`` lists them.
COMMAND_MODULES = (
    "walkmon.commands.demo",
    "walkmon.commands.calibrate",
    "walkmon.commands.calibrate_imu",
    "walkmon.commands.simulate",
    "walkmon.commands.analyze",
    "walkmon.commands.batch",
    "walkmon.commands.indicators",
    "walkmon.commands.live",
    "walkmon.commands.config",
    "walkmon.commands.sessions",
    "walkmon.commands.report",
    "walkmon.commands.history",
    "walkmon.commands.serve",
)

EXIT_USAGE = 2


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line on stderr and exit code 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        sys.stderr.write(f"{self.prog}: error: {message} (see '{self.prog} --help')\n")
        raise SystemExit(EXIT_USAGE)


def _commands() -> list[ModuleType]:
    return [importlib.import_module(name) for name in COMMAND_MODULES]


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="walkmon", description="Walking-posture monitor from a chest-worn camera.")
    parser.add_argument("--version", action="version", version=f"walkmon {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output (-vv for debug)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for module in _commands():
        p = sub.add_parser(module.NAME, help=module.HELP, description=module.HELP)
        module.add_arguments(p)
        p.set_defaults(_run=module.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    from walkmon.commands import _signals  # noqa: PLC0415

    previous = _signals.install()  # (again, when called in-process): a signal during the imports below is ours
    try:
        return _main(argv)
    except (_signals.Interrupted, KeyboardInterrupt) as exc:
        signum = getattr(exc, "signum", 2)
        sys.stderr.write(f"walkmon: interrupted ({_signals.signal_name(signum)})\n")
        return 128 + signum
    finally:
        _signals.restore(previous)


def _main(argv: Sequence[str] | None) -> int:
    import sqlite3  # noqa: PLC0415

    from walkmon.commands import _signals  # noqa: PLC0415

    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=(logging.WARNING, logging.INFO, logging.DEBUG)[min(args.verbose, 2)],
        format="%(levelname)s %(name)s: %(message)s",
    )
    if not getattr(args, "_run", None):
        parser.print_help(sys.stderr)
        return EXIT_USAGE
    for option in ("out", "data_dir"):
        if getattr(args, option, None) is not None and not str(getattr(args, option)).strip():
            # '' is the current folder to pathlib: files landed there unasked (user review)
            parser.error(f"--{option.replace('_', '-')} is empty")
    from walkmon.safe_io import pipes_read_again  # noqa: PLC0415

    try:
        with pipes_read_again():  # an input given as a pipe may be read twice (its columns, then its rows)
            return int(args._run(args) or 0)
    except WalkmonError as exc:
        why = " ".join(str(exc).splitlines())
    except FileNotFoundError as exc:
        why = f"{exc.filename or exc}: no such file or directory"
    except PermissionError as exc:
        why = f"{exc.filename or exc}: permission denied"
    except OSError as exc:
        why = str(exc)
    except sqlite3.Error as exc:
        why = f"session database: {exc}"
    except (RecursionError, MemoryError) as exc:
        why = f"input too deeply nested or too large ({type(exc).__name__})"
    signum = _signals.received()
    if signum is not None:  # the signal came back as another error (raised inside a C extension's import)
        raise _signals.Interrupted(signum)
    sys.stderr.write(f"walkmon {args.command}: error: {why}\n")
    return EXIT_USAGE


if __name__ == "__main__":
    raise SystemExit(main())
