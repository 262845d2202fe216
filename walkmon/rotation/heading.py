"""Drift-free heading for the fast method: horizontal lines of a Manhattan world as a yaw reference.

Why. Vertical lines pin pitch and roll (:mod:`walkmon.rotation.vertical`) but say nothing about the heading, and
keyframe-relative odometry lets yaw drift: ~0.03 deg/s on the simulator's walks (10 minutes: ~10-16 deg), and a
fast turn adds an error of 1-3 deg that stays. Built places are, to a good approximation, a *Manhattan world*
(Coughlan & Yuille 1999): most of their lines run along one of three orthogonal directions, the vertical and two
horizontal ones (a street and the streets crossing it; a corridor and its doors). The horizontal ones are a world
reference for the heading modulo 90 deg, measurable in any frame that sees a kerb, a ledge, a window sill or a
floor joint; removing rotational drift this way is how structured-environment odometry stays low-drift (Kim,
Coltin & Kim, "Low-drift visual odometry in structured environments by decoupling rotational and translational
motion", ICRA 2018).

How. At each keyframe the vertical reference has the frame's line segments (LSD) and the world's vertical. Each
segment that is not near-vertical, *if* it is horizontal in the world, runs along the one horizontal direction its
interpretation plane (through the optical centre and the segment, normal ``n``) contains: ``n x vertical``. Its
azimuth in the start frame, modulo 90 deg, is the same for every Manhattan line; other lines (diagonals, cracks,
people) scatter. The first measurements (the vertical reference's own first views) learn the world's Manhattan
azimuth (the weighted mode of the azimuths). Later ones measure the odometry's yaw error as the mean-shift of the
azimuth residuals near the filter's prediction, and a one-state Kalman filter estimates it: its uncertainty grows
with time (drift) and with the angle turned (a turn's error scales with it) and shrinks with each measurement.
The estimate is corrected at most 0.2 deg per keyframe (no frame jumps) and at most as fast as the odometry can
drift (``max_drift_rate_deg_s``, 0.05 deg/s, and 1 % of the angle turned): the rest waits.

That budget is what bounds the harm where the world is not Manhattan. Along a street that curves, its lines turn
with the walker and the reference would take the curve for drift and steer the heading along it; held to the
budget, it soon estimates more error than the odometry can have made (``give_up_deg`` beyond the budget), drops
the azimuth and learns the lines anew. Over a curve the heading can therefore lose up to the budget, 0.05 deg/s,
on top of the odometry's own drift (a drawn street curving at 0.3 deg/s for 40 s: 1.2 deg; without the budget
7.3 deg). Where there are no such lines (a park, fog, night, a real drone clip over a coast) nothing is corrected.

Limits: a fast turn may leave more yaw error than 1 % of the turn plus ``give_up_deg`` (the hard-scene turns
leave 1-3 deg); the reference then restarts instead of correcting it (``test_heading.py``). The reference is
modulo 90 deg (a turn onto a street at 45 deg is not corrected: its lines are not the
learnt ones, and a long oblique street is learnt anew); the line measurement has a view-dependent bias of a few
tenths of a degree, which the azimuth learnt from the first views carries into every later correction; those
views are not checked to agree, and the basis is fixed at the first call, while the vertical is still being
learnt. Segments at the camera's height (a horizontal interpretation plane) pass the near-vertical test but
give noisy azimuths; they are outvoted, not excluded.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from walkmon.rotation.geometry import rotation_from_rotvec

__all__ = ["HeadingReference", "manhattan_azimuths"]

#: Segments whose interpretation plane is this close (deg) to containing the vertical are vertical lines (or lines
#: at the camera's height, whose horizontal direction is undefined): not used.
_MIN_PLANE_TILT_DEG = 12.0


def manhattan_azimuths(
    p0: NDArray[np.float64], p1: NDArray[np.float64], orientation: NDArray[np.float64],
    vertical: NDArray[np.float64], e1: NDArray[np.float64], e2: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Azimuth (rad, in the start frame's horizontal basis ``e1``, ``e2``, modulo pi/2 in [-pi/4, pi/4)) of the
    horizontal direction each segment ``p0``-``p1`` (homogeneous normalised endpoints, camera frame) would run
    along if it were horizontal, and which segments can say (not near-vertical). ``vertical``: the world's
    vertical in the start frame; ``orientation``: camera to start frame."""
    n = np.cross(p0, p1)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-15)
    v_cam = orientation.T @ vertical
    usable = np.abs(n @ v_cam) > math.sin(math.radians(_MIN_PLANE_TILT_DEG))
    d = np.cross(n, v_cam) @ orientation.T  # the horizontal direction in each plane, start frame
    az = np.arctan2(d @ e2, d @ e1)
    return _wrap(az), usable


def _wrap(a: NDArray[np.float64] | float) -> NDArray[np.float64]:
    """Angles (rad) modulo pi/2 into [-pi/4, pi/4)."""
    q = 0.5 * math.pi
    return np.asarray((np.asarray(a) + 0.25 * math.pi) % q - 0.25 * math.pi, dtype=float)


def _weighted_mode(r: NDArray[np.float64], w: NDArray[np.float64], half_width: float) -> tuple[float, float]:
    """(mode, weight share within ``half_width`` of it) of angles ``r`` (rad, modulo pi/2) by a kernel vote."""
    grid = np.radians(np.arange(-45.0, 45.0, 0.25))
    dist = np.abs(_wrap(grid[:, None] - r[None, :]))
    score = (w[None, :] * np.clip(1.0 - dist / half_width, 0.0, None)).sum(axis=1)
    k = int(np.argmax(score))
    share = float(w[np.abs(_wrap(r - grid[k])) < half_width].sum() / max(float(w.sum()), 1e-15))
    return float(grid[k]), share


class HeadingReference:
    """The world's Manhattan azimuth and the heading uncertainty; :meth:`correct` at each keyframe.

    ``drift_deg_per_s``: random-walk growth of the odometry's yaw error (deg after one second), the filter's
    process noise; ``max_drift_rate_deg_s``: the fastest the odometry's heading is assumed to drift, which bounds
    how fast the reference may correct it (a prior, not fitted: the simulator's walks drift ~0.03 deg/s);
    ``turn_error_fraction``: yaw error per angle turned (a fast turn's error scales with the turn), added to the
    uncertainty and to what may be corrected; ``give_up_deg``: an estimated error this far beyond what may be
    corrected means the lines are not the learnt Manhattan directions: the azimuth is learnt anew;
    ``init_measurements``: measurements whose azimuths are pooled into the world's before any correction;
    ``min_lines`` / ``min_share``: a measurement needs this many lines within ``inlier_deg`` of the mode and
    that share of the usable lines' weight; ``gate_deg``: how far (at least) from the learnt azimuth the mode is
    searched, about the filter's prediction (widened to 3 sigma of the yaw uncertainty, at most ``max_gate_deg``); ``floor_deg``: the
    measurement's error floor (lines not quite along the street, lens error); ``max_step_deg``: the largest
    correction applied at one keyframe (a larger error is corrected over several, so that no frame jumps).
    """

    def __init__(
        self,
        *,
        drift_deg_per_s: float = 0.03,
        max_drift_rate_deg_s: float = 0.05,
        turn_error_fraction: float = 0.01,
        init_measurements: int = 5,
        min_lines: int = 12,
        min_share: float = 0.2,
        inlier_deg: float = 1.5,
        gate_deg: float = 2.0,
        max_gate_deg: float = 10.0,
        floor_deg: float = 0.15,
        max_step_deg: float = 0.2,
        give_up_deg: float = 0.5,
    ) -> None:
        self.q = math.radians(drift_deg_per_s) ** 2
        self.max_rate = math.radians(max_drift_rate_deg_s)
        self.turn_error_fraction = turn_error_fraction
        self.init_measurements = init_measurements
        self.min_lines = min_lines
        self.min_share = min_share
        self.inlier = math.radians(inlier_deg)
        self.gate = math.radians(gate_deg)
        self.max_gate = math.radians(max_gate_deg)
        self.floor = math.radians(floor_deg)
        self.max_step = math.radians(max_step_deg)
        self.give_up = math.radians(give_up_deg)
        self.azimuth: float | None = None  # the world's Manhattan azimuth (rad, modulo pi/2), once learnt
        self._init: list[tuple[float, float]] = []
        self._basis: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] | None = None
        self._e = self._P = self._budget = 0.0
        self._reset_filter()
        #: the last measurement of the yaw error and its standard deviation (deg), for diagnostics
        self.last_measurement_deg: tuple[float, float] | None = None
        self.corrections = 0
        self.restarts = 0  # times the lines disagreed with the drift the odometry can have and were learnt anew

    def _reset_filter(self) -> None:
        self._e = 0.0  # the filter's estimate of the current orientation's yaw error not yet corrected (rad)
        self._P = self.q  # and its variance
        self._budget = 0.0  # how much (rad) may still be corrected: what the odometry can have drifted since

    def predict(self, dt_s: float, turned_deg: float) -> None:
        """Grow the yaw uncertainty over ``dt_s`` seconds in which the camera turned ``turned_deg`` (a turn's
        error scales with it), and what may be corrected: at most the largest drift the odometry is assumed to
        have (``max_drift_rate_deg_s``, plus the turn's share)."""
        dt = max(dt_s, 0.0)
        turn = self.turn_error_fraction * math.radians(abs(turned_deg))
        self._P += self.q * dt + turn**2
        self._budget = min(self._budget + self.max_rate * dt + turn, math.radians(10.0))

    def correct(
        self, p0: NDArray[np.float64], p1: NDArray[np.float64], weights: NDArray[np.float64],
        orientation: NDArray[np.float64], vertical: NDArray[np.float64],
    ) -> NDArray[np.float64]:
        """``orientation`` (camera to start frame) with its heading corrected by the segments' Manhattan lines
        (``vertical``: the world's vertical in the start frame), or unchanged when they cannot say."""
        if self._basis is None:
            u = vertical / np.linalg.norm(vertical)
            a = np.array([0.0, 0.0, 1.0]) if abs(u[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
            e1 = a - (a @ u) * u
            e1 /= np.linalg.norm(e1)
            self._basis = (u, e1, np.cross(u, e1))
        u, e1, e2 = self._basis
        az, usable = manhattan_azimuths(p0, p1, orientation, u, e1, e2)
        # weights: the segments' lengths (the caller's are squared lengths)
        az, w = az[usable], np.sqrt(np.asarray(weights, dtype=float)[usable])
        if az.size < self.min_lines:
            return orientation
        if self.azimuth is None:
            mode, share = _weighted_mode(az, w, self.inlier)
            if share >= self.min_share and np.count_nonzero(np.abs(_wrap(az - mode)) < self.inlier) >= self.min_lines:
                self._init.append((mode, share))
            if len(self._init) >= self.init_measurements:
                m = np.array([v for v, _ in self._init])
                s = np.array([c for _, c in self._init])
                # circular mean modulo pi/2: on the circle of 4 x the angle
                self.azimuth = 0.25 * math.atan2(float(np.sum(s * np.sin(4 * m))), float(np.sum(s * np.cos(4 * m))))
                self._reset_filter()
            return orientation
        r = _wrap(az - self.azimuth)  # each line's yaw error, if it is a Manhattan line
        expected = self._e  # the filter's prediction of it
        gate = min(self.max_gate, max(self.gate, 3.0 * math.sqrt(self._P + self.floor**2)))
        near = np.abs(_wrap(r - expected)) < gate
        r = expected + _wrap(r - expected)
        if np.count_nonzero(near) < self.min_lines:
            return orientation
        mode, _ = _weighted_mode(r[near], w[near], self.inlier)
        inl = np.abs(r - mode) < self.inlier
        if np.count_nonzero(inl) < self.min_lines or float(w[inl].sum()) < self.min_share * float(w.sum()):
            return orientation
        err, sd = mode, self.inlier
        for _ in range(10):  # the weighted mean of the lines near it, re-centred until it settles (a mean-shift)
            inl = np.abs(r - err) < max(2.5 * sd, self.inlier)
            if np.count_nonzero(inl) < self.min_lines:
                return orientation
            new = float(np.sum(w[inl] * r[inl]) / np.sum(w[inl]))
            sd = math.sqrt(float(np.sum(w[inl] * (r[inl] - new) ** 2) / np.sum(w[inl])))
            done = abs(new - err) < 1e-5
            err = new
            if done:
                break
        # lines' errors are not independent enough for length² weights (a few long ledges would dominate): the
        # mean's variance from the spread over the effective number of lines, plus the floor
        n_eff = float(np.sum(w[inl])) ** 2 / float(np.sum(w[inl] ** 2))
        R = sd**2 / max(n_eff - 1.0, 1.0) + self.floor**2
        self.last_measurement_deg = (math.degrees(err), math.degrees(math.sqrt(R)))
        K = self._P / (self._P + R)
        self._e += K * (err - self._e)
        self._P *= 1.0 - K
        if abs(self._e) > self._budget + self.give_up:
            # more error than the odometry can have made: these lines are not the Manhattan directions learnt
            # (a street that curves or runs obliquely); start again from the lines seen from now on
            self.azimuth, self._init = None, []
            self._reset_filter()
            self.restarts += 1
            return orientation
        # Applied now, at most max_step (no frame jumps) and at most the budget: what the odometry can have drifted
        # since the last correction at the largest drift rate assumed. The rest waits for the next keyframes. The
        # budget is what keeps a street that curves (its lines' azimuth turning with the walker faster than any
        # drift) from dragging the heading along: the estimate soon outgrows the budget and the reference
        # restarts (above), having moved the heading by no more than that drift.
        step = float(np.clip(self._e, -min(self.max_step, self._budget), min(self.max_step, self._budget)))
        self._e -= step
        self._budget -= abs(step)
        self.corrections += 1
        # the lines' azimuths read `err` too far round the vertical: turn the camera frame back by the step
        corrected: NDArray[np.float64] = rotation_from_rotvec(-step * u) @ orientation
        return corrected
