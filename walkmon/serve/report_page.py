"""The report of a logged session for the dashboard (``/sessions/{id}/report``), built from the database read
read-only: the same report as ``walkmon report ID`` writes, rendered in memory."""

from __future__ import annotations

import numpy as np

from walkmon.errors import InvalidInputError
from walkmon.serve.store import Store

__all__ = ["session_report_html"]


def session_report_html(store: Store, session_id: int) -> str:
    from walkmon.gait.indicators import compute_indicators  # noqa: PLC0415
    from walkmon.gait.report import render_report  # noqa: PLC0415

    stats, record = store.session(session_id)
    with store.connect() as conn:
        rows = conn.execute("SELECT t_s, pitch, yaw, roll FROM frames WHERE session_id = ? ORDER BY t_s, rowid",
                            (session_id,)).fetchall()
        cal = conn.execute("SELECT pitch, yaw, roll FROM calibrations WHERE session_id = ? ORDER BY t_s LIMIT 1",
                           (session_id,)).fetchone()
    data = np.array([[np.nan if v is None else v for v in r] for r in rows], float).reshape(-1, 4)
    data = data[np.all(np.isfinite(data), axis=1)]
    if data.shape[0] < 16:
        msg = f"no session {session_id} report: {data.shape[0]} frames with angles are too few (frames not logged?)"
        raise InvalidInputError(msg)
    t, a = data[:, 0] - data[0, 0], data[:, 1:]
    reference = None if cal is None else np.asarray(cal, float)
    ind = compute_indicators(t, a, reference_deg=reference)
    tl = store.timeline(session_id)
    meta = {"session": session_id, "kind": record["kind"], "source": record["camera"],
            "started_utc": record["started_utc"], "ended_utc": record["ended_utc"], "end_reason": record["end_reason"]}
    return render_report(t, a, ind, meta=meta, reference_deg=reference, timeline=tl, stats=stats)
