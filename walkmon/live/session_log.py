"""The session log: every session written while it runs to one SQLite database in the data directory.

WAL journal, ``synchronous=FULL`` and small batched transactions: rows are buffered in memory and committed at
least every ``flush_interval_s`` (default 0.5 s, by the wall clock), so a crash or a power cut loses at most
the last second and never corrupts the database (each commit is atomic and fsynced).

Tables (angles in degrees, times ``t_s`` in seconds of capture time):

* ``sessions``: id, kind (live/analyze), started_utc, ended_utc, end_reason, camera, imu, config_json,
  versions_json, meta_json, n_frames, n_dropped, person (schema 3: who walked, optional; one device or clinic
  database may hold several people; NULL in older rows)
* ``frames``: session_id, t_s, pitch, yaw, roll, n_inliers, model, status, latency_ms, pitch_abs, roll_abs,
  fused (schema 2: the gravity-referenced angles and 1/0 fused/camera-only when an IMU was fused, NULL
  otherwise; databases of schema 1 get the columns added, NULL in their old rows, when opened)
* ``imu``: session_id, t_s, gx, gy, gz, ax, ay, az
* ``hops``: session_id, t_s, walking, cadence_spm, swing/inclination/posture per axis, step_asymmetry,
  label, json
* ``alerts``: session_id, t_s, kind, state, value, threshold, message
* ``calibrations``: session_id, t_s, pitch, yaw, roll, reason, duration_s
"""

from __future__ import annotations

import datetime as _dt
import json
import logging
import math
import platform
import sqlite3
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from walkmon.errors import InvalidInputError, WalkmonError

__all__ = [
    "DB_FILENAME",
    "SCHEMA_VERSION",
    "SessionDeletedError",
    "SessionLog",
    "check_database_usable",
    "check_session_id",
    "TABLE_COLUMNS",
    "SessionSummary",
    "default_data_dir",
    "hop_activity",
    "delete_sessions",
    "list_sessions",
    "open_database",
    "prune_sessions",
    "read_session_table",
    "record_offline_session",
    "session_record",
    "versions",
]

_log = logging.getLogger(__name__)

DB_FILENAME = "walkmon.sqlite"
SCHEMA_VERSION = 3

_SCHEMA = """
CREATE TABLE IF NOT EXISTS sessions (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    kind TEXT NOT NULL,
    started_utc TEXT NOT NULL,
    ended_utc TEXT,
    end_reason TEXT,
    camera TEXT,
    imu TEXT,
    config_json TEXT,
    versions_json TEXT,
    meta_json TEXT,
    n_frames INTEGER DEFAULT 0,
    n_dropped INTEGER DEFAULT 0,
    person TEXT
);
CREATE TABLE IF NOT EXISTS frames (
    session_id INTEGER NOT NULL, t_s REAL NOT NULL, pitch REAL, yaw REAL, roll REAL,
    n_inliers INTEGER, model TEXT, status TEXT, latency_ms REAL, pitch_abs REAL, roll_abs REAL, fused INTEGER
);
CREATE TABLE IF NOT EXISTS imu (
    session_id INTEGER NOT NULL, t_s REAL NOT NULL, gx REAL, gy REAL, gz REAL, ax REAL, ay REAL, az REAL
);
CREATE TABLE IF NOT EXISTS hops (
    session_id INTEGER NOT NULL, t_s REAL NOT NULL, walking INTEGER, cadence_spm REAL,
    pitch_swing REAL, yaw_swing REAL, roll_swing REAL,
    pitch_inclination REAL, yaw_inclination REAL, roll_inclination REAL,
    pitch_posture REAL, yaw_posture REAL, roll_posture REAL,
    step_asymmetry REAL, label TEXT, json TEXT
);
CREATE TABLE IF NOT EXISTS alerts (
    session_id INTEGER NOT NULL, t_s REAL NOT NULL, kind TEXT, state TEXT, value REAL, threshold REAL,
    message TEXT
);
CREATE TABLE IF NOT EXISTS calibrations (
    session_id INTEGER NOT NULL, t_s REAL NOT NULL, pitch REAL, yaw REAL, roll REAL, reason TEXT,
    duration_s REAL
);
CREATE INDEX IF NOT EXISTS frames_session ON frames(session_id, t_s);
CREATE INDEX IF NOT EXISTS imu_session ON imu(session_id, t_s);
CREATE INDEX IF NOT EXISTS hops_session ON hops(session_id, t_s);
"""

#: Columns of each per-session table, in order (without session_id).
TABLE_COLUMNS: dict[str, tuple[str, ...]] = {
    "frames": ("t_s", "pitch", "yaw", "roll", "n_inliers", "model", "status", "latency_ms", "pitch_abs", "roll_abs",
               "fused"),
    "imu": ("t_s", "gx", "gy", "gz", "ax", "ay", "az"),
    "hops": (
        "t_s", "walking", "cadence_spm", "pitch_swing", "yaw_swing", "roll_swing", "pitch_inclination",
        "yaw_inclination", "roll_inclination", "pitch_posture", "yaw_posture", "roll_posture",
        "step_asymmetry", "label", "json",
    ),
    "alerts": ("t_s", "kind", "state", "value", "threshold", "message"),
    "calibrations": ("t_s", "pitch", "yaw", "roll", "reason", "duration_s"),
}


def default_data_dir() -> Path:
    """``$XDG_DATA_HOME/walkmon`` or ``~/.local/share/walkmon`` (the service uses /var/lib/walkmon)."""
    import os  # noqa: PLC0415

    base = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return Path(base) / "walkmon"


def versions() -> dict[str, str]:
    """Versions of walkmon, Python and the main libraries, recorded with each session."""
    from walkmon._version import __version__  # noqa: PLC0415

    out = {"walkmon": __version__, "python": platform.python_version(), "platform": platform.platform()}
    for mod in ("numpy", "cv2", "scipy"):
        try:
            out[mod] = str(__import__(mod).__version__)
        except Exception:  # noqa: BLE001 - a missing library just goes unrecorded
            continue
    out["sqlite"] = sqlite3.sqlite_version
    return out


def _utc_now() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="milliseconds")


def _db_path(data_dir: str | Path) -> Path:
    p = Path(data_dir)
    return p if p.suffix in (".sqlite", ".db") else p / DB_FILENAME


#: ``PRAGMA application_id`` of a walkmon session database ("WKMN"): how walkmon knows a file is its own.
APPLICATION_ID = 0x574B4D4E

#: Columns every walkmon database has had since schema 1 (a foreign file with a ``sessions`` table lacks them).
_SCHEMA1_COLUMNS: dict[str, tuple[str, ...]] = {
    "sessions": ("id", "kind", "started_utc", "ended_utc", "end_reason", "camera", "imu", "config_json",
                 "versions_json", "meta_json", "n_frames", "n_dropped"),
    **{name: ("session_id", *(c for c in cols if c not in ("pitch_abs", "roll_abs", "fused")))
       for name, cols in TABLE_COLUMNS.items()},
}


def _db_error(path: Path, exc: sqlite3.Error) -> InvalidInputError:
    """One line for a database error: damaged, not a database, locked, read-only, full."""
    text = " ".join(str(exc).split())  # one line, whatever SQLite put in it
    if isinstance(exc, sqlite3.DatabaseError) and ("malformed" in text or "not a database" in text):
        return InvalidInputError(
            f"{path}: the session database is damaged ({text}); keep a copy and recover what is readable with "
            f"'sqlite3 {path} .recover | sqlite3 recovered.sqlite'")
    return InvalidInputError(f"{path}: session database error ({text})")


def _check_walkmon_database(conn: sqlite3.Connection, path: Path) -> bool:
    """Refuse a file that is not walkmon's before anything is written to it; False if it has no table yet.

    Walkmon's: ``application_id`` is :data:`APPLICATION_ID` (databases before it: 0, with every walkmon table
    and column of schema 1), and ``user_version`` at most :data:`SCHEMA_VERSION`.
    """
    app_id = int(conn.execute("PRAGMA application_id").fetchone()[0])
    user_version = int(conn.execute("PRAGMA user_version").fetchone()[0])
    tables = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type='table'")}
    if app_id not in (0, APPLICATION_ID):
        msg = (f"{path}: not a walkmon session database (SQLite application_id {app_id:#x}); refusing to touch "
               "it: give walkmon its own --data-dir")
        raise InvalidInputError(msg)
    if app_id == 0 and not tables - {"sqlite_sequence"}:
        if user_version:
            msg = f"{path}: not a walkmon session database (empty, user_version {user_version})"
            raise InvalidInputError(msg)
        return False
    if app_id == 0:  # a database of walkmon before the application id, or another application's file
        for table, cols in ((t, _SCHEMA1_COLUMNS[t]) for t in ("sessions", "frames")):  # the rest: created
            have = {r[1] for r in conn.execute(f"PRAGMA table_info({table})")} if table in tables else set()
            if not set(cols) <= have:
                what = f"table {table} lacks {', '.join(sorted(set(cols) - have))}" if have else f"no table {table}"
                msg = f"{path}: not a walkmon session database ({what}); refusing to touch it"
                raise InvalidInputError(msg)
    if user_version > SCHEMA_VERSION:
        msg = (f"{path}: written by a newer walkmon (schema {user_version}, this one knows {SCHEMA_VERSION}); "
               "upgrade walkmon")
        raise InvalidInputError(msg)
    return True


def _private(path: Path) -> None:
    """Make an existing database file (and its WAL/SHM) 0600 when it is ours: health data."""
    import os  # noqa: PLC0415
    import stat  # noqa: PLC0415

    for p in (path, path.with_name(path.name + "-wal"), path.with_name(path.name + "-shm")):
        try:
            st = p.lstat()
        except FileNotFoundError:
            continue
        if stat.S_ISREG(st.st_mode) and st.st_mode & 0o077 and st.st_uid == os.geteuid():
            _log.warning("%s was readable by other users (mode %o): made it 0600", p, st.st_mode & 0o777)
            os.chmod(p, 0o600)


def _create_private(path: Path) -> None:
    """Create the data folder (0700) and an empty database file (0600) unless they exist; never via a link."""
    import os  # noqa: PLC0415

    if path.is_symlink():
        msg = f"{path}: the session database is a symbolic link; refusing to write health data through it"
        raise InvalidInputError(msg)
    if not path.parent.exists():
        from walkmon.safe_io import prepare_dir  # noqa: PLC0415

        prepare_dir(path.parent)  # every missing parent 0700 too
    if not path.exists():
        try:
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o600)
        except FileExistsError:
            return  # another process created it meanwhile
        os.close(fd)


def hop_activity(json_text: object) -> str:
    """A hop's activity (standing, walking, turning, unknown) from its ``json`` column; '' where it has none (older
    hops, or text that is not a JSON object). The export and :func:`walkmon.load_session` give it as a column."""
    if not isinstance(json_text, str) or not json_text:
        return ""
    try:
        doc = json.loads(json_text)
    except ValueError:
        return ""
    return str(doc.get("activity") or "") if isinstance(doc, dict) else ""


def check_database_usable(data_dir: str | Path) -> Path:
    """Refuse (one :class:`~walkmon.errors.InvalidInputError` line) a data folder the session database cannot be
    written in, before any work whose result it is to hold (``analyze --save``: user review, every output was
    written and success printed, then 'Not a directory' and exit 2). An existing database is opened (a foreign
    or broken file refused); a missing one is not created: its nearest existing folder must be a writable
    folder. Returns the database's path."""
    import os  # noqa: PLC0415

    path = _db_path(data_dir)
    if path.exists() or path.is_symlink():
        open_database(data_dir).close()
        return path
    up = path.parent
    while not up.exists() and up.parent != up:
        if up.is_symlink():
            break
        up = up.parent
    if not up.is_dir():
        msg = f"{up}: not a folder; the session database cannot be made in {path.parent}"
        raise InvalidInputError(msg)
    if not os.access(up, os.W_OK | os.X_OK):
        msg = f"{up}: not writable; the session database cannot be made in {path.parent}"
        raise InvalidInputError(msg)
    return path


def open_database(data_dir: str | Path, *, create: bool = True, read_only: bool = False) -> sqlite3.Connection:
    """Open the session database in ``data_dir`` (or at that ``.sqlite`` path); WAL mode.

    ``read_only`` (the commands that only read: sessions list/export, report, prune --dry-run) opens it with
    SQLite's ``mode=ro``: nothing is written, not even the schema, so a read-only file works and its contents
    and mtime stay as they were. Otherwise the folder (0700) and file (0600) are created when ``create``, and the
    schema is brought up to date. Either way a file that is not walkmon's is refused before anything is
    written to it (:func:`_check_walkmon_database`), and every SQLite error becomes one
    :class:`~walkmon.errors.InvalidInputError` line.
    """
    from urllib.parse import quote  # noqa: PLC0415

    path = _db_path(data_dir)
    if (read_only or not create) and not path.exists():
        msg = f"{path}: no session database here (run 'walkmon live' or 'walkmon analyze --save' first)"
        raise InvalidInputError(msg)
    if path.exists() and not path.is_file():
        msg = f"{path}: not a file (a session database is one SQLite file)"
        raise InvalidInputError(msg)
    conn: sqlite3.Connection | None = None
    try:
        if read_only:
            conn = sqlite3.connect(f"file:{quote(str(path.resolve()))}?mode=ro", uri=True, check_same_thread=False,
                                   timeout=10.0)
            _check_walkmon_database(conn, path)
            return conn
        _create_private(path)
        conn = sqlite3.connect(str(path), check_same_thread=False, timeout=10.0)
        _check_walkmon_database(conn, path)
        # made private only once it is known to be walkmon's: a foreign file is refused as it was found (user review:
        # its mode was changed, with a warning, and then it was refused)
        _private(path)
        conn.execute("PRAGMA journal_mode=WAL")
        conn.execute("PRAGMA synchronous=FULL")
        conn.executescript(_SCHEMA)
        _migrate(conn)
        conn.execute(f"PRAGMA application_id={APPLICATION_ID}")
        conn.execute(f"PRAGMA user_version={SCHEMA_VERSION}")
        conn.commit()
        _private(path)  # the WAL and SHM files SQLite just made take the file's mode; make sure
    except sqlite3.Error as exc:
        if conn is not None:
            conn.close()
        raise _db_error(path, exc) from exc
    except BaseException:
        if conn is not None:
            conn.close()
        raise
    return conn


#: Columns added after schema 1: (table, column, SQL type); all nullable, so old rows read as NULL.
_ADDED_COLUMNS = (("frames", "pitch_abs", "REAL"), ("frames", "roll_abs", "REAL"), ("frames", "fused", "INTEGER"),
                  ("sessions", "person", "TEXT"))


def _migrate(conn: sqlite3.Connection) -> None:
    """Bring an older database to :data:`SCHEMA_VERSION` (add the nullable columns it lacks)."""
    for table, column, sql_type in _ADDED_COLUMNS:
        have = {row[1] for row in conn.execute(f"PRAGMA table_info({table})")}
        if column not in have:
            conn.execute(f"ALTER TABLE {table} ADD COLUMN {column} {sql_type}")
            _log.info("session database: added %s.%s (schema %d)", table, column, SCHEMA_VERSION)


class _SessionGone(Exception):
    """Internal: the session row vanished (rolls the flush's transaction back)."""


class SessionDeletedError(WalkmonError):
    """The session being recorded was deleted by another process (``walkmon sessions delete --force``)."""


def _num(v: object) -> object:
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


class SessionLog:
    """Writer of one session. Not thread-safe: one thread (the processing loop) writes.

    ``add_*`` buffer rows; :meth:`maybe_flush` commits when ``flush_interval_s`` has passed (call it often, also
    when no data arrives); :meth:`close` flushes and records the end. Use as a context manager.
    """

    def __init__(
        self,
        data_dir: str | Path,
        *,
        kind: str = "live",
        camera: str = "",
        imu: str = "",
        config: Mapping[str, object] | None = None,
        meta: dict[str, object] | None = None,
        flush_interval_s: float = 0.5,
        log_frames: bool = True,
        person: str = "",
    ) -> None:
        if flush_interval_s <= 0:
            msg = f"flush_interval_s must be > 0, got {flush_interval_s}"
            raise ValueError(msg)
        self.path = _db_path(data_dir)
        self.flush_interval_s = flush_interval_s
        self.log_frames = log_frames
        self._conn = open_database(data_dir)
        try:
            with self._conn:
                cur = self._conn.execute(
                    "INSERT INTO sessions (kind, started_utc, camera, imu, config_json, versions_json, meta_json, "
                    "person) VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                    (kind, _utc_now(), camera, imu, json.dumps(config or {}, sort_keys=True, default=str),
                     json.dumps(versions(), sort_keys=True), json.dumps(meta or {}, sort_keys=True, default=str),
                     person or None),
                )
        except sqlite3.Error as exc:
            self._conn.close()
            raise _db_error(self.path, exc) from exc
        self.session_id = int(cur.lastrowid or 0)
        self.person = person
        #: True once another process deleted this session while it was recorded: nothing more is written
        self.deleted = False
        self._buffers: dict[str, list[tuple[object, ...]]] = {name: [] for name in TABLE_COLUMNS}
        self._last_flush = time.monotonic()
        self.n_frames = 0
        self.n_dropped = 0
        self._closed = False

    # -- buffering --------------------------------------------------------------------------------------
    def add_frame(self, t_s: float, angles_deg: Sequence[float], n_inliers: int = -1, model: str = "",
                  status: str = "", latency_ms: float = math.nan,
                  abs_angles_deg: Sequence[float] | None = None, fused: bool | None = None) -> None:
        """One frame; ``abs_angles_deg`` (pitch_abs, roll_abs) and ``fused`` only when an IMU is fused."""
        self.n_frames += 1
        if self.log_frames:
            p, y, r = (float(v) for v in angles_deg)
            pa, ra = (None, None) if abs_angles_deg is None else (_num(float(v)) for v in abs_angles_deg)
            self._buffers["frames"].append(
                (self.session_id, float(t_s), _num(p), _num(y), _num(r), int(n_inliers), model, status,
                 _num(float(latency_ms)), pa, ra, None if fused is None else int(bool(fused))))

    def add_imu(self, t_s: float, gyroscope_rad_s: Sequence[float], accelerometer_ms2: Sequence[float]) -> None:
        """One IMU sample (rad/s, m/s²); a gyroscope of NaN (an accelerometer alone) is stored as NULL."""
        self._buffers["imu"].append((self.session_id, float(t_s), *(_num(float(v)) for v in gyroscope_rad_s),
                                     *map(float, accelerometer_ms2)))

    def add_timeline_hop(self, t_s: float, activity: str, label: str, pitch_deg: float, roll_deg: float,
                         cadence_spm: float) -> None:
        """One second of an offline analysis' timeline (:attr:`walkmon.api.Analysis.timeline`) as a hop: its
        activity (walking or not), posture label, heading-free pitch and roll from the upright reference, and the
        cadence of the walking bout it lies in, so that the history and the dashboard count an analysis' time as
        they count a live session's hops. The per-cycle swings and inclinations a live hop carries stay NULL."""
        walking = activity == "walking"
        doc = {"t_s": float(t_s), "walking": walking, "activity": activity, "source": "analysis timeline",
               "classification": {"label": label, "reasons": []}}
        self._buffers["hops"].append(
            (self.session_id, float(t_s), int(walking), _num(float(cadence_spm)) if walking else None,
             None, None, None, None, None, None, _num(float(pitch_deg)), None, _num(float(roll_deg)), None,
             label or ("unclassified" if walking else "not_walking"), json.dumps(doc, sort_keys=True)))

    def add_hop(self, ind: object, extra: dict[str, object] | None = None) -> None:
        """One :class:`~walkmon.gait.live.LiveIndicators`; ``extra`` is merged into its JSON (e.g. the
        fusion's counters under ``"fusion"``)."""
        d = ind.to_dict()  # type: ignore[attr-defined]
        if extra:
            d = {**d, **extra}
        sw, inc, pos = ind.swing_deg, ind.inclination_deg, ind.posture_deg  # type: ignore[attr-defined]
        self._buffers["hops"].append(
            (self.session_id, float(ind.t_s), int(bool(ind.walking)), _num(ind.cadence_spm),  # type: ignore[attr-defined]
             *(_num(float(v)) for v in (*sw, *inc, *pos)), _num(ind.step_asymmetry), ind.label,  # type: ignore[attr-defined]
             json.dumps(d, sort_keys=True)))
        if getattr(ind, "calibration", None) is not None:
            self.add_calibration(ind.calibration)  # type: ignore[attr-defined]

    def add_alert(self, ev: object) -> None:
        """One :class:`~walkmon.live.alerts.AlertEvent`."""
        self._buffers["alerts"].append((self.session_id, float(ev.t_s), ev.kind, ev.state,  # type: ignore[attr-defined]
                                        _num(float(ev.value)), float(ev.threshold), ev.message))  # type: ignore[attr-defined]

    def add_calibration(self, cal: object) -> None:
        """One :class:`~walkmon.gait.live.CalibrationEvent`."""
        p, y, r = cal.angles_deg  # type: ignore[attr-defined]
        self._buffers["calibrations"].append((self.session_id, float(cal.t_s), p, y, r, cal.reason,  # type: ignore[attr-defined]
                                              float(cal.duration_s)))  # type: ignore[attr-defined]

    # -- committing -------------------------------------------------------------------------------------
    def maybe_flush(self) -> bool:
        """Commit buffered rows if ``flush_interval_s`` has passed since the last commit; True if it did."""
        if time.monotonic() - self._last_flush >= self.flush_interval_s:
            self.flush()
            return True
        return False

    def flush(self) -> None:
        """Commit every buffered row in one transaction."""
        if self._closed:
            return
        if self.deleted:
            for rows in self._buffers.values():
                rows.clear()
            return
        try:
            with self._conn:
                # first: is the session still there? ('walkmon sessions delete --force' from another process)
                cur = self._conn.execute("UPDATE sessions SET n_frames=?, n_dropped=? WHERE id=?",
                                         (self.n_frames, self.n_dropped, self.session_id))
                if cur.rowcount == 0:
                    raise _SessionGone
                for name, rows in self._buffers.items():
                    if rows:
                        cols = ("session_id", *TABLE_COLUMNS[name])
                        self._conn.executemany(
                            f"INSERT INTO {name} ({', '.join(cols)}) VALUES ({', '.join('?' * len(cols))})", rows)
                        rows.clear()
        except _SessionGone:  # rolled back: no row is written under an id that no longer exists
            self.deleted = True
            for rows in self._buffers.values():
                rows.clear()
            msg = (f"session {self.session_id} was deleted from {self.path} by another process while it was being "
                   "recorded; stopped recording it")
            raise SessionDeletedError(msg) from None
        except sqlite3.Error as exc:
            raise _db_error(self.path, exc) from exc
        self._last_flush = time.monotonic()

    def close(self, end_reason: str = "stopped", meta: dict[str, object] | None = None) -> None:
        """Flush, record the end time, reason and counters, and close the database."""
        if self._closed:
            return
        if self.deleted:
            self._closed = True
            self._conn.close()
            return
        try:
            try:
                self.flush()
            except SessionDeletedError:
                return
            with self._conn:
                self._conn.execute("UPDATE sessions SET ended_utc=?, end_reason=? WHERE id=?",
                                   (_utc_now(), end_reason, self.session_id))
                if meta is not None:
                    row = self._conn.execute("SELECT meta_json FROM sessions WHERE id=?", (self.session_id,)).fetchone()
                    merged = {**json.loads(row[0] or "{}"), **meta}
                    self._conn.execute("UPDATE sessions SET meta_json=? WHERE id=?",
                                       (json.dumps(merged, sort_keys=True, default=str), self.session_id))
            self._conn.execute("PRAGMA wal_checkpoint(PASSIVE)")
        except sqlite3.Error as exc:
            raise _db_error(self.path, exc) from exc
        finally:
            self._closed = True
            self._conn.close()

    def discard(self, why: str) -> None:
        """Delete this session (it recorded nothing worth keeping, e.g. the camera failed to open) and close."""
        if self._closed:
            return
        try:
            if not self.deleted:
                for rows in self._buffers.values():
                    rows.clear()
                _delete_rows(self._conn, [self.session_id])
                _log.info("session %d discarded: %s", self.session_id, why)
        except sqlite3.Error as exc:
            raise _db_error(self.path, exc) from exc
        finally:
            self.deleted = True
            self._closed = True
            self._conn.close()

    @property
    def closed(self) -> bool:
        return self._closed

    def __enter__(self) -> SessionLog:
        return self

    def __exit__(self, exc_type: object, exc: object, tb: object) -> None:
        self.close("error" if exc_type else "stopped")


# ---------------------------------------------------------------------------------------------- reading


@dataclass(frozen=True, slots=True)
class SessionSummary:
    id: int
    kind: str
    started_utc: str
    ended_utc: str | None
    end_reason: str | None
    camera: str
    imu: str
    n_frames: int
    n_dropped: int
    n_hops: int
    n_alerts: int
    duration_s: float


def list_sessions(data_dir: str | Path) -> list[SessionSummary]:
    """Every session in the database, oldest first (opened read-only; a damaged file is reported, not listed)."""
    path = _db_path(data_dir)
    conn = open_database(data_dir, read_only=True)
    try:
        if not _has_tables(conn):
            return []
        check = conn.execute("PRAGMA quick_check(1)").fetchone()[0]
        if check != "ok":
            raise _db_error(path, sqlite3.DatabaseError(f"database disk image is malformed: {check}"))
        tables = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        hops = "(SELECT COUNT(*) FROM hops h WHERE h.session_id = s.id)" if "hops" in tables else "0"
        alerts = ("(SELECT COUNT(*) FROM alerts a WHERE a.session_id = s.id AND a.state = 'raised')"
                  if "alerts" in tables else "0")
        rows = conn.execute(
            "SELECT s.id, s.kind, s.started_utc, s.ended_utc, s.end_reason, s.camera, s.imu, "
            "(SELECT COUNT(*) FROM frames f WHERE f.session_id = s.id), s.n_dropped, "
            f"{hops}, {alerts}, "
            "(SELECT MAX(t_s) - MIN(t_s) FROM frames f WHERE f.session_id = s.id) "
            "FROM sessions s ORDER BY s.id"
        ).fetchall()
    except sqlite3.Error as exc:
        raise _db_error(path, exc) from exc
    finally:
        conn.close()
    return [SessionSummary(r[0], r[1], r[2], r[3], r[4], r[5] or "", r[6] or "", int(r[7]), int(r[8] or 0),
                           int(r[9]), int(r[10]), float(r[11] or 0.0)) for r in rows]


def _has_tables(conn: sqlite3.Connection) -> bool:
    return conn.execute("SELECT 1 FROM sqlite_master WHERE type='table' AND name='sessions'").fetchone() is not None


def _conn_path(conn: sqlite3.Connection) -> Path:
    row = conn.execute("PRAGMA database_list").fetchone()
    return Path(row[2] if row and row[2] else "session database")


#: Largest session id: SQLite's INTEGER PRIMARY KEY is a signed 64-bit integer.
MAX_SESSION_ID = 2**63 - 1


def check_session_id(session_id: int) -> int:
    """``session_id`` if it can be a session id (1 .. 2^63-1), else InvalidInputError (one line)."""
    if not 1 <= int(session_id) <= MAX_SESSION_ID:
        msg = f"no session {session_id} (session ids are 1 .. 2^63-1; see 'walkmon sessions list')"
        raise InvalidInputError(msg)
    return int(session_id)


def session_record(conn: sqlite3.Connection, session_id: int) -> dict[str, object]:
    """The ``sessions`` row of ``session_id`` as a dict (JSON fields decoded); InvalidInputError if absent."""
    session_id = check_session_id(session_id)
    row = None
    conn.row_factory = sqlite3.Row
    try:
        if _has_tables(conn):
            row = conn.execute("SELECT * FROM sessions WHERE id=?", (session_id,)).fetchone()
    except sqlite3.Error as exc:
        raise _db_error(_conn_path(conn), exc) from exc
    finally:
        conn.row_factory = None
    if row is None:
        msg = f"no session {session_id} in the database (see 'walkmon sessions list')"
        raise InvalidInputError(msg)
    d = dict(row)
    for k in ("config_json", "versions_json", "meta_json"):
        try:
            doc = json.loads(d.pop(k) or "{}")
        except (TypeError, ValueError):
            doc = {"unreadable": True}
        d[k[:-5]] = doc
    return d


def read_session_table(conn: sqlite3.Connection, session_id: int, table: str) -> dict[str, list[object]]:
    """Columns of ``table`` for one session, ordered by time: {column: values}.

    Columns an older database lacks (schema 1: ``pitch_abs``, ``roll_abs``, ``fused``) read as NULL (None).
    """
    if table not in TABLE_COLUMNS:
        msg = f"unknown table {table!r}; known: {sorted(TABLE_COLUMNS)}"
        raise InvalidInputError(msg)
    session_id = check_session_id(session_id)
    cols = TABLE_COLUMNS[table]
    try:
        have = {r[1] for r in conn.execute(f"PRAGMA table_info({table})")}
        if not have:  # a table an older database never had (opened read-only, so not created)
            return {c: [] for c in cols}
        select = ", ".join(c if c in have else "NULL" for c in cols)
        rows = conn.execute(
            f"SELECT {select} FROM {table} WHERE session_id=? ORDER BY t_s, rowid", (session_id,)
        ).fetchall()
    except sqlite3.Error as exc:
        raise _db_error(_conn_path(conn), exc) from exc
    return {c: [r[i] for r in rows] for i, c in enumerate(cols)}


#: An offline analysis is stored in transactions of this many rows: an hour of a 200 Hz IMU in one held the
#: database's write lock for ~2 s, which a 'walkmon live' writing beside it waits out only up to its 10 s timeout
#: on a slow card (review).
_OFFLINE_COMMIT_ROWS = 20_000


def record_offline_session(
    data_dir: str | Path,
    t_s: Iterable[float],
    angles_deg: Iterable[Sequence[float]],
    *,
    source: str,
    imu: str = "",
    meta: dict[str, object] | None = None,
    config: dict[str, object] | None = None,
    extra: Iterable[tuple[int, str, str]] | None = None,
    abs_angles_deg: Iterable[Sequence[float]] | None = None,
    fused: Iterable[bool] | None = None,
    person: str = "",
    imu_samples: tuple[Sequence[float], Sequence[Sequence[float]] | None, Sequence[Sequence[float]]] | None = None,
    timeline: Iterable[tuple[float, str, str, float, float, float]] | None = None,
) -> int:
    """Store an offline analysis (``walkmon analyze --save``) as a session of kind ``analyze``; its id.

    ``abs_angles_deg`` (pitch_abs, roll_abs per frame; NaN stored as NULL) and ``fused`` (1/0 per frame) fill
    the frames' schema-2 columns when the analysis used an IMU; without them they stay NULL, as for a
    camera-only live session. ``imu_samples``: ``(t_s, gyro rad/s or None, acc m/s²)``, the raw samples the
    analysis took its steps from, on the frames' time base (the imu table; ``walkmon report ID`` analyses them
    again as ``analyze`` did). ``timeline``: ``(t, activity, label, pitch, roll, cadence_spm)`` per second, stored
    as hops (:meth:`SessionLog.add_timeline_hop`) for the history and the dashboard.
    """
    t_list, a_list = list(t_s), list(angles_deg)
    columns: dict[str, list[Any] | None] = {"extra": None if extra is None else list(extra),
               "abs": None if abs_angles_deg is None else list(abs_angles_deg),
               "fused": None if fused is None else list(fused)}
    for name, values in columns.items():
        if values is not None and len(values) != len(t_list):
            msg = f"{name}: {len(values)} rows for {len(t_list)} frames"
            raise InvalidInputError(msg)
    log = SessionLog(data_dir, kind="analyze", camera=source, imu=imu, config=config, meta=meta,
                     flush_interval_s=3600, person=person)
    for i, (t, a) in enumerate(zip(t_list, a_list, strict=True)):
        n_inl, model, status = columns["extra"][i] if columns["extra"] is not None else (-1, "", "")
        log.add_frame(t, a, n_inl, model, status,
                      abs_angles_deg=None if columns["abs"] is None else columns["abs"][i],
                      fused=None if columns["fused"] is None else bool(columns["fused"][i]))
        if (i + 1) % _OFFLINE_COMMIT_ROWS == 0:
            log.flush()
    if imu_samples is not None:
        t_imu, gyro, acc = imu_samples
        no_gyro = (math.nan, math.nan, math.nan)
        for i, ti in enumerate(t_imu):
            log.add_imu(float(ti), no_gyro if gyro is None else gyro[i], acc[i])
            if (i + 1) % _OFFLINE_COMMIT_ROWS == 0:
                log.flush()
    for row in timeline or ():
        log.add_timeline_hop(*row)
    log.close("complete")
    return log.session_id


# ---------------------------------------------------------------------------------------------- retention


def _delete_rows(conn: sqlite3.Connection, ids: Sequence[int]) -> None:
    """Delete sessions ``ids`` and their rows in every table, in one transaction."""
    params = [(i,) for i in ids]
    with conn:
        for table in TABLE_COLUMNS:
            conn.executemany(f"DELETE FROM {table} WHERE session_id=?", params)
        conn.executemany("DELETE FROM sessions WHERE id=?", params)


def _vacuum(conn: sqlite3.Connection) -> None:
    """Rebuild the file without the freed pages and truncate the WAL, so the file on disk shrinks."""
    conn.execute("VACUUM")
    conn.execute("PRAGMA wal_checkpoint(TRUNCATE)")


def delete_sessions(data_dir: str | Path, ids: Iterable[int], *, force: bool = False) -> list[int]:
    """Delete the sessions ``ids`` and all their rows (one transaction), then VACUUM; the ids deleted.

    A session without an end time may be one a ``walkmon live`` is still writing into (it would keep adding
    rows under an id that no longer exists), so it is refused unless ``force`` (for a session cut off by a power
    loss or a crash). An id not in the database, or a refused one, raises
    :class:`~walkmon.errors.InvalidInputError` and deletes nothing.
    """
    wanted = sorted({check_session_id(i) for i in ids})
    path = _db_path(data_dir)
    conn = open_database(data_dir, create=False)
    try:
        ended = dict(conn.execute("SELECT id, ended_utc IS NOT NULL FROM sessions").fetchall())
        missing = [i for i in wanted if i not in ended]
        if missing:
            msg = (f"no session {', '.join(map(str, missing))} in the database (see 'walkmon sessions list'); "
                   "nothing deleted")
            raise InvalidInputError(msg)
        unended = [i for i in wanted if not ended[i]]
        if unended and not force:
            msg = (f"session {', '.join(map(str, unended))} has no end time and may still be running; nothing "
                   "deleted (pass --force to delete a session that was cut off, e.g. by a power loss)")
            raise InvalidInputError(msg)
        if wanted:
            _delete_rows(conn, wanted)
            _vacuum(conn)
            _log.info("deleted session(s) %s from %s%s", ", ".join(map(str, wanted)), _db_path(data_dir),
                      f" (forced, without an end time: {', '.join(map(str, unended))})" if unended else "")
    except sqlite3.Error as exc:
        raise _db_error(path, exc) from exc
    finally:
        conn.close()
    return wanted


def prune_sessions(
    data_dir: str | Path,
    older_than_days: float,
    keep: int | None = None,
    dry_run: bool = False,
    *,
    now_utc: _dt.datetime | None = None,
) -> list[int]:
    """Delete the ended sessions that started more than ``older_than_days`` ago; the ids deleted, oldest first.

    A session without an end time (running, or cut off) is never deleted. With ``keep``, the ``keep`` newest
    ended sessions (by start time) are kept whatever their age. ``dry_run`` deletes nothing and returns what
    would be deleted. After deleting, VACUUM shrinks the file. ``now_utc`` (default: the clock) is for tests.
    """
    if not (math.isfinite(older_than_days) and older_than_days >= 0):
        msg = f"older than DAYS must be a number >= 0, got {older_than_days}"
        raise InvalidInputError(msg)
    if keep is not None and keep < 0:
        msg = f"keep must be >= 0, got {keep}"
        raise InvalidInputError(msg)
    now = now_utc or _dt.datetime.now(_dt.UTC)
    try:
        cutoff = now - _dt.timedelta(days=older_than_days)
    except OverflowError:  # more days than a date can go back: nothing is that old
        cutoff = _dt.datetime.min.replace(tzinfo=_dt.UTC)
    path = _db_path(data_dir)
    conn = open_database(data_dir, create=False, read_only=dry_run)
    try:
        ended = []  # (started, id), ended sessions only
        for sid, started in ([] if not _has_tables(conn) else conn.execute("SELECT id, started_utc FROM sessions WHERE ended_utc IS NOT NULL")):
            try:
                t = _dt.datetime.fromisoformat(started)
            except (TypeError, ValueError):
                _log.warning("session %d: unreadable start time %r, not pruned", sid, started)
                continue
            ended.append((t if t.tzinfo else t.replace(tzinfo=_dt.UTC), sid))
        ended.sort()
        kept_newest = {sid for _, sid in ended[max(0, len(ended) - keep):]} if keep else set()
        doomed = [sid for t, sid in ended if t < cutoff and sid not in kept_newest]
        if doomed and not dry_run:
            _delete_rows(conn, doomed)
            _vacuum(conn)
            _log.info("pruned %d session(s) started before %s: %s", len(doomed), cutoff.isoformat(timespec="seconds"),
                      ", ".join(map(str, doomed)))
    except sqlite3.Error as exc:
        raise _db_error(path, exc) from exc
    finally:
        conn.close()
    return doomed
