"""A whole recording's gait analysis: activity timeline, walking bouts, posture segments, summary.

:func:`analyze_session` is what ``walkmon analyze`` and ``walkmon indicators`` run in walkmon mode:

1. **Activity** (:mod:`walkmon.gait.activity`): standing / walking / turning / unknown, steps and walking
   bouts, from the IMU when there is one (vertical acceleration, gyro heading rate), else from the angles
   (pitch rhythm, yaw rate).
2. **Upright reference**, in this order: the first standing phase (>= ``min_standing_s``) anywhere in the
   recording, gravity-referenced when an IMU gave absolute pitch/roll; without a standing phase, gravity itself
   (IMU: the sensor is then assumed to sit level on the trunk); else the first stride's median pose
   (``first_pose_s``). ``upright_reference``
   in the output says which. **Gravity's direction** comes from the IMU, or for video from the axes of the
   wearer's turns (:func:`vertical_from_turns`: a chest camera is rarely level on the trunk, and its tilt reads
   as posture after a turn otherwise); with it the angles are re-expressed in a level frame riding with the
   camera (:func:`level_frame_angles`), so that pitch, yaw and roll are the trunk's. Heading-free inclinations
   (:func:`heading_free_angles`) measure the tilt from the upright pose against that direction.
3. **Posture segments**: each bout minus its turns (and ``turn_margin_s`` around them) is split at change
   points of the slow (2 s mean) pitch or roll: binary segmentation, a split kept when the two sides differ by
   >= ``change_pitch_deg`` / ``change_roll_deg`` and both last >= ``min_segment_s``.
4. **Indicators per segment**: the paper's swing and inclination per axis (:func:`walkmon.indicators.analyze_gait`
   on the segment, no standing search, inclinations from the upright reference), cadence from the detected
   steps (the spectral peak kept as ``spectral_cadence_spm``), alternating-step asymmetry from the detected steps
   (IMU) or the pitch cycles (video), then :func:`walkmon.posture.classify` (the one classifier).
5. **Bouts** aggregate their segments; the **summary** is the duration-weighted aggregate over walking bouts
   only: cadence, indicators, time per posture label and the dominant label with its share.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from walkmon.consts import AXES, angle_between_deg, gravity_angles_deg_from_gravity
from walkmon.gait.activity import (
    DEFAULT_ACTIVITY_SETTINGS,
    ActivitySettings,
    Bout,
    Segmentation,
    TrunkSignals,
    cadence_from_steps,
    segment,
    signals_from_angles,
    signals_from_imu,
)
from walkmon.gait.indicators import (
    DEFAULT_INDICATOR_SETTINGS,
    AxisIndicators,
    Classification,
    Indicators,
    IndicatorSettings,
    IndicatorStatus,
    analyze_gait,
)
from walkmon.gait.posture import ROTATION_STEP_TIMES
from walkmon.sampling import sampling_rate_hz

__all__ = [
    "DEFAULT_SESSION_SETTINGS",
    "ImuInput",
    "SessionAnalysis",
    "SessionSettings",
    "analyze_session",
    "without_posture",
    "camera_level_down",
    "change_limits",
    "change_points",
    "heading_free_angles",
    "level_basis",
    "level_frame_angles",
    "span_indicators",
    "timeline_rows",
    "VERTICAL_AGREE_DEG",
    "turn_axis",
    "vertical_from_axes",
    "vertical_from_turns",
    "vertical_with_level",
    "Vertical",
    "label_within_uncertainty",
    "turn_axis_doubt_deg",
]


@dataclass(frozen=True, slots=True)
class SessionSettings:
    min_standing_s: float = 1.5
    turn_margin_s: float = 0.5
    min_segment_s: float = 4.0
    min_piece_s: float = 3.0
    change_pitch_deg: float = 4.0
    change_roll_deg: float = 3.0
    change_swing_ratio: float = 1.6
    smooth_s: float = 2.0
    still_tilt_deg: float = 20.0
    max_drift_deg: float = 8.0
    transition_s: float = 1.5
    pause_factor: float = 1.3
    turn_reference_deg: float = 4.0
    min_anchor_s: float = 0.5  # a still phase this long re-references the video's drift (as a pause in a bout)
    #: without any stance, the median pose over this many seconds from the start is taken for upright (a stride)
    first_pose_s: float = 1.2
    #: ... when its pitch and roll each span at most this (deg) and nothing in it is handled: a stride's sway (a
    #: dragged foot's up to 13 on the simulator), not a bend (a pick-up: 28 and more) or a handled camera
    first_pose_max_range_deg: float = 15.0
    #: How far a body-worn sensor's tilt on the trunk may be from level when nothing measured it (no standing
    #: phase, no baseline, no live calibration): gravity is then the reference with the sensor assumed level, and
    #: a label only given when it holds for any mounting tilt within this. Set a priori: a neck-hung camera hangs
    #: at whatever angle its strap gives, and the lower-back sensors of the shared Mobilise-D walks read 9-18 deg
    #: of pitch from gravity while their wearers walk upright (the bend threshold is -8 deg).
    mount_tilt_deg: float = 20.0
    #: Video: gravity's direction from the wearer's turns (:func:`vertical_from_turns`); False assumes the camera
    #: level on the trunk (the analysis before it existed)
    turn_vertical: bool = True


DEFAULT_SESSION_SETTINGS = SessionSettings()


@dataclass(frozen=True, slots=True)
class ImuInput:
    """Raw IMU samples on the angles' time base: ``t_s`` (N,), ``acc_m_s2`` (N,3), ``gyro_rad_s`` (N,3) or None."""

    t_s: NDArray[np.float64]
    acc_m_s2: NDArray[np.float64]
    gyro_rad_s: NDArray[np.float64] | None = None
    #: the accelerometer as the attitude filter saw it (calibrated), when its axes are the angles' (an IMU alone:
    #: its axes are taken as the camera's); None otherwise (a fused IMU in its own axes). The upright stance's
    #: gravity is measured from it (:func:`_stance_gravity_deg`)
    acc_camera_m_s2: NDArray[np.float64] | None = None
    #: the accelerometer calibration ``acc_camera_m_s2`` was corrected with (None: the raw samples), kept so that a
    #: saved analysis' report (:meth:`walkmon.api.Analysis.save`) rebuilds the same samples
    accelerometer_calibration: Any = None


@dataclass(frozen=True, slots=True)
class SessionAnalysis:
    indicators: Indicators  # top level = summary over walking bouts; .session holds bouts, segments, ...
    segmentation: Segmentation
    reference_deg: NDArray[np.float64]
    reference_source: str
    segments: tuple[dict[str, Any], ...]
    #: timeline.csv rows ``(t, activity, label, pitch, roll, ref_uncertainty_deg)`` (:func:`timeline_rows`)
    timeline: tuple[tuple[float, str, str, float, float, float], ...]


def _num(v: float, nd: int = 4) -> float | None:
    v = float(v)
    return round(v, nd) if math.isfinite(v) else None


def heading_free_angles(
    t_s: ArrayLike, angles_deg: NDArray[np.float64], upright_deg: ArrayLike, vertical: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """(pitch, yaw, roll) whose slow part (posture) is the trunk's tilt relative to the upright pose.

    Start-relative Euler angles mix pitch and roll once the wearer has turned (after a 180 deg turn a forward
    lean reads backward in them). The tilt is taken from the direction gravity has at each frame,
    ``M(t)^T v`` (``M`` the start-relative orientation, ``v`` gravity's direction in the start frame), against
    the direction it had in the upright pose, ``g_u = M(upright)^T v``: the angles of ``M(t)^T v`` in a basis of
    the camera frame that is level at the upright pose (``g_u`` down, the camera's x made horizontal, forward
    their cross product). It does not depend on heading. ``vertical``: ``v`` (down, in the start frame's
    coordinates), e.g. :func:`vertical_from_turns`; None assumes the camera level on the trunk at the upright pose
    (``v = M(upright) e_y``), which a chest camera rarely is: tilted by ``d`` on the trunk, a wearer who turns
    180 deg then reads up to ``2 d`` of tilt that is not there. Only the slow difference (2.5 s mean) between tilt
    and Euler angles is applied, so the gait oscillation (the paper's swings, defined on the camera's Euler angles)
    is kept as measured. ``upright_deg``: the start-relative angles of the upright pose.
    """
    from walkmon.consts import gravity_angles_deg_from_gravity, rotation_from_angles_deg

    a = np.asarray(angles_deg, dtype=float)
    u = np.asarray(upright_deg, dtype=float).reshape(3)
    m = rotation_from_angles_deg(a[:, 0], a[:, 1], a[:, 2])
    ms = rotation_from_angles_deg(u[0], u[1], u[2])
    v = ms @ np.array([0.0, 1.0, 0.0]) if vertical is None else np.asarray(vertical, dtype=float).reshape(3)
    v = v / np.linalg.norm(v)
    basis = level_basis(ms.T @ v)  # columns: level x, down, level forward (camera frame at the upright pose)
    g = np.einsum("nji,j->ni", m, v) @ basis
    tilt = gravity_angles_deg_from_gravity(g)
    return slow_offset(t_s, a, np.column_stack([tilt[:, 0], a[:, 1], tilt[:, 1]]))


def camera_level_down(upright_deg: ArrayLike) -> NDArray[np.float64]:
    """Gravity's direction in the start frame if the camera were level at the upright pose (start-relative
    angles ``upright_deg``): that pose's y axis, the assumption when nothing measured gravity."""
    from walkmon.consts import rotation_from_angles_deg

    u = np.asarray(upright_deg, dtype=float).reshape(3)
    return rotation_from_angles_deg(u[0], u[1], u[2]) @ np.array([0.0, 1.0, 0.0])


#: Turns' axes that agree within this make gravity's direction from turns trusted (:class:`Vertical`), degrees:
#: the same-posture accuracy of one turn on the simulator is 0.33 deg (median), 1.9 deg (worst).
VERTICAL_AGREE_DEG = 3.0


@dataclass(frozen=True, slots=True)
class Vertical:
    """Gravity's direction (down) in the start frame found from the axes of the wearer's turns: ``down`` (3,),
    the ``n_turns`` used, their total angle in degrees, ``spread_deg`` (the largest angle between two turns'
    axes; 0 for one turn) and ``verified``: two or more turns agree within :data:`VERTICAL_AGREE_DEG`. A camera's
    tilt on the trunk is the same in every turn; a change of posture across a turn, or the video's drift in it,
    is that turn's own and tilts its axis by about half of it. One turn alone cannot tell them apart."""

    down: NDArray[np.float64]
    n_turns: int
    total_turn_deg: float
    spread_deg: float
    verified: bool
    #: turns left out because their axes disagreed with the others' (a change of posture or drift in them)
    n_outliers: int = 0
    #: the kept turns' (axis, angle in degrees)
    axes: tuple[tuple[NDArray[np.float64], float], ...] = ()
    #: True when the camera-level assumption was one of the agreeing votes (:func:`vertical_with_level`)
    with_level: bool = False

    def camera_tilt_deg(self, upright_deg: ArrayLike) -> NDArray[np.float64]:
        """The camera's (pitch, roll) from level at the upright pose (start-relative angles ``upright_deg``)."""
        from walkmon.consts import gravity_angles_deg_from_gravity, rotation_from_angles_deg

        u = np.asarray(upright_deg, dtype=float).reshape(3)
        return gravity_angles_deg_from_gravity(rotation_from_angles_deg(u[0], u[1], u[2]).T @ self.down)


def turn_axis(
    t_s: ArrayLike, angles_deg: ArrayLike, start_s: float, end_s: float, *, margin_s: float = 0.3,
    window_s: float = 1.2,
) -> tuple[NDArray[np.float64], float] | None:
    """``(axis, angle in degrees)`` of one turn in the start frame of start-relative angles: the rotation from the
    camera's mean pose over ``window_s`` ending ``margin_s`` before ``start_s`` to its mean pose over ``window_s``
    starting ``margin_s`` after ``end_s`` (``R_after R_before^T``; the means over about a stride average the
    gait's sway out), its axis signed to point down (+y of the start frame). Exact when the trunk's posture is
    the same on both sides; a posture change across the turn tilts the axis by about half of it (the turn's own
    frame-to-frame rotation, tried as a cross-check, was less accurate on the simulator's walks without one: 4-6
    deg worst against 1.9). None when either window holds less than half its length of samples."""
    from walkmon.consts import rotation_from_angles_deg

    t = np.asarray(t_s, dtype=float)
    a = np.asarray(angles_deg, dtype=float)
    before = (t >= start_s - margin_s - window_s) & (t < start_s - margin_s)
    after = (t > end_s + margin_s) & (t <= end_s + margin_s + window_s)
    if before.sum() < 3 or after.sum() < 3 or np.ptp(t[before]) < 0.5 * window_s or np.ptp(t[after]) < 0.5 * window_s:
        return None

    def mean_pose(m: NDArray[np.bool_]) -> NDArray[np.float64]:
        u, _, vt = np.linalg.svd(rotation_from_angles_deg(a[m, 0], a[m, 1], a[m, 2]).mean(axis=0))
        if np.linalg.det(u @ vt) < 0:
            u[:, -1] *= -1
        return u @ vt

    q = mean_pose(after) @ mean_pose(before).T
    angle = math.acos(min(1.0, max(-1.0, (float(np.trace(q)) - 1.0) / 2.0)))
    w, vecs = np.linalg.eig(q)
    ax = np.real(vecs[:, int(np.argmin(np.abs(w - 1.0)))])
    ax /= np.linalg.norm(ax)
    return (ax if ax[1] >= 0 else -ax), math.degrees(angle)


def turn_axis_doubt_deg(
    t_s: ArrayLike, angles_deg: ArrayLike, start_s: float, end_s: float, axis: ArrayLike,
) -> float:
    """How far the turn's :func:`turn_axis` (``axis``, from the poses either side) is from the mean axis of its
    own frame-to-frame rotation over ``[start_s, end_s]``, in degrees: a sign of how well the turn gives gravity.

    Both are gravity when the trunk turns about the vertical in one posture. A posture change across the turn
    tilts the first by about half of it and leaves the second (the turn itself) nearer the vertical; the video's
    drift past a facade close by moves them apart too. On the simulator's unkind sessions (video angles, seeds 1-5,
    50 turns of 75-190 deg): the 4 turns with a posture change of 15-19 deg across them read 3.8-8.1 deg; the 40
    with less than 3 deg of change 0.3-16.5 (median 1.6); the 10 whose axis was more than 5 deg off the true
    vertical 3.8-16.5 but one (0.5); the 28 within 2 deg of it, median 1.4 (at most 5.2). A doubt, not a bound:
    the mean rotation axis alone was the less accurate vertical (:func:`turn_axis`). NaN when the turn has fewer
    than 3 samples."""
    from walkmon.consts import rotation_from_angles_deg

    t = np.asarray(t_s, dtype=float)
    a = np.asarray(angles_deg, dtype=float)
    m = (t >= start_s) & (t <= end_s)
    if m.sum() < 3:
        return math.nan
    r = rotation_from_angles_deg(a[m, 0], a[m, 1], a[m, 2])
    q = r[1:] @ np.swapaxes(r[:-1], -1, -2)  # each frame's rotation from the previous one, in the start frame
    w = 0.5 * np.stack([q[:, 2, 1] - q[:, 1, 2], q[:, 0, 2] - q[:, 2, 0], q[:, 1, 0] - q[:, 0, 1]], axis=-1).sum(axis=0)
    ax = np.asarray(axis, dtype=float).reshape(3)
    if not float(np.linalg.norm(w)) > 0 or not float(np.linalg.norm(ax)) > 0:
        return math.nan
    return math.degrees(math.acos(min(1.0, abs(float(np.dot(w, ax))) / float(np.linalg.norm(w) * np.linalg.norm(ax)))))


def vertical_from_axes(
    axes: list[tuple[NDArray[np.float64], float]], agree_deg: float = VERTICAL_AGREE_DEG
) -> Vertical | None:
    """:class:`Vertical` from turns' ``(axis, angle_deg)`` (:func:`turn_axis`): the axes summed weighted by
    ``sin(angle / 2)``; while three or more disagree by more than ``agree_deg``, the one farthest from their
    mean is left out (a posture change or the video's drift in that turn: the mount is the same in every turn);
    ``verified`` when two or more are left that agree. None without an axis."""
    if not axes:
        return None

    def mean(items: list[tuple[NDArray[np.float64], float]]) -> NDArray[np.float64]:
        v = np.sum([math.sin(math.radians(0.5 * ang)) * ax for ax, ang in items], axis=0)
        return v / np.linalg.norm(v)

    def spread(items: list[tuple[NDArray[np.float64], float]]) -> float:
        return max((angle_between_deg(p, q) for i, (p, _) in enumerate(items) for q, _ in items[i + 1:]), default=0.0)

    kept = list(axes)
    while len(kept) > 2 and spread(kept) > agree_deg:
        down = mean(kept)
        kept.pop(int(np.argmax([float(np.dot(ax, -down)) for ax, _ in kept])))  # the farthest from the mean
    return Vertical(mean(kept), len(kept), float(sum(ang for _, ang in kept)), spread(kept),
                    len(kept) >= 2 and spread(kept) <= agree_deg, len(axes) - len(kept), tuple(kept))


def vertical_with_level(
    vert: Vertical | None, level_down: ArrayLike, agree_deg: float = VERTICAL_AGREE_DEG
) -> Vertical | None:
    """An unverified :class:`Vertical` checked against the camera-level assumption (``level_down``, gravity's
    direction if the camera were level at the upright pose): the turns whose axes agree with it within
    ``agree_deg`` are kept and verified by it (two votes for a level camera: those turns and the assumption; the
    direction between them, their disagreement its spread), the others left out (a posture change or drift in
    them). When no turn agrees, the unverified ``vert`` stands
    (a tilted camera or a changed posture: one cannot tell). A verified one is returned as it is."""
    if vert is None or vert.verified or not vert.axes:
        return vert
    lv = np.asarray(level_down, dtype=float).reshape(3)
    lv = lv / np.linalg.norm(lv)
    near = [(ax, ang) for ax, ang in vert.axes if angle_between_deg(ax, lv) <= agree_deg]
    if not near:
        return vert
    v = vertical_from_axes(near, agree_deg)
    assert v is not None  # near is not empty
    down = v.down + lv  # between the agreeing turns and the assumption; their disagreement is the uncertainty
    spread = max(v.spread_deg, angle_between_deg(v.down, lv))
    return replace(v, down=down / np.linalg.norm(down), spread_deg=spread, verified=True,
                   n_outliers=vert.n_outliers + vert.n_turns - len(near), with_level=True)


def vertical_from_turns(
    t_s: ArrayLike, angles_deg: ArrayLike, turns: Any, *, min_turn_deg: float = 60.0, margin_s: float = 0.3,
    window_s: float = 1.2,
) -> Vertical | None:
    """Gravity's direction in the start frame from the turns of a camera's start-relative angles, or None.

    A wearer turns about the vertical: the rotation from the camera's mean pose just before a turn to its mean
    pose just after (:func:`turn_axis`) has gravity as its axis whatever the camera's tilt on the trunk, when the
    trunk's posture is the same on both sides. The means are over ``window_s`` (about a stride, so that the
    gait's sway averages out), ``margin_s`` outside the turn. Turns of at least ``min_turn_deg`` are used (a
    small rotation's axis is poorly defined), their axes summed weighted by ``sin(turn / 2)``
    (:func:`vertical_from_axes`). None without such a turn. On simulated walks (4 walk types, 8 seeds, mounts
    0-20 deg; the true angles) the direction was within 0.33 deg of the truth (median; 90th percentile 0.64,
    worst 1.9 deg); with a change of posture across a turn (normal to bend, 15 deg) up to 10 deg off, which only
    a second turn can reveal (``verified``). An error of the direction shows after a turn of ``phi`` as about
    ``2 sin(phi / 2)`` times itself in the tilt."""
    axes = []
    for u in turns:
        if abs(float(u.angle_deg)) < min_turn_deg:
            continue
        r = turn_axis(t_s, angles_deg, u.start_s, u.end_s, margin_s=margin_s, window_s=window_s)
        if r is not None and r[1] >= 0.5 * min_turn_deg:
            axes.append(r)
    return vertical_from_axes(axes)


def slow_offset(t_s: ArrayLike, raw: NDArray[np.float64], target: NDArray[np.float64], span_s: float = 2.5) -> NDArray:
    """``raw`` plus the slow (``span_s`` centred mean) part of ``target - raw``."""
    t = np.asarray(t_s, dtype=float)
    d = np.asarray(target, dtype=float) - raw
    if t.size < 3:
        return raw + d
    fs = sampling_rate_hz(t)
    w = max(1, int(round(span_s * fs)))
    kern = np.ones(w) / w
    sm = np.column_stack([np.convolve(np.pad(d[:, k], (w // 2, w - 1 - w // 2), mode="edge"), kern, "valid")
                          for k in range(d.shape[1])])
    return raw + sm


def _upright(
    t: NDArray, a: NDArray, seg: Segmentation, abs_deg: NDArray | None, s: SessionSettings,
    tilt: NDArray | None = None,
) -> tuple[NDArray[np.float64], str, tuple[float, float] | None]:
    """Upright (pitch, yaw, roll) reference in the angles' frame, how it was found, and the standing phase.

    A still phase is taken for standing only when its tilt is within ``still_tilt_deg`` of the walking
    posture (the median over the bouts; gravity pitch/roll with an IMU, else ``tilt``, the heading-free tilt
    from the start when the wearer turns, else the start-relative angles): a person sitting on a bench, lying or
    bent down is still too, and taking that for upright would read every walk as tilted by the seat's angle."""
    act = np.asarray(seg.activity)
    hop = float(seg.timeline_t_s[1] - seg.timeline_t_s[0]) if len(seg.timeline_t_s) > 1 else 0.1
    runs = _runs(act == "standing")
    has_abs = abs_deg is not None and np.isfinite(abs_deg).all(axis=1).mean() > 0.5
    if has_abs and abs_deg is not None:
        tilt = abs_deg[:, :2]
    elif tilt is None:
        tilt = a[:, [0, 2]]
    in_bouts = np.zeros(t.shape, bool)
    for b in seg.bouts:
        in_bouts |= (t >= b.start_s) & (t <= b.end_s)
    ok = in_bouts & np.isfinite(tilt).all(axis=1)
    walking_tilt = np.median(tilt[ok], axis=0) if ok.sum() >= 3 else None
    # standing phases (>= min_standing_s) first; without one, with an IMU, a still pause (>= min_anchor_s, outside
    # turns: the still part of a 1.5-2.5 s pause inside a bout lasts 0.5-1.5 s) is the wearer's upright stance
    # too, and measures the sensor's tilt on the trunk. (Video keeps its first stride there, and its later pauses
    # re-reference drift from it: taking the first pause instead left the stretch before it uncertain and cost one
    # change point on the unkind sessions, normal seed 5.)
    pauses: list[tuple[int, int, float, str]] = [(i0, i1, s.min_standing_s, "standing phase") for i0, i1 in runs]
    if has_abs and len(seg.still) == len(seg.timeline_t_s):
        pauses += [(i0, i1, s.min_anchor_s, "still pause")
                   for i0, i1 in _runs(np.asarray(seg.still, dtype=bool) & (act != "turning"))]
    for i0, i1, min_s, kind in pauses:
        if (i1 - i0) * hop >= min_s:
            t0, t1 = float(seg.timeline_t_s[i0]), float(seg.timeline_t_s[i1 - 1])
            m = (t >= t0) & (t <= t1)
            fine = m & np.isfinite(tilt).all(axis=1)
            if walking_tilt is not None and fine.sum() >= 3 and \
                    np.max(np.abs(np.median(tilt[fine], axis=0) - walking_tilt)) > s.still_tilt_deg:
                continue  # still but far from the walking posture: sitting, lying or bent down
            if m.sum() >= 3:
                ref = np.median(a[m], axis=0)
                where = f"first {kind} {t0:.1f}-{t1:.1f} s"
                if has_abs:
                    return ref, where + " (IMU gravity)", (t0, t1)
                return ref, where, (t0, t1)
    if has_abs:
        assert abs_deg is not None  # has_abs
        ok = np.isfinite(abs_deg).all(axis=1)
        off = np.median(a[ok][:, [0, 2]] - abs_deg[ok], axis=0)
        return np.array([off[0], 0.0, off[1]]), "gravity (IMU; no standing phase: the sensor is assumed level)", None
    # no stance at all: the first stride is taken for upright. Its median pose, not the first frame's: a walk
    # recorded from mid-stride caught the trunk at some phase of its sway, and every later inclination carried it
    # (on 30 simulated mid-walk starts the timeline's upright stretch read up to 3.0 deg off, median 1.0; over the
    # first s.first_pose_s: 1.3 and 0.37, the window the turns' axes use for the same reason)
    # Only where that stride is a stride: a recording that starts as the wearer bends down or handles the camera
    # moves the trunk by tens of degrees in it, and its median would be the bend (review: a pick-up start read
    # 37.6 deg off, a handled camera 11.9, against 1.4 and 0.75 from the first frame): then the first frame. The
    # range at 10 deg also refused a dragged foot's sway (up to 13 deg; its worst 1.8 -> 7.5 deg). At 15, with the
    # handled samples left out, one simulated camera-handling start that the segmentation does not call handled
    # still slips through (4.0 deg worst against 0.75 from the first frame; the README says so).
    m = t <= t[0] + s.first_pose_s if t.size else np.zeros(0, bool)
    grid = np.asarray(seg.timeline_t_s, dtype=float)
    handled = (len(seg.handled) == grid.size and t.size > 0
               and bool(np.any(np.asarray(seg.handled, dtype=bool) & (grid <= t[0] + s.first_pose_s))))
    if m.sum() >= 3 and not handled and float(np.max(np.ptp(a[m][:, [0, 2]], axis=0))) <= s.first_pose_max_range_deg:
        return (np.median(a[m], axis=0), f"first {s.first_pose_s:g} s (no standing phase and no IMU: assumed "
                "upright, the median pose over about a stride)", None)
    return np.zeros(3), "first frame (no standing phase and no IMU: assumed upright)", None


@dataclass(frozen=True, slots=True)
class ReferenceUncertainty:
    """How well the upright reference holds at each sample: ``deg`` (N, 2) the pitch/roll bound of its error.
    For video angles (no gravity), the orientation error carried since the nearest re-reference, 0 where a
    still phase in the same straight stretch re-referenced it; with gravity but nothing that measured the
    sensor's tilt on the trunk, that tilt's bound everywhere. ``why`` (N,) an index into ``reasons`` (-1: none)."""

    deg: NDArray[np.float64]
    why: NDArray[np.int64]
    reasons: tuple[str, ...]


def _standing_anchors(
    t: NDArray, a: NDArray, seg: Segmentation, first: tuple[float, float], s: SessionSettings,
    stray: list[tuple[float, float, NDArray, list[Bout]]] | None = None,
) -> list[tuple[float, NDArray]]:
    """(mid time, pitch/roll of the stance minus the reference stance's) of every still phase >= ``min_anchor_s``
    (outside turns) whose stance is within ``max_drift_deg`` of the reference's: the same upright stance, so the
    difference is the video's drift (a stance farther off is not taken for the same one).

    Any still phase, not only the ``standing`` activity's >= ``min_standing_s``: a pause shorter than a bout
    break (< 3 s) lies inside its bout, where the activity says walking, and the still part of a 1.5-2.5 s pause
    (the closing and first steps move the trunk) lasts 0.5-1.5 s; the stance's angles need no more (the video's
    noise while still is ~0.01 deg). On the simulator's unkind sessions many stretches after a turn that were left
    without a reference had such a pause. ``stray``: when given, gets ``(start, end, difference, bouts about it)``
    of each still pause in a walk (:func:`_walk_around`; the pause itself no longer than a bout break, 3 s) whose
    stance is farther off, but within twice ``max_drift_deg``: a stance that close to upright, that briefly,
    between steps, is standing, so the angles themselves are off there (see :func:`_reference_model`). Sitting
    (22-35 deg on the simulator) or picking something up (45-75 deg) is a posture, not the video's error."""
    act = np.asarray(seg.activity)
    grid = np.asarray(seg.timeline_t_s, dtype=float)
    hop = float(grid[1] - grid[0]) if grid.size > 1 else 0.1
    m0 = (t >= first[0]) & (t <= first[1])
    if m0.sum() < 3:
        return []
    base = np.median(a[m0][:, [0, 2]], axis=0)
    out = [(0.5 * (first[0] + first[1]), np.zeros(2))]
    # the trunk still, wherever: a pause shorter than a bout break (< 3 s) lies inside a bout, where the activity
    # says walking; not in a turn
    if len(seg.still) == grid.size:
        still = np.asarray(seg.still, dtype=bool) & (act != "turning")
        min_s = s.min_anchor_s
    else:
        still, min_s = act == "standing", s.min_standing_s
    for i0, i1 in _runs(still):
        if (i1 - i0) * hop < min_s:
            continue
        t0, t1 = float(seg.timeline_t_s[i0]), float(seg.timeline_t_s[i1 - 1])
        m = (t >= t0) & (t <= t1)
        if m.sum() < 3 or (t0 <= first[1] and t1 >= first[0]):
            continue
        d = np.median(a[m][:, [0, 2]], axis=0) - base
        if np.max(np.abs(d)) <= s.max_drift_deg:
            out.append((0.5 * (t0 + t1), d))
        elif (stray is not None and t1 - t0 <= DEFAULT_ACTIVITY_SETTINGS.max_break_s
              and np.max(np.abs(d)) <= 2.0 * s.max_drift_deg and (around := _walk_around(seg, t0, t1))):
            stray.append((t0, t1, d, around))
    return sorted(out, key=lambda v: v[0])


STRAY_PAUSE = "a pause at"  # how the reason of a pause whose stance reads off begins (_reference_model)


def _walk_around(seg: Segmentation, t0: float, t1: float) -> list[Bout]:
    """The walking bouts about a still pause ``[t0, t1]``: the one it lies in, or the two it lies between when
    each is within a bout break of it (``max_break_s``, 3 s: a pause that short between steps is standing, not
    sitting down and getting up again); empty when it is no pause in a walk."""
    inside = [b for b in seg.bouts if b.start_s < t0 and t1 < b.end_s]
    if inside:
        return inside
    brk = DEFAULT_ACTIVITY_SETTINGS.max_break_s
    before = [b for b in seg.bouts if t0 - brk <= b.end_s <= t0]
    after = [b for b in seg.bouts if t1 <= b.start_s <= t1 + brk]
    return [before[-1], after[0]] if before and after else []


def _reference_model(
    t: NDArray, a: NDArray, seg: Segmentation, stand: tuple[float, float] | None, s: SessionSettings,
    vertical_deg: float = 0.0,
) -> tuple[NDArray, ReferenceUncertainty, int]:
    """The video's pitch/roll drift at every sample and how uncertain it is after turns.

    A video's orientation has no absolute reference: its error grows mostly where tracking degrades, in turns
    (fast rotation, facades near the camera; 1-6 deg of pitch or roll across a 90-180 deg turn at 320x240). The
    recording is cut at its turns into straight stretches. A standing phase re-references the stretch it lies
    in (the stance is taken to be the reference stance, so their difference is drift): between two standing
    phases of one stretch the drift is interpolated linearly in time, before the first and after the last it is
    held. A stretch without a standing phase is reached from the nearest re-referenced stretches through n turns,
    each of which may add up to ``turn_reference_deg``: from one side its drift is that side's, within
    +-n x ``turn_reference_deg``; from both, the middle of the two intervals' overlap, within half of it.
    Without any standing phase the first stride is the reference (assumed upright) for the first stretch only.
    ``vertical_deg``: how uncertain gravity's direction is (:func:`_vertical_uncertainty`); after a turn it reads
    as up to twice itself in the tilt, so each turn's bound becomes ``hypot(turn_reference_deg, 2 vertical_deg)``.
    Returns the drift (N, 2), the uncertainty and how many standing phases re-referenced the angles."""
    n = t.size
    drift = np.zeros((n, 2))
    unc = np.zeros((n, 2))
    why = np.full(n, -1, dtype=np.int64)
    stray: list[tuple[float, float, NDArray, list[Bout]]] = []
    anchors = _standing_anchors(t, a, seg, stand, s, stray) if stand is not None else []
    if not anchors and n:
        anchors = [(float(t[0]), np.zeros(2))]
    turns = sorted(seg.turns, key=lambda u: u.start_s)
    mids = np.array([0.5 * (u.start_s + u.end_s) for u in turns])
    stretch = np.searchsorted(mids, t)  # stretch k lies between turns k-1 and k
    n_st = len(turns) + 1
    by_stretch: dict[int, list[tuple[float, NDArray]]] = {}
    for ta, d in anchors:
        by_stretch.setdefault(int(np.searchsorted(mids, ta)), []).append((ta, d))
    known = sorted(by_stretch)
    reasons: list[str] = []
    delta = math.hypot(s.turn_reference_deg, 2.0 * vertical_deg)
    for k in range(n_st):
        m = stretch == k
        if not m.any():
            continue
        if k in by_stretch:
            at = by_stretch[k]
            ts = np.array([v[0] for v in at])
            for j in range(2):
                drift[m, j] = np.interp(t[m], ts, [v[1][j] for v in at])
            continue
        left = [j for j in known if j < k]
        right = [j for j in known if j > k]
        lo = np.full(2, -np.inf)
        hi = np.full(2, np.inf)
        via: list[float] = []
        if left:
            kl = left[-1]
            dl = by_stretch[kl][-1][1]
            lo, hi = np.maximum(lo, dl - math.sqrt(k - kl) * delta), np.minimum(hi, dl + math.sqrt(k - kl) * delta)
            via += [turns[i].start_s for i in range(kl, k)]
        if right:
            kr = right[0]
            dr = by_stretch[kr][0][1]
            lo2, hi2 = dr - math.sqrt(kr - k) * delta, dr + math.sqrt(kr - k) * delta
            if left and np.any(np.maximum(lo, lo2) > np.minimum(hi, hi2)):  # drifted beyond the bound: split
                w = (k - left[-1]) / (kr - left[-1])
                centre = (1 - w) * by_stretch[left[-1]][-1][1] + w * dr
                lo, hi = centre - delta, centre + delta
            else:
                lo, hi = np.maximum(lo, lo2), np.minimum(hi, hi2)
            via += [turns[i].start_s for i in range(k, kr)]
        drift[m] = 0.5 * (lo + hi)
        unc[m] = 0.5 * (hi - lo)
        where = ", ".join(f"t={v:.1f} s" for v in sorted(via))
        reasons.append(f"the video's upright reference is uncertain across the turn{'s' if len(via) > 1 else ''} "
                       f"at {where} (no standing phase in this straight stretch to re-reference it; each turn may "
                       f"move the video's pitch and roll by up to {delta:.3g} deg"
                       + (f", gravity's direction from the turns being uncertain by {vertical_deg:.1f} deg: one turn "
                          "cannot tell the camera's tilt on the trunk from a change of posture in it"
                          if vertical_deg > 0 else "") + ")")
        why[m] = len(reasons) - 1
    # a pause in a walk, after a turn, whose stance reads farther from the upright one than any drift taken: the
    # video's angles there are off (the rotation's error in turns comes and goes: on a simulated session a 1.2 s
    # pause after two turns read 6.7 / -8.5 deg off and the stance 8 s later 1.9 / -0.3 deg, so that stretch's bent
    # walk read roll -9 deg, left shoulder down), or the wearer did not stand upright. Either way the walking of
    # the bouts about it in that stretch is uncertain by the pause's difference from the drift taken there
    k_ref = int(np.searchsorted(mids, 0.5 * (stand[0] + stand[1]))) if stand is not None else 0
    for p0, p1, d, around in stray:
        k = int(np.searchsorted(mids, 0.5 * (p0 + p1)))
        if k == k_ref:  # no turn between the pause and the upright stance: no turn's error to come and go
            continue
        m = np.zeros(n, dtype=bool)
        for b in around:
            m |= (stretch == k) & (t >= b.start_s) & (t <= b.end_s)
        i = min(int(np.searchsorted(t, 0.5 * (p0 + p1))), n - 1)
        e = np.abs(d - drift[i])
        grow = m & np.any(e[None, :] > unc, axis=1)
        if not grow.any():
            continue
        reasons.append(f"{STRAY_PAUSE} t={p0:.1f}-{p1:.1f} s reads {d[0]:+.1f} / {d[1]:+.1f} deg (pitch / roll) from "
                       f"the upright stance, {e[0]:.1f} / {e[1]:.1f} deg from the drift taken there: the video's "
                       "angles there are off after the turn, or the wearer stood leaning")
        unc[m] = np.maximum(unc[m], e)
        why[grow] = len(reasons) - 1
    return drift, ReferenceUncertainty(unc, why, tuple(reasons)), len(anchors) - 1


def _mount_uncertainty(t: NDArray, deg: float) -> ReferenceUncertainty:
    """The uncertainty of gravity as the upright reference when the sensor is only assumed level: its tilt on
    the trunk, unknown within +-``deg`` in pitch and roll at every sample."""
    return ReferenceUncertainty(np.full((t.size, 2), float(deg)), np.zeros(t.size, dtype=np.int64), (
        f"no standing phase and no baseline: gravity is the upright reference with the sensor assumed level, "
        f"and its tilt on the trunk (up to {deg:g} deg) is unknown; stand still for 2 s during the recording, "
        f"or record a baseline, to measure it",))


def _rereference(
    t: NDArray, a: NDArray, seg: Segmentation, stand: tuple[float, float] | None, s: SessionSettings,
    vertical_deg: float = 0.0,
) -> tuple[NDArray, str, ReferenceUncertainty]:
    """Video angles with the drift of :func:`_reference_model` removed, a note for the reference's source text,
    and the uncertainty left."""
    drift, unc, n_re = _reference_model(t, a, seg, stand, s, vertical_deg)
    out = a.copy()
    out[:, 0] -= drift[:, 0]
    out[:, 2] -= drift[:, 1]
    note = ""
    if n_re:
        note = (f"; re-referenced at {n_re} later still phase{'s' if n_re > 1 else ''} (drift up to "
                f"{np.max(np.abs(drift[:, 0])):.1f} / {np.max(np.abs(drift[:, 1])):.1f} deg pitch / roll removed)")
    n_turn = sum(1 for r in unc.reasons if not r.startswith(STRAY_PAUSE))
    if n_turn:
        note += f"; uncertain in {n_turn} straight stretch{'es' if n_turn > 1 else ''} after turns"
    if len(unc.reasons) > n_turn:
        k = len(unc.reasons) - n_turn
        note += f"; uncertain about {k} pause{'s' if k > 1 else ''} after turns whose stance reads off"
    return out, note, unc


def _runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    m = np.concatenate([[False], np.asarray(mask, bool), [False]]).astype(int)
    d = np.diff(m)
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist(), strict=True))


def _pause_intervals(activity: NDArray, seg: Segmentation) -> list[tuple[float, float]]:
    """Standing stretches inside bouts (the pauses :func:`_settle_timeline` found) and stretches where the sensor
    was handled inside them (``seg.handled``), as (start, end) times."""
    grid = np.asarray(seg.timeline_t_s, dtype=float)
    if grid.size < 2:
        return []
    hop = float(grid[1] - grid[0])
    out = []
    paused = np.asarray(activity) == "standing"
    if len(seg.handled) == grid.size:
        paused |= np.asarray(seg.handled, dtype=bool)
    for i0, i1 in _runs(paused):
        t0, t1 = float(grid[i0]) - 0.5 * hop, float(grid[i1 - 1]) + 0.5 * hop
        if any(b.start_s < t0 and t1 < b.end_s for b in seg.bouts):
            out.append((t0, t1))
    return out


def _pieces(bout: Any, turns: tuple, s: SessionSettings,
            pauses: list[tuple[float, float]] | None = None) -> list[tuple[float, float]]:
    """The bout minus its turns (with margins) and its pauses, pieces of at least ``min_piece_s``."""
    pieces = [(bout.start_s, bout.end_s)]
    cuts = [(u.start_s - s.turn_margin_s, u.end_s + s.turn_margin_s) for u in turns] + list(pauses or [])
    for a, b in cuts:
        nxt = []
        for p0, p1 in pieces:
            if b <= p0 or a >= p1:
                nxt.append((p0, p1))
                continue
            if a > p0:
                nxt.append((p0, a))
            if b < p1:
                nxt.append((b, p1))
        pieces = nxt
    return [(p0, p1) for p0, p1 in pieces if p1 - p0 >= s.min_piece_s]


def _moving_mean(x: NDArray, w: int) -> NDArray:
    kern = np.ones(w) / w
    return np.convolve(np.pad(x, (w // 2, w - 1 - w // 2), mode="edge"), kern, "valid")


def posture_features(t: NDArray, a: NDArray, s: SessionSettings = DEFAULT_SESSION_SETTINGS) -> NDArray:
    """Per sample: the slow (``smooth_s`` mean) pitch and roll, and the log of the gait's sway (RMS of pitch and
    roll about their slow part over ``smooth_s``): the inclination of a posture and how much the trunk sways in
    it (a dragged foot sways the trunk 2-3x as much as a normal walk, at the same inclination)."""
    fs = sampling_rate_hz(t)
    w = max(1, int(round(s.smooth_s * fs)))
    slow = np.column_stack([_moving_mean(a[:, k], w) for k in (0, 2)])
    osc = a[:, [0, 2]] - slow
    sway = np.sqrt(_moving_mean(np.sum(osc * osc, axis=1), w))
    return np.column_stack([slow, np.log(np.maximum(sway, 0.05))])


def change_limits(s: SessionSettings = DEFAULT_SESSION_SETTINGS) -> NDArray[np.float64]:
    """What a change of posture is, per :func:`posture_features` column: ``change_pitch_deg``, ``change_roll_deg``
    and the log of ``change_swing_ratio`` (features differing by at least one of them are two postures)."""
    return np.array([s.change_pitch_deg, s.change_roll_deg, math.log(s.change_swing_ratio)])


_CBS_CANDIDATES = 300  # split positions per end in change_points' search for a segment (pairs: its square)


def change_points(t: NDArray, a: NDArray, s: SessionSettings = DEFAULT_SESSION_SETTINGS) -> list[float]:
    """Split times of a piece: binary segmentation of :func:`posture_features` (a split where the two sides'
    medians differ by ``change_pitch_deg`` in pitch, ``change_roll_deg`` in roll or a factor
    ``change_swing_ratio`` in sway); where no one split does, the circular binary segmentation's look for a
    segment that differs from the rest (two splits: a posture between two stretches of another)."""
    if t.size < 4:
        return []
    fs = sampling_rate_hz(t)
    slow = posture_features(t, a, s)
    limits = change_limits(s)
    out: list[float] = []

    def split(i0: int, i1: int) -> None:
        n_min = int(s.min_segment_s * fs)
        if i1 - i0 < 2 * n_min:
            return
        # where: the CUSUM statistic of the means (largest at the middle of a step or a ramp, where medians are
        # flat across the whole ramp); whether: the medians either side differ by the limits
        x = slow[i0:i1] / limits
        csum = np.cumsum(x - x.mean(axis=0), axis=0)
        n = i1 - i0
        ks = np.arange(n_min, n - n_min, max(1, int(0.1 * fs)))
        if ks.size == 0:
            return
        cusum = np.abs(csum[ks - 1]) / np.sqrt(ks * (n - ks) / n)[:, None]
        best_k = i0 + int(ks[int(np.argmax(cusum.max(axis=1)))])
        d = np.abs(np.median(slow[i0:best_k], axis=0) - np.median(slow[best_k:i1], axis=0)) / limits
        if float(d.max()) >= 1.0:
            out.append(float(t[best_k]))
            split(i0, best_k)
            split(best_k, i1)
            return
        # no one split: a posture between two stretches of another (left shoulder down, normal, left shoulder
        # down again) leaves each side's median in the outer posture, whichever split is tried. The circular
        # binary segmentation's second look (Olshen et al. 2004, Biostatistics 5(4) 557-572): the segment whose
        # mean differs most from the rest, with at least min_segment_s inside and on each side of it
        if n < 3 * n_min:
            return
        c = np.vstack([np.zeros((1, x.shape[1])), csum])

        def best_pair(c1: NDArray, c2: NDArray) -> tuple[int, int, float]:
            m = (c2[None, :] - c1[:, None]).astype(float)
            inner = np.abs(c[c2][None, :, :] - c[c1][:, None, :]).max(axis=2)
            score = np.where(m >= n_min, inner / np.sqrt(np.maximum(m * (n - m) / n, 1e-9)), -np.inf)
            a1, a2 = np.unravel_index(int(np.argmax(score)), score.shape)
            return int(c1[a1]), int(c2[a2]), float(score[a1, a2])

        # candidates at most _CBS_CANDIDATES apart on a long piece (the pairs grow as their square: a 10-minute
        # straight walk has 6000 positions 0.1 s apart), then each end refined at 0.1 s about the best pair
        step = max(1, int(np.ceil(ks.size / _CBS_CANDIDATES)))
        k1, k2, score = best_pair(ks[::step], ks[::step])
        if not np.isfinite(score):
            return
        if step > 1:
            reach = step * (ks[1] - ks[0])
            k1, k2, score = best_pair(ks[np.abs(ks - k1) <= reach], ks[np.abs(ks - k2) <= reach])
            if not np.isfinite(score):
                return
        j1, j2 = i0 + k1, i0 + k2
        outside = np.concatenate([slow[i0:j1], slow[j2:i1]])
        d = np.abs(np.median(slow[j1:j2], axis=0) - np.median(outside, axis=0)) / limits
        if float(d.max()) >= 1.0:
            out.extend([float(t[j1]), float(t[j2])])
            split(i0, j1)
            split(j1, j2)
            split(j2, i1)

    split(0, t.size)
    return sorted(out)


def _steps_asymmetry(steps: NDArray[np.float64]) -> dict[str, float]:
    """Alternating step time asymmetry of detected steps (:func:`walkmon.gait.posture.step_time_alternation`)
    over the longest run without a pause (an interval above 1.6 x the median breaks the alternation: after a pause
    the leading foot is unknown)."""
    from walkmon.gait.posture import step_time_alternation

    st = np.asarray(steps, dtype=float)
    d = np.diff(st)
    if np.isfinite(d).any():
        ok = d <= 1.6 * np.nanmedian(d)
        runs = _runs(ok)
        if runs:
            i0, i1 = max(runs, key=lambda r: r[1] - r[0])
            st = st[i0 : i1 + 1]
    return step_time_alternation(st)


def span_indicators(
    t: NDArray, a: NDArray, t0: float, t1: float, ref: NDArray, sig_steps: NDArray, kind: str,
    settings: IndicatorSettings = DEFAULT_INDICATOR_SETTINGS, baseline: Mapping[str, Any] | None = None,
    steady_steps: NDArray | None = None, sig: TrunkSignals | None = None,
) -> tuple[Indicators, dict[str, Any]]:
    """Indicators and classification of the walking span [t0, t1] of heading-free angles ``a`` (upright =
    ``ref``): the paper's swing/inclination, cadence from the steps in the span, asymmetry, and the one
    classifier (:func:`walkmon.gait.posture.classify`); the step time asymmetry from ``steady_steps`` when given
    (steps of gait initiation/termination and turns left out). Used for every offline posture segment and every live
    window (:mod:`walkmon.gait.live`), so both label a walk with the same function, thresholds and reasons."""
    from walkmon.gait.posture import classify

    m = (t >= t0) & (t <= t1)
    st = sig_steps[(sig_steps >= t0) & (sig_steps <= t1)]
    ind = analyze_gait(t[m], a[m], replace(settings, find_standing=False, min_walking_s=2.0),
                       reference_deg=ref).indicators
    spectral = ind.cadence_spm
    cadence = cadence_from_steps(st, mend=kind != "angles", sig=sig) if st.size >= 3 else spectral
    asym = dict(ind.asymmetry)
    if kind != "angles":  # detected steps of the IMU: their alternation is the better evidence
        steady = st if steady_steps is None else steady_steps[(steady_steps >= t0) & (steady_steps <= t1)]
        alt = _steps_asymmetry(steady)
        r = alt["ratio"]
        asym["step_time_ratio"] = r
        asym["step_time_ratio_ci_low"] = alt["ratio_ci_low"]
        asym["step_time_n_pairs"] = alt["n_pairs"]
        asym["step_time_asymmetry_pct"] = 100.0 * 2 * (r - 1) / (r + 1) if math.isfinite(r) else float("nan")
        asym["n_steps"] = float(st.size)
    if kind == "angles":
        # steps seen: the pitch cycles complete inside the span miss its edge cycles, the step detector misses
        # steps within half its window of a recording's edges (a live window): both are lower bounds
        cycles = asym.get("n_steps")
        asym["n_steps"] = max(float(cycles) if cycles is not None and math.isfinite(cycles) else 0.0, float(st.size))
        asym[ROTATION_STEP_TIMES] = 1.0  # the pitch's maxima: no evidence of the feet's step times (posture.py)
    ind = replace(ind, cadence_spm=float(cadence), asymmetry=asym)
    if kind == "acc":
        # An accelerometer alone sees no turns (their centripetal acceleration tilts the low-passed "gravity") and
        # no swing (gravity angles are low-passed): its inclinations are indicative only, not a posture label.
        # They are the mean gravity angles over the span, not the cycles' mid-points: low-passed gravity has no
        # step cycles (a normal stretch had a null pitch, and the session's pitch was the bent stretch's alone).
        ind = _gravity_inclinations(ind, a[m], ref)
        ind = ind.with_classification(Classification("unclassified", (
            "accelerometer only: no gyroscope to exclude turns or measure swings, so no posture label "
            f"(pitch {ind.axes['pitch'].inclination_mean:.1f} deg, roll {ind.axes['roll'].inclination_mean:.1f} deg "
            "from gravity, indicative)",)))
    else:
        ind = ind.with_classification(classify(ind.to_dict(), baseline))
    doc = {
        "start_s": _num(t0, 3), "end_s": _num(t1, 3), "activity": "walking", "n_steps": int(st.size),
        "cadence_spm": _num(cadence, 2), "spectral_cadence_spm": _num(spectral, 2),
        "axes": {ax: ind.axes[ax].to_dict() for ax in AXES},
        "asymmetry": {k: _num(v) for k, v in asym.items()},
        "label": ind.classification.label, "reasons": list(ind.classification.reasons),
        "status": ind.status.value,
    }
    return ind, doc


def _gravity_inclinations(ind: Indicators, a: NDArray, ref: NDArray) -> Indicators:
    """``ind`` with pitch and roll inclinations the mean of the span's angles ``a`` (N,3) about ``ref`` (their
    spread as ``inclination_std``), swing and cycles not measured, and yaw none: an accelerometer's indicators."""
    nan = float("nan")
    axes = dict(ind.axes)
    for k, ax in enumerate(AXES):
        x = a[:, k] - float(ref[k])
        x = x[np.isfinite(x)]
        if ax == "yaw" or not x.size:
            axes[ax] = AxisIndicators(nan, nan, nan, nan, n_cycles=0)
        else:
            axes[ax] = AxisIndicators(nan, nan, nan, float(np.mean(x)), n_cycles=0, inclination_std=float(np.std(x)))
    ok = bool(np.isfinite(axes["pitch"].inclination_mean))
    return replace(ind, axes=axes, status=IndicatorStatus.OK if ok else ind.status)


def _weighted_axes(items: list[tuple[float, Indicators]]) -> dict[str, AxisIndicators]:
    out = {}
    for ax in AXES:
        vals = [(w, i.axes[ax]) for w, i in items if i.status is IndicatorStatus.OK]
        if not vals:
            out[ax] = AxisIndicators(*(float("nan"),) * 4, n_cycles=0)
            continue
        ws = np.array([w for w, _ in vals])

        def avg(name: str, vals=vals, ws=ws) -> float:
            x = np.array([getattr(v, name) for _, v in vals], float)
            ok = np.isfinite(x)
            return float(np.sum(ws[ok] * x[ok]) / np.sum(ws[ok])) if ok.any() else float("nan")

        out[ax] = AxisIndicators(avg("lmax_mean"), avg("lmin_mean"), avg("swing_mean"), avg("inclination_mean"),
                                 int(sum(v.n_cycles for _, v in vals)), avg("swing_std"), avg("inclination_std"),
                                 avg("frequency_hz"))
    return out


def analyze_session(
    t_s: ArrayLike,
    angles_deg: ArrayLike,
    *,
    imu: ImuInput | None = None,
    abs_angles_deg: ArrayLike | None = None,
    baseline: Indicators | Mapping[str, Any] | None = None,
    settings: IndicatorSettings = DEFAULT_INDICATOR_SETTINGS,
    activity_settings: ActivitySettings = DEFAULT_ACTIVITY_SETTINGS,
    session_settings: SessionSettings = DEFAULT_SESSION_SETTINGS,
    no_yaw: bool = False,
    reference_deg: ArrayLike | None = None,
) -> SessionAnalysis:
    """Timeline, bouts, posture segments and the summary of one recording (see the module text)."""
    t = np.asarray(t_s, dtype=float)
    a = np.array(angles_deg, dtype=float)
    if a.ndim == 2 and a.shape[1] == 3 and a.shape[0] > 1:
        a[:, 1] = np.degrees(np.unwrap(np.radians(a[:, 1])))  # yaw wraps at +-180 after a U-turn
    absd = None if abs_angles_deg is None else np.asarray(abs_angles_deg, dtype=float)
    base = baseline.to_dict() if isinstance(baseline, Indicators) else baseline
    sig: TrunkSignals
    if imu is not None:
        sig = signals_from_imu(imu.t_s, imu.acc_m_s2, imu.gyro_rad_s, activity_settings)
    else:
        sig = signals_from_angles(t, a, activity_settings)
    seg = segment(sig, activity_settings)
    s = session_settings
    has_abs = absd is not None and np.isfinite(absd).all(axis=1).mean() > 0.5
    # video: gravity's direction from the axes of the turns (a camera tilted on the trunk otherwise reads its
    # tilt as posture once the wearer has turned)
    vert = None if has_abs or not session_settings.turn_vertical else vertical_from_turns(t, a, seg.turns)
    if vert is not None and not vert.verified:  # the camera-level assumption as a vote (vertical_with_level)
        r0 = reference_deg if reference_deg is not None else _upright(t, a, seg, None, s)[0]
        vert = vertical_with_level(vert, camera_level_down(r0))
    # the angles in a level frame: the camera's frame at the start turned level (gravity's direction from the IMU
    # or the turns), so that pitch, yaw and roll (swings, the step rhythm, the heading rate) are those of the
    # trunk and not a tilted camera's mix of them
    down = _start_down(a, absd) if has_abs and absd is not None else (None if vert is None else vert.down)
    level = None if down is None else level_basis(down)
    if level is not None:
        a = level_frame_angles(a, level)
        if imu is None:  # the activity from the level angles
            sig = signals_from_angles(t, a, activity_settings)
            seg = segment(sig, activity_settings)
    v_level = None if level is None else np.array([0.0, 1.0, 0.0])
    if reference_deg is not None:
        ref = np.asarray(reference_deg, dtype=float).reshape(3)
        if level is not None:
            ref = level_frame_angles(ref[None, :], level)[0]
        ref_source, stand = "given (reference_deg: the caller's, or the live monitor's calibration)", None
    else:
        tilt = None if has_abs or not seg.turns else heading_free_angles(t, a, a[0], v_level)[:, [0, 2]]
        ref, ref_source, stand = _upright(t, a, seg, absd, s, tilt=tilt)
    ref_camera = ref if level is None else level_frame_angles(ref[None, :], level.T)[0]  # in the input's frame
    up_given = None
    if reference_deg is not None and has_abs and down is not None:
        # a given upright pose with gravity known: its gravity angles (review: it was ignored, up_abs level, and
        # the output still said 'given')
        from walkmon.consts import rotation_from_angles_deg

        r_ref = rotation_from_angles_deg(*(np.array([v]) for v in ref_camera))[0]
        up_given = np.asarray(gravity_angles_deg_from_gravity(r_ref.T @ down), dtype=float)
    a, ref_out, ref_source, unc = _heading_free(t, a, absd if has_abs else None, ref, ref_source, stand, seg, s,
                                                down=v_level, vertical_deg=_vertical_uncertainty(vert, ref_camera),
                                                stance_gravity=None if imu is None else partial(_stance_gravity_deg,
                                                                                                imu),
                                                up_abs_given=up_given)
    if not has_abs:
        ref_out = ref_camera[[0, 2]]  # the upright pose reported in the input's start-relative angles
    if unc is None and has_abs and stand is None and reference_deg is None and base is None \
            and s.mount_tilt_deg > 0:
        unc = _mount_uncertainty(t, s.mount_tilt_deg)
        ref_source += f"; labels given only where they hold for any sensor tilt within +-{s.mount_tilt_deg:g} deg"
    ref_zero = np.zeros(3)
    activity = _not_upright_is_unknown(np.asarray(seg.activity, dtype=object), seg.timeline_t_s, t, a, s)
    activity = _settle_timeline(activity, seg, s)
    pauses = _pause_intervals(activity, seg)
    seg = replace(seg, activity=tuple(str(v) for v in activity))
    seg_docs, bout_docs, weighted, label_time = _bouts(t, a, seg, sig, ref_zero, settings, base, s, no_yaw=no_yaw,
                                                       pauses=pauses, unc=unc)
    walking_s = seg.walking_s
    cad = [(b.duration_s, b.cadence_spm) for b in seg.bouts if math.isfinite(b.cadence_spm)]
    cadence = (sum(w * c for w, c in cad) / sum(w for w, _ in cad)) if cad and sum(w for w, _ in cad) > 0 \
        else float("nan")
    axes = _weighted_axes(weighted)
    dominant, share, cls = _dominant(label_time, seg_docs, seg)
    asym = _weighted_asym(weighted)
    activity_s = {k: float(np.sum(activity == k)) * activity_settings.hop_s
                  for k in ("standing", "walking", "turning", "unknown")}
    if t.size and len(seg.timeline_t_s):  # the recording's time outside the activity's (an IMU shorter than a video)
        hop = activity_settings.hop_s
        before = float(seg.timeline_t_s[0] - hop / 2 - t[0])
        after = float(t[-1] - seg.timeline_t_s[-1] - hop / 2)
        # beyond the last hop's rounding (it added 0.02 s to a fully covered recording: review)
        activity_s["unknown"] += (before if before > hop / 2 else 0.0) + (after if after > hop / 2 else 0.0)
    rows = timeline_rows(t, a, seg, seg_docs, ref_zero, unc=unc)
    # walking bouts found are a gait rhythm found (their steps and cadence are reported): 'no_gait' beside 3 bouts,
    # 20 steps and a cadence contradicted itself (user review); their posture figures may still be null
    status = IndicatorStatus.OK if seg.bouts or any(i.status is IndicatorStatus.OK for _, i in weighted) else (
        IndicatorStatus.NO_GAIT if t.size > 16 else IndicatorStatus.TOO_SHORT)
    session = {
        "upright_reference": {"source": ref_source, "pitch_deg": _num(ref_out[0]), "roll_deg": _num(ref_out[1]),
                              "frame": "gravity pitch/roll" if has_abs else "start-relative angles",
                              "vertical": _vertical_doc(vert, ref_camera, has_abs)},
        "input": {"activity_from": {"imu": "IMU (gyroscope + accelerometer)", "acc": "accelerometer only",
                                    "angles": "camera angles"}[sig.kind],
                  "notes": list(seg.notes) + (["no yaw: yaw indicators are null"] if no_yaw else [])
                  + _coverage_note(t, seg, activity_settings.hop_s)},
        "activity_s": {k: _num(v, 2) for k, v in activity_s.items()},
        "summary": {
            "cadence_spm": _num(cadence, 2), "walking_s": _num(walking_s, 2), "n_bouts": len(seg.bouts),
            "n_steps": int(sum(b.n_steps for b in seg.bouts)), "n_turns": len(seg.turns),
            "posture_time_s": {k: _num(v, 2) for k, v in sorted(label_time.items())},
            "dominant_label": dominant, "dominant_share": _num(share, 3),
        },
        "bouts": bout_docs,
        "segments": seg_docs,
        "turns": [u.to_dict() for u in seg.turns],
    }
    duration = float(t[-1] - t[0]) if t.size else 0.0
    first, last = (seg.bouts[0].start_s, seg.bouts[-1].end_s) if seg.bouts else (float("nan"), float("nan"))
    if no_yaw:
        axes["yaw"] = AxisIndicators(*(float("nan"),) * 4, n_cycles=0)
    stand_start, stand_end = _standing_at_ends(seg)
    ind = Indicators(
        cadence_spm=float(cadence), duration_s=duration, walking_s=walking_s, axes=axes, asymmetry=asym,
        classification=cls, status=status, mode=settings.mode, walking_interval_s=(first, last),
        standing_start_s=stand_start, standing_end_s=stand_end,
        reference_deg={"pitch": float(ref_out[0]), "yaw": 0.0, "roll": float(ref_out[1])}, drift_removed_deg={},
        session=session,
    )
    return SessionAnalysis(ind, seg, ref_camera, ref_source, tuple(seg_docs), rows)


def _standing_at_ends(seg: Segmentation) -> tuple[tuple[float, float] | None, tuple[float, float] | None]:
    """indicators.json ``standing_start_s`` / ``standing_end_s``: the timeline's standing that opens the recording
    (before its first bout) and that closes it (after its last), as the paper's processing reports them; None
    where the recording starts or ends otherwise (review: always null, the report's 'standing at start' a dash
    beside a reference taken from a 5 s standing phase)."""
    grid = np.asarray(seg.timeline_t_s, dtype=float)
    act = np.asarray(seg.activity, dtype=object)
    if grid.size < 2:
        return None, None
    standing = act == "standing"
    first_walk = seg.bouts[0].start_s if seg.bouts else math.inf
    last_walk = seg.bouts[-1].end_s if seg.bouts else -math.inf
    out: list[tuple[float, float] | None] = [None, None]
    if standing[0]:
        i = int(np.argmin(standing)) if not standing.all() else standing.size
        if grid[i - 1] <= first_walk:
            out[0] = (float(grid[0]), float(grid[i - 1]))
    if standing[-1]:
        j = standing.size - int(np.argmin(standing[::-1])) if not standing.all() else 0
        if grid[j] >= last_walk:
            out[1] = (float(grid[j]), float(grid[-1]))
    return out[0], out[1]


def _vertical_doc(vert: Vertical | None, ref: NDArray, has_abs: bool) -> dict[str, Any]:
    """indicators.json ``upright_reference.vertical``: where the direction of gravity came from and, from turns,
    the camera's tilt from level at the upright pose (its tilt on the trunk when the reference is a standing
    phase)."""
    if has_abs:
        return {"source": "IMU gravity"}
    if vert is None:
        return {"source": "assumed: the camera level on the trunk (no turn of 60 deg or more to measure it)"}
    tilt = vert.camera_tilt_deg(ref)
    how = ("the camera-level assumption agrees with them" if vert.with_level else
           f"their axes agree within {vert.spread_deg:.1f} deg" if vert.verified else
           "one turn: not verified by a second" if vert.n_turns == 1 else
           f"their axes disagree by {vert.spread_deg:.1f} deg: not verified")
    if vert.n_outliers:
        how += f"; {vert.n_outliers} more left out, their axes off the others'"
    return {"source": f"from {vert.n_turns} turn{'s' if vert.n_turns > 1 else ''} ({vert.total_turn_deg:.0f} deg in all; "
                      f"{how})",
            "verified": vert.verified, "uncertainty_deg": _num(_vertical_uncertainty(vert, ref), 2),
            "camera_pitch_deg": _num(tilt[0], 2), "camera_roll_deg": _num(tilt[1], 2)}


def _vertical_uncertainty(vert: Vertical | None, ref: NDArray) -> float:
    """How far gravity's direction from turns may be off, degrees: the turns' disagreement when two or more agree
    (``verified``); else also the angle between it and the camera assumed level at the upright pose: a single turn
    (or turns that disagree) cannot tell a camera tilted on the trunk from a change of posture in the turn, so
    either may hold. 0 without turns (the camera is then assumed level, as before turns existed here)."""
    if vert is None:
        return 0.0
    if vert.verified:
        return float(vert.spread_deg)
    return max(float(vert.spread_deg), angle_between_deg(camera_level_down(ref), vert.down))


def level_basis(down: ArrayLike) -> NDArray[np.float64]:
    """A level frame in the start frame's coordinates, as columns: the camera's x made horizontal, ``down``
    (gravity's direction), and forward (their cross product): the start camera turned level with the least
    rotation about its optical axis."""
    d = np.asarray(down, dtype=float).reshape(3)
    d = d / np.linalg.norm(d)
    x = np.array([1.0, 0.0, 0.0]) - d[0] * d
    x /= np.linalg.norm(x)
    return np.column_stack([x, d, np.cross(x, d)])


def level_frame_angles(angles_deg: ArrayLike, basis: NDArray[np.float64]) -> NDArray[np.float64]:
    """Start-relative camera angles (N, 3) re-expressed as the angles of the level frame that rides with the
    camera (:func:`level_basis`, fixed on the camera): ``L^T M(t) L``. The identity for a camera level at the
    start; for a camera tilted on the trunk, the trunk's own pitch, yaw and roll (a tilted camera's Euler angles
    mix them: its yaw oscillation and turns show in its roll and pitch). Yaw stays continuous."""
    from walkmon.consts import angles_deg_from_rotation, rotation_from_angles_deg

    a = np.asarray(angles_deg, dtype=float).reshape(-1, 3)
    m = rotation_from_angles_deg(a[:, 0], a[:, 1], a[:, 2])
    out = angles_deg_from_rotation(basis.T @ m @ basis)
    if out.shape[0] > 1:
        out[:, 1] = np.degrees(np.unwrap(np.radians(out[:, 1])))
        # keep yaw on the input's turn count (unwrap is relative to the first sample)
        out[:, 1] += 360.0 * np.round((a[0, 1] - out[0, 1]) / 360.0)
    return out


def _start_down(a: NDArray, absd: NDArray) -> NDArray[np.float64] | None:
    """Gravity's direction in the start frame from gravity-referenced (pitch_abs, roll_abs) (an IMU): the median
    over the recording of each frame's gravity turned into the start frame."""
    from walkmon.consts import gravity_from_angles_deg, rotation_from_angles_deg

    ok = np.isfinite(absd[:, :2]).all(axis=1) & np.isfinite(a).all(axis=1)
    if ok.sum() < 3:
        return None
    g = gravity_from_angles_deg(absd[ok, 0], absd[ok, 1])
    m = rotation_from_angles_deg(a[ok, 0], a[ok, 1], a[ok, 2])
    v = np.median(np.einsum("nij,nj->ni", m, g), axis=0)
    n = float(np.linalg.norm(v))
    return v / n if n > 0.5 else None


def _stance_gravity_deg(imu: ImuInput, stand: tuple[float, float]) -> NDArray[np.float64] | None:
    """Gravity's (pitch_abs, roll_abs) over a still stance from the mean of the accelerometer's samples in it;
    None without the accelerometer in the angles' axes or with fewer than 3 samples there."""
    acc = imu.acc_camera_m_s2
    if acc is None:
        return None
    m = (imu.t_s >= stand[0]) & (imu.t_s <= stand[1]) & np.isfinite(acc).all(axis=1)
    if m.sum() < 3:
        return None
    mean = np.mean(acc[m], axis=0)
    if float(np.linalg.norm(mean)) < 1.0:  # no gravity in it: not an accelerometer in m/s^2
        return None
    return np.asarray(gravity_angles_deg_from_gravity(-mean), dtype=float)


def _heading_free(
    t: NDArray, a: NDArray, absd: NDArray | None, ref: NDArray, ref_source: str, stand: tuple[float, float] | None,
    seg: Segmentation, s: SessionSettings, *, down: NDArray | None = None, vertical_deg: float = 0.0,
    stance_gravity: Callable[[tuple[float, float]], NDArray[np.float64] | None] | None = None,
    up_abs_given: NDArray[np.float64] | None = None,
) -> tuple[NDArray, NDArray, str, ReferenceUncertainty | None]:
    """Heading-free inclinations: gravity's pitch/roll with an IMU (``absd``, when mostly finite), else the tilt
    from the upright pose (re-referenced at later still phases, :func:`_reference_model`). Returns the angles,
    the upright pitch/roll they are relative to, the reference's source text and, for video, how uncertain the
    reference is after turns."""
    if absd is not None:
        ok = np.isfinite(absd).all(axis=1)
        gp = np.interp(t, t[ok], absd[ok, 0])
        gr = np.interp(t, t[ok], absd[ok, 1])
        # the upright pose in gravity angles: the standing phase's, or level. Measured by the accelerometer itself
        # where it can be (still, it reads gravity alone): the attitude filter's gravity lags by seconds behind a
        # stop, and its median over a stance right after walking read the sensor's tilt 1-3 deg off (user review:
        # a simulated pause after a walk, -11.9 deg against the still accelerometer's -8.9; every later segment's
        # pitch inclination read 3 deg high and normal walking 'unclassified')
        up_abs = np.zeros(2) if up_abs_given is None else np.asarray(up_abs_given, dtype=float)
        if stand is not None:
            m = (t >= stand[0]) & (t <= stand[1])
            measured = None if stance_gravity is None else stance_gravity(stand)
            up_abs = measured if measured is not None else np.array([np.median(gp[m]), np.median(gr[m])])
        a = slow_offset(t, a, np.column_stack([gp - up_abs[0], a[:, 1], gr - up_abs[1]]))
        return a, up_abs, ref_source, None
    a = heading_free_angles(t, a, ref, down)
    a, note, unc = _rereference(t, a, seg, stand, s, vertical_deg)
    return a, ref[[0, 2]], ref_source + note, unc


def _bouts(
    t: NDArray, a: NDArray, seg: Segmentation, sig: TrunkSignals, ref_zero: NDArray, settings: IndicatorSettings,
    base: Mapping[str, Any] | None, s: SessionSettings, *, no_yaw: bool,
    pauses: list[tuple[float, float]] | None = None, unc: ReferenceUncertainty | None = None,
) -> tuple[list[dict[str, Any]], list[dict[str, Any]], list[tuple[float, Indicators]], dict[str, float]]:
    """Each walking bout cut into straight pieces (between turns and pauses) and posture segments (at change
    points): the segments' documents, the bouts' documents, the (duration, indicators) of every segment and the
    time per posture label. Straight stretches that a turn or a pause separates, with no change of posture between
    them (:func:`_same_posture`), are one posture: they are labelled together, on their pooled evidence (a walk of
    4-6 s between two turns has too few steps to label on its own). So are the last stretch of a bout and the
    first of the next when they are in the same posture: a limp is the walker's, and a stop of 3 s or more that
    splits the bouts does not change it (the simulator's unkind sessions from the IMU: dragged-foot segments of
    4-7 s with 1-2 steady step pairs, 3 needed, beside a stop; labels right 94 -> 98 % of 122, held out 94 -> 97 %
    of 131, no label lost; the video's and the real recordings' labels unchanged)."""
    seg_docs: list[dict[str, Any]] = []
    bout_docs: list[dict[str, Any]] = []
    weighted: list[tuple[float, Indicators]] = []
    label_time: dict[str, float] = {}
    per_bout: list[tuple[Bout, list[tuple[float, float, bool]], list[tuple[Indicators, dict[str, Any]]]]] = []
    # chains of stretches of one posture, across bouts: (bout index, stretch index) in time order
    chains: list[list[tuple[int, int]]] = []
    for b in seg.bouts:
        spans: list[tuple[float, float, bool]] = []  # (start, end, starts at a change point)
        for p0, p1 in _pieces(b, seg.turns, s, pauses):
            m = (t >= p0) & (t <= p1)
            cuts = change_points(t[m], a[m], s)
            edges = [p0, *cuts, p1]
            spans += [(q0, q1, i > 0) for i, (q0, q1) in enumerate(zip(edges[:-1], edges[1:], strict=True))]
        items = [span_indicators(t, a, q0, q1, ref_zero, seg.steps_s, sig.kind, settings, base,
                                 steady_steps=seg.steady_steps_s, sig=sig) for q0, q1, _ in spans]
        k = len(per_bout)
        per_bout.append((b, spans, items))
        for i, (_, _, at_cut) in enumerate(spans):
            # a bout's first stretch continues the chain of the bout before when the posture is the same
            if chains and not at_cut:
                pk, pi = chains[-1][-1]
                if _same_posture(per_bout[pk][2][pi][0], items[i][0], s):
                    chains[-1].append((k, i))
                    continue
            chains.append([(k, i)])
    steps = [np.asarray(b.steps_s, dtype=float) for b, _, _ in per_bout]
    for chain in chains:
        if len(chain) > 1:
            cls, pooled = _pooled_classification(
                [per_bout[k][1][i][:2] for k, i in chain], [per_bout[k][2][i][0] for k, i in chain],
                [k for k, _ in chain], steps, seg.steady_steps_s, sig.kind, base)
        else:
            k, i = chain[0]
            cls, pooled = per_bout[k][2][i][0].classification, per_bout[k][2][i][0].to_dict()
        for k, i in chain:
            ind, doc = per_bout[k][2][i]
            # each stretch's own inclinations (with the pooled step evidence) against its own reference
            own = label_within_uncertainty(cls, {**pooled, "axes": doc["axes"]}, [per_bout[k][1][i][:2]], t, unc, base)
            per_bout[k][2][i] = (ind.with_classification(own),
                                 {**doc, "label": own.label, "reasons": list(own.reasons)})
    for b, spans, items in per_bout:
        inside = []
        for (q0, q1, _), (ind, doc) in zip(spans, items, strict=True):
            if no_yaw:
                doc["axes"]["yaw"] = None
            seg_docs.append(doc)
            inside.append((q1 - q0, ind))
            label_time[doc["label"]] = label_time.get(doc["label"], 0.0) + (q1 - q0)
        weighted += inside
        bout_docs.append(_bout_doc(b, inside, seg, s, no_yaw=no_yaw))
    return seg_docs, bout_docs, weighted, label_time


def _axis_value(ind: Indicators, axis: str, name: str) -> float:
    v = getattr(ind.axes[axis], name)
    return float(v) if v is not None and math.isfinite(v) else float("nan")


def _same_posture(x: Indicators, y: Indicators, s: SessionSettings) -> bool:
    """Two straight stretches of a bout in the same posture: inclinations within the change-point limits and
    the pitch + roll swings within a factor ``change_swing_ratio``."""
    if x.status is not IndicatorStatus.OK or y.status is not IndicatorStatus.OK:
        return False
    dp = abs(_axis_value(x, "pitch", "inclination_mean") - _axis_value(y, "pitch", "inclination_mean"))
    dr = abs(_axis_value(x, "roll", "inclination_mean") - _axis_value(y, "roll", "inclination_mean"))
    sx = _axis_value(x, "pitch", "swing_mean") + _axis_value(x, "roll", "swing_mean")
    sy = _axis_value(y, "pitch", "swing_mean") + _axis_value(y, "roll", "swing_mean")
    if not all(math.isfinite(v) for v in (dp, dr, sx, sy)) or min(sx, sy) <= 0:
        return False
    return dp < s.change_pitch_deg and dr < s.change_roll_deg and max(sx, sy) / min(sx, sy) < s.change_swing_ratio


def _pooled_alternation(
    spans: list[tuple[float, float]], span_bouts: list[int], bout_steps: Sequence[NDArray], steady: NDArray
) -> dict[str, float]:
    """Alternating step time asymmetry over several straight stretches of one posture, as
    :func:`walkmon.gait.posture.step_time_alternation` fits one stretch: the step times with a level, a rate and a
    change of rate per stretch (per block of up to 20 steps of it) and one shared side difference ``d``
    (:func:`walkmon.gait.posture.fit_step_time_alternation`; the intervals then follow ``c_j + s_j k + d (-1)^k``).
    ``span_bouts``: per stretch, the index in ``bout_steps`` (each bout's steps) of the bout it lies in. Each step's
    side is the parity of its index in the bout: steps continue through a turn, so the feet are known across it.
    After a pause, or in another bout, the walker may lead with either foot: such stretches take the side that their
    own fit gives relative to the stretches before (this choice can only favour a difference, so the classifier's
    ratio threshold, not the interval alone, guards symmetric walks, with the interval widened for the choices made),
    and those whose side no fit of their own can tell (too few steps for a fit with a degree of freedom left) are
    left out: with the side unknown their intervals would count against a limp as often as for it (the
    simulator's unkind sessions: a dragged-foot bout of 7 pairs, ratio 1.21, read 1.13 with one such pair of the
    next bout added). The reference is the largest stretch group that has a fit. Returns ``ratio``,
    ``ratio_ci_low`` and ``n_pairs`` (pairs of intervals) like ``alternation``."""
    from walkmon.gait.posture import fit_step_time_alternation, step_time_evidence, step_time_intervals

    rows: list[tuple[int, float, float, float, int]] = []  # per step: (stretch, index in bout, side, time, group)
    # a pause: an interval beyond 1.6 x its bout's median step
    long = {k: 1.6 * float(np.median(np.diff(bout_steps[k]))) if len(bout_steps[k]) > 1 else float("inf")
            for k in set(span_bouts)}
    group = 0
    for j, (q0, q1) in enumerate(spans):
        steps = bout_steps[span_bouts[j]]
        if j > 0:
            between = steps[(steps >= spans[j - 1][1] - 1e-6) & (steps <= q0 + 1e-6)]
            if span_bouts[j - 1] != span_bouts[j] or between.size < 2 or np.any(np.diff(between) > long[span_bouts[j]]):
                group += 1  # a pause, another bout (or no step seen) before the stretch: the leading foot is unknown
        st = steady[(steady >= q0) & (steady <= q1)]
        idx = np.searchsorted(steps, st - 1e-6)
        rows += [(j, float(i), 0.5 if i % 2 == 1 else -0.5, float(t), group) for i, t in zip(idx, st, strict=True)]
    r = np.array(rows, dtype=float).reshape(-1, 5)
    n_intervals = step_time_intervals(r[:, :4])[0].size
    if n_intervals < 6:
        return {"ratio": float("nan"), "ratio_ci_low": float("nan"), "n_pairs": float(n_intervals // 2)}
    groups = sorted({int(g) for g in r[:, 4]}, key=lambda g: -int(np.sum(r[:, 4] == g)))
    free = 0  # groups whose side was chosen to agree with the reference's
    if len(groups) > 1:
        fits = [(g, f) for g in groups if (f := fit_step_time_alternation(r[r[:, 4] == g, :4])) is not None]
        r = r[np.isin(r[:, 4], [g for g, _ in fits])]
        for g, f in fits[1:]:
            if f[0] * fits[0][1][0] < 0:
                r[r[:, 4] == g, 2] *= -1.0
        free = max(len(fits) - 1, 0)
    # each free side was chosen to agree, so the difference is the best of 2 ** free arrangements: the interval is
    # widened for that many (Bonferroni). Without it, three bouts of 2 pairs each, symmetric with 30 ms of noise on
    # each interval, passed the foot-drag evidence 6.5 % of the time; with it 2.0 % (600 draws; 7 and 2.8 % with the
    # interval fit of before 2026-11-28; tests/gait/test_session.py holds it under 4 %)
    return step_time_evidence(r[:, :4], min_pairs=3, tests=2**free)


def _pooled_classification(
    spans: list[tuple[float, float]], inds: list[Indicators], span_bouts: list[int], bout_steps: Sequence[NDArray],
    steady: NDArray, kind: str, base: Mapping[str, Any] | None,
) -> tuple[Classification, dict[str, Any]]:
    """One label for the straight stretches of one posture (``span_bouts``, ``bout_steps``: as
    :func:`_pooled_alternation` takes them): the classifier on their duration-weighted indicators, with the
    alternating-step evidence pooled (:func:`_pooled_alternation`, the step counts added); and the pooled indicators
    it classified."""
    from walkmon.gait.posture import classify

    if kind == "acc":  # accelerometer only: never a posture label (span_indicators says why)
        return inds[0].classification, inds[0].to_dict()
    w = [q1 - q0 for q0, q1 in spans]
    axes = _weighted_axes(list(zip(w, inds, strict=True)))
    n_steps = 0.0
    for ind in inds:
        n = ind.asymmetry.get("n_steps")
        n_steps += float(n) if n is not None and math.isfinite(n) else float(ind.axes["pitch"].n_cycles)
    alt = _pooled_alternation(spans, span_bouts, bout_steps, np.asarray(steady, dtype=float))
    swing: list[tuple[float, float]] = []
    for x, ind in zip(w, inds, strict=True):
        v = ind.asymmetry.get("step_swing_ratio")
        if v is not None and math.isfinite(v):
            swing.append((x, float(v)))
    cad = [(q1 - q0, ind.cadence_spm) for (q0, q1), ind in zip(spans, inds, strict=True)
           if math.isfinite(ind.cadence_spm)]
    doc = {
        "status": "ok",
        "cadence_spm": sum(k * v for k, v in cad) / sum(k for k, _ in cad) if cad else None,
        "axes": {ax: axes[ax].to_dict() for ax in AXES},
        "asymmetry": {"step_time_ratio": alt["ratio"], "step_time_ratio_ci_low": alt["ratio_ci_low"],
                      "step_time_n_pairs": alt["n_pairs"], "n_steps": n_steps,
                      "step_swing_ratio": sum(k * v for k, v in swing) / sum(k for k, _ in swing) if swing else None,
                      **({ROTATION_STEP_TIMES: 1.0} if kind == "angles" else {})},
    }
    cls = classify(doc, base)
    where = ", ".join(f"{q0:.1f}-{q1:.1f} s" for q0, q1 in spans)
    n_bouts = len(set(span_bouts))
    of, gaps = ("the bout", "turns and pauses") if n_bouts == 1 else (f"{n_bouts} bouts", "turns, pauses and stops")
    return Classification(cls.label, (*cls.reasons, f"one posture over {len(spans)} straight stretches of {of} "
                                      f"({where}; the {gaps} between them left out), labelled together")), doc


def label_within_uncertainty(
    cls: Classification, doc: Mapping[str, Any], spans: list[tuple[float, float]], t: NDArray,
    unc: ReferenceUncertainty | None, base: Mapping[str, Any] | None,
) -> Classification:
    """``cls`` when it holds for every pitch/roll reference within the uncertainty the spans carry (the
    classifier run with the inclinations and pitch extremums moved to the corners of +-``unc``), else
    ``unclassified`` with the reason: a label that a drift of the reference could change is not given."""
    from walkmon.gait.posture import classify

    if unc is None or cls.label == "unclassified":
        return cls
    m = np.zeros(t.shape, bool)
    for q0, q1 in spans:
        m |= (t >= q0) & (t <= q1)
    if not m.any():
        return cls
    u = unc.deg[m].max(axis=0)
    if not np.any(u > 0):
        return cls
    seen = set()
    for sp in (-1.0, 1.0):
        for sr in (-1.0, 1.0):
            axes = {k: dict(v) if isinstance(v, Mapping) else v for k, v in (doc.get("axes") or {}).items()}
            for ax, du in (("pitch", sp * u[0]), ("roll", sr * u[1])):
                for name in ("inclination_mean", "lmax_mean", "lmin_mean"):
                    v = axes.get(ax, {}).get(name)
                    if v is not None and math.isfinite(v):
                        axes[ax][name] = v + du
            seen.add(classify({**doc, "axes": axes}, base).label)
    if seen == {cls.label}:
        return cls
    why = [unc.reasons[i] for i in sorted({int(v) for v in unc.why[m] if v >= 0})]
    return Classification("unclassified", (
        *why, f"{cls.label} at the measured inclinations, but a reference within +-{u[0]:.1f} / +-{u[1]:.1f} deg "
        f"(pitch / roll) could make it {' or '.join(sorted(seen - {cls.label}))}: not labelled",
        *cls.reasons))


def _bout_doc(
    b: Any, inside: list[tuple[float, Indicators]], seg: Segmentation, s: SessionSettings, *, no_yaw: bool
) -> dict[str, Any]:
    """One walking bout's document: its steps, turns, indicators over its segments and its dominant label."""
    axes = _weighted_axes(inside)
    labels: dict[str, float] = {}
    for w, i in inside:
        labels[i.classification.label] = labels.get(i.classification.label, 0.0) + w
    label = max(labels, key=labels.__getitem__) if labels else "unclassified"
    reasons = ([f"{lab} over {w:.1f} s of {sum(labels.values()):.1f} s of straight walking" for lab, w in
                sorted(labels.items(), key=lambda kv: -kv[1])] if labels else
               ["no straight walking of at least "
                f"{s.min_piece_s:g} s between turns: not labelled"])
    return {
        "start_s": _num(b.start_s, 3), "end_s": _num(b.end_s, 3), "activity": "walking",
        "n_steps": b.n_steps, "cadence_spm": _num(b.cadence_spm, 2),
        "spectral_cadence_spm": _num(b.spectral_cadence_spm, 2),
        "n_turns": sum(1 for u in seg.turns if u.end_s > b.start_s and u.start_s < b.end_s),
        "axes": {ax: (None if no_yaw and ax == "yaw" else axes[ax].to_dict()) for ax in AXES},
        # over its segments, weighted by their durations, as the session's (documented; it was missing)
        "asymmetry": {k: _num(v) for k, v in _weighted_asym(inside).items()},
        "label": label, "reasons": reasons,
    }


def _dominant(
    label_time: dict[str, float], seg_docs: list[dict[str, Any]], seg: Segmentation
) -> tuple[str, float, Classification]:
    """The session's label: the posture of the most walking time, with its share and reasons."""
    total_labelled = sum(label_time.values())
    if label_time:
        dominant = max(label_time, key=label_time.__getitem__)
        share = label_time[dominant] / total_labelled
        dom_reasons = [f"{dominant} over {100 * share:.0f} % of the labelled walking time "
                       f"({label_time[dominant]:.1f} of {total_labelled:.1f} s)"]
        longest = max((d for d in seg_docs if d["label"] == dominant),
                      key=lambda d: (d["end_s"] or 0) - (d["start_s"] or 0))
        dom_reasons += longest["reasons"]
        return dominant, share, Classification(dominant, tuple(dom_reasons))
    why = "no walking bout" if not seg.bouts else "no straight walking segment long enough to measure"
    return "unclassified", float("nan"), Classification("unclassified", (why,))


def _not_upright_is_unknown(
    activity: NDArray, grid: NDArray, t: NDArray, a: NDArray, s: SessionSettings
) -> NDArray:
    """Still but tilted more than ``still_tilt_deg`` from upright: sitting, lying or bending down, not standing."""
    if t.size == 0:
        return activity
    p = np.interp(grid, t, a[:, 0])
    r = np.interp(grid, t, a[:, 2])
    out = activity.copy()
    out[(out == "standing") & ((np.abs(p) > s.still_tilt_deg) | (np.abs(r) > s.still_tilt_deg))] = "unknown"
    return out


def _settle_timeline(activity: NDArray, seg: Segmentation, s: SessionSettings) -> NDArray:
    """The per-hop timeline made consistent with the bout convention (walking from a bout's first to its last
    initial contact, pauses < 3 s joining bouts) and with what the body does between steps:

    * a **pause inside a bout** (the trunk still for >= 0.5 s) is ``standing`` from the last regular step
      before it to the first regular step after it (regular: its stride away from the pause is at most
      ``pause_factor`` x the bout's median stride; a weight shift in the pause taken for a step is passed
      over); the bout keeps it (Mobilise-D: a break < 3 s does not end a walking bout, and ``walking_s`` is
      the bouts' time), the timeline says what the person did;
    * **gait initiation and termination**: movement without a gait rhythm for at most ``transition_s`` between
      standing and a bout (the weight shift before the first contact, the closing step after the last) is
      ``standing``: the field counts it outside the bout, and the person stands on both feet; so is the tail
      of a turn on the spot (below the turn detector's 5 deg/s edge) before standing still;
    * a recording that **starts or ends mid-walk**: at most ``transition_s`` without detected steps between the
      recording's edge and a bout is ``walking`` (the step detector needs half a window of context, so the
      contacts nearest the edges are not found; the walker was walking).

    Longer stretches stay ``unknown`` (sitting down, bending, handling the camera), and so does any stretch the
    segmentation found the sensor handled in (``seg.handled``: tilted by more than its limit) or the recording
    has no samples in (``seg.gap``).
    """
    out = activity.copy()
    grid = np.asarray(seg.timeline_t_s, dtype=float)
    if grid.size < 2:
        return out
    hop = float(grid[1] - grid[0])
    still = np.asarray(seg.still, dtype=bool) if len(seg.still) == grid.size else np.zeros(grid.size, bool)
    handled = np.asarray(seg.handled, dtype=bool) if len(seg.handled) == grid.size else np.zeros(grid.size, bool)
    if len(seg.gap) == grid.size:
        handled |= np.asarray(seg.gap, dtype=bool)  # a gap in the recording stays unknown as a handled stretch does
    min_still = int(round(0.5 / hop))
    for b in seg.bouts:
        st = np.asarray(b.steps_s, dtype=float)
        if st.size < 5:
            continue
        long = s.pause_factor * float(np.median(st[2:] - st[:-2]))
        in_bout = (grid > b.start_s) & (grid < b.end_s)
        for i0, i1 in _runs(still & in_bout):
            if i1 - i0 < min_still:
                continue
            j = int(np.searchsorted(st, grid[i0])) - 1  # the last step before the still run
            while j >= 2 and st[j] - st[j - 2] > long:
                j -= 1
            k = int(np.searchsorted(st, grid[i1 - 1]))  # the first step after it
            while k <= st.size - 3 and st[k + 2] - st[k] > long:
                k += 1
            t0 = st[max(j, 0)]
            t1 = st[min(k, st.size - 1)]
            out[(grid > t0) & (grid < t1) & (out == "walking")] = "standing"
    max_n = int(round(s.transition_s / hop))
    for i0, i1 in _runs(out == "unknown"):
        if i1 - i0 > max_n or handled[i0:i1].any():
            continue
        before = out[i0 - 1] if i0 > 0 else "edge"
        after = out[i1] if i1 < out.size else "edge"
        sides = {before, after}
        if sides in ({"walking", "standing"}, {"turning", "standing"}):
            out[i0:i1] = "standing"
        elif sides == {"walking", "edge"}:
            out[i0:i1] = "walking"
    return out


def _weighted_asym(items: list[tuple[float, Indicators]]) -> dict[str, float]:
    keys = ("step_time_ratio", "step_swing_ratio", "step_time_asymmetry_pct", "swing_asymmetry_pct")
    out = {}
    for k in keys:
        vals = [(w, i.asymmetry.get(k, float("nan"))) for w, i in items]
        vals = [(w, v) for w, v in vals if v is not None and math.isfinite(v)]
        out[k] = sum(w * v for w, v in vals) / sum(w for w, _ in vals) if vals else float("nan")
    return out


#: How :func:`without_posture`'s reason starts (the report leaves the gravity angles out after it).
NO_POSTURE = "no posture:"


def without_posture(ind: Indicators, timeline: tuple, reason: str) -> tuple[Indicators, tuple]:
    """The analysis with no posture in it: for a sensor in another sensor's axes (``reason``: the axes warning),
    whose pitch and roll are not the trunk's (user review: a neck-pouch phone near upside down read 0-64 % upright
    in the report and the history, its pitch wrapping past -180 deg, the warning on stderr and in imu.json only).
    Pitch and roll figures become null (top level, bouts, segments; the timeline's pitch and roll empty), every
    label ``unclassified`` with the reason, and the reason joins ``input.notes``; steps, bouts, cadence, turns and
    yaw stay."""
    nan = float("nan")
    none = AxisIndicators(nan, nan, nan, nan, n_cycles=0)
    why = f"{NO_POSTURE} {reason}"
    session = {k: (dict(v) if isinstance(v, Mapping) else v) for k, v in ind.session.items()}
    for key in ("segments", "bouts"):
        docs = []
        for d in session.get(key) or ():
            axes = dict(d.get("axes") or {})
            axes.update({ax: none.to_dict() for ax in ("pitch", "roll") if ax in axes})
            docs.append({**d, "axes": axes, "label": "unclassified", "reasons": [why]})
        session[key] = docs
    summary = dict(session.get("summary") or {})
    if summary:
        labelled = sum(float(v or 0.0) for v in (summary.get("posture_time_s") or {}).values())
        summary.update(posture_time_s={"unclassified": _num(labelled, 2)} if labelled else {},
                       dominant_label="unclassified", dominant_share=1.0 if labelled else None)
        session["summary"] = summary
    inputs = dict(session.get("input") or {})
    inputs["notes"] = [*(inputs.get("notes") or []), reason]
    session["input"] = inputs
    axes = {**ind.axes, "pitch": none, "roll": none}
    rows = tuple((t, act, "unclassified" if act == "walking" else "", nan, nan, u)
                 for t, act, _label, _p, _r, u in timeline)
    return replace(ind, axes=axes, classification=Classification("unclassified", (why,)), session=session), rows


def _coverage_note(t: NDArray, seg: Segmentation, hop: float) -> list[str]:
    """A note when the activity's samples (an IMU's) span less of the recording than its angles (a video's)."""
    span = seg.timeline_t_s
    if not t.size or not len(span) or (span[0] - hop <= t[0] and span[-1] + hop >= t[-1]):
        return []
    return [f"the activity is known over {max(span[0] - hop / 2, t[0]):.1f}-{min(span[-1] + hop / 2, t[-1]):.1f} s "
            f"of the recording's "
            f"{t[0]:.1f}-{t[-1]:.1f} s (the IMU's samples): the seconds outside it are unknown"]


def timeline_rows(
    t: NDArray, a: NDArray, seg: Segmentation, seg_docs: list[dict[str, Any]], ref: NDArray,
    abs_deg: NDArray | None = None, step_s: float = 1.0, unc: ReferenceUncertainty | None = None,
) -> tuple[tuple[float, str, str, float, float, float], ...]:
    """``(t, activity, label, pitch, roll, ref_uncertainty_deg)`` every ``step_s`` from the first sample: pitch
    and roll relative to the upright reference (1 s means); label only for walking seconds inside a posture
    segment; the part of that reference's possible error the analysis bounds there (``unc``: the larger of its
    pitch and roll bounds, the largest over the second): what turns without a standing phase carried into it, or
    an unmeasured sensor tilt; 0 where none of that applies, which leaves the reference's own error (a stance or
    an assumed-upright first stride: a degree or so). Without it a pitch read after a turn, where only the turns
    could carry the reference, looked as certain as one next to a standing phase (a walker who straightened up
    inside the only turn read 14 deg bent for 25 s of upright walking, its labels withheld but its pitch column
    not qualified). A second inside a gap of the recording (:meth:`Segmentation.in_gap`) with no sample in it
    has no row. A second outside the span the activity was found over (a video's seconds before or after its IMU's
    samples) is ``unknown``: the nearest second's activity was given there (a walk read as walking for 9 s after
    its IMU stopped, a stance as walking before it started)."""
    if t.size == 0:
        return ()
    grid = np.arange(0.0, float(t[-1] - t[0]) + 1e-9, step_s) + float(t[0])
    act = seg.activity_at(grid)
    span = seg.timeline_t_s
    if len(span):
        hop = float(span[1] - span[0]) if len(span) > 1 else step_s
        act = np.where((grid < span[0] - hop / 2) | (grid > span[-1] + hop / 2), "unknown", act)  # as activity_s
    no_data = seg.in_gap(grid)
    bound = np.zeros(t.size) if unc is None else np.max(np.asarray(unc.deg, dtype=float), axis=1)
    rows = []
    for g, ac, gap in zip(grid, act, no_data, strict=True):
        m = (t >= g - 0.5 * step_s) & (t < g + 0.5 * step_s)
        if m.any():
            pr = np.mean(a[m][:, [0, 2]], axis=0) - ref[[0, 2]]
            u = float(np.max(bound[m]))
        elif gap:
            continue  # a second inside a gap of the recording has no row: no pitch or roll was measured in it
        else:
            pr = np.array([np.interp(g, t, a[:, 0]) - ref[0], np.interp(g, t, a[:, 2]) - ref[2]])
            u = float(np.interp(g, t, bound))
        label = ""
        if ac == "walking":
            label = "unclassified"
            for d in seg_docs:
                if d["start_s"] is not None and d["start_s"] <= g <= d["end_s"]:
                    label = d["label"]
                    break
        rows.append((float(g), str(ac), label, float(pr[0]), float(pr[1]), u))
    return tuple(rows)
