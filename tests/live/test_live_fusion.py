"""Camera-IMU fusion in the live monitor (issue 6).

End to end: ``walkmon live`` on the simulator's rendered walk with the simulator's imu.csv of the same script and
seed gives the same angles as the offline ``walkmon analyze VIDEO --imu imu.csv`` and gravity-referenced
pitch_abs/roll_abs close to the truth. Stage level (:class:`walkmon.imu.fusion.LiveFusion`) on synthetic data: frames
before any IMU sample, IMU gaps and an IMU that stops are camera-only, counted, and the output stays continuous.
Pipeline level (truth estimator, as test_pipeline.py): an IMU that disconnects mid-session. Plus the
session-log schema migration and the ``[imu]`` config keys.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import sqlite3
from pathlib import Path

import numpy as np
import pytest

from walkmon.commands.cli import main
from walkmon.consts import (
    angles_deg_from_rotation,
    gravity_angles_deg_from_gravity,
    rotation_from_angles_deg,
)
from walkmon.errors import ConfigError, SourceDisconnected
from walkmon.imu.attitude import ImuFilterSettings
from walkmon.imu.fusion import FusionSettings, LiveFusion, LiveFusionSettings
from walkmon.live.config import ImuSettings, config_from_dict

WALK, SEED, W, H = "normal:6", 0, 320, 240


def _read_csv(path: Path) -> dict[str, np.ndarray]:
    with path.open(newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    out = {}
    for k in rows[0]:
        try:
            out[k] = np.array([float(r[k]) for r in rows])
        except ValueError:
            continue
    return out


@pytest.fixture(scope="module")
def live_vs_offline(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    """One simulated walk, its offline fused analysis and a live session (sim: camera + file: IMU) of it."""
    root = tmp_path_factory.mktemp("live_imu")
    sim = root / "sim"
    assert main(["simulate", "--walk", WALK, "--seed", str(SEED), "--width", str(W), "--height", str(H),
                 "--out", str(sim)]) == 0
    assert main(["analyze", str(sim / "video.mp4"), "--calib", str(sim / "camera.yaml"), "--imu",
                 str(sim / "imu.csv"), "--out", str(root / "offline"), "--no-progress"]) == 0
    url = f"sim:{WALK}?seed={SEED}&width={W}&height={H}&realtime=0"
    assert main(["live", "--camera", url, "--imu", f"file:{sim / 'imu.csv'}", "--data-dir", str(root / "db"),
                 "--status", "none"]) == 0
    assert main(["sessions", "export", "1", "--data-dir", str(root / "db"), "--out", str(root / "export")]) == 0
    return {"root": root, "sim": sim, "offline": _read_csv(root / "offline" / "angles.csv"),
            "live": _read_csv(root / "export" / "angles.csv"), "truth": _read_csv(sim / "truth.csv")}


def test_live_fused_angles_match_the_offline_fusion_of_the_same_walk(live_vs_offline: dict) -> None:
    off, live = live_vs_offline["offline"], live_vs_offline["live"]
    assert len(live["t"]) == len(off["t"]) == 300
    np.testing.assert_allclose(live["t"], off["t"], atol=1e-3)
    fused = live["fused"] == 1
    assert fused.sum() >= 250  # all but the 1 s IMU warm-up at the start
    assert not fused[:25].any()
    for k in ("pitch", "yaw", "roll"):
        d = np.abs(live[k] - off[k])
        assert d.max() < 0.06, (k, d.max())  # measured: 0.015 / 0.014 / 0.006 deg
    for k in ("pitch_abs", "roll_abs"):
        assert np.all(np.isnan(live[k][~fused]))
        d = np.abs(live[k][fused] - off[k][fused])
        assert d.max() < 0.1, (k, d.max())  # measured: 0.025 / 0.018 deg


def test_imu_filter_in_the_live_config_is_the_analyze_option(live_vs_offline: dict) -> None:
    """``[imu] filter = "eskf"`` in the live config and ``analyze --imu-filter eskf`` give the same angles on the same
    recording, and the key reaches the live fusion."""
    root, sim = live_vs_offline["root"], live_vs_offline["sim"]
    cfg = root / "eskf.toml"
    cfg.write_text('[imu]\nfilter = "eskf"\n', encoding="utf-8")
    assert main(["analyze", str(sim / "video.mp4"), "--calib", str(sim / "camera.yaml"), "--imu", str(sim / "imu.csv"),
                 "--imu-filter", "eskf", "--out", str(root / "offline_eskf"), "--no-progress"]) == 0
    url = f"sim:{WALK}?seed={SEED}&width={W}&height={H}&realtime=0"
    assert main(["live", "--config", str(cfg), "--camera", url, "--imu", f"file:{sim / 'imu.csv'}",
                 "--data-dir", str(root / "db_eskf"), "--status", "none"]) == 0
    assert main(["sessions", "export", "1", "--data-dir", str(root / "db_eskf"), "--out", str(root / "export_eskf")]) == 0
    off = _read_csv(root / "offline_eskf" / "angles.csv")
    live = _read_csv(root / "export_eskf" / "angles.csv")
    fused = live["fused"] == 1
    assert fused.sum() >= 250
    for k in ("pitch", "yaw", "roll"):
        assert np.abs(live[k] - off[k]).max() < 0.06, k
    for k in ("pitch_abs", "roll_abs"):
        assert np.abs(live[k][fused] - off[k][fused]).max() < 0.1, k
    assert json.loads((root / "offline_eskf" / "imu.json").read_text())["imu_filter"] == "eskf"
    # the key reaches the live fusion (on a 6 s walk the core's slow gravity barely moves the fused angles)
    from walkmon.commands.live import live_fusion_settings

    cfg_eskf = config_from_dict({"imu": {"filter": "eskf", "tau_acc_s": 5.0}})
    assert live_fusion_settings(cfg_eskf.imu).fusion.imu_filter == ImuFilterSettings(filter="eskf", tau_acc_s=5.0)
    assert live_fusion_settings(ImuSettings()).fusion.imu_filter == ImuFilterSettings()


def test_live_fused_angles_are_close_to_the_truth(live_vs_offline: dict) -> None:
    live, tr = live_vs_offline["live"], live_vs_offline["truth"]
    truth = np.column_stack([np.interp(live["t"], tr["t"], tr[k]) for k in ("pitch", "yaw", "roll")])
    err = np.abs(np.column_stack([live[k] for k in ("pitch", "yaw", "roll")]) - truth)
    assert err.max() < 0.15, err.max(axis=0)  # measured 0.033 / 0.034 / 0.029 deg
    R = rotation_from_angles_deg(truth[:, 0], truth[:, 1], truth[:, 2])
    truth_abs = gravity_angles_deg_from_gravity(np.einsum("nji,j->ni", R, [0.0, 1.0, 0.0]))
    fused = live["fused"] == 1
    abs_err = np.abs(np.column_stack([live["pitch_abs"], live["roll_abs"]])[fused] - truth_abs[fused])
    assert abs_err.max() < 0.5, abs_err.max(axis=0)  # the simulated accelerometer bias alone is ~0.2 deg


def test_live_session_records_the_fusion_counters(live_vs_offline: dict) -> None:
    root = live_vs_offline["root"]
    meta = json.loads((root / "export" / "session.json").read_text())["meta"]
    fusion = meta["fusion"]
    assert fusion["frames_fused"] + sum(fusion["frames_camera_only"].values()) == 300
    assert fusion["frames_camera_only"]["warmup"] == 300 - fusion["frames_fused"]
    assert fusion["filter_restarts"] == 0 and fusion["imu_dropped"] == 0 and fusion["gravity_resets"] == 0
    conn = sqlite3.connect(str(root / "db" / "walkmon.sqlite"))
    try:
        hop_json = [json.loads(r[0]) for r in conn.execute("SELECT json FROM hops ORDER BY t_s")]
    finally:
        conn.close()
    assert hop_json and all("fusion" in h for h in hop_json)
    assert hop_json[-1]["fusion"]["mode"] == "fused"


# ------------------------------------------------------------------------------------ stage, synthetic data

RATE_DPS = 20.0  # yaw rate about the camera's y (down) axis from MOVE_S on: gravity stays (0, -9.81, 0)
MOVE_S = 1.5  # still before (a constant rate from the start would look like a still sensor's gyro bias)


def _yaw_deg(t: np.ndarray | float) -> np.ndarray:
    return RATE_DPS * np.maximum(np.asarray(t, dtype=float) - MOVE_S, 0.0)


def _rate_rad_s(t: float) -> float:
    return float(np.radians(RATE_DPS)) if t > MOVE_S else 0.0


def _imu(t: float) -> tuple[float, tuple[float, float, float], tuple[float, float, float]]:
    return t, (0.0, _rate_rad_s(t), 0.0), (0.0, -9.81, 0.0)


def _visual(t: float) -> np.ndarray:
    return rotation_from_angles_deg(0.0, float(_yaw_deg(t)), 0.0)


def _run_stage(stage: LiveFusion, imu_times: np.ndarray, frame_times: np.ndarray) -> list:
    out, i = [], 0
    for tf in frame_times:
        while i < len(imu_times) and imu_times[i] <= tf + 0.02:  # the IMU runs a little ahead, as on a device
            stage.push_imu(*_imu(float(imu_times[i])))
            i += 1
        out.append(stage.push_frame(float(tf), _visual(float(tf)), True))
    return out


def test_an_imu_a_few_ms_behind_the_frames_is_fused_not_an_error() -> None:
    """Each frame arrives when the IMU has delivered only up to 15 ms before it (delivery latency). A fused frame
    extrapolates the filter to its time; the samples between then came as the next frame's and went back in time:
    'IMU time went backwards' raised out of the live pipeline (found in review). Now such a sample's rate is the
    rate from then on."""
    stage = LiveFusion(LiveFusionSettings(warmup_s=0.5))
    imu_t, frames, out, i = np.arange(0, 4.0, 0.005), np.arange(0, 4.0, 1 / 30), [], 0
    for tf in frames:
        while i < len(imu_t) and imu_t[i] <= tf - 0.015:
            stage.push_imu(*_imu(float(imu_t[i])))
            i += 1
        out.append(stage.push_frame(float(tf), _visual(float(tf)), True))
    assert sum(o.mode == "fused" for o in out) > 0.8 * len(frames)
    yaw = np.array([o.angles_deg[1] for o in out])
    np.testing.assert_allclose(yaw, _yaw_deg(frames), atol=0.1)


def test_frames_before_any_imu_sample_and_in_warmup_are_camera_only() -> None:
    stage = LiveFusion(LiveFusionSettings(warmup_s=0.5))
    frames = np.arange(0, 3.0, 1 / 30)
    out = _run_stage(stage, np.arange(1.0, 3.5, 0.005), frames)  # the IMU starts 1 s late
    modes = [(o.mode, o.reason) for o in out]
    assert modes[0] == ("camera", "no_imu") and modes[29] == ("camera", "no_imu")
    assert ("camera", "warmup") in modes and modes[-1] == ("fused", "")
    c = stage.counters()["frames_camera_only"]
    assert c["no_imu"] == 30 and 14 <= c["warmup"] <= 17
    yaw = np.array([o.angles_deg[1] for o in out])
    np.testing.assert_allclose(yaw, _yaw_deg(frames), atol=0.05)  # continuous through every mode change
    assert np.isnan(out[0].abs_angles_deg[0]) and abs(out[-1].abs_angles_deg[0]) < 0.2


def test_an_imu_gap_and_a_stopped_imu_fall_back_to_the_camera_and_restart() -> None:
    stage = LiveFusion(LiveFusionSettings(warmup_s=0.5, max_gap_s=0.1))
    imu_t = np.r_[np.arange(0, 2.0, 0.005), np.arange(3.0, 4.0, 0.005)]  # 1 s gap, then stops at 4 s
    frames = np.arange(0, 5.0, 1 / 30)
    out = _run_stage(stage, imu_t, frames)
    by_t = {round(float(o.t_s), 3): o for o in out}
    assert by_t[round(frames[45], 3)].mode == "fused"  # t = 1.5
    assert by_t[round(frames[75], 3)].reason == "imu_gap"  # t = 2.5
    assert by_t[round(frames[105], 3)].mode == "fused"  # t = 3.5: restarted
    assert by_t[round(frames[135], 3)].reason == "imu_gap"  # t = 4.5: stopped
    assert stage.counters()["filter_restarts"] == 1
    yaw = np.array([o.angles_deg[1] for o in out])
    np.testing.assert_allclose(yaw, _yaw_deg(frames), atol=0.1)


def test_out_of_order_and_gyro_less_samples_are_dropped_and_counted() -> None:
    stage = LiveFusion()
    stage.push_imu(*_imu(0.1))
    stage.push_imu(*_imu(0.05))
    stage.push_imu(0.2, None, (0.0, -9.81, 0.0))
    assert stage.counters()["imu_dropped"] == 2


def test_extrinsics_rotate_imu_axes_into_the_camera_frame() -> None:
    # the IMU mounted rotated 90 deg about the optical axis: its x axis is the camera's y
    R_ci = rotation_from_angles_deg(0.0, 0.0, 90.0)
    stage = LiveFusion(LiveFusionSettings(fusion=FusionSettings(camera_from_imu=tuple(R_ci.ravel())), warmup_s=0.5))
    frames = np.arange(0, 2.0, 1 / 30)
    i, out = 0, []
    imu_t = np.arange(0, 2.1, 0.005)
    for tf in frames:
        while i < len(imu_t) and imu_t[i] <= tf:
            g = R_ci.T @ [0.0, _rate_rad_s(float(imu_t[i])), 0.0]
            a = R_ci.T @ [0.0, -9.81, 0.0]
            stage.push_imu(float(imu_t[i]), g, a)
            i += 1
        out.append(stage.push_frame(float(tf), np.eye(3), False))  # no vision: the IMU alone moves it
    yaw = angles_deg_from_rotation(out[-1].rotation)[1]
    assert out[-1].mode == "fused" and yaw == pytest.approx(float(_yaw_deg(frames[-1])), abs=0.2)
    assert abs(out[-1].abs_angles_deg[1]) < 0.2


# ------------------------------------------------------------------------- pipeline: an IMU that disconnects


def test_pipeline_keeps_running_when_the_imu_disconnects(tmp_path: Path, GaitSource, TruthEstimator) -> None:
    from walkmon.drivers.imu_types import ImuBatch, ImuSample
    from walkmon.gait.live import LiveIndicatorStage
    from walkmon.live.alerts import AlertStage
    from walkmon.live.pipeline import LivePipeline
    from walkmon.live.session_log import SessionLog, open_database, read_session_table
    from walkmon.simulate.gait import GaitModel
    from walkmon.simulate.imu import simulate_imu

    model = GaitModel("normal:4", seed=1)
    imu = simulate_imu(model)

    class CutImu:
        url, reconnectable, live = "test:imu", False, False

        def __init__(self) -> None:
            self.i = 0

        def open(self) -> None:
            self.i = 0

        def read(self) -> ImuBatch:
            if imu.t_s[self.i] > 4.0:
                raise SourceDisconnected("test:imu: unplugged")
            self.i += 1
            k = self.i - 1
            return ImuBatch((ImuSample(float(imu.t_s[k]), tuple(imu.gyroscope_rps[k]), tuple(imu.accelerometer_mps2[k])),))

        def close(self) -> None:
            pass

    log = SessionLog(tmp_path, kind="live", flush_interval_s=0.2)
    res = LivePipeline(GaitSource(model), lambda _src: TruthEstimator(model), indicators=LiveIndicatorStage(),
                       alerts=AlertStage(), session_log=log, imu_source=CutImu()).run(60.0)
    assert res.frames == int(model.duration_s * 30) + 1 or res.frames >= 239
    cam = res.fusion["frames_camera_only"]
    assert res.fusion["frames_fused"] >= 80 and cam["imu_gap"] >= 100  # 4 s fused (minus warm-up), rest camera
    conn = open_database(tmp_path, create=False)
    try:
        frames = read_session_table(conn, res.session_id, "frames")
    finally:
        conn.close()
    t = np.array(frames["t_s"])
    truth = model.truth_angles_deg(t)
    ang = np.column_stack([np.array(frames[k], float) for k in ("pitch", "yaw", "roll")])
    assert np.abs(ang - truth).max() < 0.3  # fused, then the (exact) camera chained on: no jump at the cut
    fused = np.array(frames["fused"]) == 1
    assert fused[(t > 1.5) & (t < 3.9)].all() and not fused[t > 4.2].any()


# ---------------------------------------------------------------------------------- session log, config


def test_a_schema_1_database_is_migrated_and_its_old_frames_read_as_null(tmp_path: Path) -> None:
    from walkmon.live.session_log import (
        SCHEMA_VERSION,
        SessionLog,
        list_sessions,
        open_database,
        read_session_table,
    )

    db = tmp_path / "walkmon.sqlite"
    conn = sqlite3.connect(str(db))
    conn.executescript("""
        CREATE TABLE sessions (id INTEGER PRIMARY KEY AUTOINCREMENT, kind TEXT NOT NULL, started_utc TEXT NOT NULL,
            ended_utc TEXT, end_reason TEXT, camera TEXT, imu TEXT, config_json TEXT, versions_json TEXT,
            meta_json TEXT, n_frames INTEGER DEFAULT 0, n_dropped INTEGER DEFAULT 0);
        CREATE TABLE frames (session_id INTEGER NOT NULL, t_s REAL NOT NULL, pitch REAL, yaw REAL, roll REAL,
            n_inliers INTEGER, model TEXT, status TEXT, latency_ms REAL);
        INSERT INTO sessions (kind, started_utc, ended_utc, end_reason) VALUES ('live', '2026-01-01', '2026-01-01', 'ok');
        INSERT INTO frames VALUES (1, 0.5, 1.0, 2.0, 3.0, 50, 'essential', 'OK', 4.0);
        PRAGMA user_version=1;
    """)
    conn.commit()
    conn.close()
    assert [s.n_frames for s in list_sessions(tmp_path)] == [1]
    conn = open_database(tmp_path, create=False)
    try:
        assert conn.execute("PRAGMA user_version").fetchone()[0] == SCHEMA_VERSION >= 2
        old = read_session_table(conn, 1, "frames")
        assert conn.execute("SELECT person FROM sessions").fetchall() == [(None,)]  # schema 3 column, NULL
    finally:
        conn.close()
    assert old["pitch"] == [1.0] and old["pitch_abs"] == [None] and old["fused"] == [None]
    log = SessionLog(tmp_path)
    log.add_frame(0.0, (1.0, 2.0, 3.0), abs_angles_deg=(4.0, 5.0), fused=True)
    log.close("ok")
    conn = open_database(tmp_path, create=False)
    try:
        new = read_session_table(conn, log.session_id, "frames")
    finally:
        conn.close()
    assert new["pitch_abs"] == [4.0] and new["roll_abs"] == [5.0] and new["fused"] == [1]


def test_imu_config_keys() -> None:
    cfg = config_from_dict({"imu": {"url": "file:x.csv", "time_offset_s": 0.02, "rotation_deg": [0, 90, 0]}})
    R = np.array(cfg.imu.camera_from_imu).reshape(3, 3)
    np.testing.assert_allclose(R, rotation_from_angles_deg(0, 90, 0), atol=1e-12)
    flip = [1, 0, 0, 0, -1, 0, 0, 0, -1]
    assert config_from_dict({"imu": {"extrinsics": flip}}).imu.camera_from_imu == tuple(map(float, flip))
    assert ImuSettings().camera_from_imu == (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    assert ImuSettings().filter == "vqf"
    cfg = config_from_dict({"imu": {"filter": "eskf-handheld", "tau_acc_s": 4.0}})
    assert (cfg.imu.filter, cfg.imu.tau_acc_s) == ("eskf-handheld", 4.0)
    for bad in ({"extrinsics": [1, 0, 0, 0, 1, 0, 0, 0, -1]},  # a reflection
                {"extrinsics": [1, 0, 0]},
                {"extrinsics": flip, "rotation_deg": [1, 0, 0]},
                {"max_gap_s": 0},
                {"filter": "kalman"},
                {"tau_acc_s": 0},
                {"time_offset": 0.1}):
        with pytest.raises(ConfigError):
            config_from_dict({"imu": bad})


def test_a_device_clock_that_jumps_back_restarts_the_filter_without_a_jump_in_the_output() -> None:
    stage = LiveFusion(LiveFusionSettings(warmup_s=0.5))
    frames = np.arange(0, 3.0, 1 / 30)
    out = _run_stage(stage, np.arange(0, 3.1, 0.005), frames)
    assert out[-1].mode == "fused"
    # the OAK re-opened: both clocks restart at 0 while the camera keeps moving (yaw continues from 3 s)
    yaw0 = float(_yaw_deg(3.0))
    i, imu_t = 0, np.arange(0, 1.6, 0.005)
    for tf in np.arange(0, 1.5, 1 / 30):
        while i < len(imu_t) and imu_t[i] <= tf + 0.02:
            stage.push_imu(float(imu_t[i]), (0.0, np.radians(RATE_DPS), 0.0), (0.0, -9.81, 0.0))
            i += 1
        o = stage.push_frame(float(tf), rotation_from_angles_deg(0.0, yaw0 + RATE_DPS * tf, 0.0), True)
        assert o.angles_deg[1] == pytest.approx(yaw0 + RATE_DPS * tf, abs=0.1)
    assert o.mode == "fused" and stage.counters()["filter_restarts"] == 1


def test_a_held_frame_the_imu_carried_still_counts_live(tmp_path: Path, GaitSource, TruthEstimator) -> None:
    """A frame the estimator held (a covered lens) measures nothing by itself, but when the IMU fusion carried it
    (mode 'fused') its angles are the IMU's and go into the indicators: the walk behind a 3 s cap stays walking.
    Camera-only (no IMU), the same cap reads unknown (tests/gait/test_held_frames.py)."""
    from walkmon.drivers.imu_types import ImuBatch, ImuSample
    from walkmon.gait.live import LiveIndicatorStage
    from walkmon.live.alerts import AlertStage
    from walkmon.live.pipeline import LivePipeline
    from walkmon.live.session_log import SessionLog, open_database, read_session_table
    from walkmon.rotation.types import EstimateStatus
    from walkmon.simulate.gait import GaitModel
    from walkmon.simulate.imu import simulate_imu

    model = GaitModel("normal:14", seed=2)
    imu = simulate_imu(model)
    cap = (8.0, 11.0)

    class Imu:
        url, reconnectable, live = "test:imu", False, False

        def open(self) -> None:
            self.i = 0

        def read(self) -> ImuBatch:
            if self.i >= len(imu.t_s):
                raise SourceDisconnected("test:imu: end")
            k, self.i = self.i, self.i + 1
            sample = ImuSample(float(imu.t_s[k]), tuple(imu.gyroscope_rps[k]), tuple(imu.accelerometer_mps2[k]))
            return ImuBatch((sample,))

        def close(self) -> None:
            pass

    class Capped(TruthEstimator):
        def push(self, frame: np.ndarray, t_s: float):  # noqa: ANN201
            est = super().push(frame, t_s)
            if cap[0] <= t_s < cap[1]:
                return dataclasses.replace(est, model="hold", status=EstimateStatus.TOO_FEW_FEATURES)
            return est

    log = SessionLog(tmp_path, kind="live", flush_interval_s=0.2)
    res = LivePipeline(GaitSource(model), lambda _src: Capped(model), indicators=LiveIndicatorStage(),
                       alerts=AlertStage(), session_log=log, imu_source=Imu()).run(120.0)
    conn = open_database(tmp_path, create=False)
    try:
        hops = read_session_table(conn, res.session_id, "hops")
        frames = read_session_table(conn, res.session_id, "frames")
    finally:
        conn.close()
    t = np.array(frames["t_s"])
    held = np.array(frames["model"]) == "hold"
    assert held[(t >= cap[0] + 0.1) & (t < cap[1] - 0.1)].all()
    assert (np.array(frames["fused"])[held] == 1).all()  # the IMU carried every held frame
    activity = {round(float(h)): json.loads(j)["activity"] for h, j in zip(hops["t_s"], hops["json"], strict=True)}
    assert all(activity[k] == "walking" for k in range(9, 12)), activity
