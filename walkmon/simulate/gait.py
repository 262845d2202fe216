"""A continuous-time model of a chest-worn camera during a scripted walk: orientation and position over time.

World frame = the camera's frame at t = 0 (x right, y down, z forward; see :mod:`walkmon.consts`), with the
camera standing upright and level at ``camera_height_m`` above a flat ground plane (the plane y = +height).

A session is 2 s of standing still, the scripted segments, then 2 s of standing still. Every parameter (speed,
gait amplitudes, posture offsets, cadence) moves between segments with a raised-cosine transition of
``transition_s``; the first transition after standing happens inside the walking segment, so standing stays
truly static. The gait is driven by a step phase ``phi`` (one unit per step) built from individually drawn
step durations (cycle-to-cycle variability, left/right asymmetry), through a C2 spline, so angles, angular rates
and accelerations are continuous:

* step frequency: vertical bob, pitch, forward speed modulation;
* stride frequency (half the step frequency): lateral sway, roll, yaw;
* harmonics on both, per-step amplitude variability, and a slow, smooth heading wander (the walker follows
  a gently curving line along the street, so the lateral offset stays within about a metre).

*Session scripts* (a script with ``turn:DEG`` or ``pause:S`` segments, or any script with ``stand_s = 0``) are taken
literally instead: no standing is added, a session that begins (ends) with a walk type starts (stops) mid-walk,
every start from standing is a gait initiation (cadence and amplitude ramp up over the first 2-3 steps) and every
stop a gait termination (the same, down), turns rotate the heading while stepping, and posture changes between
walk types take about 2 s. Their truth (activity and label per time, initial contacts, bouts) comes from
:meth:`GaitModel.timeline`, :meth:`GaitModel.step_times_s` and :meth:`GaitModel.bouts`; see
:mod:`walkmon.simulate.unkind` for the random "unkind session" generator.

The physical orientation is ``R = Ry(heading + yaw) Rx(pitch) Rz(roll)`` (turn about the vertical, then lean the
trunk); the truth angles are its decomposition with :func:`walkmon.consts.angles_deg_from_rotation`.
"""

from __future__ import annotations

import logging
import math
import re
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import CubicSpline

from walkmon.consts import angles_deg_from_rotation, rot_x, rot_y, rot_z, rotation_from_angles_deg
from walkmon.errors import InvalidInputError

__all__ = [
    "ACTIVITIES",
    "SESSION_TOKENS",
    "STANDING_S",
    "UNKNOWN_TOKENS",
    "WALK_TYPES",
    "GaitModel",
    "Segment",
    "SegmentParams",
    "TimelinePiece",
    "is_session_script",
    "parse_walk_script",
    "split_mount",
    "split_pitch_lr",
]

_log = logging.getLogger(__name__)

#: Walk types a script may name ("stand" is an extra standing-still pause inside a script).
WALK_TYPES = ("normal", "left_shoulder_down", "right_foot_drag", "bend", "stand")

#: Script tokens that make a script a literal *session script*: ``turn:DEGREES[:SECONDS]`` (> 0 turns right) and
#: ``pause:SECONDS`` (standing still between two walks, like ``stand``).
SESSION_TOKENS = ("turn", "pause", "sit", "pickup", "camera")

#: Session-script tokens of moving without a gait rhythm, the truth's ``unknown`` activity: ``sit:SECONDS``
#: (sit down, sit, stand up), ``pickup:SECONDS`` (bend down to pick something up and straighten again),
#: ``camera:SECONDS`` (handling the camera: irregular rotations of the chest mount while standing).
UNKNOWN_TOKENS = ("sit", "pickup", "camera")

#: Activities of the truth timeline (``unknown``: the :data:`UNKNOWN_TOKENS` pieces).
ACTIVITIES = ("standing", "walking", "turning", "unknown")

#: Script token of the camera's mount on the trunk: ``mount:PITCH[:ROLL]`` (degrees; pitch < 0 points the camera
#: down, roll > 0 clockwise seen from behind), anywhere in a script, e.g. ``mount:-15,normal:10``. A chest camera
#: is rarely level on the trunk (a strap or clip points it a little down at the path); the trunk's posture is what
#: walkmon measures, the camera's tilt on the trunk is what it must not mistake for posture (after a turn,
#: start-relative angles of a tilted camera read up to twice its tilt). Default: level (0, 0).
MOUNT_TOKEN = "mount"

#: Mount angles a script may ask for, degrees (absolute value): pitch, roll.
_MOUNT_LIMITS_DEG = (45.0, 20.0)

#: Script token of the walker's left/right difference in trunk pitch: ``lr:X`` adds a stride-frequency component
#: of X times the pitch's step-frequency amplitude to the pitch swing of every walk (default 0). Real trunks
#: pitch differently on the left and right steps: on the Mobilise-D lower backs (healthy and MS) the pitch
#: repeated once per stride (autocorrelation -0.4 at the step lag, +0.9 at the stride lag), i.e. X about 1-2.
LR_TOKEN = "lr"
_LR_MAX = 3.0
_LR_PHASE = 1.0  # rad, against the asymmetric walk's own stride component (no new random draw: lr:0 is as before)

#: Turn angles a script may ask for, degrees (absolute value).
_TURN_LIMITS_DEG = (10.0, 360.0)

#: Standing still at the start and at the end of every session, seconds.
STANDING_S = 2.0

#: Internal sampling rate of the model before spline interpolation, Hz.
_GRID_HZ = 1000.0

#: Distance from the hip pivot up to the chest camera, metres (bending the trunk moves the camera forward/down).
_HIP_TO_CAMERA_M = 0.45


@dataclass(frozen=True, slots=True)
class Segment:
    """One scripted segment: a walk type and its duration in seconds (walking time, standing excluded).

    ``turn`` segments carry their angle in ``turn_deg`` (> 0 right); their ``duration_s`` is 0 when the script
    leaves it to the model (drawn from a turning rate of 60-90 °/s on average).
    """

    walk: str
    duration_s: float
    turn_deg: float = 0.0


@dataclass(frozen=True, slots=True)
class TimelinePiece:
    """A stretch of the true timeline: ``activity`` (see :data:`ACTIVITIES`) and the posture ``label`` (the walk
    type while walking, empty otherwise) over ``[start_s, end_s)``; ``turn_deg`` for a turn."""

    start_s: float
    end_s: float
    activity: str
    label: str
    turn_deg: float = 0.0


@dataclass(frozen=True, slots=True)
class SegmentParams:
    """The drawn parameters of one segment (what meta.json records). Angles in degrees, amplitudes are 0-peak."""

    walk: str
    start_s: float
    end_s: float
    cadence_spm: float
    speed_mps: float
    pitch_offset_deg: float
    roll_offset_deg: float
    pitch_amplitude_deg: float
    roll_amplitude_deg: float
    yaw_amplitude_deg: float
    bob_amplitude_m: float
    sway_amplitude_m: float
    asymmetry: float
    step_jitter: float

    @property
    def walking(self) -> bool:
        return self.walk != "stand"

    def to_dict(self) -> dict[str, Any]:
        return {k: (round(v, 4) if isinstance(v, float) else v) for k, v in asdict(self).items()}


_SEGMENT_RE = re.compile(r"^([a-z_]+)(?::([0-9]*\.?[0-9]+))?$")
_TURN_RE = re.compile(r"^turn:([+-]?[0-9]*\.?[0-9]+)(?::([0-9]*\.?[0-9]+))?$")


def split_mount(script: str) -> tuple[str, tuple[float, float]]:
    """``(script without its mount token, (pitch, roll) of the camera on the trunk in degrees)``; (0, 0) without
    a ``mount:PITCH[:ROLL]`` token (see :data:`MOUNT_TOKEN`)."""
    if not isinstance(script, str):
        return script, (0.0, 0.0)
    rest, token = _script_token(script, MOUNT_TOKEN, "mount:PITCH[:ROLL]")
    if token is None:
        return script, (0.0, 0.0)
    try:
        vals = [float(v) for v in token.split(":")[1:]]
    except ValueError:
        vals = []
    if not 1 <= len(vals) <= 2 or not all(np.isfinite(vals)):
        msg = f"walk script {script!r}: cannot parse {token!r} (expected mount:PITCH or mount:PITCH:ROLL, degrees)"
        raise InvalidInputError(msg)
    pitch, roll = vals[0], (vals[1] if len(vals) > 1 else 0.0)
    if abs(pitch) > _MOUNT_LIMITS_DEG[0] or abs(roll) > _MOUNT_LIMITS_DEG[1]:
        msg = (f"walk script {script!r}: the camera's mount must be within +-{_MOUNT_LIMITS_DEG[0]:g} deg pitch and "
               f"+-{_MOUNT_LIMITS_DEG[1]:g} deg roll on the trunk, got {pitch:g}, {roll:g}")
        raise InvalidInputError(msg)
    _needs_walk(script, rest, "a mount token", "mount:-15,normal")
    return rest, (pitch, roll)


def _script_token(script: str, name: str, form: str) -> tuple[str, str | None]:
    """``(script without its NAME:... token, the token)``, or ``(script, None)`` without one; two are an error."""
    parts = [p.strip() for p in script.strip().split(",")]
    found = [p for p in parts if p.lower().split(":")[0] == name]
    if not found:
        return script, None
    if len(found) > 1:
        msg = f"walk script {script!r}: one {form} token at most"
        raise InvalidInputError(msg)
    return ",".join(p for p in parts if p not in found), found[0]


def _needs_walk(script: str, rest: str, what: str, example: str) -> None:
    if not rest:
        msg = f"walk script {script!r}: {what} needs a walk beside it, e.g. {example}"
        raise InvalidInputError(msg)


def split_pitch_lr(script: str) -> tuple[str, float]:
    """``(script without its lr token, X)``; 0 without an ``lr:X`` token (see :data:`LR_TOKEN`)."""
    if not isinstance(script, str):
        return script, 0.0
    rest, token = _script_token(script, LR_TOKEN, "lr:X")
    if token is None:
        return script, 0.0
    fields = token.split(":")[1:]
    try:
        value = float(fields[0]) if len(fields) == 1 else math.nan
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and 0.0 <= value <= _LR_MAX):
        msg = (f"walk script {script!r}: cannot parse {token!r} (expected lr:X, the left/right pitch difference "
               f"as a multiple of the pitch's step amplitude, 0-{_LR_MAX:g})")
        raise InvalidInputError(msg)
    _needs_walk(script, rest, "an lr token", "lr:1,normal")
    return rest, value


def is_session_script(segments: list[Segment], stand_s: float = STANDING_S) -> bool:
    """True when the script is taken literally (it has turns or pauses, or no standing is added at the ends)."""
    return stand_s == 0 or any(seg.walk in SESSION_TOKENS for seg in segments)


def _parse_turn(script: str, part: str) -> Segment:
    m = _TURN_RE.match(part)
    if not m:
        msg = (f"walk script {script!r}: cannot parse segment {part!r} "
               "(expected turn:DEGREES or turn:DEGREES:SECONDS, degrees > 0 turn right)")
        raise InvalidInputError(msg)
    deg = float(m.group(1))
    lo, hi = _TURN_LIMITS_DEG
    if not lo <= abs(deg) <= hi:
        msg = f"walk script {script!r}: turn angle {deg:g} must be between {lo:g} and {hi:g} degrees (either sign)"
        raise InvalidInputError(msg)
    dur = 0.0
    if m.group(2) is not None:
        dur = float(m.group(2))
        if not 0.3 <= dur <= 20.0:
            msg = f"walk script {script!r}: turn duration {dur:g} s must be between 0.3 and 20 s"
            raise InvalidInputError(msg)
    return Segment("turn", dur, deg)


def parse_walk_script(script: str, seconds: float | None = None, *, stand_s: float = STANDING_S) -> list[Segment]:
    """Segments of a walk script such as ``"normal"``, ``"normal:10,bend:10"`` or a session script
    ``"stand:3,normal:10,turn:180,normal:8,pause:2,bend:10,stand:1.5"`` (see :data:`SESSION_TOKENS`).

    A single walk type without a duration lasts ``seconds`` in total, standing included (so the session is
    ``seconds`` long: ``seconds - 2 * stand_s`` of walking). In a script with several segments each one needs
    its duration (walking seconds); the session then lasts their sum plus the standing at both ends.
    A ``mount:PITCH[:ROLL]`` token (:data:`MOUNT_TOKEN`) is checked and left out of the segments.
    Raises :class:`InvalidInputError` for unknown types or bad syntax.
    """
    if not isinstance(script, str) or not script.strip():
        msg = f"walk script must be a walk type or a list like 'normal:10,bend:10', got {script!r}"
        raise InvalidInputError(msg)
    script, _mount = split_mount(script)  # the camera's mount is no segment (checked there, kept by GaitModel)
    script, _lr = split_pitch_lr(script)  # nor is the walker's left/right pitch difference
    parts = [p.strip() for p in script.strip().lower().split(",")]
    segments: list[Segment] = []
    for part in parts:
        if part.startswith("turn:") or part == "turn":
            segments.append(_parse_turn(script, part))
            continue
        m = _SEGMENT_RE.match(part)
        if not m:
            msg = f"walk script {script!r}: cannot parse segment {part!r} (expected TYPE or TYPE:SECONDS)"
            raise InvalidInputError(msg)
        walk, dur = m.group(1), m.group(2)
        if walk not in WALK_TYPES and walk != "pause" and walk not in UNKNOWN_TOKENS:
            known = ", ".join((*WALK_TYPES, "pause", "turn", *UNKNOWN_TOKENS))
            msg = f"walk script {script!r}: unknown walk type {walk!r} (known: {known})"
            raise InvalidInputError(msg)
        if dur is None:
            if len(parts) > 1:
                msg = f"walk script {script!r}: segment {part!r} needs a duration, e.g. {walk}:10"
                raise InvalidInputError(msg)
            if seconds is None or not np.isfinite(seconds) or seconds <= 2 * stand_s:
                msg = f"--seconds must be more than {2 * stand_s:g} (the standing at both ends), got {seconds}"
                raise InvalidInputError(msg)
            duration = float(seconds) - 2 * stand_s
        else:
            duration = float(dur)
            if duration <= 0:
                msg = f"walk script {script!r}: segment {part!r} has a zero duration"
                raise InvalidInputError(msg)
        segments.append(Segment(walk, duration))
    if sum(s.duration_s for s in segments) > 3600:
        msg = f"walk script {script!r}: more than an hour of walking is not supported"
        raise InvalidInputError(msg)
    return segments


def _draw_params(walk: str, start_s: float, end_s: float, rng: np.random.Generator) -> SegmentParams:
    """Draw one segment's parameters; ranges follow the walk types described in issue 2."""
    # Values every type draws (in a fixed order, so seeds stay stable when a type changes its own ranges).
    def u(lo: float, hi: float) -> float:
        return float(rng.uniform(lo, hi))

    base = {
        "cadence_spm": u(105.0, 115.0),
        "speed_mps": u(1.12, 1.28),
        "pitch_amplitude_deg": u(0.8, 1.3),
        "roll_amplitude_deg": u(1.2, 2.0),
        "yaw_amplitude_deg": u(1.2, 2.0),
        "bob_amplitude_m": u(0.010, 0.015),
        "sway_amplitude_m": u(0.015, 0.025),
        "pitch_offset_deg": u(-0.5, 0.5),
        "roll_offset_deg": u(-0.5, 0.5),
        "asymmetry": 0.0,
        "step_jitter": 0.02,
    }
    extra = rng.uniform(size=4)
    if walk == "left_shoulder_down":
        base["roll_offset_deg"] = -5.0 - 2.0 * float(extra[0])
        base["pitch_offset_deg"] = -2.5 - 1.0 * float(extra[1])
        base["speed_mps"] *= 0.95
    elif walk == "right_foot_drag":
        base["cadence_spm"] = 80.0 + 10.0 * float(extra[0])
        base["speed_mps"] = 0.75 + 0.15 * float(extra[1])
        base["pitch_amplitude_deg"] = 2.5 + 1.0 * float(extra[2])
        base["roll_amplitude_deg"] = 4.0 + 1.5 * float(extra[3])
        base["yaw_amplitude_deg"] = 3.5 + 1.5 * float(extra[2])
        base["bob_amplitude_m"] *= 1.5
        base["sway_amplitude_m"] *= 1.8
        base["asymmetry"] = 0.35
        base["step_jitter"] = 0.04
    elif walk == "bend":
        base["pitch_offset_deg"] = -15.0 - 5.0 * float(extra[0])
        base["cadence_spm"] -= 5.0
        base["speed_mps"] *= 0.85
    elif walk == "stand":
        for k in (
            "speed_mps",
            "pitch_amplitude_deg",
            "roll_amplitude_deg",
            "yaw_amplitude_deg",
            "bob_amplitude_m",
            "sway_amplitude_m",
            "pitch_offset_deg",
            "roll_offset_deg",
        ):
            base[k] = 0.0
    return SegmentParams(walk=walk, start_s=start_s, end_s=end_s, **base)


def _smoothstep(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Raised cosine from 0 (x <= 0) to 1 (x >= 1)."""
    return 0.5 - 0.5 * np.cos(np.pi * np.clip(x, 0.0, 1.0))


@dataclass(frozen=True)
class GaitModel:
    """The camera trajectory of one scripted session, deterministic for a given script, duration and seed.

    ``pose(t_s)`` gives the orientation relative to frame 0 (N, 3, 3) and position (N, 3) in metres in the
    world (= camera 0) frame; ``angular_velocity_rps`` and ``acceleration_mps2`` give the exact derivatives the
    IMU model needs. Times outside ``[0, duration_s]`` are clamped. With a ``mount:PITCH[:ROLL]`` token in the
    script (:data:`MOUNT_TOKEN`) the camera (and the IMU in it) sits tilted on the trunk by ``mount_deg``: its
    orientation is the trunk's times that tilt, so the world frame is the upright trunk's at frame 0 (gravity
    along +y) and a session starting upright has the mount's angles at frame 0.
    """

    script: str
    seconds: float = 16.0
    seed: int = 0
    stand_s: float = STANDING_S
    transition_s: float = 1.0
    camera_height_m: float = 1.3
    segments: tuple[SegmentParams, ...] = field(init=False)
    duration_s: float = field(init=False)
    standing_intervals_s: tuple[tuple[float, float], ...] = field(init=False)
    literal: bool = field(init=False)
    pieces: tuple[TimelinePiece, ...] = field(init=False)
    #: (pitch, roll) of the camera on the trunk, degrees (from the script's mount token; (0, 0): level)
    mount_deg: tuple[float, float] = field(init=False)
    #: the walker's left/right pitch difference (from the script's lr token, :data:`LR_TOKEN`; 0: none)
    pitch_lr: float = field(init=False)
    _splines: dict[str, CubicSpline] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not (np.isfinite(self.stand_s) and self.stand_s >= 0.0):
            msg = f"standing time must be >= 0 s, got {self.stand_s}"
            raise InvalidInputError(msg)
        if not (np.isfinite(self.transition_s) and 0.0 < self.transition_s <= 5.0):
            msg = f"transition time must be in (0, 5] s, got {self.transition_s}"
            raise InvalidInputError(msg)
        walk_script, mount = split_mount(self.script)
        object.__setattr__(self, "mount_deg", mount)
        walk_script, lr = split_pitch_lr(walk_script)
        object.__setattr__(self, "pitch_lr", lr)
        script_segments = parse_walk_script(walk_script, self.seconds, stand_s=self.stand_s)
        literal = is_session_script(script_segments, self.stand_s)
        object.__setattr__(self, "literal", literal)
        if literal:
            _build_session(self, script_segments)
            self._align_pieces_to_contacts()
            _log.debug("session model %r seed %d: %.1f s, %d pieces", self.script, self.seed, self.duration_s,
                       len(self.pieces))
            return
        rng = np.random.default_rng(self.seed)
        t0 = self.stand_s
        params = []
        standing = [(0.0, self.stand_s)] if self.stand_s > 0 else []
        for seg in script_segments:
            params.append(_draw_params(seg.walk, t0, t0 + seg.duration_s, rng))
            if seg.walk == "stand":
                standing.append((t0, t0 + seg.duration_s))
            t0 += seg.duration_s
        duration = t0 + self.stand_s
        if self.stand_s > 0:
            standing.append((t0, duration))
        object.__setattr__(self, "segments", tuple(params))
        object.__setattr__(self, "duration_s", float(duration))
        object.__setattr__(self, "standing_intervals_s", tuple(_merge_intervals(standing)))
        object.__setattr__(self, "_splines", self._build(rng))
        pieces = [TimelinePiece(0.0, self.stand_s, "standing", "")] if self.stand_s > 0 else []
        for p in params:
            pieces.append(TimelinePiece(p.start_s, p.end_s, "walking" if p.walking else "standing",
                                        p.walk if p.walking else ""))
        if self.stand_s > 0:
            pieces.append(TimelinePiece(t0, duration, "standing", ""))
        object.__setattr__(self, "pieces", tuple(pieces))
        self._align_pieces_to_contacts()
        _log.debug("gait model %r seed %d: %.1f s, %d segments", self.script, self.seed, duration, len(params))

    # ----------------------------------------------------------------------------------------------- build
    def _weights(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """Blend weights (len(t), n_segments + 2) of [standing start, segments..., standing end]; sum to 1."""
        kinds = ["stand", *(p.walk for p in self.segments), "stand"]
        bounds = [self.stand_s, *(p.end_s for p in self.segments)]  # boundary i is between kind i and i+1
        tr = self.transition_s
        # cumulative "progress" c_i(t) in [0,1] through boundary i; weight of kind k = c_{k-1} - c_k
        prog = []
        for i, b in enumerate(bounds):
            a_stand, b_stand = kinds[i] == "stand", kinds[i + 1] == "stand"
            seg_len = [self.stand_s, *(p.end_s - p.start_s for p in self.segments), self.stand_s]
            width = min(tr, max(seg_len[i + 1], 1e-3), max(seg_len[i], 1e-3))
            if a_stand and not b_stand:
                start = b  # start walking: the transition lies inside the walking segment, standing stays static
            elif b_stand and not a_stand:
                start = b - width  # stop walking before the standing starts
            else:
                start = b - width / 2
            prog.append(_smoothstep((t - start) / width))
        c = np.stack([np.ones_like(t), *prog, np.zeros_like(t)], axis=1)
        return c[:, :-1] - c[:, 1:]

    def _build(self, rng: np.random.Generator) -> dict[str, CubicSpline]:
        T = self.duration_s
        t = np.arange(-0.5, T + 0.5 + 1.0 / _GRID_HZ, 1.0 / _GRID_HZ)
        w = self._weights(t)
        all_params = [None, *self.segments, None]

        def blend(name: str) -> NDArray[np.float64]:
            vals = np.array([0.0 if p is None else getattr(p, name) for p in all_params])
            return w @ vals

        # cadence: standing parts borrow the cadence of the nearest walking segment
        walking = [p for p in self.segments if p.walking]
        cad_default = walking[0].cadence_spm if walking else 100.0
        cad_vals: Any = []
        last = cad_default
        for p in all_params:
            if p is not None and p.walking:
                last = p.cadence_spm
            cad_vals.append(last if (p is not None and p.walking) else np.nan)
        cad_vals = np.array(cad_vals)
        idx = np.where(~np.isnan(cad_vals))[0]
        if idx.size:
            cad_vals = np.interp(np.arange(cad_vals.size), idx, cad_vals[idx])
        else:
            cad_vals[:] = cad_default
        cadence_spm = w @ cad_vals
        asym = blend("asymmetry")
        jitter = blend("step_jitter")

        # gait envelope: 1 while walking, 0 while standing
        walk_mask = np.array([0.0 if (p is None or not p.walking) else 1.0 for p in all_params])
        envelope = w @ walk_mask

        # step times: each step's duration from the local cadence, jitter, and left/right asymmetry
        step_t = [t[0]]
        k = 0
        while step_t[-1] < t[-1] + 2.0:
            tk = step_t[-1]
            j = min(int((tk - t[0]) * _GRID_HZ), t.size - 1)
            j = max(j, 0)
            period = 60.0 / cadence_spm[j]
            side = 1.0 if k % 2 == 0 else -1.0  # even steps: right foot
            factor = 1.0 + side * 0.5 * asym[j] * 0.6 + jitter[j] * rng.standard_normal()
            step_t.append(tk + period * max(factor, 0.5))
            k += 1
        step_t_arr = np.array(step_t)
        phase_spline = CubicSpline(step_t_arr, np.arange(step_t_arr.size, dtype=float))
        phi = phase_spline(t)
        if np.any(np.diff(phi) <= 0):  # pragma: no cover - guarded by the jitter limits
            msg = "internal error: non-monotonic gait phase"
            raise RuntimeError(msg)

        # per-step amplitude variability (smooth in phase), one channel per signal
        n_steps = step_t_arr.size + 2
        var = 1.0 + 0.10 * rng.standard_normal((n_steps, 5))
        var_spline = CubicSpline(np.arange(n_steps, dtype=float), var)
        v = var_spline(phi)  # (N, 5)
        ph = rng.uniform(0.0, 2.0 * np.pi, size=12)  # harmonic phases
        h2 = rng.uniform(0.15, 0.3, size=5)  # harmonic weights

        two_pi_phi = 2.0 * np.pi * phi  # step cycle
        stride = np.pi * phi  # stride cycle (half the step frequency); right step starts at stride phase 0
        # --- step-frequency signals
        pitch_osc = blend("pitch_amplitude_deg") * v[:, 0] * (
            np.cos(two_pi_phi + ph[0]) + h2[0] * np.cos(2 * two_pi_phi + ph[1]) + 0.5 * asym * np.cos(stride + ph[2])
            + self.pitch_lr * np.cos(stride + ph[2] + _LR_PHASE)
        )
        bob = blend("bob_amplitude_m") * v[:, 1] * (
            np.cos(two_pi_phi) + h2[1] * np.cos(2 * two_pi_phi + ph[3]) + 0.6 * asym * np.cos(stride + ph[4])
        )
        # --- stride-frequency signals (odd harmonics of the stride plus a little step-frequency content)
        roll_osc = blend("roll_amplitude_deg") * v[:, 2] * (
            np.sin(stride + ph[5]) + h2[2] * np.sin(3 * stride + ph[6]) + 0.2 * np.cos(two_pi_phi + ph[7])
            + asym * 0.5 * np.cos(two_pi_phi)
        )
        yaw_osc = blend("yaw_amplitude_deg") * v[:, 3] * (
            np.sin(stride + ph[8]) + h2[3] * np.sin(3 * stride + ph[9]) + 0.3 * asym * np.cos(two_pi_phi)
        )
        sway = blend("sway_amplitude_m") * v[:, 4] * (np.sin(stride + ph[10]) + h2[4] * np.sin(3 * stride + ph[11]))

        # position: forward speed (modulated at step frequency); the walker follows a gently curving line along
        # the street, lateral = f(distance walked), so the heading (the line's slope) wanders smoothly by a few
        # degrees, only while walking, and the lateral offset stays bounded (the walker never reaches a wall)
        i0 = np.searchsorted(t, 0.0)
        speed = blend("speed_mps") * (1.0 + 0.06 * envelope * np.cos(two_pi_phi + ph[0] + 0.8))
        walked_m = np.cumsum(speed) / _GRID_HZ
        walked_m -= walked_m[i0]
        wavenumbers = 2.0 * np.pi / rng.uniform(20.0, 60.0, size=3)  # wavenumbers, rad/m
        amps = rng.uniform(0.1, 0.25, size=3) * rng.choice([-1.0, 1.0], size=3)  # metres
        lateral_m = sum(a * (1.0 - np.cos(kk * walked_m)) for a, kk in zip(amps, wavenumbers, strict=True))
        hd = np.arctan(sum(a * kk * np.sin(kk * walked_m) for a, kk in zip(amps, wavenumbers, strict=True)))
        heading_deg = np.degrees(hd)

        pitch_off = blend("pitch_offset_deg")
        roll_off = blend("roll_offset_deg")
        pitch_deg = pitch_off + envelope * pitch_osc
        roll_deg = roll_off + envelope * roll_osc
        yaw_deg = heading_deg + envelope * yaw_osc

        fwd = np.stack([np.sin(hd), np.zeros_like(hd), np.cos(hd)], axis=1)
        right = np.stack([np.cos(hd), np.zeros_like(hd), -np.sin(hd)], axis=1)
        path = np.stack([lateral_m, np.zeros_like(hd), walked_m], axis=1)
        lean = np.radians(pitch_off)  # negative when bent forward
        pos = (
            path
            + (envelope * sway)[:, None] * right
            + fwd * (-_HIP_TO_CAMERA_M * np.sin(lean))[:, None]
        )
        pos[:, 1] += -envelope * bob + _HIP_TO_CAMERA_M * (1.0 - np.cos(lean))
        pos -= pos[i0]

        # static before 0 and after the end (the clamp makes this moot, but keeps the splines flat there)
        return {
            "angles": CubicSpline(t, np.stack([pitch_deg, yaw_deg, roll_deg], axis=1)),
            "position": CubicSpline(t, pos),
            "phase": phase_spline,
            "envelope": CubicSpline(t, envelope),
        }

    # ------------------------------------------------------------------------------------------- queries
    def _clamp(self, t_s: ArrayLike) -> NDArray[np.float64]:
        return np.clip(np.atleast_1d(np.asarray(t_s, dtype=float)), 0.0, self.duration_s)

    def _frozen(self, t_s: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """Clamped times with standing times moved to the middle of their interval (the splines ring for a few
        milliseconds next to a transition; this keeps standing exactly static), and the standing mask."""
        tc = self._clamp(t_s)
        standing = np.zeros(tc.shape, bool)
        for a, b in self.standing_intervals_s:
            inside = (tc >= a) & (tc <= b)
            tc[inside] = 0.5 * (a + b)
            standing |= inside
        return tc, standing

    def body_angles_deg(self, t_s: ArrayLike) -> NDArray[np.float64]:
        """The model's physical angles (pitch, heading+yaw, roll) in degrees, ``R = Ry(yaw) Rx(pitch) Rz(roll)``."""
        return self._splines["angles"](self._frozen(t_s)[0])

    def rotation(self, t_s: ArrayLike) -> NDArray[np.float64]:
        """Orientation of the camera in the world (camera-t directions into the world frame), shape (N, 3, 3):
        the trunk's, times the camera's mount on it."""
        a = np.radians(self.body_angles_deg(t_s))
        r = rot_y(a[:, 1]) @ rot_x(a[:, 0]) @ rot_z(a[:, 2])
        return r @ self._mount() if self.mount_deg != (0.0, 0.0) else r

    def _mount(self) -> NDArray[np.float64]:
        """The camera's orientation on the trunk (camera directions into trunk directions), (3, 3): the mount's
        pitch and roll in walkmon's angle convention (:mod:`walkmon.consts`)."""
        return rotation_from_angles_deg(self.mount_deg[0], 0.0, self.mount_deg[1])

    def position_m(self, t_s: ArrayLike) -> NDArray[np.float64]:
        """Camera position in the world (= camera 0) frame, metres, shape (N, 3)."""
        return self._splines["position"](self._frozen(t_s)[0])

    def pose(self, t_s: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(rotation (N,3,3), position_m (N,3))`` at the given times."""
        return self.rotation(t_s), self.position_m(t_s)

    def truth_angles_deg(self, t_s: ArrayLike) -> NDArray[np.float64]:
        """(pitch, yaw, roll) in degrees of :meth:`rotation` in walkmon's convention, shape (N, 3)."""
        return angles_deg_from_rotation(self.rotation(t_s))

    def angular_velocity_rps(self, t_s: ArrayLike) -> NDArray[np.float64]:
        """Body rate in the camera frame (``dR/dt = R skew(w)``), rad/s, shape (N, 3); exact from the splines."""
        tc, standing = self._frozen(t_s)
        a = np.radians(self._splines["angles"](tc))
        da = np.radians(self._splines["angles"](tc, 1)) * (~standing)[:, None]
        rx, rz = rot_x(a[:, 0]), rot_z(a[:, 2])
        e_x, e_y, e_z = np.eye(3)
        # R = Ry(psi) Rx(theta) Rz(phi):  w = (Rx Rz)^T e_y psi' + Rz^T e_x theta' + e_z phi'
        w_yaw = np.swapaxes(rx @ rz, -1, -2) @ e_y
        w_pitch = np.swapaxes(rz, -1, -2) @ e_x
        w = w_yaw * da[:, 1:2] + w_pitch * da[:, 0:1] + e_z[None, :] * da[:, 2:3]
        # the camera's rate is the trunk's in the camera's axes (R_cam = R_trunk M: w_cam = M^T w_trunk)
        return w @ self._mount() if self.mount_deg != (0.0, 0.0) else w

    def acceleration_mps2(self, t_s: ArrayLike) -> NDArray[np.float64]:
        """Second derivative of the position in the world frame, m/s², shape (N, 3)."""
        tc, standing = self._frozen(t_s)
        return self._splines["position"](tc, 2) * (~standing)[:, None]

    def step_phase(self, t_s: ArrayLike) -> NDArray[np.float64]:
        """Step phase (one unit per step; even integers start a right step)."""
        return self._splines["phase"](self._clamp(t_s))

    def is_standing(self, t_s: ArrayLike) -> NDArray[np.bool_]:
        """True where the session is in a standing interval (start, end, or a scripted ``stand``)."""
        tc = np.atleast_1d(np.asarray(t_s, dtype=float))
        out = np.zeros(tc.shape, bool)
        for a, b in self.standing_intervals_s:
            out |= (tc >= a) & (tc <= b)
        return out

    def meta(self) -> dict[str, Any]:
        """What meta.json records about the walk."""
        return {
            "walk": self.script,
            "seed": self.seed,
            "duration_s": round(self.duration_s, 6),
            "standing_s": self.stand_s,
            "transition_s": self.transition_s,
            "standing_intervals_s": [[round(a, 6), round(b, 6)] for a, b in self.standing_intervals_s],
            "camera_height_m": self.camera_height_m,
            "mount_deg": {"pitch": self.mount_deg[0], "roll": self.mount_deg[1]},
            "pitch_lr": self.pitch_lr,
            "segments": [p.to_dict() for p in self.segments],
        }

    # ------------------------------------------------------------------------------------------ truth
    def _align_pieces_to_contacts(self) -> None:
        """Walking starts at a bout's first initial contact and stops at its last (the field's bout convention):
        move each standing/stepping boundary of the timeline to that contact. The motion is not changed: the
        weight shift before the first contact and the closing step after the last are standing in the truth."""
        steps, _ = self.step_times_s()
        pieces = list(self.pieces)
        still = ("standing", "unknown")
        if steps.size == 0:
            return
        for i in range(len(pieces) - 1):
            a, b = pieces[i], pieces[i + 1]
            if a.activity in still and b.activity not in still:  # gait initiation
                after = steps[steps > a.end_s]
                if after.size and after[0] < b.end_s:
                    t = float(after[0])
                    pieces[i], pieces[i + 1] = replace(a, end_s=t), replace(b, start_s=t)
            elif a.activity not in still and b.activity in still:  # gait termination
                before = steps[steps < b.start_s]
                if before.size and before[-1] > a.start_s:
                    t = float(before[-1])
                    pieces[i], pieces[i + 1] = replace(a, end_s=t), replace(b, start_s=t)
        object.__setattr__(self, "pieces", tuple(pieces))

    def timeline(self, t_s: ArrayLike) -> tuple[NDArray[np.str_], NDArray[np.str_]]:
        """True ``(activity, label)`` at each time: activity in :data:`ACTIVITIES`, label the walk type while
        walking and ``""`` otherwise (a posture change switches the label in the middle of its transition)."""
        t = np.atleast_1d(np.asarray(t_s, dtype=float))
        activity = np.full(t.shape, "standing", dtype=object)
        label = np.full(t.shape, "", dtype=object)
        for piece in self.pieces:
            inside = (t >= piece.start_s) & (t < piece.end_s)
            activity[inside] = piece.activity
            label[inside] = piece.label
        if self.pieces:  # the last instant belongs to the last piece
            last = self.pieces[-1]
            activity[t >= last.end_s] = last.activity
            label[t >= last.end_s] = last.label
        return activity.astype(str), label.astype(str)

    def step_times_s(self) -> tuple[NDArray[np.float64], NDArray[np.str_]]:
        """True initial contacts within the session and their foot (``"R"``/``"L"``).

        A step's initial contact is where the step phase passes k + 1/2 (the trunk at its lowest, the upward
        acceleration at its peak) while the walker is stepping (gait envelope >= 0.4, not standing). In session
        scripts the bob's harmonics are phased so that this is the peak of the vertical acceleration; in classic
        scripts the peak may lie up to about a tenth of a step away.
        """
        T = self.duration_s
        t = np.arange(0.0, T + 0.5 / _GRID_HZ, 1.0 / _GRID_HZ)
        phi = self._splines["phase"](t)
        k = np.arange(np.ceil(phi[0] - 0.5), np.floor(phi[-1] - 0.5) + 1) + 0.5
        if k.size == 0:
            return np.zeros(0), np.zeros(0, dtype=str)
        times = np.interp(k, phi, t)
        env = self._splines["envelope"](times)
        keep = (env >= 0.4) & ~self.is_standing(times) & (times > 0.0) & (times < T)
        sides = np.where(np.floor(k[keep]).astype(int) % 2 == 0, "R", "L")
        return times[keep], sides

    def bouts(self) -> list[dict[str, Any]]:
        """True walking bouts: the initial contacts between two standing (or unknown) phases, turns included.

        Each bout: ``start_s``/``end_s`` (first and last initial contact), ``n_steps``, ``cadence_spm``
        (``60 * (n_steps - 1) / (end_s - start_s)``, None under 2 steps), ``turns`` (count) and ``labels`` (the
        walk types in it, in order); the field's >= 4 steps rule is left to the evaluation.
        """
        times, _ = self.step_times_s()
        out: list[dict[str, Any]] = []
        if times.size == 0:
            return out
        group = [0]
        breaks = [(p.start_s, p.end_s) for p in self.pieces if p.activity in ("standing", "unknown")]
        for i in range(1, times.size):
            if any(times[i - 1] <= a and b <= times[i] for a, b in breaks):
                out.append(self._bout(times[group]))
                group = []
            group.append(i)
        out.append(self._bout(times[group]))
        return out

    def _bout(self, times: NDArray[np.float64]) -> dict[str, Any]:
        a, b = float(times[0]), float(times[-1])
        labels: list[str] = []
        turns = 0
        for piece in self.pieces:
            if piece.end_s <= a or piece.start_s >= b:
                continue
            if piece.activity == "turning":
                turns += 1
            elif piece.label and (not labels or labels[-1] != piece.label):
                labels.append(piece.label)
        return {
            "start_s": round(a, 4),
            "end_s": round(b, 4),
            "n_steps": int(times.size),
            "cadence_spm": round(60.0 * (times.size - 1) / (b - a), 4) if times.size >= 2 else None,
            "turns": turns,
            "labels": labels,
        }


def _merge_intervals(intervals: list[tuple[float, float]]) -> list[tuple[float, float]]:
    out: list[tuple[float, float]] = []
    for a, b in sorted(intervals):
        if out and a <= out[-1][1] + 1e-9:
            out[-1] = (out[-1][0], max(out[-1][1], b))
        else:
            out.append((a, b))
    return out


# ================================================================================================ session scripts
def _smootherstep(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Quintic step from 0 (x <= 0) to 1 (x >= 1) with zero first and second derivatives at both ends (C2)."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * x * (x * (6.0 * x - 15.0) + 10.0)


#: Script pieces without stepping: standing still and moving without a gait rhythm.
_STILL_KINDS = ("stand", *UNKNOWN_TOKENS)


def _unknown_motion(
    kind: str, t: NDArray[np.float64], a: float, b: float, heading_rad: NDArray[np.float64], rng: np.random.Generator
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Angle (pitch, yaw, roll; degrees) and position (metres, world frame) offsets of an unknown piece over
    ``[a, b]`` on the grid ``t``, zero outside it and C2 at its ends (the IMU model differentiates twice).

    * ``sit``: sit down over 1.5-2.5 s (trunk flexes forward 25-40 deg, the chest drops 0.40-0.50 m), sit with the
      trunk 22-35 deg from upright (slumped forward or reclined against a backrest: a chest sensor reads well
      outside standing's +-10 deg), a slow postural sway, stand up the same way;
    * ``pickup``: bend down to pick something up: trunk flexion 45-75 deg with knees bent (the chest drops
      0.25-0.45 m and moves forward), held 0.5-2 s, and up again, each way 0.8-1.5 s;
    * ``camera``: handling the camera (straightening the strap or the mount) while standing: a few irregular
      adjustments (one per ~1.2 s, overlapping), each a smooth 0.6-1.8 s rotation of 5-20 deg per axis and up to
      2 cm of motion, there and back.
    """
    ang = np.zeros((t.size, 3))
    pos = np.zeros((t.size, 3))
    dur = b - a
    fwd = np.stack([np.sin(heading_rad), np.zeros_like(heading_rad), np.cos(heading_rad)], axis=1)

    def ramp(t0: float, width: float) -> NDArray[np.float64]:
        return _smootherstep((t - t0) / width)

    def bump(t0: float, width: float) -> NDArray[np.float64]:  # 0 -> 1 -> 0 over [t0, t0 + width], C2
        x = np.clip((t - t0) / width, 0.0, 1.0)
        return (4.0 * x * (1.0 - x)) ** 3

    def smooth_noise(std: float, max_hz: float) -> NDArray[np.float64]:  # random knots every 1 / (2 max_hz)
        n = int(np.ceil((dur + 1.0) * max_hz * 2)) + 2
        knots = np.linspace(a - 0.5, b + 0.5, n)
        return CubicSpline(knots, rng.standard_normal(n) * std)(np.clip(t, a - 0.5, b + 0.5))

    if kind == "sit":
        down = float(min(rng.uniform(1.5, 2.5), 0.35 * dur))
        flex = float(rng.uniform(25.0, 40.0))
        seat = float(rng.uniform(22.0, 35.0)) * float(rng.choice([-1.0, 1.0]))  # < 0 slumped forward
        drop = float(rng.uniform(0.40, 0.50))
        w = ramp(a, down) * (1.0 - ramp(b - down, down))
        sway = smooth_noise(0.4, 0.5) * ramp(a + down, 0.5) * (1.0 - ramp(b - down - 0.5, 0.5))
        ang[:, 0] = seat * w - flex * (bump(a, down) + bump(b - down, down)) + sway
        ang[:, 2] = 0.5 * sway
        pos[:, 1] = drop * w
        pos += (0.15 * w)[:, None] * fwd
    elif kind == "pickup":
        move = float(min(rng.uniform(0.8, 1.5), 0.45 * dur))
        flex = float(rng.uniform(45.0, 75.0))
        w = ramp(a, move) * (1.0 - ramp(b - move, move))
        lean = np.radians(flex * w)
        ang[:, 0] = -flex * w
        ang[:, 2] = float(rng.uniform(-8.0, 8.0)) * w
        pos[:, 1] = _HIP_TO_CAMERA_M * (1.0 - np.cos(lean)) + float(rng.uniform(0.15, 0.30)) * w
        pos += (_HIP_TO_CAMERA_M * np.sin(lean))[:, None] * fwd
    else:  # camera: a few irregular adjustments (grab, turn or tilt, let go), each its own size and length
        n = max(2, int(dur / 1.2))
        starts = np.sort(rng.uniform(a, b - 0.6, size=n))
        for t0 in starts:
            width = float(min(rng.uniform(0.6, 1.8), b - t0))
            shape = bump(float(t0), width)
            ang += shape[:, None] * rng.uniform(5.0, 20.0, size=3) * rng.choice([-1.0, 1.0], size=3)
            pos += shape[:, None] * rng.uniform(-0.02, 0.02, size=3)
    return ang, pos


#: Parameters blended between the pieces of a walking run (posture and gait amplitudes).
_BLENDED = (
    "cadence_spm",
    "speed_mps",
    "pitch_offset_deg",
    "roll_offset_deg",
    "pitch_amplitude_deg",
    "roll_amplitude_deg",
    "yaw_amplitude_deg",
    "bob_amplitude_m",
    "sway_amplitude_m",
    "asymmetry",
    "step_jitter",
)


@dataclass(slots=True)
class _Piece:
    """A piece of a session script while it is being laid out (times are filled in as the runs are stepped)."""

    kind: str  # a walk type, "turn", "stand" or one of UNKNOWN_TOKENS
    duration_s: float
    params: SegmentParams
    turn_deg: float = 0.0
    width_s: float = 1.0  # blending width at the piece's start
    speed_frac: float = 1.0  # a turn's walking speed and cadence, as fractions of the posture it inherits
    cadence_frac: float = 1.0
    start_s: float = 0.0
    end_s: float = 0.0


def _blend_run(t: NDArray[np.float64], pieces: list[_Piece], name: str) -> NDArray[np.float64]:
    """A parameter across a run's pieces: constant in each, raised-cosine transitions centred on the boundaries."""
    vals = [float(getattr(p.params, name)) for p in pieces]
    out = np.full(t.shape, vals[0])
    for i in range(1, len(pieces)):
        if vals[i] != vals[i - 1]:
            b, w = pieces[i].start_s, pieces[i].width_s
            out += (vals[i] - vals[i - 1]) * _smoothstep((t - (b - w / 2)) / w)
    return out


def _build_session(model: GaitModel, script_segments: list[Segment]) -> None:  # noqa: C901, PLR0915
    """Lay out a literal session script and build the model's splines (see the module docstring)."""
    rng = np.random.default_rng([model.seed, 0x5E55])
    pieces: list[_Piece] = []
    for seg in script_segments:
        kind = "stand" if seg.walk in ("stand", "pause") else seg.walk
        params = _draw_params("normal" if kind == "turn" else "stand" if kind in UNKNOWN_TOKENS else kind, 0.0, 0.0,
                              rng)
        turn_rate = float(rng.uniform(60.0, 90.0))  # mean turning rate, deg/s (peak 1.9x)
        turn_speed = float(rng.uniform(0.3, 0.55))  # walking speed while turning, fraction
        turn_cadence = float(rng.uniform(0.9, 1.0))
        posture_s = float(rng.uniform(1.5, 2.5))  # duration of a posture change
        duration = seg.duration_s
        if kind == "turn":
            duration = duration if duration > 0 else abs(seg.turn_deg) / turn_rate
        pieces.append(_Piece(kind, float(duration), params, seg.turn_deg, posture_s, turn_speed, turn_cadence))
    ramps = rng.integers(2, 4, size=(len(pieces) + 2, 2))  # steps of gait initiation / termination
    ramp_cadence = rng.uniform(0.75, 0.85, size=(len(pieces) + 2, 2))
    ramp_amplitude = rng.uniform(0.5, 0.7, size=(len(pieces) + 2, 2))

    # runs: maximal sequences of stepping pieces between standing pieces
    blocks: list[list[_Piece]] = []
    for p in pieces:
        if p.kind in _STILL_KINDS or not blocks or blocks[-1][0].kind in _STILL_KINDS:
            blocks.append([p])
        else:
            blocks[-1].append(p)
    # turns take the posture of the walk before them in their run (else the one after); speed scaled by it
    for block in blocks:
        walks = [p for p in block if p.kind not in ("turn", *_STILL_KINDS)]
        for i, p in enumerate(block):
            if p.kind != "turn":
                continue
            before = [q for q in block[:i] if q.kind != "turn"]
            src = before[-1] if before else (walks[0] if walks else None)
            posture = src.params if src is not None else p.params
            p.params = replace(posture, walk="turn", speed_mps=posture.speed_mps * p.speed_frac,
                               cadence_spm=posture.cadence_spm * p.cadence_frac)
        for i, p in enumerate(block):  # blend widths: ~2 s for a posture change, quick into and out of turns
            if i == 0:
                continue
            prev = block[i - 1]
            w = p.width_s if (p.kind != "turn" and prev.kind != "turn") else 0.6
            p.width_s = float(min(w, p.duration_s, prev.duration_s))

    # lay the blocks out in time; step each run
    knots_t: list[float] = []
    knots_phi: list[float] = []
    runs: list[dict[str, Any]] = []
    t = 0.0
    phase = 0.0
    for bi, block in enumerate(blocks):
        if block[0].kind in _STILL_KINDS:
            block[0].start_s, block[0].end_s = t, t + block[0].duration_s
            t = block[0].end_s
            continue
        mid_start, mid_end = bi == 0, bi == len(blocks) - 1
        a = t
        cum = a
        for p in block:
            p.start_s, p.end_s = cum, cum + p.duration_s
            cum = p.end_s
        nominal_end = cum
        n_on, n_off = (int(v) for v in ramps[bi])
        r_on, r_off = (float(v) for v in ramp_cadence[bi])

        def at(name: str, tt: float, block: list[_Piece] = block) -> float:
            return float(_blend_run(np.array([tt]), block, name)[0])

        steps = [a - 1.5 if mid_start else a]
        asym_k: list[float] = []  # the walk's left/right asymmetry at each step
        k = 0
        stopping_from = None
        while True:
            tk = steps[-1]
            base = 60.0 / at("cadence_spm", tk)
            asym_k.append(at("asymmetry", tk))
            factor = 1.0 + at("step_jitter", tk) * rng.standard_normal()
            rate = 1.0
            if not mid_start and k < n_on:
                rate = r_on + (1.0 - r_on) * float(_smoothstep(np.array(k / n_on)))
            if stopping_from is not None:
                j = k - stopping_from
                rate = min(rate, r_off + (1.0 - r_off) * float(_smoothstep(np.array((n_off - 1 - j) / n_off))))
            steps.append(tk + base * max(factor, 0.5) / rate)
            k += 1
            if mid_end:
                if steps[-1] > nominal_end + 1.5:
                    break
            elif stopping_from is None:
                remaining = nominal_end - steps[-1]
                if remaining <= n_off * base * 2.0 / (1.0 + r_off) and k >= n_on:
                    stopping_from = k
            elif k - stopping_from >= n_off:
                break
        b = nominal_end if mid_end else steps[-1]
        block[-1].end_s = b
        if block[-1].end_s - block[-1].start_s < 0.2:  # the stepping overran a short last piece: stretch it
            block[-1].start_s = min(block[-1].start_s, b - 0.2)
            if len(block) > 1:
                block[-2].end_s = block[-1].start_s
        # phase knots: filler knots through the standing before this run, then the steps
        if knots_t:
            gap = steps[0] - max(knots_t)
            m = max(1, round(gap * 1.8))
            t_prev = max(knots_t)
            for i in range(1, m):
                knots_t.append(t_prev + gap * i / m)
                knots_phi.append(phase + i)
            phase += m
        elif not mid_start:  # the session starts standing: filler knots from before t = 0
            m = max(1, round((steps[0] + 1.5) * 1.8))
            for i in range(m):
                knots_t.append(-1.5 + (steps[0] + 1.5) * i / m)
                knots_phi.append(phase + i)
            phase += m
        for i, st in enumerate(steps):
            knots_t.append(st)
            knots_phi.append(phase + i)
        # Initial contacts lie at half-integer phases (the trunk lowest, the upward acceleration at its peak).
        # A limp (asymmetry > 0) moves them off the middle of the step cycle, alternately early and late, so
        # that the contact-to-contact step times alternate long and short (step time ratio about 1 + 0.3 x
        # asymmetry: 1.23 for right_foot_drag; hemiparetic gait shows 1.1-1.3, healthy gait below ~1.06,
        # Patterson et al. 2010, Neurorehabil Neural Repair 24(9):783-790): the step that ends on the
        # dragged right foot (its slower swing) is the long one. The contact of phase P + 1/2 is foot R when
        # P is even.
        for i in range(len(steps) - 1):
            if asym_k[i] > 1e-3:
                sigma = 1.0 if (phase + i) % 2 == 0 else -1.0
                knots_t.append(steps[i] + (steps[i + 1] - steps[i]) * (0.5 + sigma * 0.15 * asym_k[i]))
                knots_phi.append(phase + i + 0.5)
        run_phase0 = phase
        phase += len(steps) - 1
        runs.append({"block": block, "a": a, "b": b, "steps": steps, "mid_start": mid_start, "mid_end": mid_end,
                     "n_on": n_on, "n_off": n_off, "amp": ramp_amplitude[bi], "phase0": run_phase0})
        t = b
    duration = t
    if not runs or not runs[-1]["mid_end"]:  # the session ends standing: filler knots after it
        t_last = max(knots_t) if knots_t else -1.5
        m = max(2, round((duration + 1.5 - t_last) * 1.8))
        for i in range(1, m + 1):
            knots_t.append(t_last + (duration + 1.5 - t_last) * i / m)
            knots_phi.append(phase + i)
    if duration <= 0.0:
        msg = f"walk script {model.script!r}: the session has no duration"
        raise InvalidInputError(msg)
    if duration > 3600.0:
        msg = f"walk script {model.script!r}: more than an hour is not supported"
        raise InvalidInputError(msg)

    grid = np.arange(-0.5, duration + 0.5 + 1.0 / _GRID_HZ, 1.0 / _GRID_HZ)
    order = np.argsort(knots_t, kind="stable")
    phase_spline = CubicSpline(np.array(knots_t)[order], np.array(knots_phi)[order])
    phi = phase_spline(grid)
    if np.any(np.diff(phi) <= 0):  # pragma: no cover - guarded by the knot spacing
        msg = "internal error: non-monotonic gait phase"
        raise RuntimeError(msg)

    # per-run parameters, gait envelope (amplitude), motion envelope (speed, posture), turning heading
    vals = {name: np.zeros_like(grid) for name in _BLENDED}
    env = np.zeros_like(grid)
    motion = np.zeros_like(grid)
    turn_deg = np.zeros_like(grid)
    for run in runs:
        a, b, steps = run["a"], run["b"], run["steps"]
        lo = -np.inf if run["mid_start"] else a
        hi = np.inf if run["mid_end"] else b
        inside = (grid >= lo) & (grid <= hi)
        g = grid[inside]
        for name in _BLENDED:
            vals[name][inside] = _blend_run(g, run["block"], name)
        amp, mot = np.ones_like(g), np.ones_like(g)
        if not run["mid_start"]:
            s1, sn = steps[1], steps[min(run["n_on"], len(steps) - 1)]
            amp *= _smootherstep((g - a) / (0.5 * (s1 - a)))
            amp *= run["amp"][0] + (1.0 - run["amp"][0]) * _smootherstep((g - a) / (sn - a))
            mot *= _smootherstep((g - a) / (sn - a))
        if not run["mid_end"]:
            s1, sn = steps[-2], steps[max(len(steps) - 1 - run["n_off"], 0)]
            amp *= _smootherstep((b - g) / (0.5 * (b - s1)))
            amp *= run["amp"][1] + (1.0 - run["amp"][1]) * _smootherstep((b - g) / (b - sn))
            mot *= _smootherstep((b - g) / (b - sn))
        env[inside] = amp
        motion[inside] = mot
    for p in pieces:
        if p.kind == "turn":
            turn_deg += p.turn_deg * _smootherstep((grid - p.start_s) / (p.end_s - p.start_s))

    var = 1.0 + 0.10 * rng.standard_normal((len(knots_t) + 4, 5))
    v = CubicSpline(np.arange(var.shape[0], dtype=float), var)(phi)
    ph = rng.uniform(0.0, 2.0 * np.pi, size=12)
    ph[3] = np.pi  # bob's 2nd harmonic sharpens the lowest point (initial contact: peak upward acceleration)
    h2 = rng.uniform(0.15, 0.3, size=5)
    h2[1] *= 2.0 / 3.0  # the bob's 2nd harmonic: a secondary hump mid-step below a third of the contact peak
    asym = vals["asymmetry"]
    two_pi_phi = 2.0 * np.pi * phi
    stride = np.pi * phi
    pitch_osc = vals["pitch_amplitude_deg"] * v[:, 0] * (
        np.cos(two_pi_phi + ph[0]) + h2[0] * np.cos(2 * two_pi_phi + ph[1]) + 0.5 * asym * np.cos(stride + ph[2])
        + model.pitch_lr * np.cos(stride + ph[2] + _LR_PHASE)
    )
    bob = vals["bob_amplitude_m"] * v[:, 1] * (
        np.cos(two_pi_phi) + h2[1] * np.cos(2 * two_pi_phi + ph[3]) + 0.6 * asym * np.cos(stride + ph[4])
    )
    roll_osc = vals["roll_amplitude_deg"] * v[:, 2] * (
        np.sin(stride + ph[5]) + h2[2] * np.sin(3 * stride + ph[6]) + 0.2 * np.cos(two_pi_phi + ph[7])
        + asym * 0.5 * np.cos(two_pi_phi)
    )
    yaw_osc = vals["yaw_amplitude_deg"] * v[:, 3] * (
        np.sin(stride + ph[8]) + h2[3] * np.sin(3 * stride + ph[9]) + 0.3 * asym * np.cos(two_pi_phi)
    )
    sway = vals["sway_amplitude_m"] * v[:, 4] * (np.sin(stride + ph[10]) + h2[4] * np.sin(3 * stride + ph[11]))

    i0 = int(np.searchsorted(grid, 0.0))
    speed = vals["speed_mps"] * motion * (1.0 + 0.06 * env * np.cos(two_pi_phi + ph[0] + 0.8))
    walked_m = np.cumsum(speed) / _GRID_HZ
    walked_m -= walked_m[i0]
    kw = 2.0 * np.pi / rng.uniform(20.0, 60.0, size=3)
    amps = rng.uniform(0.1, 0.25, size=3) * rng.choice([-1.0, 1.0], size=3)
    wander = np.arctan(sum(aa * kk * np.sin(kk * walked_m) for aa, kk in zip(amps, kw, strict=True)))
    hd = np.radians(turn_deg) + wander
    fwd = np.stack([np.sin(hd), np.zeros_like(hd), np.cos(hd)], axis=1)
    right = np.stack([np.cos(hd), np.zeros_like(hd), -np.sin(hd)], axis=1)
    path = np.cumsum(speed[:, None] * fwd, axis=0) / _GRID_HZ

    pitch_off = vals["pitch_offset_deg"] * motion
    roll_off = vals["roll_offset_deg"] * motion
    lean = np.radians(pitch_off)
    pos = path + (env * sway)[:, None] * right + fwd * (-_HIP_TO_CAMERA_M * np.sin(lean))[:, None]
    pos[:, 1] += -env * bob + _HIP_TO_CAMERA_M * (1.0 - np.cos(lean))
    pitch_deg = pitch_off + env * pitch_osc
    roll_deg = roll_off + env * roll_osc
    yaw_deg = np.degrees(hd) + env * yaw_osc
    for p in pieces:  # moving without a gait rhythm (the truth's unknown): added on top of standing still
        if p.kind in UNKNOWN_TOKENS:
            d_ang, d_pos = _unknown_motion(p.kind, grid, p.start_s, p.end_s, hd, rng)
            pitch_deg += d_ang[:, 0]
            yaw_deg += d_ang[:, 1]
            roll_deg += d_ang[:, 2]
            pos += d_pos
    pos -= pos[i0]

    # the truth: pieces with their final times
    timeline: list[TimelinePiece] = []
    params_out: list[SegmentParams] = []
    standing: list[tuple[float, float]] = []
    for p in pieces:
        a, b = max(p.start_s, 0.0), min(p.end_s, duration)
        if b <= a:
            continue
        if p.kind == "stand":
            timeline.append(TimelinePiece(a, b, "standing", ""))
            standing.append((a, b))
            walk = "stand"
        elif p.kind == "turn":
            timeline.append(TimelinePiece(a, b, "turning", "", p.turn_deg))
            walk = "turn"
        elif p.kind in UNKNOWN_TOKENS:
            timeline.append(TimelinePiece(a, b, "unknown", ""))
            walk = "stand"
        else:
            timeline.append(TimelinePiece(a, b, "walking", p.kind))
            walk = p.kind
        params_out.append(replace(p.params, walk=walk, start_s=a, end_s=b))
    object.__setattr__(model, "segments", tuple(params_out))
    object.__setattr__(model, "duration_s", float(duration))
    object.__setattr__(model, "standing_intervals_s", tuple(_merge_intervals(standing)))
    object.__setattr__(model, "pieces", tuple(timeline))
    object.__setattr__(model, "_splines", {
        "angles": CubicSpline(grid, np.stack([pitch_deg, yaw_deg, roll_deg], axis=1)),
        "position": CubicSpline(grid, pos),
        "phase": phase_spline,
        "envelope": CubicSpline(grid, env),
    })
