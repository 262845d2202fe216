"""Live monitor benchmark: realtime latency and drops, hop timing, long-session memory and database growth,
and kill -9 safety of the session log.

    python benchmarks/bench_live.py [--walk normal:20,bend:10] [--long-wall-s 600] [--long-session-s 3600]

1. ``file:clip.mp4?realtime=1`` at 30 fps through the full pipeline (fast rotation estimator, indicators,
   alerts, session log): frame-to-estimate latency (grab → estimate done) p50/p99/max, dropped frames, hop
   interval on the wall clock. Targets: p99 <= 100 ms, 0 dropped, one hop per second.
2. A long accelerated session: the same clip looped without realtime pacing, until ``--long-session-s`` of
   session time or ``--long-wall-s`` of wall time: resident memory after warm-up and its growth (target
   <= 5 MB), database size per hour of session.
3. ``kill -9`` of a live session in a child process: ``PRAGMA integrity_check`` and the data lost (the last
   processed frame's time minus the newest time in the database; target <= 1 s).

Prints a table and writes benchmarks/results/live.md and live.json. The clip is simulated at 640x480.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import signal
import sqlite3
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
RESULTS = REPO / "benchmarks" / "results"


def rss_mb() -> float:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return math.nan


def make_pipeline(url: str, calib: Path, data_dir: Path, on_hop=None, on_frame=None):  # noqa: ANN001, ANN201
    from walkmon.camera.model import read_camera_yaml
    from walkmon.commands.live import CameraAwareEstimator
    from walkmon.drivers.sources import open_camera
    from walkmon.gait.live import LiveIndicatorStage
    from walkmon.live.alerts import AlertStage
    from walkmon.live.pipeline import LivePipeline
    from walkmon.live.session_log import SessionLog

    cam = read_camera_yaml(calib)
    return LivePipeline(
        open_camera(url),
        lambda src: CameraAwareEstimator(src, cam, "fast", 70.0),
        indicators=LiveIndicatorStage(),
        alerts=AlertStage(),
        session_log=SessionLog(data_dir, camera=url),
        on_hop=on_hop,
        on_frame=on_frame,
    )


def bench_realtime(clip: Path, calib: Path, work: Path) -> dict:
    latencies: list[float] = []
    hop_wall: list[float] = []
    p = make_pipeline(f"file:{clip}?realtime=1", calib, work / "rt",
                      on_hop=lambda h: hop_wall.append(time.monotonic()),
                      on_frame=lambda f: latencies.append(f.latency_ms))
    cpu0 = time.process_time()
    res = p.run()
    cpu = time.process_time() - cpu0
    lat = np.asarray(latencies)
    intervals = np.diff(hop_wall)
    return {
        "frames": res.frames, "dropped": res.dropped, "session_s": round(res.duration_s, 2),
        "wall_s": round(res.wall_s, 2), "cpu_s": round(cpu, 2),
        "cpu_share_of_one_core": round(cpu / res.wall_s, 3),
        "latency_p50_ms": round(float(np.percentile(lat, 50)), 2),
        "latency_p99_ms": round(float(np.percentile(lat, 99)), 2),
        "latency_max_ms": round(float(lat.max()), 2),
        "hops": res.hops,
        "hop_interval_mean_s": round(float(intervals.mean()), 4),
        "hop_interval_max_dev_s": round(float(np.abs(intervals - 1.0).max()), 4),
        "alerts_raised": res.alerts_raised,
    }


def bench_long(clip: Path, calib: Path, work: Path, session_s: float, wall_s: float, warmup_s: float) -> dict:
    samples: list[tuple[float, float]] = []  # (session time, RSS MB)
    holder: dict = {}

    def on_hop(h) -> None:  # noqa: ANN001
        samples.append((h.indicators.t_s, rss_mb()))
        if h.indicators.t_s >= session_s:
            holder["p"].stop("session length reached")

    data = work / "long"
    p = make_pipeline(f"file:{clip}?loop=1", calib, data, on_hop=on_hop)
    holder["p"] = p
    res = p.run(duration_s=wall_s)
    s = np.asarray(samples)
    after = s[s[:, 0] >= warmup_s]
    db = sum(f.stat().st_size for f in data.glob("walkmon.sqlite*"))
    out = {
        "session_s": round(res.duration_s, 1), "wall_s": round(res.wall_s, 1),
        "speed_x_realtime": round(res.duration_s / res.wall_s, 2), "frames": res.frames,
        "dropped": res.dropped, "end_reason": res.end_reason, "warmup_s": warmup_s,
        "db_bytes": db, "db_mb_per_hour": round(db / 2**20 / max(res.duration_s, 1e-9) * 3600, 1),
    }
    if len(after) >= 2:
        slope = np.polyfit(after[:, 0], after[:, 1], 1)[0]
        out.update({
            "rss_after_warmup_mb": round(float(after[0, 1]), 1), "rss_end_mb": round(float(after[-1, 1]), 1),
            "rss_max_after_warmup_mb": round(float(after[:, 1].max()), 1),
            "rss_growth_mb": round(float(after[-1, 1] - after[0, 1]), 2),
            "rss_growth_max_mb": round(float(after[:, 1].max() - after[0, 1]), 2),
            "rss_slope_mb_per_hour": round(float(slope * 3600), 2),
        })
    return out


_CHILD = textwrap.dedent("""
    import sys, time
    sys.path.insert(0, {bench_dir!r})
    from bench_live import make_pipeline
    from pathlib import Path
    def on_frame(f):
        sys.stdout.write(f"{{f.t_s:.6f}}\\n"); sys.stdout.flush()
    make_pipeline({url!r}, Path({calib!r}), Path({data!r}), on_frame=on_frame).run()
""")


def bench_kill9(clip: Path, calib: Path, work: Path, kill_after_s: float) -> dict:
    data = work / "kill"
    code = _CHILD.format(bench_dir=str(Path(__file__).parent), url=f"file:{clip}?realtime=1", calib=str(calib),
                         data=str(data))
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True, cwd=REPO)
    assert proc.stdout is not None
    processed: list[float] = []
    for line in proc.stdout:
        processed.append(float(line))
        if processed[-1] >= kill_after_s:
            break
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(30)
    processed += [float(x) for x in proc.stdout.read().split()]
    conn = sqlite3.connect(data / "walkmon.sqlite")
    integrity = conn.execute("PRAGMA integrity_check").fetchone()[0]
    last_db, n_db = conn.execute("SELECT MAX(t_s), COUNT(*) FROM frames").fetchone()
    n_hops = conn.execute("SELECT COUNT(*) FROM hops").fetchone()[0]
    conn.close()
    return {"killed_at_session_s": round(processed[-1], 3), "integrity_check": integrity,
            "frames_processed": len(processed), "frames_in_db": n_db, "hops_in_db": n_hops,
            "last_db_t_s": last_db, "data_lost_s": round(processed[-1] - (last_db or 0.0), 3)}


def markdown(r: dict) -> str:
    rt, lg, k9 = r["realtime"], r["long"], r["kill9"]
    extrapolated = lg["session_s"] < 3600
    ok = lambda c: "met" if c else "NOT met"  # noqa: E731
    lines = [
        "# Live monitor benchmark (`benchmarks/bench_live.py`)",
        "",
        f"Machine: {r['machine']}; load average at start {r['loadavg']}. Clip: {r['clip']}.",
        "",
        "| measure | target | result | |",
        "|---|---|---|---|",
        f"| frame-to-estimate latency p99, file realtime 30 fps | <= 100 ms | {rt['latency_p99_ms']} ms "
        f"(p50 {rt['latency_p50_ms']}, max {rt['latency_max_ms']}) | {ok(rt['latency_p99_ms'] <= 100)} |",
        f"| dropped frames, file realtime 30 fps | 0 | {rt['dropped']} of {rt['frames'] + rt['dropped']} | "
        f"{ok(rt['dropped'] == 0)} |",
        f"| hops on time (wall-clock interval) | 1 per 1 s | {rt['hops']} hops, mean {rt['hop_interval_mean_s']} s, "
        f"worst deviation {rt['hop_interval_max_dev_s']} s | {ok(rt['hop_interval_max_dev_s'] <= 0.1)} |",
        f"| CPU used by the realtime pipeline | - | {rt['cpu_share_of_one_core'] * 100:.0f} % of one core | |",
        f"| long session (looped, accelerated) | 1 h | {lg['session_s']:.0f} s of session in {lg['wall_s']:.0f} s wall "
        f"({lg['speed_x_realtime']}x realtime){' - shorter than 1 h: extrapolated' if extrapolated else ''} | |",
        f"| RSS growth after {lg['warmup_s']:.0f} s warm-up | <= 5 MB | {lg.get('rss_growth_mb')} MB "
        f"(max {lg.get('rss_growth_max_mb')} MB; {lg.get('rss_after_warmup_mb')} -> {lg.get('rss_end_mb')} MB; "
        f"slope {lg.get('rss_slope_mb_per_hour')} MB/h) | {ok((lg.get('rss_growth_max_mb') or 99) <= 5)} |",
        f"| database size per hour of session | report | {lg['db_mb_per_hour']} MB/h | |",
        f"| kill -9 mid-session: integrity_check | ok | {k9['integrity_check']} | {ok(k9['integrity_check'] == 'ok')} |",
        f"| kill -9: data lost | <= 1 s | {k9['data_lost_s']} s ({k9['frames_processed'] - k9['frames_in_db']} frames) "
        f"| {ok(k9['data_lost_s'] <= 1.0)} |",
        "",
    ]
    if extrapolated:
        lines.append(f"The long session ran {lg['session_s']:.0f} s of session time (wall-clock limit); memory growth "
                     f"per hour is the fitted slope above, the database size per hour is scaled linearly.")
    return "\n".join(lines) + "\n"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--walk", default="normal:20,bend:10")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--long-session-s", type=float, default=3600.0)
    ap.add_argument("--long-wall-s", type=float, default=600.0)
    ap.add_argument("--warmup-s", type=float, default=120.0)
    ap.add_argument("--kill-after-s", type=float, default=6.0)
    ap.add_argument("--work", help="working folder (default: a temporary one)")
    ap.add_argument("--tag", default="", help="suffix for the result files")
    ap.add_argument("--clip-dir", help="folder for the simulated clip (default: inside the working folder)")
    args = ap.parse_args()
    import cv2

    cv2.setNumThreads(1)
    from walkmon.simulate import simulate

    with tempfile.TemporaryDirectory(prefix="walkmon-bench-live-") as tmp:
        work = Path(args.work or tmp)
        t0 = time.monotonic()
        sim = simulate(Path(args.clip_dir) if args.clip_dir else work / "clip", walk=args.walk, seed=7,
                       width=args.width, height=args.height)
        print(f"simulated {sim.duration_s:.0f} s at {args.width}x{args.height} in {time.monotonic() - t0:.0f} s",
              flush=True)
        r = {"machine": f"{platform.machine()}, {os.cpu_count()} CPUs, Python {platform.python_version()}",
             "loadavg": " ".join(f"{v:.2f}" for v in os.getloadavg()),
             "clip": f"{args.walk} (+2 s standing at both ends), {args.width}x{args.height}, 30 fps"}
        r["realtime"] = bench_realtime(sim.video_path, sim.camera_path, work)
        print("realtime:", r["realtime"], flush=True)
        r["kill9"] = bench_kill9(sim.video_path, sim.camera_path, work, args.kill_after_s)
        print("kill -9:", r["kill9"], flush=True)
        r["long"] = bench_long(sim.video_path, sim.camera_path, work, args.long_session_s, args.long_wall_s,
                               args.warmup_s)
        print("long:", r["long"], flush=True)
    RESULTS.mkdir(parents=True, exist_ok=True)
    md = markdown(r)
    (RESULTS / f"live{args.tag}.md").write_text(md)
    (RESULTS / f"live{args.tag}.json").write_text(json.dumps(r, indent=2) + "\n")
    print(md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
