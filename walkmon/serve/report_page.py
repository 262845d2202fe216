"""The report of a logged session for the dashboard (``/sessions/{id}/report``), built from the database read
read-only: the same report as ``walkmon report ID`` writes, rendered in memory."""

from __future__ import annotations

from walkmon.errors import InvalidInputError
from walkmon.serve.store import Store

__all__ = ["session_report_html"]


def session_report_html(store: Store, session_id: int) -> str:
    """The report 'walkmon report ID' writes (the same offline analysis, :meth:`walkmon.api.Session.analyze`: an
    accelerometer alone and the raw IMU an analysis stored included), with the hops and alerts a live session
    logged as its timeline."""
    from walkmon.api import load_session  # noqa: PLC0415

    stats, record = store.session(session_id)
    try:
        result = load_session(session_id, store.path).analyze()
    except InvalidInputError as exc:
        msg = f"no session {session_id} report: {exc}"
        raise InvalidInputError(msg) from exc
    tl = store.timeline(session_id) if record["kind"] != "analyze" else None
    if tl is not None and tl["hops"]["t_s"]:
        return result.report_html(timeline=tl, stats=stats, person=stats.person,
                                  timeline_source="Per second, from the hops and alerts the live monitor logged.")
    # an offline analysis: its own per-second timeline (the hops it stored are that timeline, for the history)
    return result.report_html(person=stats.person)
