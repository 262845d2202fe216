"""Simulator benchmark: render speed (target: a 16 s 640x480 walk well under a minute on one core) and how
trackable the frames are.

    python benchmarks/bench_simulator.py            # 16 s walks: 4 types at 640x480, distortion, 320x240
    python benchmarks/bench_simulator.py --quick    # normal + right_foot_drag, 8 s

Runs single-threaded (``cv2.setNumThreads(1)``, BLAS/OpenMP threads 1). Times the whole ``simulate()`` call
(truth, IMU, scene textures, rendering, mp4 encoding) by CPU time and by wall time: the development machine is
shared, so wall time swings; CPU time is the one-core cost. Also decodes the video back and reports, per frame,
Shi-Tomasi corners and the share of them that pyramidal LK tracks to the next frame and back within 1 px.
Writes the table to benchmarks/results/simulator.md and simulator.json.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import cv2  # noqa: E402
import numpy as np  # noqa: E402

from walkmon.simulate import simulate  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
TARGET_S = 60.0


def trackability(video: Path, every: int = 10) -> tuple[float, float, int]:
    """Median corners per frame, median forward-backward LK success, frames decoded."""
    cap = cv2.VideoCapture(str(video))
    frames = []
    while True:
        ok, frame = cap.read()
        if not ok:
            break
        frames.append(cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY))
    cap.release()
    corners, tracked = [], []
    lk = {"winSize": (21, 21), "maxLevel": 3}
    for i in range(0, len(frames) - 1, every):
        a, b = frames[i], frames[i + 1]
        pts = cv2.goodFeaturesToTrack(a, maxCorners=1000, qualityLevel=0.01, minDistance=8)
        if pts is None:
            corners.append(0)
            tracked.append(0.0)
            continue
        fwd, st1, _ = cv2.calcOpticalFlowPyrLK(a, b, pts, None, **lk)
        back, st2, _ = cv2.calcOpticalFlowPyrLK(b, a, fwd, None, **lk)
        good = (st1.ravel() == 1) & (st2.ravel() == 1) & (np.linalg.norm((back - pts).reshape(-1, 2), axis=1) < 1.0)
        corners.append(len(pts))
        tracked.append(float(good.mean()))
    return float(np.median(corners)), float(np.median(tracked)), len(frames)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="two 8 s walks only")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    cv2.setNumThreads(1)
    if args.quick:
        cases = [("normal", 8.0, 640, 480, False), ("right_foot_drag", 8.0, 640, 480, False)]
    else:
        cases = [
            ("normal", 16.0, 640, 480, False),
            ("left_shoulder_down", 16.0, 640, 480, False),
            ("right_foot_drag", 16.0, 640, 480, False),
            ("bend", 16.0, 640, 480, False),
            ("normal", 16.0, 640, 480, True),
            ("normal", 16.0, 320, 240, False),
        ]
    rows = []
    with tempfile.TemporaryDirectory(prefix="walkmon-bench-sim-") as tmp:
        for k, (walk, seconds, w, h, dist) in enumerate(cases):
            out = Path(tmp) / f"case{k}"
            seed = args.seed + k  # a new seed per case: every row includes generating its street's textures
            c0, w0 = time.process_time(), time.perf_counter()
            result = simulate(out, walk, seconds, seed, w, h, 30.0, dist)
            cpu, wall = time.process_time() - c0, time.perf_counter() - w0
            corners, tracked, decoded = trackability(result.video_path)
            rows.append(
                {
                    "walk": walk,
                    "seconds": seconds,
                    "size": f"{w}x{h}",
                    "distortion": dist,
                    "frames": result.n_frames,
                    "decoded_frames": decoded,
                    "cpu_s": round(cpu, 2),
                    "wall_s": round(wall, 2),
                    "cpu_ms_per_frame": round(1000 * cpu / result.n_frames, 1),
                    "mp4_kib": round(result.video_path.stat().st_size / 1024),
                    "corners_per_frame": corners,
                    "lk_fb_tracked": round(tracked, 3),
                }
            )
            sys.stdout.write(f"{rows[-1]}\n")
    header = (
        "| walk | s | size | distortion | frames (decoded) | CPU s | wall s | CPU ms/frame | mp4 KiB "
        "| corners/frame | LK fwd-bwd tracked |\n|---|---|---|---|---|---|---|---|---|---|---|\n"
    )
    lines = [
        f"| {r['walk']} | {r['seconds']:g} | {r['size']} | {'yes' if r['distortion'] else 'no'} | "
        f"{r['frames']} ({r['decoded_frames']}) | {r['cpu_s']:.1f} | {r['wall_s']:.1f} | {r['cpu_ms_per_frame']:.1f} | "
        f"{r['mp4_kib']} | {r['corners_per_frame']:.0f} | {100 * r['lk_fb_tracked']:.0f}% |"
        for r in rows
    ]
    big = [r for r in rows if r["size"] == "640x480" and r["seconds"] == 16.0]
    verdict = (
        f"Target: a 16 s 640x480 walk well under {TARGET_S:.0f} s on one core. "
        + (
            f"Measured CPU time {min(r['cpu_s'] for r in big):.1f}-{max(r['cpu_s'] for r in big):.1f} s "
            f"(wall {min(r['wall_s'] for r in big):.1f}-{max(r['wall_s'] for r in big):.1f} s on a shared machine): "
            + ("met." if max(r["cpu_s"] for r in big) < TARGET_S / 2 else "NOT met.")
            if big
            else "(not measured in --quick mode)"
        )
    )
    info = (
        f"python {platform.python_version()}, numpy {np.__version__}, opencv {cv2.__version__}, "
        f"{platform.machine()}, {os.cpu_count()} CPUs (1 thread used), load average {os.getloadavg()[0]:.1f} "
        f"at the end; each row includes generating a new street's textures (~3 s CPU)"
    )
    table = header + "\n".join(lines) + "\n\n" + verdict + "\n\n" + info + "\n"
    sys.stdout.write("\n" + table)
    RESULTS.mkdir(parents=True, exist_ok=True)
    name = "simulator_quick" if args.quick else "simulator"
    (RESULTS / f"{name}.md").write_text("# Simulator benchmark\n\n" + table, encoding="utf-8")
    (RESULTS / f"{name}.json").write_text(json.dumps({"rows": rows, "info": info}, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
