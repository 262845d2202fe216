"""``walkmon live`` as a process: status line per hop, SIGUSR1 re-calibrates, SIGINT closes cleanly with a summary."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

import pytest

from walkmon.live.session_log import list_sessions, open_database, read_session_table


@pytest.mark.slow  # real time: runs for the wall-clock seconds it simulates
def test_signals_recalibrate_and_stop_cleanly(tmp_path: Path) -> None:
    cmd = [sys.executable, "-m", "walkmon.commands.cli", "live", "--camera",
           "sim:stand:4,normal:60?width=160&height=120&realtime=1&seed=1", "--data-dir", str(tmp_path),
           "--status", "lines"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stderr is not None
    lines = []
    try:
        for line in proc.stderr:
            lines.append(line)
            n = sum(ln.startswith("t=") for ln in lines)
            if n == 3:
                proc.send_signal(signal.SIGUSR1)  # still standing until t = 6 s: a new upright reference
            if n == 7:
                proc.send_signal(signal.SIGINT)
                break
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, "".join(lines) + err
    assert "Traceback" not in err
    assert "signal SIGINT" in out and out.startswith("session 1:")
    status = [ln for ln in lines if ln.startswith("t=")]
    assert "fps" in status[0] and "drop=" in status[0] and "not_walking" in status[0]
    (s,) = list_sessions(tmp_path)
    assert s.end_reason == "signal SIGINT" and s.ended_utc
    conn = open_database(tmp_path, create=False)
    cal = read_session_table(conn, s.id, "calibrations")
    conn.close()
    assert cal["reason"] == ["start", "request"] and 3.0 < cal["t_s"][1] <= 6.1


def test_a_camera_that_does_not_open_says_so_with_an_imu_too(tmp_path: Path, capsys) -> None:
    # The IMU opened first, its reader thread made but not started, then the camera failed: the session's closing
    # joined the unstarted thread and the camera's one-line error became "unexpected error: RuntimeError('cannot
    # join thread before it is started')".
    import numpy as np

    from walkmon.commands.cli import main

    imu = tmp_path / "imu.csv"
    t = np.arange(0.0, 2.0, 0.01)
    rows = [f"{v:.2f},0,0,0,0,-9.81,0" for v in t]
    imu.write_text("t,gx,gy,gz,ax,ay,az\n" + "\n".join(rows) + "\n")
    rc = main(["live", "--camera", "v4l2:/dev/walkmon-no-such-camera", "--imu", f"file:{imu}",
               "--data-dir", str(tmp_path / "d"), "--status", "lines"])
    err = capsys.readouterr().err
    assert rc == 2
    assert "no such device /dev/walkmon-no-such-camera" in err
    assert "RuntimeError" not in err and "Traceback" not in err
