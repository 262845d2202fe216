"""End to end: a rendered simulated session (stand, normal walk, bend, normal walk, stand) through ``walkmon live``
with the real rotation estimator. The bend alert comes within delay + 3 s and clears after straightening, no alert
while standing, and the live angles are the offline estimator's angles on the same frames.
"""

from __future__ import annotations

import sqlite3
from pathlib import Path

import numpy as np
import pytest

from walkmon.commands.cli import main
from walkmon.live.session_log import list_sessions, open_database, read_session_table

pytestmark = pytest.mark.slow  # a rendered 22 s session through walkmon live (still run by CI)

BEND_START_S = 2.0 + 5.0  # standing 2 s, normal 5 s
BEND_END_S = BEND_START_S + 8.0


@pytest.fixture(scope="module")
def bend_clip(tmp_path_factory: pytest.TempPathFactory):  # noqa: ANN201
    from walkmon.simulate import simulate

    return simulate(tmp_path_factory.mktemp("clip"), walk="normal:5,bend:8,normal:5", seed=1, width=320, height=240)


@pytest.fixture(scope="module")
def live_session(bend_clip, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, int]:  # noqa: ANN001
    data = tmp_path_factory.mktemp("data")
    rc = main(["live", "--camera", f"file:{bend_clip.video_path}", "--calib", str(bend_clip.camera_path),
               "--data-dir", str(data), "--status", "none"])
    assert rc == 0
    (s,) = list_sessions(data)
    return data, s.id


def test_bend_alert_in_time_and_cleared_none_while_standing(live_session: tuple[Path, int], bend_clip) -> None:  # noqa: ANN001
    data, sid = live_session
    conn = open_database(data, create=False)
    alerts = read_session_table(conn, sid, "alerts")
    hops = read_session_table(conn, sid, "hops")
    conn.close()
    events = list(zip(alerts["kind"], alerts["state"], alerts["t_s"], strict=True))
    assert [(k, s) for k, s, _ in events] == [("lean_forward", "raised"), ("lean_forward", "cleared")], events
    assert BEND_START_S + 5.0 <= events[0][2] <= BEND_START_S + 5.0 + 3.0
    assert BEND_END_S < events[1][2] <= bend_clip.duration_s
    label = dict(zip(hops["t_s"], hops["label"], strict=True))
    assert label[1.0] == "not_walking" and label[2.0] == "not_walking"  # standing: no walking, no alert
    assert label[BEND_END_S - 1.0] == "bend"
    # 4 s into the walk: normal, or unclassified while fewer than 6 steps are seen (the one classifier's minimum)
    assert label[BEND_START_S - 1.0] in ("normal", "unclassified")


def test_live_angles_equal_offline_estimator_angles(live_session: tuple[Path, int], bend_clip) -> None:  # noqa: ANN001
    from walkmon.camera.model import read_camera_yaml
    from walkmon.drivers.video_file import VideoFile
    from walkmon.rotation import RotationEstimator

    est = RotationEstimator(read_camera_yaml(bend_clip.camera_path))
    with VideoFile(bend_clip.video_path) as video:
        offline = np.array([[t, *est.push(frame, t).angles_deg] for t, frame in video])
    data, sid = live_session
    conn = open_database(data, create=False)
    live = read_session_table(conn, sid, "frames")
    conn.close()
    live_arr = np.column_stack([live["t_s"], live["pitch"], live["yaw"], live["roll"]])
    assert live_arr.shape == offline.shape == (bend_clip.n_frames, 4)
    np.testing.assert_allclose(live_arr, offline, atol=1e-9)


def test_live_estimate_tracks_the_truth(live_session: tuple[Path, int], bend_clip) -> None:  # noqa: ANN001
    from walkmon.tables import read_table

    truth = read_table(bend_clip.truth_path, ("t", "pitch", "yaw", "roll"))
    data, sid = live_session
    conn = open_database(data, create=False)
    live = read_session_table(conn, sid, "frames")
    conn.close()
    err = np.asarray(live["pitch"]) - truth["pitch"]
    assert np.max(np.abs(err)) < 2.0  # the posture change (~17 deg) is followed, not lost


def test_sim_source_live_session_closes_cleanly_at_its_end(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rc = main(["live", "--camera", "sim:normal:1?width=160&height=120&realtime=0&seed=2", "--data-dir",
               str(tmp_path), "--status", "none"])
    assert rc == 0
    out = capsys.readouterr().out
    assert "end of stream" in out and "0 dropped" in out
    (s,) = list_sessions(tmp_path)
    assert s.n_frames == 150 and s.end_reason.startswith("end of stream")  # 1 s walk + 2 x 2 s standing
    conn = sqlite3.connect(tmp_path / "walkmon.sqlite")
    assert conn.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    conn.close()


def test_secrets_of_the_config_are_neither_stored_nor_served(tmp_path: Path,
                                                           capsys: pytest.CaptureFixture[str]) -> None:
    """User review: an apprise URL's password, a hook's token argument and the dashboard token were copied into
    the session record and served by the loopback dashboard (which asks no token)."""
    from walkmon.serve.store import Store

    cfg = tmp_path / "walkmon.toml"
    cfg.write_text('[sinks]\napprise_urls = ["json://alice:s3cretPASS@127.0.0.1:9/"]\n'
                   'hook_command = ["/usr/bin/true", "--token", "HOOKSECRET42"]\n'
                   '[serve]\ntoken = "supersecrettoken123"\n', encoding="utf-8")
    cfg.chmod(0o600)
    rc = main(["live", "--config", str(cfg), "--camera", "sim:normal:1?width=160&height=120&realtime=0&seed=2",
               "--data-dir", str(tmp_path / "data"), "--status", "none"])
    assert rc == 0, capsys.readouterr().err
    raw = (tmp_path / "data" / "walkmon.sqlite").read_bytes()
    conn = sqlite3.connect(tmp_path / "data" / "walkmon.sqlite")
    stored = conn.execute("SELECT config_json FROM sessions").fetchone()[0]
    conn.close()
    for secret in ("s3cretPASS", "alice", "HOOKSECRET42", "supersecrettoken123"):
        assert secret not in stored and secret.encode() not in raw
    assert '"json://' in stored and "/usr/bin/true" in stored  # what was configured, without its keys
    # a session recorded before (its secrets in the database) is served without them
    conn = sqlite3.connect(tmp_path / "data" / "walkmon.sqlite")
    with conn:
        conn.execute("UPDATE sessions SET config_json = ?",
                     ('{"serve": {"token": "supersecrettoken123"}, "sinks": {"apprise_urls": ["tgram://BOT99/1"]}}',))
    conn.close()
    _, record = Store(tmp_path / "data").session(1)
    text = str(record["config"])
    assert "supersecrettoken123" not in text and "BOT99" not in text
