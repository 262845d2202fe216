"""Progress bars with an ETA (tqdm) for the long commands, on stderr and only on a terminal.

Quiet when stderr is not a terminal (pipes, logs, the service) or with ``enabled=False`` (``--no-progress``);
a bar appears only once the work has taken ``delay_s`` (0.5 s), so quick runs print nothing extra.
"""

from __future__ import annotations

import sys
from typing import Any, TextIO

__all__ = ["Progress"]


class Progress:
    """``update(n)``, ``set(done, total)``, ``close()``; a context manager. ``total`` 0/None: no ETA (count only)."""

    def __init__(self, total: int | None, desc: str, unit: str, *, enabled: bool | None = None,
                 stream: TextIO | None = None, delay_s: float = 0.5) -> None:
        self.stream = stream or sys.stderr
        try:
            tty = self.stream.isatty()
        except (AttributeError, ValueError):
            tty = False
        self.enabled = tty if enabled is None else enabled
        self.count = 0
        self._bar: Any = None
        if self.enabled:
            from tqdm import tqdm  # noqa: PLC0415

            self._bar = tqdm(total=total or None, desc=desc, unit=unit, file=self.stream, delay=delay_s,
                             leave=True, smoothing=0.1)

    def update(self, n: int = 1) -> None:
        self.count += n
        if self._bar is not None:
            self._bar.update(n)

    def set(self, done: int, total: int | None = None) -> None:
        """Progress as 'done of total' (callbacks that report absolute counts)."""
        if self._bar is not None and total and self._bar.total != total:
            self._bar.total = total
        self.update(done - self.count)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
