"""Session scripts (issue 11 item 8): the true timeline agrees with the motion the model produces.

Every check compares the truth (pieces, initial contacts, bouts) with an independent reading of the model's
motion: angular rates, accelerations, positions, rendered geometry and the simulated IMU.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from scipy.signal import find_peaks, peak_prominences

from walkmon.errors import InvalidInputError
from walkmon.simulate import (
    GaitModel,
    SimulatedSession,
    parse_walk_script,
    simulate,
    simulate_imu,
)
from walkmon.simulate.unkind import UNKIND_WALKS, unkind_script
from walkmon.tables import read_table

SCRIPT = "stand:3,normal:10,turn:180,normal:8,pause:2,bend:10,stand:1.5"
DT = 0.001


@pytest.fixture(scope="module")
def model() -> GaitModel:
    return GaitModel(SCRIPT, seed=4)


def _world_yaw_rate_dps(m: GaitModel, t: np.ndarray) -> np.ndarray:
    """Rate of turn about the world's vertical, deg/s (> 0 right), from the body rate rotated into the world."""
    w_world = np.einsum("nij,nj->ni", m.rotation(t), m.angular_velocity_rps(t))
    return np.degrees(w_world[:, 1])


def _pieces(m: GaitModel, activity: str) -> list:
    return [p for p in m.pieces if p.activity == activity]


# --------------------------------------------------------------------------------------------- scripts
def test_session_script_is_taken_literally(model) -> None:
    acts = [(p.activity, p.label) for p in model.pieces]
    assert acts == [("standing", ""), ("walking", "normal"), ("turning", ""), ("walking", "normal"),
                    ("standing", ""), ("walking", "bend"), ("standing", "")]
    assert model.literal
    assert model.pieces[0].start_s == 0.0 and model.pieces[-1].end_s == pytest.approx(model.duration_s)
    # the body stands still exactly as long as scripted: 3 s, the 2 s pause, the final 1.5 s
    still = model.standing_intervals_s
    assert [round(b - a, 6) for a, b in still] == [3.0, 2.0, 1.5]
    assert still[0][0] == 0.0 and still[-1][1] == pytest.approx(model.duration_s)
    # in the timeline, walking runs from a bout's first initial contact to its last (the field's convention)
    steps, _ = model.step_times_s()
    bouts = model.bouts()
    assert model.pieces[1].start_s == pytest.approx(steps[0]) == pytest.approx(bouts[0]["start_s"], abs=1e-3)
    assert model.pieces[3].end_s == pytest.approx(bouts[0]["end_s"], abs=1e-3)
    assert model.pieces[5].start_s == pytest.approx(bouts[1]["start_s"], abs=1e-3)
    assert 0.2 < model.pieces[1].start_s - still[0][1] < 0.8  # weight shift, then the first contact
    assert 33.0 < model.duration_s < 40.0
    for a, b in zip(model.pieces[:-1], model.pieces[1:], strict=True):
        assert a.end_s == pytest.approx(b.start_s)


@pytest.mark.parametrize(
    ("script", "fragment"),
    [
        ("normal:5,turn:45x", "cannot parse"),
        ("normal:5,turn", "cannot parse"),
        ("normal:5,turn:5", "between 10 and 360"),
        ("normal:5,turn:400", "between 10 and 360"),
        ("normal:5,turn:90:99", "turn duration"),
        ("normal:5,pause", "needs a duration"),
        ("normal:5,pause:0", "zero duration"),
        ("normal:5,sitting:3,turn:90", "unknown walk type"),
    ],
)
def test_bad_session_scripts(script, fragment) -> None:
    with pytest.raises(InvalidInputError, match=fragment):
        parse_walk_script(script, None)


def test_cli_rejects_a_bad_script_in_one_line(tmp_path) -> None:
    out = tmp_path / "sim"
    proc = subprocess.run(
        [sys.executable, "-m", "walkmon", "simulate", "--walk", "normal:5,turn:5", "--out", str(out), "--no-video"],
        capture_output=True, text=True, timeout=120, check=False,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0 and "turn angle 5" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert not (out / "truth.csv").exists()


def test_classic_scripts_keep_their_standing_ends() -> None:
    m = GaitModel("normal:3,stand:1.5,bend:2", seed=1)
    assert not m.literal
    t = np.array([1.0, 3.0, 5.5, 7.5, 9.5])
    activity, label = m.timeline(t)
    assert list(activity) == ["standing", "walking", "standing", "walking", "standing"]
    assert list(label) == ["", "normal", "", "bend", ""]


# ---------------------------------------------------------------------------------- timeline vs motion
def test_standing_is_still_and_turning_turns(model) -> None:
    t = np.arange(0.0, model.duration_s, DT)
    activity, _ = model.timeline(t)
    rate = _world_yaw_rate_dps(model, t)
    standing = model.is_standing(t)
    assert np.all(activity[standing] == "standing")
    assert standing.sum() > 5000
    assert np.abs(model.angular_velocity_rps(t[standing])).max() < 1e-9
    assert np.abs(model.acceleration_mps2(t[standing])).max() < 1e-9
    (turn,) = _pieces(model, "turning")
    inside = (t >= turn.start_s) & (t < turn.end_s)
    assert np.abs(rate[inside]).mean() > 45.0  # a 180° turn in 2-3 s, while stepping
    heading = model.body_angles_deg(np.array([turn.start_s, turn.end_s]))[:, 1]
    assert heading[1] - heading[0] == pytest.approx(180.0, abs=8.0)  # plus a few degrees of stride swing
    # walking: the heading holds over every stride (the stride's own yaw swing averages out)
    walking = activity == "walking"
    stride = int(1.3 / DT)
    smooth = np.convolve(rate, np.ones(stride) / stride, mode="same")
    assert np.abs(smooth[walking][stride:-stride]).max() < 15.0


@pytest.mark.parametrize("walk", UNKIND_WALKS)
def test_initial_contacts_are_the_vertical_acceleration_peaks(walk) -> None:
    m = GaitModel(f"stand:1,{walk}:8,turn:-90,{walk}:4,pause:2,{walk}:5", seed=3)
    steps, feet = m.step_times_s()
    t = np.arange(0.0, m.duration_s, DT)
    up = -m.acceleration_mps2(t)[:, 1]  # world y points down
    peaks, _ = find_peaks(up, distance=int(0.25 / DT))
    prominence = peak_prominences(up, peaks)[0]
    nearest = np.array([np.min(np.abs(t[peaks] - s)) for s in steps])
    # a limp's contacts sit off the middle of the step cycle (alternating step times): the phase speeds up or
    # slows down through them, which moves the acceleration peak by ~1-2 % of a step
    assert np.median(nearest) < (0.02 if walk == "right_foot_drag" else 0.01)
    assert nearest.max() < 0.06  # every step is a peak
    # and no other peak while stepping comes near a step's: the mid-step hump stays below half of it
    is_step = np.array([np.min(np.abs(steps - p)) < 0.06 for p in t[peaks]])
    activity, _ = m.timeline(t[peaks])
    others = ~is_step & (activity != "standing")
    assert prominence[others].max() < 0.5 * np.median(prominence[is_step])
    assert set(feet) == {"R", "L"} and np.all(feet[1:] != feet[:-1])


def test_gait_initiation_and_termination_ramp_over_a_few_steps(model) -> None:
    bout = model.bouts()[0]
    steps, _ = model.step_times_s()
    s = steps[(steps >= bout["start_s"]) & (steps <= bout["end_s"])]
    d = np.diff(s)
    steady = np.median(d[4:-4])
    assert d[0] > 1.08 * steady and d[-1] > 1.08 * steady  # slower first and last steps
    assert np.all(d[3:-3] < 1.25 * steady)
    t = np.arange(0.0, model.duration_s, DT)
    up = -model.acceleration_mps2(t)[:, 1]
    amp = np.interp(s, t, up)
    assert amp[0] < 0.8 * np.median(amp[4:-4]) and amp[-1] < 0.8 * np.median(amp[4:-4])
    # the walk starts from standing: the first contact comes within a step of leaving the standing phase
    onset = model.standing_intervals_s[0][1]
    assert onset < s[0] < onset + 0.8


def test_posture_change_takes_about_two_seconds() -> None:
    m = GaitModel("normal:8,bend:8", seed=2, stand_s=0.0)
    assert m.literal
    boundary = m.pieces[1].start_s
    t = np.arange(0.0, m.duration_s, 0.01)
    stride = 110  # 1.1 s: average the stride's oscillation out
    pitch = np.convolve(m.body_angles_deg(t)[:, 0], np.ones(stride) / stride, mode="same")
    lo, hi = pitch[np.searchsorted(t, boundary + 3.5)], pitch[np.searchsorted(t, boundary - 3.5)]
    assert lo < -13.0 and abs(hi) < 1.5
    level = (pitch - hi) / (lo - hi)
    t10 = t[np.argmax(level > 0.1)]
    t90 = t[np.argmax(level > 0.9)]
    assert 0.8 < t90 - t10 < 2.6
    assert abs(0.5 * (t10 + t90) - boundary) < 0.4  # the label switches in the middle of the change
    _, label = m.timeline(np.array([boundary - 0.05, boundary + 0.05]))
    assert list(label) == ["normal", "bend"]


def test_sessions_can_start_and_end_mid_walk() -> None:
    m = GaitModel("normal:6,turn:90,normal:5", seed=7)
    v = np.gradient(m.position_m(np.array([0.0, 0.01, 0.02]))[:, 2], 0.01)
    assert v[1] > 0.9  # already walking at full speed at t = 0
    end = m.position_m(np.array([m.duration_s - 0.02, m.duration_s]))
    assert np.linalg.norm(end[1] - end[0]) / 0.02 > 0.7  # still walking at the end
    steps, _ = m.step_times_s()
    assert steps[0] < 0.7 and steps[-1] > m.duration_s - 0.7
    (bout,) = m.bouts()
    assert bout["n_steps"] == steps.size and bout["turns"] == 1


def test_bouts_follow_the_steps(model) -> None:
    steps, _ = model.step_times_s()
    bouts = model.bouts()
    assert len(bouts) == 2  # the pause splits; the turn does not
    assert sum(b["n_steps"] for b in bouts) == steps.size
    for b in bouts:
        s = steps[(steps >= b["start_s"] - 1e-3) & (steps <= b["end_s"] + 1e-3)]
        assert s.size == b["n_steps"]
        assert b["cadence_spm"] == pytest.approx(60.0 * (s.size - 1) / (s[-1] - s[0]), rel=1e-3)
        assert 80.0 < b["cadence_spm"] < 125.0
    assert bouts[0]["turns"] == 1 and bouts[0]["labels"] == ["normal"]
    assert bouts[1]["labels"] == ["bend"]


# ------------------------------------------------------------------------------------- scene and IMU
def test_turns_face_facades_at_close_range() -> None:
    session = SimulatedSession("normal:5,turn:90,pause:2,turn:90,normal:4", seed=5, width=64, height=48)
    pause = _pieces(session.model, "standing")[0]
    t = 0.5 * (pause.start_s + pause.end_s)
    R, p = session.model.pose([t])
    dist, label, _ = session.renderer.cast(R[0], p[0])
    centre = dist.reshape(48, 64)[24, 32]
    assert 0.9 < centre < 3.2  # facing a facade, 1-3 m away
    assert label.reshape(48, 64)[24, 32] in (1, 2)
    # after the U-turn the street is closed by buildings behind: no sky straight ahead at eye level
    R, p = session.model.pose([session.model.duration_s - 0.5])
    dist, label, _ = session.renderer.cast(R[0], p[0])
    assert label.reshape(48, 64)[22, 32] >= 0


def test_imu_sees_turns_and_stillness() -> None:
    m = GaitModel("stand:2,normal:4,turn:-180,normal:3,stand:2", seed=9)
    imu = simulate_imu(m)
    activity, _ = m.timeline(imu.t_s)
    gyro = imu.gyroscope_rps - imu.gyroscope_bias_rps
    standing = m.is_standing(imu.t_s)
    assert np.abs(np.degrees(gyro[standing])).max() < 0.6  # noise only (0.1 deg/s rms)
    # while turning, the gyro turns through -180° about the (tilted, bobbing) vertical: integrate it
    turning = activity == "turning"
    g_world = np.einsum("nij,nj->ni", m.rotation(imu.t_s), gyro)
    turned = np.degrees(g_world[turning, 1].sum() / 200.0)
    assert turned == pytest.approx(-180.0, abs=10.0)
    acc = np.linalg.norm(imu.accelerometer_mps2 - imu.accelerometer_bias_mps2, axis=1)
    assert np.abs(acc[standing] - 9.81).max() < 0.12
    assert np.ptp(acc[activity == "walking"]) > 2.0


# -------------------------------------------------------------------------------- files and generator
def test_truth_files_of_a_session(tmp_path) -> None:
    result = simulate(tmp_path / "s", SCRIPT, seed=4, width=64, height=48, fps=20.0, video=False)
    tl = read_table(result.out_dir / "truth_timeline.csv", ["t", "trunk_pitch", "trunk_roll", "heading"])
    lines = (result.out_dir / "truth_timeline.csv").read_text().splitlines()
    assert lines[0] == "t,activity,label,trunk_pitch,trunk_roll,heading"
    assert len(lines) - 1 == result.n_frames == tl["t"].size
    rows = [ln.split(",") for ln in lines[1:]]
    m = GaitModel(SCRIPT, seed=4)
    activity, label = m.timeline(tl["t"])
    assert [r[1] for r in rows] == list(activity) and [r[2] for r in rows] == list(label)
    assert {r[1] for r in rows} == {"standing", "walking", "turning"}
    bent = np.array([r[2] == "bend" for r in rows])
    assert np.median(tl["trunk_pitch"][bent]) < -12.0  # heading-free: bent forward even after the U-turn
    truth = read_table(result.out_dir / "truth.csv", ["t", "yaw"])
    assert np.abs(np.diff(truth["yaw"])).max() < 20.0  # yaw unwrapped across the turn
    assert truth["yaw"].max() > 150.0
    steps = read_table(result.out_dir / "truth_steps.csv", ["t", "bout"])
    np.testing.assert_allclose(steps["t"], m.step_times_s()[0], atol=1e-4)
    meta = json.loads(result.meta_path.read_text())
    assert meta["simulator_version"] >= 2 and meta["session_script"] is True
    assert [b["n_steps"] for b in meta["bouts"]] == [b["n_steps"] for b in m.bouts()]
    assert [p["activity"] for p in meta["pieces"]] == [p.activity for p in m.pieces]


def test_unkind_scripts_are_reproducible_and_unkind() -> None:
    assert unkind_script(3, "bend") == unkind_script(3, "bend")
    assert unkind_script(3, "bend") != unkind_script(4, "bend")
    turns = pauses = mid_start = 0
    for walk in UNKIND_WALKS:
        for seed in range(1, 6):
            script = unkind_script(seed, walk)
            m = GaitModel(script, seed=seed)
            assert m.literal and 25.0 < m.duration_s < 110.0
            labels = {p.label for p in m.pieces if p.label}
            assert walk in labels and len(labels) == 2  # a posture change mid-walk
            turns += sum(p.activity == "turning" for p in m.pieces)
            pauses += len(m.bouts()) - 1
            mid_start += m.pieces[0].activity != "standing"
    assert turns >= 20 and pauses >= 20 and 3 <= mid_start <= 17
    with pytest.raises(InvalidInputError, match="walk type"):
        unkind_script(1, "stand")


def test_cli_unkind_session(tmp_path, capsys) -> None:
    from walkmon.commands.cli import main  # noqa: PLC0415

    out = tmp_path / "u"
    assert main(["simulate", "--unkind", "--walk", "bend", "--seed", "2", "--out", str(out), "--no-video",
                 "--width", "64", "--height", "48"]) == 0
    script = unkind_script(2, "bend")
    assert script in capsys.readouterr().out
    meta = json.loads((out / "meta.json").read_text())
    assert meta["walk"] == script and meta["session_script"] is True
    assert main(["simulate", "--unkind", "--walk", "stand", "--out", str(tmp_path / "x"), "--no-video"]) == 2
    assert "built around a walk type" in capsys.readouterr().err


# ---------------------------------------------------------------------------------- limp and unknown activity
def _acc_peaks(m: GaitModel, a: float, b: float) -> np.ndarray:
    """Times of the upward acceleration peaks (one per step) between a and b, read from the motion."""
    t = np.arange(a, b, DT)
    up = -m.acceleration_mps2(t)[:, 1]
    peaks, _ = find_peaks(up, distance=int(0.35 / DT), prominence=0.3 * np.ptp(up))
    return t[peaks]


@pytest.mark.parametrize(("walk", "lo", "hi"), [("right_foot_drag", 1.15, 1.35), ("normal", 0.95, 1.06)])
def test_a_dragged_foot_alternates_long_and_short_steps(walk, lo, hi) -> None:
    m = GaitModel(f"{walk}:14", seed=5, stand_s=0.0)
    steps, feet = m.step_times_s()
    d = np.diff(steps)
    ends_right = feet[1:] == "R"
    assert lo < d[ends_right].mean() / d[~ends_right].mean() < hi  # the step onto the right foot is the long one
    peaks = _acc_peaks(m, 1.0, m.duration_s - 1.0)  # the same alternation in the trunk's motion itself
    dp = np.diff(peaks)
    ratio = max(dp[0::2].mean(), dp[1::2].mean()) / min(dp[0::2].mean(), dp[1::2].mean())
    assert lo < ratio < hi


def test_unknown_pieces_move_without_a_gait_rhythm() -> None:
    m = GaitModel("stand:1,sit:10,pause:1.5,normal:6,pause:1,pickup:4,pause:1,camera:5,stand:1", seed=2)
    kinds = [p.activity for p in m.pieces]
    assert kinds.count("unknown") == 3
    sit, pickup, camera = (p for p in m.pieces if p.activity == "unknown")
    steps, _ = m.step_times_s()
    for p in (sit, pickup, camera):
        assert not np.any((steps > p.start_s) & (steps < p.end_s))  # no initial contact while not walking
        t = np.arange(p.start_s, p.end_s, DT)
        assert np.degrees(np.abs(m.angular_velocity_rps(t))).max() > 10.0  # it moves
    t_sit = np.arange(sit.start_s + 3.0, sit.end_s - 3.0, 0.01)
    tilt = m.body_angles_deg(t_sit)
    assert np.all(np.abs(tilt[:, 0]) > 20.0)  # seated: the chest well off the standing pose
    assert np.all(m.position_m(t_sit)[:, 1] > 0.35)  # and 0.4-0.5 m lower (y points down)
    mid = 0.5 * (pickup.start_s + pickup.end_s)
    assert m.body_angles_deg([mid])[0, 0] < -40.0  # bent down to the ground
    t_cam = np.arange(camera.start_s + 0.5, camera.end_s - 0.5, DT)
    rate = np.degrees(np.linalg.norm(m.angular_velocity_rps(t_cam), axis=1))
    assert np.sqrt(np.mean(rate**2)) > 10.0
    # smooth at the edges (the IMU model differentiates twice) and still before and after
    for p in (sit, pickup, camera):
        for edge in (p.start_s, p.end_s):
            acc = m.acceleration_mps2(np.array([edge - 0.3, edge - 0.002, edge + 0.002]))
            assert np.abs(acc[0]).max() < 1e-6 or np.abs(acc[2] - acc[1]).max() < 0.05
    assert [b["n_steps"] > 4 for b in m.bouts()] == [True]


def test_most_unkind_sessions_move_without_walking_once() -> None:
    n = sum("unknown" in {p.activity for p in GaitModel(unkind_script(s, w), seed=s).pieces}
            for w in UNKIND_WALKS for s in range(1, 6))
    assert 10 <= n <= 19


def test_lr_token_adds_a_stride_rhythm_to_the_pitch_only() -> None:
    """``lr:X``: the pitch gains a stride-frequency component X times its step amplitude (real trunks pitch
    differently on the two steps); lr:0 is the walk without the token, to the bit."""
    from walkmon.simulate.gait import split_pitch_lr

    t = np.arange(0.0, 20.0, 1 / 30)
    plain = GaitModel("stand:2,normal:16,stand:2", seed=5)
    zero = GaitModel("lr:0,stand:2,normal:16,stand:2", seed=5)
    strong = GaitModel("lr:2,stand:2,normal:16,stand:2", seed=5)
    assert strong.pitch_lr == 2.0 and strong.meta()["pitch_lr"] == 2.0
    np.testing.assert_array_equal(zero.truth_angles_deg(t), plain.truth_angles_deg(t))
    a, b = plain.truth_angles_deg(t), strong.truth_angles_deg(t)
    assert np.abs(b[:, 1:] - a[:, 1:]).max() < 0.3  # yaw and roll as before (but for the Euler angles' coupling)
    walk = (t > 4.0) & (t < 16.0)
    x = b[walk, 0] - a[walk, 0]  # the added pitch: a sinusoid at the stride frequency
    steps = plain.step_times_s()[0]
    stride = 2 * float(np.median(np.diff(steps[(steps > 4.0) & (steps < 16.0)])))
    spec = np.abs(np.fft.rfft(x - x.mean()))
    f = np.fft.rfftfreq(x.size, 1 / 30)
    assert abs(f[int(np.argmax(spec))] - 1 / stride) < 0.1
    for bad in ("lr:-1,normal", "lr:4,normal", "lr:x,normal", "lr:1,lr:1,normal", "lr:1"):
        with pytest.raises(InvalidInputError):
            split_pitch_lr(bad)
        with pytest.raises(InvalidInputError):
            GaitModel(bad)



def test_a_rolling_shutter_clips_calibration_carries_its_readout(tmp_path) -> None:
    """User review: '--rolling-shutter-ms 30' rendered the rows over 30 ms but camera.yaml said nothing of it, so
    'analyze --calib camera.yaml' corrected nothing (3.2 deg RMS on a turning clip, 1.2 with the readout given)."""
    import contextlib
    import io
    import json

    from walkmon.camera.model import read_camera_yaml
    from walkmon.commands.cli import main

    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["simulate", "--walk", "normal:1", "--rolling-shutter-ms", "30", "--width", "160", "--height",
                     "120", "--out", str(tmp_path / "s"), "--no-progress"]) == 0
    rendered = json.loads((tmp_path / "s" / "meta.json").read_text())["render"]["rolling_shutter_s"]
    assert rendered == 0.03
    assert read_camera_yaml(tmp_path / "s" / "camera.yaml").readout_s == rendered


def test_an_odd_image_size_is_refused(tmp_path, capsys) -> None:
    """User review: '--width 321 --height 241' printed and wrote a 321x241 camera.yaml beside a 320x240 video (the
    encoder made it even), and analyze then scaled the intrinsics."""
    from walkmon.commands.cli import main

    with pytest.raises(SystemExit) as exc:
        main(["simulate", "--walk", "normal:1", "--width", "321", "--height", "240", "--out", str(tmp_path / "s")])
    assert exc.value.code == 2
    assert "must be even" in capsys.readouterr().err
    assert not (tmp_path / "s").exists()
