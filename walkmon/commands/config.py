"""``walkmon config``: the live monitor's configuration file: print the documented example, the defaults, or check
a file."""

from __future__ import annotations

import argparse
import sys
from importlib import resources

NAME = "config"
HELP = "print the documented example config (--example) or the defaults (--defaults), or check a config file"


def example_config_text() -> str:
    """The documented example walkmon.toml shipped in the package (the same file as deploy/walkmon.toml)."""
    return resources.files("walkmon.live").joinpath("example.toml").read_text(encoding="utf-8")


def add_arguments(p: argparse.ArgumentParser) -> None:
    what = p.add_mutually_exclusive_group(required=True)
    what.add_argument("--example", action="store_true",
                      help="print the example config with every key documented (start /etc/walkmon/walkmon.toml from it)")
    what.add_argument("--defaults", action="store_true", help="print the built-in defaults as TOML")
    what.add_argument("--check", metavar="TOML", help="read a config file; one line and exit 2 if anything is wrong")


def run(args: argparse.Namespace) -> int:
    from walkmon.live.config import DEFAULT_CONFIG, config_to_toml, read_config  # noqa: PLC0415

    if args.example:
        sys.stdout.write(example_config_text())
    elif args.defaults:
        sys.stdout.write(config_to_toml(DEFAULT_CONFIG))
    else:
        read_config(args.check)
        sys.stdout.write(f"{args.check}: ok\n")
    return 0
