"""``walkmon sessions list|export|delete|prune``: the session history in the data directory's database."""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from pathlib import Path
from typing import Any

from walkmon.errors import ConfigError

NAME = "sessions"
HELP = "list logged sessions, export one as CSV or Parquet, delete or prune old ones"

#: Exported file stem per table (frames export as angles.* so 'walkmon indicators' reads them directly).
EXPORT_NAMES = {"frames": "angles", "hops": "hops", "alerts": "alerts", "imu": "imu", "calibrations": "calibrations"}
_RENAME = {"t_s": "t"}
_TEXT_COLUMNS = {"model", "status", "label", "json", "kind", "state", "message", "reason"}


def session_id_arg(text: str) -> int:
    """argparse type of a session id: an integer 1 .. 2^63-1 (SQLite's integer range)."""
    try:
        value = int(text)
    except ValueError:
        msg = f"session id must be a whole number, got {text!r}"
        raise argparse.ArgumentTypeError(msg) from None
    if not 1 <= value <= 2**63 - 1:
        msg = f"session id must be in 1 .. 2^63-1, got {text}"
        raise argparse.ArgumentTypeError(msg)
    return value


_CONTROL = {c: f"\\x{c:02x}" for c in (*range(0x20), 0x7F, *range(0x80, 0xA0))}


def printable(text: object) -> str:
    """``text`` with control characters (terminal escape sequences, newlines) shown as ``\\xNN``: a stored
    string (a source URL, an end reason) never drives the terminal."""
    return str(text).translate(_CONTROL)


def _data_dir_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--data-dir", metavar="DIR", help="session database folder (default ~/.local/share/walkmon)")


def add_arguments(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="sessions_command", metavar="ACTION", parser_class=type(p))
    sub.required = True
    lp = sub.add_parser("list", help="one line per session")
    _data_dir_arg(lp)
    ep = sub.add_parser("export", help="write a session's tables to a folder")
    ep.add_argument("session_id", type=session_id_arg, metavar="ID")
    ep.add_argument("--format", choices=("csv", "parquet"), default="csv")
    ep.add_argument("--out", required=True, metavar="DIR")
    _data_dir_arg(ep)
    dp = sub.add_parser("delete", help="delete sessions and all their rows, then shrink the file")
    dp.add_argument("session_ids", type=session_id_arg, nargs="+", metavar="ID")
    dp.add_argument("--force", action="store_true",
                    help="also delete sessions without an end time (cut off, e.g. by a power loss); by default "
                         "they are refused, as a running 'walkmon live' may still be writing into them")
    _data_dir_arg(dp)
    pp = sub.add_parser("prune", help="delete ended sessions older than DAYS (never a running one)")
    pp.add_argument("--older-than", type=float, required=True, metavar="DAYS",
                    help="delete ended sessions that started more than DAYS ago")
    pp.add_argument("--keep", type=int, metavar="N", help="always keep the newest N ended sessions")
    pp.add_argument("--dry-run", action="store_true", help="print what would be deleted, delete nothing")
    _data_dir_arg(pp)


def data_dir_of(args: argparse.Namespace) -> Path:
    from walkmon.live.session_log import default_data_dir  # noqa: PLC0415

    return Path(args.data_dir).expanduser() if getattr(args, "data_dir", None) else default_data_dir()


def _list(args: argparse.Namespace) -> int:
    from walkmon.live.session_log import list_sessions  # noqa: PLC0415

    sessions = list_sessions(data_dir_of(args))
    out = sys.stdout
    out.write(f"{'id':>4}  {'kind':<7} {'started (UTC)':<23} {'duration':>9} {'frames':>7} {'dropped':>7} "
              f"{'hops':>5} {'alerts':>6}  {'end':<24} source\n")
    for s in sessions:
        end = printable(s.end_reason) if s.ended_utc else "(running or cut off)"
        out.write(f"{s.id:>4}  {printable(s.kind):<7} {printable(s.started_utc)[:23]:<23} {s.duration_s:>8.1f}s "
                  f"{s.n_frames:>7} {s.n_dropped:>7} {s.n_hops:>5} {s.n_alerts:>6}  {end[:24]:<24} "
                  f"{printable(s.camera)}\n")
    if not sessions:
        out.write("(no sessions yet)\n")
    return 0


def _clean(col: str, values: list[Any]) -> list[Any]:
    if col in _TEXT_COLUMNS:
        return ["" if v is None else str(v) for v in values]
    return [math.nan if v is None else v for v in values]


def export_session(data_dir: Path, session_id: int, out_dir: Path, fmt: str = "csv") -> list[Path]:
    """Write every table of one session (+ session.json) to ``out_dir``; the written paths."""
    from walkmon.live.session_log import (  # noqa: PLC0415
        hop_activity,
        open_database,
        read_session_table,
        session_record,
    )

    if fmt == "parquet":
        try:
            import pyarrow as pa  # noqa: PLC0415
            import pyarrow.parquet as pq  # noqa: PLC0415
        except ImportError as exc:
            msg = "parquet export needs pyarrow (pip install 'walkmon[parquet]'), or use --format csv"
            raise ConfigError(msg) from exc
    from walkmon.safe_io import atomic_write, prepare_dir, write_text  # noqa: PLC0415

    conn = open_database(data_dir, read_only=True)
    try:
        record = session_record(conn, session_id)
        tables = {name: read_session_table(conn, session_id, name) for name in EXPORT_NAMES}
    finally:
        conn.close()
    prepare_dir(out_dir)
    written = []
    for name, cols in tables.items():
        data = {_RENAME.get(c, c): _clean(c, v) for c, v in cols.items()}
        if name == "hops":  # the hop's activity (standing/walking/turning/unknown) lives only in its JSON
            act = [hop_activity(v) for v in data.pop("json", [])]
            keys = list(data)
            at = keys.index("walking") + 1 if "walking" in keys else len(keys)
            data = dict([*list(data.items())[:at], ("activity", act), *list(data.items())[at:]])
        if name == "imu" and cols.get("t_s") and all(v is None for c in ("gx", "gy", "gz") for v in cols.get(c, [])):
            # an accelerometer alone: its samples as 't,ax,ay,az', which 'walkmon analyze --imu' reads (review: with
            # gx,gy,gz empty, every row was refused as non-finite)
            for c in ("gx", "gy", "gz"):
                data.pop(c, None)
        path = out_dir / f"{EXPORT_NAMES[name]}.{fmt}"
        if fmt == "csv":
            with atomic_write(path, "w", newline="", encoding="utf-8") as fh:  # temp + rename, never via a link
                w = csv.writer(fh)
                w.writerow(list(data))
                w.writerows(zip(*data.values(), strict=True))
        else:
            with atomic_write(path, "wb") as fh:
                pq.write_table(pa.table(data), fh)
        written.append(path)
    meta = out_dir / "session.json"
    write_text(meta, json.dumps(record, indent=2, sort_keys=True, default=str) + "\n")
    written.append(meta)
    return written


def _export(args: argparse.Namespace) -> int:
    written = export_session(data_dir_of(args), args.session_id, Path(args.out), args.format)
    sys.stdout.write(f"session {args.session_id}: wrote {', '.join(p.name for p in written)} to "
                     f"{printable(args.out)}\n")
    return 0


def _describe(sessions: dict[int, Any], ids: list[int]) -> str:
    return "\n".join(
        f"  {i:>4}  {printable(sessions[i].kind):<7} started {printable(sessions[i].started_utc)[:19]}  "
        f"{sessions[i].n_frames} frames  {printable(sessions[i].camera)}" for i in ids)


def _delete(args: argparse.Namespace) -> int:
    from walkmon.live.session_log import delete_sessions, list_sessions  # noqa: PLC0415

    data_dir = data_dir_of(args)
    before = {s.id: s for s in list_sessions(data_dir)}
    deleted = delete_sessions(data_dir, args.session_ids, force=args.force)
    sys.stdout.write(f"deleted {len(deleted)} session(s):\n{_describe(before, deleted)}\n")
    return 0


def _prune(args: argparse.Namespace) -> int:
    from walkmon.live.session_log import list_sessions, prune_sessions  # noqa: PLC0415

    data_dir = data_dir_of(args)  # prune_sessions checks --older-than and --keep (one-line errors)
    before = {s.id: s for s in list_sessions(data_dir)}
    ids = prune_sessions(data_dir, args.older_than, keep=args.keep, dry_run=args.dry_run)
    verb = "would delete" if args.dry_run else "deleted"
    if not ids:
        sys.stdout.write(f"{verb} no session (no ended session started more than {args.older_than:g} days ago"
                         f"{'' if args.keep is None else f' beyond the newest {args.keep}'})\n")
    else:
        sys.stdout.write(f"{verb} {len(ids)} session(s):\n{_describe(before, ids)}\n")
    return 0


def run(args: argparse.Namespace) -> int:
    actions = {"export": _export, "delete": _delete, "prune": _prune, "list": _list}
    return actions[args.sessions_command](args)
