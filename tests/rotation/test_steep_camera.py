"""A chest camera tilted 25 deg down on a walker bent forward (issue 14's "25 deg-down camera on a stooping walker").

The camera looks about 45 deg below level and sees mostly the ground near the feet: a plane, so the essential
fit is ill-posed and the plane's solution whose normal is the vertical is taken for the ground. Two rules failed
there (simulated 8 s walks, 320x240, seeds 1 and 3):

* The ground was recognised against the camera's start assumed level, within 30 deg, with the normals' signs
  ignored: 45 deg off, the ground's normal and the other solution's (the direction of travel) were equally far
  from it and neither was taken. Every frame was flagged, the rotation-only fallback drifted (before both rules:
  118 and 33 deg off; signed but within 30 deg: 59 and 12). Signed, the two normals lie about 90 deg apart and the
  ground's is the one on the side of the image's down, so it is taken up to 60 deg from an assumed vertical.
* A ground fit more than 1 deg from the previous frame moved on by the frame-to-frame rotation-only change was
  replaced by the rotation-only fit and a keyframe started on it. Over the near ground one frame's walk moves
  the tracks like a rotation of about a degree, so the chained change was the biased one and each such frame
  took its bias up for good: 2.4 and 6.9 deg off.
"""

from __future__ import annotations

import numpy as np
import pytest

from walkmon.rotation import EstimateStatus

SCRIPT = "mount:-25:-2,bend:8"


@pytest.fixture(scope="module", params=[1, 3])
def steep_walk(request, tmp_path_factory, script_renderer):
    return script_renderer(tmp_path_factory, f"steep_{request.param}", SCRIPT, seed=request.param)


def _angle_deg(R: np.ndarray) -> np.ndarray:
    return np.degrees(np.arccos(np.clip((np.trace(R, axis1=-2, axis2=-1) - 1.0) / 2.0, -1.0, 1.0)))


def _errors_deg(run) -> tuple[np.ndarray, np.ndarray]:
    """``(truth, error)``: the true orientations start-relative, as the estimator reports them (n, 3, 3), and the
    angle between estimate and truth at every frame (n,)."""
    truth = run.relative_truth
    return truth, _angle_deg(np.einsum("nji,njk->nik", run.est, truth))


def test_steep_camera_on_a_bent_walker_keeps_its_orientation(steep_walk, clip_run) -> None:
    run = clip_run(steep_walk)
    truth, err = _errors_deg(run)
    assert err.max() < 1.5, err.max()  # 118 / 33 deg (ground not recognised), 2.4 / 6.9 (chain preferred)
    assert np.median(err) < 1.0, np.median(err)
    # the walk is seen: most frames are estimated ok, and no ok frame jumps. (The worst ok frame-to-frame error
    # here is 0.62 / 0.96 deg: above the hard scenes' 0.5 deg target, a known weakness of the steep ground view;
    # the bound only catches jumps.)
    assert run.ok.mean() > 0.8, run.ok.mean()
    for i in range(1, run.n):
        if run.out[i].status is EstimateStatus.OK and run.out[i - 1].status is EstimateStatus.OK:
            step_err = (truth[i - 1].T @ truth[i]).T @ (run.est[i - 1].T @ run.est[i])
            assert _angle_deg(step_err) < 1.25, run.t[i]


@pytest.fixture(scope="module")
def steep_walk_640(tmp_path_factory):
    from walkmon.simulate.session import simulate

    out = tmp_path_factory.mktemp("steep_640")
    simulate(out, walk=SCRIPT, seed=2, width=640, height=480)
    return out


@pytest.mark.slow
def test_where_the_ground_confirms_the_essential_fit_the_rotation_only_fit_is_not_taken(steep_walk_640, clip_run):
    """At 640x480 (seed 2) the essential fit and the ground's plane solution agreed while the rotation-only fit,
    pulled by the walker's translation over the near ground, lay further from them than its parallax allowed: the
    frame was flagged ``models_disagree`` and the rotation-only fit used, and the keyframe it started kept its
    2-4 deg of pitch. On this walk: 15.4 deg at worst, RMS 7.2, 105 ok frames more than 1 deg off (16 s, the
    mounts benchmark: 86 deg by the end). Two models that agree now stand against the third: 1.9, 0.67, 26."""
    run = clip_run(steep_walk_640)
    _, err = _errors_deg(run)
    assert float(np.sqrt(np.mean(err**2))) < 1.2, float(np.sqrt(np.mean(err**2)))
    assert err.max() < 3.0, err.max()
    assert np.count_nonzero(run.ok & (err > 1.0)) < 50, np.count_nonzero(run.ok & (err > 1.0))
    assert not any(o.reason == "models_disagree" for o in run.out)  # 3 frames before


@pytest.fixture(scope="module")
def steep_walk_16s(tmp_path_factory):
    from walkmon.simulate.session import simulate

    out = tmp_path_factory.mktemp("steep_16s")
    simulate(out, walk="mount:-25:-2,bend", seconds=16.0, seed=2, width=320, height=240)
    return out


@pytest.mark.slow
def test_a_ground_fit_in_doubt_holds_the_frame_instead_of_keyframing_the_rotation_only_fit(steep_walk_16s, clip_run):
    """Where the ground is recognised but neither the essential fit nor its refinement lands on the ground's plane
    solution, the rotation-only fit was used (flagged ``planar_ambiguity``) and a keyframe started on it: over
    the near ground that fit carries the walker's translation, and each such keyframe kept 2-4 deg of pitch
    (this walk, the mounts benchmark's 320x240 bend seed 2: RMS 2.7 deg, 5.1 at worst, a 3.5 deg frame-to-frame
    error). The frame is now held and tracking restarts from it: it loses only its own frame's rotation."""
    run = clip_run(steep_walk_16s)
    truth, err = _errors_deg(run)
    assert float(np.sqrt(np.mean(err**2))) < 1.5, float(np.sqrt(np.mean(err**2)))  # 2.68 before, 0.92 now
    assert err.max() < 3.5, err.max()  # 5.07 before, 2.42 now
    steps = np.einsum("nji,njk->nik", truth[:-1], truth[1:])
    est_steps = np.einsum("nji,njk->nik", run.est[:-1], run.est[1:])
    step_err = _angle_deg(np.einsum("nji,njk->nik", steps, est_steps))
    assert step_err.max() < 1.5, step_err.max()  # 3.52 before, 0.99 now
    assert any(o.model == "hold" and o.reason == "planar_ambiguity" for o in run.out)


@pytest.fixture(scope="module")
def turn_walk(tmp_path_factory, script_renderer):
    return script_renderer(tmp_path_factory, "turn_walk", "normal:3,turn:90,normal:3", seed=1)


def test_a_held_ground_frame_never_loses_a_turning_frames_rotation(turn_walk, clip_run, monkeypatch):
    """A held frame's own rotation is lost for good, so a ground frame in doubt is held only while the frame turns
    the camera by little (``_HOLD_MAX_STEP_DEG``, review). The boundary is faked: every plane check of a level walk
    with a 90 deg turn reports a ground in doubt. Held whatever the frame's rotation (the bound set to 1e9), the
    turn's frames of 2-3 deg were held too (2.85 deg at most) and the walk ended 10.0 deg off; with the bound, 5.0
    (the fake's own cost: every frame of the walk held or flagged)."""
    from walkmon.rotation import fast

    def every_plane_a_ground_in_doubt(self, q_kf, q_cur, pose, mask):
        return True, pose.rotation

    monkeypatch.setattr(fast.FastEngine, "_plane_ambiguous", every_plane_a_ground_in_doubt)
    monkeypatch.setattr(fast.FastEngine, "_ground_refit", lambda self, q_kf, q_cur, ground: None)
    run = clip_run(turn_walk)
    truth, err = _errors_deg(run)
    true_steps = _angle_deg(np.einsum("nji,njk->nik", truth[:-1], truth[1:]))
    held = [i for i, o in enumerate(run.out) if o.model == "hold" and o.reason == "planar_ambiguity"]
    assert len(held) > 50  # the fake reaches the hold
    assert max(true_steps[i - 1] for i in held) < 2.0  # 1.32 here; 2.85 unbounded
    assert err[-1] < 7.5, err[-1]  # 4.98 here; 9.96 unbounded


def _about(axis: np.ndarray, deg: float) -> np.ndarray:
    """The rotation by ``deg`` about ``axis``."""
    from walkmon.rotation.geometry import rotation_from_rotvec

    return rotation_from_rotvec(np.radians(deg) * axis / np.linalg.norm(axis))


@pytest.mark.parametrize("turned_deg", [0.0, 90.0, 180.0])
def test_after_a_u_turn_a_steep_cameras_ground_is_still_recognised(turned_deg: float) -> None:
    """No vertical lines measured the vertical, so the start's y axis, through the chained orientation, stood for
    it: wrong by the camera's start tilt, an error a turn swings about the true vertical. A camera 45 deg below
    level (25 deg on a walker bent 20) that had turned 180 deg had it on its optical axis: the ground's normal and
    the direction of travel were both 45 deg from it, the ground was not recognised, and every frame's
    rotation-only fallback drifted the walk off. The geometry here is exact: the true vertical and direction of
    travel in the camera frame, the orientation a perfect chain would have after turning about the vertical."""
    from walkmon.camera.model import CameraModel
    from walkmon.rotation import RotationSettings
    from walkmon.rotation import geometry as geo
    from walkmon.rotation.fast import FastEngine

    tilt = np.radians(45.0)
    down = np.array([0.0, np.cos(tilt), np.sin(tilt)])  # the world's down seen from the camera (y down, z ahead)
    ahead = np.array([0.0, -np.sin(tilt), np.cos(tilt)])  # the walk's direction, level
    K = np.array([[230.0, 0.0, 159.5], [0.0, 230.0, 119.5], [0.0, 0.0, 1.0]])
    engine = FastEngine(CameraModel(320, 240, K), RotationSettings())
    assert engine._vertical is None or engine._vertical.world_vertical is None  # nothing measured
    # the keyframe's orientation (camera to start frame) after the turn about the vertical; the camera is rigid on
    # the trunk, so the vertical and the walk's direction are where they were in the camera frame
    engine._R_kf = _about(down, turned_deg)
    R_ground, R_other = _about(np.array([1.0, 0.0, 0.0]), 0.3), _about(np.array([1.0, 0.0, 0.0]), -1.2)
    hom = geo.HomographyFit(np.eye(3), np.eye(3), np.zeros(1), np.ones(1, bool), 1.5,
                            ((R_other, ahead), (R_ground, down)))
    pose = geo.PoseFit(np.eye(3), np.array([0.0, 0.0, 1.0]), np.zeros(1), np.ones(1, bool))
    found = engine._ground_solution(hom, pose)
    assert found is not None and np.allclose(found, R_ground), turned_deg


@pytest.fixture(scope="module")
def steep_u_turn(tmp_path_factory, script_renderer):
    return script_renderer(tmp_path_factory, "steep_u_turn", "mount:-25:-2,bend:4,turn:180,bend:4", seed=2)


def test_a_steep_camera_that_turns_is_not_lost(steep_u_turn, clip_run) -> None:
    """End to end, the walk whose U-turn hid the ground (the test above). Before: 9.9 deg RMS, 17.3 at the end;
    now 4.1 and 5.6. Still far from issue 14's 0.5 deg: every frame of the fast turn adds 0.1-0.3 deg of bias
    (the rotation-only, essential and ground fits are each biased, each its own way, also in an image without blur
    or noise), which this does not address."""
    run = clip_run(steep_u_turn)
    _, err = _errors_deg(run)
    assert float(np.sqrt(np.mean(err**2))) < 7.0, float(np.sqrt(np.mean(err**2)))
    assert err[-1] < 10.0, err[-1]


def test_the_cameras_own_y_axis_takes_no_facade_for_the_ground() -> None:
    """The camera's own y axis is tried only for a camera tilted down (review): with it, a facade 1.5 m beside a
    walker going down a 25 deg ramp, seen by a camera 15 deg up, was taken for the ground after a U-turn in 6 of
    these 20 frames (9 of 20 in the review's draw), 5 deg off (its plane's other solution, the walk's direction,
    lay just over 90 deg from the camera's y axis). Synthetic tracks on the facade, exact but for 0.3 px of
    noise; the truth is that no plane here is the ground."""
    from walkmon.camera.model import CameraModel
    from walkmon.consts import rot_x, rot_y
    from walkmon.rotation import RotationSettings
    from walkmon.rotation import geometry as geo
    from walkmon.rotation.fast import FastEngine

    f = 230.0
    K = np.array([[f, 0.0, 159.5], [0.0, f, 119.5], [0.0, 0.0, 1.0]])

    def camera(up_deg: float, heading_deg: float) -> np.ndarray:
        return np.asarray(rot_y(np.radians(heading_deg))) @ np.asarray(rot_x(np.radians(up_deg)))

    taken = 0
    rng = np.random.default_rng(1)
    for trial in range(20):
        start, R0, R1 = camera(15.0, 0.0), camera(15.0, 180.0), camera(15.3, 180.5)
        turn = np.asarray(rot_y(np.pi))
        facade = np.c_[np.full(400, 1.5), rng.uniform(-2.5, 1.3, 400), rng.uniform(0.5, 8.0, 400)] @ turn.T
        down_ramp = turn @ (0.14 * np.array([0.0, np.sin(np.radians(25.0)), np.cos(np.radians(25.0))]))
        X0, X1 = facade @ R0, (facade - down_ramp) @ R1
        q0, q1 = X0 / X0[:, 2:3], X1 / X1[:, 2:3]
        seen = ((X0[:, 2] > 0.3) & (X1[:, 2] > 0.3) & (np.abs(q0[:, 0]) < 0.69) & (np.abs(q0[:, 1]) < 0.52)
                & (np.abs(q1[:, 0]) < 0.69) & (np.abs(q1[:, 1]) < 0.52))
        q0, q1 = q0[seen], q1[seen]
        noise = np.random.default_rng(trial)
        q0[:, :2] += noise.normal(0.0, 0.3 / f, q0[:, :2].shape)
        q1[:, :2] += noise.normal(0.0, 0.3 / f, q1[:, :2].shape)
        hom = geo.homography_fit(q0, q1, f, R0.T @ R1, method="dlt")
        engine = FastEngine(CameraModel(320, 240, K), RotationSettings())
        engine._R_kf = start.T @ R0  # after the U-turn, the chain exact
        pose = geo.PoseFit(R0.T @ R1, np.array([0.0, 0.0, 1.0]), np.zeros(1), np.ones(1, bool))
        taken += engine._ground_solution(hom, pose) is not None
    assert taken == 0, taken
