"""``walkmon history``: per-day walking, upright time, alerts, cadence and posture across sessions."""

from __future__ import annotations

import argparse
import csv
import datetime as _dt
import io
import sys
from pathlib import Path

NAME = "history"
HELP = "history across sessions: history.html (trend figure, per-day table) and history.csv, in local time"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--since", default="30d", metavar="SPAN",
                   help="sessions started within this span before now: 30d (default), 2w, 12h or a number of days")
    p.add_argument("--person", metavar="NAME", help="only this person's sessions (see [session] person / --person)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder for history.html and history.csv")
    p.add_argument("--data-dir", metavar="DIR", help="session database folder (default ~/.local/share/walkmon)")


def run(args: argparse.Namespace) -> int:
    from walkmon.commands.sessions import data_dir_of  # noqa: PLC0415
    from walkmon.errors import InvalidInputError  # noqa: PLC0415
    from walkmon.serve.store import Store  # noqa: PLC0415
    from walkmon.views.history import daily, parse_since  # noqa: PLC0415

    try:
        span = parse_since(args.since)
    except ValueError as exc:
        raise InvalidInputError(str(exc)) from exc
    from walkmon.commands.progress import Progress  # noqa: PLC0415

    store = Store(data_dir_of(args))
    with Progress(3, "history", "step") as progress:  # shown only when it takes over 0.5 s (a large database)
        stats = store.session_stats(since=span, person=args.person)
        progress.update()
        days = daily(stats)
        progress.update()
        _write(args, store, stats, days, span)
        progress.update()
    who = f" of {args.person}" if args.person else ""
    sys.stdout.write(f"history{who}: {len(stats)} sessions on {len(days)} days; wrote {Path(args.out) / 'history.html'} "
                     f"and {Path(args.out) / 'history.csv'}\n")
    return 0


def _write(args: argparse.Namespace, store: object, stats: list, days: list, span: _dt.timedelta) -> None:
    from walkmon.safe_io import prepare_dir, write_text  # noqa: PLC0415
    from walkmon.views import svg, words  # noqa: PLC0415
    from walkmon.views.history import csv_rows  # noqa: PLC0415
    from walkmon.views.render import render  # noqa: PLC0415

    out = prepare_dir(args.out)  # 0700, never through a symlink: history is health data
    header, rows = csv_rows(days)
    buf = io.StringIO(newline="")
    w = csv.writer(buf)
    w.writerow(header)
    w.writerows(rows)
    write_text(out / "history.csv", buf.getvalue())
    tz = _dt.datetime.now().astimezone().tzname() or "local"
    now = _dt.datetime.now().astimezone()
    period = (f"Sessions started from {(now - span).strftime('%Y-%m-%d %H:%M')} to {now.strftime('%Y-%m-%d %H:%M')}"
              f" ({len(stats)} sessions)")
    kinds = sorted({k for d in days for k in d.alerts_per_hour})
    html = render("history.html", standalone=True, tz=tz, page="History", since=args.since, person=args.person,
                  persons=[], days=days, kinds=kinds, summary=words.history_summary(days), period=period,
                  trend_svg=svg.trend_svg(days))
    write_text(out / "history.html", html)
