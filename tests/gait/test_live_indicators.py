"""Sliding-window live indicators against waveforms with known cadence, swing and inclination."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from walkmon.gait.live import (
    DEFAULT_LIVE_INDICATOR_SETTINGS,
    LiveIndicators,
    LiveIndicatorStage,
    cadence_hz_from_signal,
    gait_band_rms_deg,
)

FPS = 30.0


def synthetic_walk(
    seconds_stand: float = 3.0,
    seconds_walk: float = 14.0,
    step_hz: float = 1.83,
    pitch_offset: float = 0.0,
    roll_offset: float = 0.0,
    stance: tuple[float, float, float] = (1.0, -0.5, 0.3),
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Standing still at ``stance`` then walking: pitch at step, yaw/roll at stride frequency, about the stance."""
    rng = np.random.default_rng(seed)
    t = np.arange(int((seconds_stand + seconds_walk) * FPS)) / FPS
    walking = t >= seconds_stand
    tw = t - seconds_stand
    a = np.tile(np.asarray(stance, float), (len(t), 1))
    a[walking, 0] += pitch_offset + 1.0 * np.sin(2 * np.pi * step_hz * tw[walking])
    a[walking, 1] += 1.5 * np.sin(2 * np.pi * step_hz / 2 * tw[walking] + 0.3)
    a[walking, 2] += roll_offset + 2.0 * np.sin(2 * np.pi * step_hz / 2 * tw[walking] + 1.0)
    a += rng.normal(0, 0.02, a.shape)
    return t, a


def run_stage(t: np.ndarray, a: np.ndarray, stage: LiveIndicatorStage | None = None) -> list[LiveIndicators]:
    stage = stage or LiveIndicatorStage()
    out = []
    for ti, ai in zip(t, a, strict=True):
        r = stage.push(ti, ai)
        if r is not None:
            out.append(r)
    return out


def run_with_alerts(t: np.ndarray, a: np.ndarray, stage: LiveIndicatorStage) -> tuple[list[LiveIndicators], list]:
    """The hops and the alerts raised (AlertEvent) of the stage fed with (t, a), through the default alert stage."""
    from walkmon.live.alerts import AlertStage

    alerts = AlertStage()
    out, raised = [], []
    for r in run_stage(t, a, stage):
        out.append(r)
        raised += [e for e in alerts.push(r) if e.state == "raised"]
    return out, raised


def test_cadence_refined_below_bin_width() -> None:
    rng = np.random.default_rng(1)
    for f in (1.51, 1.77, 1.93, 2.2):
        t = np.arange(int(8 * FPS)) / FPS
        x = np.sin(2 * np.pi * f * t + rng.uniform(0, 6)) + rng.normal(0, 0.05, t.size) + 0.1 * t
        est, share = cadence_hz_from_signal(x, FPS, (1.0, 2.5))
        assert abs(est - f) / f < 0.01, (f, est)  # the raw 8 s bin width is 0.125 Hz (~7 %)
        assert share > 0.5


def test_gait_band_rms_matches_sine_rms_and_ignores_slow_drift() -> None:
    t = np.arange(int(3 * FPS)) / FPS
    x = 1.0 * np.sin(2 * np.pi * 2.0 * t) + 5.0 * t  # 1 deg amplitude + strong linear drift
    assert gait_band_rms_deg(x, FPS, (0.6, 3.5)) == pytest.approx(1 / math.sqrt(2), rel=0.1)
    assert gait_band_rms_deg(5.0 * t, FPS, (0.6, 3.5)) < 0.05


def test_hops_every_hop_s_with_cadence_swing_inclination_of_the_waveform() -> None:
    step_hz = 1.83
    t, a = synthetic_walk(step_hz=step_hz, pitch_offset=-4.0, roll_offset=1.5)
    res = run_stage(t, a)
    hop_t = np.array([r.t_s for r in res])
    assert np.allclose(np.diff(hop_t), 1.0, atol=1.5 / FPS)  # one result per hop, on capture time
    cal = [r.calibration for r in res if r.calibration is not None]
    assert len(cal) == 1 and cal[0].reason == "start" and cal[0].t_s < 3.0
    assert all(r.calibrated for r in res if r.t_s >= 3.0)
    assert cal[0].angles_deg == pytest.approx((1.0, -0.5, 0.3), abs=0.05)  # the still stance
    late = [r for r in res if r.t_s > 3.0 + 8.5]  # windows fully inside the walk
    assert late
    for r in late:
        assert r.walking
        assert r.cadence_spm == pytest.approx(60 * step_hz, rel=0.01)
        assert r.swing_deg[0] == pytest.approx(2.0, rel=0.1)  # pitch: 2 x 1 deg amplitude
        assert r.swing_deg[1] == pytest.approx(3.0, rel=0.1)
        assert r.swing_deg[2] == pytest.approx(4.0, rel=0.1)
        assert r.inclination_deg[0] == pytest.approx(-4.0, abs=0.3)  # relative to the standing stance
        assert r.inclination_deg[2] == pytest.approx(1.5, abs=0.3)
        assert r.posture_deg[0] == pytest.approx(-4.0, abs=1.0)
        # the one classifier's rule: a pitch inclination of -4 deg is outside the normal +-3 deg
        assert r.label == "unclassified" and "outside the normal range" in r.reasons[0]
    standing = [r for r in res if r.t_s < 2.9]
    assert all(not r.walking and r.label == "not_walking" for r in standing)


def test_bend_and_shoulder_down_are_labelled() -> None:
    t, a = synthetic_walk(pitch_offset=-17.0)
    assert run_stage(t, a)[-1].label == "bend"
    t, a = synthetic_walk(roll_offset=-6.0)
    assert run_stage(t, a)[-1].label == "left_shoulder_down"


def test_recalibration_on_request_moves_the_reference() -> None:
    stage = LiveIndicatorStage()
    t, a = synthetic_walk(seconds_stand=3.0, seconds_walk=6.0)
    run_stage(t, a, stage)
    assert stage.reference_deg == pytest.approx([1.0, -0.5, 0.3], abs=0.05)
    stage.request_calibration()
    t2 = t[-1] + 1 / FPS + np.arange(int(3 * FPS)) / FPS
    a2 = np.tile([-3.0, 2.0, 1.0], (t2.size, 1))
    res = run_stage(t2, a2, stage)
    events = [r.calibration for r in res if r.calibration is not None]
    assert events and events[0].reason == "request"
    assert stage.reference_deg == pytest.approx([-3.0, 2.0, 1.0], abs=1e-6)


def test_reset_restores_initial_state_and_settings_are_frozen_and_validated() -> None:
    stage = LiveIndicatorStage()
    t, a = synthetic_walk(seconds_walk=4.0)
    first = run_stage(t, a, stage)
    stage.reset()
    assert not stage.calibrated
    assert [r.to_dict() for r in run_stage(t, a, stage)] == [r.to_dict() for r in first]
    with pytest.raises(dataclasses.FrozenInstanceError):
        DEFAULT_LIVE_INDICATOR_SETTINGS.window_s = 3.0  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        first[0].walking = False  # type: ignore[misc]
    with pytest.raises(ValueError, match="hop_s"):
        dataclasses.replace(DEFAULT_LIVE_INDICATOR_SETTINGS, hop_s=0.0)


@pytest.mark.parametrize("walk", ["normal", "right_foot_drag", "left_shoulder_down", "bend"])
def test_live_and_offline_label_the_same_windows_alike(walk: str) -> None:
    """Issue 10/11: one classifier. Every live window of a steady simulated walk is also analysed offline
    (walkmon.gait.session.analyze_session on exactly the window's samples, with the live upright reference):
    the labels are identical, and they are the simulated walk type; a dragged foot is `unclassified` from the
    camera's rotation alone (its pitch maxima are no evidence of the feet's step times)."""
    from walkmon.gait.session import analyze_session
    from walkmon.simulate.gait import GaitModel

    model = GaitModel(walk, seconds=24, seed=2)
    t = np.arange(0, 24, 1 / FPS)
    a = model.truth_angles_deg(t) + np.random.default_rng(1).normal(0, 0.05, (t.size, 3))
    stage = LiveIndicatorStage()
    checked = 0
    for ti, ai in zip(t, a, strict=True):
        r = stage.push(ti, ai)
        if r is None or not 11 <= r.t_s <= 21:
            continue
        m = (t > r.t_s - stage.settings.window_s) & (t <= r.t_s)
        offline = analyze_session(t[m], a[m], reference_deg=stage.reference_deg).indicators
        want = "unclassified" if walk == "right_foot_drag" else walk
        assert r.label == offline.classification.label == want, (r.t_s, r.reasons, offline.classification)
        checked += 1
    assert checked >= 10


@pytest.mark.parametrize("walk", ["normal", "right_foot_drag", "left_shoulder_down", "bend"])
def test_live_windows_agree_with_the_offline_analysis_of_the_whole_walk(walk: str) -> None:
    """Median over the hops of a steady walk vs walkmon.gait.indicators on the whole session (offline targets:
    cadence 1 %, swing 10 %, pitch/roll inclination 0.5 deg), on the simulator's gait with estimator-like noise."""
    from walkmon.gait.indicators import compute_indicators
    from walkmon.simulate.gait import GaitModel

    model = GaitModel(walk, seconds=24, seed=1)
    t = np.arange(0, 24, 1 / FPS)
    a = model.truth_angles_deg(t) + np.random.default_rng(0).normal(0, 0.05, (t.size, 3))
    offline = compute_indicators(t, a).to_dict()
    res = [r for r in run_stage(t, a) if 11 <= r.t_s <= 21]  # windows inside the steady walk
    # a window may fall back to 'unclassified' (never to another label); the paper's whole-walk computation
    # (compute_indicators) still names the dragged foot from its sway
    labels = [r.label for r in res]
    if walk == "right_foot_drag":  # the camera's rotation alone is no evidence of the feet's step times
        assert set(labels) == {"unclassified"}
    else:
        assert set(labels) <= {walk, "unclassified"} and labels.count(walk) >= 0.9 * len(labels)
    assert offline["classification"]["label"] == walk
    assert np.median([r.cadence_spm for r in res]) == pytest.approx(offline["cadence_spm"], rel=0.01)
    for k, ax in enumerate(("pitch", "yaw", "roll")):
        assert np.median([r.swing_deg[k] for r in res]) == pytest.approx(offline["axes"][ax]["swing_mean"], rel=0.1)
    for k, ax in ((0, "pitch"), (2, "roll")):  # yaw: live keeps heading changes, offline detrends them
        assert np.median([r.inclination_deg[k] for r in res]) == pytest.approx(
            offline["axes"][ax]["inclination_mean"], abs=0.5)


@pytest.mark.parametrize("seed", [1, 4])  # seated reclined (+23 deg: walks read bent) and slumped (-33 deg)
@pytest.mark.parametrize(("script", "stands_before_walking"), [
    ("stand:0.5,sit:12,pause:1.5,stand:3,normal:20", True),  # stands up, stands a moment, walks off
    ("stand:0.5,sit:12,normal:12,pause:4,normal:10", False),  # walks off from the seat; a pause later
])
def test_a_still_stance_far_from_the_walking_posture_is_no_upright_reference(
    script: str, stands_before_walking: bool, seed: int
) -> None:
    """A wearer who starts the monitor seated (simulator truth: the chest 22-35 deg from upright) is still, and
    that stance was taken for upright: every normal walk after it read bent forward (or leaning back). Walking
    that reads more than ``still_tilt_deg`` from the reference rejects it: no posture label, and the next still
    stance near the walking posture (the one just before walking, when it is still in the window, else the
    next pause) becomes the reference."""
    from walkmon.simulate.gait import GaitModel

    model = GaitModel(script, seed=seed)
    t = np.arange(0, model.duration_s, 1 / FPS)
    a = model.truth_angles_deg(t) + np.random.default_rng(2).normal(0, 0.02, (t.size, 3))
    sit = next(p for p in model.pieces if p.activity == "unknown")
    out = run_stage(t, a)
    events = [r.calibration for r in out if r.calibration is not None]
    assert events[0].reason == "start" and sit.start_s < events[0].t_s < sit.end_s  # taken while seated
    walking = [r for r in out if r.walking]
    assert walking and not any(r.label in ("bend", "left_shoulder_down", "right_foot_drag") for r in walking), \
        [(r.t_s, r.label) for r in walking]
    again = [e for e in events[1:] if e.reason == "posture"]
    assert len(again) == 1 and again[0].t_s > sit.end_s
    upright = model.truth_angles_deg(np.array([again[0].t_s]))[0]
    assert np.allclose(again[0].angles_deg, upright, atol=2.0)  # the new reference is the standing pose
    first_walk = next(p for p in model.pieces if p.activity == "walking")
    normal = [r for r in walking if r.label == "normal"]
    if stands_before_walking:  # labelled from the first classified window on
        assert sum(r.label == "unclassified" for r in walking if r.t_s < first_walk.start_s + 6) <= 2
        assert len(normal) >= 0.8 * len(walking)
    else:  # unclassified (with the reason) until the pause, then normal
        pause = next(p for p in model.pieces if p.activity == "standing" and p.start_s > first_walk.start_s)
        before = [r for r in walking if r.t_s < pause.start_s]
        assert before and all(r.label == "unclassified" for r in before)
        assert any("no standing stance" in r.reasons[0] for r in before)
        assert normal and min(r.t_s for r in normal) > pause.start_s
        # and no posture to alert on meanwhile: the wearer walking upright is not told to straighten up
        rejected = [r for r in before if "no standing stance" in r.reasons[0]]
        assert all(math.isnan(r.posture_deg[0]) and math.isnan(r.posture_deg[2]) for r in rejected)
        assert all(math.isfinite(r.posture_deg[0]) for r in walking if r.t_s > again[0].t_s + 1.0)
    from walkmon.live.alerts import AlertStage

    alerts = AlertStage()
    raised = [e for r in out for e in alerts.push(r) if e.state == "raised"]
    assert raised == [], raised


def test_a_calibration_request_while_the_reference_is_rejected_keeps_its_name() -> None:
    """The wearer's own request (SIGUSR1) made while a seated reference is rejected is logged as a request
    when the next still stance near the walking posture answers it."""
    from walkmon.simulate.gait import GaitModel

    model = GaitModel("stand:0.5,sit:12,normal:12,pause:4,normal:10", seed=1)
    t = np.arange(0, model.duration_s, 1 / FPS)
    a = model.truth_angles_deg(t) + np.random.default_rng(2).normal(0, 0.02, (t.size, 3))
    stage = LiveIndicatorStage()
    events, asked = [], False
    for ti, ai in zip(t, a, strict=True):
        r = stage.push(ti, ai)
        if r is None:
            continue
        if r.calibration is not None:
            events.append(r.calibration)
        if not asked and r.reasons and "no standing stance" in r.reasons[0]:
            assert not stage.calibrated  # a rejected reference is no calibration
            stage.request_calibration()
            asked = True
    assert asked and [e.reason for e in events] == ["start", "request"]
    assert stage.calibrated


@pytest.mark.parametrize("seed", [2, 4, 8])
def test_straightening_up_is_not_labelled_bent_while_the_window_still_holds_the_bend(seed: int) -> None:
    """A wearer walks bent, then straightens up and walks on (simulator truth). The live window (8 s) mixes both
    postures until the new one can be split off (4 s of it), and its mean read ``bend`` for 2-3 hops after the
    trunk was upright: an alarm for a walk that is normal. Those hops are now unclassified with the reason; the
    bent walk before is still labelled bend, and the normal walk normal once it fills the split."""
    from walkmon.simulate.gait import GaitModel

    model = GaitModel("stand:3,bend:12,normal:12", seed=seed)
    t = np.arange(0, model.duration_s, 1 / FPS)
    a = model.truth_angles_deg(t) + np.random.default_rng(2).normal(0, 0.02, (t.size, 3))
    out = [r for r in run_stage(t, a) if r.walking]
    bend = next(p for p in model.pieces if p.label == "bend")
    normal = next(p for p in model.pieces if p.label == "normal")
    # the truth: upright from the end of the posture ramp (< 1.5 s) on
    upright_from = normal.start_s + 1.5
    assert abs(model.truth_angles_deg(np.array([upright_from + 0.5]))[0, 0]
               - model.truth_angles_deg(np.array([3.0]))[0, 0]) < 3.0
    late = [(r.t_s, r.label) for r in out if r.t_s >= upright_from + 1.5 and r.label != "normal"]
    assert not [x for x in late if x[1] in ("bend", "left_shoulder_down", "right_foot_drag")], late
    assert any("read upright again" in r.reasons[0] for r in out if r.label == "unclassified")
    assert sum(r.label == "bend" for r in out if bend.start_s + 4.0 < r.t_s <= bend.end_s) >= 7
    assert sum(r.label == "normal" for r in out if r.t_s > normal.start_s + 6.0) >= 5


@pytest.mark.parametrize("seed", [1, 5])
def test_a_posture_change_across_a_turn_gives_no_alarm_after_it(seed: int) -> None:
    """A camera tilted 12 deg down on the chest; the wearer walks normally, bends, turns round while
    straightening up, and walks on upright (simulator truth). The turn's axis (poses either side) was gravity's
    direction for the stage, tilted by the posture change, and every hop of the upright walk after it read bent.
    The turn's own rotation axis disagrees with it (turn_axis_doubt_deg): the labels a doubt that large could
    change are withheld, with the reason; the bent walk before the turn is still labelled bend."""
    from walkmon.simulate.gait import GaitModel

    model = GaitModel("mount:-12:-2,stand:3,normal:8,bend:10,turn:180,normal:12", seed=seed)
    t = np.arange(0, model.duration_s, 1 / FPS)
    a = model.truth_angles_deg(t) + np.random.default_rng(2).normal(0, 0.02, (t.size, 3))
    out = [r for r in run_stage(t, a) if r.walking]
    bend = next(p for p in model.pieces if p.label == "bend")
    after = [p for p in model.pieces if p.label == "normal"][-1]
    late = [r for r in out if after.start_s + 4.0 <= r.t_s <= after.end_s]
    assert late and not any(r.label in ("bend", "left_shoulder_down", "right_foot_drag") for r in late), \
        [(r.t_s, r.label) for r in late]
    assert any("rests on turns whose axes are in doubt" in " ".join(r.reasons) for r in late)
    assert sum(r.label == "bend" for r in out if bend.start_s + 4.0 < r.t_s <= bend.end_s) >= 5


@pytest.mark.parametrize("seed", [1, 3])
def test_a_still_pause_after_a_turn_re_references_the_video(seed: int) -> None:
    """A camera tilted 12 deg on the chest; a shoulder-down walk, a U-turn in which the video's pitch drifts by
    6 deg (added to the simulator's truth), a still pause (upright, simulator truth), and the walk on. The drift
    puts gravity's direction from the turn in doubt, and the labels after the turn were withheld for the rest of
    the walk. The pause's still stance, within 8 deg of the reference, becomes the reference (logged with
    reason "pause"), as the offline analysis' standing anchors: the walk after it is labelled again."""
    from walkmon.simulate.gait import GaitModel

    model = GaitModel("mount:-12:-2,stand:3,left_shoulder_down:8,turn:180,left_shoulder_down:6,pause:3,"
                      "left_shoulder_down:12", seed=seed)
    t = np.arange(0, model.duration_s, 1 / FPS)
    a = model.truth_angles_deg(t) + np.random.default_rng(2).normal(0, 0.02, (t.size, 3))
    turn = next(p for p in model.pieces if p.activity == "turning")
    a[:, 0] += 6.0 * np.clip((t - turn.start_s) / (turn.end_s - turn.start_s), 0.0, 1.0)
    pause = [p for p in model.pieces if p.activity == "standing"][-1]
    assert np.all(np.abs(model.body_angles_deg(np.array([pause.start_s + 1.0]))[0][[0, 2]]) < 1.0)  # upright
    out = run_stage(t, a)
    events = [r.calibration for r in out if r.calibration is not None]
    assert [e.reason for e in events] == ["start", "pause"]
    assert pause.start_s < events[1].t_s <= pause.end_s + 0.5
    last = [p for p in model.pieces if p.label][-1]
    late = [r.label for r in out if r.walking and r.t_s >= last.start_s + 4.0]
    assert late and all(v == "left_shoulder_down" for v in late), late


@pytest.mark.parametrize("seed", [1, 3])
def test_a_turn_left_out_of_gravitys_direction_leaves_out_its_doubt(seed: int) -> None:
    """Three U-turns with a tilted camera; in the first the wearer straightens up from a bend (its axis is off
    gravity by 7-10 deg and disagrees with the others, so gravity's direction leaves it out). Its doubt must not
    withhold the labels of a shoulder-down walk after the third turn (found in review: the doubt was taken over
    every turn seen)."""
    from walkmon.simulate.gait import GaitModel

    model = GaitModel("mount:-12:-2,stand:3,bend:6,turn:180,normal:6,turn:180,normal:6,turn:180,normal:4,"
                      "left_shoulder_down:10", seed=seed)
    t = np.arange(0, model.duration_s, 1 / FPS)
    a = model.truth_angles_deg(t) + np.random.default_rng(2).normal(0, 0.02, (t.size, 3))
    out = run_stage(t, a)
    last = [p for p in model.pieces if p.label][-1]
    late = [r.label for r in out if r.walking and r.t_s >= last.start_s + 4.0]
    assert len(late) >= 5 and late.count("left_shoulder_down") >= len(late) - 2, late
    assert "bend" not in late and "right_foot_drag" not in late


@pytest.mark.parametrize(("seed", "roll_deg"), [(1, 6.0), (2, -6.0)])
def test_a_tilted_pause_after_a_turn_is_no_reference(seed: int, roll_deg: float) -> None:
    """A pause after a U-turn with the trunk rolled 6 deg (leaning on one leg), then an upright walk (simulator
    truth: the model's trunk angles with the roll added in the pause, composed with the camera's mount as the
    model composes them). Taken as the reference (within the offline anchors' 8 deg, the first version), it made
    the upright walk read 6 deg the other way: a shoulder_down alert and left_shoulder_down labels on a normal
    walk (found in review). A pause re-references only within the classifier's normal range (3 deg)."""
    from walkmon.consts import angles_deg_from_rotation, rot_x, rot_y, rot_z, rotation_from_angles_deg
    from walkmon.simulate.gait import GaitModel

    model = GaitModel("mount:-12:-2,stand:3,normal:8,turn:180,normal:5,pause:4,normal:16", seed=seed)
    t = np.arange(0, model.duration_s, 1 / FPS)
    body = model.body_angles_deg(t).copy()
    pause = [p for p in model.pieces if p.activity == "standing"][-1]
    ramp = np.clip((t - pause.start_s) / 0.5, 0, 1) * np.clip((pause.end_s - t) / 0.5, 0, 1)
    body[:, 2] += roll_deg * ramp
    r = np.radians(body)
    mount = rotation_from_angles_deg(model.mount_deg[0], 0.0, model.mount_deg[1])
    a = angles_deg_from_rotation(rot_y(r[:, 1]) @ rot_x(r[:, 0]) @ rot_z(r[:, 2]) @ mount)
    a += np.random.default_rng(2).normal(0, 0.02, a.shape)
    assert np.allclose(angles_deg_from_rotation(model.rotation(t[:5])), a[:5], atol=0.2)  # composed as the model
    out, raised = run_with_alerts(t, a, LiveIndicatorStage())
    assert not [r for r in out if r.calibration is not None and r.calibration.reason == "pause"]
    assert raised == [], raised
    last = [p for p in model.pieces if p.label == "normal"][-1]
    late = [r for r in out if r.walking and r.t_s >= last.start_s + 4.0]
    assert late and not any(r.label in ("bend", "left_shoulder_down", "right_foot_drag") for r in late)
    assert all(abs(r.posture_deg[2]) < 3.0 for r in late)


@pytest.mark.parametrize("seed", [1, 2])
def test_a_video_drift_across_a_pick_up_labels_no_bend(seed: int) -> None:
    """Two U-turns (gravity's direction learnt, a pause re-references), picking something up, standing, a normal
    walk (simulator truth), with 10 deg of pitch a video lost across the pick-up added from it on (the chest drops
    while it pitches, which the camera can take for a rotation: 8 deg in an unkind session). The stance after it
    reads too far off to re-reference (3 deg), so the walk after it read bent forward (the held-out live replay:
    2 pathology hops on true normal walking). Each stretch of tilting far and fast since the reference now allows
    4 deg of drift (the offline bound for a turn): no bend label; the walk before the pick-up keeps its label."""
    from walkmon.simulate.gait import GaitModel

    model = GaitModel("mount:-12:-1,stand:3,normal:6,turn:180,normal:6,turn:180,normal:6,pause:3,pickup:4,stand:3,"
                      "normal:10", seed=seed)
    t = np.arange(0, model.duration_s, 1 / FPS)
    a = model.truth_angles_deg(t) + np.random.default_rng(seed).normal(0, 0.02, (t.size, 3))
    pick = next(p for p in model.pieces if p.activity == "unknown")
    a[:, 0] -= 10.0 * np.clip((t - pick.start_s) / (pick.end_s - pick.start_s), 0.0, 1.0)
    out = run_stage(t, a)
    walks = [p for p in model.pieces if p.label == "normal"]
    before = [r.label for r in out if r.walking and walks[-2].start_s + 4.0 <= r.t_s <= walks[-2].end_s]
    last = [r.label for r in out if r.walking and r.t_s >= walks[-1].start_s + 4.0]
    assert before and all(lab == "normal" for lab in before), before
    assert last and not any(lab in ("bend", "left_shoulder_down", "right_foot_drag") for lab in last), last


def test_a_shoulder_down_walk_after_a_pick_up_keeps_its_label() -> None:
    """The drift a pick-up may leave is a pitch drift: a shoulder-down walk after it (6 deg of pitch drift added,
    simulator truth) keeps its label (review: the drift's doubt on the roll too withheld every such label)."""
    from walkmon.simulate.gait import GaitModel

    model = GaitModel("mount:-12:-1,stand:3,normal:6,turn:180,normal:6,turn:180,normal:6,pause:3,pickup:4,stand:3,"
                      "left_shoulder_down:12", seed=1)
    t = np.arange(0, model.duration_s, 1 / FPS)
    a = model.truth_angles_deg(t) + np.random.default_rng(1).normal(0, 0.02, (t.size, 3))
    pick = next(p for p in model.pieces if p.activity == "unknown")
    a[:, 0] -= 6.0 * np.clip((t - pick.start_s) / (pick.end_s - pick.start_s), 0.0, 1.0)
    out = run_stage(t, a)
    last = [p for p in model.pieces if p.label == "left_shoulder_down"][-1]
    labels = [r.label for r in out if r.walking and r.t_s >= last.start_s + 4.0]
    assert len(labels) >= 5 and labels.count("left_shoulder_down") >= len(labels) - 1, labels


def test_no_posture_alert_before_an_upright_reference() -> None:
    """A walk that starts mid-walk with the left shoulder 6 deg down, then a normal walk (simulator truth): the
    first frame is the reference, assumed upright, and the normal walk read 6 deg the other way, raising "right
    shoulder down" (an unkind session's live replay; here at 17 s, the left shoulder 6.4 deg down at the start).
    Before a still stance no posture alert is raised; after one, a shoulder held down raises it as before."""
    from walkmon.consts import angles_deg_from_rotation, gravity_angles_deg_from_gravity
    from walkmon.live.alerts import AlertStage
    from walkmon.simulate.gait import GaitModel

    model = GaitModel("mount:-5:0,left_shoulder_down:10,normal:20", seed=1, stand_s=0.0)  # starts mid-walk
    t = np.arange(0, model.duration_s, 1 / FPS)
    rot = model.rotation(t)
    a = angles_deg_from_rotation(rot[0].T @ rot)  # relative to the first frame, as a camera measures
    a += np.random.default_rng(4).normal(0, 0.02, a.shape)
    out, raised = run_with_alerts(t, a, LiveIndicatorStage())
    assert not any(r.calibrated for r in out)
    assert not [e for e in raised if e.kind in ("shoulder_down", "lean_forward")], raised
    # labels are still given against the assumed reference, saying so
    labelled = [r for r in out if r.label in ("normal", "left_shoulder_down", "bend")]
    assert labelled and all(any("upright reference assumed" in why for why in r.reasons) for r in labelled)
    # an IMU's gravity does not tell the trunk's upright pose on the camera either (review): no alert fused
    stage, alerts = LiveIndicatorStage(), AlertStage()
    down = np.einsum("nji,j->ni", rot, [0.0, 1.0, 0.0])  # the world's down (+y) in the camera, per frame
    g = gravity_angles_deg_from_gravity(down)
    fused = []
    for ti, ai, gi in zip(t, a, g, strict=True):
        hop = stage.push(ti, ai, (float(gi[0]), float(gi[1])))
        if hop is not None:
            fused += [e for e in alerts.push(hop) if e.state == "raised"]
    assert stage._gravity_known and not fused, fused
    model = GaitModel("mount:-5:0,stand:3,normal:6,left_shoulder_down:14", seed=4)
    t = np.arange(0, model.duration_s, 1 / FPS)
    a = model.truth_angles_deg(t) + np.random.default_rng(4).normal(0, 0.02, (t.size, 3))
    _, raised = run_with_alerts(t, a, LiveIndicatorStage())
    assert [e.kind for e in raised] == ["shoulder_down"], raised


@pytest.mark.parametrize(("turn_deg", "seed"), [(-45, 1), (30, 2), (45, 2)])
def test_a_tilted_camera_after_a_small_turn_raises_no_alert(turn_deg: int, seed: int) -> None:
    """A camera 12 deg down on the chest, a normal walk, a turn of 30-45 deg (a corner: too small to learn
    gravity's direction from, >= 60 deg) and the normal walk on (simulator truth). The start-relative angles then
    mix the camera's tilt into pitch and roll (5-10 deg of roll read): a shoulder_down alert, left_shoulder_down
    labels, and an asymmetric_gait alert from the roll and yaw leaking into the start-relative pitch (found in
    review). The tilt doubt of an unknown direction (the camera's tilt on the trunk, up to 20 deg, times
    2 sin(dpsi/2)) withholds the labels and is taken off the posture before the alerts compare it; the step
    asymmetry is measured only where the pitch does not depend on the heading."""
    from walkmon.simulate.gait import GaitModel

    model = GaitModel(f"mount:-12:-2,stand:3,normal:8,turn:{turn_deg},normal:14", seed=seed)
    t = np.arange(0, model.duration_s, 1 / FPS)
    a = model.truth_angles_deg(t) + np.random.default_rng(2).normal(0, 0.02, (t.size, 3))
    stage = LiveIndicatorStage()
    out, raised = run_with_alerts(t, a, stage)
    assert stage.vertical is None  # no turn to learn gravity's direction from
    assert raised == [], [(e.t_s, e.kind) for e in raised]
    walking = [r for r in out if r.walking]
    assert walking and not any(r.label in ("bend", "left_shoulder_down", "right_foot_drag") for r in walking)
    last = [p for p in model.pieces if p.label == "normal"][-1]
    late = [r for r in walking if r.t_s >= last.start_s + 4.0]
    assert late and all(r.posture_doubt_deg > 5.0 for r in late)  # 2 sin(15..22 deg) x 20 deg
    before = [r for r in walking if r.t_s < last.start_s - 2.0]
    assert before and all(r.posture_doubt_deg < 1.0 for r in before)  # facing the reference's way: no doubt


@pytest.mark.parametrize("lr", [1.0, 2.0])
def test_a_trunk_that_pitches_differently_left_and_right_raises_no_asymmetry_alert(lr: float) -> None:
    """A normal walk whose trunk pitches differently on the left and right steps (the simulator's lr token; real
    trunks do, the Mobilise-D lower backs to the point of a pitch that repeats once per stride): the step times
    do not alternate, but the pitch's stride-frequency amplitude and the timing of its maxima read as if they did
    (an asymmetric_gait alert, alternate steps 1.27-1.5 apart): the camera alone measures no step asymmetry."""
    from walkmon.simulate.gait import GaitModel

    model = GaitModel(f"lr:{lr},stand:3,normal:30,stand:2", seed=4)
    t = np.arange(0, model.duration_s, 1 / FPS)
    a = model.truth_angles_deg(t) + np.random.default_rng(3).normal(0, 0.02, (t.size, 3))
    out, raised = run_with_alerts(t, a, LiveIndicatorStage())
    assert [e.kind for e in raised] == []
    walking = [r for r in out if r.walking]
    assert walking and all(not np.isfinite(r.step_asymmetry) for r in walking)  # not measured from the camera
    assert not any(r.label == "right_foot_drag" for r in walking)


def _run_covered(t: np.ndarray, a: np.ndarray, covered: np.ndarray) -> dict[int, LiveIndicators]:
    """The hops (by whole second) of a fresh stage fed (t, a), the ``covered`` frames as measuring nothing."""
    stage = LiveIndicatorStage()
    got = {}
    for ti, ai, c in zip(t, a, covered, strict=True):
        h = stage.push_unmeasured(ti) if c else stage.push(ti, ai)
        if h is not None:
            got[round(h.t_s)] = h
    return got


def test_unmeasured_frames_keep_the_hops_going_and_read_unknown_never_standing() -> None:
    """Frames that measured nothing (push_unmeasured: a covered lens) give hops on time whose activity is unknown
    once nothing was measured for max_gap_s, with no posture; a session that starts covered says so; and when
    measuring resumes the stage waits 2 s before it names the activity again, then finds the walking."""
    stage = LiveIndicatorStage()
    hops = [h for h in (stage.push_unmeasured(i / FPS) for i in range(int(4 * FPS))) if h is not None]
    assert [round(h.t_s, 3) for h in hops] == [1.0, 2.0, 3.0]
    assert all(h.activity == "unknown" and not h.walking for h in hops)
    assert all("nothing measured since the start" in h.reasons[0] for h in hops)

    t, a = synthetic_walk(seconds_stand=3.0, seconds_walk=20.0)
    covered = (t >= 10.0) & (t < 14.0)  # walking all along; the lens covered for 4 s
    got = _run_covered(t, a, covered)
    assert got[9].activity == "walking"
    for k in (12, 13):  # more than max_gap_s (1 s) into the cap
        assert got[k].activity == "unknown" and "nothing measured for" in got[k].reasons[0]
        assert all(math.isnan(v) for v in got[k].posture_deg)
    assert got[14].activity == "unknown" and "measuring again" in got[14].reasons[0]
    assert all(got[k].activity != "standing" for k in range(10, 17))
    assert all(got[k].activity == "walking" for k in range(17, 23))


def test_a_cap_longer_than_the_window_and_a_covered_start_give_no_posture_from_a_stride() -> None:
    """Review cases: a cap longer than the 8 s window still says how long nothing was measured (the window's
    trimming used to turn it into 'since the start'), and when measuring resumes, after such a cap or at a session
    that starts covered, the first hops give no posture or cadence from the stride or less in the window (one
    sample gave a posture of -1.9 deg roll mid-stride)."""
    t, a = synthetic_walk(seconds_stand=3.0, seconds_walk=30.0)
    covered = (t >= 10.0) & (t < 20.0)
    got = _run_covered(t, a, covered)
    for k in range(11, 20):
        assert got[k].activity == "unknown" and f"nothing measured for {k - 10 + 0.03:.1f} s" in got[k].reasons[0]
    for k in (20, 21):
        assert got[k].activity == "unknown" and "measuring again after nothing measured for 10.0 s" in got[k].reasons[0]
        assert all(math.isnan(v) for v in (*got[k].posture_deg, got[k].cadence_spm))
    assert all(got[k].activity == "walking" for k in range(24, 33))

    stage = LiveIndicatorStage()
    for i in range(30):  # covered for the first second
        stage.push_unmeasured(i / FPS)
    first = stage.push(1.0, (0.0, 0.0, -1.9))
    assert first is not None and first.n_samples == 1 and first.activity == "unknown"
    assert "measuring again after nothing measured since the start" in first.reasons[0]
    assert all(math.isnan(v) for v in first.posture_deg)


def test_max_gap_must_be_shorter_than_the_window() -> None:
    from walkmon.gait.live import LiveIndicatorSettings

    with pytest.raises(ValueError, match="max_gap_s must be less than window_s"):
        LiveIndicatorSettings(max_gap_s=8.0)
    with pytest.raises(ValueError, match="max_gap_s must be > 0"):
        LiveIndicatorSettings(max_gap_s=0.0)


@pytest.mark.parametrize("seed", [1, 3, 4])
def test_sitting_again_after_a_seated_start_is_not_standing(seed: int) -> None:
    """Review: with the start's seated reference rejected (no posture then), the rule above did nothing and the
    second sit was logged standing (10 hops of 11), where the offline analysis says unknown. (Seed 2 is another
    case, not handled: its first sit is never still, the walk reads normal against the first frame, and the second
    sit becomes the first calibration, seated, so it reads upright until the walk after it rejects it.)"""
    from walkmon.simulate.gait import GaitModel

    model = GaitModel("sit:6,normal:10,sit:14,normal:6", seed=seed)
    t = np.arange(0, model.duration_s, 1 / FPS)
    a = model.truth_angles_deg(t) + np.random.default_rng(2).normal(0, 0.02, (t.size, 3))
    sit = [p for p in model.pieces if p.activity == "unknown"][-1]
    out = run_stage(t, a)
    seated = [r for r in out if sit.start_s + 4.0 <= r.t_s <= sit.end_s - 2.0]
    assert seated and all(r.activity == "unknown" for r in seated), [(r.t_s, r.activity) for r in seated]


@pytest.mark.parametrize("seed", [1, 2])
def test_sitting_still_after_a_walk_is_not_standing(seed: int) -> None:
    """User review: hops of a wearer seated still (the chest 27-30 deg from upright, truth 'unknown') were logged
    'standing', which the dashboard, history and report counted as standing; the offline timeline's rule (still
    but tilted > still_tilt_deg from upright: sitting, lying or bent down) now holds live too."""
    from walkmon.simulate.gait import GaitModel

    model = GaitModel("stand:4,normal:8,sit:14,normal:6", seed=seed)
    t = np.arange(0, model.duration_s, 1 / FPS)
    a = model.truth_angles_deg(t) + np.random.default_rng(2).normal(0, 0.02, (t.size, 3))
    sit = next(p for p in model.pieces if p.activity == "unknown")
    truth = model.truth_angles_deg(np.array([sit.start_s + 0.5 * (sit.end_s - sit.start_s)]))[0]
    assert abs(truth[0]) > 20.0  # the simulator's seated chest
    out = run_stage(t, a)
    seated = [r for r in out if sit.start_s + 4.0 <= r.t_s <= sit.end_s - 2.0]
    assert seated and all(r.activity == "unknown" for r in seated), [(r.t_s, r.activity) for r in seated]
    stood = [r for r in out if 2.0 <= r.t_s <= 3.5]
    assert stood and all(r.activity == "standing" for r in stood)  # the upright stance stays standing
