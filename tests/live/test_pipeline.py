"""The live pipeline on scripted walks: alerts in time, clean close on end of stream, reconnection, drops.

These tests drive the pipeline with the simulator's gait model (ground-truth orientation) through a test
double of the rotation estimator that returns the true angles, so they check the threads, the indicator and
alert stages and the session log independently of image processing. The end-to-end test on rendered video
with the real estimator is in test_end_to_end.py.
"""

from __future__ import annotations

import sqlite3
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from walkmon.drivers.camera_base import CameraSource
from walkmon.gait.live import LiveIndicatorStage
from walkmon.live.alerts import AlertSettings, AlertStage
from walkmon.live.pipeline import LivePipeline
from walkmon.live.session_log import (
    SessionLog,
    list_sessions,
    open_database,
    read_session_table,
)
from walkmon.simulate.gait import GaitModel

FPS = 30.0
TINY = np.zeros((4, 4), np.uint8)


def make_pipeline(source: CameraSource, estimator: object, data_dir: Path, **kw: object) -> LivePipeline:
    return LivePipeline(
        source,
        lambda _src: estimator,
        indicators=LiveIndicatorStage(),
        alerts=AlertStage(AlertSettings(delay_s=5.0)),
        session_log=SessionLog(data_dir, camera=source.url),
        **kw,
    )


@pytest.fixture(scope="module")
def bend_model() -> GaitModel:
    # standing 0-2 s, normal 2-10 s, bend 10-22 s, normal 22-30 s, standing 30-32 s
    return GaitModel("normal:8,bend:12,normal:8", seed=3)


def test_bend_alert_within_delay_plus_3s_cleared_after_straightening_none_while_standing(
    bend_model: GaitModel, tmp_path: Path, GaitSource, TruthEstimator
) -> None:
    hops = []
    p = make_pipeline(GaitSource(bend_model), TruthEstimator(bend_model), tmp_path, on_hop=hops.append)
    res = p.run()
    assert res.end_reason.startswith("end of stream")
    events = [e for h in hops for e in h.events]
    lean = [(e.state, e.t_s) for e in events if e.kind == "lean_forward"]
    assert [s for s, _ in lean] == ["raised", "cleared"], events
    assert 10.0 + 5.0 <= lean[0][1] <= 10.0 + 5.0 + 3.0  # the bend begins at 10 s
    assert 22.0 < lean[1][1] <= 30.0  # cleared after straightening, before the final stance
    assert all(e.kind == "lean_forward" for e in events), events  # nothing else on a normal walk
    standing = [h for h in hops if h.indicators.t_s < 2.0]
    assert standing and all(not h.indicators.walking and not h.active_alerts for h in standing)
    labels = {round(h.indicators.t_s): h.indicators.label for h in hops}
    assert labels[20] == "bend" and labels[9] == "normal"
    # the session is in the database with its frames, hops and alerts
    conn = open_database(tmp_path, create=False)
    frames = read_session_table(conn, res.session_id, "frames")
    assert len(frames["t_s"]) == res.frames == int(bend_model.duration_s * FPS) + 1
    assert np.allclose(frames["pitch"], bend_model.truth_angles_deg(np.asarray(frames["t_s"]))[:, 0], atol=1e-6)
    alerts = read_session_table(conn, res.session_id, "alerts")
    assert alerts["state"] == ["raised", "cleared"]
    cal = read_session_table(conn, res.session_id, "calibrations")
    assert cal["reason"] == ["start"] and cal["t_s"][0] <= 2.1
    conn.close()


def test_source_ending_mid_stream_closes_the_session_with_its_data(bend_model: GaitModel, tmp_path: Path, GaitSource, TruthEstimator) -> None:
    src = GaitSource(bend_model, stop_after_s=6.0)
    res = make_pipeline(src, TruthEstimator(bend_model), tmp_path).run()
    assert res.end_reason.startswith("end of stream") and res.frames == src.produced == 181
    (s,) = list_sessions(tmp_path)
    assert s.ended_utc and s.n_frames == 181 and s.n_hops == res.hops >= 5
    assert s.duration_s == pytest.approx(6.0)


@pytest.mark.slow  # real time: runs for the wall-clock seconds it simulates
def test_stop_from_another_thread_ends_a_realtime_session_cleanly(bend_model: GaitModel, tmp_path: Path, GaitSource, TruthEstimator) -> None:
    hop_seen = threading.Event()
    p = make_pipeline(GaitSource(bend_model, realtime=True), TruthEstimator(bend_model), tmp_path,
                      on_hop=lambda h: hop_seen.set())
    threading.Thread(target=lambda: hop_seen.wait(20) and p.stop("test stop"), daemon=True).start()
    res = p.run()
    assert res.end_reason == "test stop"
    assert 0 < res.frames < bend_model.duration_s * FPS
    assert list_sessions(tmp_path)[0].end_reason == "test stop"


@pytest.mark.slow  # real time: runs for the wall-clock seconds it simulates
def test_slow_consumer_drops_oldest_frames_and_counts_them(bend_model: GaitModel, tmp_path: Path, GaitSource, TruthEstimator) -> None:
    """A 30 fps realtime source and a 25 ms-per-frame... no: a 60 ms-per-frame estimator: about half is dropped."""
    src = GaitSource(bend_model, stop_after_s=3.0, realtime=True)
    res = make_pipeline(src, TruthEstimator(bend_model, delay_s=0.06), tmp_path).run()
    assert res.dropped > 0
    assert res.frames + res.dropped == src.produced  # every frame processed or counted as dropped
    conn = open_database(tmp_path, create=False)
    t = np.asarray(read_session_table(conn, res.session_id, "frames")["t_s"])
    conn.close()
    assert np.all(np.diff(t) > 0) and t[-1] == pytest.approx(3.0)  # in order, and the newest frame was kept
    assert list_sessions(tmp_path)[0].n_dropped == res.dropped


def test_reconnectable_source_is_reopened_with_backoff(bend_model: GaitModel, tmp_path: Path, TruthEstimator, FlakySource) -> None:
    from walkmon.live.config import PipelineSettings

    src = FlakySource(bend_model)
    p = make_pipeline(src, TruthEstimator(bend_model), tmp_path,
                      settings=PipelineSettings(reconnect_initial_s=0.01, reconnect_max_s=0.05))
    res = p.run()
    assert res.reconnects == 1 and src.failed_reopens == 2 and src.opens == 4
    assert res.frames == src.produced == int(4 * FPS) + 1 - 5
    assert res.end_reason.startswith("end of stream")


def test_a_failing_thread_is_reported_not_silent(bend_model: GaitModel, tmp_path: Path,
                                                 caplog: pytest.LogCaptureFixture, TruthEstimator, BrokenSource) -> None:
    from walkmon.errors import WalkmonError

    p = make_pipeline(BrokenSource(bend_model), TruthEstimator(bend_model), tmp_path)
    with pytest.raises(WalkmonError, match="driver bug"):
        p.run()
    assert any("grabber thread failed" in r.message for r in caplog.records)
    (s,) = list_sessions(tmp_path)
    assert s.end_reason.startswith("error") and s.n_frames == 10
    assert sqlite3.connect(tmp_path / "walkmon.sqlite").execute("PRAGMA integrity_check").fetchone()[0] == "ok"


def test_imu_samples_are_logged_with_the_session(bend_model: GaitModel, tmp_path: Path, GaitSource, TruthEstimator) -> None:
    from walkmon.drivers.sources import open_imu

    imu_csv = tmp_path / "imu.csv"
    t = np.arange(400) / 200.0
    rows = "\n".join(f"{ti:.3f},0.01,{0.001 * i},0,0,-9.81,0" for i, ti in enumerate(t))
    imu_csv.write_text("t,gx,gy,gz,ax,ay,az\n" + rows + "\n")
    src = GaitSource(bend_model, stop_after_s=2.0)
    res = make_pipeline(src, TruthEstimator(bend_model), tmp_path, imu_source=open_imu(f"file:{imu_csv}")).run()
    assert res.imu_samples == 400 and res.imu_overflows == 0
    conn = open_database(tmp_path, create=False)
    imu = read_session_table(conn, res.session_id, "imu")
    conn.close()
    assert np.allclose(imu["t_s"], t) and np.allclose(imu["gy"], 0.001 * np.arange(400)) and set(imu["ay"]) == {-9.81}


class SlowCommitLog(SessionLog):
    """A session log whose commits take 300 ms (an SD card's fsync on a bad day)."""

    def flush(self) -> None:
        time.sleep(0.3)
        super().flush()


@pytest.mark.slow  # real time: runs for the wall-clock seconds it simulates
def test_slow_database_commits_do_not_stall_frames(bend_model: GaitModel, tmp_path: Path, GaitSource, TruthEstimator) -> None:
    src = GaitSource(bend_model, stop_after_s=3.0, realtime=True)
    p = LivePipeline(src, lambda _s: TruthEstimator(bend_model), indicators=LiveIndicatorStage(),
                     alerts=AlertStage(), session_log=SlowCommitLog(tmp_path, flush_interval_s=0.2))
    res = p.run()
    assert res.dropped == 0 and res.frames == src.produced  # a 300 ms stall would overflow the 4-frame queue
    assert list_sessions(tmp_path)[0].n_frames == res.frames


class FailingLog(SessionLog):
    def add_frame(self, *args: object, **kw: object) -> None:
        if self.n_frames == 20:
            raise sqlite3.OperationalError("database or disk is full")
        super().add_frame(*args, **kw)  # type: ignore[arg-type]


@pytest.mark.slow  # real time: runs for the wall-clock seconds it simulates
def test_a_failing_session_log_ends_the_session_with_the_error(bend_model: GaitModel, tmp_path: Path, GaitSource, TruthEstimator) -> None:
    from walkmon.errors import WalkmonError

    p = LivePipeline(GaitSource(bend_model, stop_after_s=5.0, realtime=True), lambda _s: TruthEstimator(bend_model),
                     indicators=LiveIndicatorStage(), alerts=AlertStage(), session_log=FailingLog(tmp_path))
    with pytest.raises(WalkmonError, match="disk is full"):
        p.run()
    (s,) = list_sessions(tmp_path)
    assert s.end_reason.startswith("error") and s.n_frames == 20


def test_a_session_ending_while_an_alert_is_raised_clears_it_in_the_log(
    bend_model: GaitModel, tmp_path: Path, GaitSource, TruthEstimator
) -> None:
    from walkmon.live.sinks import AlertSinks, SinkSettings

    # the stream stops at 19 s, mid-bend (bend 10-22 s): the lean-forward alert (raised ~15 s) is still on
    delivered = []

    class Sinks(AlertSinks):
        def deliver(self, events: list) -> None:
            delivered.extend(events)

    res = make_pipeline(GaitSource(bend_model, stop_after_s=19.0), TruthEstimator(bend_model), tmp_path,
                        sinks=Sinks(SinkSettings(terminal=False))).run()
    conn = open_database(tmp_path, create=False)
    alerts = read_session_table(conn, res.session_id, "alerts")
    conn.close()
    assert alerts["kind"] == ["lean_forward", "lean_forward"]
    assert alerts["state"] == ["raised", "cleared"]
    assert alerts["message"][1] == "session ended: alert cleared"
    assert alerts["t_s"][1] == pytest.approx(19.0, abs=1 / FPS)  # at the last frame
    assert [(e.kind, e.state) for e in delivered] == [("lean_forward", "raised"), ("lean_forward", "cleared")]
