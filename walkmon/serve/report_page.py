"""The report of a logged session for the dashboard (``/sessions/{id}/report``), built from the database read
read-only: the same report as ``walkmon report ID`` writes, rendered in memory."""

from __future__ import annotations

import numpy as np

from walkmon.errors import InvalidInputError
from walkmon.serve.store import Store

__all__ = ["session_report_html"]


def session_report_html(store: Store, session_id: int) -> str:
    from walkmon.api import analyze_angles  # noqa: PLC0415

    stats, record = store.session(session_id)
    with store.connect() as conn:
        columns = {r[1] for r in conn.execute("PRAGMA table_info(frames)").fetchall()}
        fused = {"pitch_abs", "roll_abs"} <= columns  # schema 2: the fused gravity-referenced angles
        rows = conn.execute(f"SELECT t_s, pitch, yaw, roll{', pitch_abs, roll_abs' if fused else ''} FROM frames "
                            "WHERE session_id = ? ORDER BY t_s, rowid", (session_id,)).fetchall()
        cal = conn.execute("SELECT pitch, yaw, roll FROM calibrations WHERE session_id = ? ORDER BY t_s LIMIT 1",
                           (session_id,)).fetchone()
    data = np.array([[np.nan if v is None else v for v in r] for r in rows], float).reshape(-1, 6 if fused else 4)
    data = data[np.all(np.isfinite(data[:, :4]), axis=1)]
    if data.shape[0] < 16:
        msg = f"no session {session_id} report: {data.shape[0]} frames with angles are too few (frames not logged?)"
        raise InvalidInputError(msg)
    t, a = data[:, 0] - data[0, 0], data[:, 1:4]
    absolute = data[:, 4:6] if fused and np.isfinite(data[:, 4:6]).any() else None
    reference = None if cal is None else np.asarray(cal, float)
    meta = {"session": session_id, "kind": record["kind"], "source": record["camera"],
            "started_utc": record["started_utc"], "ended_utc": record["ended_utc"], "end_reason": record["end_reason"],
            "frames": int(t.size)}
    # the offline analysis 'walkmon report ID' runs (walkmon.api.Session.analyze), not the paper's whole-walk one
    result = analyze_angles(t, a, abs_angles_deg=absolute, reference_deg=reference, meta=meta)
    tl = store.timeline(session_id)
    if tl is not None and tl["hops"]["t_s"]:
        return result.report_html(timeline=tl, stats=stats, person=stats.person,
                                  timeline_source="Per second, from the hops and alerts the live monitor logged.")
    return result.report_html(person=stats.person)
