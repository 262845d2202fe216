"""``walkmon report ID``: the offline analysis report (indicators.json + report.html) of a logged session."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from walkmon.commands.indicators import _existing_file as existing_small_file
from walkmon.commands.sessions import session_id_arg

NAME = "report"
HELP = "write indicators.json, timeline.csv and report.html for a logged session (same report as 'walkmon analyze')"


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
    # indicators.json and timeline.csv as 'walkmon analyze' writes them; the report's first page shows the hops
    # (1 s) and alerts the live monitor logged, read through the dashboard's read-only store (an offline analysis
    # without hops gets the gait analysis's own per-second timeline)
    from walkmon.safe_io import write_text  # noqa: PLC0415
    from walkmon.serve.store import Store  # noqa: PLC0415

    files = result.write(out, angles=False, report=False)
    store = Store(data_dir_of(args))
    stats, record = store.session(args.session_id)
    # an offline analysis' hops are its own per-second timeline, stored for the history: its report draws that
    hops: dict[str, Any] | None = store.timeline(args.session_id) if record["kind"] != "analyze" else None
    if hops is not None and hops["hops"]["t_s"]:
        html = result.report_html(timeline=hops, stats=stats, person=stats.person,
                                  timeline_source="Per second, from the hops and alerts the live monitor logged.")
    else:
        html = result.report_html(person=stats.person)
    files["report.html"] = out / "report.html"
    write_text(files["report.html"], html)
    label = result.indicators.get("classification", {}).get("label", "?")
    timeline = f", {files['timeline.csv']}" if "timeline.csv" in files else ""
    sys.stdout.write(f"session {args.session_id}: {label}; wrote {files['indicators.json']}{timeline} and "
                     f"{files['report.html']}\n")
    return 0
