"""The fast method walking towards a wall (issue 14): a near plane must be flagged, never reported ok wrongly.

Before the homography check, on this clip (320x240, 8 s, seed 1, the street ending 3 m in front of a facade)
the error grew to 3.1 deg with frame-to-frame errors of 0.7 deg while every frame reported ok (101 frames ok
with more than 1 deg of error).
"""

from __future__ import annotations

import numpy as np
import pytest

from walkmon.rotation import EstimateStatus
from walkmon.rotation import geometry as geo


@pytest.fixture(scope="module")
def wall_clip(tmp_path_factory):
    from walkmon.simulate.scenarios import simulate_scenario

    return simulate_scenario(tmp_path_factory.mktemp("wall"), "wall", seed=1, seconds=8.0, width=320, height=240)


@pytest.mark.slow
def test_walking_towards_a_wall_is_flagged_not_reported_ok(wall_clip, clip_run):
    run = clip_run(wall_clip)
    out, n, Rt, Re, ok = run.out, run.n, run.truth, run.est, run.ok
    flagged = [o for o in out[:n] if o.status is EstimateStatus.LOW_QUALITY]
    assert flagged, "the near plane must be flagged"
    ref = 0
    worst_ok = 0.0
    for i in range(n):
        if not ok[i]:
            ref = i  # after a flagged frame the output is only claimed relative to it
            continue
        err = geo.rotation_angle_deg((Rt[ref].T @ Rt[i]).T @ (Re[ref].T @ Re[i]))
        worst_ok = max(worst_ok, err)
    assert worst_ok <= 1.0, worst_ok
    steps = [geo.rotation_angle_deg((Rt[i - 1].T @ Rt[i]).T @ (Re[i - 1].T @ Re[i])) for i in range(1, n) if ok[i]]
    assert max(steps) <= 0.5, max(steps)  # no jumps among the frames reported ok


@pytest.fixture(scope="module")
def turns_clip(tmp_path_factory):
    from walkmon.simulate.scenarios import simulate_scenario

    return simulate_scenario(tmp_path_factory.mktemp("turns"), "turns", seed=1, seconds=8.0, width=320, height=240)


@pytest.mark.slow
def test_fast_turns_past_facades_are_flagged_with_a_reason_never_ok_and_wrong(turns_clip, clip_run):
    """Turns of 90-180 deg at up to 180 deg/s past facades 1-3 m away (simulator truth).

    Before the fast-rotation flag, the second essential start and the frame-to-frame check, 21 frames of this
    clip were reported ok with more than 1 deg of error since the last flagged frame (frame-to-frame errors up to
    0.8 deg): the lateral translation past the facade was taken for a yaw.
    """
    from walkmon.rotation import FLAG_REASONS

    run = clip_run(turns_clip)
    out, n, Rt, Re, ok = run.out, run.n, run.truth, run.est, run.ok
    # every flagged frame says why, in words the README and FLAG_REASONS explain; ok frames say nothing
    assert all(o.reason in FLAG_REASONS for o, k in zip(out[:n], ok, strict=True) if not k)
    assert all(o.reason == "" for o, k in zip(out[:n], ok, strict=True) if k)
    # the fastest part of the turns (above 120 deg/s true) is never reported ok
    rate = np.array([0.0] + [geo.rotation_angle_deg(Rt[i - 1].T @ Rt[i]) for i in range(1, n)]) / np.diff(
        run.t, prepend=run.t[0] - 1.0)
    fast = rate > 120.0
    assert fast.sum() > 20  # the clip does turn that fast
    assert not ok[fast].any(), np.flatnonzero(fast & ok)
    assert any(o.reason == "fast_rotation" for o in out[:n])
    ref = 0
    worst_ok = 0.0
    for i in range(n):
        if not ok[i]:
            ref = i
            continue
        worst_ok = max(worst_ok, geo.rotation_angle_deg((Rt[ref].T @ Rt[i]).T @ (Re[ref].T @ Re[i])))
    assert worst_ok <= 1.0, worst_ok


def test_max_ok_rate_is_validated():
    from walkmon.errors import ConfigError
    from walkmon.rotation import RotationSettings

    with pytest.raises(ConfigError, match="max_ok_rate_deg_s"):
        RotationSettings(max_ok_rate_deg_s=0.0)


@pytest.fixture(scope="module")
def turns_clip_seed2(tmp_path_factory):
    from walkmon.simulate.scenarios import simulate_scenario

    return simulate_scenario(tmp_path_factory.mktemp("turns2"), "turns", seed=2, seconds=8.0, width=640, height=480)


@pytest.mark.slow
def test_sideways_past_a_facade_the_rotation_only_fit_is_not_reported(turns_clip_seed2, clip_run):
    """After a turn, looking across the heading at a facade 1-3 m away, one frame after a keyframe GRIC kept the
    rotation-only model, which took the 2 cm sideways step for 0.6 deg of yaw (reported ok, and 0.6 back the
    next frame: 0.62 deg frame-to-frame against the truth); the essential fit from the second start was right.
    """
    run = clip_run(turns_clip_seed2)
    n, Rt, Re, ok = run.n, run.truth, run.est, run.ok
    step_err = np.array([geo.rotation_angle_deg((Rt[i - 1].T @ Rt[i]).T @ (Re[i - 1].T @ Re[i])) for i in range(1, n)])
    assert step_err[ok[1:]].max() <= 0.5, (step_err[ok[1:]].max(), np.flatnonzero(ok[1:] & (step_err > 0.5)) + 1)


@pytest.fixture(scope="module")
def fog_clip(tmp_path_factory):
    from walkmon.simulate.scenarios import simulate_scenario

    return simulate_scenario(tmp_path_factory.mktemp("fog"), "fog", seed=5, seconds=8.0, width=640, height=480)


@pytest.mark.slow
def test_in_fog_the_tracks_do_not_creep_and_the_pitch_does_not_drift(fog_clip, clip_run):
    """Fog veils every patch by a fraction that changes with its depth as the walker approaches: Lucas-Kanade's
    brightness constancy fails and the tracks crept upwards. Before the haze refinement this clip (seed 5, the
    scenario benchmark's worst fog clip) drifted to a start-relative error of 1.6 deg (RMSE 1.1 deg, pitch) with
    116 ok frames more than 1 deg off the simulator's truth; issue 14's target is a raw RMSE of 0.5 deg."""
    run = clip_run(fog_clip)
    Rt, Re = run.truth, run.est
    err = np.array([geo.rotation_angle_deg((Rt[0].T @ Rt[i]).T @ Re[i]) for i in range(run.n)])
    assert float(np.sqrt(np.mean(err**2))) <= 0.5, float(np.sqrt(np.mean(err**2)))
    assert not (run.ok & (err > 1.0)).any(), float(err[run.ok].max())


def _haze_refinements(clip_dir, monkeypatch, clip_run) -> tuple[int, int]:
    """(frames, frames whose tracks the fast method refined as haze) when it runs over the clip."""
    from walkmon.rotation.fast import FastEngine

    calls = []
    refine = FastEngine._refine_in_haze

    def counted(self, *args, **kwargs):  # noqa: ANN001, ANN002, ANN003, ANN202
        calls.append(1)
        return refine(self, *args, **kwargs)

    with monkeypatch.context() as m:
        m.setattr(FastEngine, "_refine_in_haze", counted)
        run = clip_run(clip_dir)
    return run.n, len(calls)


@pytest.mark.slow
def test_a_steep_cameras_ground_is_no_haze_and_fog_is(tmp_path, fog_clip, monkeypatch, clip_run) -> None:
    """A camera 25 deg down on a walker who stoops (its view all ground, the mounts table's -25:-2, bend seed 2)
    shows a low-contrast ground: with the haze bound at 0.4 the fast method refined 15 of its frames as fog, and
    its pitch error grew from 2.61 to 2.98 deg. The bound now lies in the middle of the gap between clear frames
    (at most 0.49) and fog (at least 0.59): the estimator refines no frame of that walk as haze, and every frame
    of the fog clip but the first (nothing tracked into it)."""
    from walkmon.simulate import simulate

    simulate(tmp_path, walk="mount:-25:-2,bend", seconds=16.0, seed=2, width=320, height=240)
    n, hazy = _haze_refinements(tmp_path, monkeypatch, clip_run)
    assert n == 480 and hazy == 0, hazy
    n, hazy = _haze_refinements(fog_clip, monkeypatch, clip_run)
    assert n > 200 and hazy == n - 1, (hazy, n)


@pytest.fixture(scope="module")
def night_clip(tmp_path_factory):
    from walkmon.simulate.scenarios import simulate_scenario

    return simulate_scenario(tmp_path_factory.mktemp("night"), "night", seed=3, seconds=8.0, width=640, height=480)


@pytest.mark.slow
def test_at_night_the_noise_is_smoothed_away_and_the_pitch_does_not_drift(night_clip, clip_run):
    """Night: sensor noise a third of the image's contrast. Before the tracking images were smoothed there, this
    clip (seed 3, the scenario benchmark's worst night clip) drifted to a raw RMSE of 0.81 deg of pitch with 88 ok
    frames more than 1 deg off the simulator's truth; issue 14's target is 0.5 deg."""
    run = clip_run(night_clip)
    Rt, Re = run.truth, run.est
    err = np.array([geo.rotation_angle_deg((Rt[0].T @ Rt[i]).T @ Re[i]) for i in range(run.n)])
    assert float(np.sqrt(np.mean(err**2))) <= 0.5, float(np.sqrt(np.mean(err**2)))
    assert not (run.ok & (err > 1.0)).any(), float(err[run.ok].max())
