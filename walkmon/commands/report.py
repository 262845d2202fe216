"""``walkmon report ID``: the offline analysis report (indicators.json + report.html) of a logged session."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from walkmon.errors import InvalidInputError

NAME = "report"
HELP = "write indicators.json and report.html for a logged session (same report as 'walkmon analyze')"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("session_id", type=int, metavar="ID", help="session id (see 'walkmon sessions list')")
    p.add_argument("--out", metavar="DIR", help="output folder (default: ./session-ID)")
    p.add_argument("--baseline", metavar="JSON", help="indicators.json of the same person's normal walk")
    p.add_argument("--data-dir", metavar="DIR", help="session database folder (default ~/.local/share/walkmon)")


def run(args: argparse.Namespace) -> int:
    from walkmon.commands.sessions import data_dir_of  # noqa: PLC0415
    from walkmon.gait.indicators import (  # noqa: PLC0415
        compute_indicators,
        read_indicators,
        write_indicators,
    )
    from walkmon.gait.report import write_report  # noqa: PLC0415
    from walkmon.live.session_log import (  # noqa: PLC0415
        open_database,
        read_session_table,
        session_record,
    )

    conn = open_database(data_dir_of(args), create=False)
    try:
        record = session_record(conn, args.session_id)
        frames = read_session_table(conn, args.session_id, "frames")
        cal = read_session_table(conn, args.session_id, "calibrations")
    finally:
        conn.close()
    t = np.asarray(frames["t_s"], dtype=float)

    def column(name: str) -> np.ndarray:
        return np.asarray([np.nan if v is None else v for v in frames[name]], float)

    a = np.column_stack([column(c) for c in ("pitch", "yaw", "roll")]) if t.size else np.empty((0, 3))
    ok = np.all(np.isfinite(a), axis=1) if t.size else np.zeros(0, bool)
    t, a = t[ok], a[ok]
    # schema 2: the fused gravity-referenced angles (NULL where not fused, or in a camera-only session)
    absolute = np.column_stack([column("pitch_abs"), column("roll_abs")])[ok] if ok.size else None
    if absolute is not None and not np.isfinite(absolute).any():
        absolute = None
    if t.size < 16:
        msg = f"session {args.session_id} has {t.size} frames with angles: too few for a report"
        raise InvalidInputError(msg)
    reference = None
    if cal["t_s"]:
        reference = np.array([cal["pitch"][0], cal["yaw"][0], cal["roll"][0]], dtype=float)
    baseline = read_indicators(args.baseline) if args.baseline else None
    ind = compute_indicators(t - t[0], a, baseline=baseline, reference_deg=reference)
    out = Path(args.out or f"session-{args.session_id}")
    out.mkdir(parents=True, exist_ok=True)
    write_indicators(out / "indicators.json", ind)
    meta = {"session": args.session_id, "kind": record["kind"], "source": record["camera"],
            "started_utc": record["started_utc"], "ended_utc": record["ended_utc"],
            "end_reason": record["end_reason"], "frames": int(t.size)}
    html = write_report(out / "report.html", t - t[0], a, ind, baseline, meta, reference_deg=reference,
                        abs_angles_deg=absolute)
    label = ind.to_dict().get("classification", {}).get("label", "?")
    sys.stdout.write(f"session {args.session_id}: {label}; wrote {out / 'indicators.json'} and {html}\n")
    return 0
