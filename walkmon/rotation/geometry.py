"""Two-view rotation geometry: pure functions on matched normalised image points, no state and no I/O.

Conventions are those of :mod:`walkmon.consts`: ``R`` is the orientation of view 1 relative to view 0 (it maps
view-1 directions into view 0) and ``c`` is the centre of view 1 in view 0's frame (unit length; the scale is
unknown from images). A scene point ``X`` (view-0 frame) is seen along ``X`` in view 0 and along
``R.T @ (X - c)`` in view 1, so ``q0``, ``R @ q1`` and ``c`` are coplanar: ``q0 . (c x R q1) = 0``, i.e.
``q0.T @ E @ q1 = 0`` with ``E = [c]x R``. OpenCV's ``findEssentialMat(points0, points1)`` returns the point
transform ``R_cv = R.T``; :func:`orientation_candidates_from_essential` converts.

Why there are two models: between frames of a walk the camera moves a few centimetres, so parallax is tiny or
zero (standing). The essential matrix is then ill-conditioned and OpenCV's cheirality vote picks decompositions
~180 degrees off. :func:`rotation_only_fit` fits the rotation-only model (the infinite homography ``K R K^-1``);
:func:`refine_relative_pose` fits the essential model starting from a nearby rotation, so it never leaves the
small-rotation basin; :func:`gric` (Torr's Geometric Robust Information Criterion) says which model the data
support.

Residuals are returned in pixels: normalised-coordinate errors times ``focal_px``.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from walkmon.consts import skew
from walkmon.errors import InvalidInputError

__all__ = [
    "HomographyFit",
    "PoseFit",
    "RotationFit",
    "cauchy_weights",
    "centre_from_rotation",
    "essential_from_pose",
    "essential_ransac",
    "gric",
    "homogeneous_from_normalized",
    "homography_fit",
    "orientation_candidates_from_essential",
    "pose_rotation_std_deg",
    "refine_relative_pose",
    "rotation_angle_deg",
    "rotation_from_bearings",
    "rotation_from_rotvec",
    "rotation_only_fit",
    "rotation_only_residuals_px",
    "sampson_residuals_px",
    "select_nearest_rotation",
]

_log = logging.getLogger(__name__)


def _check_points(q0: ArrayLike, q1: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    a = np.asarray(q0, dtype=float)
    b = np.asarray(q1, dtype=float)
    if a.ndim != 2 or a.shape[1] not in (2, 3) or a.shape != b.shape:
        msg = f"matched points must both have shape (N, 2) or (N, 3), got {a.shape} and {b.shape}"
        raise InvalidInputError(msg)
    if a.shape[1] == 2:
        a, b = homogeneous_from_normalized(a), homogeneous_from_normalized(b)
    return a, b


def _skew3(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """``consts.skew`` for one 3-vector, without the broadcasting machinery (hot loops call this)."""
    x, y, z = float(v[0]), float(v[1]), float(v[2])
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def homogeneous_from_normalized(xy: ArrayLike) -> NDArray[np.float64]:
    """``(x, y) -> (x, y, 1)``; shape (N, 3)."""
    p = np.asarray(xy, dtype=float).reshape(-1, 2)
    return np.hstack([p, np.ones((p.shape[0], 1))])


def rotation_from_rotvec(rotvec: ArrayLike) -> NDArray[np.float64]:
    """Rodrigues: the rotation by ``|v|`` radians about ``v``."""
    v = np.asarray(rotvec, dtype=float)
    theta = math.sqrt(float(v @ v))
    if theta < 1e-12:
        return np.eye(3) + _skew3(v)
    k = _skew3(v / theta)
    return np.eye(3) + math.sin(theta) * k + (1.0 - math.cos(theta)) * (k @ k)


def rotation_angle_deg(R: ArrayLike) -> float:
    """Angle of the rotation ``R`` in degrees (0..180)."""
    c = (float(np.trace(np.asarray(R, dtype=float))) - 1.0) / 2.0
    return math.degrees(math.acos(min(1.0, max(-1.0, c))))


def rotation_from_bearings(b0: ArrayLike, b1: ArrayLike, weights: ArrayLike | None = None) -> NDArray[np.float64]:
    """Weighted least-squares rotation with ``b0 ~ R @ b1`` (Kabsch/Wahba, closed form via SVD).

    ``b0``, ``b1`` are (N, 3) direction vectors (any length; they are normalised here).
    """
    a = np.asarray(b0, dtype=float)
    b = np.asarray(b1, dtype=float)
    a = a / np.linalg.norm(a, axis=1, keepdims=True)
    b = b / np.linalg.norm(b, axis=1, keepdims=True)
    w = np.ones(a.shape[0]) if weights is None else np.asarray(weights, dtype=float)
    M = (a * w[:, None]).T @ b
    U, _, Vt = np.linalg.svd(M)
    D = np.diag([1.0, 1.0, float(np.sign(np.linalg.det(U @ Vt)) or 1.0)])
    return U @ D @ Vt


def rotation_only_residuals_px(R: ArrayLike, q0: NDArray[np.float64], q1: NDArray[np.float64], focal_px: float):
    """Transfer error of the rotation-only model: distance between ``q0`` and ``R q1`` projected, in pixels."""
    p = q1 @ np.asarray(R, dtype=float).T
    z = np.where(np.abs(p[:, 2]) < 1e-9, 1e-9, p[:, 2])
    d = p[:, :2] / z[:, None] - q0[:, :2] / q0[:, 2:3]
    return focal_px * np.sqrt(np.sum(d * d, axis=1))


def cauchy_weights(residuals_px: NDArray[np.float64], scale_px: float) -> NDArray[np.float64]:
    """IRLS weights of the Cauchy loss ``log(1 + (r/s)^2)``."""
    return 1.0 / (1.0 + (residuals_px / scale_px) ** 2)


@dataclass(frozen=True, slots=True)
class RotationFit:
    """Result of :func:`rotation_only_fit`: rotation, per-point residuals (px) and the inlier mask."""

    rotation: NDArray[np.float64]
    residuals_px: NDArray[np.float64]
    inliers: NDArray[np.bool_]


def rotation_only_fit(
    q0: ArrayLike,
    q1: ArrayLike,
    focal_px: float,
    *,
    rotation_init: ArrayLike | None = None,
    scale_px: float = 1.0,
    inlier_px: float = 2.0,
    iterations: int = 4,
) -> RotationFit:
    """Robust rotation-only model ``q0 ~ R q1`` by iteratively reweighted Kabsch (Cauchy loss).

    Starting weights come from ``rotation_init`` when given (e.g. the previous frame's estimate), so a minority
    of bad tracks cannot pull the first solve.
    """
    a, b = _check_points(q0, q1)
    if a.shape[0] < 2:
        msg = f"the rotation-only model needs at least 2 matches, got {a.shape[0]}"
        raise InvalidInputError(msg)
    if rotation_init is None:
        w = np.ones(a.shape[0])
    else:
        w = cauchy_weights(rotation_only_residuals_px(rotation_init, a, b, focal_px), scale_px * 3.0)
    R = np.eye(3)
    for _ in range(max(1, iterations)):
        R = rotation_from_bearings(a, b, w)
        r = rotation_only_residuals_px(R, a, b, focal_px)
        w = cauchy_weights(r, scale_px)
    r = rotation_only_residuals_px(R, a, b, focal_px)
    return RotationFit(R, r, r < inlier_px)


def essential_from_pose(R: ArrayLike, c: ArrayLike) -> NDArray[np.float64]:
    """``E = [c]x R`` so that ``q0.T E q1 = 0`` for matches (see the module docstring)."""
    cv = np.asarray(c, dtype=float)
    return (_skew3(cv) if cv.shape == (3,) else skew(cv)) @ np.asarray(R, dtype=float)


def sampson_residuals_px(
    E: ArrayLike, q0: NDArray[np.float64], q1: NDArray[np.float64], focal_px: float
) -> NDArray[np.float64]:
    """First-order geometric (Sampson) distance of each match to ``q0.T E q1 = 0``, in pixels (signed)."""
    E = np.asarray(E, dtype=float)
    Eq1 = q1 @ E.T
    Etq0 = q0 @ E
    e = np.sum(q0 * Eq1, axis=1)
    den = Eq1[:, 0] ** 2 + Eq1[:, 1] ** 2 + Etq0[:, 0] ** 2 + Etq0[:, 1] ** 2
    return focal_px * e / np.sqrt(np.maximum(den, 1e-30))


def _sampson(R: NDArray[np.float64], c: NDArray[np.float64], q0: NDArray[np.float64], q1: NDArray[np.float64]):
    """Signed Sampson residuals in normalised units for ``E = [c]x R`` (c need not be unit length)."""
    E = _skew3(c) @ R
    Eq1 = q1 @ E.T
    Etq0 = q0 @ E
    e = np.einsum("ij,ij->i", q0, Eq1)
    den = Eq1[:, 0] ** 2 + Eq1[:, 1] ** 2 + Etq0[:, 0] ** 2 + Etq0[:, 1] ** 2
    return e / np.sqrt(np.maximum(den, 1e-30))


#: Generators of rotations about x, y, z (``skew`` of the unit vectors), for the Jacobian's perturbations.
_GENERATORS = np.array(
    [[[0, 0, 0], [0, 0, -1], [0, 1, 0]], [[0, 0, 1], [0, 0, 0], [-1, 0, 0]], [[0, -1, 0], [1, 0, 0], [0, 0, 0]]],
    dtype=float,
)


def _sampson_batch(Es: NDArray[np.float64], q0: NDArray[np.float64], q1: NDArray[np.float64]):
    """Signed Sampson residuals (normalised units) for a stack of essential matrices (K, 3, 3) -> (K, N)."""
    Eq1 = Es @ q1.T  # (K, 3, N)
    Etq0 = q0 @ Es  # (K, N, 3)
    e = np.sum(q0.T * Eq1, axis=1)
    den = Eq1[:, 0] ** 2 + Eq1[:, 1] ** 2 + Etq0[:, :, 0] ** 2 + Etq0[:, :, 1] ** 2
    return e / np.sqrt(np.maximum(den, 1e-30))


def centre_from_rotation(q0: NDArray[np.float64], q1: NDArray[np.float64], R: ArrayLike, weights=None):
    """Least-squares baseline direction for a known rotation: ``c`` minimising ``sum w (c . (q0 x R q1))^2``."""
    A = np.cross(q0, q1 @ np.asarray(R, dtype=float).T)
    if weights is not None:
        A = A * np.sqrt(np.asarray(weights, dtype=float))[:, None]
    _, _, Vt = np.linalg.svd(A, full_matrices=False)
    return Vt[-1]


def _tangent_basis(c: NDArray[np.float64]) -> NDArray[np.float64]:
    """Two unit vectors orthogonal to the unit vector ``c`` (and to each other), as columns (3, 2)."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(c[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = _skew3(c) @ helper
    u /= np.linalg.norm(u)
    v = _skew3(c) @ u
    return np.stack([u, v], axis=1)


@dataclass(frozen=True, slots=True)
class PoseFit:
    """Result of :func:`refine_relative_pose`: rotation, unit baseline direction, Sampson residuals (px), inliers."""

    rotation: NDArray[np.float64]
    centre: NDArray[np.float64]
    residuals_px: NDArray[np.float64]
    inliers: NDArray[np.bool_]


def refine_relative_pose(
    q0: ArrayLike,
    q1: ArrayLike,
    focal_px: float,
    rotation_init: ArrayLike,
    centre_init: ArrayLike | None = None,
    *,
    scale_px: float = 1.0,
    inlier_px: float = 2.0,
    iterations: int = 10,
    fix_centre: bool = False,
) -> PoseFit:
    """Essential-model refinement of (R, c) by Gauss-Newton on Sampson errors with Cauchy IRLS weights.

    Starts at ``rotation_init`` (and ``centre_init``, or the best baseline for that rotation) and takes small
    steps, so the answer stays in the small-rotation basin: the twisted-pair decomposition (~180 degrees away)
    is never reached. ``c`` and ``-c`` give the same errors; the sign is not meaningful. ``fix_centre`` keeps
    the baseline direction at ``centre_init`` (required then) and refines the rotation alone: the essential
    model with a known direction of travel (3 parameters instead of 5).
    """
    a, b = _check_points(q0, q1)
    if a.shape[0] < 5:
        msg = f"the essential model needs at least 5 matches, got {a.shape[0]}"
        raise InvalidInputError(msg)
    R = np.array(rotation_init, dtype=float)
    w = np.ones(a.shape[0])
    if fix_centre and centre_init is None:
        msg = "fix_centre needs centre_init"
        raise InvalidInputError(msg)
    if centre_init is None:
        w = cauchy_weights(rotation_only_residuals_px(R, a, b, focal_px), 3.0 * scale_px + 1.0)
        c = centre_from_rotation(a, b, R, w)
    else:
        c = np.asarray(centre_init, dtype=float)
        c = c / np.linalg.norm(c)
        w = cauchy_weights(sampson_residuals_px(essential_from_pose(R, c), a, b, focal_px), scale_px)
    eps = 1e-7
    for _ in range(max(1, iterations)):
        B = _tangent_basis(c)
        # Forward-difference Jacobian of the full Sampson residual (its denominator depends on R and c too;
        # treating it as constant turns Gauss-Newton into a slow fixed-point iteration along the
        # pitch/baseline valley that ground-only views create). All six E matrices are evaluated in one batch;
        # rotation perturbations are first order, (I + eps [e_k]x) R, exact to O(eps^2).
        C = _skew3(c)
        E0 = C @ R
        k = 4 if fix_centre else 6
        Es = np.empty((k, 3, 3))
        Es[0] = E0
        Es[1:4] = E0 + eps * (C @ _GENERATORS @ R)
        if not fix_centre:
            Es[4] = _skew3(c + eps * B[:, 0]) @ R
            Es[5] = _skew3(c + eps * B[:, 1]) @ R
        rs = _sampson_batch(Es, a, b)
        r = rs[0]
        J = ((rs[1:] - r) / eps).T
        w = cauchy_weights(focal_px * r, scale_px)
        JW = J * w[:, None]
        H = JW.T @ J + 1e-12 * np.eye(k - 1)
        g = JW.T @ r
        try:
            step = -np.linalg.solve(H, g)
        except np.linalg.LinAlgError:
            break
        R = rotation_from_rotvec(step[:3]) @ R
        if not fix_centre:
            c = c + B @ step[3:]
            c = c / np.linalg.norm(c)
        if float(step @ step) < 1e-14:
            break
    res = sampson_residuals_px(essential_from_pose(R, c), a, b, focal_px)
    return PoseFit(R, c, res, np.abs(res) < inlier_px)


def gric(residuals_px: ArrayLike, sigma_px: float, model_dim: int, n_params: int, data_dim: int = 4) -> float:
    """Torr's Geometric Robust Information Criterion (lower is better).

    ``GRIC = sum(min(e^2/sigma^2, 2 (r - d))) + ln(r) d n + ln(r n) k`` with ``r`` the data dimension (4 for
    two-view matches), ``d`` the model's manifold dimension (2 for a homography/rotation, 3 for the essential
    matrix) and ``k`` its number of parameters (3 for a rotation, 5 for an essential matrix).
    """
    e2 = (np.asarray(residuals_px, dtype=float) / sigma_px) ** 2
    n = e2.size
    rho = np.minimum(e2, 2.0 * (data_dim - model_dim))
    return float(np.sum(rho) + math.log(data_dim) * model_dim * n + math.log(data_dim * max(n, 1)) * n_params)


def orientation_candidates_from_essential(E_cv: ArrayLike) -> list[NDArray[np.float64]]:
    """The two orientations (``R = R_cv.T``) an OpenCV essential matrix decomposes into."""
    import cv2  # noqa: PLC0415

    R1, R2, _ = cv2.decomposeEssentialMat(np.asarray(E_cv, dtype=float))
    return [R1.T.copy(), R2.T.copy()]


def select_nearest_rotation(candidates: list[NDArray[np.float64]], prior: ArrayLike) -> NDArray[np.float64]:
    """The candidate rotation closest (in angle) to ``prior``: small inter-frame rotation, never a flip."""
    P = np.asarray(prior, dtype=float)
    return min(candidates, key=lambda R: rotation_angle_deg(P.T @ R))


def essential_ransac(
    q0: ArrayLike,
    q1: ArrayLike,
    focal_px: float,
    *,
    threshold_px: float = 1.0,
    confidence: float = 0.999,
    method: str = "ransac",
) -> tuple[NDArray[np.float64] | None, NDArray[np.bool_]]:
    """5-point essential matrix with RANSAC (``method="ransac"``) or USAC MAGSAC++ (``"magsac"``).

    Returns OpenCV's ``E_cv`` (``q1.T E_cv q0 = 0``; the first 3x3 solution when OpenCV returns several) and
    the inlier mask, or ``(None, all False)`` when it fails.
    """
    import cv2  # noqa: PLC0415

    a, b = _check_points(q0, q1)
    n = a.shape[0]
    if n < 5:
        return None, np.zeros(n, dtype=bool)
    p0 = np.ascontiguousarray(a[:, :2] / a[:, 2:3])
    p1 = np.ascontiguousarray(b[:, :2] / b[:, 2:3])
    flag = cv2.USAC_MAGSAC if method == "magsac" else cv2.RANSAC
    E, mask = cv2.findEssentialMat(p0, p1, np.eye(3), method=flag, prob=confidence, threshold=threshold_px / focal_px)
    if E is None or E.shape[0] < 3:
        return None, np.zeros(n, dtype=bool)
    return E[:3].copy(), (mask.ravel() > 0) if mask is not None else np.ones(n, dtype=bool)


#: A homography decomposition is kept when its plane faces the camera for this fraction of the matches.
_VISIBLE_FRACTION = 0.9


@dataclass(frozen=True, slots=True)
class HomographyFit:
    """Result of :func:`homography_fit`: the rotation of the plane-induced homography ``H = R + c n^T / d``
    nearest the prior, H itself (``q0 ~ H q1``), transfer residuals (px) of every match and the inlier mask."""

    rotation: NDArray[np.float64]
    homography: NDArray[np.float64]
    residuals_px: NDArray[np.float64]
    inliers: NDArray[np.bool_]
    #: Largest angle between the decomposition's rotations whose plane faces the camera: how ambiguous the
    #: plane leaves the rotation (walking along the ground keeps two, ~ baseline/height apart; a facade
    #: passed sideways has one visible solution).
    ambiguity_deg: float = 0.0
    #: The decomposition's solutions whose plane faces the camera: (rotation, unit plane normal in view 1).
    #: Knowing the plane's normal (the ground's is the vertical) picks the true one of two.
    solutions: tuple[tuple[NDArray[np.float64], NDArray[np.float64]], ...] = ()


def homography_fit(
    q0: ArrayLike,
    q1: ArrayLike,
    focal_px: float,
    rotation_prior: ArrayLike,
    *,
    inlier_px: float = 2.0,
    method: str = "magsac",
    use: ArrayLike | None = None,
) -> HomographyFit | None:
    """Plane-induced homography ``q0 ~ H q1`` and the rotation of its decomposition nearest ``rotation_prior``;
    None when it fails. ``method``: ``"magsac"`` (OpenCV ``findHomography`` with USAC MAGSAC++, robust),
    ``"ransac"``, or ``"dlt"``: a plain least-squares direct linear transform (Hartley-normalised) over the
    matches ``use`` marks (default all), six times cheaper than MAGSAC++ (0.1 vs 0.9 ms for 150 matches), for
    callers that have already removed outliers (the fast method passes its rotation/essential inliers).

    A scene dominated by one plane (a wall or door close ahead, the ground) with parallax fits a homography
    ``H = R + c n^T / d`` exactly, while the essential matrix of a plane is degenerate (a family of (R, c) fit
    equally well, so its rotation wanders); :func:`gric` with ``model_dim=2, n_params=8`` scores it against
    the other models. ``cv2.decomposeHomographyMat`` gives up to four (R, t, n); with this module's
    convention (``H`` maps view-1 points to view 0) its ``R`` is the orientation of view 1 in view 0 directly.
    """
    import cv2  # noqa: PLC0415

    a, b = _check_points(q0, q1)
    n = a.shape[0]
    if n < 8:
        return None
    p0 = np.ascontiguousarray(a[:, :2] / a[:, 2:3])
    p1 = np.ascontiguousarray(b[:, :2] / b[:, 2:3])
    if method == "dlt":
        sel = np.ones(n, bool) if use is None else np.asarray(use, bool)
        if np.count_nonzero(sel) < 8:
            return None
        H = _homography_dlt(p1[sel], p0[sel])
    else:
        flag = cv2.USAC_MAGSAC if method == "magsac" else cv2.RANSAC
        H, _mask = cv2.findHomography(p1, p0, flag, inlier_px / focal_px, maxIters=500, confidence=0.99)
    if H is None or not np.all(np.isfinite(H)) or abs(np.linalg.det(H)) < 1e-12:
        return None
    H = H / np.cbrt(np.linalg.det(H))  # scale so that det = 1 (the rotation part's)
    _, Rs, _, Ns = cv2.decomposeHomographyMat(H, np.eye(3))
    # Visibility: the plane's normal n (view-1 frame, n . X = d > 0 on the plane) must face the camera for the
    # points it was fitted to (n . q1 > 0). A facade passed sideways has a second solution whose plane would
    # be seen edge-on with points on both sides: not visible, dropped. The ground walked along keeps both.
    pts = b if method != "dlt" or use is None else b[np.asarray(use, bool)]
    sols = [(np.asarray(r, dtype=float), np.asarray(nrm, dtype=float).ravel() / max(np.linalg.norm(nrm), 1e-12))
            for r, nrm in zip(Rs, Ns, strict=True)
            if np.mean(pts @ np.asarray(nrm, dtype=float).ravel() > 0) >= _VISIBLE_FRACTION]
    visible = [r for r, _ in sols]
    cands = visible or [np.asarray(r, dtype=float) for r in Rs]
    R = select_nearest_rotation(cands, rotation_prior)
    spread = max((rotation_angle_deg(A.T @ B) for A in cands for B in cands), default=0.0)
    p = b @ H.T
    z = np.where(np.abs(p[:, 2]) < 1e-9, 1e-9, p[:, 2])
    d = p[:, :2] / z[:, None] - p0
    r = focal_px * np.sqrt(np.sum(d * d, axis=1))
    return HomographyFit(R, H, r, r < inlier_px, spread, tuple(sols))


def pose_rotation_std_deg(
    q0: ArrayLike, q1: ArrayLike, focal_px: float, fit: PoseFit, sigma_px: float, scale_px: float = 1.0
) -> float:
    """Standard deviation (deg, worst direction) of an essential fit's rotation from its Gauss-Newton Hessian.

    The Sampson residuals' Jacobian in the fit's five parameters (rotation, baseline direction), Cauchy
    weights at ``scale_px``, noise ``sigma_px``: ``cov = sigma^2 (J^T W J)^-1``, rotation block. A scene
    whose tracks lie near one plane, or a baseline too short for the depth, leaves the rotation trading
    against the baseline: the Hessian is near singular along that valley and this number large.
    """
    a, b = _check_points(q0, q1)
    R, c = fit.rotation, fit.centre
    eps = 1e-7
    B = _tangent_basis(c)
    C = _skew3(c)
    E0 = C @ R
    Es = np.empty((6, 3, 3))
    Es[0] = E0
    Es[1:4] = E0 + eps * (C @ _GENERATORS @ R)
    Es[4] = _skew3(c + eps * B[:, 0]) @ R
    Es[5] = _skew3(c + eps * B[:, 1]) @ R
    rs = _sampson_batch(Es, a, b)
    J = ((rs[1:] - rs[0]) / eps).T
    w = cauchy_weights(focal_px * rs[0], scale_px)
    Hm = (J * w[:, None]).T @ J
    try:
        cov = np.linalg.inv(Hm + 1e-15 * np.eye(5)) * (sigma_px / focal_px) ** 2
    except np.linalg.LinAlgError:
        return math.inf
    ev = np.linalg.eigvalsh(cov[:3, :3])
    return math.degrees(math.sqrt(max(float(ev[-1]), 0.0)))


def _homography_dlt(src: NDArray[np.float64], dst: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """Least-squares ``dst ~ H src`` by the normalised direct linear transform (Hartley & Zisserman, Alg. 4.2)."""

    def normaliser(p: NDArray[np.float64]) -> NDArray[np.float64]:
        c = p.mean(axis=0)
        s = math.sqrt(2.0) / max(float(np.mean(np.linalg.norm(p - c, axis=1))), 1e-12)
        return np.array([[s, 0.0, -s * c[0]], [0.0, s, -s * c[1]], [0.0, 0.0, 1.0]])

    Ts, Td = normaliser(src), normaliser(dst)
    x = src @ Ts[:2, :2].T + Ts[:2, 2]
    y = dst @ Td[:2, :2].T + Td[:2, 2]
    n = x.shape[0]
    A = np.zeros((2 * n, 9))
    A[0::2, 0:2], A[0::2, 2] = x, 1.0
    A[0::2, 6:8], A[0::2, 8] = -y[:, :1] * x, -y[:, 0]
    A[1::2, 3:5], A[1::2, 5] = x, 1.0
    A[1::2, 6:8], A[1::2, 8] = -y[:, 1:2] * x, -y[:, 1]
    try:
        _, _, Vt = np.linalg.svd(A, full_matrices=False)
    except np.linalg.LinAlgError:
        return None
    Hn = Vt[-1].reshape(3, 3)
    return np.linalg.inv(Td) @ Hn @ Ts
