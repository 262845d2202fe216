"""The batch's tables: one summary row per recording, one bout row per walking bout, and the manifest.

``OUT/summary.parquet`` and ``OUT/summary.csv`` (same rows, sorted by name), columns :data:`SUMMARY_COLUMNS`:

* identity: ``name`` (the ``OUT/<name>/`` folder), ``status`` (``ok`` or ``failed``), ``error`` (one line,
  empty when ok), ``kind`` (``video``, ``video+imu``, ``imu``), ``video``, ``imu``, ``calib`` (absolute paths,
  empty when none);
* the walk, from ``OUT/<name>/indicators.json``: ``duration_s``, ``walking_s``, ``cadence_spm``,
  ``indicator_status`` (ok, too_short, no_gait), ``label`` and ``reasons`` ("; "-joined), ``gait_mode``,
  per axis ``{pitch,yaw,roll}_{lmax_mean,lmin_mean,swing_mean,inclination_mean,swing_std,inclination_std,
  frequency_hz,n_cycles}`` (degrees, Hz) and the step asymmetry ``asym_*`` columns;
* time per posture: ``time_{normal,left_shoulder_down,right_foot_drag,bend,unclassified}_s``, the walking time
  under each label: indicators.json's ``summary.posture_time_s`` when it has one (schema 2: per posture
  segment), else the sum of the durations of the bouts with each label, else the recording's whole
  ``walking_s`` under its one label;
* ``activity_{standing,walking,turning,unknown}_s`` (indicators.json ``activity_s``; NaN before schema 2);
* ``n_bouts`` (the rows this recording has in bouts.parquet), ``n_steps`` and ``n_turns`` (indicators.json
  ``summary``; NaN before schema 2);
* the run: ``method`` (rotation method), ``analysis_s`` (wall time of the task), ``cpu_s`` (CPU time of the
  worker process over the task: what a recording costs, for sizing a cluster), ``worker`` (Dask worker
  address), ``attempts`` (times the task was started: more than 1 when a worker died under it), ``resumed``
  (True: outputs kept from an earlier run by ``--resume``), ``finished_utc``;
* versions: ``walkmon_version``, ``indicators_schema``, ``python_version``, ``numpy_version``,
  ``opencv_version``.

Missing numbers are NaN (empty in the CSV). ``OUT/bouts.parquet`` columns :data:`BOUT_COLUMNS`: ``name``,
``bout`` (0-based within the recording), ``start_s``, ``end_s``, ``duration_s``, ``n_steps``, ``cadence_spm``,
``label`` (the bout's own label when indicators.json gives one, else empty), then any other number or text a
bout entry of indicators.json carries, nested keys joined with ``_`` (``axes_pitch_swing_mean``; a list of
texts such as ``reasons`` joined with "; "). No bouts anywhere: an empty table with
those columns.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from walkmon.consts import AXES
from walkmon.gait.posture import LABELS

__all__ = [
    "AXIS_FIELDS",
    "BOUT_COLUMNS",
    "MANIFEST_NAME",
    "SUMMARY_COLUMNS",
    "bouts_frame",
    "bouts_from_indicators",
    "indicator_columns",
    "read_manifest",
    "summary_frame",
    "write_manifest",
    "write_tables",
]

AXIS_FIELDS = ("lmax_mean", "lmin_mean", "swing_mean", "inclination_mean", "swing_std", "inclination_std",
               "frequency_hz", "n_cycles")
ASYMMETRY_FIELDS = ("n_steps", "step_swing_ratio", "swing_asymmetry_pct", "step_time_ratio",
                    "step_time_asymmetry_pct")
POSTURE_COLUMNS = tuple(f"time_{label}_s" for label in LABELS)
#: indicators.json ``activity_s`` keys (schema 2), as ``activity_<key>_s`` columns.
ACTIVITIES = ("standing", "walking", "turning", "unknown")

SUMMARY_COLUMNS: tuple[str, ...] = (
    "name", "status", "error", "kind", "video", "imu", "calib",
    "duration_s", "walking_s", "cadence_spm", "indicator_status", "label", "reasons", "gait_mode",
    *(f"{a}_{f}" for a in AXES for f in AXIS_FIELDS),
    *(f"asym_{f}" for f in ASYMMETRY_FIELDS),
    *POSTURE_COLUMNS,
    *(f"activity_{k}_s" for k in ACTIVITIES),
    "n_bouts", "n_steps", "n_turns",
    "method", "analysis_s", "cpu_s", "worker", "attempts", "resumed", "finished_utc",
    "walkmon_version", "indicators_schema", "python_version", "numpy_version", "opencv_version",
)
_TEXT = {"name", "status", "error", "kind", "video", "imu", "calib", "indicator_status", "label", "reasons",
         "gait_mode", "method", "worker", "finished_utc", "walkmon_version", "indicators_schema", "python_version",
         "numpy_version", "opencv_version"}  # indicators_schema read as a number was NaN on every row (review)
_INT = {"attempts", "n_bouts"}  # n_steps, n_turns: float, NaN where indicators.json does not say
_BOOL = {"resumed"}

BOUT_COLUMNS: tuple[str, ...] = ("name", "bout", "start_s", "end_s", "duration_s", "n_steps", "cadence_spm", "label")

MANIFEST_NAME = "manifest.json"
MANIFEST_FORMAT = "walkmon-batch-manifest"
MANIFEST_VERSION = 1


def _num(v: Any) -> float:
    """A JSON number (or null) as float (NaN for null or anything not a number)."""
    if isinstance(v, bool) or not isinstance(v, int | float):
        return math.nan
    return float(v)


def indicator_columns(doc: Mapping[str, Any]) -> dict[str, Any]:
    """The summary columns that come from one indicators.json document (see the module docstring)."""
    row: dict[str, Any] = {
        "duration_s": _num(doc.get("duration_s")),
        "walking_s": _num(doc.get("walking_s")),
        "cadence_spm": _num(doc.get("cadence_spm")),
        "indicator_status": str(doc.get("status", "")),
        "gait_mode": str(doc.get("mode", "")),
        "indicators_schema": str(doc.get("schema_version", "")),
    }
    cls = doc.get("classification") or {}
    label = str(cls.get("label", "unclassified")) if isinstance(cls, Mapping) else "unclassified"
    reasons = cls.get("reasons", []) if isinstance(cls, Mapping) else []
    row["label"] = label
    row["reasons"] = "; ".join(str(r) for r in reasons) if isinstance(reasons, list) else str(reasons)
    axes = doc.get("axes") or {}
    for a in AXES:
        ax = axes.get(a) or {} if isinstance(axes, Mapping) else {}
        for f in AXIS_FIELDS:
            row[f"{a}_{f}"] = _num(ax.get(f)) if isinstance(ax, Mapping) else math.nan
    asym = doc.get("asymmetry") or {}
    for f in ASYMMETRY_FIELDS:
        row[f"asym_{f}"] = _num(asym.get(f)) if isinstance(asym, Mapping) else math.nan
    bouts = bouts_from_indicators("", doc)
    row["n_bouts"] = len(bouts)
    given_summary = doc.get("summary")
    summary: Mapping[str, Any] = given_summary if isinstance(given_summary, Mapping) else {}
    row["n_steps"] = _num(summary.get("n_steps"))
    row["n_turns"] = _num(summary.get("n_turns"))
    given_activity = doc.get("activity_s")
    activity: Mapping[str, Any] = given_activity if isinstance(given_activity, Mapping) else {}
    for k in ACTIVITIES:
        row[f"activity_{k}_s"] = _num(activity.get(k))
    row.update(_posture_times(doc, summary, bouts, label, row["walking_s"]))
    return row


def _posture_times(doc: Mapping[str, Any], summary: Mapping[str, Any], bouts: list[dict[str, Any]], label: str,
                   walking_s: float) -> dict[str, float]:
    """Walking time per label: indicators.json's ``summary.posture_time_s`` (schema 2: per posture segment),
    else the labelled bouts' durations, else the whole walking time under the recording's one label."""
    times = dict.fromkeys(POSTURE_COLUMNS, 0.0)
    given = summary.get("posture_time_s")
    labelled = [b for b in bouts if b.get("label")]
    if isinstance(given, Mapping):
        for lab, sec in given.items():
            key = f"time_{lab}_s"
            if key in times and math.isfinite(_num(sec)):
                times[key] += _num(sec)
    elif labelled:
        for b in labelled:
            key = f"time_{b['label']}_s"
            if key in times and math.isfinite(b["duration_s"]):
                times[key] += b["duration_s"]
    else:
        key = f"time_{label}_s"
        if key in times and math.isfinite(walking_s):
            times[key] = walking_s
    return times


def _flatten(prefix: str, value: Any, out: dict[str, Any]) -> None:
    if isinstance(value, Mapping):
        for k, v in value.items():
            _flatten(f"{prefix}_{k}" if prefix else str(k), v, out)
    elif isinstance(value, bool):
        out[prefix] = value
    elif isinstance(value, int | float):
        out[prefix] = _num(value)
    elif isinstance(value, str):
        out[prefix] = value
    elif isinstance(value, list) and value and all(isinstance(v, str) for v in value):
        out[prefix] = "; ".join(value)  # e.g. a bout's reasons
    # null (a column other bouts may fill: NaN there) and lists of numbers (step times) stay in indicators.json


def bouts_from_indicators(name: str, doc: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The bouts.parquet rows of one recording: indicators.json's ``bouts`` list (absent: no rows)."""
    bouts = doc.get("bouts")
    if not isinstance(bouts, list):
        return []
    rows = []
    for i, b in enumerate(bouts):
        if not isinstance(b, Mapping):
            continue
        flat: dict[str, Any] = {}
        _flatten("", b, flat)
        start, end = _num(b.get("start_s")), _num(b.get("end_s"))
        duration = _num(b.get("duration_s"))
        if not math.isfinite(duration):
            duration = end - start
        label = b.get("label")
        if label is None and isinstance(b.get("classification"), Mapping):
            label = b["classification"].get("label")
        row: dict[str, Any] = {
            "name": name, "bout": i, "start_s": start, "end_s": end, "duration_s": duration,
            "n_steps": _num(b.get("n_steps")), "cadence_spm": _num(b.get("cadence_spm")),
            "label": "" if label is None else str(label),
        }
        for k, v in flat.items():
            if k not in row and k != "classification_label":
                row[k] = v
        rows.append(row)
    return rows


def summary_frame(rows: Iterable[Mapping[str, Any]]):  # noqa: ANN201 - pandas is imported lazily
    """The summary DataFrame: :data:`SUMMARY_COLUMNS` in order, one row per recording, sorted by name."""
    import pandas as pd  # noqa: PLC0415

    records = []
    for r in rows:
        rec: dict[str, Any] = {}
        for c in SUMMARY_COLUMNS:
            v = r.get(c)
            if c in _TEXT:
                rec[c] = "" if v is None else str(v)
            elif c in _BOOL:
                rec[c] = bool(v)
            elif c in _INT:
                rec[c] = int(v) if isinstance(v, int | float) and math.isfinite(v) else 0
            else:
                rec[c] = _num(v)
        records.append(rec)
    df = pd.DataFrame.from_records(records, columns=list(SUMMARY_COLUMNS))
    for c in SUMMARY_COLUMNS:
        if c in _TEXT:
            df[c] = df[c].astype(object)
        elif c in _BOOL:
            df[c] = df[c].astype(bool)
        elif c in _INT:
            df[c] = df[c].astype("int64")
        else:
            df[c] = df[c].astype("float64")
    return df.sort_values("name", kind="stable").reset_index(drop=True)


def bouts_frame(rows: Iterable[Mapping[str, Any]]):  # noqa: ANN201
    """The bouts DataFrame: :data:`BOUT_COLUMNS` first, then extra bout fields in first-seen order."""
    import pandas as pd  # noqa: PLC0415

    rows = list(rows)
    extra: list[str] = []
    for r in rows:
        extra += [k for k in r if k not in BOUT_COLUMNS and k not in extra]
    df = pd.DataFrame.from_records(rows, columns=[*BOUT_COLUMNS, *extra])
    df["name"] = df["name"].astype(object)
    df["label"] = df["label"].fillna("").astype(object)
    df["bout"] = df["bout"].astype("int64")
    for c in ("start_s", "end_s", "duration_s", "n_steps", "cadence_spm"):
        df[c] = df[c].astype("float64")
    return df.sort_values(["name", "bout"], kind="stable").reset_index(drop=True)


def write_tables(out_dir: Path, summary, bouts) -> list[Path]:  # noqa: ANN001
    """``summary.parquet``, ``summary.csv`` and ``bouts.parquet`` in ``out_dir`` (each replaced atomically)."""
    paths = [out_dir / "summary.parquet", out_dir / "summary.csv", out_dir / "bouts.parquet"]
    from walkmon.safe_io import atomic_write  # noqa: PLC0415

    with atomic_write(paths[0], "wb") as fh:
        summary.to_parquet(fh, index=False)
    with atomic_write(paths[1], newline="") as fh:
        summary.to_csv(fh, index=False)
    with atomic_write(paths[2], "wb") as fh:
        bouts.to_parquet(fh, index=False)
    return paths


def read_manifest(out_dir: Path) -> dict[str, Any]:
    """``{name: entry}`` of ``out_dir/manifest.json``; empty when there is none or it is unreadable."""
    path = out_dir / MANIFEST_NAME
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    if not isinstance(doc, dict) or doc.get("format") != MANIFEST_FORMAT:
        return {}
    recs = doc.get("recordings")
    return {str(k): v for k, v in recs.items() if isinstance(v, dict)} if isinstance(recs, dict) else {}


def write_manifest(out_dir: Path, entries: Mapping[str, Any]) -> None:
    """Replace ``out_dir/manifest.json`` with ``entries`` (atomically: an interrupted write leaves the old one)."""
    doc = {"format": MANIFEST_FORMAT, "version": MANIFEST_VERSION,
           "recordings": {k: entries[k] for k in sorted(entries)}}
    text = json.dumps(doc, indent=1, allow_nan=False, default=str)
    from walkmon.safe_io import write_text  # noqa: PLC0415

    write_text(out_dir / MANIFEST_NAME, text)
