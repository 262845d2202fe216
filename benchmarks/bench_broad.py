"""IMU-only attitude on all shared BROAD trials: walkmon's default against the field's reference filters.

    python benchmarks/bench_broad.py            # all trials in ../shared/data/broad (about 3 min on one core)
    python benchmarks/bench_broad.py --quick    # trials cut to 70 s, nothing written

For every trial of BROAD (Laidig, Caruso, Cereatti, Seel (2021), "BROAD - A Benchmark for Robust Inertial
Orientation Estimation", Data 6(7):72, CC BY 4.0; real IMU with optical motion-capture truth), run on the raw
gyroscope and accelerometer (no magnetometer):

* walkmon's default IMU attitude (``ImuFilterSettings()``, what ``walkmon analyze --imu``, the offline fusion and
  ``walkmon live`` with an IMU all use), sample by sample through :func:`walkmon.imu.attitude.track_attitude`;
* VQF online (``vqf.VQF(Ts).updateBatch``, 6-D, default parameters) and imufusion (Fusion AHRS, defaults);
* walkmon's own ESKF with its old walking default and its hand-held preset (``--imu-filter eskf`` /
  ``eskf-handheld``), for reference;
* the other candidates of the choice below (VQF with a shorter / longer accelerometer time constant).

Errors: inclination (angle between estimated and optical gravity direction in the sensor frame, independent of
heading) RMSE over the ``movement`` samples with optical truth, and the longest stretch of consecutive samples
with optical truth (any, not only ``movement``) where the inclination error stays above 5 deg (the divergence
criterion: above 5 deg for more than 1 s on any trial is a failure).

How the default is chosen (it cannot be tuned to a trial): leave one motion type out. The trials fall in three
motion types, rotation (02, 03, 05, 07, 09), translation (11, 16, 18) and disturbed (24 tapping, 27 vibration).
For each type held out, every candidate is scored on the trials of the other two types by its worst ratio of
RMSE to VQF online (the target: no worse than VQF on every trial), ties by mean RMSE; the candidate with the best
score is the choice for that fold, and its errors on the held-out type are what the table reports as "held out".
The default is the candidate chosen in every fold. Prints the tables and writes benchmarks/results/broad.md and
broad.json.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_fusion import BROAD_DEFAULT, inclination_deg, load_broad  # noqa: E402

from walkmon.imu.attitude import DEFAULT_IMU_FILTER, ImuFilterSettings, track_attitude  # noqa: E402
from walkmon.imu.recordings import rotation_matrices_from_quaternions_wxyz  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
DIVERGENCE_DEG, DIVERGENCE_S = 5.0, 1.0
#: equal within floating-point rounding (sample-by-sample VQF and its batch call differ by ~1e-15)
TIE_DEG = 1e-9
MOTION_TYPES = {"rotation": ("02", "03", "05", "07", "09"), "translation": ("11", "16", "18"), "disturbed": ("24", "27")}
#: candidates of the default (name -> settings); the first is the shipped default
CANDIDATES: dict[str, ImuFilterSettings] = {
    "walkmon default (vqf core)": DEFAULT_IMU_FILTER,
    "vqf core, tau_acc 1.5 s": ImuFilterSettings(filter="vqf", tau_acc_s=1.5),
    "vqf core, tau_acc 6 s": ImuFilterSettings(filter="vqf", tau_acc_s=6.0),
    "old walkmon default (eskf)": ImuFilterSettings(filter="eskf"),
    "old walkmon eskf-handheld": ImuFilterSettings(filter="eskf-handheld"),
}


def motion_type(trial: str) -> str:
    for kind, prefixes in MOTION_TYPES.items():
        if trial[:2] in prefixes:
            return kind
    return "other"


def errors(trial: dict, down: np.ndarray) -> dict:
    """RMSE over movement samples with truth; longest time above 5 deg over all samples with truth."""
    has_truth = trial["has_truth"]
    e_all = np.full(len(down), np.nan)
    e_all[has_truth] = inclination_deg(down[has_truth], trial["down_true"][has_truth])
    e = e_all[trial["valid"]]
    if len(e) == 0:
        e = np.array([np.nan])
    above = np.nan_to_num(e_all, nan=0.0) > DIVERGENCE_DEG
    longest = 0
    run = 0
    for flag in above:  # consecutive samples above 5 deg (a sample without truth ends a stretch)
        run = run + 1 if flag else 0
        longest = max(longest, run)
    return {"rmse_deg": float(np.sqrt(np.mean(e**2))), "max_deg": float(np.max(e)),
            "longest_above_5_deg_s": float(longest / trial["rate"])}


def vqf_online(trial: dict) -> np.ndarray:
    import vqf  # noqa: PLC0415

    q = vqf.VQF(1.0 / trial["rate"]).updateBatch(np.ascontiguousarray(trial["gyr"]), np.ascontiguousarray(trial["acc"]))
    return -rotation_matrices_from_quaternions_wxyz(q["quat6D"])[:, 2, :]


def imufusion_down(trial: dict) -> np.ndarray:
    import imufusion  # noqa: PLC0415

    ahrs = imufusion.Ahrs()
    ahrs.set_sample_period(1.0 / trial["rate"])
    q = np.empty((len(trial["gyr"]), 4))
    gyr_dps, acc_g = np.degrees(trial["gyr"]), trial["acc"] / 9.81
    for i in range(len(q)):
        ahrs.update_no_magnetometer(gyr_dps[i], acc_g[i])
        q[i] = ahrs.get_quaternion()
    return -rotation_matrices_from_quaternions_wxyz(q)[:, 2, :]


def run_trial(path: Path, max_seconds: float | None) -> dict:
    trial = load_broad(path, max_seconds)
    trial["has_truth"] = np.isfinite(np.asarray(trial["down_true_raw"])).all(axis=1)
    row: dict = {"trial": trial["name"], "type": motion_type(trial["name"]), "seconds": round(float(trial["t"][-1]), 1),
                 "movement_samples": int(trial["valid"].sum()), "filters": {}}
    for name, settings in CANDIDATES.items():
        t0 = time.perf_counter()
        down = track_attitude(trial["t"], trial["gyr"], trial["acc"], settings).gravity_down
        row["filters"][name] = errors(trial, down) | {"seconds": round(time.perf_counter() - t0, 2)}
    for name, fn in (("vqf online", vqf_online), ("imufusion", imufusion_down)):
        t0 = time.perf_counter()
        row["filters"][name] = errors(trial, fn(trial)) | {"seconds": round(time.perf_counter() - t0, 2)}
    sys.stderr.write(f"  {trial['name']}: " + ", ".join(f"{k} {v['rmse_deg']:.3f}" for k, v in row["filters"].items()) + "\n")
    return row


def choose(rows: list[dict]) -> list[dict]:
    """Leave one motion type out (see the module docstring)."""
    folds = []
    for held in MOTION_TYPES:
        train = [r for r in rows if r["type"] != held]
        test = [r for r in rows if r["type"] == held]
        if not train or not test:
            continue

        def score(name: str, train: list[dict] = train) -> tuple[float, float]:
            ratios = [r["filters"][name]["rmse_deg"] / r["filters"]["vqf online"]["rmse_deg"] for r in train]
            return (round(max(ratios), 6), float(np.mean([r["filters"][name]["rmse_deg"] for r in train])))

        chosen = min(CANDIDATES, key=score)
        folds.append({"held_out": held, "chosen": chosen, "train_worst_ratio_to_vqf": score(chosen)[0],
                      "held_out_rmse_deg": {r["trial"]: r["filters"][chosen]["rmse_deg"] for r in test}})
    return folds


def table(rows: list[dict], folds: list[dict]) -> str:
    default = next(iter(CANDIDATES))
    names = [default, "vqf online", "imufusion", "old walkmon default (eskf)", "old walkmon eskf-handheld"]
    lines = [
        "Inclination RMSE over the movement samples (deg) and, in brackets, the longest time (s) above 5 deg.",
        "",
        "| trial | type | " + " | ".join(names) + " | default <= vqf online | default never > 5 deg for > 1 s |",
        "|---|---|" + "---|" * len(names) + "---|---|",
    ]
    for r in rows:
        f = r["filters"]
        cells = [f"{f[n]['rmse_deg']:.3f} ({f[n]['longest_above_5_deg_s']:.2f})" for n in names]
        cells[0] = f"**{cells[0]}**"
        ok = f[default]["rmse_deg"] <= f["vqf online"]["rmse_deg"] + TIE_DEG
        holds = f[default]["longest_above_5_deg_s"] <= DIVERGENCE_S
        lines.append(f"| {r['trial']} | {r['type']} | " + " | ".join(cells) + f" | {'yes' if ok else 'no'} | {'yes' if holds else 'no'} |")
    lines += ["", "All candidates (RMSE, deg):", "",
              "| trial | " + " | ".join(CANDIDATES) + " |", "|---|" + "---|" * len(CANDIDATES)]
    for r in rows:
        lines.append(f"| {r['trial']} | " + " | ".join(f"{r['filters'][n]['rmse_deg']:.3f}" for n in CANDIDATES) + " |")
    lines += ["", "Leave one motion type out: the candidate with the best worst-case RMSE ratio to vqf online on the "
              "other two types, and its RMSE on the held-out type:", "",
              "| held out | chosen on the others | worst ratio to vqf (training) | held-out RMSE (deg) |", "|---|---|---|---|"]
    for fold in folds:
        held = ", ".join(f"{k[:2]} {v:.3f}" for k, v in fold["held_out_rmse_deg"].items())
        lines.append(f"| {fold['held_out']} | {fold['chosen']} | {fold['train_worst_ratio_to_vqf']:.3f} | {held} |")
    n_ok = sum(r["filters"][default]["rmse_deg"] <= r["filters"]["vqf online"]["rmse_deg"] + TIE_DEG for r in rows)
    n_hold = sum(r["filters"][default]["longest_above_5_deg_s"] <= DIVERGENCE_S for r in rows)
    lines += ["", f"Default <= vqf online on {n_ok}/{len(rows)} trials; never above 5 deg for more than 1 s on "
              f"{n_hold}/{len(rows)} trials. Chosen in every fold: "
              f"{'yes' if folds and all(f['chosen'] == default for f in folds) else 'no'}."]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="trials cut to 70 s; nothing written")
    p.add_argument("--broad", default=str(BROAD_DEFAULT))
    args = p.parse_args(argv)
    paths = sorted(Path(args.broad).glob("*.hdf5"))
    if not paths:
        sys.stderr.write(f"no BROAD trials (*.hdf5) in {args.broad}\n")
        return 2
    t0 = time.perf_counter()
    rows = [run_trial(pth, 70.0 if args.quick else None) for pth in paths]
    folds = choose(rows)
    text = table(rows, folds)
    sys.stdout.write(text)
    if not args.quick:
        header = (f"## BROAD, all shared trials (benchmarks/bench_broad.py)\n\n"
                  f"Data: BROAD, Laidig, Caruso, Cereatti, Seel (2021), Data 6(7):72, CC BY 4.0. "
                  f"Machine: {platform.machine()}, Python {platform.python_version()}. "
                  f"Date: {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}. "
                  f"Run time {time.perf_counter() - t0:.0f} s.\n\n")
        RESULTS.mkdir(exist_ok=True)
        (RESULTS / "broad.md").write_text(header + text, encoding="utf-8")
        (RESULTS / "broad.json").write_text(json.dumps({
            "candidates": {k: {"filter": v.filter, "tau_acc_s": v.tau_acc_s, "rest_min_s": v.rest_min_s}
                           for k, v in CANDIDATES.items()},
            "motion_types": MOTION_TYPES, "rows": rows, "folds": folds}, indent=1), encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
