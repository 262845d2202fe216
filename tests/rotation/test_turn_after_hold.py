"""A turn that speeds up past ``max_ok_rate_deg_s`` just as a frame is held is flagged on the frame after the hold;
a fast turn's tail is flagged until a fit that is not itself in doubt measures the rate halved.

A held frame (implausible step, few inliers, lost tracks) restarts the tracks on itself, so the next frame's
change spans one frame. Its rate was taken over two frames (from the last accepted one), half the true rate:
turns seed 4 (640x480) reported a frame of a 93 deg/s turn ok, 0.9 deg off. Here a camera yaws in front of a
textured plane at infinity (exact pure rotation, rendered independently of the estimator) at 75 deg/s, then
speeds up to 120 deg/s; one frame's fit is made implausible on purpose.
"""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from walkmon.camera.model import default_camera
from walkmon.rotation import RotationEstimator, RotationSettings
from walkmon.rotation import fast as fast_module

W, H = 320, 240
FPS = 30.0
HELD_FRAME = 9


def _yaw_deg(t: np.ndarray) -> np.ndarray:
    """75 deg/s until 0.25 s, then the rate ramps linearly to 120 deg/s at 0.35 s and stays."""
    t = np.asarray(t, dtype=float)
    r0, r1, t0, t1 = 75.0, 120.0, 0.25, 0.35
    ramp = r0 * t + (r1 - r0) * (t - t0) ** 2 / (2 * (t1 - t0))
    after = (r0 * t0) + (r0 + r1) / 2 * (t1 - t0) + r1 * (t - t1)
    return np.where(t < t0, r0 * t, np.where(t < t1, ramp, after))


def _render(yaw_deg, n: int = 16, readout_s: float = 0.0):
    """Frames of a camera yawing by ``yaw_deg(t)`` in front of a textured plane at infinity, and their truth. With
    ``readout_s`` > 0 a rolling shutter: each image row seen at its own time over the readout (the middle row at the
    frame time), and the camera told its readout."""
    cam = default_camera(W, H)
    K, Kinv = cam.camera_matrix, np.linalg.inv(cam.camera_matrix)
    rng = np.random.default_rng(3)
    tex = cv2.resize((rng.random((H // 2, W)) * 255).astype(np.uint8), (8 * W, 4 * H), interpolation=cv2.INTER_CUBIC)
    tex = cv2.GaussianBlur(tex, (0, 0), 1.5)
    Kt = K.copy()
    Kt[0, 2], Kt[1, 2] = 2 * W, 2 * H  # the texture's centre a quarter of the way in: room to turn right
    u, v = np.meshgrid(np.arange(W, dtype=float), np.arange(H, dtype=float))
    rays = np.stack([u, v, np.ones_like(u)], -1) @ Kinv.T
    row_dt = readout_s * ((np.arange(H) + 0.5) / H - 0.5)
    frames, truth = [], []
    for i in range(n):
        yaw_rows = np.radians(np.asarray(yaw_deg(i / FPS + row_dt), dtype=float))
        c, sn = np.cos(yaw_rows)[:, None], np.sin(yaw_rows)[:, None]
        x, y, z = rays[..., 0], rays[..., 1], rays[..., 2]
        p = np.stack([c * x + sn * z, y, -sn * x + c * z], -1) @ Kt.T  # Ry(yaw) of each row's time
        frames.append(cv2.remap(tex, (p[..., 0] / p[..., 2]).astype(np.float32),
                                (p[..., 1] / p[..., 2]).astype(np.float32), cv2.INTER_LINEAR))
        truth.append(Rotation.from_euler("y", float(yaw_deg(np.array(i / FPS))), degrees=True).as_matrix())
    return (dataclasses.replace(cam, readout_s=readout_s) if readout_s > 0 else cam), frames, np.array(truth)


@pytest.fixture(scope="module")
def speeding_turn():
    return _render(_yaw_deg)


def test_the_frame_after_a_held_one_in_a_fast_turn_is_flagged(speeding_turn, monkeypatch) -> None:
    cam, frames, truth = speeding_turn
    original = fast_module.FastEngine._fit

    def fit(self, t_s, n):
        out = original(self, t_s, n)
        if round(t_s * FPS) == HELD_FRAME:  # tracks latched onto a wrong pattern: a 10 deg jump
            return dataclasses.replace(out, rotation=out.rotation @ Rotation.from_euler("x", 10, degrees=True).as_matrix())
        return out

    monkeypatch.setattr(fast_module.FastEngine, "_fit", fit)
    est = RotationEstimator(cam)
    out = [est.push(f, i / FPS) for i, f in enumerate(frames)]
    assert out[HELD_FRAME].reason == "implausible_step"
    # true_rate[i]: frame i's true turning rate (from frame i - 1)
    true_rate = np.degrees([0.0] + [Rotation.from_matrix(truth[i - 1].T @ truth[i]).magnitude() for i in range(1, 16)])
    true_rate *= FPS
    limit = RotationSettings().max_ok_rate_deg_s
    assert true_rate[HELD_FRAME - 1] < 0.9 * limit  # the turn was slow enough to be ok before the hold
    assert true_rate[HELD_FRAME + 1] > 1.1 * limit  # and is fast after it
    ok = [o.status.value == "ok" for o in out]
    assert not any(ok[i] for i in range(16) if true_rate[i] > 1.1 * limit), [o.reason for o in out]
    assert out[HELD_FRAME + 1].reason == "fast_rotation"
    # before the turn sped up, the frames were ok and right (the hold's cause was injected, not the images')
    assert all(ok[1:HELD_FRAME])


def _rates(truth: np.ndarray) -> np.ndarray:
    """Each frame's true turning rate (deg/s, from the frame before)."""
    n = len(truth)
    return FPS * np.degrees([0.0] + [Rotation.from_matrix(truth[i - 1].T @ truth[i]).magnitude() for i in range(1, n)])


def _inject(monkeypatch, frame, change) -> None:
    """Replace the fit of ``frame`` (a frame number, or a set of them) by ``change(fit)``."""
    frames = {frame} if isinstance(frame, int) else set(frame)
    original = fast_module.FastEngine._fit

    def fit(self, t_s, n):
        out = original(self, t_s, n)
        return change(out) if round(t_s * FPS) in frames else out

    monkeypatch.setattr(fast_module.FastEngine, "_fit", fit)


@pytest.mark.parametrize(("rate", "flagged"), [(70.0, True), (30.0, False)])
def test_after_a_held_frame_the_rate_is_unknown_until_an_ok_fit_measures_it(rate, flagged, monkeypatch) -> None:
    """A steady turn at 70 deg/s (under max_ok_rate_deg_s, above half of it) with one frame held: the rate the
    frames after the hold are judged by is measured against the held frame (a rolling-shutter frame right after
    a hold was corrected with the rate from before it: rolling_shutter seed 3, ok 0.64 deg off in one frame), so
    they are a turn's tail until the rate halves; at a walking rate (30 deg/s) they are ok as before."""
    cam, frames, truth = _render(lambda t: rate * t)
    _inject(monkeypatch, HELD_FRAME, lambda f: dataclasses.replace(
        f, rotation=f.rotation @ Rotation.from_euler("x", 10, degrees=True).as_matrix()))
    est = RotationEstimator(cam)
    out = [est.push(f, i / FPS) for i, f in enumerate(frames)]
    assert out[HELD_FRAME].reason == "implausible_step"
    limit = RotationSettings().max_ok_rate_deg_s
    true_rate = _rates(truth)
    assert np.all(true_rate[1:] < 0.9 * limit)
    assert all(o.status.value == "ok" for o in out[1:HELD_FRAME])  # before the hold: ok
    after = [o.reason for o in out[HELD_FRAME + 1:]]
    if flagged:
        assert np.all(true_rate[HELD_FRAME + 1:] > 0.55 * limit)
        assert after == ["fast_rotation"] * len(after)
    else:
        assert np.all(true_rate[HELD_FRAME + 1:] < 0.45 * limit)
        assert after == [""] * len(after)


def test_a_fit_in_doubt_does_not_end_a_fast_turns_tail(monkeypatch) -> None:
    """A turn at 120 deg/s slowing to 70 deg/s: the frames at 70 are its tail (flagged) until the rate halves.
    One frame's fit is in doubt (planar_ambiguity) and reads too slow a turn: it must not end the tail (a
    turn's end read 42 deg/s where the camera turned at 81, and the next two frames, at 73 and 61 deg/s, were
    reported ok 0.8 deg off in one frame: rolling_shutter seed 1)."""

    def yaw(t):
        t = np.asarray(t, dtype=float)
        r0, r1, t0, t1 = 120.0, 70.0, 0.15, 0.25
        ramp = r0 * t + (r1 - r0) * (t - t0) ** 2 / (2 * (t1 - t0))
        after = r0 * t0 + (r0 + r1) / 2 * (t1 - t0) + r1 * (t - t1)
        return np.where(t < t0, r0 * t, np.where(t < t1, ramp, after))

    cam, frames, truth = _render(yaw)
    doubt = HELD_FRAME

    def slow_and_in_doubt(f):
        # 1.5 deg less turn in this frame (within the jerk limit): a measured rate of ~25 deg/s
        less = Rotation.from_euler("y", -1.5, degrees=True).as_matrix()
        return dataclasses.replace(f, rotation=f.rotation @ less, status=fast_module.EstimateStatus.LOW_QUALITY,
                                   reason="planar_ambiguity")

    _inject(monkeypatch, doubt, slow_and_in_doubt)
    est = RotationEstimator(cam)
    out = [est.push(f, i / FPS) for i, f in enumerate(frames)]
    limit = RotationSettings().max_ok_rate_deg_s
    true_rate = _rates(truth)
    assert np.all(true_rate[doubt + 1:] > 0.7 * limit) and np.all(true_rate[doubt + 1:] < 0.9 * limit)
    assert out[doubt].reason == "planar_ambiguity"
    assert all(o.reason == "fast_rotation" for o in out[doubt + 1:]), [o.reason for o in out]


def _start_relative_errors_deg(out, truth: np.ndarray) -> np.ndarray:
    """Each frame's orientation error (deg) against the rendered truth, both relative to the first frame."""
    rel = np.einsum("ji,njk->nik", truth[0], truth)
    return np.array([Rotation.from_matrix(r.T @ o.rotation).magnitude() for r, o in zip(rel, out, strict=True)]) * (
        180.0 / np.pi)


def _jump(f):
    """A fit 10 deg off (tracks latched onto a wrong pattern): implausible, so the frame cannot be measured."""
    return dataclasses.replace(f, rotation=f.rotation @ Rotation.from_euler("x", 10, degrees=True).as_matrix())


def _run(cam, frames, fps: float = FPS):
    """Every frame through a fresh estimator, frame ``i`` at ``i / fps``."""
    est = RotationEstimator(cam)
    return [est.push(f, i / fps) for i, f in enumerate(frames)]


def _steady_turn_with_one_implausible_fit(monkeypatch, rate_deg_s: float):
    """A steady turn at ``rate_deg_s`` whose HELD_FRAME fit is implausible: the estimates and the truth."""
    cam, frames, truth = _render(lambda t: rate_deg_s * t)
    _inject(monkeypatch, HELD_FRAME, _jump)
    out = _run(cam, frames)
    assert out[HELD_FRAME].reason == "implausible_step"
    return out, truth


def test_a_frame_that_cannot_be_measured_in_a_turn_is_carried_on_at_the_turns_rate(monkeypatch) -> None:
    """A steady turn at 70 deg/s (2.3 deg a frame) with one frame's fit implausible: held, the frame's rotation was
    lost for good (every later frame 2.3 deg off; two held frames of the scenario clips' turns were 3.2 and 2.7 deg
    off); carried on at the last measured rate (model ``coast``, still flagged) it is right to the rate's
    change, and so is the rest of the turn."""
    out, truth = _steady_turn_with_one_implausible_fit(monkeypatch, 70.0)
    assert out[HELD_FRAME].model == "coast"
    assert out[HELD_FRAME].status.value == "low_quality"
    err = _start_relative_errors_deg(out, truth)
    assert err[HELD_FRAME - 1] < 0.1  # measured: the turn itself is easy (a plane at infinity)
    assert err[HELD_FRAME] < 0.3, err
    assert err[-1] < 0.3, err  # a held frame left 2.3 deg here


def test_only_one_frame_in_a_row_is_carried_on(monkeypatch) -> None:
    """Two unmeasurable frames in a row: the first is carried on, the second held (beyond one frame the rate is a
    guess: a lens cap in a turn must not spin the orientation on)."""
    cam, frames, _ = _render(lambda t: 70.0 * t)
    _inject(monkeypatch, {HELD_FRAME, HELD_FRAME + 1}, _jump)
    out = _run(cam, frames)
    assert [out[HELD_FRAME].model, out[HELD_FRAME + 1].model] == ["coast", "hold"]
    np.testing.assert_allclose(out[HELD_FRAME + 1].rotation, out[HELD_FRAME].rotation)


def test_at_a_walking_rate_an_unmeasurable_frame_is_held(monkeypatch) -> None:
    """Below _COAST_MIN_RATE_DEG_S (20 deg/s) a frame that cannot be measured is held, as before: the walker's
    sway changes direction within a few frames, so its rate is no prediction."""
    out, _ = _steady_turn_with_one_implausible_fit(monkeypatch, 20.0)
    assert out[HELD_FRAME].model == "hold"
    np.testing.assert_allclose(out[HELD_FRAME].rotation, out[HELD_FRAME - 1].rotation)


def test_a_walkers_fast_u_turn_keeps_its_rotation_through_a_lost_frame(tmp_path_factory, script_renderer,
                                                                        clip_run) -> None:
    """A walker's own U-turn, 180 deg in 1.2 s (``normal:3,turn:180:1.2,normal:3``, seed 2, 320x240): at its peak,
    274 deg/s, one frame keeps too few inliers. Held, that frame's 9.1 deg were lost for good (whole-angle error
    6.3 deg RMS, 9.0 deg at the end); carried on at the last rate, the frame is 0.3 deg off and the walk ends
    well under a degree off."""
    run = clip_run(script_renderer(tmp_path_factory, "u_turn", "normal:3,turn:180:1.2,normal:3", seed=2))
    coasted = [o for o in run.out if o.model == "coast"]
    assert coasted, [(o.t_s, o.model, o.reason) for o in run.out if o.status.value != "ok"]
    assert all(o.status.value != "ok" for o in coasted)  # still flagged
    truth = run.relative_truth
    err = np.degrees([Rotation.from_matrix(r.T @ e).magnitude() for r, e in zip(truth, run.est, strict=True)])
    assert float(np.sqrt(np.mean(err**2))) < 1.5, err.round(2)
    assert err[-1] < 1.5, err.round(2)


def test_after_a_held_frame_the_next_unmeasurable_one_is_held_too(monkeypatch) -> None:
    """Review: a lens cap in a turn (frames 9-13 uniform: held), then two frames whose fits are implausible. The
    first is held (0.2 s since the last measured frame); the second was carried on at the rate from before the
    cap, which the hold had made look one frame old. Nothing unmeasured is carried on after a hold."""
    cam, frames, _ = _render(lambda t: 70.0 * t, n=20)
    frames = [np.full_like(f, 128) if 9 <= i <= 13 else f for i, f in enumerate(frames)]
    _inject(monkeypatch, {14, 15}, _jump)
    out = _run(cam, frames)
    assert [o.reason for o in out[9:14]] == ["featureless"] * 5
    assert [out[14].model, out[15].model] == ["hold", "hold"], [(o.model, o.reason) for o in out[9:17]]


def test_a_turn_whose_rate_just_changed_is_not_carried_on(monkeypatch) -> None:
    """70 deg/s, then from frame 8 on 35 deg/s: the frame after the change cannot be measured; the last two rates
    differ by more than _COAST_STEADY of the last (the turn slowing, or the last step the odd one), so it is
    held, not carried on at either rate."""
    cam, frames, _ = _render(lambda t: np.where(t < 7 / FPS, 70.0 * t, 70.0 * 7 / FPS + 35.0 * (t - 7 / FPS)))
    _inject(monkeypatch, HELD_FRAME, _jump)
    out = _run(cam, frames)
    assert out[HELD_FRAME].reason == "implausible_step"
    assert out[HELD_FRAME].model == "hold"


def test_at_15_fps_a_walking_rate_is_still_no_turn(monkeypatch) -> None:
    """20 deg/s filmed at 15 fps turns 1.33 deg a frame, above the 1 deg a frame that marks a turn at 30 fps: the
    turn test is a rate (_COAST_MIN_RATE_DEG_S), so the unmeasurable frame is held as at 30 fps (review)."""
    cam, frames, _ = _render(lambda t: 20.0 * 2.0 * t)  # frame i shows 20 deg/s x i / 15 s
    original = fast_module.FastEngine._fit

    def fit(self, t_s, n):
        out = original(self, t_s, n)
        return _jump(out) if round(t_s * 15.0) == HELD_FRAME else out

    monkeypatch.setattr(fast_module.FastEngine, "_fit", fit)
    out = _run(cam, frames, fps=15.0)
    assert out[HELD_FRAME].reason == "implausible_step"
    assert out[HELD_FRAME].model == "hold"


def test_lost_tracks_in_a_turn_are_carried_on_and_tracking_restarts(monkeypatch) -> None:
    """Every track lost in one frame of a 70 deg/s turn (``tracking_lost``): carried on at the turn's rate, and
    the turn is measured again from that frame on."""
    cam, frames, truth = _render(lambda t: 70.0 * t)
    original = fast_module.FastEngine._track

    def track(self, small):
        n = original(self, small)
        if round(self._t_s * FPS) == HELD_FRAME:
            self._keep(np.zeros(self._pts.shape[0], bool))
            return 0
        return n

    monkeypatch.setattr(fast_module.FastEngine, "_track", track)
    out = _run(cam, frames)
    assert (out[HELD_FRAME].model, out[HELD_FRAME].reason) == ("coast", "tracking_lost")
    err = _start_relative_errors_deg(out, truth)
    assert err[HELD_FRAME] < 0.3 and err[-1] < 0.3, err.round(2)


def test_after_a_gap_in_the_frames_an_unmeasurable_one_is_held(monkeypatch) -> None:
    """Frames 9-14 of a 70 deg/s turn never arrive (a stalled camera: 0.23 s without frames); frame 15's fit is
    implausible. Over a gap longer than _COAST_MAX_S the last rate is a guess: held, not carried on."""
    cam, frames, _ = _render(lambda t: 70.0 * t, n=20)
    _inject(monkeypatch, 15, _jump)
    est = RotationEstimator(cam)
    out = {i: est.push(f, i / FPS) for i, f in enumerate(frames) if not 9 <= i <= 14}
    assert out[15].reason == "implausible_step"
    assert out[15].model == "hold"


def _slowing_turn_deg(t):
    """35 deg/s, 45 deg/s from frame 8, 5 deg/s from frame 11 on (review's clip)."""
    t = np.asarray(t, dtype=float)
    a8, a11 = 8 / FPS, 11 / FPS
    slow = 35 * a8 + 45 * (a11 - a8) + 5 * (t - a11)
    return np.where(t < a8, 35 * t, np.where(t < a11, 35 * a8 + 45 * (t - a8), slow))


def test_a_step_over_dropped_frames_is_no_change_of_rate_and_a_hold_does_not_freeze_the_turn() -> None:
    """Frames 9-11 of a turn that slows from 45 to 5 deg/s never arrive. Frame 12's step spans the gap (4.7 deg);
    judged against that step itself, frame 13's 0.2 deg was a change of rate (held), and judged against it again
    every later frame was held too, the orientation frozen for the rest of the clip (review: frames 13-44). The
    change of rate is judged against the last step's rate over this frame's interval: every frame from 13 on is
    measured and right."""
    cam, frames, truth = _render(_slowing_turn_deg, n=30)
    est = RotationEstimator(cam)
    kept = [i for i in range(30) if not 9 <= i <= 11]
    out = [est.push(frames[i], i / FPS) for i in kept]
    after = [o for i, o in zip(kept, out, strict=True) if i >= 13]
    assert all(o.model not in ("hold", "coast") for o in after), [(o.t_s, o.model, o.reason) for o in after]
    err = _start_relative_errors_deg(out, truth[kept])
    assert err[-1] < 0.3, err.round(2)


def test_no_frame_is_carried_on_at_a_rate_measured_over_dropped_frames(monkeypatch) -> None:
    """The same gap; frame 13's fit implausible. The last rate was measured over 4 frames (0.13 s, more than
    _COAST_MAX_S): an average over the gap, no prediction (carried on at it, 35 deg/s where the camera turned at
    5, the frame was 1.0 deg off; held, 0.16): held."""
    cam, frames, _ = _render(_slowing_turn_deg, n=20)
    _inject(monkeypatch, 13, _jump)
    est = RotationEstimator(cam)
    out = {i: est.push(f, i / FPS) for i, f in enumerate(frames) if not 9 <= i <= 11}
    assert out[13].reason == "implausible_step"
    assert out[13].model == "hold"


def test_the_turn_test_needs_both_of_the_last_two_rates_above_the_floor(monkeypatch) -> None:
    """25 deg/s, then 32 deg/s over the last measured frame: steady within _COAST_STEADY, but the frame before it
    turned below _COAST_MIN_RATE_DEG_S, so the turn has not been established: the unmeasurable frame is held."""
    t7 = 7 / FPS
    cam, frames, _ = _render(lambda t: np.where(t < t7, 25.0 * t, 25.0 * t7 + 32.0 * (t - t7)))
    _inject(monkeypatch, 9, _jump)
    out = _run(cam, frames)
    assert out[9].reason == "implausible_step"
    assert out[9].model == "hold"


def test_after_a_hold_two_measured_frames_come_before_the_next_carried_one(monkeypatch) -> None:
    """A 70 deg/s turn, frames 9 and 11 unmeasurable (frame 10 measured between them): 9 is carried on, 11 is held.
    Its last rate is measured, but the one before it spans the carried frame: the turn is not re-established."""
    cam, frames, _ = _render(lambda t: 70.0 * t)
    _inject(monkeypatch, {9, 11}, _jump)
    out = _run(cam, frames)
    models = [o.model for o in out[9:12]]
    assert models[0] == "coast" and models[1] not in ("hold", "coast") and models[2] == "hold", models


def test_with_a_rolling_shutter_the_keyframe_after_an_unmeasured_frame_keeps_the_turns_rate(monkeypatch) -> None:
    """A 70 deg/s turn seen through a 30 ms readout, one implausible fit (frame 9). The keyframe tracking restarts
    on moves its corners to the frame's time at the last measured rate; it used the rejected fit's (308 deg/s),
    and the rest of the clip stayed 2.0 deg off where the same clip without the fault ends 1 deg off (review)."""
    cam, frames, truth = _render(lambda t: 70.0 * np.asarray(t, dtype=float), readout_s=0.03)
    clean = _start_relative_errors_deg(_run(cam, frames), truth)
    _inject(monkeypatch, HELD_FRAME, _jump)
    out = _run(cam, frames)
    assert out[HELD_FRAME].reason == "implausible_step"
    err = _start_relative_errors_deg(out, truth)
    assert abs(err[-1] - clean[-1]) < 0.3, (err.round(2), clean.round(2))


def test_after_a_carried_frame_a_fit_that_reads_no_rotation_in_a_fast_turn_is_held(monkeypatch) -> None:
    """A steady 150 deg/s turn (5 deg a frame): frame 9's fit is implausible (carried on), frame 10's reads no
    rotation at all (tracks latched one texture period on, or a duplicated frame). Accepting a turn that stopped
    as plausible after an unmeasured frame let such fits through, reported ok, and a 180 deg/s turn ended 116 deg
    off (review); judged against the turn's rate, the frame is held."""
    cam, frames, _ = _render(lambda t: 150.0 * t, n=13)
    original = fast_module.FastEngine._fit

    def fit(self, t_s, n):
        out = original(self, t_s, n)
        frame = round(t_s * FPS)
        if frame == 10:
            return dataclasses.replace(out, rotation=self._R_kf.T @ self._orientation)  # no rotation since frame 9
        return _jump(out) if frame == HELD_FRAME else out

    monkeypatch.setattr(fast_module.FastEngine, "_fit", fit)
    out = _run(cam, frames)
    assert out[HELD_FRAME].model == "coast"
    assert (out[10].model, out[10].reason) == ("hold", "implausible_step"), [(o.model, o.reason) for o in out[8:]]


def test_after_a_long_gap_a_swaying_camera_is_not_judged_by_an_extrapolated_rate() -> None:
    """A 5 deg, 1 Hz yaw sway (a walker's trunk) with frames 16-26 missing (0.37 s): extrapolating the last rate
    over the gap predicted 12.6 deg where the camera had swung back by 2.9, and the right fit was held for good
    (review). Across a gap the last step is the test's reference, as before: frame 27 is measured and right."""
    cam, frames, truth = _render(lambda t: 5.0 * np.sin(2 * np.pi * np.asarray(t, dtype=float)), n=30)
    est = RotationEstimator(cam)
    kept = [i for i in range(30) if not 16 <= i <= 26]
    out = {i: est.push(frames[i], i / FPS) for i in kept}
    assert out[27].model not in ("hold", "coast"), (out[27].model, out[27].reason)
    err = _start_relative_errors_deg([out[i] for i in kept], truth[kept])
    assert err[-1] < 0.3, err.round(2)
