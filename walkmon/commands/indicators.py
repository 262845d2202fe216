"""``walkmon indicators``: gait indicators, classification and report from an angles CSV (t,pitch,yaw,roll)."""

from __future__ import annotations

import argparse
import json
import logging
import math
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from walkmon.consts import ANGLE_COLUMNS
from walkmon.errors import InvalidInputError

_log = logging.getLogger(__name__)

NAME = "indicators"
HELP = "gait indicators, walk classification and report.html from an angles CSV (t,pitch,yaw,roll; truth.csv works)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("angles", help="CSV with columns t,pitch,yaw,roll in degrees; pitch_abs,roll_abs (an angles.csv "
                   "of 'walkmon analyze --imu') add the report's absolute-angle section; other columns are ignored")
    p.add_argument("--out", required=True, help="output folder for indicators.json, timeline.csv and report.html")
    add_gait_arguments(p)


def _existing_file(text: str) -> str:
    """argparse type: a regular file of at most 4 MiB (an indicators.json is a few kB), checked before any long
    computation starts (a device such as /dev/zero or a huge file is refused, not read until memory runs out)."""
    from walkmon.safe_io import MAX_TEXT_INPUT_BYTES  # noqa: PLC0415

    p = Path(text)
    if not p.is_file():
        msg = f"{text}: not a regular file" if p.exists() else f"{text}: no such file"
        raise argparse.ArgumentTypeError(msg)
    if p.stat().st_size > MAX_TEXT_INPUT_BYTES:
        msg = f"{text}: larger than {MAX_TEXT_INPUT_BYTES >> 20} MiB, not an indicators.json"
        raise argparse.ArgumentTypeError(msg)
    return text


def add_gait_arguments(p: argparse.ArgumentParser) -> None:
    """The options ``walkmon analyze`` shares with ``walkmon indicators``."""
    p.add_argument(
        "--baseline",
        type=_existing_file,
        metavar="INDICATORS_JSON",
        help="indicators.json of the same person's normal walk: classify relative to it",
    )
    p.add_argument(
        "--mode",
        choices=("walkmon", "paper"),
        default="walkmon",
        help="walkmon: standing-referenced, drift-corrected (default); paper: exactly the paper's processing",
    )


def gait_outputs(
    out_dir: str | Path,
    t_s: np.ndarray,
    angles_deg: np.ndarray,
    *,
    baseline_path: str | Path | None = None,
    mode: str = "walkmon",
    meta: Mapping[str, Any] | None = None,
    abs_angles_deg: np.ndarray | None = None,
) -> tuple[Path, Path, Any]:
    """Write ``out_dir/indicators.json`` and ``out_dir/report.html``; returns their paths and the Indicators.

    ``abs_angles_deg`` (N, 2): fused absolute pitch and roll at ``t_s`` (NaN where not fused) for the report.
    The analysis is :func:`walkmon.api.analyze_angles`, as ``walkmon analyze`` and the Python API do it.
    """
    from walkmon.api import analyze_angles  # noqa: PLC0415

    result = analyze_angles(t_s, angles_deg, baseline=baseline_path, mode=mode, abs_angles_deg=abs_angles_deg,
                            meta=meta)
    files = result.write(out_dir, angles=False)
    return files["indicators.json"], files["report.html"], result.gait


def _meta_beside(path: Path) -> dict[str, Any]:
    """Session metadata for the report: the input's name, plus a simulator's meta.json next to it if any."""
    meta: dict[str, Any] = {"input": str(path)}
    side = path.parent / "meta.json"
    if side.is_file():
        from walkmon.safe_io import MAX_TEXT_INPUT_BYTES, read_bounded  # noqa: PLC0415

        try:
            doc = json.loads(read_bounded(side, MAX_TEXT_INPUT_BYTES, "meta.json"))
        except (OSError, ValueError, RecursionError, InvalidInputError):
            return meta
        if isinstance(doc, dict):
            for key, value in doc.items():
                if isinstance(value, str | int | float | bool):
                    meta[f"meta.json {key}"] = value
    return meta


def run(args: argparse.Namespace) -> int:
    from walkmon.api import measured_rows  # noqa: PLC0415
    from walkmon.tables import read_table, read_text_column  # noqa: PLC0415

    path = Path(args.angles)
    table = read_table(path, ("t", "pitch", "roll"))
    yaw = table.get("yaw")
    if yaw is not None and yaw.size and not np.isfinite(yaw).any():
        # the angles.csv of 'analyze --imu t,ax,ay,az': gravity's pitch and roll, low-passed, which hold no step
        # rhythm (user review: refused as 'nan is not a finite number', against this command's help)
        msg = (f"{path}: no yaw on any row: the angles of an accelerometer alone (gravity's pitch and roll, "
               "low-passed), which hold no steps; analyse its t,ax,ay,az file with 'walkmon analyze --imu FILE'")
        raise InvalidInputError(msg)
    if yaw is None or not np.isfinite(yaw).all():
        # a yaw missing, not a number, or missing on some rows only: read strictly, to be said as before
        table = read_table(path, ANGLE_COLUMNS)
    t = table["t"]
    angles = np.column_stack([table[c] for c in ANGLE_COLUMNS[1:]])
    # the gravity-referenced angles of 'walkmon analyze --imu' (NaN where not fused), shown as analyze shows them
    absolute = (np.column_stack([table["pitch_abs"], table["roll_abs"]])
                if "pitch_abs" in table and "roll_abs" in table else None)
    model = read_text_column(path, "model")
    # a fused analyze's angles.csv (visual_used): the IMU carried every row; sessions export: fused per row
    keep = (measured_rows(model, table.get("fused"))
            if args.mode == "walkmon" and model is not None and len(model) == len(t) and "visual_used" not in table
            else None)
    if keep is not None:  # the frames the estimator held measure nothing (see measured_rows), as in analyze
        t, angles, absolute = t[keep], angles[keep], None if absolute is None else absolute[keep]
    fused = table.get("fused")
    if (absolute is not None and not any(model or ()) and "visual_used" not in table
            and (fused is None or not np.isfinite(fused).any())):
        # (a sessions export of an IMU analysis has model and fused columns, empty on every row: review)
        # an IMU analysis's angles (its attitude; no camera columns): user review, its cadence read 130.7 where
        # 'analyze --imu' read 81.6 (74-93 by INDIP), silently. Said, and kept with the outputs.
        _log.warning("%s: the angles of an IMU analysis: steps and cadence here come from the pitch, as a camera's "
                     "would; 'walkmon analyze --imu' found them in the accelerometer, the better source", path)
    json_path, html_path, ind = gait_outputs(
        args.out, t, angles, baseline_path=args.baseline, mode=args.mode, meta=_meta_beside(path),
        abs_angles_deg=absolute,
    )
    sys.stdout.write(summary_line(json_path, html_path, ind))
    return 0


def summary_line(json_path: Path, html_path: Path, indicators: Any) -> str:
    """What the commands print: label, cadence, reasons and where the files went."""
    cls = indicators.classification
    extra = ""
    summary = indicators.session.get("summary") if indicators.session else None
    if summary:
        from walkmon.gait.report import vertical_text  # noqa: PLC0415

        upright = indicators.session.get("upright_reference", {})
        extra = (f" in {summary['n_bouts']} bout(s), {summary['n_steps']} steps, {summary['n_turns']} turn(s); "
                 f"upright reference: {upright.get('source', '')}")
        gravity = vertical_text(upright).strip().rstrip(".")
        extra += f"; {gravity[0].lower()}{gravity[1:]}" if gravity else ""
        notes = indicators.session.get("input", {}).get("notes") or []
        extra += "".join(f"\n  note: {n}" for n in notes)
    lines = "\n  ".join(cls.reasons)
    timeline = f"\n-> {Path(json_path).parent / 'timeline.csv'}" if summary is not None else ""
    # no cadence (no walking bout): said, not printed as 'nan' (user review)
    cadence = (f"cadence {indicators.cadence_spm:.1f} steps/min" if math.isfinite(indicators.cadence_spm)
               else "no cadence")
    return (
        f"{cls.label}: {cadence}, walking {indicators.walking_s:.1f} s{extra} "
        f"[{indicators.status.value}]\n  " + lines + f"\n-> {json_path}{timeline}\n-> {html_path}\n"
    )
