"""Benchmark: session analysis on simulated sessions as unkind as life (issue 11, "Simulated unkind sessions").

For each walk type x seed, ``walkmon.simulate.unkind.unkind_script`` draws a session (random standing or mid-walk
start and end, 2-4 bouts, pauses of 1-6 s, 90/180 degree turns sweeping facades at 1-3 m, gait initiation and
termination, one posture change mid-walk, in most sessions once sitting down, bending down to pick something up or
handling the camera (the truth's ``unknown``); 30-100 s). The simulation is cached under a key of the simulator
version and every parameter. ``walkmon analyze`` runs on its IMU (``--imu imu.csv``, IMU only) and on its video
(320x240, 30 fps: rendering at 640x480 would take ~4x longer; the rotation estimate is not what is scored here),
and the result is scored against the true timeline (truth_timeline.csv, truth_steps.csv) with
:mod:`walkmon.simulate.scoring`:

* activity per second right (standing / walking / turning / unknown on a 1 s grid) - target >= 95 %;
* posture change points (true changes during a walk) within 1.5 s of an estimated one - target: all;
* posture segment labels right (true segments >= 4 s) - target >= 95 %;
* cadence per estimated bout against the true steps of its stretch - target within 1 %. The truth uses the
  field's definition, the one walkmon reports and the real data's INDIP reference uses: the mean over strides of
  120 / stride duration, every stride of 0.2-3.0 s counted (Mobilise-D's stride selection: a stride across a
  short stop counts, one across a longer stop does not; until 2026-11-27 any stride across a stop was left out,
  which is not INDIP's rule). The true steps of a bout run from the true step its first detected
  step times (the nearest, within half a step) to the one its last times (a first step detected 20 ms late must
  not drop the true one). The same bouts scored as steps over walking time are printed beside it (a walk whose
  cadence changes mid-bout reads lower that way: a different quantity, not a different accuracy).

THE ADAPTER. What is scored is whatever :func:`estimate` returns. Today (main) ``analyze`` treats the recording
as one walk: :func:`estimate_today_whole_recording` turns its indicators.json (walking_interval_s, one label,
one cadence) into a timeline, one segment and one bout - the baseline figures. When the session analysis of
issue 11 writes ``timeline.csv`` and ``bouts``/``segments`` in indicators.json (the formats issue 11 documents),
:func:`estimate_from_session_outputs` reads them instead; switch or adjust it there after merging.

    python benchmarks/bench_unkind.py                    # IMU and video, 4 walks x seeds 1-5
    python benchmarks/bench_unkind.py --sources imu      # IMU only (seconds)
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import io
import json
import os
import platform
import sys
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from walkmon.commands.cli import main as walkmon_main
from walkmon.rotation import UNMEASURED_MODELS
from walkmon.simulate import SIMULATOR_VERSION
from walkmon.simulate.cache import cached_simulation
from walkmon.simulate.scoring import (
    activity_per_second,
    cadence_errors,
    change_points,
    posture_change_errors,
    segment_label_accuracy,
    segments_labelled_otherwise,
    true_posture_segments,
)
from walkmon.simulate.unkind import UNKIND_WALKS, unkind_script
from walkmon.tables import read_table, read_text_column

RESULTS = Path(__file__).resolve().parent / "results"
TARGETS = {"activity_pct": 95.0, "boundary_s": 1.5, "labels_pct": 95.0, "cadence_pct": 1.0}
MIN_SEGMENT_S = 4.0  # true posture segments shorter than this are not scored for their label


# ----------------------------------------------------------------------------------------------- truth
@dataclass
class Truth:
    t: np.ndarray
    activity: list[str]
    label: list[str]
    steps_t: np.ndarray
    steps_bout: np.ndarray
    bouts: list[dict[str, Any]]
    duration_s: float
    script: str


def read_truth(d: Path) -> Truth:
    with (d / "truth_timeline.csv").open(encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    steps = read_table(d / "truth_steps.csv", ["t", "bout"])
    meta = json.loads((d / "meta.json").read_text(encoding="utf-8"))
    return Truth(
        t=np.array([float(r["t"]) for r in rows]),
        activity=[r["activity"] for r in rows],
        label=[r["label"] for r in rows],
        steps_t=steps["t"],
        steps_bout=steps["bout"].astype(int),
        bouts=meta["bouts"],
        duration_s=float(meta["duration_s"]),
        script=meta["walk"],
    )


# -------------------------------------------------------------------------------------------- estimate
@dataclass
class Estimate:
    """What an analysis says about a session: a 1 s activity timeline, posture segments, walking bouts."""

    kind: str  # which adapter produced it
    t: np.ndarray
    activity: list[str]
    segments: list[tuple[float, float, str]] = field(default_factory=list)
    bouts: list[tuple[float, float, float]] = field(default_factory=list)


def estimate_today_whole_recording(out_dir: Path, duration_s: float) -> Estimate:
    """ADAPTER for today's ``analyze`` (main): one walk between ``walking_interval_s``, standing outside it, one
    label and one cadence for all of it."""
    doc = json.loads((out_dir / "indicators.json").read_text(encoding="utf-8"))
    grid = np.arange(0.0, duration_s + 1e-9, 1.0)
    interval = doc.get("walking_interval_s")
    label = (doc.get("classification") or {}).get("label") or "unclassified"
    cadence = doc.get("cadence_spm")
    if not interval or cadence is None:
        return Estimate("whole recording (main)", grid, ["standing"] * grid.size)
    a, b = float(interval[0]), float(interval[1])
    activity = ["walking" if a <= g <= b else "standing" for g in grid]
    return Estimate("whole recording (main)", grid, activity, [(a, b, label)], [(a, b, float(cadence))])


def estimate_from_session_outputs(out_dir: Path) -> Estimate | None:
    """ADAPTER for the session analysis of issue 11: ``timeline.csv`` (t, activity, label, ...) and indicators.json
    ``bouts`` / ``segments`` (start_s, end_s, label, cadence_spm), at the top level or under ``session``.
    None when the analysis did not write them (main today)."""
    tl = out_dir / "timeline.csv"
    if not tl.is_file():
        return None
    doc = json.loads((out_dir / "indicators.json").read_text(encoding="utf-8"))
    sess = doc.get("session") if isinstance(doc.get("session"), dict) else doc
    if "bouts" not in sess:
        return None
    with tl.open(encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    segments = [(float(s["start_s"]), float(s["end_s"]), str(s.get("label") or "unclassified"))
                for s in sess.get("segments", []) if s.get("start_s") is not None]
    bouts = [(float(b["start_s"]), float(b["end_s"]),
              float(b["cadence_spm"]) if b.get("cadence_spm") is not None else float("nan"))
             for b in sess["bouts"] if b.get("start_s") is not None]
    return Estimate("session analysis (issue 11)", np.array([float(r["t"]) for r in rows]),
                    [r["activity"] for r in rows], segments, bouts)


def estimate(out_dir: Path, duration_s: float) -> Estimate:
    """The estimate scored: the session analysis' outputs where ``analyze`` writes them, else today's."""
    return estimate_from_session_outputs(out_dir) or estimate_today_whole_recording(out_dir, duration_s)


def run_analysis(d: Path, source: str, fresh: bool) -> tuple[Path, float]:
    out = d / f"est-{source}"
    t0 = time.perf_counter()
    if fresh or not (out / "indicators.json").is_file():
        if source == "imu":
            argv = ["analyze", "--imu", str(d / "imu.csv"), "--out", str(out)]
        else:
            argv = ["analyze", str(d / "video.mp4"), "--calib", str(d / "camera.yaml"), "--out", str(out),
                    "--no-progress"]
        with contextlib.redirect_stdout(io.StringIO()):
            rc = walkmon_main(argv)
        if rc != 0:
            msg = f"walkmon {' '.join(argv)} failed with exit code {rc}"
            raise RuntimeError(msg)
    return out, time.perf_counter() - t0


# ----------------------------------------------------------------------------------------------- live
LIVE_TRUTH_S = 4.0  # a hop is scored when the last 4 s were >= 75 % walking, >= 90 % of it in one posture


def live_replay(out_dir: Path, truth: Truth) -> dict[str, int]:
    """The video's angles (``angles.csv`` of ``analyze``) replayed through the live stage sample by sample, as
    ``walkmon live`` runs it; each walking hop counted as ``"TRUE>LIVE"`` (true posture of the last
    ``LIVE_TRUTH_S`` against the hop's label); and each alert the alert stage raises, as ``"alert:TRUE>KIND"``
    (the true posture: the commonest label of the walking over the alert's delay before it, else the activity)."""
    from walkmon.gait.live import LiveIndicatorStage  # noqa: PLC0415
    from walkmon.live.alerts import AlertStage  # noqa: PLC0415

    x = read_table(out_dir / "angles.csv", ["t", "pitch", "yaw", "roll"])
    model = read_text_column(out_dir / "angles.csv", "model")
    held = np.isin(np.asarray(model if model is not None else [""] * len(x["t"])), UNMEASURED_MODELS)
    tt = truth.t
    act = np.asarray(truth.activity, dtype=object)
    lab = np.asarray(truth.label, dtype=object)
    stage = LiveIndicatorStage()
    alerts = AlertStage()
    out: Counter[str] = Counter()
    for t, p, y, r, h in zip(x["t"], x["pitch"], x["yaw"], x["roll"], held, strict=True):
        # a held (or coasted) frame measured nothing: walkmon live gives it to the stage as such
        # (LivePipeline._process_frame)
        hop = stage.push_unmeasured(float(t)) if h else stage.push(float(t), (float(p), float(y), float(r)))
        if hop is None:
            continue
        for e in alerts.push(hop):
            if e.state == "raised":
                w = (tt > t - alerts.settings.delay_s) & (tt <= t)
                walk = w & (act == "walking")
                names, counts = np.unique(lab[walk] if walk.any() else act[w], return_counts=True)
                out[f"alert:{names[int(np.argmax(counts))] if names.size else 'unknown'}>{e.kind}"] += 1
        if not hop.walking:
            continue
        w = (tt > t - LIVE_TRUTH_S) & (tt <= t)
        m = w & (act == "walking")
        if not m.any() or m.sum() < 0.75 * w.sum():
            continue
        names, counts = np.unique(lab[m], return_counts=True)
        if counts.max() < 0.9 * m.sum():
            continue
        out[f"{names[int(np.argmax(counts))]}>{hop.label}"] += 1
    return dict(out)


def _live_lines(rows: list[dict]) -> list[str]:
    from walkmon.live.alerts import CONDITIONS  # noqa: PLC0415

    tot: Counter[str] = Counter()
    for r in rows:
        tot.update(r.get("live") or {})
    if not tot:
        return []
    alert_pairs = {tuple(k[len("alert:"):].split(">")): v for k, v in tot.items() if k.startswith("alert:")}
    pairs = {tuple(k.split(">")): v for k, v in tot.items() if not k.startswith("alert:")}
    n = sum(pairs.values())
    right = sum(v for (a, b), v in pairs.items() if a == b)
    normal = sum(v for (a, _), v in pairs.items() if a == "normal")
    false = sum(v for (a, b), v in pairs.items() if a == "normal" and b not in ("normal", "unclassified"))
    unc = sum(v for (_, b), v in pairs.items() if b == "unclassified")
    return [
        "Live monitor replay (the video's angles through the live stage, sample by sample; a walking hop is scored "
        f"when the last {LIVE_TRUTH_S:g} s were walking in one true posture):",
        "",
        "| hops scored | label right | unclassified | pathology labels on true normal walking |",
        "|---|---|---|---|",
        f"| {n} | {right} ({100.0 * right / n:.0f} %) | {unc} | {false} of {normal} |",
        "",
        "Alerts the live alert stage raised over the same replay, by the true posture of the walking over the alert's "
        "delay before it:",
        "",
        "| true posture | " + " | ".join(CONDITIONS) + " |",
        "|---" * (len(CONDITIONS) + 1) + "|",
        *(f"| {p} | " + " | ".join(str(alert_pairs.get((p, k), 0)) for k in CONDITIONS) + " |"
          for p in sorted({a for a, _ in alert_pairs})),
    ]


# ----------------------------------------------------------------------------------------------- score
def score(truth: Truth, est: Estimate) -> dict[str, Any]:
    act_pct, n_sec = activity_per_second(truth.t, truth.activity, est.t, est.activity)
    true_segs = true_posture_segments(truth.t, truth.label)
    true_cp = change_points(true_segs, max_gap_s=0.5)  # changes during a walk (not across turns or pauses)
    est_cp = change_points(est.segments, max_gap_s=2.0)
    cp_err, cp_false = posture_change_errors(true_cp, est_cp, TARGETS["boundary_s"])
    scored = [s for s in true_segs if s[1] - s[0] >= MIN_SEGMENT_S]
    lab_pct, n_lab = segment_label_accuracy(scored, est.segments)
    lab_wrong = segments_labelled_otherwise(scored, est.segments)
    cad = cadence_errors(est.bouts, truth.steps_t, truth.steps_bout)
    cad_steps = cadence_errors(est.bouts, truth.steps_t, truth.steps_bout, definition="steps")
    true_bouts = [b for b in truth.bouts if b["n_steps"] >= 4]
    found = sum(any(min(b["end_s"], e[1]) - max(b["start_s"], e[0]) > 0 for e in est.bouts) for b in true_bouts)
    return {
        "activity_pct": act_pct,
        "seconds": n_sec,
        "change_points": len(true_cp),
        "change_err_s": [float(v) for v in cp_err],
        "change_false": cp_false,
        "labels_pct": lab_pct,
        "labels_n": n_lab,
        "labels_right": round(lab_pct * n_lab / 100.0) if n_lab else 0,
        "labels_wrong": lab_wrong,
        "cadence": [{"start_s": c.start_s, "end_s": c.end_s, "est_spm": c.est_cadence_spm,
                     "true_spm": c.true_cadence_spm, "err_pct": c.error_pct, "n_steps": c.n_true_steps}
                    for c in cad],
        "cadence_steps_over_time_err_pct": [c.error_pct for c in cad_steps],
        "true_bouts": len(true_bouts),
        "true_bouts_found": int(found),
        "est_bouts": len(est.bouts),
    }


def _fmt(v: float, spec: str = ".1f") -> str:
    return "-" if v is None or not np.isfinite(v) else format(v, spec)


def _row_line(r: dict) -> str:
    errs = r["change_err_s"]
    cp = "-" if not errs else " / ".join("miss" if not np.isfinite(e) else f"{e:.1f}" for e in errs)
    cad = [c["err_pct"] for c in r["cadence"]]
    cad_s = "-" if not cad else f"{max(abs(c) for c in cad):.1f} ({len(cad)})"
    wrong = f" ({r['labels_wrong']} wrong)" if r.get("labels_wrong") else ""
    return (f"| {r['walk']} | {r['seed']} | {r['source']} | {r['duration_s']:.0f} | {_fmt(r['activity_pct'])} | "
            f"{cp} | {r['change_false']} | {r['labels_right']}/{r['labels_n']}{wrong} | {cad_s} | "
            f"{r['true_bouts_found']}/{r['true_bouts']} | {r['est_bouts']} |")


def summarise(rows: list[dict]) -> list[dict[str, Any]]:
    out = []
    for source in sorted({r["source"] for r in rows}):
        rs = [r for r in rows if r["source"] == source]
        act = np.array([r["activity_pct"] for r in rs], dtype=float)
        cp = np.array([e for r in rs for e in r["change_err_s"]], dtype=float)
        lab_n = sum(r["labels_n"] for r in rs)
        lab_right = sum(r["labels_right"] for r in rs)
        cad = np.array([abs(c["err_pct"]) for r in rs for c in r["cadence"]], dtype=float)
        cad_steps = np.array([abs(e) for r in rs for e in r.get("cadence_steps_over_time_err_pct", [])], dtype=float)
        out.append({
            "source": source,
            "sessions": len(rs),
            "estimate": rs[0]["estimate"],
            "activity_pct_mean": float(np.nanmean(act)),
            "activity_pct_min": float(np.nanmin(act)),
            "change_points": int(cp.size),
            "change_within_pct": float(100.0 * np.mean(cp <= TARGETS["boundary_s"])) if cp.size else float("nan"),
            "change_err_max_s": float(cp[np.isfinite(cp)].max()) if np.isfinite(cp).any() else float("nan"),
            "change_missed": int(np.sum(~np.isfinite(cp))),
            "change_false": int(sum(r["change_false"] for r in rs)),
            "labels_pct": 100.0 * lab_right / lab_n if lab_n else float("nan"),
            "labels_n": lab_n,
            "labels_wrong": int(sum(r.get("labels_wrong", 0) for r in rs)),
            "cadence_bouts": int(cad.size),
            "cadence_within_pct": float(100.0 * np.mean(cad <= TARGETS["cadence_pct"])) if cad.size else float("nan"),
            "cadence_err_median_pct": float(np.median(cad)) if cad.size else float("nan"),
            "cadence_err_max_pct": float(cad.max()) if cad.size else float("nan"),
            "cadence_steps_over_time_within_pct": (float(100.0 * np.mean(cad_steps <= TARGETS["cadence_pct"]))
                                                   if cad_steps.size else float("nan")),
            "true_bouts_found": int(sum(r["true_bouts_found"] for r in rs)),
            "true_bouts": int(sum(r["true_bouts"] for r in rs)),
        })
    return out


def _summary_lines(summary: list[dict]) -> list[str]:
    head = ("| source | sessions | activity right % mean (min) | true change points within 1.5 s | "
            "false change points | labels right % (wrong: another label) | "
            "bouts with cadence within 1 % (median / max err %) | "
            "same, as steps over time | true bouts found |")
    lines = [head, "|" + "|".join(["---"] * 9) + "|"]
    for s in summary:
        lines.append(
            f"| {s['source']} | {s['sessions']} | {_fmt(s['activity_pct_mean'])} ({_fmt(s['activity_pct_min'])}) | "
            f"{_fmt(s['change_within_pct'], '.0f')} % of {s['change_points']} "
            f"(max {_fmt(s['change_err_max_s'])} s over those found, {s['change_missed']} not found) | "
            f"{s['change_false']} | {_fmt(s['labels_pct'], '.0f')} % of {s['labels_n']} ({s['labels_wrong']} wrong) | "
            f"{_fmt(s['cadence_within_pct'], '.0f')} % of {s['cadence_bouts']} "
            f"({_fmt(s['cadence_err_median_pct'], '.2f')} / {_fmt(s['cadence_err_max_pct'], '.1f')}) | "
            f"{_fmt(s['cadence_steps_over_time_within_pct'], '.0f')} % | "
            f"{s['true_bouts_found']}/{s['true_bouts']} |"
        )
    return lines


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--first-seed", type=int, default=1)
    ap.add_argument("--walks", nargs="+", default=list(UNKIND_WALKS), choices=UNKIND_WALKS)
    ap.add_argument("--sources", default="imu,video", help="comma-separated: imu, video (default both)")
    ap.add_argument("--video-seeds", type=int, default=None,
                    help="analyse the video of the first N seeds only (default: all; rendering is the slow part)")
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    ap.add_argument("--fps", type=float, default=30.0)
    ap.add_argument("--cache", default=os.environ.get("WALKMON_BENCH_CACHE_UNKIND", "/tmp/walkmon_bench_unkind"))
    ap.add_argument("--reuse-analysis", action="store_true",
                    help="keep earlier analyze outputs in the cache (default: analyse again, the code may have moved)")
    ap.add_argument("--name", default="unkind", help="results file stem (default unkind)")
    ap.add_argument("--results", default=str(RESULTS), help="folder for NAME.md and NAME.json (default: "
                    "benchmarks/results)")
    args = ap.parse_args()
    sources = [s.strip() for s in args.sources.split(",") if s.strip()]
    if not sources or any(s not in ("imu", "video") for s in sources):
        ap.error(f"--sources must list imu and/or video, got {args.sources!r}")
    import cv2  # noqa: PLC0415

    cv2.setNumThreads(1)
    cache = Path(args.cache)
    video_seeds = args.seeds if args.video_seeds is None else args.video_seeds
    rows: list[dict] = []
    t_start = time.perf_counter()
    for walk in args.walks:
        for seed in range(args.first_seed, args.first_seed + args.seeds):
            script = unkind_script(seed, walk)
            seed_sources = [s for s in sources if s != "video" or seed < args.first_seed + video_seeds]
            t0 = time.perf_counter()
            d = cached_simulation(cache, walk=script, seed=seed, width=args.width, height=args.height,
                                  fps=args.fps, video="video" in seed_sources)
            t_sim = time.perf_counter() - t0
            truth = read_truth(d)
            for source in seed_sources:
                out, t_an = run_analysis(d, source, fresh=not args.reuse_analysis)
                est = estimate(out, truth.duration_s)
                r = {"walk": walk, "seed": seed, "source": source, "script": script,
                     "duration_s": truth.duration_s, "estimate": est.kind, "simulate_s": round(t_sim, 1),
                     "analyze_s": round(t_an, 1), **score(truth, est)}
                if source == "video" and (out / "angles.csv").is_file():
                    r["live"] = live_replay(out, truth)
                rows.append(r)
                print(_row_line(r), flush=True)
    summary = summarise(rows)
    live = _live_lines(rows)
    head = ("| walk | seed | source | s | activity right % | change point err s | false cps | labels right | "
            "max cadence err % (bouts) | true bouts found | est bouts |")
    table = [head, "|" + "|".join(["---"] * 11) + "|"] + [_row_line(r) for r in rows]
    video_note = "" if video_seeds >= args.seeds else f" (video of seeds {args.first_seed}-" \
        f"{args.first_seed + video_seeds - 1} only)"
    env = (f"python {platform.python_version()}, {platform.machine()}, {os.cpu_count()} CPUs, simulator version "
           f"{SIMULATOR_VERSION}, video {args.width}x{args.height} at {args.fps:g} fps{video_note}, "
           f"{time.perf_counter() - t_start:.0f} s in all"
           f"{' (simulations and analyses reused from the cache)' if args.reuse_analysis else ''} "
           f"(load average {os.getloadavg()[0]:.1f})")
    estimates = sorted({r["estimate"] for r in rows})
    md = [
        "# Unkind simulated sessions: activity, posture segments, cadence per bout",
        "",
        (f"Estimate scored: {', '.join(estimates)} (see the adapter in benchmarks/bench_unkind.py). "
         f"{len(args.walks)} walk types x seeds {args.first_seed}-{args.first_seed + args.seeds - 1}, "
         "sessions from `walkmon simulate --unkind` (random standing or mid-walk start/end, pauses, 90/180 deg "
         "turns at facades 1-3 m away, gait initiation/termination, one posture change mid-walk, and in most sessions "
         "one sitting, picking up or camera handling: `unknown`)."),
        "",
        (f"Targets (issue 11): activity per second >= {TARGETS['activity_pct']:g} %, posture change points within "
         f"{TARGETS['boundary_s']:g} s, segment labels (true segments >= {MIN_SEGMENT_S:g} s) >= "
         f"{TARGETS['labels_pct']:g} %, cadence per bout within {TARGETS['cadence_pct']:g} % (each estimated bout "
         "against its own true steps, from the one its first detected step times to the one its last times, "
         "by the field's definition: the mean over strides of 120 / stride duration, every stride of 0.2-3.0 s "
         "(Mobilise-D's stride selection: one across a short stop counts), as walkmon reports it and as INDIP "
         "reports the real data; the "
         "column beside it scores the same bouts as steps over walking time, a different quantity where the "
         "cadence changes within a bout)."),
        "",
        *_summary_lines(summary),
        "",
        *(live + [""] if live else []),
        *table,
        "",
        env,
        "",
    ]
    results = Path(args.results)
    results.mkdir(parents=True, exist_ok=True)
    (results / f"{args.name}.md").write_text("\n".join(md), encoding="utf-8")
    (results / f"{args.name}.json").write_text(
        json.dumps({"summary": summary, "rows": rows, "targets": TARGETS, "environment": env}, indent=1,
                   default=lambda v: None) + "\n", encoding="utf-8")
    print()
    print("\n".join(_summary_lines(summary) + live))
    print(env)
    return 0


if __name__ == "__main__":
    sys.exit(main())
