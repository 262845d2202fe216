"""Drift-free tilt for the fast method: vertical lines (the vertical vanishing direction) as a world reference.

Why. Keyframe-relative visual odometry adds a small error at every keyframe link, and the errors do not average
out: KLT tracks of facade and ground patches that stretch and shear as the walker approaches them carry a
scene-dependent bias. On the simulator's 40 s walks (640x480, seeds 1-5) roll drifted 0.4-1.0 deg by the end
(raw roll RMSE up to 0.56 deg, issue 14's target 0.5), while the same engine fed the tracks' exact projections
(the simulator's geometry, 0.1 px noise) drifted 0.01 deg: the fitting is right, the tracks are biased. Tuning
the tracker (window, corner quality, full-resolution tracking, tracking against the keyframe image, symmetric
forward-backward tracking) moved the drift by tens of percent on one seed and in either direction on others.

Streets, corridors and rooms are full of vertical edges (facades, doors, window frames, poles), and their
image lines all pass through one vanishing point: the direction of gravity in the camera frame. That is an
absolute reference for pitch and roll (not yaw), measurable in every frame, with no drift. So at keyframes the
fast method detects line segments (OpenCV's LSD on the tracking image), keeps those consistent with the
vertical its own orientation predicts, measures the vertical from them (weighted least squares with an honest
covariance: for a level camera the vanishing point lies far outside the image and pins roll well, pitch
poorly) and corrects its orientation a little, as a 2-state Kalman filter of the tilt error would: the tilt
uncertainty grows with time (visual drift) and shrinks with each measurement. The world's vertical itself is
learnt from the first measurements (the start-relative frame need not be level), so a constant offset of the
line measurement cancels. Vertical lines leave yaw untouched; the same segments' horizontal ones correct it
(:mod:`walkmon.rotation.heading`, called from :meth:`VerticalReference.correct` once the vertical is measured).

Where there are no vertical lines (an open field, fog, night) nothing is corrected and the drift is that of the
odometry alone; fast turns (rolling shutter leans vertical lines) are skipped.

After a turn. A turn past a facade 1-3 m away can leave the odometry's tilt several degrees off (2-9 deg on the
simulator's unkind sessions at 320x240), more than the filter's slow random walk expects and more than its 3 deg
limit accepts, so such an error stayed for the rest of a walk. The fast method therefore adds *doubt* for each
frame of a fast turn (:meth:`VerticalReference.add_doubt`, linear: the errors are biases); with doubt the lines are
looked at as soon as the turn is over (:meth:`VerticalReference.due`, between keyframes), searched as far as the
doubt reaches, and a clear view (many long segments that agree) takes the error out at once. A poor view is used at
keyframes as if there were no doubt, and not at all between them: a few noisy lines pulled harder moved good tilts
by degrees at night.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from walkmon.rotation.geometry import rotation_angle_deg, rotation_from_rotvec
from walkmon.rotation.heading import HeadingReference

__all__ = ["VerticalFit", "VerticalReference", "vertical_fit"]

#: Line segments shorter than this fraction of the image width are not used (too imprecise in direction).
_MIN_LENGTH_FRACTION = 0.04
#: The first measurements search this far (deg) around the camera's y axis for the vertical, then narrow down.
_INIT_GATES_DEG = (15.0, 5.0, 2.0)
#: LSD's own image scale (OpenCV's default). 0.5 halved the detector's cost (5.6 -> 2.6 ms a keyframe at 320x240)
#: but doubled the roll error left on the simulated 40 s walks (mean raw roll 0.095 -> 0.206 deg).
_LSD_SCALE = 0.8
#: The most tilt doubt flagged frames add up to (deg): beyond it the lines are trusted all the same.
_MAX_DOUBT_DEG = 20.0
#: From this doubt (deg) on, the lines are looked at every _DOUBT_CHECK_INTERVAL_S (s) without waiting for a
#: keyframe (VerticalReference.due).
_DOUBT_CHECK_DEG = 1.0
_DOUBT_CHECK_INTERVAL_S = 0.2
#: A clear view of the vertical (VerticalReference.correct): the lines' fit within this standard deviation (deg),
#: from at least this many times min_lines segments.
_CLEAR_SD_DEG = 0.5
_CLEAR_LINES_FACTOR = 2
#: Looks between keyframes stop this long (s) after the last doubt was added (VerticalReference.due).
_DOUBT_LOOK_S = 3.0
#: A vertical that would have the camera look up by more than this (deg) is not taken (VerticalReference.correct).
#: A chest camera looks level or down (a little up on a wearer leaning back). The ground's lines along the walk
#: (kerbs, paving joints) meet at the horizon ahead, which for a camera d deg down would be a vertical with the
#: camera looking up by 90 - d deg: refused while d < 60 (a 25 deg mount on a walker stooping 30 deg is 55 deg
#: down; review found a 65 deg-down camera learns the horizon). Set from that geometry, not tuned.
_MAX_UP_TILT_DEG = 30.0


def _sd_deg(cov: NDArray[np.float64]) -> float:
    """The standard deviation (deg) in the worst direction of a tilt covariance (rad^2)."""
    return math.degrees(math.sqrt(float(np.max(np.linalg.eigvalsh(cov)))))


@dataclass(frozen=True, slots=True)
class VerticalFit:
    """The vertical measured from lines, as a small rotation of the predicted one.

    ``vertical = rotation_from_rotvec(basis @ delta) @ predicted``; ``basis`` (3, 2) spans the rotations that
    move the predicted vertical (those about it do not), ``covariance`` (2, 2, rad²) is ``delta``'s.
    """

    predicted: NDArray[np.float64]
    delta: NDArray[np.float64]
    basis: NDArray[np.float64]
    covariance: NDArray[np.float64]
    n_lines: int

    @property
    def vertical(self) -> NDArray[np.float64]:
        v: NDArray[np.float64] = rotation_from_rotvec(self.basis @ self.delta) @ self.predicted
        return v


def _basis(v: NDArray[np.float64]) -> NDArray[np.float64]:
    a = np.array([1.0, 0.0, 0.0]) if abs(v[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    e1 = np.cross(v, a)
    e1 /= np.linalg.norm(e1)
    return np.column_stack([e1, np.cross(v, e1)])


def vertical_fit(
    p0: NDArray[np.float64],
    p1: NDArray[np.float64],
    predicted: NDArray[np.float64],
    weights: NDArray[np.float64],
    *,
    gates_deg: tuple[float, ...] = (2.0,),
    min_lines: int = 12,
    floor_deg: float = 0.1,
    covariance_scale: float = 1.0,
) -> VerticalFit | None:
    """The common vanishing direction of the segments ``p0``-``p1`` (homogeneous normalised endpoints, (N, 3))
    near ``predicted`` (unit, camera frame), or None when fewer than ``min_lines`` support it or they cannot
    fix it. A segment supports a direction ``v`` when its interpretation plane (through the optical centre and
    the segment, normal ``n``) contains ``v``: ``n . v = 0``. Weighted least squares (``weights``: the squared
    length in pixels, as a segment's direction error goes with 1/length), over the segments within each of
    ``gates_deg`` in turn, then within 3 of the fit's own residual standard deviations; the covariance is the
    fit's (scaled by the residuals) plus ``floor_deg``² per axis for what the lines cannot show (slightly
    leaning structure, lens error).
    """
    v_pred = np.asarray(predicted, dtype=float)
    v_pred = v_pred / np.linalg.norm(v_pred)
    n = np.cross(p0, p1)
    norm = np.linalg.norm(n, axis=1)
    ok = norm > 1e-12
    n, w = n[ok] / norm[ok, None], np.asarray(weights, dtype=float)[ok]
    if n.shape[0] < min_lines:
        return None
    v = v_pred
    for gate in gates_deg:  # re-centre on the lines near the prediction, narrowing the gate
        B = _basis(v)
        J = np.cross(v, n) @ B  # d(n . v) / d(rotation of v), rotations in the basis
        r = n @ v
        inl = np.abs(r) < math.sin(math.radians(gate))
        if np.count_nonzero(inl) < min_lines:
            return None
        delta = _solve(J[inl], r[inl], w[inl])
        if delta is None:
            return None
        v = rotation_from_rotvec(B @ delta) @ v
    B = _basis(v_pred)
    J = np.cross(v_pred, n) @ B
    r = n @ v_pred
    delta = B.T @ _rotvec_between(v_pred, v)
    inl = np.abs(r + J @ delta) < math.sin(math.radians(gates_deg[-1]))
    if np.count_nonzero(inl) < min_lines:
        return None
    for _ in range(2):  # keep the lines within 3 residual standard deviations of the fit, refit
        res = r + J @ delta
        s = math.sqrt(float(np.sum(w[inl] * res[inl] ** 2) / np.sum(w[inl])))
        inl = np.abs(res) < max(3.0 * s, math.sin(math.radians(0.2)))
        if np.count_nonzero(inl) < min_lines:
            return None
        new = _solve(J[inl], r[inl], w[inl])
        if new is None:
            return None
        delta = new
    res = r + J @ delta
    H = (J[inl] * w[inl, None]).T @ J[inl]
    dof = max(1, int(np.count_nonzero(inl)) - 2)
    s2 = float(np.sum(w[inl] * res[inl] ** 2)) / dof  # variance of a unit-weight residual
    cov = covariance_scale * s2 * np.linalg.inv(H) + math.radians(floor_deg) ** 2 * np.eye(2)
    return VerticalFit(v_pred, delta, B, cov, int(np.count_nonzero(inl)))


def _solve(J: NDArray[np.float64], r: NDArray[np.float64], w: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """Weighted least squares ``J delta = -r``; None when the lines leave a direction undetermined."""
    H = (J * w[:, None]).T @ J
    if not np.all(np.isfinite(H)) or np.linalg.cond(H) > 1e8:
        return None
    out: NDArray[np.float64] = np.asarray(-np.linalg.solve(H, (J * w[:, None]).T @ r), dtype=np.float64)
    return out


def _looks_up_deg(v: NDArray[np.float64]) -> float:
    """How far (deg) the camera looks above level if ``v`` (a direction in the camera frame, either sign) is the
    vertical: negative when it looks down."""
    down = v if v[1] >= 0 else -v
    return math.degrees(math.atan2(-float(down[2]), float(down[1])))


def _rotvec_between(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """The smallest rotation vector taking unit ``a`` to unit ``b``."""
    axis = np.cross(a, b)
    s = float(np.linalg.norm(axis))
    if s < 1e-15:
        return np.zeros(3)
    out: NDArray[np.float64] = axis / s * math.atan2(s, float(a @ b))
    return out


class VerticalReference:
    """The world's vertical and the tilt uncertainty; :meth:`correct` at each keyframe.

    ``drift_deg_per_s``: how fast the odometry's tilt error may grow (random-walk standard deviation after one
    second), the filter's process noise. ``init_measurements``: measurements averaged (in the world frame) into
    the world's vertical before any correction. ``max_rate_deg_s``: keyframes turning faster than this are
    skipped (a rolling shutter leans vertical lines in proportion to the turn rate).
    """

    def __init__(
        self,
        *,
        drift_deg_per_s: float = 0.03,
        floor_deg: float = 0.1,
        min_lines: int = 12,
        init_measurements: int = 5,
        max_rate_deg_s: float = 30.0,
        max_correction_deg: float = 3.0,
        interval_s: float = 0.0,
        covariance_scale: float = 1.0,
        heading: HeadingReference | None = None,
    ) -> None:
        self.q = math.radians(drift_deg_per_s) ** 2
        self.floor_deg = floor_deg
        self.min_lines = min_lines
        self.init_measurements = init_measurements
        self.max_rate_deg_s = max_rate_deg_s
        self.max_correction_rad = math.radians(max_correction_deg)
        self.interval_s = interval_s
        self.covariance_scale = covariance_scale
        self._lsd = cv2.createLineSegmentDetector(cv2.LSD_REFINE_NONE, _LSD_SCALE)
        self.world_vertical: NDArray[np.float64] | None = None
        self._acc = np.zeros(3)
        self._n_init = 0
        self._P = self.q * np.eye(2)
        #: tilt doubt (deg) the odometry added in frames it flagged since the last correction (:meth:`add_doubt`)
        self._doubt_deg = 0.0
        self._doubt_t = -math.inf  # when doubt was last added
        self._last: tuple[float, NDArray[np.float64]] | None = None
        self.corrections = 0
        #: the yaw reference fed with the same line segments (see walkmon.rotation.heading), or None
        self.heading = heading

    def add_doubt(self, deg: float, t_s: float) -> None:
        """The odometry flagged a frame at ``t_s`` (a fast turn, a held orientation): its tilt may be off by up to
        ``deg`` more. Such errors are mostly biases that add up (a turn past a facade 1-3 m away: 2-9 deg of tilt
        in 30-60 frames on the simulator's unkind sessions), so the doubt adds linearly until a clear view takes
        it up, not as a random walk. Ignored before the first measurement of the world's vertical (nothing to
        correct towards); a turn while it is being learnt ends the learning with the measurements so far, which
        the turn's drift would otherwise enter."""
        if self._n_init == 0:
            return
        self._n_init = max(self._n_init, self.init_measurements)
        self._doubt_deg = min(self._doubt_deg + max(0.0, float(deg)), _MAX_DOUBT_DEG)
        self._doubt_t = float(t_s)

    def due(self, t_s: float) -> bool:
        """Whether to look at the lines now, between keyframes: the doubt has reached _DOUBT_CHECK_DEG, the last
        look was _DOUBT_CHECK_INTERVAL_S ago or more, and the last doubt came less than _DOUBT_LOOK_S ago (in
        steady walking a keyframe can hold for a second, and the drift a turn left would stay in the walk until
        then; where no clear view comes, at night or in fog, the looks stop and the doubt waits for keyframes)."""
        if self._doubt_deg < _DOUBT_CHECK_DEG or self._n_init < self.init_measurements:
            return False
        if float(t_s) - self._doubt_t > _DOUBT_LOOK_S:
            return False
        return self._last is None or float(t_s) - self._last[0] >= _DOUBT_CHECK_INTERVAL_S

    def _segments(
        self, small: NDArray[np.uint8], normalized: Callable[[NDArray[np.float32]], NDArray[np.float64]], scale_px: float
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] | None:
        found = self._lsd.detect(small)[0]
        if found is None:
            return None
        seg = found.reshape(-1, 4)
        length = np.hypot(seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1])
        seg = seg[length >= _MIN_LENGTH_FRACTION * small.shape[1]]
        if seg.shape[0] < self.min_lines:
            return None
        p0 = normalized(np.ascontiguousarray(seg[:, :2], dtype=np.float32).reshape(-1, 1, 2))
        p1 = normalized(np.ascontiguousarray(seg[:, 2:], dtype=np.float32).reshape(-1, 1, 2))
        w = (np.hypot(seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1]).astype(float) * scale_px) ** 2
        return p0, p1, w

    def correct(
        self,
        small: NDArray[np.uint8],
        orientation: NDArray[np.float64],
        t_s: float,
        normalized: Callable[[NDArray[np.float32]], NDArray[np.float64]],
        scale_px: float = 1.0,
        *,
        doubt_only: bool = False,
    ) -> NDArray[np.float64]:
        """``orientation`` (camera to start frame) corrected by the vertical lines of ``small`` (the tracking
        image; ``normalized`` maps its pixel positions (N, 1, 2) to homogeneous normalised coordinates,
        ``scale_px`` its pixel to the input's), or unchanged when they cannot say. ``doubt_only``: a look between
        keyframes (:meth:`due`), which corrects only by taking the doubt up from a clear view: the filter's
        ordinary small corrections, five times a second, shook the pitch that the step rhythm is read from."""
        if self._last is not None and float(t_s) - self._last[0] < self.interval_s:
            return orientation
        last, self._last = self._last, (float(t_s), orientation.copy())
        if last is not None:
            dt = max(float(t_s) - last[0], 1e-3)
            self._P = self._P + self.q * dt * np.eye(2)
            if self.heading is not None and self.world_vertical is not None:
                self.heading.predict(dt, _turned_about_deg(last[1], orientation, self.world_vertical))
            if rotation_angle_deg(last[1].T @ orientation) / dt > self.max_rate_deg_s:
                return orientation
        found = self._segments(small, normalized, scale_px)
        if found is None:
            return orientation
        p0, p1, w = found
        # the camera's y axis until the world's vertical has a first measurement (add_doubt keeps _n_init at 0 until
        # then, so the learning below covers that case too)
        predicted = np.array([0.0, 1.0, 0.0]) if self.world_vertical is None else orientation.T @ self.world_vertical
        if self._n_init < self.init_measurements:
            fit = vertical_fit(p0, p1, predicted, w, gates_deg=_INIT_GATES_DEG if self.world_vertical is None else (2.0,),
                               min_lines=self.min_lines, floor_deg=self.floor_deg, covariance_scale=self.covariance_scale)
            if fit is None or _looks_up_deg(fit.vertical) > _MAX_UP_TILT_DEG:
                return self._heading(p0, p1, w, orientation)
            # the world's vertical: an information-weighted mean of the first measurements, while the odometry's
            # drift is still negligible; no correction yet
            self._acc += (orientation @ fit.vertical) / float(np.trace(fit.covariance))
            self.world_vertical = self._acc / np.linalg.norm(self._acc)
            self._n_init += 1
            self._P = self.q * np.eye(2)
            # the heading reference learns its azimuth from the same first views (with the vertical known so far)
            return self._heading(p0, p1, w, orientation)
        P, fit = self._P, None
        if self._doubt_deg > 0:
            # After flagged frames the search reaches 3 standard deviations of the doubt, then narrows as at the
            # start; only a clear view of the vertical (many long lines that agree) takes the doubt up: a few noisy
            # lines (night, fog) pulled harder by it moved a good tilt by degrees (night seed 3: 0.1 -> 3.3 deg).
            P = self._P + math.radians(self._doubt_deg) ** 2 * np.eye(2)
            sigma_deg = _sd_deg(P)
            wide = min(_INIT_GATES_DEG[0], 3.0 * sigma_deg)
            gates = (wide, *(g for g in _INIT_GATES_DEG if g < wide)) if wide > 2.0 else (2.0,)
            fit = vertical_fit(p0, p1, predicted, w, gates_deg=gates, min_lines=self.min_lines,
                               floor_deg=self.floor_deg, covariance_scale=self.covariance_scale)
            clear = (fit is not None and _looks_up_deg(fit.vertical) <= _MAX_UP_TILT_DEG
                     and fit.n_lines >= _CLEAR_LINES_FACTOR * self.min_lines
                     and _sd_deg(fit.covariance) <= _CLEAR_SD_DEG)
            if clear and fit is not None and float(np.linalg.norm(fit.delta)) <= math.radians(wide):
                return self._update(fit, P, p0, p1, w, orientation, t_s, spend_doubt=True)
            P, fit = self._P, None  # not a clear view: as if nothing had been flagged
        if doubt_only:
            return orientation
        fit = vertical_fit(p0, p1, predicted, w, min_lines=self.min_lines, floor_deg=self.floor_deg,
                           covariance_scale=self.covariance_scale)
        if fit is None or float(np.linalg.norm(fit.delta)) > self.max_correction_rad:
            return self._heading(p0, p1, w, orientation)  # none, or not the vertical predicted: something else
        return self._update(fit, P, p0, p1, w, orientation, t_s, spend_doubt=False)

    def _update(self, fit: VerticalFit, P: NDArray[np.float64], p0: NDArray[np.float64], p1: NDArray[np.float64],
                w: NDArray[np.float64], orientation: NDArray[np.float64], t_s: float, *, spend_doubt: bool
                ) -> NDArray[np.float64]:
        """The filter's update with the tilt covariance ``P``, the heading's after it; the result is the
        orientation the next look's rate is measured from."""
        K = P @ np.linalg.inv(P + fit.covariance)
        step = K @ fit.delta
        self._P = (np.eye(2) - K) @ P
        if spend_doubt:
            self._doubt_deg = 0.0
        self.corrections += 1
        # the camera's vertical is where the lines put it: rotate the camera frame so that the measured vertical
        # (rotated from the predicted one by basis @ delta) maps to the world's, by the filter's share of it
        corrected = self._heading(p0, p1, w, orientation @ rotation_from_rotvec(-(fit.basis @ step)))
        self._last = (float(t_s), corrected.copy())  # a correction is no turn of the camera's
        return corrected

    def _heading(
        self, p0: NDArray[np.float64], p1: NDArray[np.float64], w: NDArray[np.float64], orientation: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """The heading correction, once the world's vertical is measured (it needs the vertical)."""
        if self.heading is None or self.world_vertical is None:
            return orientation
        return self.heading.correct(p0, p1, w, orientation, self.world_vertical)


def _turned_about_deg(a: NDArray[np.float64], b: NDArray[np.float64], vertical: NDArray[np.float64]) -> float:
    """How far (deg) the camera turned about the world's ``vertical`` from orientation ``a`` to ``b`` (camera to
    start frame): the change of the azimuth of its optical axis (or, looking along the vertical, of its x axis)."""
    u = vertical / np.linalg.norm(vertical)
    k = 2 if abs(float(a[:, 2] @ u)) < 0.9 else 0
    fa, fb = a[:, k] - (a[:, k] @ u) * u, b[:, k] - (b[:, k] @ u) * u
    return math.degrees(math.atan2(float(np.cross(fa, fb) @ u), float(fa @ fb)))
