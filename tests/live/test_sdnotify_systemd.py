"""The systemd unit (systemd-analyze verify), deploy scripts, and the sd_notify protocol on a socket we own."""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
import threading
import uuid
from pathlib import Path

import pytest

from walkmon.gait.live import LiveIndicatorStage
from walkmon.live.alerts import AlertStage
from walkmon.live.pipeline import LivePipeline
from walkmon.live.sdnotify import Notifier, notify_socket_address
from walkmon.live.session_log import SessionLog

REPO = Path(__file__).resolve().parents[2]
UNIT = REPO / "systemd" / "walkmon.service"


def test_unit_has_the_service_contract(unit_settings: dict[str, list[str]]) -> None:
    s = unit_settings
    assert s["Type"] == ["notify"] and int(s["WatchdogSec"][0]) > 0
    assert s["Restart"] == ["on-failure"] and s["User"] == ["walkmon"] and s["StateDirectory"] == ["walkmon"]
    (exec_start,) = s["ExecStart"]
    assert " live " in exec_start and "--config /etc/walkmon/walkmon.toml" in exec_start
    assert "--data-dir /var/lib/walkmon" in exec_start
    # a config or input walkmon refuses (exit 2) is no crash to restart every 5 s (user review)
    assert s["RestartPreventExitStatus"] == ["2"]


def test_the_network_drop_in_opens_loopback_for_the_dashboard() -> None:
    """The unit allows no IP socket, so the dashboard thread ([serve] enabled) and apprise alerts cannot work under
    it (user review); systemd/walkmon-network.conf adds IPv4/6 sockets and loopback, and install.sh installs it
    when the config enables either. The config file is installed readable by root and the service only (it may
    hold the dashboard token and apprise credentials; it was 0644)."""
    text = (REPO / "systemd" / "walkmon-network.conf").read_text()
    lines = [ln.strip() for ln in text.splitlines() if ln.strip() and not ln.startswith("#")]
    assert lines[0] == "[Service]"
    (families,) = [ln for ln in lines if ln.startswith("RestrictAddressFamilies=")]
    assert {"AF_UNIX", "AF_NETLINK", "AF_INET", "AF_INET6"} == set(families.split("=", 1)[1].split())
    assert "IPAddressAllow=localhost" in lines
    install = (REPO / "deploy" / "install.sh").read_text()
    assert "systemd/walkmon-network.conf" in install and "walkmon.service.d/network.conf" in install
    assert "install -m 0640 -o root -g walkmon" in install
    assert 'install -m 0644 "$SRC_DIR/deploy/walkmon.toml"' not in install


def test_unit_passes_systemd_analyze_verify(tmp_path: Path) -> None:
    exe = shutil.which("systemd-analyze")
    if exe is None:
        pytest.skip("systemd-analyze is not installed (apt-get install systemd)")
    # verify checks that ExecStart's binary exists: point it at this environment's walkmon (or python)
    walkmon_bin = Path(sys.executable).with_name("walkmon")
    target = walkmon_bin if walkmon_bin.exists() else Path(sys.executable)
    unit = tmp_path / "walkmon.service"
    unit.write_text(UNIT.read_text().replace("/opt/walkmon/venv/bin/walkmon", str(target)))
    res = subprocess.run([exe, "verify", str(unit)], capture_output=True, text=True, timeout=60, check=False)
    problems = [ln for ln in (res.stdout + res.stderr).splitlines() if "walkmon.service" in ln or "Unknown" in ln]
    assert res.returncode == 0 and not problems, res.stdout + res.stderr


def test_deploy_scripts_parse_and_reference_the_shipped_files() -> None:
    for name in ("install.sh", "uninstall.sh"):
        script = REPO / "deploy" / name
        assert os.access(script, os.X_OK)
        subprocess.run(["sh", "-n", str(script)], check=True, timeout=30)
    install = (REPO / "deploy" / "install.sh").read_text()
    for shipped in ("deploy/walkmon.toml", "deploy/99-walkmon.rules", "systemd/walkmon.service"):
        assert shipped in install and (REPO / shipped).exists()
    rules = (REPO / "deploy" / "99-walkmon.rules").read_text()
    assert 'SYMLINK+="walkmon-camera"' in rules and 'SYMLINK+="walkmon-imu"' in rules


class _Listener:
    """A NOTIFY_SOCKET owned by the test, read by a thread like systemd would."""

    def __init__(self, address: str | bytes) -> None:
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self.sock.bind(address)
        self.sock.settimeout(0.1)
        self._got: list[str] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self) -> None:
        while not self._stop.is_set():
            try:
                self._got.append(self.sock.recv(4096).decode())
            except TimeoutError:
                continue

    def messages(self) -> list[str]:
        self._stop.set()
        self._thread.join(5)
        self.sock.settimeout(0.0)
        while True:
            try:
                self._got.append(self.sock.recv(4096).decode())
            except BlockingIOError:
                break
        self.sock.close()
        return self._got


@pytest.mark.parametrize("abstract", [False, True])
def test_notifier_speaks_the_protocol_on_path_and_abstract_sockets(tmp_path: Path, abstract: bool) -> None:
    name = f"@walkmon-test-{uuid.uuid4().hex}" if abstract else str(tmp_path / "notify.sock")
    listener = _Listener(notify_socket_address(name))  # type: ignore[arg-type]
    n = Notifier({"NOTIFY_SOCKET": name, "WATCHDOG_USEC": "2000000"})
    assert n.enabled and n.watchdog_period_s == 2.0
    assert n.ready("monitoring")
    assert not n.ready()  # only once
    assert n.watchdog(now_s=100.0)
    assert not n.watchdog(now_s=100.5)  # rate-limited to half the period
    assert n.watchdog(now_s=101.1)
    n.stopping()
    assert listener.messages() == ["READY=1\nSTATUS=monitoring", "WATCHDOG=1", "WATCHDOG=1", "STOPPING=1"]
    n.close()


def test_notifier_is_a_no_op_outside_systemd() -> None:
    n = Notifier({})
    assert not n.enabled and not n.ready() and not n.watchdog()
    assert notify_socket_address("relative/path") is None


@pytest.mark.slow  # real time: runs for the wall-clock seconds it simulates
def test_pipeline_sends_ready_after_first_frame_and_watchdog_from_its_loop(tmp_path: Path, GaitSource, TruthEstimator) -> None:

    from walkmon.simulate.gait import GaitModel  # noqa: PLC0415

    sock_path = str(tmp_path / "n.sock")
    listener = _Listener(sock_path)
    model = GaitModel("normal:2", seed=1)
    notifier = Notifier({"NOTIFY_SOCKET": sock_path, "WATCHDOG_USEC": "20000"})  # ping at most every 10 ms
    LivePipeline(GaitSource(model, stop_after_s=0.5, realtime=True), lambda _s: TruthEstimator(model),
                 indicators=LiveIndicatorStage(), alerts=AlertStage(), session_log=SessionLog(tmp_path),
                 notifier=notifier).run()
    msgs = listener.messages()
    assert msgs[0].startswith("STATUS=waiting for frames")
    ready = [i for i, m in enumerate(msgs) if m.startswith("READY=1")]
    assert len(ready) == 1 and msgs.count("WATCHDOG=1") >= 5
    assert msgs[-1] == "STOPPING=1"


@pytest.mark.slow  # real time: runs for the wall-clock seconds it simulates
def test_a_hung_camera_stops_the_watchdog_pings(tmp_path: Path, caplog: pytest.LogCaptureFixture, GaitSource, TruthEstimator) -> None:
    """The grabber stuck inside a driver call: the loop keeps running but stops WATCHDOG=1 (systemd restarts)."""
    from walkmon.drivers.camera_base import Frame  # noqa: PLC0415
    from walkmon.live.config import PipelineSettings  # noqa: PLC0415
    from walkmon.simulate.gait import GaitModel  # noqa: PLC0415

    release = threading.Event()
    stalled = threading.Event()

    class HangingSource(GaitSource):
        def _read(self) -> Frame:
            if self._i == 15:
                stalled.set()
                release.wait(20)  # a driver call that does not return
                raise SourceDisconnected("test: gone")
            return super()._read()

    from walkmon.errors import SourceDisconnected  # noqa: PLC0415

    sock_path = str(tmp_path / "n.sock")
    listener = _Listener(sock_path)
    model = GaitModel("normal:2", seed=1)
    p = LivePipeline(HangingSource(model, realtime=True), lambda _s: TruthEstimator(model),
                     indicators=LiveIndicatorStage(), alerts=AlertStage(), session_log=SessionLog(tmp_path),
                     settings=PipelineSettings(frame_timeout_s=0.2),
                     notifier=Notifier({"NOTIFY_SOCKET": sock_path, "WATCHDOG_USEC": "20000"}))

    def supervisor() -> None:
        stalled.wait(20)
        while not any("watchdog pings stopped" in r.message for r in caplog.records):
            if p._stop.wait(0.05):  # noqa: SLF001
                return
        release.set()

    threading.Thread(target=supervisor, daemon=True).start()
    res = p.run()
    msgs = listener.messages()
    assert res.frames == 15 and res.end_reason.startswith("end of stream")
    k = msgs.index("STATUS=stalled: no frame for 0.2 s")
    assert "WATCHDOG=1" in msgs[:k] and "WATCHDOG=1" not in msgs[k:]
