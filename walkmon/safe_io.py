"""Safe file writing and bounded reading: the one place every walkmon writer and input reader goes through.

Writing (:func:`atomic_write`, :func:`write_text`, :func:`write_bytes`, :func:`prepare_dir`):

* A file is written to a new temporary file in the target's own folder (created with ``O_CREAT|O_EXCL``, which
  never follows a link, mode 0600), flushed and fsynced, then renamed over the target with ``os.replace``: a
  reader sees the old file or the new one, never half of one, and an interrupted write leaves the old file.
* A target that is a symbolic link (planted or dangling) is refused with
  :class:`~walkmon.errors.UnsafePathError`: walkmon never writes through a link it did not make. The rename
  itself replaces a directory entry and never follows a link either, so a link planted between the check and
  the rename is replaced, not written through.
* Output folders are created 0700 and a folder given as a symbolic link is refused too. Files are 0600: what
  walkmon writes is health data (angles of a person's walk), readable only by its owner.

Reading (:func:`read_bounded`): at most ``max_bytes`` are read, so ``/dev/zero``, a FIFO fed forever or a huge
file given by mistake ends in one clear error instead of exhausting the memory.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

from walkmon.errors import InvalidInputError, UnsafePathError

__all__ = [
    "FILE_MODE",
    "DIR_MODE",
    "MAX_TEXT_INPUT_BYTES",
    "MAX_TABLE_BYTES",
    "atomic_write",
    "check_not_symlink",
    "json_text",
    "prepare_dir",
    "read_bounded",
    "read_text_bounded",
    "write_bytes",
    "write_text",
]

#: Mode of every file walkmon writes (owner read/write only: health data).
FILE_MODE = 0o600
#: Mode of every folder walkmon creates.
DIR_MODE = 0o700
#: Largest small text input (calibration YAML, config TOML, indicators.json baseline): 4 MiB.
MAX_TEXT_INPUT_BYTES = 4 * 1024 * 1024
#: Largest CSV table (angles.csv, imu.csv): 512 MiB, about 8 h of a 200 Hz IMU.
MAX_TABLE_BYTES = 512 * 1024 * 1024


def check_not_symlink(path: str | Path, what: str = "output") -> None:
    """Raise :class:`UnsafePathError` if ``path`` is a symbolic link (dangling or not)."""
    p = Path(path)
    if p.is_symlink():
        msg = (f"{p}: {what} is a symbolic link (to {os.readlink(p)}); refusing to write through a link walkmon "
               "did not make: remove it or give another path")
        raise UnsafePathError(msg)


def prepare_dir(path: str | Path) -> Path:
    """Create the output folder ``path`` (0700, with its parents) unless it exists; refuse a symlinked one."""
    p = Path(path)
    check_not_symlink(p, "output folder")
    if p.exists():
        if not p.is_dir():
            msg = f"{p}: exists and is not a folder"
            raise InvalidInputError(msg)
        return p
    # each missing folder made 0700 (mkdir(parents=True) gives the parents the umask's mode: 0755 under umask 022,
    # user review), and only the folders made here: an existing one reached as 'new/..' is left as it is (review:
    # it was chmodded 0700)
    missing = [p]
    while not missing[-1].parent.exists() and missing[-1].parent != missing[-1]:
        missing.append(missing[-1].parent)
    for d in reversed(missing):
        check_not_symlink(d, "output folder")
        try:
            d.mkdir(mode=DIR_MODE)
        except FileExistsError:
            continue  # made by someone else meanwhile: left as it is
        if (d.stat().st_mode & 0o777) != DIR_MODE:
            os.chmod(d, DIR_MODE)  # a umask stricter than 0700 takes bits mkdir's mode asked for
    check_not_symlink(p, "output folder")  # raced in between: refuse
    if not p.is_dir():
        msg = f"{p}: exists and is not a folder"
        raise InvalidInputError(msg)
    return p


@contextlib.contextmanager
def atomic_write(path: str | Path, mode: str = "w", *, encoding: str | None = "utf-8",
                 newline: str | None = None) -> Iterator[IO[Any]]:
    """Open a temporary file beside ``path`` for writing; on success it replaces ``path`` atomically.

    ``mode`` is ``"w"`` (text, ``encoding``/``newline`` apply) or ``"wb"``. On an exception (or a signal that
    raises) the temporary file is removed and ``path`` is left as it was.
    """
    if mode not in ("w", "wb"):
        msg = f"atomic_write mode must be 'w' or 'wb', got {mode!r}"
        raise ValueError(msg)
    target = Path(path)
    check_not_symlink(target)
    parent = target.parent
    if not parent.exists():
        prepare_dir(parent)
    if target.exists() and not target.is_file():
        msg = f"{target}: exists and is not a regular file"
        raise InvalidInputError(msg)
    fd, tmp_name = tempfile.mkstemp(dir=parent, prefix=f".{target.name}.", suffix=".tmp")  # O_EXCL, 0600
    tmp = Path(tmp_name)
    done = False
    try:
        kwargs: dict[str, Any] = {} if mode == "wb" else {"encoding": encoding, "newline": newline}
        with os.fdopen(fd, mode, **kwargs) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        check_not_symlink(target)
        os.replace(tmp, target)
        done = True
    finally:
        if not done:
            with contextlib.suppress(OSError):
                tmp.unlink()


def write_text(path: str | Path, text: str, *, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` safely (see :func:`atomic_write`); the path."""
    with atomic_write(path, "w", encoding=encoding, newline="") as fh:
        fh.write(text)
    return Path(path)


def write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` safely (see :func:`atomic_write`); the path."""
    with atomic_write(path, "wb") as fh:
        fh.write(data)
    return Path(path)


def json_text(obj: Any, indent: int | None = 1) -> str:
    """``obj`` as strict JSON text: NaN and infinities become null (``json.dumps`` would write the invalid
    tokens ``NaN``/``Infinity``), numpy scalars and arrays become numbers and lists."""
    import json  # noqa: PLC0415
    import math  # noqa: PLC0415

    def clean(v: Any) -> Any:
        if isinstance(v, dict):
            return {str(k): clean(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [clean(x) for x in v]
        if hasattr(v, "tolist") and not isinstance(v, (str, bytes)):
            return clean(v.tolist())
        if isinstance(v, float) and not math.isfinite(v):
            return None
        return v

    return json.dumps(clean(obj), indent=indent, allow_nan=False, default=str) + "\n"


def read_bounded(path: str | Path, max_bytes: int, what: str = "file") -> bytes:
    """The bytes of ``path``, at most ``max_bytes`` of them: a longer input raises :class:`InvalidInputError`.

    Works for devices and pipes too (``/dev/zero`` ends in the size error, not in exhausted memory); a folder
    or a missing file raises :class:`InvalidInputError` naming it. A pipe (``--imu <(zcat imu.csv.gz)``) can be
    read once only, while an analysis reads its input twice (its columns, then its rows): within
    :func:`pipes_read_again` (every command of the CLI, and :func:`walkmon.api.analyze`), a pipe's bytes are kept
    and given again (user review: the second read found it empty, 'empty file').
    """
    p = Path(path)
    cache = _PIPES.get()
    try:
        piped = cache is not None and stat.S_ISFIFO(os.stat(p).st_mode)
    except OSError:
        piped = False
    if piped and cache is not None and str(p) in cache:
        return cache[str(p)]
    data = _read_bounded(p, max_bytes, what)
    if piped and cache is not None:
        cache[str(p)] = data
    return data


#: Within :func:`pipes_read_again`: the bytes of each pipe read there, by path (None outside). A context variable:
#: each thread has its own (a thread starts without one), and so does each asyncio task.
_PIPES: contextvars.ContextVar[dict[str, bytes] | None] = contextvars.ContextVar("walkmon_pipes", default=None)


@contextlib.contextmanager
def pipes_read_again() -> Iterator[None]:
    """Within it (in this thread), a pipe :func:`read_bounded` reads again gives the bytes it gave the first time;
    outside, every read reads (a named pipe fed anew is read anew). Nested: the outer one's pipes stay known."""
    outer = _PIPES.get()
    token = _PIPES.set({} if outer is None else outer)
    try:
        yield
    finally:
        _PIPES.reset(token)


def _read_bounded(p: Path, max_bytes: int, what: str) -> bytes:
    try:
        fd = os.open(p, os.O_RDONLY | getattr(os, "O_CLOEXEC", 0))
    except FileNotFoundError:
        msg = f"{p}: no such file" + ("" if what == "file" else f" (expected {what})")
        raise InvalidInputError(msg) from None
    except IsADirectoryError:
        msg = f"{p}: is a folder, expected a {what}"
        raise InvalidInputError(msg) from None
    except PermissionError:
        msg = f"{p}: permission denied"
        raise InvalidInputError(msg) from None
    except OSError as exc:
        msg = f"{p}: cannot open ({exc.strerror or exc})"
        raise InvalidInputError(msg) from None
    try:
        if stat.S_ISDIR(os.fstat(fd).st_mode):
            msg = f"{p}: is a folder, expected a {what}"
            raise InvalidInputError(msg)
        chunks: list[bytes] = []
        total = 0
        while True:
            try:
                chunk = os.read(fd, min(1 << 20, max_bytes + 1 - total))
            except OSError as exc:
                msg = f"{p}: cannot read ({exc.strerror or exc})"
                raise InvalidInputError(msg) from None
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
            if total > max_bytes:
                msg = f"{p}: larger than {_size(max_bytes)}, the most a {what} may be (wrong file?)"
                raise InvalidInputError(msg)
        return b"".join(chunks)
    finally:
        os.close(fd)


def read_text_bounded(path: str | Path, max_bytes: int = MAX_TEXT_INPUT_BYTES, what: str = "file") -> str:
    """:func:`read_bounded` decoded as UTF-8; a binary file raises :class:`InvalidInputError`."""
    data = read_bounded(path, max_bytes, what)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        msg = f"{path}: not a UTF-8 text file"
        raise InvalidInputError(msg) from None


def _size(n: int) -> str:
    return f"{n / (1 << 20):g} MiB" if n >= 1 << 20 else f"{n} bytes"
