"""The ``paper`` rotation method: the reference paper's pipeline (Sec. 2-3) as written, for comparison.

Per frame: AKAZE features and descriptors on the full-resolution grey frame; pyramidal Lucas-Kanade tracks the
previous frame's keypoints to find where each should land (the matching area); FLANN (LSH index, AKAZE
descriptors are binary) matches previous to current descriptors with Lowe's ratio test, and only matches inside
the LK-predicted area are kept; the essential matrix comes from the 5-point algorithm with RANSAC; the rotation
is decomposed with the cheirality check (``recoverPose``) and refined by two-view bundle adjustment
(``scipy.optimize.least_squares`` over the rotation, the baseline direction and each point's inverse depth); the
frame-to-frame rotations are chained.

Departures from the paper, kept minimal and on purpose: (1) when the cheirality vote returns a rotation larger
than ``max_frame_rotation_deg`` (the ~180 degree twisted pair that low parallax produces), the decomposition
nearest to no rotation is used instead; (2) degenerate input holds the last orientation with a status, as the
estimator contract requires. Everything else, including the drift of chaining, is the paper's.
"""

from __future__ import annotations

import logging

import cv2
import numpy as np
from numpy.typing import NDArray

from walkmon.camera.model import CameraModel
from walkmon.rotation import geometry as geo
from walkmon.rotation.types import (
    EstimateStatus,
    RotationEstimate,
    RotationSettings,
    make_estimate,
)

__all__ = ["PaperEngine", "bundle_adjust_two_view"]

_log = logging.getLogger(__name__)

_UNIFORM_STD = 2.0
_FLANN_INDEX_LSH = 6


def _project(R: NDArray[np.float64], c: NDArray[np.float64], q0: NDArray[np.float64], rho: NDArray[np.float64]):
    """View-1 normalised projections of points seen along ``q0`` (view 0) at inverse depth ``rho``."""
    # X = q0 / rho ; X1 = R.T (X - c)  ->  scale by rho:  R.T (q0 - rho c)
    X1 = (q0 - rho[:, None] * c[None, :]) @ R
    z = np.where(np.abs(X1[:, 2]) < 1e-9, 1e-9, X1[:, 2])
    return X1[:, :2] / z[:, None]


def bundle_adjust_two_view(
    q0: NDArray[np.float64],
    q1: NDArray[np.float64],
    R: NDArray[np.float64],
    c: NDArray[np.float64],
    focal_px: float,
    *,
    max_evaluations: int = 30,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Two-view bundle adjustment of (R, c, inverse depths) minimising reprojection error in view 1 (pixels).

    View 0 is the reference, so its rays fix the points' directions; each point keeps one inverse depth (which
    handles distant and zero-parallax points). The baseline length is fixed at 1 (scale is unobservable).
    Returns the refined (R, c).
    """
    from scipy.optimize import least_squares  # noqa: PLC0415
    from scipy.sparse import lil_matrix  # noqa: PLC0415

    n = q0.shape[0]
    # Initial inverse depths by linear triangulation along view-0 rays: q1 x R.T(q0 - rho c) = 0.
    a = np.cross(q1, q0 @ R)
    b = np.cross(q1, np.tile(c @ R, (n, 1)))
    rho0 = np.clip(np.sum(a * b, axis=1) / np.maximum(np.sum(b * b, axis=1), 1e-12), 0.0, 10.0)
    x0 = np.concatenate([np.zeros(3), np.zeros(2), rho0])
    basis = np.linalg.svd(c.reshape(1, 3))[2][1:].T  # 3x2 tangent basis at c

    def unpack(x: NDArray[np.float64]):
        Rx = geo.rotation_from_rotvec(x[:3]) @ R
        cx = c + basis @ x[3:5]
        return Rx, cx / np.linalg.norm(cx), x[5:]

    def residuals(x: NDArray[np.float64]) -> NDArray[np.float64]:
        Rx, cx, rho = unpack(x)
        return (focal_px * (_project(Rx, cx, q0, rho) - q1[:, :2])).ravel()

    sparsity = lil_matrix((2 * n, 5 + n), dtype=int)
    sparsity[:, :5] = 1
    idx = np.arange(n)
    sparsity[2 * idx, 5 + idx] = 1
    sparsity[2 * idx + 1, 5 + idx] = 1
    sol = least_squares(
        residuals, x0, jac_sparsity=sparsity, loss="huber", f_scale=1.0, max_nfev=max_evaluations, x_scale="jac",
        method="trf",
    )
    Rx, cx, _ = unpack(sol.x)
    return Rx, cx


class PaperEngine:
    """State of the paper method for one camera size; see the module docstring."""

    def __init__(self, camera: CameraModel, settings: RotationSettings) -> None:
        self.camera = camera
        self.s = settings
        self._akaze = cv2.AKAZE_create(threshold=settings.akaze_threshold)
        index = {"algorithm": _FLANN_INDEX_LSH, "table_number": 6, "key_size": 12, "multi_probe_level": 1}
        self._flann = cv2.FlannBasedMatcher(index, {"checks": 50})
        self._focal = 0.5 * (camera.fx + camera.fy)
        self._orientation = np.eye(3)
        self._prev: NDArray[np.uint8] | None = None
        self._prev_kp: NDArray[np.float32] | None = None
        self._prev_desc: NDArray[np.uint8] | None = None
        self.started = False

    def _hold(self, t_s: float, status: EstimateStatus, n: int = 0) -> RotationEstimate:
        return make_estimate(t_s, self._orientation, n_inliers=0, model="hold", status=status, n_tracks=n)

    def _features(self, grey: NDArray[np.uint8]):  # noqa: ANN202
        kps, desc = self._akaze.detectAndCompute(grey, None)
        if desc is None or len(kps) == 0:
            return np.zeros((0, 2), np.float32), None
        return np.array([k.pt for k in kps], np.float32), desc

    def push(self, grey: NDArray[np.uint8], t_s: float) -> RotationEstimate:
        if float(grey.std()) < _UNIFORM_STD:
            self.started = True
            return self._hold(t_s, EstimateStatus.TOO_FEW_FEATURES)
        if self._prev is not None and np.array_equal(grey, self._prev):
            return self._hold(t_s, EstimateStatus.REPEATED_FRAME)
        kp, desc = self._features(grey)
        if self._prev is None or self._prev_desc is None or desc is None or len(kp) < 5:
            first = not self.started
            self.started = True
            prev_ok = self._prev_desc is not None
            self._prev, self._prev_kp, self._prev_desc = grey, kp, desc
            if desc is None or len(kp) < 5 or (not first and prev_ok):
                return self._hold(t_s, EstimateStatus.TOO_FEW_FEATURES, len(kp))
            status = EstimateStatus.FIRST_FRAME if first else EstimateStatus.TOO_FEW_FEATURES
            return make_estimate(
                t_s, self._orientation, n_inliers=len(kp), model="identity" if first else "hold", status=status,
                n_tracks=len(kp), keyframe=True,
            )
        est = self._estimate(grey, kp, desc, t_s)
        self._prev, self._prev_kp, self._prev_desc = grey, kp, desc
        return est

    def _match(self, grey: NDArray[np.uint8], kp: NDArray[np.float32], desc: NDArray[np.uint8]):  # noqa: ANN202
        s = self.s
        prev_kp = self._prev_kp
        assert prev_kp is not None and self._prev is not None  # noqa: S101
        # LK finds the matching area: where each previous keypoint should be in this frame.
        pred, st, _ = cv2.calcOpticalFlowPyrLK(
            self._prev, grey, prev_kp.reshape(-1, 1, 2), None, winSize=(21, 21), maxLevel=3,
        )
        pred = pred.reshape(-1, 2)
        lk_ok = st.ravel().astype(bool)
        try:
            knn = self._flann.knnMatch(self._prev_desc, desc, k=2)
        except cv2.error:
            return np.zeros((0, 2)), np.zeros((0, 2))
        i0, i1 = [], []
        for pair in knn:
            if len(pair) < 2:
                continue
            m, m2 = pair
            if m.distance >= s.ratio_test * m2.distance or not lk_ok[m.queryIdx]:
                continue
            if np.hypot(*(kp[m.trainIdx] - pred[m.queryIdx])) > s.match_radius_px:
                continue
            i0.append(m.queryIdx)
            i1.append(m.trainIdx)
        return prev_kp[i0], kp[i1]

    def _estimate(self, grey, kp, desc, t_s: float) -> RotationEstimate:  # noqa: ANN001
        s = self.s
        p0, p1 = self._match(grey, kp, desc)
        n = len(p0)
        if n < max(5, s.min_inliers):
            return self._hold(t_s, EstimateStatus.TOO_FEW_FEATURES, n)
        q0 = geo.homogeneous_from_normalized(self.camera.normalized_from_pixels(p0))
        q1 = geo.homogeneous_from_normalized(self.camera.normalized_from_pixels(p1))
        E, mask = geo.essential_ransac(q0, q1, self._focal, threshold_px=s.ransac_threshold_px)
        if E is None or int(mask.sum()) < s.min_inliers:
            return self._hold(t_s, EstimateStatus.LOW_QUALITY, n)
        x0 = np.ascontiguousarray(q0[mask, :2])
        x1 = np.ascontiguousarray(q1[mask, :2])
        _, R_cv, t_cv, _ = cv2.recoverPose(E, x0, x1, np.eye(3))
        R = R_cv.T
        if geo.rotation_angle_deg(R) > s.max_frame_rotation_deg:
            R = geo.select_nearest_rotation(geo.orientation_candidates_from_essential(E), np.eye(3))
        c = -R @ t_cv.ravel()  # x1 = R_cv x0 + t  ->  centre of view 1 in view 0 = -R_cv.T t
        c = c / max(np.linalg.norm(c), 1e-12)
        a0, a1 = q0[mask], q1[mask]
        if s.bundle_adjust:
            if a0.shape[0] > s.max_ba_points:
                pick = np.linspace(0, a0.shape[0] - 1, s.max_ba_points).astype(int)
                a0, a1 = a0[pick], a1[pick]
            R, c = bundle_adjust_two_view(a0, a1, R, c, self._focal)
        if geo.rotation_angle_deg(R) > s.max_frame_rotation_deg:
            return self._hold(t_s, EstimateStatus.LOW_QUALITY, n)
        self._orientation = self._orientation @ R
        res = np.abs(geo.sampson_residuals_px(geo.essential_from_pose(R, c), q0[mask], q1[mask], self._focal))
        return make_estimate(
            t_s, self._orientation, n_inliers=int(mask.sum()), model="essential", status=EstimateStatus.OK,
            n_tracks=n, residual_px=float(np.median(res)),
        )
