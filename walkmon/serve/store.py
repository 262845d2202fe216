"""Read-only access to the session database for the dashboard and ``walkmon history``.

Every connection is opened with ``file:PATH?mode=ro`` (SQLite refuses any write through it), one per call, so
a running ``walkmon live`` keeps writing undisturbed (WAL: readers never block the writer) and the dashboard
sees each commit (at least every ``session.flush_interval_s``, 0.5 s by default) on its next query.
Databases of older schemas (no ``sessions.person``) are read as they are: the store never migrates them.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import sqlite3
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from walkmon.errors import InvalidInputError
from walkmon.gait.live import unmeasured_why
from walkmon.live.config import redacted
from walkmon.views.history import SessionStats, local_time

__all__ = ["DEFAULT_THRESHOLDS", "Store"]

DB_FILENAME = "walkmon.sqlite"  # as walkmon.live.session_log.DB_FILENAME

#: Alert thresholds used when a session's config does not say (walkmon.live.alerts.AlertSettings defaults).
DEFAULT_THRESHOLDS = {"lean_forward_deg": 10.0, "shoulder_down_deg": 5.0, "unsteady_roll_swing_deg": 8.0,
                      "asymmetry_ratio": 0.35}

#: A running session whose newest hop has not changed for this long is reported as stale (crashed, or paused).
STALE_AFTER_S = 5.0


def _f(v: object) -> float:
    return math.nan if v is None else float(v)  # type: ignore[arg-type]


def _num(v: float, digits: int = 3) -> float | None:
    return round(v, digits) if v is not None and math.isfinite(v) else None


class Store:
    """The session database of ``data_dir`` (a folder holding walkmon.sqlite, or the .sqlite file itself)."""

    def __init__(self, data_dir: str | Path) -> None:
        p = Path(data_dir).expanduser()
        self.path = p if p.suffix in (".sqlite", ".db") else p / DB_FILENAME
        self._seen: dict[int, tuple[float, float]] = {}  # session -> (newest hop t_s, monotonic time first seen)
        self._lock = threading.Lock()
        # statistics of ended sessions (ids are never reused: AUTOINCREMENT), keyed by id and end time
        self._ended: dict[int, tuple[str, SessionStats]] = {}

    # -- connections --------------------------------------------------------------------------------------
    @contextmanager
    def connect(self) -> Iterator[sqlite3.Connection]:
        """A read-only connection (closed on exit): the session log's own read-only opening, which refuses a file
        that is not walkmon's; InvalidInputError when there is no database yet or it cannot be read."""
        from walkmon.live.session_log import open_database  # noqa: PLC0415

        conn = open_database(self.path, read_only=True)
        try:
            yield conn
        except sqlite3.DatabaseError as exc:
            msg = f"{self.path}: not a usable walkmon session database ({exc})"
            raise InvalidInputError(msg) from exc
        finally:
            conn.close()

    @staticmethod
    def _has_person(conn: sqlite3.Connection) -> bool:
        return any(r[1] == "person" for r in conn.execute("PRAGMA table_info(sessions)"))

    def _session_rows(self, conn: sqlite3.Connection, where: str = "", params: tuple[Any, ...] = ()) -> list[dict[str, Any]]:
        person = "person" if self._has_person(conn) else "NULL AS person"
        conn.row_factory = sqlite3.Row
        try:
            rows = conn.execute(
                f"SELECT id, kind, started_utc, ended_utc, end_reason, camera, imu, config_json, n_frames, "
                f"n_dropped, {person} FROM sessions {where} ORDER BY id", params).fetchall()
        finally:
            conn.row_factory = None
        return [dict(r) for r in rows]

    # -- statistics -------------------------------------------------------------------------------------
    @staticmethod
    def _settings(row: dict[str, Any]) -> tuple[float, dict[str, float]]:
        try:
            cfg = json.loads(row.get("config_json") or "{}")
        except ValueError:
            cfg = {}
        ind = cfg.get("indicators") if isinstance(cfg, dict) else None
        alerts = cfg.get("alerts") if isinstance(cfg, dict) else None
        hop_s = float(ind.get("hop_s", 1.0)) if isinstance(ind, dict) else 1.0
        th = dict(DEFAULT_THRESHOLDS)
        if isinstance(alerts, dict):
            for k in th:
                if isinstance(alerts.get(k), int | float):
                    th[k] = float(alerts[k])
        return (hop_s if hop_s > 0 else 1.0), th

    _AGG = ("COUNT(*), SUM(walking = 1), SUM(walking = 1 AND -pitch_posture <= ? AND ABS(roll_posture) <= ?), "
            "SUM(walking = 1 AND pitch_posture IS NOT NULL AND roll_posture IS NOT NULL), "
            "AVG(CASE WHEN walking = 1 THEN cadence_spm END), AVG(CASE WHEN walking = 1 THEN pitch_posture END), "
            "AVG(CASE WHEN walking = 1 THEN roll_posture END), AVG(CASE WHEN walking = 1 THEN step_asymmetry END)")

    def _all_stats(self, conn: sqlite3.Connection, rows: list[dict[str, Any]],
                   counts: dict[int, dict[str, int]]) -> list[SessionStats]:
        """Statistics of ``rows`` in one pass over their hops per distinct pair of alert thresholds (usually
        one): a GROUP BY over the hops table rather than a query per session."""
        with self._lock:
            cached = {int(r["id"]): self._ended[int(r["id"])][1] for r in rows
                      if r["ended_utc"] and int(r["id"]) in self._ended and self._ended[int(r["id"])][0] == r["ended_utc"]}
        if len(cached) == len(rows):
            return [cached[int(r["id"])] for r in rows]
        todo = [r for r in rows if int(r["id"]) not in cached]
        groups: dict[tuple[float, float], list[int]] = {}
        settings = {}
        for r in todo:
            hop_s, th = self._settings(r)
            settings[int(r["id"])] = (hop_s, th)
            groups.setdefault((th["lean_forward_deg"], th["shoulder_down_deg"]), []).append(int(r["id"]))
        agg: dict[int, tuple[Any, ...]] = {}
        for (lean, shoulder), ids in groups.items():
            lo, hi = min(ids), max(ids)
            wanted = set(ids)
            for sid, *values in conn.execute(
                    f"SELECT session_id, {self._AGG} FROM hops WHERE session_id BETWEEN ? AND ? GROUP BY session_id",
                    (lean, shoulder, lo, hi)):
                if sid in wanted:
                    agg[int(sid)] = tuple(values)
        out = []
        for r in rows:
            sid = int(r["id"])
            if sid in cached:
                out.append(cached[sid])
                continue
            hop_s, _th = settings[sid]
            n, walking, upright, known, cad, pitch, roll, asym = agg.get(sid, (0, 0, 0, 0, None, None, None, None))
            out.append(SessionStats(
                id=sid, kind=r["kind"], person=r.get("person") or "", started_utc=r["started_utc"],
                ended_utc=r["ended_utc"], end_reason=r["end_reason"], camera=r["camera"] or "", hop_s=hop_s,
                recorded_s=n * hop_s, walking_s=(walking or 0) * hop_s, upright_s=(upright or 0) * hop_s,
                posture_known_s=(known or 0) * hop_s, cadence_spm=_f(cad), pitch_deg=_f(pitch), roll_deg=_f(roll),
                asymmetry=_f(asym), alerts=counts.get(sid, {})))
            if r["ended_utc"]:
                with self._lock:
                    self._ended[sid] = (r["ended_utc"], out[-1])
        return out

    def _stats(self, conn: sqlite3.Connection, row: dict[str, Any], alerts: dict[str, int]) -> SessionStats:
        return self._all_stats(conn, [row], {int(row["id"]): alerts})[0]

    @staticmethod
    def _alert_counts(conn: sqlite3.Connection, ids: list[int] | None = None) -> dict[int, dict[str, int]]:
        q = "SELECT session_id, kind, COUNT(*) FROM alerts WHERE state = 'raised'"
        params: tuple[Any, ...] = ()
        if ids is not None and len(ids) == 1:
            q += " AND session_id = ?"
            params = (ids[0],)
        out: dict[int, dict[str, int]] = {}
        for sid, kind, n in conn.execute(q + " GROUP BY session_id, kind", params):
            out.setdefault(int(sid), {})[str(kind)] = int(n)
        return out

    def session_stats(self, *, since: _dt.timedelta | None = None, person: str | None = None,
                      now_utc: _dt.datetime | None = None) -> list[SessionStats]:
        """Statistics of every session (oldest first), optionally started within ``since`` and of ``person``."""
        where, params = [], []
        if since is not None:
            cutoff = (now_utc or _dt.datetime.now(_dt.UTC)) - since
            where.append("started_utc >= ?")
            params.append(cutoff.astimezone(_dt.UTC).isoformat(timespec="milliseconds"))
        with self.connect() as conn:
            if person is not None:
                if not self._has_person(conn):
                    return []
                where.append("person = ?")
                params.append(person)
            rows = self._session_rows(conn, ("WHERE " + " AND ".join(where)) if where else "", tuple(params))
            counts = self._alert_counts(conn, [r["id"] for r in rows] if len(rows) == 1 else None)
            return self._all_stats(conn, rows, counts)

    def persons(self) -> list[str]:
        with self.connect() as conn:
            if not self._has_person(conn):
                return []
            return [r[0] for r in conn.execute(
                "SELECT DISTINCT person FROM sessions WHERE person IS NOT NULL AND person != '' ORDER BY person")]

    # -- one session ------------------------------------------------------------------------------------
    def session(self, session_id: int) -> tuple[SessionStats, dict[str, Any]]:
        """(statistics, record: the sessions row with config/meta decoded) of one session."""
        with self.connect() as conn:
            rows = self._session_rows(conn, "WHERE id = ?", (session_id,))
            if not rows:
                msg = f"no session {session_id} in the database"
                raise InvalidInputError(msg)
            row = rows[0]
            stats = self._stats(conn, row, self._alert_counts(conn, [session_id]).get(session_id, {}))
            meta = conn.execute("SELECT meta_json FROM sessions WHERE id = ?", (session_id,)).fetchone()[0]
        record = {k: v for k, v in row.items() if k != "config_json"}
        try:
            cfg = json.loads(row.get("config_json") or "{}")
            # sessions recorded before the session log left secrets out may still hold them: never served
            record["config"] = redacted(cfg) if isinstance(cfg, dict) else {}
            record["meta"] = json.loads(meta or "{}")
        except ValueError:
            record["config"], record["meta"] = {}, {}
        return stats, record

    def timeline(self, session_id: int, *, since_t_s: float | None = None, limit: int | None = None) -> dict[str, Any]:
        """The hops of a session as columns (one row per hop) and its alert events.

        ``activity`` is the hop's own (``activity`` in its JSON, from the gait segmentation) when present, else
        ``walking``/``not walking`` from its walking flag. ``since_t_s``: only hops after that capture time;
        ``limit``: only the newest ``limit`` hops.
        """
        with self.connect() as conn:
            rows = self._session_rows(conn, "WHERE id = ?", (session_id,))
            if not rows:
                msg = f"no session {session_id} in the database"
                raise InvalidInputError(msg)
            hop_s, th = self._settings(rows[0])
            q = ("SELECT t_s, walking, cadence_spm, pitch_posture, yaw_posture, roll_posture, label, step_asymmetry, "
                 "json FROM hops WHERE session_id = ?")
            params: list[Any] = [session_id]
            if since_t_s is not None:
                q += " AND t_s > ?"
                params.append(since_t_s)
            if limit is not None:
                q = f"SELECT * FROM ({q} ORDER BY t_s DESC, rowid DESC LIMIT ?) ORDER BY t_s"
                params.append(int(limit))
            else:
                q += " ORDER BY t_s, rowid"
            hops = conn.execute(q, params).fetchall()
            alerts = conn.execute(
                "SELECT t_s, kind, state, value, threshold, message FROM alerts WHERE session_id = ? "
                "ORDER BY t_s, rowid", (session_id,)).fetchall()
        cols: dict[str, list[Any]] = {k: [] for k in ("t_s", "walking", "activity", "label", "cadence_spm", "pitch",
                                                      "yaw", "roll", "step_asymmetry")}
        for t, walking, cad, p, y, r, label, asym, js in hops:
            activity, unseen = None, False
            if js and '"activity"' in js:
                try:
                    doc = json.loads(js)
                    activity = doc.get("activity")
                    if doc.get("source") == "analysis timeline":  # a timeline row's t is its second's middle;
                        t = _f(t) + hop_s / 2  # a hop's is its window's end (gait.report.timeline_from_columns)
                    reasons = (doc.get("classification") or {}).get("reasons") or []
                    # a hop in which the camera measured nothing (a covered lens: LiveIndicatorStage.push_unmeasured)
                    unseen = isinstance(reasons, list) and bool(unmeasured_why(activity, reasons))
                except (ValueError, AttributeError):
                    activity = None
            cols["t_s"].append(_num(_f(t)))
            cols["walking"].append(bool(walking))
            if activity == "unknown" and unseen:
                pass  # drawn as unknown, not as standing
            elif not activity or activity == "unknown":  # older hops, or none of the segmentation's classes
                activity = "walking" if walking else "not walking"
            cols["activity"].append(str(activity))
            cols["label"].append(label or "")
            cols["cadence_spm"].append(_num(_f(cad), 1))
            cols["pitch"].append(_num(_f(p), 2))
            cols["yaw"].append(_num(_f(y), 2))
            cols["roll"].append(_num(_f(r), 2))
            cols["step_asymmetry"].append(_num(_f(asym), 3))
        return {
            "session_id": session_id, "hop_s": hop_s, "thresholds": th, "hops": cols,
            "alerts": [{"t_s": _num(_f(t)), "kind": k, "state": s, "value": _num(_f(v)), "threshold": _num(_f(th_)),
                        "message": m} for t, k, s, v, th_, m in alerts],
        }

    def _since_written_s(self) -> float:
        """Seconds since the database (or its WAL, where a running monitor commits every 0.5 s) was last written."""
        times = []
        for p in (self.path, self.path.with_name(self.path.name + "-wal")):
            try:
                times.append(p.stat().st_mtime)
            except OSError:
                continue
        return max(0.0, time.time() - max(times)) if times else 0.0

    # -- the running session ------------------------------------------------------------------------------
    def live(self, recent: int = 60) -> dict[str, Any]:
        """The newest live session without an end time: its newest hop, active alerts and recent hops.

        ``running`` is False when there is none (then ``last_session`` names the newest session). ``stale_s``:
        seconds since the newest hop last changed, as seen by this store, or since the database was last written,
        whichever is longer (a ``walkmon live`` that was killed leaves a session without an end time whose hops
        stop; a store started after that saw them change at its first look: 'running, not stale' for 5 s, user
        review). Only the newest live session can be running: an older one left without an end time is a monitor
        that was killed before a newer one ran (it was shown running after the newer one had ended).
        """
        with self.connect() as conn:
            rows = self._session_rows(conn, "WHERE kind = 'live' AND ended_utc IS NULL AND id = "
                                            "(SELECT MAX(id) FROM sessions WHERE kind = 'live')")
            if not rows:
                last = conn.execute("SELECT MAX(id) FROM sessions").fetchone()[0]
                return {"running": False, "last_session": last}
            row = rows[0]
            sid = int(row["id"])
            alerts = conn.execute("SELECT t_s, kind, state, message FROM alerts WHERE session_id = ? "
                                  "ORDER BY t_s, rowid", (sid,)).fetchall()
        tl = self.timeline(sid, limit=recent)
        active: dict[str, dict[str, Any]] = {}
        for t, kind, state, message in alerts:
            if state == "raised":
                active[kind] = {"kind": kind, "since_t_s": _num(_f(t)), "message": message}
            else:
                active.pop(kind, None)
        hops = tl["hops"]
        now = time.monotonic()
        newest: dict[str, Any] | None = None
        stale_s = None
        if hops["t_s"]:
            newest = {k: v[-1] for k, v in hops.items()}
            with self._lock:
                seen = self._seen.get(sid)
                if seen is None or seen[0] != newest["t_s"]:
                    self._seen[sid] = (newest["t_s"], now)
                    seen = self._seen[sid]
            stale_s = round(max(now - seen[1], self._since_written_s()), 1)
        return {
            "running": True, "session_id": sid, "person": row.get("person") or None, "camera": row["camera"],
            "started_utc": row["started_utc"], "started_local": local_time(row["started_utc"]).isoformat(
                timespec="seconds"), "hop": newest, "active_alerts": list(active.values()),
            "stale": stale_s is not None and stale_s > STALE_AFTER_S, "stale_s": stale_s,
            "recent": {k: hops[k] for k in ("t_s", "pitch", "roll", "cadence_spm", "activity")},
            "thresholds": tl["thresholds"],
        }
