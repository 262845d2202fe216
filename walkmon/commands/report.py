"""``walkmon report ID``: the offline analysis report (indicators.json + report.html) of a logged session."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from walkmon.commands.indicators import _existing_file as existing_small_file
from walkmon.commands.sessions import session_id_arg

NAME = "report"
HELP = "write indicators.json and report.html for a logged session (same report as 'walkmon analyze')"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("session_id", type=session_id_arg, metavar="ID", help="session id (see 'walkmon sessions list')")
    p.add_argument("--out", metavar="DIR", help="output folder (default: ./session-ID)")
    p.add_argument("--baseline", type=existing_small_file, metavar="JSON",
                   help="indicators.json of the same person's normal walk")
    p.add_argument("--data-dir", metavar="DIR", help="session database folder (default ~/.local/share/walkmon)")


def run(args: argparse.Namespace) -> int:
    from walkmon.api import load_session  # noqa: PLC0415
    from walkmon.commands.sessions import data_dir_of  # noqa: PLC0415

    result = load_session(args.session_id, data_dir_of(args)).analyze(baseline=args.baseline)
    out = Path(args.out or f"session-{args.session_id}")
    # the report's first page: the hops (1 s) and alerts the live monitor logged, read through the dashboard's
    # read-only store (an offline analysis without hops gets the report's own per-second fallback)
    from walkmon.gait.report import render_report  # noqa: PLC0415
    from walkmon.safe_io import prepare_dir, write_text  # noqa: PLC0415
    from walkmon.serve.store import Store  # noqa: PLC0415
    from walkmon.tables import write_indicators  # noqa: PLC0415

    prepare_dir(out)

    store = Store(data_dir_of(args))
    stats, _ = store.session(args.session_id)
    timeline: dict[str, Any] | None = store.timeline(args.session_id)
    if timeline is not None and not timeline["hops"]["t_s"]:
        timeline = None
    write_indicators(out / "indicators.json", result.gait)
    html = render_report(result.t_s, result.angles_deg, result.gait, result.baseline, dict(result.meta),
                         settings=result.settings, reference_deg=result.reference_deg,
                         abs_angles_deg=result.abs_angles_deg, timeline=timeline,
                         stats=stats if timeline else None, person=stats.person,
                         timeline_source="Per second, from the hops and alerts the live monitor logged."
                         if timeline else "")
    write_text(out / "report.html", html)
    label = result.indicators.get("classification", {}).get("label", "?")
    sys.stdout.write(f"session {args.session_id}: {label}; wrote {out / 'indicators.json'} and "
                     f"{out / 'report.html'}\n")
    return 0
