"""What a Dask worker does with one recording: :func:`analyze_task` (a plain function of plain data).

Per recording: note the attempt, hash the inputs, skip when ``--resume`` finds complete outputs for the same
inputs and options, else run the analysis of ``walkmon analyze`` (one call, :func:`walkmon.api.analyze`) into a
private temporary folder beside the outputs and move it to ``OUT/<name>/`` only when it is complete, so a
killed worker never leaves a half-written folder that looks finished. Every error becomes a ``failed`` row
with a one-line reason; nothing is raised (a worker that dies is the scheduler's business: it reruns the task).

The workers must see OUT and the inputs at the same paths as the client (one machine, or a shared file system).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
import sys
import time
import uuid
from collections.abc import Mapping, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from walkmon.batching.tables import bouts_from_indicators, indicator_columns
from walkmon.errors import InvalidInputError, WalkmonError

__all__ = ["STATE_DIR", "analyze_task", "file_digest", "one_line", "run_analysis"]

#: Batch bookkeeping under OUT (temporary outputs, attempt counters); never a recording's name (names never
#: start with a dot).
STATE_DIR = ".walkmon-batch"


def run_analysis(video: str | None, imu: str | None, calib: str | None, options: Mapping[str, Any],
                 out_dir: Path, written: list[str] | None = None) -> dict[str, Any]:
    """``walkmon analyze [VIDEO] [--imu IMU] [--calib CALIB] ... --out out_dir``: the one call into the analysis
    (:func:`walkmon.api.analyze`, which the command runs too) and its files; returns the indicators.json document.
    ``written``: the names of the files written are appended to it."""
    from walkmon.api import analyze  # noqa: PLC0415

    result = analyze(video, imu=imu, calib=calib, method=str(options["method"]), baseline=options.get("baseline"),
                     mode=str(options["mode"]), imu_filter=str(options["imu_filter"]),
                     imu_extrinsics=str(options["imu_extrinsics"]), imu_calib=options.get("imu_calib"))
    files = result.write(out_dir)
    if written is not None:
        written.extend(files)
    return result.indicators


def file_digest(path: Path) -> dict[str, Any]:
    """``{"path", "size", "sha256"}`` of a file (read in 1 MiB blocks)."""
    h = hashlib.sha256()
    with path.open("rb") as fh:
        while block := fh.read(1 << 20):
            h.update(block)
    return {"path": str(path), "size": path.stat().st_size, "sha256": h.hexdigest()}


def one_line(exc: BaseException) -> str:
    """The reason of a failed recording: one line, as the CLI would print it."""
    if isinstance(exc, WalkmonError):
        text = str(exc)
    elif isinstance(exc, FileNotFoundError):
        text = f"{exc.filename or exc}: no such file or directory"
    elif isinstance(exc, PermissionError):
        text = f"{exc.filename or exc}: permission denied"
    elif isinstance(exc, OSError):
        text = str(exc)
    else:
        text = f"{type(exc).__name__}: {exc}"
    text = " ".join(text.split()) or type(exc).__name__
    return text if len(text) <= 400 else text[:397] + "..."


def _versions() -> dict[str, str]:
    import cv2  # noqa: PLC0415
    import numpy as np  # noqa: PLC0415

    from walkmon._version import __version__  # noqa: PLC0415

    return {"walkmon_version": __version__, "python_version": sys.version.split()[0],
            "numpy_version": np.__version__, "opencv_version": cv2.__version__}


def _one_core() -> None:
    """A worker is one core (one single-threaded worker process per core): OpenCV's own thread pool would
    only compete with the other workers."""
    import cv2  # noqa: PLC0415

    cv2.setNumThreads(1)


def _jsonable(row: Mapping[str, Any]) -> dict[str, Any]:
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in row.items()}


def _worker_address() -> str:
    try:
        from distributed import get_worker  # noqa: PLC0415

        return str(get_worker().address)
    except (ImportError, ValueError):
        return f"pid {os.getpid()}"


def _count_attempt(state: Path, name: str) -> int:
    """Append this start to ``state/attempts/<name>``; returns how many starts it holds (this one included)."""
    folder = state / "attempts"
    folder.mkdir(mode=0o700, parents=True, exist_ok=True)  # inside the 0700 state folder
    path = folder / name
    fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW, 0o600)
    try:
        os.write(fd, f"{_worker_address()} {os.getpid()}\n".encode())
    finally:
        os.close(fd)
    return sum(1 for line in path.read_text(encoding="utf-8").splitlines() if line.strip())


def _outputs(folder: Path) -> dict[str, dict[str, Any]]:
    return {p.name: {k: v for k, v in file_digest(p).items() if k != "path"}
            for p in sorted(folder.iterdir()) if p.is_file()}


def _complete(previous: Mapping[str, Any] | None, inputs: Mapping[str, Any], options: Mapping[str, Any],
              folder: Path) -> bool:
    """True when ``previous`` (a manifest entry) is an ok result of these inputs and options whose output files
    are all still in ``folder`` unchanged."""
    if not previous or (previous.get("row") or {}).get("status") != "ok":
        return False
    if previous.get("inputs") != inputs or previous.get("options") != options:
        return False
    outputs = previous.get("outputs")
    if not isinstance(outputs, dict) or not outputs or folder.is_symlink() or not folder.is_dir():
        return False
    try:
        return _outputs(folder) == outputs
    except OSError:
        return False


def _replace_folder(tmp: Path, final: Path, state: Path, expected: Sequence[str] = ()) -> None:
    """Move the finished ``tmp`` folder to ``final``, replacing an earlier result (never through a link).
    ``expected``: the files the analysis wrote there; each must still be there, so a folder emptied under the
    worker is never moved over a complete result."""
    missing = [n for n in expected if not (tmp / n).is_file()]
    if missing:
        msg = f"{tmp}: {', '.join(sorted(missing))} gone before it was moved into place (the batch was stopped?)"
        raise InvalidInputError(msg)
    if final.is_symlink():
        msg = f"{final}: is a symbolic link; not replacing it (remove it or choose another --out)"
        raise InvalidInputError(msg)
    if final.exists():
        if not final.is_dir():
            msg = f"{final}: exists and is not a folder; not replacing it"
            raise InvalidInputError(msg)
        trash = state / "trash" / f"{final.name}-{uuid.uuid4().hex[:8]}"
        trash.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
        os.replace(final, trash)
        os.replace(tmp, final)
        shutil.rmtree(trash, ignore_errors=True)
    else:
        os.replace(tmp, final)


def analyze_task(task: Mapping[str, Any]) -> dict[str, Any]:
    """Analyse one recording (runs on a Dask worker). Returns ``{"row", "bouts", "manifest"}``.

    ``task``: ``name``, ``video``, ``imu``, ``calib`` (path strings or None), ``problem`` (a reason to fail
    without analysing, or ""), ``out`` (the batch's OUT folder), ``options`` (method, mode, baseline,
    imu_filter, imu_extrinsics, imu_calib) and ``previous`` (this name's manifest entry for ``--resume``, or None).
    """
    t0 = time.perf_counter()
    c0 = time.process_time()
    _one_core()
    name = str(task["name"])
    out = Path(task["out"])
    state = out / STATE_DIR
    options = dict(task["options"])
    row: dict[str, Any] = {"name": name, "status": "failed", "error": "", "kind": task.get("kind", ""),
                           "video": task.get("video") or "", "imu": task.get("imu") or "",
                           "calib": task.get("calib") or "", "method": options.get("method", ""),
                           "worker": _worker_address(), "resumed": False, **_versions()}
    bouts: list[dict[str, Any]] = []
    manifest: dict[str, Any] = {}
    tmp: Path | None = None
    try:
        row["attempts"] = _count_attempt(state, name)
        if task.get("problem"):
            raise InvalidInputError(str(task["problem"]))
        inputs = {k: file_digest(Path(task[k])) for k in ("video", "imu", "calib") if task.get(k)}
        for key in ("baseline", "imu_calib"):  # files that change the result: hashed like the inputs
            if options.get(key):
                inputs[key] = file_digest(Path(options[key]))
        final = out / name
        previous = task.get("previous") or {}
        if task.get("resume") and _complete(previous, inputs, options, final):
            kept = dict(previous["row"])
            kept.update({"resumed": True, "attempts": row["attempts"], "worker": row["worker"]})
            doc = json.loads((final / "indicators.json").read_text(encoding="utf-8"))
            return {"row": kept, "bouts": bouts_from_indicators(name, doc), "manifest": dict(previous)}
        tmp = state / "tmp" / f"{name}-{uuid.uuid4().hex[:8]}"
        tmp.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
        written: list[str] = []
        doc = run_analysis(task.get("video"), task.get("imu"), task.get("calib"), options, tmp, written)
        row.update(indicator_columns(doc))
        bouts = bouts_from_indicators(name, doc)
        outputs = _outputs(tmp)
        _replace_folder(tmp, final, state, written)
        tmp = None
        row["status"] = "ok"
        manifest = {"inputs": inputs, "options": options, "outputs": outputs}
    except Exception as exc:  # noqa: BLE001 - any failure of one recording is that recording's row
        row["status"] = "failed"
        row["error"] = one_line(exc)
    finally:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)
    row["analysis_s"] = round(time.perf_counter() - t0, 3)
    row["cpu_s"] = round(time.process_time() - c0, 3)
    row["finished_utc"] = datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
    row = _jsonable(row)
    manifest["row"] = row
    return {"row": row, "bouts": [_jsonable(b) for b in bouts], "manifest": manifest}
