"""Fixtures of the dashboard tests: session databases written through the real SessionLog, a dashboard server
on a loopback port (stopped at teardown), and headless Chromium driven by selenium (skipped, with the reason,
where Chromium, chromedriver or selenium cannot be found)."""

from __future__ import annotations

import os
import shutil
import socket
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from walkmon.gait.live import LiveIndicators
from walkmon.live.alerts import AlertEvent
from walkmon.live.session_log import SessionLog

REPO = Path(__file__).resolve().parents[2]


def hop(t: float, *, walking: bool = True, pitch: float = 0.0, roll: float = 0.0, cadence: float = 100.0,
        label: str = "normal", asym: float = 0.1) -> LiveIndicators:
    return LiveIndicators(t_s=t, window_s=8.0, n_samples=240, walking=walking, gait_rms_deg=1.0 if walking else 0.0,
                          cadence_spm=cadence if walking else float("nan"), swing_deg=(2.0, 3.0, 2.0),
                          inclination_deg=(pitch, 0.0, roll), posture_deg=(pitch, 0.0, roll), step_asymmetry=asym,
                          label=label if walking else "not_walking", reasons=(), calibrated=True)


@pytest.fixture
def make_hop() -> Callable[..., LiveIndicators]:
    """make_hop(t, walking=True, pitch=0, roll=0, cadence=100, label="normal", asym=0.1): one hop's indicators."""
    return hop


@pytest.fixture
def write_session() -> Callable[..., int]:
    """write_session(data_dir, hops, alerts=(), person="", started_utc=None, end=True) -> session id."""

    def write(data_dir: Path, hops: list[LiveIndicators], alerts: tuple[AlertEvent, ...] = (), person: str = "",
              started_utc: str | None = None, end: bool = True) -> int:
        log = SessionLog(data_dir, kind="live", camera="test", person=person, flush_interval_s=0.5)
        for h in hops:
            log.add_hop(h)
        for a in alerts:
            log.add_alert(a)
        log.flush()
        if started_utc is not None:
            log._conn.execute("UPDATE sessions SET started_utc=? WHERE id=?", (started_utc, log.session_id))
            log._conn.commit()
        sid = log.session_id
        if end:
            log.close("complete")
        else:
            log._conn.close()  # a session cut off: no end time
        return sid

    return write


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture
def dashboard() -> Iterator[Callable[..., str]]:
    """dashboard(data_dir, token="") -> base URL of a running server on 127.0.0.1 (stopped at teardown)."""
    pytest.importorskip("uvicorn")
    from walkmon.serve.server import DashboardThread

    started: list[Any] = []

    def start(data_dir: Path, token: str = "") -> str:
        port = free_port()
        th = DashboardThread(data_dir, "127.0.0.1", port, token).start()
        started.append(th)
        deadline = time.monotonic() + 15
        while not th.server.started:
            if time.monotonic() > deadline:
                pytest.fail("the dashboard server did not start within 15 s")
            time.sleep(0.05)
        return f"http://127.0.0.1:{port}"

    yield start
    for th in started:
        th.stop()


def _find(*names: str) -> str | None:
    for n in names:
        p = shutil.which(n)
        if p:
            return p
    return None


CHROMIUM_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--disable-dev-shm-usage", "--window-size=1100,1300")


@pytest.fixture
def browser(tmp_path: Path) -> Iterator[Any]:
    """A headless Chromium (selenium + chromedriver) with a fresh profile; quit at teardown."""
    webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is not installed (test extra)")
    chromium = _find("chromium", "chromium-browser", "google-chrome")
    driver_path = _find("chromedriver", "chromium-driver")
    if chromium is None or driver_path is None:
        pytest.skip("headless Chromium and chromedriver are not installed (apt-get install chromium chromium-driver)")
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    opts.binary_location = chromium
    for flag in CHROMIUM_FLAGS:
        opts.add_argument(flag)
    opts.add_argument(f"--user-data-dir={tmp_path / 'chromium-profile'}")
    drv = webdriver.Chrome(service=Service(executable_path=driver_path), options=opts)
    drv.set_page_load_timeout(30)
    drv.set_script_timeout(30)
    try:
        yield drv
    finally:
        drv.quit()


@pytest.fixture
def screenshots(tmp_path: Path) -> Path:
    """Folder for the page screenshots: $WALKMON_SCREENSHOTS when set (kept as artefacts), else tmp."""
    out = Path(os.environ.get("WALKMON_SCREENSHOTS") or tmp_path / "screens")
    out.mkdir(parents=True, exist_ok=True)
    return out


def axe_script() -> str | None:
    """axe-core's axe.min.js: $WALKMON_AXE_JS, or node_modules/axe-core under the repository or .ci/."""
    candidates = [os.environ.get("WALKMON_AXE_JS", ""), REPO / "node_modules/axe-core/axe.min.js",
                  REPO / ".ci/node_modules/axe-core/axe.min.js", Path("/usr/share/nodejs/axe-core/axe.min.js")]
    for c in candidates:
        if c and Path(c).is_file():
            return Path(c).read_text(encoding="utf-8")
    return None


@pytest.fixture
def axe() -> str:
    text = axe_script()
    if text is None:
        pytest.skip("axe-core not found: npm install --prefix .ci axe-core (or set WALKMON_AXE_JS)")
    return text


@pytest.fixture
def python_cmd() -> list[str]:
    return [sys.executable, "-m", "walkmon"]
