"""``walkmon.batch(...)``: analyse many recordings on Dask distributed, one task per recording.

A :class:`distributed.LocalCluster` of ``workers`` single-threaded worker processes (default: one per core),
or the scheduler at ``scheduler`` (``tcp://HOST:PORT``), or a ``client`` you already hold. Each recording is
one task (:func:`walkmon.batching.worker.analyze_task`); results are gathered as they complete, the manifest
is kept up to date while the batch runs (so an interrupted batch continues with ``resume=True``), and the
summary and bout tables are written at the end (also after Ctrl-C, with the recordings finished so far).

Failures: a recording that cannot be analysed is a ``failed`` row with its one-line reason. A worker process
that dies (killed, out of memory, a crash in a native library) is restarted by its nanny and the scheduler
runs its task again elsewhere; a task whose workers died more than ``allowed_failures`` times (Dask's
``distributed.scheduler.allowed-failures``, default 3; set on the scheduler for an external cluster) is
given up as a ``failed`` row, so one poisonous file cannot stall the batch. Recording errors are not retried:
they are deterministic (a corrupt file stays corrupt).
"""

from __future__ import annotations

import math
import os
import shutil
import sys
import time
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, TextIO

from walkmon.batching.pairing import Recording, find_recordings
from walkmon.batching.tables import (
    bouts_frame,
    read_manifest,
    summary_frame,
    write_manifest,
    write_tables,
)
from walkmon.batching.worker import STATE_DIR, analyze_task
from walkmon.errors import ConfigError, InvalidInputError
from walkmon.imu.attitude import IMU_FILTERS
from walkmon.safe_io import check_not_symlink

__all__ = ["BatchProgress", "batch"]

METHODS = ("fast", "paper")
GAIT_MODES = ("walkmon", "paper")
IMU_EXTRINSICS = ("identity", "estimate")


class BatchProgress:
    """One line over the recordings: ``[#####.....] 5/10  ok 4  failed 1  running 2  0:42``.

    Drawn on ``stream`` (stderr) only when it is a terminal (or ``enabled``); :meth:`note` prints one line per
    finished recording to ``log`` (stdout) either way, clearing the bar first.
    """

    def __init__(self, total: int, stream: TextIO | None = None, log: TextIO | None = None,
                 enabled: bool | None = None) -> None:
        self.stream = stream or sys.stderr
        self.log = log
        self.enabled = self.stream.isatty() if enabled is None else enabled
        self.total = total
        self.ok = 0
        self.failed = 0
        self.running = 0
        self.t0 = time.perf_counter()
        self._width = 0

    @property
    def done(self) -> int:
        return self.ok + self.failed

    def line(self) -> str:
        frac = self.done / self.total if self.total else 1.0
        bar = "#" * round(24 * frac)
        el = int(time.perf_counter() - self.t0)
        return (f"[{bar:<24}] {self.done}/{self.total}  ok {self.ok}  failed {self.failed}  "
                f"running {self.running}  {el // 60}:{el % 60:02d}")

    def draw(self) -> None:
        if self.enabled:
            text = self.line()
            self.stream.write("\r" + text + " " * max(0, self._width - len(text)))
            self.stream.flush()
            self._width = len(text)

    def _clear(self) -> None:
        if self.enabled and self._width:
            self.stream.write("\r" + " " * self._width + "\r")
            self.stream.flush()
            self._width = 0

    def note(self, text: str) -> None:
        if self.log is not None:
            self._clear()
            self.log.write(text + "\n")
            self.log.flush()
        self.draw()

    def close(self) -> None:
        if self.enabled:
            self.draw()
            self.stream.write("\n")
            self.stream.flush()


def _describe(row: Mapping[str, Any]) -> str:
    if row.get("status") != "ok":
        return f"{row['name']}: failed: {row.get('error', '')}"
    cad = row.get("cadence_spm")
    cad_text = f"{cad:.1f} steps/min" if isinstance(cad, int | float) and math.isfinite(cad) else "no cadence"
    walk = row.get("walking_s")
    walk_text = f"{walk:.1f} s walking" if isinstance(walk, int | float) and math.isfinite(walk) else ""
    extra = " (kept from the earlier run)" if row.get("resumed") else ""
    retried = f", {row['attempts']} attempts" if int(row.get("attempts") or 1) > 1 else ""
    return f"{row['name']}: ok: {row.get('label', '')}, {cad_text}, {walk_text}{retried}{extra}"


def _analyze_default(name: str) -> Any:
    """The default of ``walkmon.analyze``'s parameter ``name`` (so a batch analyses as ``walkmon analyze`` does)."""
    import inspect  # noqa: PLC0415

    from walkmon.api import analyze  # noqa: PLC0415

    return inspect.signature(analyze).parameters[name].default


def _existing(path: str | os.PathLike[str] | None, what: str) -> str | None:
    if path is None:
        return None
    p = Path(path).expanduser().resolve()
    if not p.is_file():  # a device such as /dev/zero exists: 'no such file' misled (user review)
        msg = f"{path}: not a regular file (expected a {what} file)" if p.exists() else f"{path}: no such {what} file"
        raise InvalidInputError(msg)
    return str(p)


def _options(method: str | None, mode: str | None, baseline: str | os.PathLike[str] | None, imu_filter: str | None,
             imu_extrinsics: str | None, imu_calib: str | os.PathLike[str] | None) -> dict[str, Any]:
    """The analysis options of every recording (None: ``walkmon analyze``'s default), checked."""
    chosen = {"method": method, "mode": mode, "imu_filter": imu_filter, "imu_extrinsics": imu_extrinsics}
    values = {k: (_analyze_default(k) if v is None else v) for k, v in chosen.items()}
    for key, allowed in (("method", METHODS), ("mode", GAIT_MODES), ("imu_filter", IMU_FILTERS),
                         ("imu_extrinsics", IMU_EXTRINSICS)):
        if values[key] not in allowed:
            msg = f"{key} must be one of {', '.join(allowed)}, got {values[key]!r}"
            raise ConfigError(msg)
    return {**values, "baseline": _existing(baseline, "baseline"), "imu_calib": _existing(imu_calib, "IMU calibration")}


def _check_out(out: Path) -> None:
    """Refuse an OUT that cannot be a batch's output folder (before any cluster starts; nothing written): a
    symbolic link, dangling or not (a link walkmon did not make; user review: the batch wrote through one, as
    no other command does)."""
    check_not_symlink(out, "output folder")
    if out.exists() and not out.is_dir():
        msg = f"{out}: exists and is not a folder"
        raise InvalidInputError(msg)


def _prepare_out(out: Path) -> Path:
    """Create OUT (private to the user: 0700) or check the existing one; returns it resolved."""
    _check_out(out)
    from walkmon.safe_io import prepare_dir  # noqa: PLC0415

    prepare_dir(out)  # every missing parent 0700 too
    out = out.resolve()
    for name in ("summary.parquet", "summary.csv", "bouts.parquet", "manifest.json"):
        if (out / name).is_symlink():
            msg = f"{out / name}: is a symbolic link; not writing through it"
            raise InvalidInputError(msg)
    state = out / STATE_DIR
    if state.is_symlink():
        msg = f"{state}: is a symbolic link; not writing through it"
        raise InvalidInputError(msg)
    shutil.rmtree(state, ignore_errors=True)  # temporary outputs and attempt counts of an earlier run
    state.mkdir(mode=0o700)
    return out


def _client(workers: int | None, scheduler: str | None, client: Any, dashboard_address: str | None,
            allowed_failures: int | None) -> tuple[Any, Any, bool]:
    """(client, cluster or None, whether we own the client)."""
    try:
        import distributed  # noqa: PLC0415
    except ImportError:
        msg = "walkmon batch needs Dask distributed: pip install 'walkmon[batch]'"
        raise ConfigError(msg) from None
    if client is not None:
        return client, None, False
    if scheduler is not None:
        if workers is not None:
            msg = "give either workers (a local cluster) or scheduler (an existing cluster), not both"
            raise ConfigError(msg)
        try:
            return distributed.Client(scheduler, timeout="20s"), None, True
        except (OSError, TimeoutError) as exc:
            msg = f"cannot reach the Dask scheduler at {scheduler}: {' '.join(str(exc).split())}"
            raise ConfigError(msg) from None
    n = workers if workers is not None else (os.cpu_count() or 1)
    if n < 1:
        msg = f"workers must be >= 1, got {n}"
        raise ConfigError(msg)
    import dask  # noqa: PLC0415

    with dask.config.set({"distributed.scheduler.allowed-failures": 3 if allowed_failures is None
                          else int(allowed_failures)}), warnings.catch_warnings():
        # "Port 8787 is already in use ... Hosting the HTTP server on port N instead": the link printed says so
        warnings.filterwarnings("ignore", message="Port .* is already in use", category=UserWarning)
        # the scheduler serves HTTP (health, metrics) whatever: without a dashboard on a free port, so that
        # it does not compete for 8787
        cluster = distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                           dashboard_address=dashboard_address or "127.0.0.1:0",
                                           host="127.0.0.1")
    return distributed.Client(cluster), cluster, True


def _dashboard(client: Any) -> str | None:
    try:
        services = client.scheduler_info().get("services", {})
    except (OSError, TimeoutError, AttributeError):
        return None
    return str(client.dashboard_link) if "dashboard" in services else None


def _tasks(recs: Sequence[Recording], out: Path, options: Mapping[str, Any], resume: bool,
           manifest: Mapping[str, Any]) -> list[dict[str, Any]]:
    return [{"name": r.name, "kind": r.kind, "video": None if r.video is None else str(r.video),
             "imu": None if r.imu is None else str(r.imu), "calib": None if r.calib is None else str(r.calib),
             "problem": r.problem, "out": str(out), "options": dict(options), "resume": resume,
             "previous": manifest.get(r.name) if resume else None} for r in recs]


def _failed_row(task: Mapping[str, Any], reason: str) -> dict[str, Any]:
    return {"name": task["name"], "status": "failed", "error": reason, "kind": task["kind"],
            "video": task["video"] or "", "imu": task["imu"] or "", "calib": task["calib"] or "",
            "method": task["options"]["method"], "resumed": False}


def batch(
    inputs: str | os.PathLike[str] | Iterable[str | os.PathLike[str]],
    out: str | os.PathLike[str],
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    client: Any = None,
    imu_patterns: Sequence[str] | None = None,
    calib: str | os.PathLike[str] | None = None,
    resume: bool = False,
    method: str | None = None,
    mode: str | None = None,
    baseline: str | os.PathLike[str] | None = None,
    imu_filter: str | None = None,
    imu_extrinsics: str | None = None,
    imu_calib: str | os.PathLike[str] | None = None,
    dashboard_address: str | None = "127.0.0.1:8787",
    allowed_failures: int | None = None,
    progress: bool | None = False,
    log: TextIO | None = None,
    on_start: Callable[[Any, list[dict[str, Any]]], None] | None = None,
):  # noqa: ANN201 - returns a pandas DataFrame (pandas imported lazily)
    """Analyse every recording of ``inputs`` into ``out/<name>/`` as ``walkmon analyze`` does; returns the
    summary (one row per recording, :data:`walkmon.batching.tables.SUMMARY_COLUMNS`) as a pandas DataFrame.

    ``inputs``: files, folders or globs (pairing rule: :mod:`walkmon.batching.pairing`). Cluster: ``workers``
    local worker processes (default: one per core), or ``scheduler`` ``"tcp://HOST:PORT"``, or an existing
    ``client``. ``resume``: keep recordings whose outputs are complete for the same inputs (by SHA-256) and
    options. ``method``, ``mode``, ``baseline``, ``imu_filter``, ``imu_extrinsics``, ``imu_calib``: as
    ``walkmon.analyze`` (None: its default).
    ``progress``: draw the bar on stderr (None: when stderr is a terminal); ``log``: a stream for one line per
    recording. ``on_start(client, tasks)`` is called once the tasks are submitted (e.g. to watch them).
    Writes ``out/summary.parquet``, ``out/summary.csv``, ``out/bouts.parquet`` and ``out/manifest.json``.
    """
    if isinstance(inputs, str | os.PathLike):
        inputs = [inputs]
    inputs = list(inputs)
    if not inputs:
        msg = "no INPUTS given"
        raise InvalidInputError(msg)
    options = _options(method, mode, baseline, imu_filter, imu_extrinsics, imu_calib)
    out_path = Path(out).expanduser()
    recs = find_recordings(inputs, imu_patterns=imu_patterns, calib=calib,
                           exclude=out_path if out_path.exists() else None)
    _check_out(out_path)

    import pandas  # noqa: F401, PLC0415 - fail before starting a cluster when pandas/pyarrow are missing
    import pyarrow  # noqa: F401, PLC0415

    cl, cluster, owned = _client(workers, scheduler, client, dashboard_address, allowed_failures)
    prepared: Path | None = None
    try:
        prepared = out_path = _prepare_out(out_path)
        return _run(cl, recs, out_path, options, resume, log=log, progress=progress,
                    dashboard=_dashboard(cl) if (cluster is None or dashboard_address) else None,
                    allowed_failures=allowed_failures, on_start=on_start)
    finally:
        if owned:
            cl.close()
        if cluster is not None:
            cluster.close()
        # the temporary folders only once no worker of ours can still write into one: removed under a worker
        # that then moved its half-emptied folder into place, a Ctrl-C replaced complete earlier results with a
        # folder holding report.html alone (user review). Another's cluster may still run our tasks: its folders
        # are left, and the next run's _prepare_out clears them.
        if prepared is not None and cluster is not None:
            shutil.rmtree(prepared / STATE_DIR / "tmp", ignore_errors=True)


def _run(cl: Any, recs: Sequence[Recording], out_path: Path, options: Mapping[str, Any], resume: bool, *,
         log: TextIO | None, progress: bool | None, dashboard: str | None, allowed_failures: int | None,
         on_start: Callable[[Any, list[dict[str, Any]]], None] | None):  # noqa: ANN202
    """Submit one task per recording, gather as they complete, keep the manifest; the tables at the end."""
    from distributed import as_completed  # noqa: PLC0415

    manifest = dict(read_manifest(out_path))
    tasks = _tasks(recs, out_path, options, resume, manifest)
    if not resume:  # a fresh batch: entries of an earlier run must not vouch for outputs being replaced
        manifest = {k: v for k, v in manifest.items() if k not in {t["name"] for t in tasks}}
    bar = BatchProgress(len(tasks), log=log, enabled=progress)
    rows: dict[str, dict[str, Any]] = {}
    bouts: list[dict[str, Any]] = []
    futures: dict[Any, dict[str, Any]] = {}
    try:
        if dashboard and log is not None:
            log.write(f"Dask dashboard: {dashboard}\n")
        for t in tasks:
            f = cl.submit(analyze_task, t, key=f"walkmon-batch-{t['name']}-{os.urandom(4).hex()}", pure=False)
            futures[f] = t
        if on_start is not None:
            on_start(cl, tasks)
        pending = as_completed(list(futures))
        last_write = time.monotonic()
        last_poll = 0.0
        while not pending.is_empty():
            finished = pending.next_batch(block=False) if pending.has_ready() else []
            if not finished:
                now = time.monotonic()
                if bar.enabled and now - last_poll > 0.5:
                    bar.running = _running(cl, futures)
                    last_poll = now
                    bar.draw()
                time.sleep(0.05)
                continue
            for f in finished:
                t = futures[f]
                try:
                    result = f.result()
                except Exception as exc:  # noqa: BLE001 - KilledWorker, lost scheduler...: a failed row
                    reason = _task_error(exc, allowed_failures)
                    result = {"row": _failed_row(t, reason), "bouts": [], "manifest": {}}
                row = result["row"]
                rows[t["name"]] = row
                bouts += result["bouts"]
                manifest[t["name"]] = {**result["manifest"], "row": row}
                if row.get("status") == "ok":
                    bar.ok += 1
                else:
                    bar.failed += 1
                bar.running = max(0, min(bar.running, len(tasks) - bar.done))
                bar.note(_describe(row))
            if time.monotonic() - last_write > 2.0:
                write_manifest(out_path, manifest)
                last_write = time.monotonic()
    finally:  # also after Ctrl-C: what finished so far is kept and listed
        bar.close()
        write_manifest(out_path, manifest)
        summary = summary_frame(rows.values())
        write_tables(out_path, summary, bouts_frame(bouts))
        if all(f.done() for f in futures):  # no task of ours can still write into one (else: see batch())
            shutil.rmtree(out_path / STATE_DIR / "tmp", ignore_errors=True)
    return summary


def _running(client: Any, futures: Mapping[Any, Any]) -> int:
    """How many of our tasks the workers hold now (one thread each: running)."""
    try:
        processing = client.processing()
    except (OSError, TimeoutError):
        return 0
    keys = {f.key for f in futures if not f.done()}
    return sum(1 for ks in processing.values() for k in ks if k in keys)


def _task_error(exc: BaseException, allowed_failures: int | None) -> str:
    name = type(exc).__name__
    if name == "KilledWorker":
        n = 3 if allowed_failures is None else allowed_failures
        return (f"the worker process died {n + 1} times while analysing this recording (killed, out of memory, "
                f"or a crash in a native library); given up")
    if name == "CancelledError":
        return "cancelled (the scheduler or the client went away)"
    return f"{name}: {' '.join(str(exc).split())}"[:400]
