"""``walkmon batch INPUTS... --out DIR``: every recording analysed as ``walkmon analyze`` does, on Dask.

DIR/<name>/ per recording (angles.csv, indicators.json, report.html, imu.json with an IMU), DIR/summary.parquet
and summary.csv (one row per recording), DIR/bouts.parquet (one row per walking bout), DIR/manifest.json (input
hashes, for --resume). Exit code 0 when every recording was analysed, 1 when some failed (their rows say why),
2 when the batch could not start.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

NAME = "batch"
HELP = "analyse many recordings (videos and/or IMU files) as 'analyze' does, in parallel on Dask -> OUT/summary.*"

_PAIRING = (
    "pairing: a video STEM.EXT takes the first existing --imu-pattern file of its folder ({stem}.imu.csv, "
    "{stem}_imu.csv, {stem}-imu.csv, or imu.csv when it is the folder's only video) and the calibration "
    "--calib, else {stem}.yaml / camera.yaml beside it; an IMU file no video claimed is analysed alone. "
    "Folders are searched recursively for videos and *imu*.csv files."
)


def _workers(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        msg = f"expected a whole number, got {text!r}"
        raise argparse.ArgumentTypeError(msg) from None
    if value < 1:
        msg = f"must be >= 1, got {value}"
        raise argparse.ArgumentTypeError(msg)
    return value


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.epilog = _PAIRING
    p.add_argument("inputs", nargs="+", metavar="INPUT", help="video or IMU files, folders, or globs (quoted)")
    p.add_argument("--out", required=True, help="output folder: OUT/<name>/ per recording, OUT/summary.parquet ...")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=_workers, metavar="N",
                       help="local Dask cluster of N single-threaded worker processes (default: one per core)")
    where.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                       help="an existing Dask scheduler (its workers must see the inputs and OUT at the same paths)")
    p.add_argument("--imu-pattern", action="append", metavar="PATTERN",
                   help="IMU file beside a video, relative to its folder, {stem} = the video's name without "
                   "extension (repeatable, first match wins; 'none': no pairing)")
    p.add_argument("--calib", metavar="CAMERA_YAML", help="calibration for every video (default: per video, see below)")
    p.add_argument("--resume", action="store_true",
                   help="keep recordings whose outputs in OUT are complete for the same inputs (SHA-256) and options")
    p.add_argument("--method", choices=("fast", "paper"), help="rotation method (as analyze; default fast)")
    p.add_argument("--mode", choices=("walkmon", "paper"), help="gait indicator mode (as analyze; default walkmon)")
    p.add_argument("--baseline", metavar="INDICATORS_JSON", help="the wearer's normal walk, for every recording")
    from walkmon.imu.attitude import IMU_FILTERS  # noqa: PLC0415

    p.add_argument("--imu-filter", choices=IMU_FILTERS, help="IMU attitude filter (as analyze, and its default)")
    p.add_argument("--imu-extrinsics", choices=("identity", "estimate"),
                   help="IMU-to-camera rotation for fused recordings (as analyze; default identity)")
    p.add_argument("--imu-calib", metavar="JSON", help="accelerometer calibration for every IMU file (as analyze)")
    p.add_argument("--dashboard", default="127.0.0.1:8787", metavar="ADDRESS",
                   help="local cluster's Dask dashboard address (needs bokeh; 'none' for none; default %(default)s)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar even on a terminal")


def run(args: argparse.Namespace) -> int:
    import os  # noqa: PLC0415

    from walkmon.batching.run import batch  # noqa: PLC0415

    if not getattr(args, "verbose", 0):
        # Dask logs every worker start and stop at INFO, in this process and (through the environment) in the
        # worker processes; the batch prints its own lines. -v shows them.
        os.environ.setdefault("DASK_LOGGING__DISTRIBUTED", "error")

    dashboard = None if str(args.dashboard).lower() == "none" else args.dashboard
    summary = batch(
        args.inputs, args.out, workers=args.workers, scheduler=args.scheduler, imu_patterns=args.imu_pattern,
        calib=args.calib, resume=args.resume, method=args.method, mode=args.mode, baseline=args.baseline,
        imu_filter=args.imu_filter, imu_extrinsics=args.imu_extrinsics, imu_calib=args.imu_calib,
        dashboard_address=dashboard,
        progress=False if args.no_progress else None, log=sys.stdout,
    )
    n_ok = int((summary["status"] == "ok").sum())
    n_failed = len(summary) - n_ok
    n_kept = int(summary["resumed"].sum())
    kept = f" ({n_kept} kept from the earlier run)" if n_kept else ""
    sys.stdout.write(f"{len(summary)} recordings: {n_ok} ok{kept}, {n_failed} failed -> {Path(args.out) / 'summary.parquet'}, "
                     f"summary.csv, bouts.parquet\n")
    return 1 if n_failed else 0
