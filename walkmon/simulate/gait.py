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

The physical orientation is ``R = Ry(heading + yaw) Rx(pitch) Rz(roll)`` (turn about the vertical, then lean the
trunk); the truth angles are its decomposition with :func:`walkmon.consts.angles_deg_from_rotation`.
"""

from __future__ import annotations

import logging
import re
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import CubicSpline

from walkmon.consts import angles_deg_from_rotation, rot_x, rot_y, rot_z
from walkmon.errors import InvalidInputError

__all__ = [
    "STANDING_S",
    "WALK_TYPES",
    "GaitModel",
    "Segment",
    "SegmentParams",
    "parse_walk_script",
]

_log = logging.getLogger(__name__)

#: Walk types a script may name ("stand" is an extra standing-still pause inside a script).
WALK_TYPES = ("normal", "left_shoulder_down", "right_foot_drag", "bend", "stand")

#: Standing still at the start and at the end of every session, seconds.
STANDING_S = 2.0

#: Internal sampling rate of the model before spline interpolation, Hz.
_GRID_HZ = 1000.0

#: Distance from the hip pivot up to the chest camera, metres (bending the trunk moves the camera forward/down).
_HIP_TO_CAMERA_M = 0.45


@dataclass(frozen=True, slots=True)
class Segment:
    """One scripted segment: a walk type and its duration in seconds (walking time, standing excluded)."""

    walk: str
    duration_s: float


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


def parse_walk_script(script: str, seconds: float | None = None, *, stand_s: float = STANDING_S) -> list[Segment]:
    """Segments of a walk script such as ``"normal"`` or ``"normal:10,bend:10"``.

    A single walk type without a duration lasts ``seconds`` in total, standing included (so the session is
    ``seconds`` long: ``seconds - 2 * stand_s`` of walking). In a script with several segments each one needs
    its duration (walking seconds); the session then lasts their sum plus the standing at both ends.
    Raises :class:`InvalidInputError` for unknown types or bad syntax.
    """
    if not isinstance(script, str) or not script.strip():
        msg = f"walk script must be a walk type or a list like 'normal:10,bend:10', got {script!r}"
        raise InvalidInputError(msg)
    parts = [p.strip() for p in script.strip().lower().split(",")]
    segments: list[Segment] = []
    for part in parts:
        m = _SEGMENT_RE.match(part)
        if not m:
            msg = f"walk script {script!r}: cannot parse segment {part!r} (expected TYPE or TYPE:SECONDS)"
            raise InvalidInputError(msg)
        walk, dur = m.group(1), m.group(2)
        if walk not in WALK_TYPES:
            msg = f"walk script {script!r}: unknown walk type {walk!r} (known: {', '.join(WALK_TYPES)})"
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
    IMU model needs. Times outside ``[0, duration_s]`` are clamped.
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
    _splines: dict[str, CubicSpline] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not (np.isfinite(self.stand_s) and self.stand_s >= 0.0):
            msg = f"standing time must be >= 0 s, got {self.stand_s}"
            raise InvalidInputError(msg)
        if not (np.isfinite(self.transition_s) and 0.0 < self.transition_s <= 5.0):
            msg = f"transition time must be in (0, 5] s, got {self.transition_s}"
            raise InvalidInputError(msg)
        script_segments = parse_walk_script(self.script, self.seconds, stand_s=self.stand_s)
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
        """Orientation relative to frame 0 (camera-t directions into camera 0 / world), shape (N, 3, 3)."""
        a = np.radians(self.body_angles_deg(t_s))
        return rot_y(a[:, 1]) @ rot_x(a[:, 0]) @ rot_z(a[:, 2])

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
        return w_yaw * da[:, 1:2] + w_pitch * da[:, 0:1] + e_z[None, :] * da[:, 2:3]

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
            "segments": [p.to_dict() for p in self.segments],
        }


def _merge_intervals(intervals: list[tuple[float, float]]) -> list[tuple[float, float]]:
    out: list[tuple[float, float]] = []
    for a, b in sorted(intervals):
        if out and a <= out[-1][1] + 1e-9:
            out[-1] = (out[-1][0], max(out[-1][1], b))
        else:
            out.append((a, b))
    return out
