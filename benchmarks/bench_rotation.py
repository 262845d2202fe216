"""Rotation benchmark: both methods against simulated walks' truth, accuracy and end-to-end frames/s.

    python benchmarks/bench_rotation.py            # full: 4 walk types x 16 s, distorted lens, 40 s walk
    python benchmarks/bench_rotation.py --quick    # normal + bend, 8 s, paper on 4 s (a few minutes)
    python benchmarks/bench_rotation.py --sweep    # fast only: 4 walk types x 5 seeds x 640x480 and 320x240
    python benchmarks/bench_rotation.py --sweep --sizes 160x120 --out benchmarks/results/rotation-sweep-160x120
    python benchmarks/bench_rotation.py --long     # fast only: 40 s normal walks x 5 seeds + 2 min + 10 min walks
    python benchmarks/bench_rotation.py --long --long-walks 600@640x480     # the 10-minute walk at 640x480

The long-walk run (``--long``, results in benchmarks/results/rotation-long.md/.json) checks drift: issue 14 asks
for raw RMSE <= 0.5 deg on every seed of a 40 s walk and <= 1.5 deg on a 10-minute walk (640x480). Long clips
are rendered once and cached like the others (a 10-minute 640x480 clip: 18,000 frames, ~20 CPU minutes).

The sweep (``--sweep``, results in benchmarks/results/rotation-sweep.md/.json) exists because one seed at one
size hid a failure: right_foot_drag seed 2 at 320x240 slid 3.2 deg in 0.4 s with status ok.

Simulates each walk once (640x480, 30 fps, the simulator's noise, motion blur and mp4 compression; cached
under --cache), then runs ``fast`` and ``paper`` in the same process, single-threaded (``cv2.setNumThreads(1)``,
one FFmpeg decoder thread), timing decode + estimation together. Compares with truth.csv (relative to the
first frame) and prints a table, also written to benchmarks/results/rotation.md and rotation.json.

Columns: detrended RMSE (a least-squares line removed from estimate and truth, as the paper does), raw RMSE
(drift included), largest frame-to-frame error (of the per-frame change, any axis), end drift (error at the
last frame), frames/s end to end. The paper method is slow, so it runs on the first ``--paper-seconds`` of
each walk (said in the table). The machine is shared, so absolute frames/s are noisy: the ratio
fast/paper measured on the same frames is quoted too.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import sys
import time
from pathlib import Path

import cv2
import numpy as np

from walkmon.camera.model import read_camera_yaml
from walkmon.consts import angles_deg_from_rotation, rotation_from_angles_deg
from walkmon.drivers.video_file import VideoFile
from walkmon.rotation import (
    DEFAULT_ROTATION_SETTINGS,
    RotationEstimator,
    RotationSettings,
)
from walkmon.rotation.geometry import rotation_angle_deg
from walkmon.tables import read_table

RESULTS = Path(__file__).resolve().parent / "results"

TARGETS = {"detrended_rmse_deg": 0.15, "raw_rmse_deg": 0.5, "max_frame_error_deg": 0.5, "fps": 300.0, "ratio": 10.0}
#: issue 14's raw-RMSE targets by walk length: 40 s walks (every seed) and a 10-minute walk
LONG_RAW_TARGET_DEG = {40.0: 0.5, 600.0: 1.5}


def walks(args: argparse.Namespace) -> list[dict]:
    if args.quick:
        return [
            {"name": "normal", "walk": "normal", "seconds": 8.0, "distortion": False},
            {"name": "bend", "walk": "bend", "seconds": 8.0, "distortion": False},
        ]
    s = args.seconds
    out = [{"name": w, "walk": w, "seconds": s, "distortion": False} for w in args.walks]
    out.append({"name": "normal+distortion", "walk": "normal", "seconds": s, "distortion": True})
    out.append({"name": "normal 40 s", "walk": "normal", "seconds": 40.0, "distortion": False})
    return out


def simulated(spec: dict, cache: Path, seed: int) -> Path:
    """The clip of ``spec``, cached under a key of the simulator version and every parameter."""
    from walkmon.simulate.cache import cached_simulation  # noqa: PLC0415

    t0 = time.perf_counter()
    d = cached_simulation(cache, walk=spec["walk"], seconds=spec["seconds"], seed=seed, distortion=spec["distortion"])
    if time.perf_counter() - t0 > 1.0:
        sys.stderr.write(f"  simulated {d.name} in {time.perf_counter() - t0:.0f} s\n")
    return d


def simulated_sized(walk: str, seconds: float, seed: int, size: tuple[int, int], cache: Path) -> Path:
    """A pinhole clip of ``walk`` at ``size`` (width, height), simulated once and cached (key: simulator version
    and every parameter)."""
    from walkmon.simulate.cache import cached_simulation  # noqa: PLC0415

    w, h = size
    t0 = time.perf_counter()
    d = cached_simulation(cache, walk=walk, seconds=seconds, seed=seed, width=w, height=h)
    if time.perf_counter() - t0 > 1.0:
        sys.stderr.write(f"  simulated {d.name} in {time.perf_counter() - t0:.0f} s\n")
    return d


def truth_relative(d: Path) -> tuple[np.ndarray, np.ndarray]:
    tr = read_table(d / "truth.csv", ["t", "pitch", "yaw", "roll"])
    Rs = rotation_from_angles_deg(tr["pitch"], tr["yaw"], tr["roll"])
    return tr["t"], angles_deg_from_rotation(Rs[0].T @ Rs)


#: Ablations of the fast method (``--variants``): what the half-resolution tracking and the keyframe window buy.
VARIANTS = {
    "fast, full-res tracking": {"tracking_scale": 1.0, "klt_levels": 3},
    "fast, no keyframe window": {"keyframe_window": 1},
    "fast, no heading reference": {"heading_reference": False},
}


def run_method(d: Path, method: str, max_frames: int | None, overrides: dict | None = None) -> tuple[np.ndarray, tuple[float, float], dict]:
    """Angles, (wall seconds, CPU seconds of this process) for decode + estimation, and model/status counts."""
    camera = read_camera_yaml(d / "camera.yaml")
    est = RotationEstimator(camera, RotationSettings(method=method, **(overrides or {})))
    angles, models = [], {}
    t0, c0 = time.perf_counter(), time.process_time()
    with VideoFile(d / "video.mp4", decode_threads=1) as video:
        for i, (t_s, frame) in enumerate(video):
            if max_frames is not None and i >= max_frames:
                break
            e = est.push(frame, t_s)
            angles.append(e.angles_deg)
            models[e.model] = models.get(e.model, 0) + 1
            if not e.status.is_measured:
                models[f"status:{e.status.value}"] = models.get(f"status:{e.status.value}", 0) + 1
    elapsed = (time.perf_counter() - t0, time.process_time() - c0)
    return np.array(angles), elapsed, models


def detrend(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    A = np.c_[t, np.ones_like(t)]
    coef, *_ = np.linalg.lstsq(A, x, rcond=None)
    return x - A @ coef


def metrics(t: np.ndarray, est: np.ndarray, truth: np.ndarray) -> dict:
    n = min(len(est), len(truth))
    t, est, truth = t[:n], est[:n], truth[:n]
    err = est - truth
    err[:, 1] = (err[:, 1] + 180.0) % 360.0 - 180.0  # a yaw error is an angle: a lost track's 359 deg is -1
    derr = detrend(t, est) - detrend(t, truth)
    return {
        "frames": int(n),
        "detrended_rmse_deg": np.sqrt(np.mean(derr**2, axis=0)).round(4).tolist(),
        "raw_rmse_deg": np.sqrt(np.mean(err**2, axis=0)).round(4).tolist(),
        "max_frame_error_deg": round(float(np.abs((np.diff(err, axis=0) + 180.0) % 360.0 - 180.0).max()), 4)
        if n > 1 else 0.0,
        "end_drift_deg": err[-1].round(3).tolist(),
    }


def fmt3(v: list[float]) -> str:
    return "/".join(f"{x:.3f}" for x in v)


def meets(r: dict) -> bool:
    return bool(
        max(r["detrended_rmse_deg"]) <= TARGETS["detrended_rmse_deg"]
        and max(r["raw_rmse_deg"]) <= TARGETS["raw_rmse_deg"]
        and r["max_frame_error_deg"] <= TARGETS["max_frame_error_deg"]
    )


def sweep(args: argparse.Namespace) -> int:
    """Fast method only, every walk type x seed x size; one row per clip and a summary per walk type and size."""
    cache = Path(args.sweep_cache)
    cache.mkdir(parents=True, exist_ok=True)
    sizes = [tuple(int(v) for v in sz.lower().split("x")) for sz in args.sizes]
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    load0 = os.getloadavg()
    rows: list[dict] = []
    for size in sizes:
        for walk in args.walks:
            for seed in seeds:
                d = simulated_sized(walk, args.seconds, seed, size, cache)
                t, truth = truth_relative(d)
                est, elapsed, models = run_method(d, "fast", None)
                row = {"size": f"{size[0]}x{size[1]}", "walk": walk, "seed": seed, **metrics(t, est, truth)}
                row["cpu_fps"] = round(row["frames"] / elapsed[1], 1)
                row["fps"] = round(row["frames"] / elapsed[0], 1)
                row["not_ok_frames"] = sum(v for k, v in models.items() if k.startswith("status:"))
                row["models"] = models
                row["meets_accuracy_targets"] = meets(row)
                rows.append(row)
                sys.stderr.write(f"  {row['size']} {walk} seed {seed}: {row}\n")
    info = {
        "date_utc": time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime()),
        "machine": f"{platform.machine()} {os.cpu_count()} cores, load average {load0[0]:.1f} at start, "
        f"{os.getloadavg()[0]:.1f} at end",
        "python": platform.python_version(),
        "opencv": cv2.__version__,
        "threads": "cv2.setNumThreads(1), FFmpeg decode_threads=1",
        "video": f"{args.seconds:g} s 30 fps mp4 from walkmon.simulate (noise, motion blur, compression, pinhole)",
        "targets_fast": TARGETS,
        "settings": dataclasses.asdict(DEFAULT_ROTATION_SETTINGS),
    }
    lines = [
        "# Rotation robustness sweep (fast method)",
        "",
        f"{info['date_utc']} UTC, {info['machine']}, Python {info['python']}, OpenCV {info['opencv']}, "
        f"{info['threads']}. {info['video']}; seeds {seeds[0]}-{seeds[-1]}, sizes {', '.join(args.sizes)}.",
        "",
        "Same columns as rotation.md (degrees, pitch/yaw/roll, against truth.csv relative to the first frame). "
        "not ok: frames whose status was not ok/first_frame (held, or LOW_QUALITY when the essential fit strayed). frames/s per CPU second, one thread.",
        "",
        "## Summary per walk type and size",
        "",
        "| size | walk | clips meeting all accuracy targets | worst detrended RMSE (any axis) | worst raw RMSE | "
        "worst max frame err | worst end drift (abs) | not ok frames | frames/s CPU (min) |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for size in sizes:
        sz = f"{size[0]}x{size[1]}"
        for walk in args.walks:
            rs = [r for r in rows if r["size"] == sz and r["walk"] == walk]
            lines.append(
                f"| {sz} | {walk} | {sum(r['meets_accuracy_targets'] for r in rs)}/{len(rs)} | "
                f"{max(max(r['detrended_rmse_deg']) for r in rs):.3f} | {max(max(r['raw_rmse_deg']) for r in rs):.3f} | "
                f"{max(r['max_frame_error_deg'] for r in rs):.3f} | "
                f"{max(max(abs(v) for v in r['end_drift_deg']) for r in rs):.3f} | "
                f"{sum(r['not_ok_frames'] for r in rs)} | {min(r['cpu_fps'] for r in rs):.0f} |"
            )
    lines += [
        "",
        "## Every clip",
        "",
        "| size | walk | seed | frames | detrended RMSE | raw RMSE | max frame err | end drift | not ok | frames/s CPU |",
        "|---|---|---:|---:|---|---|---:|---|---:|---:|",
    ]
    for r in rows:
        flag = " ✓" if r["meets_accuracy_targets"] else " ✗"
        lines.append(
            f"| {r['size']} | {r['walk']}{flag} | {r['seed']} | {r['frames']} | {fmt3(r['detrended_rmse_deg'])} | "
            f"{fmt3(r['raw_rmse_deg'])} | {r['max_frame_error_deg']:.3f} | {fmt3(r['end_drift_deg'])} | "
            f"{r['not_ok_frames']} | {r['cpu_fps']:.0f} |"
        )
    n_met = sum(r["meets_accuracy_targets"] for r in rows)
    lines += [
        "",
        f"Targets for fast: detrended RMSE <= {TARGETS['detrended_rmse_deg']} deg/axis, raw RMSE <= "
        f"{TARGETS['raw_rmse_deg']} deg/axis, max frame error <= {TARGETS['max_frame_error_deg']} deg (✓/✗ above). "
        f"Accuracy targets met on {n_met}/{len(rows)} clips.",
        "",
    ]
    text = "\n".join(lines)
    sys.stdout.write(text + "\n")
    out = Path(args.out if args.out != str(RESULTS / "rotation") else RESULTS / "rotation-sweep")
    out.parent.mkdir(parents=True, exist_ok=True)
    Path(f"{out}.md").write_text(text, encoding="utf-8")
    Path(f"{out}.json").write_text(json.dumps({"info": info, "rows": rows}, indent=2) + "\n", encoding="utf-8")
    return 0


def error_at_minutes(t: np.ndarray, est: np.ndarray, truth: np.ndarray, every_s: float) -> list[dict]:
    """The error (estimate - truth, deg per axis) at every ``every_s`` seconds and the RMSE of each stretch."""
    n = min(len(est), len(truth))
    t, err = t[:n], est[:n] - truth[:n]
    out = []
    for t_end in np.arange(every_s, t[-1] + every_s, every_s):
        sel = (t > t_end - every_s) & (t <= t_end)
        if not sel.any():
            continue
        k = int(np.flatnonzero(sel)[-1])
        out.append({"t_s": round(float(t[k]), 2), "error_deg": err[k].round(3).tolist(),
                    "rmse_deg_stretch": np.sqrt(np.mean(err[sel] ** 2, axis=0)).round(3).tolist()})
    return out


def long_walks(args: argparse.Namespace) -> int:
    """Fast method only on long walks: 40 s normal walks x seeds, then (unless --no-ten-minutes) one long walk."""
    cache = Path(args.cache)
    cache.mkdir(parents=True, exist_ok=True)
    specs = [{"walk": "normal", "seconds": 40.0, "seed": s, "size": (640, 480)}
             for s in range(args.first_seed, args.first_seed + args.seeds)]
    for item in args.long_walks:  # SECONDS@WxH
        sec, size = item.split("@")
        w, h = (int(v) for v in size.lower().split("x"))
        specs.append({"walk": "normal", "seconds": float(sec), "seed": args.seed, "size": (w, h)})
    load0 = os.getloadavg()
    rows: list[dict] = []
    for spec in specs:
        d = simulated_sized(spec["walk"], spec["seconds"], spec["seed"], spec["size"], cache)
        t, truth = truth_relative(d)
        est, elapsed, models = run_method(d, "fast", None)
        row = {"walk": spec["walk"], "seconds": spec["seconds"], "seed": spec["seed"],
               "size": f"{spec['size'][0]}x{spec['size'][1]}", **metrics(t, est, truth)}
        row["cpu_fps"] = round(row["frames"] / elapsed[1], 1)
        row["fps"] = round(row["frames"] / elapsed[0], 1)
        row["not_ok_frames"] = sum(v for k, v in models.items() if k.startswith("status:"))
        row["models"] = models
        row["clip"] = d.name
        target = LONG_RAW_TARGET_DEG.get(spec["seconds"])  # the issue states none between 40 s and 10 minutes
        row["raw_target_deg"] = target
        row["meets_raw_target"] = None if target is None else bool(max(row["raw_rmse_deg"]) <= target)
        row["error_every"] = error_at_minutes(t, est, truth, 60.0 if spec["seconds"] > 120 else 10.0)
        rows.append(row)
        sys.stderr.write(f"  {spec['seconds']:g} s seed {spec['seed']}: {row}\n")
    info = {
        "date_utc": time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime()),
        "machine": f"{platform.machine()} {os.cpu_count()} cores, load average {load0[0]:.1f} at start, "
        f"{os.getloadavg()[0]:.1f} at end",
        "python": platform.python_version(),
        "opencv": cv2.__version__,
        "threads": "cv2.setNumThreads(1), FFmpeg decode_threads=1",
        "video": "640x480 30 fps mp4 from walkmon.simulate (noise, motion blur, compression, pinhole), normal walk, "
        "2 s standing at each end",
        "targets_raw_rmse_deg": {f"{k:g} s": v for k, v in LONG_RAW_TARGET_DEG.items()},
        "settings": dataclasses.asdict(DEFAULT_ROTATION_SETTINGS),
    }
    lines = [
        "# Rotation on long walks (fast method)",
        "",
        f"{info['date_utc']} UTC, {info['machine']}, Python {info['python']}, OpenCV {info['opencv']}, "
        f"{info['threads']}. {info['video']}.",
        "",
        "Errors in degrees per axis as pitch/yaw/roll, against truth.csv relative to the first frame (raw: drift "
        "included). Targets (issue 14): raw RMSE <= 0.5 deg on every seed of a 40 s walk, <= 1.5 deg on a 10-minute "
        "walk. frames/s: decode + estimation per CPU second, one thread.",
        "",
        "| walk | size | seed | frames | raw RMSE | target | detrended RMSE | max frame err | end drift | not ok | frames/s CPU |",
        "|---|---|---:|---:|---|---:|---|---:|---|---:|---:|",
    ]
    for r in rows:
        flag = {True: " ✓", False: " ✗", None: ""}[r["meets_raw_target"]]
        target = "-" if r["raw_target_deg"] is None else f"{r['raw_target_deg']:g}"
        lines.append(
            f"| {r['walk']} {r['seconds']:g} s{flag} | {r['size']} | {r['seed']} | {r['frames']} | {fmt3(r['raw_rmse_deg'])} | "
            f"{target} | {fmt3(r['detrended_rmse_deg'])} | {r['max_frame_error_deg']:.3f} | "
            f"{fmt3(r['end_drift_deg'])} | {r['not_ok_frames']} | {r['cpu_fps']:.0f} |"
        )
    for r in rows:
        if r["seconds"] <= 120:
            continue
        lines += ["", f"Error along the {r['seconds']:g} s walk ({r['size']}, seed {r['seed']}): at the end of each minute, and "
                  "the raw RMSE over that minute (pitch/yaw/roll, deg):", "",
                  "| t (s) | error | RMSE over the minute |", "|---:|---|---|"]
        lines += [f"| {e['t_s']:.0f} | {fmt3(e['error_deg'])} | {fmt3(e['rmse_deg_stretch'])} |" for e in r["error_every"]]
    n40 = [r for r in rows if r["seconds"] == 40.0]
    lines += [
        "",
        f"40 s walks meeting raw <= 0.5 deg: {sum(r['meets_raw_target'] for r in n40)}/{len(n40)}; worst raw RMSE "
        f"(any axis) {max((max(r['raw_rmse_deg']) for r in n40), default=float('nan')):.3f} deg.",
        "",
    ]
    text = "\n".join(lines)
    sys.stdout.write(text + "\n")
    out = Path(args.out if args.out != str(RESULTS / "rotation") else RESULTS / "rotation-long")
    out.parent.mkdir(parents=True, exist_ok=True)
    Path(f"{out}.md").write_text(text, encoding="utf-8")
    Path(f"{out}.json").write_text(json.dumps({"info": info, "rows": rows}, indent=2) + "\n", encoding="utf-8")
    return 0


def angle_rmse_deg(est: np.ndarray, truth: np.ndarray) -> float:
    """The RMS (deg) of the whole angle between estimated and true orientations, both (n, 3) walkmon angles."""
    n = min(len(est), len(truth))
    Re = np.asarray(rotation_from_angles_deg(est[:n, 0], est[:n, 1], est[:n, 2]), dtype=float).reshape(n, 3, 3)
    Rt = np.asarray(rotation_from_angles_deg(truth[:n, 0], truth[:n, 1], truth[:n, 2]), dtype=float).reshape(n, 3, 3)
    angles = np.array([rotation_angle_deg(t.T @ e) for t, e in zip(Rt, Re, strict=True)])
    return round(float(np.sqrt(np.mean(angles**2))), 4)


def mounts(args: argparse.Namespace) -> int:
    """A chest camera tilted on the trunk (``mount:PITCH:ROLL`` scripts): raw and detrended error of the fast
    method per mount and seed, with the ground's plane solution (default) and without it
    (``ground_plane=False``: the frames where the ground fills the view flagged planar-ambiguous, the rotation-only
    fit used). Walk types x seeds at ``--sizes``' first size."""
    cache = Path(args.sweep_cache)
    cache.mkdir(parents=True, exist_ok=True)
    w, h = (int(v) for v in args.sizes[0].lower().split("x"))
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    rows: list[dict] = []
    for mount in args.mount_list:
        for walk in args.walks:
            for seed in seeds:
                d = simulated_sized(f"mount:{mount},{walk}", args.seconds, seed, (w, h), cache)
                t, truth = truth_relative(d)
                for variant, overrides in (("ground plane", {}), ("flag planes", {"ground_plane": False})):
                    est, _elapsed, models = run_method(d, "fast", None, overrides)
                    r = {"mount": mount, "walk": walk, "seed": seed, "variant": variant, **metrics(t, est, truth),
                         "angle_rmse_deg": angle_rmse_deg(est, truth),
                         "flagged": int(sum(v for k, v in models.items() if k.startswith("status:")))}
                    rows.append(r)
                    sys.stderr.write(f"  {mount} {walk} {seed} {variant}: raw {fmt3(r['raw_rmse_deg'])} "
                                     f"flagged {r['flagged']}\n")
    lines = [
        "# A chest camera tilted on the trunk: rotation error by mount (bench_rotation.py --mounts)",
        "",
        f"{', '.join(args.walks)} x seeds {seeds[0]}-{seeds[-1]}, {args.seconds:g} s, {w}x{h}, simulator version "
        f"{_sim_version()}; the camera tilted on the trunk by the script's mount:PITCH:ROLL (pitch < 0: down). "
        "Degrees, pitch/yaw/roll, against truth.csv relative to the first frame. 'ground plane': the default (the "
        "plane solution whose normal is the vertical taken for the ground); 'flag planes': RotationSettings("
        "ground_plane=False), as before: every frame where one plane explains the tracks flagged planar-ambiguous "
        "and the rotation-only fit used. 'angle': the RMS of the whole angle between the estimated and the true "
        "orientation (the per-axis errors are differences of angles about a tilted start frame's axes, which a "
        "turn of a tilted camera mixes: they exaggerate there).",
        "",
        "| mount | variant | clips | worst raw p/y/r | mean raw p/y/r | worst angle | mean angle | worst detrended |"
        " worst f2f | flagged frames | raw <= 0.5 |",
        "|---|---|---:|---|---|---:|---:|---|---:|---:|---:|",
    ]
    for mount in args.mount_list:
        for variant in ("ground plane", "flag planes"):
            rs = [r for r in rows if r["mount"] == mount and r["variant"] == variant]
            raw = np.array([r["raw_rmse_deg"] for r in rs])
            det = np.array([r["detrended_rmse_deg"] for r in rs])
            angle = [r["angle_rmse_deg"] for r in rs]
            lines.append(
                f"| {mount} | {variant} | {len(rs)} | {fmt3(raw.max(axis=0).tolist())} | {fmt3(raw.mean(axis=0).tolist())} "
                f"| {max(angle):.3f} | {np.mean(angle):.3f} | {fmt3(det.max(axis=0).tolist())} | "
                f"{max(r['max_frame_error_deg'] for r in rs):.3f} | "
                f"{sum(r['flagged'] for r in rs)} of {sum(r['frames'] for r in rs)} | "
                f"{sum(max(r['raw_rmse_deg']) <= TARGETS['raw_rmse_deg'] for r in rs)}/{len(rs)} |")
    lines += ["", f"Machine: {platform.machine()}, Python {platform.python_version()}, OpenCV {cv2.__version__}.", ""]
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.with_suffix(".md").write_text("\n".join(lines), encoding="utf-8")
    out.with_suffix(".json").write_text(json.dumps(rows, indent=1) + "\n", encoding="utf-8")
    print("\n".join(lines))
    return 0


def _sim_version() -> int:
    from walkmon.simulate import SIMULATOR_VERSION  # noqa: PLC0415

    return SIMULATOR_VERSION


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="normal + bend, 8 s, paper on 4 s")
    p.add_argument("--walks", nargs="+", default=["normal", "left_shoulder_down", "right_foot_drag", "bend"])
    p.add_argument("--seconds", type=float, default=16.0, help="length of each walk (default 16)")
    p.add_argument("--paper-seconds", type=float, default=None, help="run paper on the first N s (default 8; quick 4)")
    p.add_argument("--no-paper", action="store_true", help="fast method only")
    p.add_argument("--variants", action="store_true", help="also run the fast-method ablations (VARIANTS)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--cache", default=os.environ.get("WALKMON_BENCH_CACHE", "/tmp/walkmon_bench_sims"))
    p.add_argument("--out", default=str(RESULTS / "rotation"), help="results path without suffix")
    p.add_argument("--sweep", action="store_true", help="robustness sweep: fast only, walks x seeds x sizes")
    p.add_argument("--seeds", type=int, default=5, help="sweep: number of seeds (default 5)")
    p.add_argument("--first-seed", type=int, default=None, help="sweep/long: first seed (default 0 sweep, 1 long)")
    p.add_argument("--sizes", nargs="+", default=["640x480", "320x240"], help="sweep: frame sizes WxH")
    p.add_argument("--sweep-cache", default=os.environ.get("WALKMON_SWEEP_CACHE", "/tmp/walkmon_bench_sweep"))
    p.add_argument("--long", action="store_true", help="long walks: 40 s normal x --seeds (from --first-seed) + one long")
    p.add_argument("--long-walks", nargs="*", default=["120@640x480", "600@320x240"], metavar="SECONDS@WxH",
                   help="--long: the long walks besides the 40 s ones (seed --seed). Default: 2 min at 640x480 and "
                   "10 min at 320x240 (a 10-minute 640x480 render is ~20 CPU minutes, more than a shared 2-core "
                   "machine had; 320x240 input is tracked at the same 320x240 as 640x480 input)")
    p.add_argument("--mounts", action="store_true",
                   help="camera tilted on the trunk: --mount-list x --walks x --seeds at the first of --sizes, "
                   "with and without the ground-plane rule (writes --out, default results/rotation-mounts)")
    p.add_argument("--mount-list", nargs="+", default=["0:0", "-12:1", "-25:-2"], metavar="PITCH:ROLL")
    args = p.parse_args(argv)
    cv2.setNumThreads(1)
    if args.mounts:
        args.first_seed = 1 if args.first_seed is None else args.first_seed
        if args.out == str(RESULTS / "rotation"):
            args.out = str(RESULTS / "rotation-mounts")
        return mounts(args)
    if args.sweep:
        args.first_seed = 0 if args.first_seed is None else args.first_seed
        return sweep(args)
    if args.long:
        args.first_seed = 1 if args.first_seed is None else args.first_seed  # seeds 1-5, as bench_fusion's walks
        return long_walks(args)
    paper_s = args.paper_seconds if args.paper_seconds is not None else (4.0 if args.quick else 8.0)
    cache = Path(args.cache)
    cache.mkdir(parents=True, exist_ok=True)
    load0 = os.getloadavg()
    rows: list[dict] = []
    for spec in walks(args):
        d = simulated(spec, cache, args.seed)
        t, truth = truth_relative(d)
        fps_video = 30.0
        est, elapsed, models = run_method(d, "fast", None)
        row = {"method": "fast", "walk": spec["name"], **metrics(t, est, truth)}
        row["fps"] = round(row["frames"] / elapsed[0], 1)
        row["cpu_fps"] = round(row["frames"] / elapsed[1], 1)
        row["models"] = models
        # fast again on exactly the paper's frames, for a like-for-like speed ratio
        paper_frames = int(round(paper_s * fps_video))
        rows.append(row)
        sys.stderr.write(f"  fast  {spec['name']}: {row}\n")
        for vname, overrides in VARIANTS.items() if args.variants else ():
            vest, velapsed, vmodels = run_method(d, "fast", None, overrides)
            vrow = {"method": vname, "walk": spec["name"], **metrics(t, vest, truth), "overrides": overrides}
            vrow["fps"] = round(vrow["frames"] / velapsed[0], 1)
            vrow["cpu_fps"] = round(vrow["frames"] / velapsed[1], 1)
            vrow["models"] = vmodels
            rows.append(vrow)
        if args.no_paper or spec["seconds"] > 30:
            continue
        _, fast_elapsed_sub, _ = run_method(d, "fast", paper_frames)
        pest, pelapsed, pmodels = run_method(d, "paper", paper_frames)
        prow = {"method": "paper", "walk": f"{spec['name']} (first {paper_s:g} s)", **metrics(t, pest, truth)}
        prow["fps"] = round(prow["frames"] / pelapsed[0], 2)
        prow["cpu_fps"] = round(prow["frames"] / pelapsed[1], 2)
        prow["models"] = pmodels
        prow["fast_cpu_fps_same_frames"] = round(prow["frames"] / fast_elapsed_sub[1], 1)
        prow["ratio_fast_over_paper"] = round(prow["fast_cpu_fps_same_frames"] / prow["cpu_fps"], 1)
        rows.append(prow)
        sys.stderr.write(f"  paper {spec['name']}: {prow}\n")

    for r in rows:
        if r["method"] == "fast":
            r["meets_accuracy_targets"] = meets(r)
    ratios = [r["ratio_fast_over_paper"] for r in rows if "ratio_fast_over_paper" in r]
    info = {
        "date_utc": time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime()),
        "machine": f"{platform.machine()} {os.cpu_count()} cores, load average {load0[0]:.1f} at start, "
        f"{os.getloadavg()[0]:.1f} at end",
        "python": platform.python_version(),
        "opencv": cv2.__version__,
        "threads": "cv2.setNumThreads(1), FFmpeg decode_threads=1",
        "video": f"640x480 30 fps mp4 from walkmon.simulate (noise, motion blur, compression), seed {args.seed}",
        "targets_fast": TARGETS,
        "paper_seconds": paper_s,
        "settings": dataclasses.asdict(DEFAULT_ROTATION_SETTINGS),
    }
    lines = [
        "# Rotation benchmark",
        "",
        f"{info['date_utc']} UTC, {info['machine']}, Python {info['python']}, OpenCV {info['opencv']}, "
        f"{info['threads']}. {info['video']}.",
        "",
        "Errors in degrees per axis as pitch/yaw/roll, against truth.csv relative to the first frame. "
        "Detrended: a least-squares line removed from estimate and truth. Max frame error: largest error of the "
        "frame-to-frame change, any axis. frames/s: decode + estimation, end to end, one thread; 'CPU' divides by "
        "the CPU time this process used (what one core delivers), 'wall' by elapsed time (lower whenever the "
        "shared machine is busy; load average above).",
        "",
        "| method | walk | frames | detrended RMSE | raw RMSE | max frame err | end drift | frames/s CPU | frames/s wall | fast/paper (CPU) |",
        "|---|---|---:|---|---|---:|---|---:|---:|---:|",
    ]
    for r in rows:
        ratio = f"{r['ratio_fast_over_paper']:.0f}x ({r['fast_cpu_fps_same_frames']:.0f} vs {r['cpu_fps']:.1f})" if (
            "ratio_fast_over_paper" in r) else ""
        flag = "" if r["method"] != "fast" else (" ✓" if r["meets_accuracy_targets"] else " ✗")
        lines.append(
            f"| {r['method']}{flag} | {r['walk']} | {r['frames']} | {fmt3(r['detrended_rmse_deg'])} | "
            f"{fmt3(r['raw_rmse_deg'])} | {r['max_frame_error_deg']:.3f} | {fmt3(r['end_drift_deg'])} | "
            f"{r['cpu_fps']:.1f} | {r['fps']:.1f} | {ratio} |"
        )
    fast_rows = [r for r in rows if r["method"] == "fast"]
    lines += [
        "",
        f"Targets for fast: detrended RMSE <= {TARGETS['detrended_rmse_deg']} deg/axis, raw RMSE <= "
        f"{TARGETS['raw_rmse_deg']} deg/axis, max frame error <= {TARGETS['max_frame_error_deg']} deg (✓/✗ above); "
        f">= {TARGETS['fps']:.0f} frames/s and >= {TARGETS['ratio']:.0f}x paper.",
        f"Accuracy targets met on {sum(r['meets_accuracy_targets'] for r in fast_rows)}/{len(fast_rows)} walks; "
        f"fast frames/s (CPU) min {min(r['cpu_fps'] for r in fast_rows):.0f}, median "
        f"{float(np.median([r['cpu_fps'] for r in fast_rows])):.0f}; wall min {min(r['fps'] for r in fast_rows):.0f}, "
        f"median {float(np.median([r['fps'] for r in fast_rows])):.0f}"
        + (f"; fast/paper ratio min {min(ratios):.0f}x, median {float(np.median(ratios)):.0f}x." if ratios else "."),
        f"The paper method ran on the first {paper_s:g} s of each walk (not on the 40 s walk): it is slow.",
        "",
    ]
    text = "\n".join(lines)
    sys.stdout.write(text + "\n")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    Path(f"{out}.md").write_text(text, encoding="utf-8")
    Path(f"{out}.json").write_text(json.dumps({"info": info, "rows": rows}, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
