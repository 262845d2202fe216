"""The one exception tree of walkmon.

Every error walkmon raises on purpose derives from :class:`WalkmonError`, so the CLI can turn any of them into
one clear line on stderr and exit code 2, and library users can catch one base class.
"""

from __future__ import annotations

__all__ = [
    "ConfigError",
    "InvalidInputError",
    "SourceDisconnected",
    "SourceError",
    "SourceTimeout",
    "UnsafePathError",
    "WalkmonError",
]


class WalkmonError(Exception):
    """Base class of every error walkmon raises on purpose."""


class ConfigError(WalkmonError, ValueError):
    """A configuration or calibration value is missing, unknown or out of range."""


class InvalidInputError(WalkmonError, ValueError):
    """An input file or array is malformed (wrong columns, non-numeric values, wrong shape)."""


class UnsafePathError(InvalidInputError):
    """An output path is a symbolic link (or otherwise unsafe to write through); nothing was written."""


class SourceError(WalkmonError, OSError):
    """A camera, IMU or file source cannot be opened or read."""


class SourceDisconnected(SourceError):
    """A source that was delivering data has gone away (unplugged, closed, end of stream)."""


class SourceTimeout(SourceError):
    """A source did not deliver data within its deadline."""
