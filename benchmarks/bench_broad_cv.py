"""Held-out check of the hand-held IMU preset on BROAD (leave one trial out).

    python benchmarks/bench_broad_cv.py            # 54 settings x both trials (about 12 min on one core)
    python benchmarks/bench_broad_cv.py --quick    # 8 settings, trials cut to 60 s

``HANDHELD_ATTITUDE_SETTINGS`` was chosen by looking at the same two BROAD trials the fusion benchmark reports
(benchmarks/results/fusion.md), so its margin over VQF and imufusion there is optimistic. This script measures
how much: it runs walkmon's ESKF over a grid of the preset's knobs (gravity low-pass time and std, gyroscope bias
walk, gyroscope scale error; gyro samples as interval means, as the preset has) on each trial, then for each
trial picks the grid point that is best on the *other* trial and reports its error on this one (leave one trial
out), next to the shipped preset, the best grid point in hindsight, VQF (online) and imufusion with their
default settings. Error: inclination (angle between estimated and optical gravity in the sensor frame) RMSE over
the ``movement`` samples, as bench_fusion.py.

BROAD: Laidig, Caruso, Cereatti, Seel (2021), "BROAD - A Benchmark for Robust Inertial Orientation Estimation",
Data 6(7):72, CC BY 4.0. Prints the table and writes benchmarks/results/broad-cv.md and broad-cv.json.
"""

from __future__ import annotations

import argparse
import itertools
import json
import platform
import sys
import time
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_fusion import BROAD_DEFAULT, inclination_deg, load_broad  # noqa: E402

from walkmon.imu.attitude import (  # noqa: E402
    HANDHELD_ATTITUDE_SETTINGS,
    AttitudeSettings,
    estimate_attitude,
)
from walkmon.imu.recordings import rotation_matrices_from_quaternions_wxyz, vqf_attitude  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
GRID = {
    "gravity_lowpass_s": (1.0, 2.0, 4.0),
    "gravity_std_lowpass": (0.01, 0.02, 0.05),
    "gyroscope_bias_walk_rad_s_sqrt_s": (5e-5, 2e-4, 1e-3),
    "gyroscope_scale_error": (0.01, 0.03),
}
QUICK_GRID = {
    "gravity_lowpass_s": (1.0, 2.0),
    "gravity_std_lowpass": (0.02, 0.05),
    "gyroscope_bias_walk_rad_s_sqrt_s": (2e-4, 1e-3),
    "gyroscope_scale_error": (0.01,),
}


def rmse(trial: dict, down: np.ndarray) -> float:
    e = inclination_deg(down[trial["valid"]], trial["down_true"][trial["valid"]])
    return float(np.sqrt(np.mean(e**2)))


def walkmon_rmse(trial: dict, settings: AttitudeSettings) -> float:
    return rmse(trial, estimate_attitude(trial["t"], trial["gyr"], trial["acc"], settings).gravity_down)


def imufusion_rmse(trial: dict) -> float:
    import imufusion  # noqa: PLC0415

    ahrs = imufusion.Ahrs()
    ahrs.set_sample_period(1.0 / trial["rate"])
    q = np.empty((len(trial["gyr"]), 4))
    gyr_dps, acc_g = np.degrees(trial["gyr"]), trial["acc"] / 9.81
    for i in range(len(q)):
        ahrs.update_no_magnetometer(gyr_dps[i], acc_g[i])
        q[i] = ahrs.get_quaternion()
    return rmse(trial, -rotation_matrices_from_quaternions_wxyz(q)[:, 2, :])


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true")
    p.add_argument("--broad", default=str(BROAD_DEFAULT))
    args = p.parse_args(argv)
    paths = sorted(Path(args.broad).glob("*.hdf5"))
    if len(paths) < 2:
        sys.stderr.write(f"need at least two BROAD trials in {args.broad}, found {len(paths)}\n")
        return 2
    grid = QUICK_GRID if args.quick else GRID
    trials = [load_broad(pth, 60.0 if args.quick else None) for pth in paths]
    keys = list(grid)
    points = [dict(zip(keys, values, strict=True)) for values in itertools.product(*(grid[k] for k in keys))]
    base = replace(HANDHELD_ATTITUDE_SETTINGS)
    t0 = time.perf_counter()
    scores = np.empty((len(points), len(trials)))
    for i, point in enumerate(points):
        for j, trial in enumerate(trials):
            scores[i, j] = walkmon_rmse(trial, replace(base, **point))
        sys.stderr.write(f"  {i + 1}/{len(points)} {point}: {np.round(scores[i], 3)}\n")
    rows = []
    for j, trial in enumerate(trials):
        others = [k for k in range(len(trials)) if k != j]
        chosen = int(np.argmin(scores[:, others].mean(axis=1)))
        hindsight = int(np.argmin(scores[:, j]))
        _, down = vqf_attitude(trial["gyr"], trial["acc"], trial["rate"], offline=False)
        rows.append({
            "trial": trial["name"],
            "held_out": float(scores[chosen, j]),
            "held_out_settings": points[chosen],
            "preset": walkmon_rmse(trial, HANDHELD_ATTITUDE_SETTINGS),
            "hindsight": float(scores[hindsight, j]),
            "hindsight_settings": points[hindsight],
            "rank_of_held_out": int(np.sum(scores[:, j] < scores[chosen, j])) + 1,
            "vqf_online": rmse(trial, down),
            "imufusion": imufusion_rmse(trial),
        })
        r = rows[-1]
        r["held_out_no_worse_than_vqf_and_imufusion"] = bool(r["held_out"] <= min(r["vqf_online"], r["imufusion"]))
    elapsed = time.perf_counter() - t0
    text = table(rows, len(points), keys, args.quick)
    sys.stdout.write(text)
    header = (f"## BROAD leave-one-trial-out (benchmarks/bench_broad_cv.py{' --quick' if args.quick else ''})\n\n"
              f"Machine: {platform.machine()}, Python {platform.python_version()}. "
              f"Date: {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}. Run time {elapsed:.0f} s.\n\n")
    if not args.quick:
        RESULTS.mkdir(exist_ok=True)
        (RESULTS / "broad-cv.md").write_text(header + text, encoding="utf-8")
        (RESULTS / "broad-cv.json").write_text(json.dumps({
            "grid": {k: list(v) for k, v in grid.items()}, "base": asdict(base), "points": points,
            "scores_deg": scores.round(4).tolist(), "trials": [t["name"] for t in trials], "rows": rows,
        }, indent=1), encoding="utf-8")
    return 0


def table(rows: list[dict], n_points: int, keys: list[str], quick: bool) -> str:
    short = {"gravity_lowpass_s": "lp", "gravity_std_lowpass": "std", "gyroscope_bias_walk_rad_s_sqrt_s": "bias walk",
             "gyroscope_scale_error": "scale"}

    def fmt(point: dict) -> str:
        return ", ".join(f"{short[k]} {point[k]:g}" for k in keys)

    lines = [
        f"Inclination RMSE over movement (deg). Grid of {n_points} settings"
        f"{' (quick: trials cut to 60 s)' if quick else ''}; held out = the grid point best on the other trial.",
        "",
        "| trial | walkmon, chosen on the other trial (held out) | settings chosen | shipped hand-held preset | best in hindsight | vqf (online) | imufusion | held out <= vqf and imufusion |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['trial']} | **{r['held_out']:.3f}** (rank {r['rank_of_held_out']}/{n_points}) | {fmt(r['held_out_settings'])} "
            f"| {r['preset']:.3f} | {r['hindsight']:.3f} | {r['vqf_online']:.3f} | {r['imufusion']:.3f} "
            f"| {'yes' if r['held_out_no_worse_than_vqf_and_imufusion'] else 'no'} |"
        )
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    raise SystemExit(main())
