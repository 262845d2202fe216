"""RotationEstimator: synthetic rotations of a textured plane at infinity, degenerate input, the stage contract,
and a short simulated walk against its truth.csv (both methods)."""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest

from walkmon.camera.model import default_camera, read_camera_yaml
from walkmon.consts import angles_deg_from_rotation, rotation_from_angles_deg
from walkmon.errors import ConfigError, InvalidInputError
from walkmon.rotation import (
    DEFAULT_ROTATION_SETTINGS,
    EstimateStatus,
    RotationEstimate,
    RotationEstimator,
    RotationSettings,
)
from walkmon.tables import read_table

W, H = 320, 240


def _texture(w: int, h: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    img = (rng.random((h // 8, w // 8)) * 255).astype(np.uint8)
    img = cv2.resize(img, (w, h), interpolation=cv2.INTER_CUBIC)
    return cv2.GaussianBlur(img, (0, 0), 1.5)


def rotation_clip(n: int = 60, seed: int = 0):
    """Frames of a camera rotating in front of a textured plane at infinity (exact homography K R K^-1)."""
    cam = default_camera(W, H)
    K = cam.camera_matrix
    Ks = K.copy()
    Ks[0, 2] += W
    Ks[1, 2] += H
    src = _texture(3 * W, 3 * H, seed)
    t = np.arange(n) / 30.0
    ang = np.c_[3 * np.sin(2 * np.pi * t), 2 * np.sin(np.pi * t + 1), 2.5 * np.sin(2 * np.pi * 0.9 * t + 2)]
    Rs = rotation_from_angles_deg(ang[:, 0], ang[:, 1], ang[:, 2])
    frames = [
        cv2.warpPerspective(src, Ks @ R @ np.linalg.inv(K), (W, H), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP)
        for R in Rs
    ]
    truth = angles_deg_from_rotation(Rs[0].T @ Rs)  # relative to the first frame, as the estimator reports
    return cam, t, truth, frames


@pytest.fixture(scope="module")
def clip():
    return rotation_clip()


# -------------------------------------------------------------------------------------------------- contract
def test_settings_validate():
    with pytest.raises(ConfigError, match="method"):
        RotationSettings(method="magic")
    with pytest.raises(ConfigError, match="tracking_scale"):
        RotationSettings(tracking_scale=0.0)
    with pytest.raises(ConfigError, match="min_inliers"):
        RotationSettings(min_inliers=3)
    assert dataclasses.replace(DEFAULT_ROTATION_SETTINGS, method="paper").method == "paper"


def test_estimator_rejects_wrong_collaborators():
    with pytest.raises(ConfigError):
        RotationEstimator("not a camera")  # type: ignore[arg-type]
    with pytest.raises(ConfigError):
        RotationEstimator(default_camera(W, H), settings={"method": "fast"})  # type: ignore[arg-type]


def test_results_are_frozen(clip):
    cam, t, _, frames = clip
    est = RotationEstimator(cam).push(frames[0], t[0])
    assert isinstance(est, RotationEstimate)
    with pytest.raises(dataclasses.FrozenInstanceError):
        est.n_inliers = 3  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        est.rotation[0, 0] = 2.0


def test_first_frame_is_identity_and_reset_restarts(clip):
    cam, t, _, frames = clip
    est = RotationEstimator(cam)
    first = est.push(frames[0], t[0])
    assert first.status is EstimateStatus.FIRST_FRAME
    assert np.allclose(first.rotation, np.eye(3))
    for i in range(1, 10):
        moved = est.push(frames[i], t[i])
    assert np.abs(moved.angles_deg).max() > 0.5
    est.reset()
    again = est.push(frames[10], t[10])
    assert again.status is EstimateStatus.FIRST_FRAME
    assert np.allclose(again.rotation, np.eye(3))


def test_bad_frames_raise_invalid_input(clip):
    cam, t, _, frames = clip
    est = RotationEstimator(cam)
    with pytest.raises(InvalidInputError, match="uint8"):
        est.push(frames[0].astype(np.float32), 0.0)
    with pytest.raises(InvalidInputError, match="shape"):
        est.push(np.zeros((H, W, 2), np.uint8), 0.0)
    est.push(frames[0], 0.0)
    with pytest.raises(InvalidInputError, match="size changed"):
        est.push(frames[1][: H // 2], 0.033)


def test_other_frame_size_scales_the_camera(clip):
    """A camera calibrated at 640x480 fed 320x240 frames: same lens, intrinsics scaled, same answer."""
    _, t, truth, frames = clip
    est = RotationEstimator(default_camera(2 * W, 2 * H))
    out = [est.push(f, ti) for f, ti in zip(frames[:30], t[:30], strict=True)]
    err = np.array([o.angles_deg for o in out]) - truth[:30]
    assert np.abs(err).max() < 0.1


# ------------------------------------------------------------------------------------------------- accuracy
@pytest.mark.parametrize("method", ["fast", "paper"])
def test_pure_rotation_clip(clip, method):
    cam, t, truth, frames = clip
    n = 60 if method == "fast" else 12  # the paper method is slow
    est = RotationEstimator(cam, RotationSettings(method=method))
    out = [est.push(f, ti) for f, ti in zip(frames[:n], t[:n], strict=True)]
    err = np.array([o.angles_deg for o in out]) - truth[:n]
    assert all(o.status.is_measured for o in out)
    if method == "fast":
        # a pure rotation is the rotation-only model's home ground: hundredths of a degree
        assert np.abs(err).max() < 0.06
        assert {o.model for o in out[1:]} == {"rotation"}
    else:
        # 5-point RANSAC on zero-parallax data is ill-posed; the paper method still must not flip or explode
        assert np.abs(err).max() < 3.0


# ------------------------------------------------------------------------------------------------ degenerate
@pytest.mark.parametrize("method", ["fast", "paper"])
def test_black_and_uniform_frames_hold_without_jump(clip, method):
    cam, t, _, frames = clip
    est = RotationEstimator(cam, RotationSettings(method=method))
    for i in range(4):
        last = est.push(frames[i], t[i])
    black = est.push(np.zeros((H, W, 3), np.uint8), t[4])
    grey = est.push(np.full((H, W), 128, np.uint8), t[5])
    for e in (black, grey):
        assert e.status is EstimateStatus.TOO_FEW_FEATURES
        assert e.model == "hold"
        assert np.array_equal(e.rotation, last.rotation)


def test_black_first_frame_never_raises():
    est = RotationEstimator(default_camera(W, H))
    e = est.push(np.zeros((H, W), np.uint8), 0.0)
    assert e.status is EstimateStatus.TOO_FEW_FEATURES
    assert np.allclose(e.rotation, np.eye(3))


@pytest.mark.parametrize("method", ["fast", "paper"])
def test_repeated_frame_holds(clip, method):
    cam, t, _, frames = clip
    est = RotationEstimator(cam, RotationSettings(method=method))
    est.push(frames[0], t[0])
    a = est.push(frames[1], t[1])
    b = est.push(frames[1].copy(), t[2])
    assert b.status is EstimateStatus.REPEATED_FRAME
    assert np.array_equal(a.rotation, b.rotation)


def test_lens_cap_then_recovery_has_no_jump(clip):
    """Cap on for 10 frames while the camera keeps moving: held, flagged, then tracking resumes smoothly."""
    cam, t, truth, frames = clip
    est = RotationEstimator(cam)
    out = []
    for i in range(len(frames)):
        frame = np.full((H, W), 3, np.uint8) if 20 <= i < 30 else frames[i]
        out.append(est.push(frame, t[i]))
    capped = out[20:30]
    assert all(o.status is EstimateStatus.TOO_FEW_FEATURES for o in capped)
    assert all(np.array_equal(o.rotation, out[19].rotation) for o in capped)
    angles = np.array([o.angles_deg for o in out])
    # after the cap the estimate continues from where it was: the largest step is what the camera really did
    steps = np.abs(np.diff(angles, axis=0)).max(axis=1)
    true_steps = np.abs(np.diff(truth, axis=0)).max(axis=1)
    assert steps.max() < true_steps.max() * 10 + 0.5
    assert all(o.status.is_measured for o in out[31:])


def test_too_few_features_hold(clip):
    """A frame with only a couple of corners (a dot on black) is held and flagged."""
    cam, t, _, frames = clip
    est = RotationEstimator(cam)
    first = est.push(frames[0], t[0])
    sparse = np.zeros((H, W), np.uint8)
    cv2.circle(sparse, (100, 100), 10, 255, -1)
    cv2.rectangle(sparse, (200, 150), (230, 170), 200, -1)
    e = est.push(sparse, t[1])
    assert e.status in (EstimateStatus.TOO_FEW_FEATURES, EstimateStatus.LOW_QUALITY)
    assert np.array_equal(e.rotation, first.rotation)


# ------------------------------------------------------------------------------------------- simulated walk
@pytest.fixture(scope="module")
def simulated_walk(tmp_path_factory):
    simulate = pytest.importorskip("walkmon.simulate").simulate
    out = tmp_path_factory.mktemp("rotation_sim")
    # 1 s standing, 4 s walking on a forward bend (mostly ground in view: the hard case), 1 s standing
    result = simulate(out, walk="bend", seconds=6.0, seed=3, width=W, height=H, stand_s=1.0)
    return result


def _truth_relative(truth_path):
    tr = read_table(truth_path, ["t", "pitch", "yaw", "roll"])
    Rs = rotation_from_angles_deg(tr["pitch"], tr["yaw"], tr["roll"])
    return tr["t"], angles_deg_from_rotation(Rs[0].T @ Rs)


def _run(result, method, n=None):
    from walkmon.drivers.video_file import VideoFile

    cam = read_camera_yaml(result.camera_path)
    est = RotationEstimator(cam, RotationSettings(method=method))
    out = []
    with VideoFile(result.video_path) as video:
        for i, (t_s, frame) in enumerate(video):
            if n is not None and i >= n:
                break
            out.append(est.push(frame, t_s))
    return np.array([o.angles_deg for o in out]), out


def test_fast_method_follows_simulated_bend_walk(simulated_walk):
    t, truth = _truth_relative(simulated_walk.truth_path)
    est, out = _run(simulated_walk, "fast")
    n = min(len(est), len(truth))
    err = est[:n] - truth[:n]
    assert np.ptp(truth[:n, 0]) > 5.0  # the walk really moves
    rmse = np.sqrt(np.mean(err**2, axis=0))
    assert rmse.max() < 0.5, rmse
    assert np.abs(np.diff(err, axis=0)).max() < 0.5
    models = {o.model for o in out}
    assert "essential" in models and "rotation" in models  # both models are used, chosen per frame


def test_paper_method_on_a_short_stretch(simulated_walk):
    t, truth = _truth_relative(simulated_walk.truth_path)
    n = 45  # 1 s standing + 0.5 s walking: the paper method is slow
    est, out = _run(simulated_walk, "paper", n)
    err = est[:n] - truth[:n]
    assert all(o.model in ("identity", "essential", "hold") for o in out)
    assert np.abs(err).max() < 5.0  # chained 5-point estimates drift; no flips, no explosions


# ------------------------------------------------------------------ a camera tilted down on the chest: the ground
@pytest.fixture(scope="module")
def tilted_walk(tmp_path_factory):
    simulate = pytest.importorskip("walkmon.simulate").simulate
    out = tmp_path_factory.mktemp("rotation_tilted")
    # the chest mount points the camera 25 deg down: the ground fills most of the view, one plane
    return simulate(out, walk="mount:-25,normal", seconds=10.0, seed=3, width=320, height=240, stand_s=1.0)


def _run_settings(result, **overrides):
    from walkmon.drivers.video_file import VideoFile

    cam = read_camera_yaml(result.camera_path)
    est = RotationEstimator(cam, RotationSettings(**overrides))
    with VideoFile(result.video_path) as video:
        out = [est.push(frame, t_s) for t_s, frame in video]
    return np.array([o.angles_deg for o in out]), out


def test_a_camera_looking_down_at_the_ground_keeps_its_pitch(tilted_walk):
    t, truth = _truth_relative(tilted_walk.truth_path)
    est, out = _run_settings(tilted_walk)
    n = min(len(est), len(truth))
    rmse = np.sqrt(np.mean((est[:n] - truth[:n]) ** 2, axis=0))
    assert rmse.max() < 0.5, rmse
    flagged = sum(o.status is not EstimateStatus.OK for o in out)
    assert flagged < 0.1 * len(out), flagged
    # without the ground's plane solution the frames were flagged as planar-ambiguous and the rotation-only
    # fallback took the walk's translation for pitch
    est0, out0 = _run_settings(tilted_walk, ground_plane=False)
    rmse0 = np.sqrt(np.mean((est0[:n] - truth[:n]) ** 2, axis=0))
    assert sum(o.reason == "planar_ambiguity" for o in out0) > 0.3 * len(out0)
    assert rmse0[0] > 2 * rmse[0]
