"""Sliding-window live indicators: upright calibration, walking detection, cadence, swing, inclination, label.

A stage (no threads, no I/O, no clock reads): :meth:`LiveIndicatorStage.push` takes one camera orientation
sample (capture time and (pitch, yaw, roll) in degrees relative to the first frame) and returns a
:class:`LiveIndicators` once per hop (``hop_s``, default 1 s) computed over the last ``window_s`` (default 8 s);
:meth:`LiveIndicatorStage.push_unmeasured` takes a frame that measured nothing (the estimator held it: a covered
lens), which adds no sample but keeps the hops coming (``unknown`` once nothing was measured for ``max_gap_s``):

* **Upright calibration.** At the start, and again after :meth:`request_calibration` (SIGUSR1 in ``walkmon
  live``), the stage waits for ``calibration_s`` of stillness and takes the mean angles as the upright
  reference; inclinations are measured from it. Until then the first frame is the reference. A still stance
  is not always standing: a wearer who starts the monitor seated is still too. When walking reads more than
  ``still_tilt_deg`` (20 deg, the offline analysis' rule) from the reference, the reference is rejected: no
  posture label (``unclassified`` with the reason) until a still stance near the walking posture replaces it
  (the latest one still in the window, usually the moment the wearer stood before walking off, else the next
  pause), logged as a calibration with reason ``posture``.
* **Activity** (standing / walking / turning / unknown) from the same segmentation as the offline analysis
  (:mod:`walkmon.gait.activity`) run on the window: walking when the window's last walking bout (>= 4 steps)
  reaches the present (its last step within ``1.5`` steps of now), so a clip that starts mid-walk is walking
  from its first full window. ``walking`` is False otherwise (label ``not_walking``; no alerts then).
* **Cadence** from the FFT peak of the pitch waveform (the vertical rhythm is at step frequency), refined below
  the bin width by parabolic interpolation of the log magnitude.
* **Swing** (per axis, mean over gait cycles of max - min, the paper's φ) and **inclination** (mean over cycles
  of (max + min) / 2, the paper's ρ, relative to the upright reference), cycles being steps for pitch and
  strides for yaw and roll.
* **Posture** = mean calibrated angles over the last ``posture_window_s``: what alerts react to, so that a
  change of posture shows up within about a second rather than after half a window.
* **Label**: the offline analysis's classifier on the window's walking span
  (:func:`walkmon.gait.session.span_indicators` -> :func:`walkmon.gait.posture.classify`: the same function,
  thresholds and reasons as ``walkmon analyze``), plus ``not_walking``. Swing and inclination shown with the
  label are those the classifier saw (heading-free tilt from the upright reference); the cheap per-cycle values
  are used only when the span is too short to classify.
"""

from __future__ import annotations

import collections
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from walkmon.consts import AXES
from walkmon.gait.posture import Classification

__all__ = [
    "DEFAULT_LIVE_INDICATOR_SETTINGS",
    "CalibrationEvent",
    "LiveIndicatorSettings",
    "LiveIndicatorStage",
    "LiveIndicators",
    "cadence_hz_from_signal",
    "cycle_extremes",
    "gait_band_rms_deg",
    "resample_uniform",
    "unmeasured_why",
]

LABELS = ("normal", "bend", "left_shoulder_down", "right_foot_drag", "not_walking", "unclassified")

#: The live stage keeps the axes of this many recent turns for gravity's direction (a long session's turns
#: would otherwise grow its cost without bound).
_MAX_TURN_AXES = 20


@dataclass(frozen=True, slots=True)
class LiveIndicatorSettings:
    """Settings of the sliding-window stage (seconds, degrees, steps per minute)."""

    #: Analysis window for cadence, swing and inclination, s.
    window_s: float = 8.0
    #: One result per hop, s.
    hop_s: float = 1.0
    #: Recent window for the posture the alerts react to, s.
    posture_window_s: float = 1.5
    #: Window for the walking detector, s.
    walking_window_s: float = 3.0
    #: Gait-band RMS (max over pitch and roll) above which the wearer is walking, degrees.
    walking_min_rms_deg: float = 0.2
    #: Gait band, Hz (step and stride rhythms of walking).
    gait_band_hz: tuple[float, float] = (0.6, 3.5)
    #: Plausible cadence range, steps/min.
    cadence_min_spm: float = 60.0
    cadence_max_spm: float = 150.0
    #: Swings and inclinations are taken after a low-pass at this multiple of the step frequency (0: none).
    lowpass_factor: float = 3.0
    #: Upright calibration: this long a still stance, s ...
    calibration_s: float = 2.0
    #: ... with every axis' standard deviation below this, degrees.
    calibration_max_std_deg: float = 0.3
    #: A still stance is the upright reference only while walking reads within this (pitch or roll, degrees) of
    #: it: the offline analysis' rule (:class:`walkmon.gait.session.SessionSettings` ``still_tilt_deg``). A
    #: wearer who starts the monitor seated is still, 22-35 deg from upright, and every walk after it read "bent
    #: forward" (the simulator's unkind sessions that start seated: 11 of 19 false bend hops on normal walking).
    still_tilt_deg: float = 20.0
    #: Before any still stance (no upright calibration) the first frame is the reference, assumed upright (with an
    #: IMU too: gravity's direction is known, the trunk's upright pose on the camera is not): the posture the alerts
    #: react to may be off by this much (degrees, pitch and roll), so no posture alert is raised against it. A walk
    #: that starts tilted reads its return to upright as the opposite tilt: an unkind session starting mid-walk
    #: with the left shoulder 6 deg down raised "right shoulder down 6 deg" on the normal walk after it. 20 deg:
    #: walks start bent forward by up to 15-20 deg (the simulator's bend walks), and a stooped wearer by more.
    #: Labels are still given against it, as the offline analysis gives them without a standing phase, with the
    #: reason that the reference is assumed (so a walk that starts with the right shoulder down labels the upright
    #: walk after it left_shoulder_down, saying so).
    uncalibrated_doubt_deg: float = 20.0
    #: How far a video's pitch may move across each stretch where the trunk tilts far and fast (the segmentation's
    #: handled stretches: sitting down and standing up, picking something up, handling the camera; a pick-up is
    #: two, down and up) since the upright reference was taken, degrees (the bound grows with the square root of
    #: their number), until a pause re-references it: the offline analysis' bound for a turn
    #: (:class:`walkmon.gait.session.SessionSettings` ``turn_reference_deg``), on the pitch alone (the chest drops
    #: while it pitches, and a camera facing a near surface can take the drop for a pitch; a roll has no
    #: translation to be taken for). Turns have their own doubt (their axes',
    #: :meth:`LiveIndicatorStage._tilt_doubt_deg`) and re-reference at a pause. 0 for angles that do not drift.
    #: Without it, 2 pathology hops on true normal walking in the live replay of the held-out unkind sessions (a
    #: normal walk after picking something up read bent 8 deg).
    tilt_drift_deg: float = 4.0
    #: Uniform resampling rate of the analysis, Hz.
    resample_hz: float = 30.0
    #: Frames that measured nothing (:meth:`LiveIndicatorStage.push_unmeasured`: a covered lens, darkness) for
    #: longer than this make the activity unknown, as the offline analysis' gaps
    #: (:class:`walkmon.gait.activity.ActivitySettings` ``max_gap_s``), s.
    max_gap_s: float = 1.0
    #: Deprecated, kept so that existing config files still load: labels now come from the one classifier
    #: (:mod:`walkmon.gait.posture`, the offline thresholds); these four values are not used.
    bend_pitch_deg: float = 10.0
    shoulder_down_roll_deg: float = 4.0
    foot_drag_roll_swing_deg: float = 6.0
    foot_drag_asymmetry: float = 0.35
    #: Deprecated likewise: the step asymmetry is no longer measured from the camera's rotation (not used).
    steady_posture_range_deg: float = 3.0

    def __post_init__(self) -> None:
        for name in ("window_s", "hop_s", "posture_window_s", "walking_window_s", "calibration_s", "resample_hz",
                     "still_tilt_deg", "max_gap_s"):
            if not getattr(self, name) > 0:
                msg = f"indicators.{name} must be > 0, got {getattr(self, name)}"
                raise ValueError(msg)
        for name in ("uncalibrated_doubt_deg", "tilt_drift_deg"):
            if not 0 <= getattr(self, name) <= 90:
                msg = f"indicators.{name} must be in [0, 90], got {getattr(self, name)}"
                raise ValueError(msg)
        if self.max_gap_s >= self.window_s:
            msg = "indicators.max_gap_s must be less than window_s"
            raise ValueError(msg)
        if self.walking_window_s > self.window_s or self.posture_window_s > self.window_s:
            msg = "indicators.walking_window_s and posture_window_s must not exceed window_s"
            raise ValueError(msg)
        lo, hi = self.gait_band_hz
        if not 0 < lo < hi:
            msg = f"indicators.gait_band_hz must be (low, high) with 0 < low < high, got {self.gait_band_hz}"
            raise ValueError(msg)
        if not 0 < self.cadence_min_spm < self.cadence_max_spm:
            msg = "indicators.cadence_min_spm must be > 0 and < cadence_max_spm"
            raise ValueError(msg)


DEFAULT_LIVE_INDICATOR_SETTINGS = LiveIndicatorSettings()


@dataclass(frozen=True, slots=True)
class CalibrationEvent:
    """An upright reference taken (or assumed) at ``t_s``: mean (pitch, yaw, roll) in degrees."""

    t_s: float
    angles_deg: tuple[float, float, float]
    # "start", "request", "posture" (the previous one was no standing stance) or "pause" (a still stance near the
    # reference after a turn: the video's drift taken out)
    reason: str
    duration_s: float


@dataclass(frozen=True, slots=True)
class LiveIndicators:
    """One hop's indicators. Angles in degrees, relative to the upright reference; NaN where unknown."""

    t_s: float
    window_s: float
    n_samples: int
    walking: bool
    gait_rms_deg: float
    cadence_spm: float
    swing_deg: tuple[float, float, float]
    inclination_deg: tuple[float, float, float]
    posture_deg: tuple[float, float, float]
    step_asymmetry: float
    label: str
    reasons: tuple[str, ...]
    calibrated: bool
    calibration: CalibrationEvent | None = None
    extra: dict[str, float] = field(default_factory=dict)
    activity: str = "unknown"
    #: How far ``posture_deg``'s pitch and roll may be off (degrees; the larger of the two below): gravity's
    #: direction not known well enough at this heading, the video's drift since the reference, or no upright
    #: reference yet (:meth:`LiveIndicatorStage._posture_doubt_deg`). The alerts take it off before comparing.
    posture_doubt_deg: float = 0.0
    #: The same, for the pitch alone (NaN: as ``posture_doubt_deg``); a video's drift across sitting down or
    #: picking something up is a pitch drift.
    posture_doubt_pitch_deg: float = math.nan
    #: The same, for the roll alone (NaN: as ``posture_doubt_deg``).
    posture_doubt_roll_deg: float = math.nan

    def to_dict(self) -> dict[str, object]:
        def num(v: float) -> float | None:
            return None if v is None or not math.isfinite(v) else round(float(v), 4)

        return {
            "t_s": num(self.t_s),
            "window_s": self.window_s,
            "n_samples": self.n_samples,
            "walking": self.walking,
            "activity": self.activity,
            "gait_rms_deg": num(self.gait_rms_deg),
            "cadence_spm": num(self.cadence_spm),
            "axes": {
                ax: {
                    "swing_deg": num(self.swing_deg[i]),
                    "inclination_deg": num(self.inclination_deg[i]),
                    "posture_deg": num(self.posture_deg[i]),
                }
                for i, ax in enumerate(AXES)
            },
            "posture_doubt_deg": num(self.posture_doubt_deg),
            "posture_doubt_pitch_deg": num(self.posture_doubt_pitch_deg),
            "posture_doubt_roll_deg": num(self.posture_doubt_roll_deg),
            "step_asymmetry": num(self.step_asymmetry),
            "classification": {"label": self.label, "reasons": list(self.reasons)},
            "calibrated": self.calibrated,
        }


# ----------------------------------------------------------------------------------------------- pure maths


#: How the reason of a hop in which the camera measured nothing begins (:meth:`LiveIndicatorStage._unmeasured`);
#: the status line, the alerts and the dashboard tell such hops from other unknown ones by it (:func:`unmeasured_why`).
UNMEASURED_REASONS = ("nothing measured", "measuring again")


def unmeasured_why(activity: str | None, reasons: Sequence[object]) -> str:
    """Why a hop is unknown in a few words (its first reason up to the colon) when the camera measured nothing in
    it (:data:`UNMEASURED_REASONS`), else ''. Takes the hop's activity and reasons as :class:`LiveIndicators`
    holds them or as its JSON in the session log gives them back."""
    why = str(reasons[0]).split(":")[0] if activity == "unknown" and reasons else ""
    return why if why.startswith(UNMEASURED_REASONS) else ""


#: After nothing was measured for ``max_gap_s`` (a covered lens), hops stay ``unknown`` for this long once measuring
#: resumes (s): what a session's first hops need too (:meth:`LiveIndicatorStage._activity` wants 2 s of samples).
RESUME_S = 2.0
#: Labels that an inclination gives (the window's mean posture); a wearer who straightens up is still read bent
#: by them until the new posture can be split off.
_POSTURE_LABELS = ("bend", "left_shoulder_down")
#: How recent a return to upright :func:`upright_again` looks at: the posture features' own smoothing
#: (SessionSettings.smooth_s), the shortest stretch whose inclination they settle on.
UPRIGHT_TAIL_S = 2.0


def upright_again(
    t: NDArray[np.float64], hf: NDArray[np.float64], t0: float, t1: float, tail_s: float = UPRIGHT_TAIL_S,
) -> str | None:
    """Why a posture label of the walk ``[t0, t1]`` (heading-free angles ``hf`` from the upright reference) is
    withheld, or None: the last ``tail_s`` read upright (slow pitch and roll within the classifier's normal range)
    and differ from the walk before them by a change of posture (the change-point limits).

    A posture change is split off only once ``min_segment_s`` (4 s) of the new posture lie in the window
    (:func:`walkmon.gait.session.change_points`); until then the window's mean mixes both. Straightening up from a
    bent walk kept the label ``bend`` for 2-3 hops after the trunk was upright (the unkind sessions' live replay:
    6 of the 17 pathology hops on true normal walking, seeds 1-10). A mixed window that still reads normal while
    the wearer bends down is a late label, not a false alarm, so only this direction is withheld."""
    from walkmon.gait.posture import DEFAULT_POSTURE_THRESHOLDS as th  # noqa: PLC0415
    from walkmon.gait.session import change_limits, posture_features  # noqa: PLC0415

    m = (t >= t0) & (t <= t1)
    if t1 - t0 < 2.0 * tail_s or np.count_nonzero(m) < 10:
        return None
    f = posture_features(t[m], hf[m])
    tail = t[m] >= t1 - tail_s
    if tail.all() or not tail.any():
        return None
    now, before = np.median(f[tail], axis=0), np.median(f[~tail], axis=0)
    if max(abs(float(now[0])), abs(float(now[1]))) >= th.normal_max_inclination_deg:
        return None
    d = np.abs(now - before) / change_limits()
    if float(np.max(d)) < 1.0:
        return None
    return (f"the last {tail_s:g} s read upright again (pitch {now[0]:.1f}, roll {now[1]:.1f} deg, "
            f"{before[0]:.1f} and {before[1]:.1f} before): a change of posture too recent to split off, not labelled")


def resample_uniform(t_s: NDArray[np.float64], values: NDArray[np.float64], rate_hz: float) -> tuple[
    NDArray[np.float64], NDArray[np.float64]
]:
    """Linear interpolation of ``values`` (N, K) sampled at increasing ``t_s`` onto a uniform grid."""
    if len(t_s) < 2:
        return t_s.copy(), values.copy()
    n = int(math.floor((t_s[-1] - t_s[0]) * rate_hz)) + 1
    grid = t_s[0] + np.arange(n) / rate_hz
    out = np.column_stack([np.interp(grid, t_s, values[:, k]) for k in range(values.shape[1])])
    return grid, out


def _detrend(x: NDArray[np.float64]) -> NDArray[np.float64]:
    n = len(x)
    if n < 2:
        return x - x.mean() if n else x
    s = np.arange(n, dtype=float)
    a, b = np.polyfit(s, x, 1)
    return x - (a * s + b)


def gait_band_rms_deg(x: NDArray[np.float64], rate_hz: float, band_hz: tuple[float, float]) -> float:
    """RMS of ``x`` (uniformly sampled, degrees) restricted to ``band_hz`` after removing a linear trend."""
    if len(x) < 8:
        return 0.0
    spec = np.fft.rfft(_detrend(np.asarray(x, dtype=float)))
    f = np.fft.rfftfreq(len(x), 1.0 / rate_hz)
    spec[(f < band_hz[0]) | (f > band_hz[1])] = 0
    y = np.fft.irfft(spec, n=len(x))
    return float(np.sqrt(np.mean(y * y)))


def cadence_hz_from_signal(
    x: NDArray[np.float64], rate_hz: float, band_hz: tuple[float, float], pad_to: int = 4096
) -> tuple[float, float]:
    """Dominant frequency of ``x`` inside ``band_hz`` and its share of the band's power.

    Linear detrend, Hamming taper, zero-padded FFT, parabolic interpolation of the log magnitude around the
    peak (sub-bin refinement). Returns (NaN, 0) when the signal is too short or flat.
    """
    x = np.asarray(x, dtype=float)
    if len(x) < 16:
        return math.nan, 0.0
    y = _detrend(x) * np.hamming(len(x))
    n = max(pad_to, 1 << int(math.ceil(math.log2(len(x)))))
    mag = np.abs(np.fft.rfft(y, n=n))
    f = np.fft.rfftfreq(n, 1.0 / rate_hz)
    band = np.flatnonzero((f >= band_hz[0]) & (f <= band_hz[1]))
    if band.size < 3 or not np.any(mag[band] > 0):
        return math.nan, 0.0
    k = int(band[np.argmax(mag[band])])
    near = band[np.abs(f[band] - f[k]) <= rate_hz / len(x)]  # within one unpadded bin of the peak
    share = float(np.sum(mag[near] ** 2) / np.sum(mag[band] ** 2))
    if 0 < k < len(mag) - 1 and mag[k - 1] > 0 and mag[k + 1] > 0:
        a, b, c = np.log(mag[k - 1]), np.log(mag[k]), np.log(mag[k + 1])
        denom = a - 2 * b + c
        delta = 0.5 * (a - c) / denom if denom != 0 else 0.0
        return float(f[k] + np.clip(delta, -0.5, 0.5) * (f[1] - f[0])), share
    return float(f[k]), share


def cycle_extremes(x: NDArray[np.float64], rate_hz: float, cycle_hz: float) -> tuple[
    NDArray[np.float64], NDArray[np.float64]
]:
    """Per complete cycle (period ``1 / cycle_hz``, counted back from the newest sample): (max, min) arrays."""
    period = int(round(rate_hz / cycle_hz)) if cycle_hz > 0 else 0
    if period < 2 or len(x) < period:
        return np.empty(0), np.empty(0)
    n_cycles = len(x) // period
    seg = np.asarray(x[len(x) - n_cycles * period :], dtype=float).reshape(n_cycles, period)
    return seg.max(axis=1), seg.min(axis=1)


# ------------------------------------------------------------------------------------------------- the stage


class LiveIndicatorStage:
    """Sliding-window indicator stage: ``push(t_s, angles_deg) -> LiveIndicators | None`` for a measured frame,
    ``push_unmeasured(t_s)`` for one that measured nothing, and ``reset()``."""

    def __init__(self, settings: LiveIndicatorSettings = DEFAULT_LIVE_INDICATOR_SETTINGS) -> None:
        from scipy import signal  # noqa: PLC0415 - slow first import: here, not inside the first hop

        self._signal = signal
        self.settings = settings
        self.reset()

    def reset(self) -> None:
        """Forget all samples and the upright reference; calibrate again from the next still stance."""
        self._t: collections.deque[float] = collections.deque()
        self._a: collections.deque[tuple[float, float, float]] = collections.deque()
        self._next_hop_t: float | None = None
        self._last_push_t = -math.inf  # the last frame's time, measured or not (push_unmeasured)
        self._last_measured_t = -math.inf  # the last measured sample's time (the window's trimming keeps it)
        # measuring again after nothing was measured for max_gap_s or more: (first sample after, the gap's length)
        self._resumed: tuple[float, float] | None = None
        self._reference = np.zeros(3)
        self._calibrated = False
        self._calibration_pending = "start"
        self._pending_events: collections.deque[CalibrationEvent] = collections.deque()
        self._last_steps = np.zeros(0)
        # gravity's direction in the start frame, learnt from the turns seen so far (see :meth:`_learn_vertical`)
        self._turn_axes: list[tuple[NDArray[np.float64], float]] = []
        self._turn_doubts: list[float] = []  # each turn's turn_axis_doubt_deg, alongside _turn_axes
        self._vertical_doubt = 0.0  # the largest of them among the turns _vertical rests on
        self._turns_done_s = -math.inf
        # the end of every handled stretch seen (the trunk tilted past the segmentation's reorientation limit:
        # sitting down, picking something up; once each, when complete): those since the reference was taken
        # bound the video's drift (:meth:`_tilt_doubt_deg`) and let a pause re-reference it
        self._tilt_ends: list[float] = []
        self._tilts_counted_s = -math.inf
        self._vertical: NDArray[np.float64] | None = None
        self._gravity_sum = np.zeros(3)  # gravity in the start frame summed over IMU samples (_learn_gravity)
        # a reference found to be no standing stance (walking read too far from it): the walking tilt relative to
        # it, what the next still stance must be close to (see :meth:`_check_reference`)
        self._rejected: tuple[float, float] | None = None
        self._calibrated_at_s = math.nan
        self._pause_checked_s = -math.inf
        self._near_checked_s = -math.inf  # the last still stance checked against the walking posture

    @property
    def _gravity_known(self) -> bool:
        """Whether an IMU fused with the camera has given gravity's direction (:meth:`_learn_gravity`)."""
        return float(np.linalg.norm(self._gravity_sum)) > 0

    @property
    def reference_deg(self) -> NDArray[np.float64]:
        """Current upright reference (pitch, yaw, roll), degrees."""
        return self._reference.copy()

    @property
    def calibrated(self) -> bool:
        return self._calibrated

    @property
    def vertical(self) -> NDArray[np.float64] | None:
        """Gravity's direction (down) in the start frame: from a fused IMU's gravity, else learnt from the wearer's
        turns; None before either (the camera is then assumed level on the trunk)."""
        return None if self._vertical is None else self._vertical.copy()

    def request_calibration(self) -> None:
        """Take a new upright reference from the next ``calibration_s`` of still stance."""
        self._calibration_pending = "request"

    def push(
        self, t_s: float, angles_deg: NDArray[np.float64] | tuple[float, float, float],
        abs_deg: tuple[float, float] | None = None,
    ) -> LiveIndicators | None:
        """Add one sample; returns the hop's indicators when a hop boundary is crossed, else ``None``.
        ``abs_deg``: gravity's (pitch_abs, roll_abs) in the camera at this sample (an IMU fused with the camera);
        gravity's direction is then taken from it (:meth:`_learn_gravity`) instead of from the turns."""
        a = tuple(float(v) for v in angles_deg)
        if not all(math.isfinite(v) for v in a):
            return None
        if t_s <= self._last_push_t:
            return None  # out of order or repeated timestamp: ignore
        s = self.settings
        if self._last_push_t > self._last_measured_t and t_s - self._last_measured_t > s.max_gap_s:
            # the first sample after frames that measured nothing for max_gap_s or more (or from the start)
            gap = t_s - self._last_measured_t
            self._resumed = (float(t_s), gap)
        if self._a:  # yaw continuous across +-180 (a U-turn): a wrapped window reads a 360 deg "swing"
            prev = self._a[-1][1]
            a = (a[0], a[1] + 360.0 * round((prev - a[1]) / 360.0), a[2])
        if abs_deg is not None:
            self._learn_gravity((a[0], a[1], a[2]), abs_deg)
        self._t.append(float(t_s))
        self._a.append(a)  # type: ignore[arg-type]
        while self._t and self._t[0] < t_s - s.window_s:
            self._t.popleft()
            self._a.popleft()
        self._last_push_t = self._last_measured_t = float(t_s)
        if self._calibration_pending:
            self._try_calibrate()
        else:
            self._rereference_at_pause()
        return self._compute(t_s) if self._hop_due(t_s) else None

    def push_unmeasured(self, t_s: float) -> LiveIndicators | None:
        """A frame that measured nothing (the rotation estimator held its orientation: a covered lens, darkness,
        a featureless or repeated frame): no sample (held angles are flat and would read as standing), but the
        hops go on; once nothing was measured for ``max_gap_s`` the activity is unknown (the offline analysis
        leaves the same frames out: :func:`walkmon.api.measured_rows`)."""
        if t_s <= self._last_push_t:
            return None
        self._last_push_t = float(t_s)
        while self._t and self._t[0] < t_s - self.settings.window_s:
            self._t.popleft()
            self._a.popleft()
        return self._compute(t_s) if self._hop_due(t_s) else None

    def _hop_due(self, t_s: float) -> bool:
        """Whether ``t_s`` crosses the next hop boundary (the first sample only starts the hop clock)."""
        hop = self.settings.hop_s
        if self._next_hop_t is None:
            self._next_hop_t = t_s + hop
            return False
        if t_s + 1e-9 < self._next_hop_t:
            return False
        self._next_hop_t += hop * max(1, math.floor((t_s - self._next_hop_t) / hop) + 1)
        return True

    def _unmeasured(self, t_now: float) -> LiveIndicators | None:
        """The hop's indicators when nothing was measured for ``max_gap_s`` before ``t_now``, or measuring
        resumed after such a stretch less than :data:`RESUME_S` ago (as little to go on as at the start, and the
        window's few samples would give a posture and a cadence from a stride or less); else None."""
        last = self._last_measured_t
        if t_now - last > self.settings.max_gap_s:
            since = f"for {t_now - last:.1f} s" if math.isfinite(last) else "since the start"
            why = f"{UNMEASURED_REASONS[0]} {since}: the camera's view held (covered, dark or featureless)"
        elif self._resumed is not None and t_now - self._resumed[0] < RESUME_S:
            gap = self._resumed[1]
            why = (f"{UNMEASURED_REASONS[1]} after nothing measured for {gap:.1f} s" if math.isfinite(gap)
                   else f"{UNMEASURED_REASONS[1]} after nothing measured since the start")
        else:
            return None
        nan3 = (math.nan, math.nan, math.nan)
        return LiveIndicators(
            t_s=float(t_now), window_s=float(self._t[-1] - self._t[0]) if self._t else 0.0, n_samples=len(self._t),
            walking=False, gait_rms_deg=math.nan, cadence_spm=math.nan, swing_deg=nan3, inclination_deg=nan3,
            posture_deg=nan3, step_asymmetry=math.nan, label="not_walking", reasons=(why,),
            calibrated=self._calibrated, calibration=self._pending_events.popleft() if self._pending_events else None,
            activity="unknown")

    def _try_calibrate(self) -> None:
        t = np.fromiter(self._t, float)
        recent = self._stance_window(t, float(t[-1]))
        if recent is None or not self._still(recent):
            return
        if self._rejected is not None:
            if t[-1] - self._near_checked_s < 0.1:  # checked 10 times a second, not at every frame
                return
            self._near_checked_s = float(t[-1])
            if not self._near_walking(t, recent):
                return  # still, but as far from the walking posture as the rejected reference: sitting again
        self._take_reference(t, recent)

    def _rereference_at_pause(self) -> None:
        """After a turn, the first still stance (``calibration_s``) whose heading-free tilt lies within the
        classifier's normal range (``normal_max_inclination_deg``, 3 deg) of the reference becomes the reference,
        logged with reason ``"pause"``: the offline analysis' standing anchors, run incrementally. A video's
        orientation drifts most in turns (1-6 deg of pitch or roll across a 90-180 deg turn) and gravity's direction
        from the turns is in doubt (:meth:`_tilt_doubt_deg`); a still stance that near the reference is taken
        for the same upright stance, so the difference is the video's error. Not with an IMU's gravity (nothing
        drifts), not while the reference is rejected, and checked 10 times a second.

        The bound: the offline anchors take 8 deg (``max_drift_deg``), but live a stance that is not upright
        becomes the reference at once, and the upright walk after it reads the opposite tilt: a pause with the
        trunk rolled 6 deg raised a false shoulder_down alert (> 5 deg) and labelled the upright walk after it
        left_shoulder_down (found in review; the simulator's pauses are upright, so the replay could not show it).
        Within the normal range a re-reference alone cannot move an upright walk out of it.

        Live replay of the unkind sessions: labels right 335 -> 342 of 560 (seeds 1-5) and 377 -> 387 of 600
        (6-10), pathology hops on true normal walking 0 and 0 as before (with 8 deg: 354 and 383)."""
        from walkmon.gait.posture import DEFAULT_POSTURE_THRESHOLDS  # noqa: PLC0415

        if not self._calibrated or self._rejected is not None or self._gravity_known:
            return
        if not (self._turns_done_s > self._calibrated_at_s or self._tilts_since_reference()):
            return  # no turn and no stretch of tilting far and fast since the reference was taken
        t_now = self._t[-1]
        if t_now - self._pause_checked_s < 0.1:
            return
        self._pause_checked_s = t_now
        t = np.fromiter(self._t, float)
        recent = self._stance_window(t, t_now)
        if recent is None or not self._still(recent):
            return
        pitch, roll = self._stance_tilt(t, recent)
        if max(abs(pitch), abs(roll)) < DEFAULT_POSTURE_THRESHOLDS.normal_max_inclination_deg:
            self._calibration_pending = "pause"
            self._take_reference(t, recent)

    def _stance_window(self, t: NDArray[np.float64], t_end: float) -> NDArray[np.bool_] | None:
        """The samples of the ``calibration_s`` ending at ``t_end``; None when the window does not hold that long
        (90 % of it) or 5 samples."""
        s = self.settings
        recent = (t >= t_end - s.calibration_s) & (t <= t_end)
        if recent.sum() < 5 or t_end - t[recent][0] < 0.9 * s.calibration_s:
            return None
        return recent

    def _still(self, recent: NDArray[np.bool_]) -> bool:
        """Every axis' standard deviation over ``recent`` within ``calibration_max_std_deg``."""
        a = np.asarray(self._a, dtype=float)[recent]
        return bool(np.all(a.std(axis=0) <= self.settings.calibration_max_std_deg))

    def _take_reference(self, t: NDArray[np.float64], recent: NDArray[np.bool_]) -> None:
        """The mean angles over ``recent`` become the upright reference, logged as a calibration event with the
        pending reason ("start", "request", "posture" after a rejection, or "pause" after a turn)."""
        tr = t[recent]
        self._reference = np.asarray(self._a, dtype=float)[recent].mean(axis=0)
        self._calibrated = True
        self._calibrated_at_s = float(tr[-1])
        self._rejected = None
        self._pending_events.append(CalibrationEvent(
            float(tr[-1]), tuple(float(v) for v in self._reference), self._calibration_pending,  # type: ignore[arg-type]
            float(tr[-1] - tr[0]),
        ))
        self._calibration_pending = ""

    def _near_walking(self, t: NDArray[np.float64], recent: NDArray[np.bool_]) -> bool:
        """Whether the ``recent`` still samples' heading-free tilt lies within ``still_tilt_deg`` of the walking
        posture seen against the rejected reference (both relative to that reference, so comparable whatever the
        heading)."""
        assert self._rejected is not None
        if recent.sum() < 3:
            return False
        still = self._stance_tilt(t, recent)
        return max(abs(still[0] - self._rejected[0]), abs(still[1] - self._rejected[1])) <= self.settings.still_tilt_deg

    def _stance_tilt(self, t: NDArray[np.float64], recent: NDArray[np.bool_]) -> tuple[float, float]:
        """The ``recent`` samples' mean heading-free (pitch, roll) from the reference."""
        from walkmon.gait.session import heading_free_angles  # noqa: PLC0415

        hf = heading_free_angles(t[recent], np.asarray(self._a, dtype=float)[recent], self._reference, self._vertical)
        return float(np.mean(hf[:, 0])), float(np.mean(hf[:, 2]))

    def _calibrate_from_window(self) -> bool:
        """After a rejection: the latest still stance (``calibration_s``, as :meth:`_try_calibrate`) in the window
        that lies near the walking posture becomes the reference at once (the wearer stood up and stood a moment
        before walking off: that stance is usually still in the window). False when there is none."""
        t = np.fromiter(self._t, float)
        if len(t) < 5:
            return False
        step = max(1, int(round(0.1 * len(t) / max(t[-1] - t[0], 1e-9))))
        for j in range(len(t) - 1, 0, -step):
            recent = self._stance_window(t, float(t[j]))
            if recent is None:
                break
            if self._still(recent) and self._near_walking(t, recent):
                self._take_reference(t, recent)  # logged as "posture", or "request" if the wearer asked
                return True
        return False

    def _check_reference(self, incl: tuple[float, float]) -> str | None:
        """After a classified walking span: None when the upright reference can be a standing stance; else it is
        rejected (a new one is taken from the next still stance near the walking posture) and the reason."""
        s = self.settings
        if self._rejected is None and not max(abs(incl[0]), abs(incl[1])) > s.still_tilt_deg:
            return None
        where = (f"the still stance at {self._calibrated_at_s:.1f} s" if math.isfinite(self._calibrated_at_s)
                 else "the first frame")
        if self._rejected is None:
            self._rejected = incl
            self._calibrated = False
            if self._calibration_pending != "request":  # a wearer's own request keeps its name in the log
                self._calibration_pending = "posture"

        return (f"walking reads {self._rejected[0]:.0f} / {self._rejected[1]:.0f} deg (pitch / roll) from the upright "
                f"reference ({where}), more than {s.still_tilt_deg:g} deg: that was no standing stance (sitting, bent "
                "down), so no posture label until the next still stance near the walking posture re-calibrates")

    def _lowpass(self, u: NDArray[np.float64], cutoff_hz: float, fs: float) -> NDArray[np.float64]:
        """Zero-phase 4th-order Butterworth low-pass (as the offline analysis does before its extremums)."""
        if not cutoff_hz > 0 or cutoff_hz >= 0.45 * fs or len(u) < 32:
            return u
        sos = self._signal.butter(4, cutoff_hz, btype="low", fs=fs, output="sos")
        return self._signal.sosfiltfilt(sos, u, axis=0)

    def _compute(self, t_now: float) -> LiveIndicators:
        gap = self._unmeasured(t_now)
        if gap is not None:
            return gap
        s = self.settings
        t = np.fromiter(self._t, float)
        a = np.asarray(self._a, dtype=float) - self._reference
        grid, u = resample_uniform(t, a, s.resample_hz)
        fs = s.resample_hz
        nan3 = (math.nan, math.nan, math.nan)
        # the activity first: its segmentation learns gravity's direction from a turn that just ended, which the
        # posture below then uses in the same hop
        activity, span = self._activity(t, np.asarray(self._a, dtype=float), t_now)
        walk_part = u[grid >= t_now - s.walking_window_s]
        gait_rms = max(gait_band_rms_deg(walk_part[:, k], fs, s.gait_band_hz) for k in (0, 2)) if len(walk_part) else 0.0
        walking = bool(gait_rms >= s.walking_min_rms_deg)
        cadence_spm = math.nan
        swing, incl = nan3, nan3
        if walking and len(u) >= 16:
            band = (s.cadence_min_spm / 60.0, s.cadence_max_spm / 60.0)
            f_step, _ = cadence_hz_from_signal(u[:, 0], fs, band)
            if math.isfinite(f_step):
                cadence_spm = 60.0 * f_step
                sw, inc = [], []
                smooth = self._lowpass(u, s.lowpass_factor * f_step, fs)
                for k in range(3):
                    cycle_hz = f_step if k == 0 else f_step / 2.0
                    hi, lo = cycle_extremes(smooth[:, k], fs, cycle_hz)
                    hi_d, lo_d = cycle_extremes(_detrend(smooth[:, k]), fs, cycle_hz)
                    sw.append(float(np.mean(hi_d - lo_d)) if hi_d.size else math.nan)
                    inc.append(float(np.mean((hi + lo) / 2.0)) if hi.size else math.nan)
                # no step asymmetry from the camera's rotation (step_asymmetry NaN): the pitch's stride-frequency
                # amplitude over its step-frequency one (what the stage measured until 2026-11-27) and the timing
                # of its maxima both read a trunk that pitches differently on the left and right steps as
                # asymmetric gait, and real trunks do (the Mobilise-D lower backs; the simulator's lr:X): with
                # lr 1-2 it raised asymmetric_gait on 5 normal walks of the unkind replay and read alternate
                # steps 1.27-1.5 apart on a symmetric one
                swing, incl = tuple(sw), tuple(inc)  # type: ignore[assignment]
        walking = activity == "walking"
        label = "not_walking"
        reasons: tuple[str, ...] = (f"activity {activity}: no walking bout reaching the present",)
        if walking and span is not None:
            ind = self._classify_span(t, np.asarray(self._a, dtype=float), span)
            label, reasons = ind.classification.label, tuple(ind.classification.reasons)
            if ind.status.value == "ok":
                swing = tuple(ind.axes[ax].swing_mean for ax in AXES)  # type: ignore[assignment]
                incl = tuple(ind.axes[ax].inclination_mean for ax in AXES)  # type: ignore[assignment]
                if math.isfinite(ind.cadence_spm):
                    cadence_spm = ind.cadence_spm
                tilt = (ind.axes["pitch"].inclination_mean, ind.axes["roll"].inclination_mean)
                why = self._check_reference(tilt) if all(math.isfinite(v) for v in tilt) else None
                if why is not None and self._calibrate_from_window():
                    ind = self._classify_span(t, np.asarray(self._a, dtype=float), span)
                    label, reasons = ind.classification.label, tuple(ind.classification.reasons)
                    if ind.status.value == "ok":
                        swing = tuple(ind.axes[ax].swing_mean for ax in AXES)  # type: ignore[assignment]
                        incl = tuple(ind.axes[ax].inclination_mean for ax in AXES)  # type: ignore[assignment]
                elif why is not None:
                    label, reasons = "unclassified", (why,)
            if not self._calibrated and label in ("normal", *_POSTURE_LABELS):
                # against the first frame, assumed upright (as the offline analysis without a standing phase)
                reasons = (*reasons, "upright reference assumed: the first frame (no still stance yet; stand still "
                                     f"for {s.calibration_s:g} s to calibrate)")
        # the posture the alerts react to, from the reference as it stands after this hop (a rejected one gives
        # no pitch and roll: a wearer who started the monitor seated must not be told to straighten up)
        recent = t >= t_now - s.posture_window_s
        posture = tuple(float(v) for v in self._posture(t, recent)) if recent.any() else nan3
        doubt_pitch, doubt_roll = self._posture_doubt_deg(t, recent) if recent.any() else (0.0, 0.0)
        if self._rejected is not None:
            posture = (math.nan, posture[1], math.nan)
        tilted = [abs(v) for v in (posture[0], posture[2]) if math.isfinite(v)]
        if activity == "standing" and tilted and max(tilted) > s.still_tilt_deg:
            # still but tilted from upright: sitting, lying or bent down, as the offline timeline says (user review:
            # a seated wearer, the chest 27-30 deg from upright, was logged standing)
            activity = "unknown"
            reasons = (f"activity unknown: still but {max(tilted):.0f} deg from upright (sitting, lying or bent "
                       "down?)",)
        elif activity == "standing" and self._rejected is not None and recent.sum() >= 3 \
                and not self._near_walking(t, recent):
            # the reference rejected (taken seated), so no posture: the stance against the walking posture seen
            # since (review: a wearer who started the monitor seated was logged standing when seated again)
            activity = "unknown"
            reasons = ("activity unknown: still but far from the walking posture (sitting, lying or bent down?)",)
        event = self._pending_events.popleft() if self._pending_events else None
        return LiveIndicators(
            t_s=float(t_now),
            window_s=float(t[-1] - t[0]),
            n_samples=len(t),
            walking=walking,
            gait_rms_deg=float(gait_rms),
            cadence_spm=float(cadence_spm),
            swing_deg=swing,  # type: ignore[arg-type]
            inclination_deg=incl,  # type: ignore[arg-type]
            posture_deg=posture,  # type: ignore[arg-type]
            step_asymmetry=math.nan,  # not from the camera's rotation (see the swings above)
            label=label,
            reasons=reasons,
            calibrated=self._calibrated,
            calibration=event,
            activity=activity,
            posture_doubt_deg=float(max(doubt_pitch, doubt_roll)),
            posture_doubt_pitch_deg=float(doubt_pitch),
            posture_doubt_roll_deg=float(doubt_roll),
        )

    def _posture(self, t: NDArray[np.float64], recent: NDArray[np.bool_]) -> NDArray[np.float64]:
        """Mean (pitch, yaw, roll) over the ``recent`` samples: pitch and roll the trunk's heading-free tilt from
        the upright reference (start-relative Euler angles mix them once the wearer has turned: after a U-turn a
        forward lean reads backward, and a camera tilted by d on the trunk reads up to 2 d of tilt), yaw from the
        reference."""
        from walkmon.gait.session import heading_free_angles  # noqa: PLC0415

        a = np.asarray(self._a, dtype=float)
        if len(t) >= 3:
            a = heading_free_angles(t, a, self._reference, self._vertical)
            a[:, 1] -= self._reference[1]
        else:
            a = a - self._reference
        out = a[recent].mean(axis=0)
        out[1] = (out[1] + 180.0) % 360.0 - 180.0  # the heading, shown within +-180
        return out

    def _posture_doubt_deg(self, t: NDArray[np.float64], recent: NDArray[np.bool_]) -> tuple[float, float]:
        """(pitch, roll) doubt of the posture the alerts react to: :meth:`_tilt_doubt_deg` of the ``recent``
        samples and, before any upright calibration, ``uncalibrated_doubt_deg``: the reference is then the first
        frame, only assumed upright (with an IMU too: gravity's direction is known, the trunk's upright pose on it
        is not)."""
        a, ref = self._level(np.asarray(self._a, dtype=float))
        pitch, roll, _ = self._tilt_doubt_deg(a, ref, recent)
        if not self._calibrated:
            pitch = math.hypot(pitch, self.settings.uncalibrated_doubt_deg)
            roll = math.hypot(roll, self.settings.uncalibrated_doubt_deg)
        return pitch, roll

    def _level(self, a: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Angles ``a`` and the reference in the level frame of gravity's direction once it is known, else as
        they are (start-relative)."""
        from walkmon.gait.session import level_basis, level_frame_angles  # noqa: PLC0415

        if self._vertical is None:
            return a, self._reference
        basis = level_basis(self._vertical)
        return level_frame_angles(a, basis), level_frame_angles(self._reference[None, :], basis)[0]

    def _learn_gravity(self, a: tuple[float, float, float], abs_deg: tuple[float, float]) -> None:
        """Gravity's direction in the start frame from an IMU: each sample's gravity (from ``abs_deg``) turned into
        the start frame by its orientation ``a``, averaged over the session (the fused angles and gravity agree
        whatever the camera's tilt on the trunk, from the first hop on, without waiting for a turn)."""
        from walkmon.consts import gravity_from_angles_deg, rotation_from_angles_deg  # noqa: PLC0415

        if not all(math.isfinite(float(v)) for v in abs_deg):
            return
        self._gravity_sum += rotation_from_angles_deg(a[0], a[1], a[2]) @ gravity_from_angles_deg(*abs_deg)
        self._vertical = self._gravity_sum / float(np.linalg.norm(self._gravity_sum))

    def _learn_vertical(self, t: NDArray[np.float64], a: NDArray[np.float64], turns: tuple) -> None:
        """Add each turn of 60 deg or more, once it lies in the window with a stride's margin on both sides, to
        the turns that give gravity's direction (:func:`walkmon.gait.session.turn_axis`)."""
        from walkmon.gait.session import (  # noqa: PLC0415
            camera_level_down,
            turn_axis,
            turn_axis_doubt_deg,
            vertical_from_axes,
            vertical_with_level,
        )

        if self._gravity_known:
            return  # an IMU gives gravity itself
        added = False
        for u in turns:
            if u.start_s <= self._turns_done_s:
                # a turn already taken (each hop's window finds it again, its end a little later): once only
                self._turns_done_s = max(self._turns_done_s, u.end_s)
                continue
            if abs(u.angle_deg) < 60.0 or u.end_s + 1.6 > t[-1]:
                continue
            r = turn_axis(t, a, u.start_s, u.end_s)
            if r is not None and r[1] >= 30.0:
                self._turn_axes = [*self._turn_axes, r][-_MAX_TURN_AXES:]
                doubt = turn_axis_doubt_deg(t, a, u.start_s, u.end_s, r[0])
                # NaN only for a turn with < 3 samples inside, which detect_turns (>= 0.5 s) does not give
                self._turn_doubts = [*self._turn_doubts, doubt if math.isfinite(doubt) else 0.0][-_MAX_TURN_AXES:]
                added = True
            self._turns_done_s = u.end_s
        if added:
            # one turn alone is taken too (a tilted chest camera is the rule, a posture change mid-turn the
            # exception); turns that do not verify each other are checked against the camera-level assumption,
            # as offline (walkmon.gait.session.vertical_with_level)
            v = vertical_with_level(vertical_from_axes(self._turn_axes), camera_level_down(self._reference))
            self._vertical = None if v is None else v.down
            # the doubt of the turns this direction rests on (not of those left out as disagreeing)
            kept = set() if v is None else {id(ax) for ax, _ in v.axes}
            self._vertical_doubt = max((d for (ax, _), d in zip(self._turn_axes, self._turn_doubts, strict=True)
                                        if id(ax) in kept), default=0.0)

    def _tilt_doubt_deg(self, a: NDArray[np.float64], ref: NDArray[np.float64], m: NDArray[np.bool_]) -> tuple[
        float, float, str
    ]:
        """How far the heading-free (pitch, roll) of the samples ``m`` may be off, and why. Gravity's direction not
        known well enough: ``2 sin(dpsi / 2)`` times the direction's possible error, ``dpsi`` the heading turned
        since the reference (an error of the direction shows in the tilt only as the wearer faces away from where
        the reference was taken), in pitch and roll alike; and in pitch, the video's drift across each stretch of
        tilting far and fast since the reference (``tilt_drift_deg``, :meth:`_count_tilts`: the chest drops while
        it pitches, and a camera facing a near surface can take the drop for a pitch; a roll has no translation
        to be taken for). ``a`` and ``ref``: the angles and the reference, in the level frame when the direction
        is known. 0 with an IMU's gravity.

        * Learnt from turns: the largest doubt of the turns it rests on (:func:`walkmon.gait.session.
          turn_axis_doubt_deg`; those vertical_from_axes and vertical_with_level kept). The live replay of the
          unkind sessions gave 8 pathology hops on true normal walking after turns (seeds 1-5: a 15 deg posture
          change across a turn, or the video's drift, had tilted the direction by 4-8 deg): 0 with this; labels
          right 349 -> 335 of 560. The largest turn's doubt was chosen as the bound the direction rests on (the
          mean or median kept 8-12 more right labels on both seed sets, with the same 0 false ones: tuning on
          them, not done). Held-out seeds 6-10: 3 -> 0 false, right 399 -> 377 of 600. (Taken over every turn
          seen, including those left out, it was 331 and 373: found in review.)
        * Not learnt yet (no turn of 60 deg or more; the camera assumed level on the trunk): the camera's tilt on
          the trunk, up to ``mount_tilt_deg`` (20 deg, the offline analysis' a-priori bound). A camera 12 deg down
          read 5-10 deg of roll after a 30-45 deg turn (a corner, a curved path), which raised shoulder_down and
          labelled the normal walk left_shoulder_down (found in review, on simulator truth)."""
        from walkmon.gait.session import DEFAULT_SESSION_SETTINGS  # noqa: PLC0415

        if self._gravity_known or not m.any():
            return 0.0, 0.0, ""
        yaw = np.radians(a[m, 1] - float(ref[1]))
        dpsi = abs(math.degrees(math.atan2(float(np.mean(np.sin(yaw))), float(np.mean(np.cos(yaw))))))
        factor = 2.0 * math.sin(math.radians(dpsi) / 2.0)
        if self._vertical is None:
            bound = DEFAULT_SESSION_SETTINGS.mount_tilt_deg
            doubt, why = factor * bound, (
                f"gravity's direction is not known yet (no turn of 60 deg or more to learn it from; the camera is "
                f"assumed level on the trunk, which it may not be by up to {bound:g} deg): after turning "
                f"{dpsi:.0f} deg the tilt may be off by {factor * bound:.1f} deg")
        else:
            doubt, why = factor * self._vertical_doubt, (
                f"gravity's direction rests on turns whose axes are in doubt by up to {self._vertical_doubt:.1f} deg "
                f"(a posture change or the video's drift across a turn), {factor * self._vertical_doubt:.1f} deg of "
                f"tilt at this heading")
        # the video's own pitch drift: each stretch of tilting far and fast since the reference was taken may move
        # it (the offline analysis' per-turn bound, walkmon.gait.session._reference_model; turns: their axes' doubt)
        pitch = doubt
        n = self._tilts_since_reference()
        per = self.settings.tilt_drift_deg
        if n and per > 0:
            drift = math.sqrt(n) * per
            pitch = math.hypot(doubt, drift)
            why += (f"; and the video's pitch may have moved by up to {per:g} deg each time the trunk tilted far and "
                    f"fast since the upright reference was taken (sitting down, standing up, picking something up: "
                    f"{n}, {drift:.1f} deg)")
        return pitch, doubt, why

    def _tilts_since_reference(self) -> int:
        """Handled stretches (:meth:`_count_tilts`) since the upright reference was taken (all of them before a
        reference was: the first frame is it)."""
        since = self._calibrated_at_s if self._calibrated else -math.inf
        return sum(1 for end in self._tilt_ends if end > since)

    def _count_tilts(self, t: NDArray[np.float64], seg: Any) -> None:
        """Note the end of each handled stretch of the window's segmentation ``seg`` (the trunk tilted far and fast)
        once it is complete (a stride's margin before the window's end), once: each hop's window finds it again,
        its ends a little later. A video's orientation can drift there: sitting down or picking something up, the
        chest drops 0.3-0.5 m while it pitches 25-75 deg, which a camera facing a near surface can take for a
        rotation (4.5 deg of pitch after sitting down, 8 after picking something up, in the simulator's
        sessions; since 2026-11-28 the rotation estimator takes such a drift out where it sees clear vertical
        lines, :data:`walkmon.rotation.fast._FAST_TILT_DEG`, and this bound stays for the views without them)."""
        if self._gravity_known:
            return
        from walkmon.gait.activity import _runs  # noqa: PLC0415

        grid = np.asarray(seg.timeline_t_s, dtype=float)
        handled = np.asarray(seg.handled, dtype=bool)
        if handled.size != grid.size:
            return
        for i0, i1 in _runs(handled):
            a, b = float(grid[i0]), float(grid[i1 - 1])
            if a <= self._tilts_counted_s:
                self._tilts_counted_s = max(self._tilts_counted_s, b)  # noted already (found again, a little later)
            elif b + 1.6 <= t[-1]:
                self._tilt_ends = [*self._tilt_ends, b][-_MAX_TURN_AXES:]
                self._tilts_counted_s = b

    def _activity(self, t: NDArray[np.float64], a: NDArray[np.float64], t_now: float) -> tuple[
        str, tuple[float, float] | None
    ]:
        """Activity at ``t_now`` from the window's segmentation, and the walking span to classify."""
        from walkmon.gait.activity import segment, signals_from_angles  # noqa: PLC0415

        if len(t) < 10 or t[-1] - t[0] < 2.0:
            return "unknown", None
        try:
            seg = segment(signals_from_angles(t, a))
        except Exception:  # noqa: BLE001 - a degenerate window is 'unknown', never a crash of the live loop
            return "unknown", None
        self._learn_vertical(t, a, seg.turns)
        self._count_tilts(t, seg)
        for u in seg.turns:
            if u.end_s >= t_now - 0.5:
                return "turning", None
        if seg.bouts:
            b = seg.bouts[-1]
            d = np.diff(b.steps_s)
            step = float(np.median(d)) if d.size else 1.0
            if t_now - b.end_s <= max(1.5 * step, 1.0):
                # the span after the last turn inside the bout
                start = max([b.start_s, *(u.end_s for u in seg.turns if u.end_s <= b.end_s)])
                self._last_steps = seg.steps_s
                return "walking", (start, float(b.end_s))
        act = seg.activity_at(np.array([t_now]))[0]
        return ("standing" if act == "standing" else "unknown"), None

    def _classify_span(self, t: NDArray[np.float64], a: NDArray[np.float64], span: tuple[float, float]):  # noqa: ANN202
        """The offline classifier on the window's walking span (heading-free angles from the reference; in the
        level frame of gravity's direction once the turns gave it, as the offline analysis)."""
        from walkmon.gait.session import (  # noqa: PLC0415
            ReferenceUncertainty,
            change_points,
            heading_free_angles,
            label_within_uncertainty,
            span_indicators,
        )

        a, ref = self._level(a)
        hf = heading_free_angles(t, a, ref, None if self._vertical is None else np.array([0.0, 1.0, 0.0]))
        steps = self._last_steps  # the window's steps, from the segmentation that found the walking span
        m = (t >= span[0]) & (t <= span[1])
        cuts = change_points(t[m], hf[m])  # a posture change inside the span: classify what follows it
        start = cuts[-1] if cuts else span[0]
        ind, _ = span_indicators(t, hf, start, span[1], np.zeros(3), steps, "angles")
        pitch, roll, why = self._tilt_doubt_deg(a, ref, (t >= start) & (t <= span[1]))
        if ind.classification.label in _POSTURE_LABELS and max(pitch, roll) > 0:
            # a posture label that the doubt could change is withheld, as offline
            # (walkmon.gait.session.label_within_uncertainty with the same corners)
            deg = np.tile([pitch, roll], (t.size, 1))
            unc = ReferenceUncertainty(deg, np.zeros(t.size, dtype=np.int64), (why,))
            ind = ind.with_classification(label_within_uncertainty(
                ind.classification, ind.to_dict(), [(start, span[1])], t, unc, None))
        if ind.classification.label in _POSTURE_LABELS:
            again = upright_again(t, hf, start, span[1])
            if again is not None:
                ind = ind.with_classification(Classification("unclassified", (again, *ind.classification.reasons)))
        return ind
