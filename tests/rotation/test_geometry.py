"""Two-view geometry on synthetic scenes with a known rotation (kornia-style): points in front of the camera,
projected into both views, with pixel noise and outliers; the estimated rotation must be within tight bounds."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from walkmon.consts import rotation_from_angles_deg
from walkmon.errors import InvalidInputError
from walkmon.rotation import geometry as geo

FOCAL_PX = 457.0  # 640 px wide, 70 degree HFOV


def make_scene(R, c, *, n=150, depth_m=(2.0, 10.0), noise_px=0.3, outlier_fraction=0.0, seed=0, ground=False):
    """Matched homogeneous normalised points (q0, q1): view 1 has orientation R and centre c in view 0."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-1, 1, (n, 2)) * np.array([0.7, 0.5])
    if ground:  # only the lower half of the image, as when the walker bends and sees the ground
        xy[:, 1] = np.abs(xy[:, 1]) + 0.05
    X = np.c_[xy, np.ones(n)] * rng.uniform(*depth_m, (n, 1))
    q0 = X / X[:, 2:3]
    X1 = (X - np.asarray(c)) @ np.asarray(R)  # R.T (X - c), row-wise
    q1 = X1 / X1[:, 2:3]
    q0[:, :2] += rng.normal(0, noise_px / FOCAL_PX, (n, 2))
    q1[:, :2] += rng.normal(0, noise_px / FOCAL_PX, (n, 2))
    k = int(outlier_fraction * n)
    q1[:k, :2] += rng.uniform(-0.1, 0.1, (k, 2))  # up to ~45 px off
    return q0, q1


def angle_error_deg(A, B) -> float:
    return geo.rotation_angle_deg(np.asarray(A).T @ np.asarray(B))


def choose(q0, q1, sigma_px=0.5):
    """The model GRIC prefers and its rotation, as the fast method decides."""
    rot = geo.rotation_only_fit(q0, q1, FOCAL_PX)
    pose = geo.refine_relative_pose(q0, q1, FOCAL_PX, rot.rotation)
    mask = rot.inliers | pose.inliers
    g_rot = geo.gric(rot.residuals_px[mask], sigma_px, 2, 3)
    g_ess = geo.gric(pose.residuals_px[mask], sigma_px, 3, 5)
    return ("essential", pose.rotation) if g_ess < g_rot else ("rotation", rot.rotation)


def test_kabsch_matches_scipy_align_vectors():
    rng = np.random.default_rng(3)
    R = Rotation.from_rotvec(rng.normal(size=3) * 0.3).as_matrix()
    b1 = rng.normal(size=(40, 3))
    b0 = b1 @ R.T + rng.normal(0, 0.01, (40, 3))
    ours = geo.rotation_from_bearings(b0, b1)
    b0n = b0 / np.linalg.norm(b0, axis=1, keepdims=True)
    b1n = b1 / np.linalg.norm(b1, axis=1, keepdims=True)
    ref, _ = Rotation.align_vectors(b0n, b1n)
    assert angle_error_deg(ours, ref.as_matrix()) < 1e-4


def test_rotvec_matches_scipy():
    v = np.array([0.1, -0.2, 0.3])
    assert np.allclose(geo.rotation_from_rotvec(v), Rotation.from_rotvec(v).as_matrix(), atol=1e-12)


def test_pure_rotation_is_exact_and_gric_picks_rotation():
    R = rotation_from_angles_deg(1.0, -2.0, 0.5)
    q0, q1 = make_scene(R, np.zeros(3), outlier_fraction=0.2)
    rot = geo.rotation_only_fit(q0, q1, FOCAL_PX)
    assert angle_error_deg(rot.rotation, R) < 0.02
    assert rot.inliers[30:].mean() > 0.95  # the clean points are inliers
    assert rot.inliers[:30].mean() < 0.2  # the outliers are not
    model, R_est = choose(q0, q1)
    assert model == "rotation"
    assert angle_error_deg(R_est, R) < 0.02


def test_zero_motion_gives_identity():
    q0, q1 = make_scene(np.eye(3), np.zeros(3), seed=1)
    model, R_est = choose(q0, q1)
    assert model == "rotation"
    assert geo.rotation_angle_deg(R_est) < 0.01


def test_forward_walking_needs_the_essential_model():
    R = rotation_from_angles_deg(0.5, 0.3, -0.4)
    c = np.array([0.02, 0.01, 0.3])  # 30 cm forward, as between keyframes ~8 frames apart
    q0, q1 = make_scene(R, c, depth_m=(1.5, 6.0), outlier_fraction=0.2, seed=2, ground=True)
    rot = geo.rotation_only_fit(q0, q1, FOCAL_PX)
    model, R_est = choose(q0, q1)
    assert model == "essential"
    assert angle_error_deg(R_est, R) < 0.1
    # the rotation-only model is visibly biased by the parallax: that is why the selection matters
    assert angle_error_deg(rot.rotation, R) > 5 * angle_error_deg(R_est, R)


def test_essential_refinement_recovers_baseline_direction():
    R = rotation_from_angles_deg(-1.0, 2.0, 0.5)
    c = np.array([0.1, -0.05, 1.0])
    q0, q1 = make_scene(R, c, depth_m=(2.0, 8.0), noise_px=0.2, seed=4)
    pose = geo.refine_relative_pose(q0, q1, FOCAL_PX, np.eye(3))
    assert angle_error_deg(pose.rotation, R) < 0.03
    assert abs(abs(pose.centre @ c / np.linalg.norm(c)) - 1.0) < 1e-3


def test_distant_scene_uses_rotation_model():
    R = rotation_from_angles_deg(2.0, 1.0, 1.0)
    q0, q1 = make_scene(R, np.array([0.0, 0.0, 0.04]), depth_m=(50.0, 100.0), outlier_fraction=0.2, seed=5)
    model, R_est = choose(q0, q1)
    assert model == "rotation"
    assert angle_error_deg(R_est, R) < 0.02


@pytest.mark.parametrize("seed", range(5))
def test_low_parallax_decomposition_never_flips(seed):
    """Plain RANSAC + decomposition offers a ~180 degree candidate; the nearest-rotation choice never takes it."""
    R = rotation_from_angles_deg(0.3, -0.2, 0.1)
    q0, q1 = make_scene(R, np.array([0.0, 0.0, 0.01]), seed=10 + seed)
    E, mask = geo.essential_ransac(q0, q1, FOCAL_PX)
    assert E is not None and mask.sum() > 20
    candidates = geo.orientation_candidates_from_essential(E)
    assert max(geo.rotation_angle_deg(C) for C in candidates) > 90  # the flip exists
    chosen = geo.select_nearest_rotation(candidates, np.eye(3))
    assert geo.rotation_angle_deg(chosen) < 5.0


def test_refine_stays_in_small_rotation_basin_at_zero_parallax():
    R = rotation_from_angles_deg(0.2, 0.1, -0.3)
    q0, q1 = make_scene(R, np.zeros(3), seed=6)
    pose = geo.refine_relative_pose(q0, q1, FOCAL_PX, np.eye(3))
    assert geo.rotation_angle_deg(pose.rotation) < 2.0


def test_gric_formula_by_hand():
    e = np.array([0.0, 1.0, 10.0])
    # rotation model: d=2, k=3, r=4: rho caps at 2*(4-2)=4
    expected = (0 + 4 + 4) + math.log(4) * 2 * 3 + math.log(12) * 3
    assert geo.gric(e, 0.5, 2, 3) == pytest.approx(expected)


def test_too_few_points_raise_invalid_input():
    q = np.c_[np.zeros((4, 2)), np.ones(4)]
    with pytest.raises(InvalidInputError, match="at least 5"):
        geo.refine_relative_pose(q, q, FOCAL_PX, np.eye(3))
    with pytest.raises(InvalidInputError, match="at least 2"):
        geo.rotation_only_fit(q[:1], q[:1], FOCAL_PX)
    E, mask = geo.essential_ransac(q, q, FOCAL_PX)
    assert E is None and not mask.any()


def test_shape_mismatch_is_reported_with_both_shapes():
    with pytest.raises(InvalidInputError, match=r"\(5, 2\).*\(4, 2\)"):
        geo.rotation_only_fit(np.zeros((5, 2)), np.zeros((4, 2)), FOCAL_PX)


def _plane_scene(R, c, n_world, d_m, *, n=120, noise_px=0.0, seed=0):
    """Matches of points on the plane ``n . X = d`` (view-0 frame) seen from view 0 and from (R, c)."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-1, 1, (n, 2)) * np.array([0.7, 0.5])
    rays = np.c_[xy, np.ones(n)]
    X = rays * (d_m / (rays @ np.asarray(n_world)))[:, None]
    X1 = (X - np.asarray(c)) @ np.asarray(R)
    q0, q1 = X / X[:, 2:3], X1 / X1[:, 2:3]
    q0[:, :2] += rng.normal(0, noise_px / FOCAL_PX, (n, 2))
    q1[:, :2] += rng.normal(0, noise_px / FOCAL_PX, (n, 2))
    return q0, q1


def test_homography_of_a_wall_ahead_fits_and_holds_the_rotation():
    import cv2  # the decomposition's rotations, to check that the truth is among them

    R = rotation_from_angles_deg(1.5, -2.0, 0.7)
    q0, q1 = _plane_scene(R, [0.02, -0.01, 0.5], [0.0, 0.0, 1.0], 4.0, noise_px=0.2)  # 0.5 m towards a wall 4 m off
    hom = geo.homography_fit(q0, q1, FOCAL_PX, R)
    assert hom is not None and hom.inliers.mean() > 0.95
    # the solution nearest a good prior is the truth, within what 0.2 px of noise does to a homography (0.15 deg)
    assert angle_error_deg(hom.rotation, R) < 0.25
    assert np.median(hom.residuals_px) < 0.5
    _, Rs, _, _ = cv2.decomposeHomographyMat(hom.homography, np.eye(3))
    spread = max(angle_error_deg(A, B) for A in Rs for B in Rs)
    assert hom.ambiguity_deg == pytest.approx(spread)  # what the fast method compares with its threshold


def test_homography_visibility_resolves_a_facade_passed_sideways_but_not_the_ground():
    """A plane admits two (rotation, baseline, normal) solutions about baseline/distance apart. Walking 0.3 m
    along a facade 3 m away while looking at it, the second solution's plane would be seen edge-on with points
    on both sides of it: not visible, so the rotation is unique and right (the essential matrix of a plane
    cannot tell). Walking 0.3 m forward over the ground 1.3 m below, both solutions are visible: the ambiguity
    (about 0.3/1.3 rad) is reported for the caller to flag."""
    import cv2  # the decomposition itself

    R = rotation_from_angles_deg(0.2, 0.5, -0.3)
    q0, q1 = _plane_scene(R, [0.3, 0.0, 0.0], [0.0, 0.0, 1.0], 3.0)
    hom = geo.homography_fit(q0, q1, FOCAL_PX, np.eye(3), method="ransac")
    assert hom is not None and hom.ambiguity_deg < 0.1
    assert angle_error_deg(hom.rotation, R) < 0.05
    _, Rs, _, _ = cv2.decomposeHomographyMat(hom.homography, np.eye(3))
    assert max(angle_error_deg(A, B) for A in Rs for B in Rs) > 3.0  # without the visibility test: two
    rng = np.random.default_rng(2)
    xy = np.c_[rng.uniform(-0.7, 0.7, 150), rng.uniform(0.1, 0.5, 150)]  # the lower half: ground
    X = np.c_[xy, np.ones(150)] * (1.3 / xy[:, 1])[:, None]
    X1 = (X - np.array([0.0, 0.0, 0.3])) @ R
    g0, g1 = X / X[:, 2:3], X1 / X1[:, 2:3]
    ground = geo.homography_fit(g0, g1, FOCAL_PX, R, method="ransac")
    assert ground is not None and 5.0 < ground.ambiguity_deg < 20.0, ground.ambiguity_deg
    assert angle_error_deg(ground.rotation, R) < 0.05  # the nearest to a good prior is the truth


def test_homography_dlt_matches_opencv_on_clean_matches():
    R = rotation_from_angles_deg(-1.0, 2.5, 0.4)
    q0, q1 = _plane_scene(R, [0.1, 0.05, 0.4], [0.1, 0.0, 1.0], 5.0, noise_px=0.1, seed=4)
    ours = geo.homography_fit(q0, q1, FOCAL_PX, R, method="dlt")
    ref = geo.homography_fit(q0, q1, FOCAL_PX, R, method="ransac")
    assert ours is not None and ref is not None
    assert np.allclose(ours.homography, ref.homography, atol=2e-3)
    assert angle_error_deg(ours.rotation, R) < 0.2 and np.median(ours.residuals_px) < 0.2


def test_known_heading_removes_the_noise_bias_of_short_baselines_over_the_ground():
    """Night or fog: a 6 cm step forward, tracks only on the ground within 6 m, 0.5 px noise. The free essential
    fit's minimum leans its baseline towards the tracks (downwards) and its pitch pays for it, consistently, so the
    error piles up over keyframes; with the baseline fixed along the (true) heading the bias is gone."""
    R = rotation_from_angles_deg(0.3, -0.2, 0.1)
    c = np.array([0.0, 0.0, 0.06])
    free, fixed = [], []
    for seed in range(40):
        q0, q1 = make_scene(R, c, depth_m=(1.5, 6.0), noise_px=0.5, seed=seed, ground=True)
        rot = geo.rotation_only_fit(q0, q1, FOCAL_PX, scale_px=1.0)
        pose = geo.refine_relative_pose(q0, q1, FOCAL_PX, rot.rotation, scale_px=1.0, iterations=4)
        held = geo.refine_relative_pose(q0, q1, FOCAL_PX, pose.rotation, c, scale_px=1.0, iterations=3,
                                        fix_centre=True)
        np.testing.assert_allclose(held.centre, c / np.linalg.norm(c))  # the baseline stays where it was put
        free.append(Rotation.from_matrix(R.T @ pose.rotation).as_rotvec(degrees=True))
        fixed.append(Rotation.from_matrix(R.T @ held.rotation).as_rotvec(degrees=True))
    free_x, fixed_x = np.array(free)[:, 0], np.array(fixed)[:, 0]  # about the camera's x axis: pitch
    assert free_x.mean() > 0.02  # the free fit's bias (0.046 deg a fit: 2-3 deg over a walk's keyframes)
    assert abs(fixed_x.mean()) < 0.01
    assert np.sqrt(np.mean(fixed_x**2)) < np.sqrt(np.mean(free_x**2)) / 3


def test_fixed_centre_needs_a_centre():
    q0, q1 = make_scene(np.eye(3), np.array([0.0, 0.0, 0.1]), seed=1)
    with pytest.raises(InvalidInputError, match="centre_init"):
        geo.refine_relative_pose(q0, q1, FOCAL_PX, np.eye(3), fix_centre=True)
