"""Benchmark: gait indicators from *estimated* angles vs the same computation on the simulator's truth.csv.

For every walk type x seed: simulate a session (video + truth.csv + meta.json, cached under --work), run
``walkmon analyze`` on the video (rotation estimate -> angles.csv -> indicators.json), compute the indicators of
truth.csv the same way, and compare, against issue 4's targets:

* cadence within 1 % of the simulated cadence (meta.json's nominal ``cadence_spm``; also shown: the cadence the
  simulated steps actually had over the analysed span, from the gait model's step phase: the nominal one
  is only the mean of randomly jittered steps);
* swing_mean within 10 % and inclination_mean within 0.5 deg of the truth-derived values, per axis;
* classification right (no baseline, and with another seed's estimated normal walk as the baseline).

Prints the table and writes benchmarks/results/indicators.md and indicators.json.

    python benchmarks/bench_indicators.py --seeds 5 --width 320 --height 240 --work /tmp/walkmon-bench
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from walkmon.commands.cli import main as walkmon_main
from walkmon.consts import ANGLE_COLUMNS
from walkmon.gait.indicators import compute_indicators
from walkmon.simulate import GaitModel
from walkmon.tables import read_table

WALKS = ("normal", "left_shoulder_down", "right_foot_drag", "bend")
AXES = ("pitch", "yaw", "roll")
RESULTS = Path(__file__).resolve().parent / "results"


def _angles(path: Path) -> tuple[np.ndarray, np.ndarray]:
    table = read_table(path, ANGLE_COLUMNS)
    return table["t"], np.column_stack([table[c] for c in ANGLE_COLUMNS[1:]])


def run_one(work: Path, walk: str, seed: int, args: argparse.Namespace) -> dict:
    from walkmon.simulate.cache import cached_simulation  # noqa: PLC0415

    t0 = time.perf_counter()
    # keyed by the simulator version and every parameter: a changed simulator never serves an old clip
    session = cached_simulation(work, walk=walk, seconds=args.seconds, seed=seed, width=args.width,
                                height=args.height)
    t_sim = time.perf_counter() - t0
    est_dir = session / f"est-{args.method}"
    t0 = time.perf_counter()
    if not (est_dir / "angles.csv").is_file() or args.fresh:
        rc = walkmon_main(["analyze", str(session / "video.mp4"), "--calib", str(session / "camera.yaml"),
                           "--method", args.method, "--out", str(est_dir), "--no-progress"])
        if rc != 0:
            msg = f"walkmon analyze failed on {session}"
            raise RuntimeError(msg)
    t_est = time.perf_counter() - t0
    est = compute_indicators(*_angles(est_dir / "angles.csv"))
    truth = compute_indicators(*_angles(session / "truth.csv"))
    meta = json.loads((session / "meta.json").read_text())
    nominal = float(meta["segments"][0]["cadence_spm"])
    model = GaitModel(walk, args.seconds, seed)
    a, b = est.walking_interval_s
    phase = model.step_phase(np.array([a, b]))
    realised = 60.0 * float(phase[1] - phase[0]) / (b - a)
    row = {
        "walk": walk,
        "seed": seed,
        "nominal_cadence_spm": nominal,
        "realised_cadence_spm": realised,
        "est_cadence_spm": est.cadence_spm,
        "truth_cadence_spm": truth.cadence_spm,
        "cadence_err_nominal_pct": 100.0 * (est.cadence_spm / nominal - 1.0),
        "cadence_err_realised_pct": 100.0 * (est.cadence_spm / realised - 1.0),
        "label_est": est.classification.label,
        "label_truth": truth.classification.label,
        "simulate_s": round(t_sim, 1),
        "analyze_s": round(t_est, 1),
        "est_dir": str(est_dir),
    }
    # the session analysis 'walkmon analyze' now runs (issue 11): bouts, posture segments, one classifier
    from walkmon.gait.session import analyze_session  # noqa: PLC0415

    ses = analyze_session(*_angles(est_dir / "angles.csv")).indicators
    sa, sb = ses.walking_interval_s
    if np.isfinite(sa) and sb > sa:
        ph = model.step_phase(np.array([sa, sb]))
        ses_realised = 60.0 * float(ph[1] - ph[0]) / (sb - sa)
    else:
        ses_realised = float("nan")
    row["session_cadence_spm"] = ses.cadence_spm
    row["session_cadence_err_realised_pct"] = 100.0 * (ses.cadence_spm / ses_realised - 1.0)
    row["session_walking_s"] = ses.walking_s
    row["session_label"] = ses.classification.label
    row["session_pitch_incl"] = ses.axes["pitch"].inclination_mean
    row["session_roll_incl"] = ses.axes["roll"].inclination_mean
    for axis in AXES:
        e, t = est.axes[axis], truth.axes[axis]
        row[f"{axis}_swing_est"] = e.swing_mean
        row[f"{axis}_swing_truth"] = t.swing_mean
        row[f"{axis}_swing_err_pct"] = 100.0 * (e.swing_mean / t.swing_mean - 1.0)
        row[f"{axis}_incl_est"] = e.inclination_mean
        row[f"{axis}_incl_truth"] = t.inclination_mean
        row[f"{axis}_incl_err_deg"] = e.inclination_mean - t.inclination_mean
    return row


def _fmt_table(rows: list[dict]) -> list[str]:
    head = ("| walk | seed | cadence est / nominal / realised [spm] | err vs nominal | err vs realised | "
            "swing err % p / y / r | incl err deg p / y / r | pitch incl est / truth | label (est) |")
    lines = [head, "|" + "|".join(["---"] * 9) + "|"]
    for r in rows:
        sw = " / ".join(f"{r[f'{a}_swing_err_pct']:+.1f}" for a in AXES)
        inc = " / ".join(f"{r[f'{a}_incl_err_deg']:+.2f}" for a in AXES)
        lines.append(
            f"| {r['walk']} | {r['seed']} | {r['est_cadence_spm']:.1f} / {r['nominal_cadence_spm']:.1f} / "
            f"{r['realised_cadence_spm']:.1f} | {r['cadence_err_nominal_pct']:+.2f} % | "
            f"{r['cadence_err_realised_pct']:+.2f} % | {sw} | {inc} | "
            f"{r['pitch_incl_est']:.2f} / {r['pitch_incl_truth']:.2f} | {r['label_est']}"
            f"{'' if r['label_est'] == r['walk'] else ' (WRONG)'} |"
        )
    return lines


def _summary(rows: list[dict]) -> tuple[list[str], dict]:
    lines = [
        "| walk | runs | max abs cadence err vs nominal (target 1 %) | same on truth.csv angles | vs realised "
        "| max abs swing err % (target 10) | max abs incl err deg (target 0.5) | classified right (no baseline) "
        "| with baseline |",
        "|" + "|".join(["---"] * 9) + "|",
    ]
    summary = {}
    normals_present = any(r["walk"] == "normal" for r in rows)
    for walk in WALKS:
        rs = [r for r in rows if r["walk"] == walk]
        if not rs:
            continue
        cad_n = max(abs(r["cadence_err_nominal_pct"]) for r in rs)
        cad_r = max(abs(r["cadence_err_realised_pct"]) for r in rs)
        cad_t = max(abs(100.0 * (r["truth_cadence_spm"] / r["nominal_cadence_spm"] - 1.0)) for r in rs)
        sw = max(abs(r[f"{a}_swing_err_pct"]) for r in rs for a in AXES)
        inc = max(abs(r[f"{a}_incl_err_deg"]) for r in rs for a in AXES)
        ok = sum(r["label_est"] == walk for r in rs)
        okb = sum(r.get("label_est_baseline") == walk for r in rs)
        summary[walk] = {"runs": len(rs), "max_cadence_err_nominal_pct": cad_n, "max_cadence_err_realised_pct": cad_r,
                         "max_truth_cadence_err_nominal_pct": cad_t,
                         "max_swing_err_pct": sw, "max_incl_err_deg": inc, "classified_right": ok,
                         "classified_right_with_baseline": okb if normals_present else None}

        def mark(value: float, target: float) -> str:
            return f"{value:.2f} ({'met' if value <= target else 'NOT met'})"

        lines.append(
            f"| {walk} | {len(rs)} | {mark(cad_n, 1.0)} | {cad_t:.2f} | {mark(cad_r, 1.0)} | {mark(sw, 10.0)} | "
            f"{mark(inc, 0.5)} | {ok}/{len(rs)} | {f'{okb}/{len(rs)}' if normals_present else 'n/a'} |"
        )
    lines += [
        "",
        "Session analysis (`walkmon analyze` since issue 11: walking bouts from detected steps, cadence from the",
        "steps, posture segments, the one classifier) on the same estimated angles; cadence vs the cadence the",
        "simulated steps realised over the detected bouts.",
        "",
        "| walk | runs | max abs cadence err vs realised (target 1 %) | walking s (min-max) | classified right "
        "| with baseline |",
        "|---|---|---|---|---|---|",
    ]
    for walk in WALKS:
        rs = [r for r in rows if r["walk"] == walk and "session_label" in r]
        if not rs:
            continue
        cad = max(abs(r["session_cadence_err_realised_pct"]) for r in rs)
        ok = sum(r["session_label"] == walk for r in rs)
        okb = sum(r.get("session_label_baseline") == walk for r in rs)
        ws = [r["session_walking_s"] for r in rs]
        labels = ", ".join(sorted({r["session_label"] for r in rs if r["session_label"] != walk}))
        summary[walk].update({"session_max_cadence_err_realised_pct": cad, "session_classified_right": ok,
                              "session_classified_right_with_baseline": okb if normals_present else None})
        lines.append(f"| {walk} | {len(rs)} | {cad:.2f} ({'met' if cad <= 1.0 else 'NOT met'}) | "
                     f"{min(ws):.1f}-{max(ws):.1f} | {ok}/{len(rs)}{f' (others: {labels})' if labels else ''} | "
                     f"{f'{okb}/{len(rs)}' if normals_present else 'n/a'} |")
    return lines, summary


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seeds", type=int, default=5)
    p.add_argument("--first-seed", type=int, default=0)
    p.add_argument("--seconds", type=float, default=16.0)
    p.add_argument("--width", type=int, default=320)
    p.add_argument("--height", type=int, default=240)
    p.add_argument("--method", choices=("fast", "paper"), default="fast")
    p.add_argument("--walks", default=",".join(WALKS))
    p.add_argument("--work", type=Path, default=Path("/tmp/walkmon-bench-indicators"))
    p.add_argument("--fresh", action="store_true", help="re-run the rotation estimate even when cached")
    p.add_argument("--results", type=Path, default=RESULTS)
    p.add_argument("--tag", default="", help="suffix of the result files: indicators-TAG.md / .json")
    args = p.parse_args(argv)
    args.work.mkdir(parents=True, exist_ok=True)
    rows = []
    for walk in args.walks.split(","):
        for seed in range(args.first_seed, args.first_seed + args.seeds):
            row = run_one(args.work, walk, seed, args)
            rows.append(row)
            sys.stdout.write(
                f"{walk} seed {seed}: cadence {row['cadence_err_nominal_pct']:+.2f}% (nominal) "
                f"{row['cadence_err_realised_pct']:+.2f}% (realised); label {row['label_est']}; "
                f"simulate {row['simulate_s']} s, analyze {row['analyze_s']} s\n"
            )
            sys.stdout.flush()
    # baseline-relative classification: the estimated normal walk of the next seed is the baseline
    normals = {r["seed"]: r for r in rows if r["walk"] == "normal"}
    for r in rows:
        seeds = sorted(normals)
        if not seeds:
            break
        other = [s for s in seeds if s != r["seed"]] or seeds
        base_seed = next((s for s in other if s > r["seed"]), other[0])
        # the whole-walk computation against the whole-walk baseline, the session analysis against the session
        # analysis of the baseline walk (what indicators.json of 'walkmon analyze' holds since schema 2)
        from walkmon.gait.session import analyze_session  # noqa: PLC0415

        base_angles = _angles(Path(normals[base_seed]["est_dir"]) / "angles.csv")
        base = compute_indicators(*base_angles)
        ind = compute_indicators(*_angles(Path(r["est_dir"]) / "angles.csv"), baseline=base)
        r["label_est_baseline"] = ind.classification.label
        ses_base = analyze_session(*base_angles).indicators
        r["session_label_baseline"] = analyze_session(*_angles(Path(r["est_dir"]) / "angles.csv"),
                                                      baseline=ses_base).indicators.classification.label
        r["baseline_seed"] = base_seed
    table = _fmt_table(rows)
    summary_lines, summary = _summary(rows)
    header = [
        "# Gait indicators: estimated angles vs truth",
        "",
        f"{len(rows)} simulated sessions ({args.seconds:g} s, {args.width}x{args.height}, 30 fps, rotation method "
        f"`{args.method}`), indicators in walkmon mode on the estimated angles vs the same computation on "
        "truth.csv. Cadence error vs meta.json's nominal cadence and vs the cadence the simulated steps realised "
        "over the analysed span. Baseline runs use the estimated normal walk of another seed.",
        "",
        "## Summary",
        "",
        *summary_lines,
        "",
        "## Per run",
        "",
        *table,
        "",
    ]
    text = "\n".join(header)
    sys.stdout.write("\n" + text)
    args.results.mkdir(parents=True, exist_ok=True)
    stem = f"indicators-{args.tag}" if args.tag else "indicators"
    (args.results / f"{stem}.md").write_text(text, encoding="utf-8")
    clean = [{k: v for k, v in r.items() if k != "est_dir"} for r in rows]
    (args.results / f"{stem}.json").write_text(
        json.dumps({"settings": {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items()},
                    "summary": summary, "runs": clean}, indent=2) + "\n",
        encoding="utf-8",
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
