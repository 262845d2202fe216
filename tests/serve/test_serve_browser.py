"""The dashboard in a real browser: headless Chromium loads the live page while ``walkmon live`` runs a simulated
walk (normal, then bent forward) and must show the new hops, the bend and the lean-forward alert as they happen;
then every page is loaded, screenshotted and (when axe-core is available) checked for contrast and labels."""

from __future__ import annotations

import json
import re
import sqlite3
import statistics
import subprocess
import threading
import time
from pathlib import Path
from typing import Any

import pytest

pytestmark = pytest.mark.slow

SIM = "sim:normal:9,bend:16?width=160&height=120&fps=15"
_T_LINE = re.compile(r"^t=\s*([0-9.]+)s ")


class _StatusReader(threading.Thread):
    """Reads ``walkmon live --status lines`` from its stderr and notes when each hop's line arrived (wall clock)."""

    def __init__(self, proc: subprocess.Popen[str]) -> None:
        super().__init__(daemon=True)
        self.proc, self.hop_wall, self.lines = proc, {}, []

    def run(self) -> None:
        assert self.proc.stderr is not None
        for line in self.proc.stderr:
            now = time.time()
            self.lines.append(line.rstrip())
            m = _T_LINE.match(line.strip())
            if m:
                self.hop_wall.setdefault(round(float(m.group(1)), 1), now)


def _wait(cond: Any, timeout_s: float, what: str) -> Any:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        v = cond()
        if v:
            return v
        time.sleep(0.1)
    pytest.fail(f"timed out after {timeout_s:.0f} s waiting for {what}")


def run_live_page(tmp_path: Path, python_cmd: list[str], dashboard: Any, browser: Any, shots: Path) -> dict[str, Any]:
    """Run the simulated live session with the live page open; return the hops shown, their latencies, texts."""
    data = tmp_path / "data"
    proc = subprocess.Popen([*python_cmd, "live", "--camera", SIM, "--data-dir", str(data), "--status", "lines",
                             "--person", "Ann"], stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    reader = _StatusReader(proc)
    reader.start()
    try:
        _wait(lambda: (data / "walkmon.sqlite").exists(), 30, "the session database")
        base = dashboard(data)
        browser.get(base + "/")
        seen_texts: set[tuple[str, str]] = set()
        alert_text = ""
        deadline = time.monotonic() + 90
        while proc.poll() is None and time.monotonic() < deadline:
            label = browser.find_element("id", "label").text
            pitch = browser.find_element("id", "pitch").text
            seen_texts.add((label, pitch))
            alerts = browser.find_element("id", "alerts").text
            if "lean-forward" in alerts and not alert_text:
                alert_text = alerts
                browser.save_screenshot(str(shots / "live.png"))
            time.sleep(0.2)
        # the page polls twice a second: give it a few polls to see that the session ended
        end_wait = time.monotonic() + 5
        final_state = browser.find_element("id", "state").text
        while "No session is running" not in final_state and time.monotonic() < end_wait:
            time.sleep(0.2)
            final_state = browser.find_element("id", "state").text
        shown = browser.execute_script("return window.walkmonHops;")
        if not alert_text:
            browser.save_screenshot(str(shots / "live.png"))
    finally:
        if proc.poll() is None:
            proc.terminate()
        proc.wait(30)
        reader.join(5)
    assert proc.returncode == 0, "\n".join(reader.lines[-20:])
    latencies = [h["shown_ms"] / 1000.0 - reader.hop_wall[round(h["t_s"], 1)]
                 for h in shown if round(h["t_s"], 1) in reader.hop_wall]
    return {"data": data, "base": base, "shown": shown, "latencies": latencies, "texts": seen_texts,
            "alert_text": alert_text, "final_state": final_state, "hop_lines": reader.hop_wall}


def test_live_page_follows_a_running_session_and_every_page_renders(
        tmp_path: Path, python_cmd: list[str], dashboard: Any, browser: Any, screenshots: Path) -> None:
    r = run_live_page(tmp_path, python_cmd, dashboard, browser, screenshots)
    shown, lat = r["shown"], r["latencies"]
    # the page followed the session without a reload: most of its hops appeared, in order
    assert len(shown) >= 0.7 * len(r["hop_lines"]), (len(shown), len(r["hop_lines"]))
    ts = [h["t_s"] for h in shown]
    assert ts == sorted(ts) and len(set(ts)) == len(ts)
    # what it showed is what walkmon live logged for that hop (the database it wrote, read independently)
    conn = sqlite3.connect(r["data"] / "walkmon.sqlite")
    db = {round(t, 3): (p, lab) for t, p, lab in conn.execute("SELECT t_s, pitch_posture, label FROM hops")}
    person = conn.execute("SELECT person FROM sessions").fetchone()[0]
    conn.close()
    assert person == "Ann"
    for h in shown:
        p, lab = db[round(h["t_s"], 3)]
        assert h["label"] == lab and (p is None or abs(h["pitch"] - p) < 0.01)
    # and it follows the simulated truth: upright at first, then bent forward about 17 deg with the alert raised
    pitches = [h["pitch"] for h in shown if h["pitch"] is not None]
    assert max(pitches) > -5 and min(pitches) < -12
    assert any(label == "bent forward" for label, _ in r["texts"])
    assert "lean-forward alert" in r["alert_text"]
    assert "No session is running" in r["final_state"]
    # each new hop reached the page within 2 s of walkmon live printing it (issue target; 90th percentile, so
    # that one scheduling hiccup of a loaded CI machine does not fail the run: the benchmark reports the max)
    assert lat, "no latency measured"
    assert statistics.quantiles(lat, n=10)[-1] <= 2.0, sorted(lat)
    # every page renders in the browser, without a script error
    sid = int(shown[0]["session"])
    for name, path in (("sessions", "/sessions"), ("session", f"/sessions/{sid}"), ("history", "/history"),
                       ("report", f"/sessions/{sid}/report")):
        browser.get(r["base"] + path)
        assert browser.find_element("tag name", "h1").text
        errors = [e for e in browser.get_log("browser") if e.get("level") == "SEVERE"]
        assert not errors, errors
        browser.save_screenshot(str(screenshots / f"{name}.png"))
    browser.get(r["base"] + f"/sessions/{sid}")
    assert "Ann" in browser.find_element("tag name", "h1").text
    assert browser.find_elements("css selector", "svg polyline"), "the timeline has no curve"
    (screenshots / "latency.json").write_text(json.dumps({"latencies_s": lat}))


def test_every_page_passes_axe(tmp_path: Path, write_session: Any, make_hop: Any, dashboard: Any, browser: Any,
                               axe: str) -> None:
    from walkmon.live.alerts import AlertEvent

    mk = make_hop
    data = tmp_path / "data"
    hops = [mk(float(t), pitch=-15.0 if t > 20 else -1.0) for t in range(1, 41)]
    sid = write_session(data, hops, (AlertEvent(30.0, "lean_forward", "raised", 15.0, 10.0, "leaning forward"),),
                        person="Ann")
    write_session(data, [mk(float(t)) for t in range(1, 30)], end=False)
    base = dashboard(data)
    for path in ("/", "/sessions", f"/sessions/{sid}", "/history"):
        browser.get(base + path)
        time.sleep(0.8)  # the live page's first poll
        browser.execute_script(axe)
        result = browser.execute_async_script(
            "const done = arguments[arguments.length - 1];"
            "axe.run(document, {runOnly: {type: 'tag', values: ['wcag2a', 'wcag2aa']}})"
            ".then(r => done(r.violations.map(v => [v.id, v.impact, v.nodes.length, v.nodes[0].html])))"
            ".catch(e => done([['axe-error', String(e), 0, '']]));")
        assert result == [], (path, result)
