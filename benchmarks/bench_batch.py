"""Batch benchmark: throughput of ``walkmon.batch`` with 2 local Dask workers against 1, and the scheduler's cost.

    nice -n 10 python benchmarks/bench_batch.py                 # 8 simulated walks, 1 and 2 workers
    nice -n 10 python benchmarks/bench_batch.py --repeat 2      # each configuration twice (alternating)

Inputs: ``--n`` (8) simulated chest-camera walks (4 walk types x seeds, ``--seconds`` 10 s, ``--size`` 320x240,
30 fps, camera-only), rendered once and cached under ``--cache`` in a folder keyed by the walkmon version, a
hash of the simulator's source and the parameters.

Measured, in this order (``--repeat`` times, the cluster sizes alternating so that a change in the machine's
load hits both):

* ``serial``: the same analyses in this process, one after the other (:func:`walkmon.batching.worker.run_analysis`,
  OpenCV single-threaded as on a worker): the work itself without Dask;
* ``1 worker`` / ``2 workers``: ``walkmon.batch`` on a LocalCluster of that many single-threaded worker
  processes, started and warmed (modules imported) before the clock starts; the start-up is reported apart.

Figures: wall time, recordings per minute, speed-up of 2 workers over 1 (target >= 1.8 on 8 recordings, 2
cores), the concurrency (sum of the tasks' wall times / batch wall time: 2 means both workers were analysing all
the time), the CPU share of the tasks (their CPU time / their wall time: below 1 when other processes took the
cores), and the scheduler overhead per recording = (1-worker batch wall - sum of its task walls) / n:
submission, scheduling, result transfer and the manifest, which a 1-worker batch pays on top of the analyses
(input hashing and moving the outputs into place are inside the tasks); the difference to a plain serial loop is
printed too. The load average (1 min) is printed beside each run: wall-time ratios are only the program's when
the load is below the number of cores. Results: benchmarks/results/batch.md and batch.json.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import shutil
import sys
import tempfile
import time
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"
WALKS = ("normal", "bend", "left_shoulder_down", "right_foot_drag")
TARGET_SPEEDUP = 1.8


def _simulator_key() -> str:
    import walkmon  # noqa: PLC0415

    src = Path(walkmon.__file__).resolve().parent / "simulate"
    h = hashlib.sha256()
    for p in sorted(src.glob("*.py")):
        h.update(p.name.encode())
        h.update(p.read_bytes())
    return f"walkmon{walkmon.__version__}-sim{h.hexdigest()[:10]}"


def inputs(n: int, seconds: float, size: tuple[int, int], cache: Path) -> Path:
    """``n`` walks as ``cache/<key>/walkNN.mp4`` (+ camera.yaml), simulated once."""
    from walkmon.simulate import simulate  # noqa: PLC0415

    w, h = size
    folder = cache / f"{_simulator_key()}_{seconds:g}s_{w}x{h}_30fps"
    folder.mkdir(parents=True, exist_ok=True)
    for i in range(n):
        target = folder / f"walk{i:02d}.mp4"
        if target.is_file():
            continue
        walk, seed = WALKS[i % len(WALKS)], 100 + i
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            r = simulate(Path(tmp) / "s", walk=walk, seconds=seconds, seed=seed, width=w, height=h, fps=30.0)
            shutil.copy(Path(tmp) / "s" / "camera.yaml", folder / "camera.yaml")
            shutil.copy(r.video_path, target.with_suffix(".tmp"))
            os.replace(target.with_suffix(".tmp"), target)
            sys.stderr.write(f"  simulated {target.name} ({walk}, seed {seed}) in {time.perf_counter() - t0:.0f} s\n")
    return folder


def _load() -> float:
    return round(os.getloadavg()[0], 2)


def _warm() -> str:
    """Import what an analysis imports (run on each worker before timing)."""
    import cv2  # noqa: F401, PLC0415
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot  # noqa: F401, PLC0415

    import walkmon.batching.worker  # noqa: F401, PLC0415
    import walkmon.commands.analyze  # noqa: F401, PLC0415
    import walkmon.gait.report  # noqa: F401, PLC0415

    return "ok"


def serial(folder: Path, videos: list[Path], work: Path) -> dict:
    import cv2  # noqa: PLC0415

    from walkmon.batching.worker import run_analysis  # noqa: PLC0415

    cv2.setNumThreads(1)
    opts = {"method": "fast", "mode": "walkmon", "baseline": None, "imu_filter": "vqf", "imu_extrinsics": "identity",
            "imu_calib": None}
    _warm()
    load0 = _load()
    t0 = time.perf_counter()
    c0 = time.process_time()
    for v in videos:
        run_analysis(str(v), None, str(folder / "camera.yaml"), opts, work / "serial" / v.stem)
    wall = time.perf_counter() - t0
    return {"config": "serial", "workers": 0, "wall_s": wall, "task_s_sum": wall, "task_cpu_s_sum": time.process_time() - c0,
            "load_before": load0, "load_after": _load()}


def batched(folder: Path, n_workers: int, work: Path, run: int) -> dict:
    import dask  # noqa: PLC0415
    import distributed  # noqa: PLC0415

    import walkmon  # noqa: PLC0415

    load0 = _load()
    t0 = time.perf_counter()
    import logging  # noqa: PLC0415

    logging.getLogger("distributed").setLevel(logging.ERROR)  # "worker still alive after 4 s" at shutdown
    with dask.config.set({"logging.distributed": "error"}):
        cluster = distributed.LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                                           dashboard_address="127.0.0.1:0", host="127.0.0.1")
    client = distributed.Client(cluster)
    client.run(_warm)
    startup = time.perf_counter() - t0
    try:
        t1 = time.perf_counter()
        summary = walkmon.batch([folder], work / f"w{n_workers}-{run}", client=client)
        wall = time.perf_counter() - t1
    finally:
        client.close()
        cluster.close()
    ok = int((summary["status"] == "ok").sum())
    return {"config": f"{n_workers} worker{'s' if n_workers > 1 else ''}", "workers": n_workers, "wall_s": wall,
            "startup_s": startup, "ok": ok, "task_s_sum": float(summary["analysis_s"].sum()),
            "task_cpu_s_sum": float(summary["cpu_s"].sum()), "load_before": load0, "load_after": _load()}


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--n", type=int, default=8, help="recordings (default 8)")
    p.add_argument("--seconds", type=float, default=10.0, help="length of each walk (default 10 s)")
    p.add_argument("--size", default="320x240", help="video size (default 320x240)")
    p.add_argument("--repeat", type=int, default=1, help="measure each configuration this many times (default 1)")
    p.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "walkmon-bench-batch",
                   help="where the simulated inputs are kept")
    p.add_argument("--out", type=Path, default=RESULTS / "batch", help="results path without extension")
    args = p.parse_args()
    w, h = (int(x) for x in args.size.lower().split("x"))
    folder = inputs(args.n, args.seconds, (w, h), args.cache)
    videos = sorted(folder.glob("walk*.mp4"))[: args.n]
    rows = []
    with tempfile.TemporaryDirectory(prefix="walkmon-bench-batch-") as tmp:
        work = Path(tmp)
        for r in range(args.repeat):
            rows.append(serial(folder, videos, work))
            order = (1, 2) if r % 2 == 0 else (2, 1)
            for n_workers in order:
                rows.append(batched(folder, n_workers, work, r))
                sys.stderr.write(f"  {rows[-1]['config']}: {rows[-1]['wall_s']:.1f} s (load {rows[-1]['load_before']})\n")

    def best(config: str) -> dict:
        return min((x for x in rows if x["config"] == config), key=lambda x: x["wall_s"])

    s, one, two = best("serial"), best("1 worker"), best("2 workers")
    n = len(videos)
    speedup = one["wall_s"] / two["wall_s"]
    overhead = (one["wall_s"] - one["task_s_sum"]) / n
    overhead_vs_serial = (one["wall_s"] - s["wall_s"]) / n
    lines = [
        f"# walkmon batch: {n} recordings, 1 vs 2 local Dask workers",
        "",
        f"Inputs: {n} simulated walks ({', '.join(WALKS)}; seeds 100-{99 + n}), {args.seconds:g} s at {w}x{h}, 30 fps, "
        "camera-only, fast method. Each configuration measured "
        f"{args.repeat} time(s); cluster start-up (processes + imports) not included in the wall time.",
        "",
        "concurrency = sum of the tasks' wall times / batch wall time (how many recordings were in analysis at once);",
        "CPU share = sum of the tasks' CPU times / sum of their wall times (1.0 when nothing else wants the cores).",
        "",
        "| configuration | wall (s) | recordings/min | start-up (s) | task wall sum (s) | task CPU sum (s) "
        "| concurrency | CPU share | load avg before -> after |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for x in rows:
        lines.append(
            f"| {x['config']} | {x['wall_s']:.2f} | {60 * n / x['wall_s']:.1f} | "
            f"{x.get('startup_s', float('nan')):.1f} | {x['task_s_sum']:.1f} | {x['task_cpu_s_sum']:.1f} | "
            f"{x['task_s_sum'] / x['wall_s']:.2f} | {x['task_cpu_s_sum'] / x['task_s_sum']:.2f} | "
            f"{x['load_before']} -> {x['load_after']} |"
        )
    verdict = "met" if speedup >= TARGET_SPEEDUP else "NOT met"
    lines += [
        "",
        f"- speed-up, 2 workers over 1 (best wall times): **{speedup:.2f}x** (target >= {TARGET_SPEEDUP}x: {verdict}); "
        f"the machine has {os.cpu_count()} cores.",
        f"- concurrency with 2 workers: {two['task_s_sum'] / two['wall_s']:.2f} (2 = both workers busy all the time).",
        f"- scheduler overhead per recording, 1 worker: (batch wall - sum of task walls) / {n} = **{overhead:.3f} s** "
        "(submission, scheduling, result transfer, manifest; the input hashing and the move of the outputs are "
        f"inside the tasks); against the serial loop: (batch wall - serial wall) / {n} = {overhead_vs_serial:.2f} s.",
        f"- every batch row ok: {all(x.get('ok', n) == n for x in rows)}.",
        f"- Python {platform.python_version()}, {platform.machine()}, {os.cpu_count()} cores. Load average (1 min) "
        "per run: above the core count other processes shared the cores, the CPU share drops and wall-time "
        "ratios measure the machine, not the program.",
    ]
    text = "\n".join(lines) + "\n"
    sys.stdout.write(text)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.with_suffix(".md").write_text(text, encoding="utf-8")
    doc = {"n": n, "seconds": args.seconds, "size": [w, h], "repeat": args.repeat, "runs": rows,
           "speedup_2_over_1": speedup, "overhead_per_recording_s": overhead,
           "overhead_vs_serial_per_recording_s": overhead_vs_serial, "target_speedup": TARGET_SPEEDUP,
           "cpu_count": os.cpu_count(), "python": platform.python_version()}
    args.out.with_suffix(".json").write_text(json.dumps(doc, indent=1), encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
