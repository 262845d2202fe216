"""Dashboard benchmark: history page time on 100 hours of sessions, server CPU while idle, live-page latency.

    nice python benchmarks/bench_serve.py [--hours 100] [--idle-s 30] [--no-browser]

1. A session database of ``--hours`` hours of live sessions (30 min each, spread over 60 days, one hop per
   second with a walking/bent/upright pattern and a few alerts; per-frame rows are not written: the history
   reads hops and alerts only, as with ``[session] log_frames = false``). Times: ``/history?since=90d`` (the page
   with its trend figure and per-day table) in-process and through uvicorn over HTTP, ``/api/history``,
   ``/sessions``. Target: the history page <= 1 s.
2. ``walkmon serve`` as its own process on that database: CPU time over ``--idle-s`` seconds with no client
   (target <= 2 % of one core), and with one client polling /api/live twice a second as the live page does.
3. Live latency: a writer logs one hop per second through the real SessionLog (flush every 0.5 s, as
   ``walkmon live``); headless Chromium shows the live page; the time from each hop's add_hop to the page
   showing it (``window.walkmonHops``) is the latency. Target: every hop within 2 s. Without Chromium/selenium
   (or with --no-browser) a Python poller that behaves like the page stands in (then said in the table).

Prints a table and writes benchmarks/results/serve.md and serve.json.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
RESULTS = REPO / "benchmarks" / "results"
SESSION_S = 1800


def build_db(data: Path, hours: float) -> dict[str, int]:
    """Sessions of 30 min over 60 days through the real schema (open_database), hops at 1 Hz."""
    from walkmon.live.session_log import open_database

    conn = open_database(data)
    n_sessions = int(round(hours * 3600 / SESSION_S))
    t0 = dt.datetime(2026, 1, 1, 8, 0, tzinfo=dt.UTC)
    now = dt.datetime.now(dt.UTC)
    n_hops = n_alerts = 0
    with conn:
        for k in range(n_sessions):
            start = now - dt.timedelta(days=60) + dt.timedelta(hours=k * 60 * 24 / n_sessions)
            cur = conn.execute(
                "INSERT INTO sessions (kind, started_utc, ended_utc, end_reason, camera, config_json, person) "
                "VALUES ('live', ?, ?, 'stopped', 'bench', '{}', ?)",
                (start.isoformat(timespec="milliseconds"), (start + dt.timedelta(seconds=SESSION_S)).isoformat(
                    timespec="milliseconds"), ("Ann", "Bob")[k % 2]))
            sid = cur.lastrowid
            rows = []
            for i in range(SESSION_S):
                walking = (i // 60) % 5 != 4
                bent = (i // 300) % 3 == 2
                rows.append((sid, float(i + 1), int(walking), 100.0 + (k % 7), 2.0, 3.0, 2.0,
                             -12.0 if bent else -1.0, 0.0, 0.5, -12.0 if bent else -1.0, 0.0, 0.5, 0.15,
                             "bend" if bent else "normal" if walking else "not_walking", "{}"))
            conn.executemany("INSERT INTO hops VALUES (" + ",".join("?" * 16) + ")", rows)
            n_hops += len(rows)
            alerts = [(sid, 610.0 + 900 * j, "lean_forward", "raised", 12.0, 10.0, "leaning forward") for j in range(2)]
            conn.executemany("INSERT INTO alerts VALUES (?,?,?,?,?,?,?)", alerts)
            n_alerts += len(alerts)
    conn.close()
    return {"sessions": n_sessions, "hops": n_hops, "alerts": n_alerts, "t0": int(t0.timestamp())}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def timed(fn, n: int = 5) -> tuple[float, float]:  # noqa: ANN001
    times = []
    for _ in range(n):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), max(times)


def wait_up(url: str, timeout_s: float = 30) -> None:
    import httpx

    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            httpx.get(url, timeout=2)
            return
        except httpx.HTTPError:
            time.sleep(0.2)
    raise SystemExit(f"server at {url} did not come up")


def live_latency(data: Path, port: int, use_browser: bool, n_hops: int = 20) -> tuple[list[float], str]:
    """Latency from add_hop (writer, flush 0.5 s as walkmon live) to the hop shown (browser) or seen (poller)."""
    from walkmon.gait.live import LiveIndicators
    from walkmon.live.session_log import SessionLog

    log = SessionLog(data, kind="live", camera="bench", flush_interval_s=0.5, person="Ann")
    written: dict[float, float] = {}
    stop = threading.Event()

    def writer() -> None:
        t = 0.0
        next_at = time.monotonic() + 2.0
        while not stop.is_set() and len(written) < n_hops + 4:
            now = time.monotonic()
            if now >= next_at:
                t += 1.0
                ind = LiveIndicators(t, 8.0, 240, True, 1.0, 100.0, (2.0, 3.0, 2.0), (-t, 0.0, 0.0), (-t, 0.0, 0.0),
                                     0.1, "normal", (), True)
                log.add_hop(ind)
                written[t] = time.time()
                next_at += 1.0
            log.maybe_flush()
            time.sleep(0.05)  # the session-log thread of walkmon live wakes every <= 0.1 s

    th = threading.Thread(target=writer, daemon=True)
    th.start()
    base = f"http://127.0.0.1:{port}/"
    how = ""
    shown: list[tuple[float, float]] = []
    try:
        drv = _browser() if use_browser else None
        if drv is not None:
            how = "headless Chromium (selenium), the live page"
            try:
                drv.get(base)
                time.sleep(n_hops + 3)
                shown = [(h["t_s"], h["shown_ms"] / 1000.0) for h in drv.execute_script("return window.walkmonHops;")
                         if h["session"] == log.session_id]
            finally:
                drv.quit()
        else:
            import httpx

            how = "a Python poller of /api/live every 0.5 s (no browser available)"
            last = None
            deadline = time.monotonic() + n_hops + 3
            while time.monotonic() < deadline:
                d = httpx.get(base + "api/live", timeout=5).json()
                h = d.get("hop")
                if d.get("running") and h and h["t_s"] != last:
                    last = h["t_s"]
                    shown.append((h["t_s"], time.time()))
                time.sleep(0.5)
    finally:
        stop.set()
        th.join(5)
        log.close("stopped")
    return [s - written[t] for t, s in shown if t in written], how


def _browser():  # noqa: ANN202
    chromium, driver = shutil.which("chromium") or shutil.which("chromium-browser"), shutil.which("chromedriver")
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        return None
    if not chromium or not driver:
        return None
    opts = webdriver.ChromeOptions()
    opts.binary_location = chromium
    for flag in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync",
                 "--disable-dev-shm-usage", f"--user-data-dir={tempfile.mkdtemp(prefix='walkmon-bench-chromium-')}"):
        opts.add_argument(flag)
    return webdriver.Chrome(service=Service(executable_path=driver), options=opts)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hours", type=float, default=100.0)
    ap.add_argument("--idle-s", type=float, default=30.0)
    ap.add_argument("--no-browser", action="store_true")
    args = ap.parse_args()
    sys.path.insert(0, str(REPO))
    import httpx
    from starlette.testclient import TestClient

    from walkmon.serve.app import create_app

    rows: list[tuple[str, str, str, str]] = []
    out: dict[str, object] = {"machine": f"{platform.machine()}, {os.cpu_count()} CPUs, Python "
                                         f"{platform.python_version()}", "load_avg": os.getloadavg()}
    with tempfile.TemporaryDirectory(prefix="walkmon-bench-serve-") as tmp:
        data = Path(tmp)
        t = time.perf_counter()
        info = build_db(data, args.hours)
        size_mb = (data / "walkmon.sqlite").stat().st_size / 1e6
        out["database"] = {**info, "hours": args.hours, "size_mb": round(size_mb, 1),
                           "build_s": round(time.perf_counter() - t, 1)}
        print(f"database: {info['sessions']} sessions, {info['hops']} hops, {size_mb:.0f} MB")
        def cold() -> None:  # a fresh app: nothing cached yet (the first request after the server starts)
            assert TestClient(create_app(data), base_url="http://127.0.0.1").get("/history?since=90d").status_code == 200

        med_c, worst_c = timed(cold, 3)
        cpu0 = time.process_time()
        cold()
        cpu_cold = time.process_time() - cpu0  # CPU seconds of one cold render: what the load cannot inflate
        out["history_page_cold_cpu_s"] = cpu_cold
        client = TestClient(create_app(data), base_url="http://127.0.0.1")
        client.get("/history?since=90d")
        med, worst = timed(lambda: client.get("/history?since=90d"))
        out["history_page_in_process_s"] = {"cold": [med_c, worst_c], "warm": [med, worst]}
        rows.append(("history page, 100 h of sessions, first request (in-process)", "<= 1 s",
                     f"{med_c:.3f} s (max {worst_c:.3f}); CPU {cpu_cold:.3f} s",
                     "met" if worst_c <= 1.0 else "NOT met (wall)" if cpu_cold <= 1.0 else "NOT met"))
        rows.append(("history page, later requests (ended sessions' statistics cached)", "<= 1 s",
                     f"{med:.3f} s (max {worst:.3f})", "met" if worst <= 1.0 else "NOT met"))
        med_api, _ = timed(lambda: client.get("/api/history?since=90d"))
        med_list, _ = timed(lambda: client.get("/sessions"), 3)
        out["api_history_s"], out["sessions_page_s"] = med_api, med_list
        port = free_port()
        env = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
        proc = subprocess.Popen([sys.executable, "-m", "walkmon", "serve", "--data-dir", str(data), "--port",
                                 str(port)], env=env, stderr=subprocess.DEVNULL)
        try:
            base = f"http://127.0.0.1:{port}/"
            wait_up(base + "api/live")
            time.sleep(3.0)  # walkmon serve computes the ended sessions' statistics in the background at start
            t = time.perf_counter()
            httpx.get(base + "history?since=90d", timeout=30)
            first_http = time.perf_counter() - t
            med_http, worst_http = timed(lambda: httpx.get(base + "history?since=90d", timeout=30))
            out["history_page_http_s"] = {"first": first_http, "later": [med_http, worst_http]}
            rows.append(("history page over HTTP (walkmon serve, 3 s after its start): first / later", "<= 1 s",
                         f"{first_http:.3f} s / {med_http:.3f} s (max {worst_http:.3f})",
                         "met" if max(first_http, worst_http) <= 1.0 else "NOT met"))
            rows.append(("/api/history, /sessions (200 rows)", "-", f"{med_api:.3f} s, {med_list:.3f} s", ""))
            time.sleep(2.0)
            c0, w0 = cpu_s(proc.pid), time.monotonic()
            time.sleep(args.idle_s)
            idle = 100 * (cpu_s(proc.pid) - c0) / (time.monotonic() - w0)
            out["idle_cpu_pct"] = idle
            rows.append((f"server CPU, idle ({args.idle_s:.0f} s, no client)", "<= 2 % of a core", f"{idle:.2f} %",
                         "met" if idle <= 2 else "NOT met"))
            c0, w0 = cpu_s(proc.pid), time.monotonic()
            with httpx.Client() as hc:
                while time.monotonic() - w0 < args.idle_s:
                    hc.get(base + "api/live", timeout=5)
                    time.sleep(0.5)
            polled = 100 * (cpu_s(proc.pid) - c0) / (time.monotonic() - w0)
            out["polled_cpu_pct"] = polled
            rows.append(("server CPU, one live page open (2 polls/s)", "-", f"{polled:.2f} %", ""))
            lat, how = live_latency(data, port, not args.no_browser)
            out["live_latency_s"], out["live_latency_how"] = lat, how
            if lat:
                rows.append((f"live page: hop written -> shown ({how}; {len(lat)} hops)", "<= 2 s",
                             f"median {statistics.median(lat):.2f} s, max {max(lat):.2f} s",
                             "met" if max(lat) <= 2.0 else "NOT met"))
            else:
                rows.append(("live page latency", "<= 2 s", "no hop shown", "NOT met"))
        finally:
            proc.terminate()
            proc.wait(10)
    md = ["# Dashboard benchmark (`benchmarks/bench_serve.py`)", "",
          f"Machine: {out['machine']}; load average at start {' '.join(f'{v:.2f}' for v in out['load_avg'])}. "
          f"Database: {out['database']['sessions']} sessions of 30 min ({args.hours:g} h), "
          f"{out['database']['hops']} hops, {out['database']['alerts']} alerts, {out['database']['size_mb']} MB "
          "(no per-frame rows: the history reads hops and alerts).", "",
          "| measure | target | result | |", "|---|---|---|---|"]
    md += [f"| {a} | {b} | {c} | {d} |" for a, b, c, d in rows]
    text = "\n".join(md) + "\n"
    print(text)
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "serve.md").write_text(text)
    (RESULTS / "serve.json").write_text(json.dumps(out, indent=1, default=float) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
