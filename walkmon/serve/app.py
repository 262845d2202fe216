"""The dashboard's Starlette app: pages and JSON endpoints over the session database (read-only).

Pages: ``/`` (live), ``/sessions``, ``/sessions/{id}``, ``/sessions/{id}/report``, ``/history``
(``?since=30d&person=NAME``), ``/history.csv``. JSON: ``/api/live``, ``/api/sessions``, ``/api/sessions/{id}``,
``/api/sessions/{id}/timeline``, ``/api/history``.

Access: with a token every request needs it: ``Authorization: Bearer TOKEN``, the ``walkmon_token`` cookie, or
``?token=TOKEN`` once (a page opened that way sets the cookie, HttpOnly and SameSite=Strict); otherwise 401.
Requests whose ``Host`` is not the address the server is bound to (or a loopback name when bound to loopback)
are refused (DNS-rebinding: a web page elsewhere cannot read the dashboard through the wearer's browser). A
Content-Security-Policy allows only this origin: nothing on a page loads from or talks to another host.
"""

from __future__ import annotations

import datetime as _dt
import hmac
import logging
import math
import time
from importlib import resources
from typing import Any
from urllib.parse import parse_qs

from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import HTMLResponse, JSONResponse, PlainTextResponse, Response
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from walkmon.errors import InvalidInputError
from walkmon.live.config import is_loopback
from walkmon.live.session_log import MAX_SESSION_ID
from walkmon.serve.store import Store
from walkmon.views import svg, words
from walkmon.views.history import SessionStats, csv_rows, daily, parse_since
from walkmon.views.render import render

__all__ = ["create_app", "is_loopback"]

_log = logging.getLogger(__name__)

COOKIE = "walkmon_token"
CSP = ("default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' data:; "
       "connect-src 'self'; form-action 'self'; frame-ancestors 'none'; base-uri 'none'")
_LOOPBACK_NAMES = {"localhost", "127.0.0.1", "::1", "[::1]"}


def _host_only(header: str) -> str:
    if header.startswith("["):
        return header[: header.find("]") + 1] if "]" in header else header
    return header.rsplit(":", 1)[0] if header.count(":") == 1 else header


class _Guard:
    """ASGI middleware: the Host check, the token check and the security headers."""

    def __init__(self, app: ASGIApp, token: str, bound_host: str) -> None:
        self.app, self.token = app, token
        # on loopback: the loopback names and the address bound to (user review: bound to 127.0.0.2, every request,
        # the printed URL's included, was refused as an unexpected Host)
        bound = bound_host.strip().strip("[]").lower()
        names = {*_LOOPBACK_NAMES, bound, f"[{bound}]"}  # an IPv6 address comes bracketed in a Host header
        self.allowed_hosts = names if is_loopback(bound_host) else None

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope["headers"]}
        host = _host_only(headers.get("host", "")).lower()
        if self.allowed_hosts is not None and host not in self.allowed_hosts:
            await PlainTextResponse("walkmon: unexpected Host header", 400)(scope, receive, send)
            return
        set_cookie = False
        if self.token:
            given = ""
            auth = headers.get("authorization", "")
            if auth.lower().startswith("bearer "):
                given = auth[7:].strip()
            if not given:
                for part in headers.get("cookie", "").split(";"):
                    name, _, value = part.strip().partition("=")
                    if name == COOKIE:
                        given = value
            if not given:
                query = parse_qs(scope.get("query_string", b"").decode("latin-1"))
                given = (query.get("token") or [""])[0]
                set_cookie = bool(given)
            if not hmac.compare_digest(given.encode(), self.token.encode()):
                await PlainTextResponse("walkmon: a token is needed (Authorization: Bearer TOKEN, or ?token=TOKEN)",
                                        401, headers={"WWW-Authenticate": "Bearer"})(scope, receive, send)
                return

        async def send_with_headers(message: Message) -> None:
            if message["type"] == "http.response.start":
                extra = [(b"content-security-policy", CSP.encode()), (b"x-content-type-options", b"nosniff"),
                         (b"referrer-policy", b"no-referrer"), (b"cache-control", b"no-store")]
                if set_cookie:
                    extra.append((b"set-cookie", f"{COOKIE}={self.token}; HttpOnly; SameSite=Strict; Path=/".encode()))
                message["headers"] = list(message.get("headers", [])) + extra
            await send(message)

        await self.app(scope, receive, send_with_headers)


def _tz_name() -> str:
    return _dt.datetime.now().astimezone().tzname() or "local"


def _page(template: str, status: int = 200, **context: Any) -> HTMLResponse:
    return HTMLResponse(render(template, tz=_tz_name(), **context), status_code=status)


def _api(request: Request) -> bool:
    return request.url.path.startswith("/api/")


def _error(request: Request, status: int, message: str) -> Response:
    if _api(request):
        return JSONResponse({"error": message}, status_code=status)
    title = {400: "Bad request", 404: "Not found", 503: "No data yet"}.get(status, "Error")
    return _page("error.html", status, page="", code=status, title=title, message=message)


def create_app(data_dir: Any, *, token: str = "", bound_host: str = "127.0.0.1") -> Starlette:
    """The dashboard over the session database of ``data_dir``."""
    store = Store(data_dir)

    def session_id(request: Request) -> int:
        value = int(request.path_params["session_id"])
        if not 1 <= value <= MAX_SESSION_ID:  # beyond SQLite's integers: no such session (a query there raised: 500)
            msg = f"no session {value} in the database"
            raise InvalidInputError(msg)
        return value

    def period(request: Request) -> tuple[str, _dt.timedelta, str | None]:
        since = request.query_params.get("since") or "30d"
        try:
            span = parse_since(since)
        except ValueError as exc:
            raise _BadRequest(str(exc)) from exc
        person = request.query_params.get("person") or None
        return since, span, person

    # -- JSON -------------------------------------------------------------------------------------------
    def api_live(request: Request) -> Response:
        return JSONResponse(store.live())

    def api_sessions(request: Request) -> Response:
        person = request.query_params.get("person") or None
        return JSONResponse([s.to_dict() for s in store.session_stats(person=person)][::-1])

    def api_session(request: Request) -> Response:
        stats, record = store.session(session_id(request))
        return JSONResponse({**stats.to_dict(), "record": record})

    def api_timeline(request: Request) -> Response:
        return JSONResponse(store.timeline(session_id(request)))

    def api_history(request: Request) -> Response:
        since, span, person = period(request)
        days = daily(store.session_stats(since=span, person=person))
        return JSONResponse({"since": since, "person": person, "timezone": _tz_name(),
                             "days": [d.to_dict() for d in days]})

    # -- pages ------------------------------------------------------------------------------------------
    def live_page(request: Request) -> Response:
        return _page("live.html", page="Live")

    def sessions_page(request: Request) -> Response:
        person = request.query_params.get("person") or None
        sessions = store.session_stats(person=person)[::-1]
        return _page("sessions.html", page="Sessions", sessions=sessions, person=person, persons=store.persons())

    def session_page(request: Request) -> Response:
        sid = session_id(request)
        stats, _record = store.session(sid)
        tl = store.timeline(sid)
        baseline, what = _baseline(store, stats)
        legend = svg.legend(tl)
        return _page("session.html", page="Sessions", s=stats, summary=words.session_summary(stats, baseline, what),
                     timeline_svg=svg.timeline_svg(tl, title=f"Session {sid}: posture per second"), legend=legend,
                     postures=words.posture_times(tl), alerts=tl["alerts"])

    def report_page(request: Request) -> Response:
        from walkmon.serve.report_page import session_report_html  # noqa: PLC0415

        return HTMLResponse(session_report_html(store, session_id(request)))

    def history_page(request: Request) -> Response:
        since, span, person = period(request)
        t0 = time.perf_counter()
        stats = store.session_stats(since=span, person=person)
        days = daily(stats)
        kinds = sorted({k for d in days for k in d.alerts_per_hour})
        html = render("history.html", tz=_tz_name(), page="History", since=since, person=person,
                      persons=store.persons(), days=days, kinds=kinds, summary=words.history_summary(days),
                      period=f"Sessions started in the last {since}", trend_svg=svg.trend_svg(days))
        _log.debug("history page: %d sessions, %d days in %.3f s", len(stats), len(days), time.perf_counter() - t0)
        return HTMLResponse(html)

    def history_csv(request: Request) -> Response:
        _since, span, person = period(request)
        header, rows = csv_rows(daily(store.session_stats(since=span, person=person)))
        lines = [",".join(header)] + [",".join(str(v) for v in r) for r in rows]
        return PlainTextResponse("\n".join(lines) + "\n", media_type="text/csv",
                                 headers={"Content-Disposition": "attachment; filename=history.csv"})

    async def on_invalid(request: Request, exc: Exception) -> Response:
        message = str(exc)
        status = 404 if message.startswith("no session") else 503
        return _error(request, status, message)

    async def on_bad(request: Request, exc: Exception) -> Response:
        return _error(request, 400, str(exc))

    def favicon(request: Request) -> Response:
        return Response(status_code=308, headers={"Location": "/static/favicon.svg"})

    static_dir = str(resources.files("walkmon.views").joinpath("static"))
    routes = [
        Route("/", live_page),
        Route("/sessions", sessions_page),
        Route("/sessions/{session_id:int}", session_page),
        Route("/sessions/{session_id:int}/report", report_page),
        Route("/history", history_page),
        Route("/history.csv", history_csv),
        Route("/favicon.ico", favicon),
        Route("/api/live", api_live),
        Route("/api/sessions", api_sessions),
        Route("/api/sessions/{session_id:int}", api_session),
        Route("/api/sessions/{session_id:int}/timeline", api_timeline),
        Route("/api/history", api_history),
        Mount("/static", StaticFiles(directory=static_dir), name="static"),
    ]
    app = Starlette(routes=routes, exception_handlers={InvalidInputError: on_invalid, _BadRequest: on_bad})
    app.add_middleware(_Guard, token=token, bound_host=bound_host)
    app.state.store = store
    return app


class _BadRequest(Exception):
    """A query parameter that cannot be used (400)."""


def _baseline(store: Store, s: SessionStats) -> tuple[Any, str]:
    """The same person's earlier sessions of the 30 days before this one, as one aggregate (or None)."""
    try:
        start = _dt.datetime.fromisoformat(s.started_utc)
    except ValueError:
        return None, ""
    if start.tzinfo is None:
        start = start.replace(tzinfo=_dt.UTC)
    # the same person only: a session without a person among those without one (the store's None is no filter:
    # user review, a session of no one was compared with alice's)
    earlier = [x for x in store.session_stats(since=_dt.timedelta(days=30), person=s.person or None,
                                              now_utc=start + _dt.timedelta(seconds=0))
               if x.id != s.id and x.started_utc < s.started_utc and x.walking_s > 0
               and (x.person or "") == (s.person or "")]
    if not earlier:
        return None, ""
    days = daily(earlier)
    walking = sum(d.walking_min for d in days)

    class _Agg:
        upright_pct = _wmean([(d.upright_pct, d.walking_min) for d in days])
        cadence_spm = _wmean([(d.cadence_spm, d.walking_min) for d in days])
        pitch_deg = _wmean([(d.pitch_deg, d.walking_min) for d in days])

    who = f"{s.person}'s" if s.person else "the"
    amount = f"{walking:.1f}" if walking < 10 else f"{walking:.0f}"  # 0.3 min read '0 min walking' (review)
    return _Agg(), f"{who} {len(earlier)} earlier session{'s' if len(earlier) != 1 else ''} of the 30 days before " \
                   f"({amount} min walking)"


def _wmean(pairs: list[tuple[float, float]]) -> float:
    ok = [(v, w) for v, w in pairs if math.isfinite(v) and w > 0]
    return sum(v * w for v, w in ok) / sum(w for _, w in ok) if ok else math.nan
