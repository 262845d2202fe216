"""The ``walkmon`` program's entry point (console script and ``python -m walkmon``).

Importing this module installs walkmon's signal handlers before anything else is imported (the subcommands pull
in numpy, OpenCV and SciPy, which takes a second on a small board): a SIGINT, SIGTERM or SIGUSR1 during the
start-up is handled by walkmon from here on (:mod:`walkmon.commands._signals`). Only entry points import it;
:func:`walkmon.commands.cli.main` itself can be called in-process without it.
"""

from walkmon.commands import _signals

_signals.install()


def main() -> int:
    try:
        from walkmon.commands.cli import main as cli_main  # noqa: PLC0415 - after the handlers are in place

        return cli_main()
    except _signals.Interrupted as exc:  # during the import of the CLI (cli_main handles its own)
        import sys  # noqa: PLC0415

        sys.stderr.write(f"walkmon: interrupted ({_signals.signal_name(exc.signum)})\n")
        return 128 + exc.signum
