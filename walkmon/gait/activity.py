"""Activity segmentation and step detection from trunk motion: standing / walking / turning / unknown.

Works on any trunk-worn recording (chest or neck like walkmon's camera, or the lower back like the Mobilise-D
sensor), from one of three inputs, all reduced to the same two signals on a uniform grid:

* a **step signal** that moves once per step: the vertical acceleration (accelerometer projected on the
  low-passed gravity direction, gravity removed; m/s²) with an IMU or an accelerometer alone, or the pitch angle
  (degrees) of a camera's rotation estimate;
* a **heading rate** (deg/s): the gyroscope's component along gravity with an IMU, the yaw rate of the video
  angles; none with an accelerometer alone (no turns then, and the output says so).

Processing (:func:`segment`):

1. **Gait candidates**: windows (``window_s``) whose step signal is periodic at a step rhythm (normalised
   autocorrelation >= ``min_periodicity`` at a lag of one step or one stride, the stride lag covering
   asymmetric gait) and strong enough (RMS in the gait band >= the source's ``min_rms``).
2. **Steps** (initial-contact proxies): in each candidate region, the step signal low-passed at
   ``lowpass_factor`` x the region's step frequency (from the autocorrelation), one maximum per step (maxima at
   least ``min_step_fraction`` of a step apart). From camera angles a region whose rhythm changes (by
   ``pace_change_ratio``, a step and a stride of one rhythm counting as one; :func:`_pace_pieces`) is split
   there first, each piece with its own rhythm. From trunk acceleration, which repeats once per step, a
   window's lag longer than any step (``step_period_s``) is a stride and is halved into the step range before
   the region takes its rhythm (the camera's pitch may repeat per stride: :func:`_is_stride` decides there).
   The vertical acceleration peaks just after each heel strike,
   so the maxima lag the initial contacts by a nearly constant delay: cadence and bouts are unaffected. A maximum
   where the acceleration itself hardly moves, or has no maximum of its own, is the band-pass ringing beside a
   stop, not a step (``ringing_fraction``, ``ringing_peak_s``; :func:`_without_ringing`).
3. **Walking bouts** (Mobilise-D convention, Kluge et al. 2021, PLoS ONE 16(8) e0256541 and the mobgap
   ``WbAssembly`` defaults): steps closer than ``max_break_s`` = 3 s belong to one bout (a shorter pause
   joins the bouts around it); a bout needs ``min_steps`` = 4 steps (two strides). A bout runs from its first
   to its last step; leading/trailing steps weaker than ``weak_step_fraction`` x the bout's median step amplitude
   (a weight shift before the first step, sway after the last) and a first/last step interval shorter than
   0.6 x the bout's median are gait initiation/termination, not steps, and are dropped. From an IMU (whose
   events are steps), so is a first or last step that starts or ends no stride of at most 3 s
   (:func:`_stride_edges`: Mobilise-D assembles bouts from strides; a lone step 2.8 s after a bout's last
   joined it by the step rule, and MS/001's course ran 2.8 s past an INDIP bout's end on one).
   From camera angles only, the ends of each bout are searched again (:func:`_extend_edges`) for the steps a
   posture change at the same time hides from the running-median pitch: the pitch about its mean over one step
   period, maxima in the bout's rhythm, strong enough, where the trunk is not still. Known weakness: bending
   while standing just before or after a walk moves the trunk (not still) and leaves a bump after the one-step
   mean; a synthetic 10 deg bend ending 0.5 s before the first step starts the bout ~1 s early.
4. **Cadence per bout** from the steps: the mean of 120 / stride duration over the strides of ``stride_s``
   (0.2-3.0 s, the duration rule of Mobilise-D's stride selection), after mending an isolated missed step (an
   interval ~2x the median step between ordinary ones) and extra ones (two short intervals summing to one).
   From camera angles, no mending: strides with an interval off the local rhythm are left out instead
   (:func:`cadence_from_steps`). The spectral peak of the bout is kept as a cross-check.
5. **Turns** (El-Gohary et al. 2013, Sensors 14(1) 356-369; also mobgap's ``TdElGohary``): the heading rate
   low-passed at 1.5 Hz; a turn is a run above ``turn_edge_deg_s`` (5 deg/s) that peaks above
   ``turn_peak_deg_s`` (15 deg/s) and turns at least ``turn_min_deg`` (45 deg) in 0.5-10 s.
6. **Handling**: where the trunk's tilt (:func:`tilt_change_deg`; for camera angles pitch and roll) spreads over
   more than ``reorient_deg`` within ``reorient_window_s``, outside turns, the sensor is being
   handled (put on, taken off) or the wearer sits down, stands up or bends down; so is it, turns or not, where a
   gyroscope's angular rate has an RMS over that window above ``spin_deg_s`` (faster than a trunk turns): steps
   there are dropped, and so are the few steps such a stretch cuts off a bout's ends and a lone edge step just beside it
   (:func:`_without_handled_edges`); inside a bout the stretch is a pause (shorter than ``max_break_s`` it joins, as
   above). A sensor turned over more slowly than that is caught per bout: an IMU's or accelerometer's bout whose
   gravity direction lies more than ``reorient_deg`` from its median direction (each stretch between handled
   ones against its own) for more than a quarter of its time is no walk (:func:`_tilt_wanders`).
7. **Timeline** at ``hop_s``: ``turning`` inside turns, ``walking`` inside bouts, ``standing`` where the trunk
   is still (step-signal RMS, or the raw signal's spread, and, with a gyro, angular rate below the standing
   limits; :func:`_still_samples`) and ``unknown`` otherwise (moving without a gait rhythm: sitting down,
   bending, handling the camera) and where handled.

Thresholds were chosen on one healthy participant's recordings (Mobilise-D lab example HA/002) and checked,
unchanged, on the others (the MS participant and the Oxford neck-pouch sessions): ``benchmarks/bench_real_gait.py``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from walkmon.errors import InvalidInputError
from walkmon.sampling import gaps, sampling_rate_hz

__all__ = [
    "ACTIVITIES",
    "DEFAULT_ACTIVITY_SETTINGS",
    "ActivitySettings",
    "Bout",
    "Segmentation",
    "TrunkSignals",
    "Turn",
    "bouts_from_steps",
    "cadence_from_steps",
    "corrected_step_times",
    "detect_steps",
    "detect_turns",
    "gravity_direction",
    "segment",
    "signals_from_angles",
    "signals_from_imu",
    "steady_state_steps",
    "tilt_change_deg",
]

ACTIVITIES = ("standing", "walking", "turning", "unknown")

G = 9.80665
STILL_WINDOW_S = 1.0  # the standing test's window (:func:`_still_samples`), s
#: A hole in the samples at least this long (and shorter than ``max_gap_s``) may hide a step: no stride across it
#: counts in a cadence (a 0.95 s dropout lost two steps and read a bout 2 % slow: user review)
HOLE_S = 0.25


#: The share of a bout's time (outside handled stretches) that gravity's direction may spend more than
#: ``reorient_deg`` from its median direction (each stretch between handled ones its own); beyond it the bout is
#: a sensor turned by hand (:func:`_tilt_wanders`): a quarter, so a short bend or a pick-up the handling rule
#: missed is no reason
TILT_WANDER_FRACTION = 0.25

#: How far a difference of times (s) may pass a bound and still meet it: steps found on a sample grid make strides
#: of exactly 3.00 s, which a float difference reads as 3.0000000000000004 (10.8 - 7.8), and the 3.0 s bound
#: dropped such a stride (a simulated bout read +1.5 % for it)
DURATION_TOLERANCE_S = 1e-9


@dataclass(frozen=True, slots=True)
class ActivitySettings:
    """Settings of the segmentation (seconds, Hz, steps/min; see the module text for their role)."""

    rate_hz: float = 50.0
    window_s: float = 3.0
    hop_s: float = 0.1
    step_period_s: tuple[float, float] = (0.3, 1.1)  # 55-200 steps/min
    min_periodicity: float = 0.4
    min_rms_acc: float = 0.25  # m/s², vertical acceleration in the gait band
    min_rms_deg: float = 0.25  # degrees, pitch in the gait band (video)
    lowpass_factor: float = 1.6
    min_step_fraction: float = 0.6
    max_break_s: float = 3.0
    # trunk acceleration: the strides a bout's cadence averages, s: longer than the first, up to the second (the
    # duration half of Mobilise-D's stride selection; its length half, >= 0.15 m, needs a stride length walkmon
    # does not measure): slow turning strides and short stops included
    stride_s: tuple[float, float] = (0.2, 3.0)
    min_steps: int = 4
    # camera angles, a bout with too few regular strides (see :func:`cadence_from_steps`): strides beyond
    # pause_factor x the median stride about them (pause_window_strides either side), or below it /
    # hurried_factor, are left out
    pause_factor: float = 1.3
    hurried_factor: float = 1.6
    pause_window_strides: int = 3
    rhythm_ratio: float = 1.3  # camera angles: a stride with an interval this far off the local rhythm is not used
    rhythm_window_steps: int = 4
    missed_step_ratio: tuple[float, float] = (1.6, 2.5)  # an interval this many median steps long: one step missed
    ordinary_step_ratio: float = 1.4  # neighbours of a missed step are shorter than this x the median
    extra_step_fraction: float = 0.7  # two intervals each shorter than this x the median, summing to one: one extra
    # an interval whose middle half moves less than this x the bout's typical step (the gait-band RMS) is a pause,
    # never a missed step (:func:`quiet_intervals`)
    quiet_interval_ratio: float = 0.3
    turn_edge_deg_s: float = 5.0
    turn_peak_deg_s: float = 15.0
    turn_min_deg: float = 45.0
    turn_duration_s: tuple[float, float] = (0.5, 10.0)
    still_rms_acc: float = 0.15  # m/s²
    still_rms_deg: float = 0.15  # degrees
    still_gyro_deg_s: float = 10.0  # RMS angular rate
    weak_step_fraction: float = 0.3  # edge steps weaker than this x the bout's median amplitude are not steps
    # trunk acceleration: a 'step' whose acceleration spans less than this x the median of its own and its
    # neighbours' (ringing_window_steps either side) is the band-pass ringing beside a stop, not a heel strike
    # (see :func:`_without_ringing`)
    ringing_fraction: float = 0.1
    ringing_window_steps: int = 4
    # ... and one without a maximum of the acceleration itself within this many seconds (0: not asked)
    ringing_peak_s: float = 0.1
    edge_steps: int = 2  # steps of gait initiation / termination at each end of a bout (not steady walking)
    turn_margin_s: float = 0.5  # steps this close to a turn are turn entry / exit (not steady walking)
    # camera angles only: a bout's edges are searched again for the steps of gait initiation / termination that
    # a posture change at the same time hides from the running-median step signal (see :func:`_extend_edges`)
    edge_search_steps: int = 3  # at most this many steps added at each end of a bout (0: no search)
    # an added step lies this many median steps from its neighbour (the first and last steps are slower)
    edge_rhythm: tuple[float, float] = (0.7, 1.3)
    edge_prominence: float = 0.6  # x the bout's RMS of the one-step detrended pitch (a steady step: ~2.8)
    # camera angles: where the pitch repeats once per stride (:func:`_is_stride`), the steps are the maxima of
    # its step-frequency band, this many times the step frequency
    stride_band: tuple[float, float] = (0.7, 1.3)
    pace_change_ratio: float = 1.2  # camera angles: a gait region splits where its rhythm changes this much
    # where the trunk's tilt spreads over more than this within reorient_window_s (outside turns), the sensor is
    # being handled or the wearer sits down, stands up or bends down: no steps there (see :func:`segment`); the
    # window is applied when the signals are made (signals_from_imu / signals_from_angles)
    reorient_deg: float = 45.0
    reorient_window_s: float = 1.5
    # a gyroscope's angular rate whose RMS over reorient_window_s is above this (deg/s) is a sensor spun by hand,
    # not a walker's trunk, turns included: a trunk's reaches 115 deg/s on the Mobilise-D courses' tightest turns
    # (peaks of 136 deg/s; 126 in the simulator's 90-180 deg turns); BROAD's hand-held rotations run at 200-700
    spin_deg_s: float = 250.0
    # no samples for this long or longer (a dropout, the logger paused; walkmon.sampling.gaps): nothing is known
    # there, so it is unknown, holds no steps and no turn, and no bout spans it (a step or more is lost in it)
    max_gap_s: float = 1.0

    def __post_init__(self) -> None:
        for name in ("rate_hz", "window_s", "hop_s", "min_periodicity", "lowpass_factor", "max_break_s",
                     "reorient_deg", "reorient_window_s", "spin_deg_s", "max_gap_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                msg = f"activity setting {name} must be a finite number > 0, got {v}"
                raise InvalidInputError(msg)
        lo, hi = self.missed_step_ratio
        if not (1.0 < lo < hi) or not (0.0 < self.extra_step_fraction < 1.0):
            msg = (f"missed_step_ratio must be 1 < low < high and extra_step_fraction in (0, 1), got "
                   f"{self.missed_step_ratio}, {self.extra_step_fraction}")
            raise InvalidInputError(msg)
        if not 1.0 < self.pace_change_ratio <= math.sqrt(2.0):
            msg = (f"pace_change_ratio must be in (1, 1.414] (a step and a stride of one rhythm are one rhythm, so "
                   f"two rhythms differ by at most a factor sqrt 2), got {self.pace_change_ratio}")
            raise InvalidInputError(msg)
        if not 0.0 < self.stride_s[0] < self.stride_s[1]:
            msg = f"stride_s must be 0 < shortest < longest, got {self.stride_s}"
            raise InvalidInputError(msg)
        if int(self.min_steps) < 2:
            msg = f"min_steps must be >= 2, got {self.min_steps}"
            raise InvalidInputError(msg)
        w = self.ringing_window_steps
        if not 0.0 <= self.ringing_fraction < 1.0 or not (float(w).is_integer() and w >= 1):
            msg = (f"ringing_fraction must be in [0, 1) (0: every maximum kept) and ringing_window_steps >= 1, got "
                   f"{self.ringing_fraction}, {self.ringing_window_steps}")
            raise InvalidInputError(msg)
        if not self.ringing_peak_s >= 0.0:
            msg = f"ringing_peak_s must be >= 0 (0: not asked), got {self.ringing_peak_s}"
            raise InvalidInputError(msg)


DEFAULT_ACTIVITY_SETTINGS = ActivitySettings()


@dataclass(frozen=True, slots=True)
class TrunkSignals:
    """The two signals of the segmentation on a uniform grid: ``t_s`` (N,), ``step`` (N,), ``heading_rate``
    (N,) deg/s or None, ``tilt_deg`` (N,2) gravity pitch/roll or None; ``kind`` 'imu', 'acc' or 'angles'."""

    t_s: NDArray[np.float64]
    step: NDArray[np.float64]
    heading_rate_deg_s: NDArray[np.float64] | None
    kind: str
    gyro_norm_deg_s: NDArray[np.float64] | None = None
    tilt_deg: NDArray[np.float64] | None = None
    #: the camera's pitch itself (angles only), for the bouts' edge search (:func:`_extend_edges`)
    pitch_deg: NDArray[np.float64] | None = None
    #: how far the trunk's tilt spreads within ``reorient_window_s`` about each sample, degrees (gravity's
    #: direction in an IMU, :func:`tilt_change_deg`; a camera's pitch and roll), for the handling rule
    tilt_change_deg: NDArray[np.float64] | None = None
    #: the camera's yaw and roll (angles only, (N,2) degrees): the trunk's axial rotation and side bend, which
    #: swing once per stride, for telling a step from a stride (:func:`_is_stride`)
    sway_deg: NDArray[np.float64] | None = None
    #: per sample: inside a gap of the recording (no samples for ``max_gap_s`` or longer; the signals there are
    #: the straight line :func:`_resample` bridged it with); None without such a gap
    gap: NDArray[np.bool_] | None = None
    #: the gaps themselves, ``(last sample before, first sample after)``
    gaps_s: tuple[tuple[float, float], ...] = ()
    #: shorter holes (``HOLE_S`` to ``max_gap_s``) a bout may span but a step in them is not known: no stride
    #: across one counts in a cadence (:func:`cadence_from_steps`)
    holes_s: tuple[tuple[float, float], ...] = ()
    #: how far the measurement itself spreads within ``STILL_WINDOW_S`` about each sample, unfiltered (the
    #: acceleration vector in m/s², or a camera's pitch and roll in degrees), for the standing test
    #: (:func:`_still_samples`); None: not measured
    spread: NDArray[np.float64] | None = None
    #: gravity's direction in the sensor per sample, (N,3) unit vectors pointing up (:func:`gravity_direction`),
    #: for the bouts' tilt test (:func:`_tilt_wanders`); None: not measured (camera angles)
    gravity_up: NDArray[np.float64] | None = None
    #: the step signal's gait band per rate, filled by :func:`gait_band` (one filter over the recording, not one
    #: per bout and posture segment)
    _bands: dict[float, NDArray[np.float64]] = field(default_factory=dict, repr=False, compare=False)

    @property
    def rate_hz(self) -> float:
        return (len(self.t_s) - 1) / max(float(self.t_s[-1] - self.t_s[0]), 1e-9)


@dataclass(frozen=True, slots=True)
class Turn:
    start_s: float
    end_s: float
    angle_deg: float

    def to_dict(self) -> dict[str, Any]:
        return {"start_s": round(self.start_s, 3), "end_s": round(self.end_s, 3), "angle_deg": round(self.angle_deg, 1)}


@dataclass(frozen=True, slots=True)
class Bout:
    """A walking bout: first to last step, its steps' times, cadence from the steps and from the spectrum."""

    start_s: float
    end_s: float
    steps_s: tuple[float, ...]
    cadence_spm: float
    spectral_cadence_spm: float

    @property
    def n_steps(self) -> int:
        return len(self.steps_s)

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s


@dataclass(frozen=True, slots=True)
class Segmentation:
    """Bouts, turns, all detected steps, and the activity per ``hop_s`` (``timeline_t_s``, ``activity``)."""

    bouts: tuple[Bout, ...]
    turns: tuple[Turn, ...]
    steps_s: NDArray[np.float64]
    timeline_t_s: NDArray[np.float64]
    activity: tuple[str, ...]
    source: str
    notes: tuple[str, ...] = field(default_factory=tuple)
    #: steps of steady walking: bout steps minus the first and last ``edge_steps`` of each bout (gait
    #: initiation and termination) and minus steps within ``turn_margin_s`` of a turn
    steady_steps_s: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    still: tuple[bool, ...] = ()  # per timeline sample: the trunk still (before bouts and turns overwrite it)
    handled: tuple[bool, ...] = ()  # per timeline sample: the sensor handled (:func:`_handled_samples`)
    gap: tuple[bool, ...] = ()  # per timeline sample: inside a gap of the recording (TrunkSignals.gap)

    @property
    def walking_s(self) -> float:
        return float(sum(b.duration_s for b in self.bouts))

    def activity_at(self, t_s: ArrayLike) -> NDArray[np.str_]:
        """Activity at arbitrary times (nearest timeline sample)."""
        tt = np.asarray(t_s, dtype=float)
        if not self.activity:
            return np.full(tt.shape, "unknown")
        return np.asarray(self.activity)[self._index(tt)]

    def in_gap(self, t_s: ArrayLike) -> NDArray[np.bool_]:
        """Inside a gap of the recording at arbitrary times (nearest timeline sample; :attr:`gap`)."""
        tt = np.asarray(t_s, dtype=float)
        if len(self.gap) != len(self.activity) or not any(self.gap):
            return np.zeros(tt.shape, dtype=bool)
        return np.asarray(self.gap, dtype=bool)[self._index(tt)]

    def _index(self, tt: NDArray[np.float64]) -> NDArray[np.intp]:
        return np.clip(np.searchsorted(self.timeline_t_s, tt - 0.5 * self._hop()), 0, len(self.activity) - 1)

    def _hop(self) -> float:
        return float(self.timeline_t_s[1] - self.timeline_t_s[0]) if len(self.timeline_t_s) > 1 else 0.1


# --------------------------------------------------------------------------------------------- filters
def _butter(x: NDArray[np.float64], fs: float, cutoff: float | tuple[float, float], btype: str) -> NDArray[np.float64]:
    from scipy import signal

    nyq = 0.5 * fs
    if btype == "band":
        lo, hi = cutoff  # type: ignore[misc]
        hi = min(hi, 0.9 * nyq)
        sos = signal.butter(2, (lo, hi), btype="band", fs=fs, output="sos")
    else:
        c = min(float(cutoff), 0.9 * nyq)  # type: ignore[arg-type]
        sos = signal.butter(2, c, btype="low" if btype == "low" else "high", fs=fs, output="sos")
    if len(x) < 16:
        return x.copy()
    return signal.sosfiltfilt(sos, x, axis=0)


#: a recording sampled faster than the analysis rate is low-passed at this fraction of the analysis rate before it
#: is decimated to it (anti-aliasing; see :func:`_resample`)
_ANTI_ALIAS_FRACTION = 0.4


def _resample(t: NDArray[np.float64], x: NDArray[np.float64], rate_hz: float) -> tuple[NDArray, NDArray]:
    """``x`` (N, ...) sampled at times ``t`` on a uniform grid at ``rate_hz``: ``(grid, values)``.

    The same walk must read the same whatever rate its sensor sampled it at. Decimated by interpolation alone, a
    100 Hz recording folded its heel strikes' 25-50 Hz content into the gait band (no anti-aliasing: a floor
    vibrating at 48 Hz read as walking at 120 steps/min), and a 60 Hz one, interpolated linearly straight onto
    the 50 Hz grid, folded the images of its 10-25 Hz content there: a Mobilise-D course resampled from its
    100 Hz to 50, 60, 128 and 200 Hz (band-limited, scipy's resample_poly) gave bouts whose cadences differed by
    up to 8 % (and one 63 steps/min or none).

    So a recording faster than ``rate_hz`` (its rate: :func:`walkmon.sampling.sampling_rate_hz`, gaps left out)
    is interpolated linearly onto a uniform grid k times finer than ``rate_hz`` and at least twice the
    recording's rate (gaps bridged by a straight line, as before; :func:`segment` then takes them for unknown),
    low-passed there (4th-order Butterworth, zero phase, at ``_ANTI_ALIAS_FRACTION``
    x ``rate_hz``, 20 Hz: well above the gait band) and decimated by k. At twice its rate the linear
    interpolation's images of the recording's content (at its rate +- up to half of it) stay above the filter's
    cut-off on the fine grid; on a grid only 50 Hz above its rate a 48 Hz vibration in a 100 Hz recording folded
    to 2 Hz. A cubic spline straight onto the grid reconstructed as well but took 300 MB for an hour at 200 Hz
    and was fooled by timestamps that arrive in bursts; this takes about 3 s and 130 MB.

    On HA/002's course the five rates then give the same bouts (edges within 0.02 s, cadences within 0.4 %); on
    MS/001's the recording and its 128 and 200 Hz versions give the same bouts, at 50 Hz the last bout starts
    2.8 s later and at 60 Hz the 45-57 s bout reads 63 steps/min where the others have none (a signal
    difference of about 1 % flips them: the segmentation's sensitivity, see bench_real_gait.py's spread table).
    A slower recording (a camera's 30 frames/s) is interpolated linearly, as before; a fast camera's angles (an
    action camera at 60-240 frames/s) take the same path as an IMU."""
    n = int(math.floor((t[-1] - t[0]) * rate_hz)) + 1
    grid = t[0] + np.arange(n) / rate_hz
    x2 = x.reshape(len(t), -1)
    fs_in = sampling_rate_hz(t) if len(t) > 1 else rate_hz
    if fs_in <= 1.05 * rate_hz or n < 32:
        out = np.column_stack([np.interp(grid, t, x2[:, c]) for c in range(x2.shape[1])])
        return grid, out.reshape((n, *x.shape[1:]))
    from scipy import signal

    k = max(2, int(math.ceil(2.0 * fs_in / rate_hz)))
    fine = t[0] + np.arange((n - 1) * k + 1) / (rate_hz * k)
    sos = signal.butter(4, _ANTI_ALIAS_FRACTION * rate_hz, btype="low", fs=rate_hz * k, output="sos")
    # one column at a time: an hour at 200 Hz is 1.4 million fine samples a column
    out = np.column_stack([signal.sosfiltfilt(sos, np.interp(fine, t, x2[:, c]))[::k] for c in range(x2.shape[1])])
    return grid, out.reshape((n, *x.shape[1:]))


#: The longest recording the segmentation takes (s): its analysis grid spans the recording, gaps included.
MAX_SPAN_S = 48 * 3600.0


def _check(t: ArrayLike, *arrays: ArrayLike) -> NDArray[np.float64]:
    tt = np.asarray(t, dtype=float)
    if tt.ndim != 1 or tt.size < 10:
        msg = (f"too short to analyse: {tt.size} sample(s) or frame(s), at least 10 needed (an image or a clip of "
               "a few frames is no recording of a walk)")
        raise InvalidInputError(msg)
    if not np.all(np.isfinite(tt)):
        i = int(np.flatnonzero(~np.isfinite(tt))[0])
        msg = f"times must be finite: sample {i + 1} has t={tt[i]}"
        raise InvalidInputError(msg)
    if np.any(np.diff(tt) <= 0):
        i = int(np.flatnonzero(np.diff(tt) <= 0)[0])
        msg = f"times must strictly increase: sample {i + 2} has t={tt[i + 1]:.9g} after t={tt[i]:.9g}"
        raise InvalidInputError(msg)
    span = float(tt[-1] - tt[0])
    if span > MAX_SPAN_S:
        # the analysis grid spans the whole recording, gaps included (1e7 s: a MemoryError)
        i = int(np.argmax(np.diff(tt)))
        jump = float(tt[i + 1] - tt[i])
        where = (f"its longest gap, {jump:.6g} s after t={tt[i] - tt[0]:.6g} s (from its first sample), may be a clock "
                 "that jumped: fix its times or split it there" if jump > 0.5 * (span - MAX_SPAN_S)
                 else "split it into recordings of at most that length")
        msg = f"the recording spans {span / 3600:.0f} h, more than {MAX_SPAN_S / 3600:.0f} h: {where}"
        raise InvalidInputError(msg)
    for a in arrays:
        arr = np.asarray(a, dtype=float)
        if arr.shape[0] != tt.size:
            msg = f"signals must have one row per time stamp ({tt.size}), got shape {arr.shape}"
            raise InvalidInputError(msg)
        if not np.all(np.isfinite(arr)):  # the first one named (review: the shape was named, which was right)
            row = int(np.flatnonzero(~np.isfinite(arr.reshape(tt.size, -1)).all(axis=1))[0])
            msg = f"signals must be finite: sample {row + 1} (t={tt[row]:.9g}) has {arr[row].tolist()}"
            raise InvalidInputError(msg)
    return tt


def gravity_direction(acc: NDArray[np.float64], fs: float, cutoff_hz: float = 0.25) -> NDArray[np.float64]:
    """Unit vector of the low-passed specific force (points up, away from the ground) per sample (N,3)."""
    g = _butter(np.asarray(acc, dtype=float), fs, cutoff_hz, "low")
    return g / np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-9)


def signals_from_imu(
    t_s: ArrayLike,
    acc_m_s2: ArrayLike,
    gyro_rad_s: ArrayLike | None = None,
    settings: ActivitySettings = DEFAULT_ACTIVITY_SETTINGS,
) -> TrunkSignals:
    """Trunk signals of an IMU (gyro + acc) or an accelerometer alone (``gyro_rad_s`` None).

    Works in the sensor's own axes: the gravity direction comes from the low-passed accelerometer, so no
    mounting orientation is needed. Pitch/roll (tilt) are those of gravity in the sensor frame.
    """
    t = _check(t_s, acc_m_s2, *(() if gyro_rad_s is None else (gyro_rad_s,)))
    acc = np.asarray(acc_m_s2, dtype=float)
    gyr = None if gyro_rad_s is None else np.asarray(gyro_rad_s, dtype=float)
    grid, acc_u = _resample(t, acc, settings.rate_hz)
    fs = settings.rate_hz
    up = gravity_direction(acc_u, fs)
    vertical = np.einsum("ij,ij->i", acc_u, up) - G
    heading = gnorm = None
    if gyr is not None:
        _, gyr_u = _resample(t, gyr, fs)
        # the rate about the down axis: > 0 turns right, as yaw does (walkmon.consts), for any sensor mounting
        heading = -np.degrees(np.einsum("ij,ij->i", gyr_u, up))
        gnorm = np.degrees(np.linalg.norm(gyr_u, axis=1))
    tilt = np.degrees(np.column_stack([np.arcsin(np.clip(up[:, 2], -1, 1)), np.arcsin(np.clip(up[:, 0], -1, 1))]))
    change = tilt_change_deg(acc_u, None if gyr is None else gyr_u, fs, settings.reorient_window_s)
    return TrunkSignals(grid, vertical, heading, "imu" if gyr is not None else "acc", gnorm, tilt,
                        tilt_change_deg=change, spread=_window_range(acc_u, fs, STILL_WINDOW_S), gravity_up=up,
                        **_gap_fields(t, grid, settings))


def _window_range(x: NDArray[np.float64], fs: float, window_s: float) -> NDArray[np.float64]:
    """For each row of ``x`` (N, d), how far the signal spreads within ``window_s`` centred on it: the norm of
    each column's max - min there (for a rotation about one axis the angle it spans, whether it comes back
    within the window or not: a sensor lifted and put back spans its lift)."""
    from scipy.ndimage import maximum_filter1d, minimum_filter1d

    size = 2 * max(1, int(round(0.5 * window_s * fs))) + 1
    spread = maximum_filter1d(x, size, axis=0, mode="nearest") - minimum_filter1d(x, size, axis=0, mode="nearest")
    return np.asarray(np.linalg.norm(spread, axis=1), dtype=float)


def tilt_change_deg(
    acc: NDArray[np.float64], gyro_rad_s: NDArray[np.float64] | None, fs: float, window_s: float
) -> NDArray[np.float64]:
    """How far gravity's direction in the sensor spreads within ``window_s`` centred on each sample, degrees.

    With a gyroscope: the spread of the rotation's component across gravity, integrated (a turn about the
    vertical adds nothing, acceleration does not enter). With an accelerometer alone: the spread of gravity's
    direction low-passed at 0.5 Hz (as the angle of its chord; the low-pass shrinks a lift and return within a
    second to about half, so with an accelerometer alone mostly one-way tilts and slower handling are caught;
    an accelerometer that reads nothing for 1.5 s or more reads as handled about it).
    Walking spreads a trunk's tilt by up to about 15 deg in a straight line (Mobilise-D lab recordings, lower
    back; more in tight turns, which :func:`segment` leaves out); standing up, sitting down, bending down or
    handling the sensor by 45-90 deg."""
    if gyro_rad_s is None:
        g = _butter(np.asarray(acc, dtype=float), fs, 0.5, "low")
        norm = np.linalg.norm(g, axis=1, keepdims=True)
        up = np.where(norm > 1e-6, g / np.maximum(norm, 1e-6), 0.0)
        chord = _window_range(up, fs, window_s)
        return np.degrees(2.0 * np.arcsin(np.clip(0.5 * chord, 0.0, 1.0)))
    up = gravity_direction(acc, fs)
    across = gyro_rad_s - np.einsum("ij,ij->i", gyro_rad_s, up)[:, None] * up
    return np.degrees(_window_range(np.cumsum(across, axis=0) / fs, fs, window_s))


def signals_from_angles(
    t_s: ArrayLike, angles_deg: ArrayLike, settings: ActivitySettings = DEFAULT_ACTIVITY_SETTINGS
) -> TrunkSignals:
    """Trunk signals of a camera's (pitch, yaw, roll) series in degrees: pitch is the step signal, the yaw
    rate the heading rate."""
    t = _check(t_s, angles_deg)
    # unwrapped (a camera upside down reads roll +-180 deg): the rates, the tilt and the resampling stay smooth
    a = np.degrees(np.unwrap(np.radians(np.asarray(angles_deg, dtype=float)), axis=0))
    grid, a_u = _resample(t, a, settings.rate_hz)
    yaw = _butter(a_u[:, 1], settings.rate_hz, 3.0, "low")
    heading = np.gradient(yaw, 1.0 / settings.rate_hz)
    rate = np.degrees(np.linalg.norm(np.gradient(np.radians(a_u), 1.0 / settings.rate_hz, axis=0), axis=1))
    # a posture change mid-walk (bending down by 15-20 deg within a second) would swamp the 1-2 deg step rhythm
    # of pitch: take the rhythm about the pitch's 1 s running median (one step or more at >= 60 steps/min)
    from scipy.ndimage import median_filter

    smooth = [without_jumps(t, a[:, c]) for c in (0, 2)]  # pitch, roll
    pitch = _resample(t, smooth[0], settings.rate_hz)[1]  # anti-aliased from a fast action camera's frame rate
    step = pitch - median_filter(pitch, size=max(3, int(settings.rate_hz)), mode="nearest")
    # the tilt's change: of pitch and roll (about the start's vertical, so a turn changes them only by the
    # camera's own tilt; :func:`segment` leaves turns out of the handling rule), without the estimate's one-frame
    # corrections and single-frame glitches (a running median over ~0.1 s: 3 frames at 30 fps)
    fps = sampling_rate_hz(t)
    glitch = max(3, int(round(0.1 * fps)) | 1)
    tilt = np.column_stack([_resample(t, median_filter(x, size=glitch, mode="nearest"), settings.rate_hz)[1]
                            for x in smooth])
    change = _window_range(tilt, settings.rate_hz, settings.reorient_window_s)
    return TrunkSignals(grid, step, heading, "angles", rate, None, a_u[:, 0].copy(), tilt_change_deg=change,
                        sway_deg=a_u[:, 1:3].copy(), spread=_window_range(tilt, settings.rate_hz, STILL_WINDOW_S),
                        **_gap_fields(t, grid, settings))


def _gap_fields(t: NDArray[np.float64], grid: NDArray[np.float64], s: ActivitySettings) -> dict[str, Any]:
    """:class:`TrunkSignals`' ``gap``, ``gaps_s`` and ``holes_s`` for samples at ``t`` resampled onto ``grid``."""
    every = gaps(t, HOLE_S)
    holes = tuple((a, b) for a, b in every if b - a < s.max_gap_s)
    found = tuple((a, b) for a, b in every if b - a >= s.max_gap_s)
    if not found:
        return {"holes_s": holes} if holes else {}
    gap = np.zeros(grid.shape, dtype=bool)
    for a, b in found:
        gap[(grid > a) & (grid < b)] = True
    return {"gap": gap, "gaps_s": found, "holes_s": holes}


def without_jumps(t_s: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.float64]:
    """``x`` (degrees, one axis) with its one-sample jumps taken out: a change above _JUMP_MIN_DEG whose rate is
    above _JUMP_FACTOR times the median rate around it (1 s) and three times the rates either side. A trunk does
    not turn by a degree in one frame between frames in which it barely moves; a camera estimate does, where its
    drift is corrected (the vertical lines after a turn: up to ~9 deg at once). Rates, not changes, so that a gap
    in the frames is not taken for a jump. For the step rhythm only: the correction itself is right, the posture
    keeps it."""
    from scipy.ndimage import median_filter

    if x.size < 5:
        return x
    d = np.diff(x)
    dt = np.maximum(np.diff(t_s), 1e-9)
    r = np.abs(d) / dt
    fs = sampling_rate_hz(t_s)
    local = median_filter(r, size=max(3, int(round(fs)) | 1), mode="mirror")
    before = np.concatenate([[np.nan], r[:-1]])
    after = np.concatenate([r[1:], [np.nan]])
    # at the ends the one neighbour there is stands for both
    before = np.where(np.isfinite(before), before, after)
    after = np.where(np.isfinite(after), after, before)
    jump = (np.abs(d) > _JUMP_MIN_DEG) & (r > _JUMP_FACTOR * local) & (before < r / 3.0) & (after < r / 3.0)
    if not jump.any():
        return x
    motion = 0.5 * (before + after) * dt * np.sign(d)  # the frame's own motion, guessed from its neighbours
    return x - np.concatenate([[0.0], np.cumsum(np.where(jump, d - motion, 0.0))])


#: One-sample jumps of camera angles (:func:`without_jumps`): above this (deg) and this many times the local change.
_JUMP_MIN_DEG = 0.75
_JUMP_FACTOR = 6.0


# --------------------------------------------------------------------------------------------- gait windows
def _autocorrelation(seg: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """Normalised autocorrelation of a window, unbiased (each lag's product sum over its overlap); None when flat."""
    seg = seg - seg.mean()
    e = float(np.dot(seg, seg))
    if e <= 0:
        return None
    ac = np.correlate(seg, seg, mode="full")[len(seg) - 1 :]
    overlap = len(seg) - np.arange(len(ac))
    return ac / e * len(seg) / np.maximum(overlap, 1)


def gait_band(sig: TrunkSignals, fs: float) -> NDArray[np.float64]:
    """The step signal band-passed to the gait band (0.4-4 Hz) at sampling rate ``fs``, computed once per signals
    (the segmentation, the steps' amplitudes, the standing test and every bout's pauses use it). Read-only."""
    x = sig._bands.get(fs)
    if x is None:
        x = _butter(sig.step, fs, (0.4, 4.0), "band")
        x.setflags(write=False)
        sig._bands[fs] = x
    return x


def _windowed_gait(sig: TrunkSignals, s: ActivitySettings) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Per hop: centre times, band RMS, periodicity (max normalised autocorrelation at a step or stride lag)
    and the step period in s (NaN where no rhythm)."""
    fs = s.rate_hz
    x = gait_band(sig, fs)
    n = len(x)
    w = int(round(s.window_s * fs))
    hop = max(1, int(round(s.hop_s * fs)))
    lag_lo = int(round(s.step_period_s[0] * fs))
    lag_hi = int(round(s.step_period_s[1] * fs))
    centres = np.arange(0, n, hop)
    rms = np.zeros(len(centres))
    per = np.zeros(len(centres))
    period = np.full(len(centres), np.nan)
    for j, c in enumerate(centres):
        i0, i1 = max(0, c - w // 2), min(n, c + w // 2)
        seg = x[i0:i1]
        if len(seg) < 2 * lag_hi // 2 + 4:
            continue
        rms[j] = float(np.sqrt(np.mean((seg - seg.mean()) ** 2)))
        ac = _autocorrelation(seg)
        if ac is None:
            continue
        hi = min(2 * lag_hi, len(ac) - 1)
        if hi <= lag_lo:
            continue
        per[j], period[j] = _step_lag(ac, lag_lo, hi, fs)
    return sig.t_s[centres], rms, per, period


def _is_stride(p: float, sway: NDArray[np.float64] | None, s: ActivitySettings) -> bool:
    """True when a gait region's rhythm ``p`` (s, the step signal's strongest lag) is a stride, not a step.

    Camera angles: the pitch can repeat once per stride, not per step, where the left and right steps move the
    trunk differently (on the real lower-back walks of Mobilise-D the pitch was anti-correlated at the step
    lag, -0.4, and correlated at the stride lag, +0.9: the cadences came out half the reference's). The
    trunk's axial rotation and side bend (yaw, roll; ``sway`` (N,2) band-passed) swing once per stride in any
    gait: one step later they are in anti-phase, one stride later in phase. So the lag is a stride where one of
    them, about its ~2 s running median (a turn's heading ramp left in the yaw correlated it at every short
    lag: a true 0.75 s step was halved; review), repeats at it (autocorrelation above ``min_periodicity``) and
    is in anti-phase at half of it (below -``min_periodicity``), over a region of three strides or more, while
    no channel is in anti-phase at the lag itself (that says the lag is a step: a stride's sway half a stride
    on; it also keeps a roll that copies a step-rhythm pitch, as a camera yawed on the chest gives, from
    halving it, as long as the yaw sways at all). Whether a channel moves with the pitch is no test: a pitch
    that repeats per stride shares the sway's frequency, and a bound on their correlation refused true
    strides by their phase alone (review: a camera yawed 75-90 deg on the chest, 20-45 % of simulated walks). A lag
    longer than the longest step (``step_period_s``) is not halved without that evidence either: a slow
    rhythm that is no gait (a camera handled for seconds) then found steps.
    """
    if sway is None or p < 2 * s.step_period_s[0]:
        return False
    k = int(round(p * s.rate_hz))
    if 3 * k > sway.shape[0]:
        return False  # fewer than three strides: their correlation rests on too short an overlap
    r = s.min_periodicity
    support = False
    for c in range(sway.shape[1]):
        ac = _autocorrelation(sway[:, c])
        if ac is None:
            continue
        if ac[k] < -r:
            return False  # this sway is in anti-phase one lag later: the lag is a step
        support |= bool(ac[k] > r and ac[k // 2] < -r)
    return support


def _pace_pieces(period: NDArray[np.float64], j0: int, j1: int, n: int, ratio: float) -> list[tuple[int, int]]:
    """Hop ranges of the gait run [j0, j1) with one rhythm each (camera angles).

    A region gets one period and one decision whether its pitch repeats per stride: a dragged-foot walk (its
    pitch's lag the 0.74 s step) that turned into a normal one (repeating per stride, 1.1 s) in one region read
    the normal part's strides as steps (unkind video, right_foot_drag seed 2: a bout 26 % slow). The hops'
    periods flip between a step and a stride of one rhythm where the left and right steps pitch the trunk
    differently, so they are compared as log2(period) on a circle (a factor 2 is no change): the run splits
    (recursively) at the hop where the mean directions of the ``n`` hops before and the ``n`` after differ most,
    when by ``ratio`` or more, leaving pieces of at least 1.5 ``n`` hops (4.5 s: a dragged stretch between two
    turns is that short). The stride test sees the piece alone, so a piece of 4.5 s holds three strides only up
    to 1.5 s (80 steps/min; review): a slower stride-repeating rhythm there is not found as one (longer pieces or
    the neighbours' context each lost a true split on the unkind sessions: a bout 27 or 22 % slow)."""
    m = max(n, int(round(1.5 * n)))
    if j1 - j0 < 2 * m:
        return [(j0, j1)]
    z = np.exp(2j * np.pi * np.log2(period[j0:j1]))
    c = np.concatenate([[0.0], np.cumsum(z)])
    k = np.arange(m, j1 - j0 - m + 1)  # split hops (offsets): the n before and the n after each
    left, right = c[k] - c[k - n], c[k + n] - c[k]
    d = np.abs(np.angle(right * np.conj(left))) / (2.0 * np.pi)  # in octaves, 0-0.5
    i = int(np.argmax(d))
    if not d[i] >= math.log2(ratio):
        return [(j0, j1)]
    j = j0 + int(k[i])
    return _pace_pieces(period, j0, j, n, ratio) + _pace_pieces(period, j, j1, n, ratio)


def _step_lag(ac: NDArray[np.float64], lag_lo: int, lag_hi: int, fs: float) -> tuple[float, float]:
    """(periodicity, step period in s) from a normalised autocorrelation.

    The strongest lag in [step minimum, stride maximum] is a step, a stride or two strides; it is halved while
    half of it is itself a positively correlated local maximum (steps alternate, so half a stride is a step
    whenever the two steps look alike at all; half a step is anti-correlated). An asymmetric gait, whose
    stride lag dominates, thus still gives the step period.
    """
    k = int(np.argmax(ac[lag_lo : lag_hi + 1])) + lag_lo
    r = float(ac[k])
    if k <= lag_lo and ac[k] < ac[k - 1]:
        # no peak, only the decay of a slow movement (bending down, sitting down): correlated at the shortest
        # lag because it is smooth, not because it repeats
        return 0.0, k / fs
    while k // 2 >= lag_lo * 0.9:
        half = k / 2.0
        a, b = max(1, int(half * 0.85)), min(len(ac) - 2, int(math.ceil(half * 1.15)))
        if b <= a:
            break
        m = int(np.argmax(ac[a : b + 1])) + a
        if ac[m] > max(0.3, 0.4 * ac[k]) and ac[m] >= ac[m - 1] and ac[m] >= ac[m + 1]:
            k = m
        else:
            break
    return r, k / fs


def _runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """Index ranges [i0, i1) of the True runs."""
    m = np.concatenate([[False], mask.astype(bool), [False]])
    d = np.diff(m.astype(int))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1), strict=True))


def detect_steps(sig: TrunkSignals, settings: ActivitySettings = DEFAULT_ACTIVITY_SETTINGS) -> NDArray[np.float64]:
    """Times of the steps (one maximum of the low-passed step signal per step) inside gait candidate regions."""
    return _detect(sig, settings)[0]


def _detect(sig: TrunkSignals, s: ActivitySettings) -> tuple[NDArray[np.float64], NDArray, NDArray]:
    from scipy.signal import find_peaks

    fs = s.rate_hz
    tc, rms, per, period = _windowed_gait(sig, s)
    sway = None
    if sig.sway_deg is not None and len(sig.t_s) > 12:
        from scipy.ndimage import median_filter

        # about a 2 s running median: a turn's heading ramp goes (it correlated yaw at every short lag), a
        # stride's sway (1-1.7 s) stays
        x = sig.sway_deg - median_filter(sig.sway_deg, size=(int(2 * fs) | 1, 1), mode="nearest")
        sway = _butter(x, fs, (0.3, 3.0), "band")
    min_rms = s.min_rms_deg if sig.kind == "angles" else s.min_rms_acc
    gait = (per >= s.min_periodicity) & (rms >= min_rms) & np.isfinite(period)
    steps: list[float] = []
    hop = float(tc[1] - tc[0]) if len(tc) > 1 else s.hop_s
    n_pace = max(2, int(round(s.window_s / hop)))
    for j0, j1 in _runs(gait):
        pieces = _pace_pieces(period, j0, j1, n_pace, s.pace_change_ratio) if sway is not None else [(j0, j1)]
        for k0, k1 in pieces:
            # the piece's own span: a run's outer edges reach half a window out (context of the first and last
            # hop), an edge between two pieces is the hop where the rhythm changed
            lo = tc[k0] if k0 > j0 else tc[j0] - 0.5 * s.window_s
            hi = tc[k1] if k1 < j1 else tc[j1 - 1] + 0.5 * s.window_s
            i0 = max(0, int(np.searchsorted(sig.t_s, lo)))
            i1 = min(len(sig.t_s), int(np.searchsorted(sig.t_s, hi)))
            if i1 - i0 < int(fs):
                continue
            q = period[k0:k1]
            if sig.kind != "angles":
                # trunk acceleration repeats once per step: a hop whose lag is longer than the longest step read
                # a stride (or two) where its left and right steps differed (a turn, slow or shuffling steps),
                # so it is folded back into the step range before the piece's median. Unfolded, a course's run
                # whose hops read strides half the time took a stride as its period, its low-pass and peak
                # spacing then kept one step per stride (real daily-living courses, Mobilise-D: steps found
                # 63 / 71 % of INDIP's)
                q = np.where(q > s.step_period_s[1], q / 2.0 ** np.ceil(np.log2(q / s.step_period_s[1])), q)
            p = float(np.nanmedian(q))
            # the stride test on the piece alone: with the neighbouring piece's half window as context (the other
            # rhythm) the sway's correlation at a normal walk's stride fell below the bound beside a dragged one
            strided = _is_stride(p, None if sway is None else sway[i0:i1], s)
            if strided:
                p /= 2.0
            f = 1.0 / p
            # the filter sees half a window beyond an edge between pieces (its transient stays out of the piece)
            c0 = max(0, int(np.searchsorted(sig.t_s, lo - 0.5 * s.window_s))) if k0 > j0 else i0
            c1 = min(len(sig.t_s), int(np.searchsorted(sig.t_s, hi + 0.5 * s.window_s))) if k1 < j1 else i1
            # a step signal that repeats once per stride has one clear maximum per stride: its step-frequency
            # component alone (a narrow band about it) has one per step
            band = (s.stride_band[0] * f, s.stride_band[1] * f) if strided else (0.25, s.lowpass_factor * f)
            y = _butter(sig.step[c0:c1] - np.mean(sig.step[c0:c1]), fs, band, "band")
            amp = np.sqrt(np.mean(y[i0 - c0 : i1 - c0] ** 2))
            pk, _ = find_peaks(y, distance=max(1, int(s.min_step_fraction * p * fs)), prominence=0.5 * amp)
            # keep peaks inside the piece proper (the window half-width at a run's edges is context); at an edge
            # between pieces each keeps a quarter step beyond it, since each filters on its own and may place the
            # step at the edge on the other side (review: a step lost, a 1.2 s gap for a 0.57 s step); one found
            # by both is merged below
            keep_lo = lo + 0.25 * p if k0 == j0 else lo - 0.25 * p
            keep_hi = hi - 0.25 * p if k1 == j1 else hi + 0.25 * p
            for k in pk:
                tk = float(sig.t_s[c0 + k])
                if keep_lo <= tk <= keep_hi:
                    steps.append(tk)
    st = np.unique(np.round(np.asarray(steps, dtype=float), 6))
    # two regions may overlap at their edges: merge steps closer than the shortest step
    if st.size > 1:
        keep = np.concatenate([[True], np.diff(st) >= s.step_period_s[0]])
        st = st[keep]
    if sig.kind != "angles":
        st = _without_ringing(st, sig, s)
    return st, tc, gait


def _without_ringing(st: NDArray[np.float64], sig: TrunkSignals, s: ActivitySettings) -> NDArray[np.float64]:
    """Trunk acceleration: the steps ``st`` without the maxima the band-pass makes where nothing happened.

    The step signal is band-passed about the region's step frequency before its maxima are taken, and a
    band-pass rings: after the last step before a stop and before the first one after it, the filtered signal
    swings on for a cycle over a trunk that is already (or still) quiet, and that swing is taken for a step.
    Beside a 2-3 s stop such a 'step' makes strides of 2-3 s that count in the bout's cadence (Mobilise-D keeps
    strides up to 3 s), and beside a stop of 3-3.5 s it bridges two bouts. A heel strike moves the acceleration
    itself: a step is kept when the acceleration (low-passed at 8 Hz, not band-passed) spans, within 0.15 s of
    it, at least ``ringing_fraction`` of the median span of itself and the ``ringing_window_steps`` steps either side.
    Measured before the bound was set, against the median span of the step's bout (steps judged against the truth
    within 0.25 s): on the simulator's unkind sessions, seeds 1-5, all 1665 true steps spanned 0.20 of it or more
    and 7 of the 10 false ones less than 0.1 (3 on a trunk standing still); on the real daily-living courses of
    Mobilise-D (both participants), every detected step that matched an INDIP contact spanned 0.17 or more. The
    bound is a round number below both, not fitted between them. A step is also a maximum of that acceleration:
    one with no maximum of it within ``ringing_peak_s`` (0.1 s: under half the shortest step) is the filter's
    alone. Measured before it was added: on the unkind sessions, seeds 1-10, every one of 3503 true steps had
    one, and 4 of the 9 false steps left by the span test none; on the Mobilise-D courses every step matching an
    INDIP contact had one."""
    if st.size < 3:
        return st
    x = _butter(sig.step, s.rate_hz, 8.0, "low")
    span = _ptp_about(x, np.clip(np.searchsorted(sig.t_s, st), 0, x.size - 1), max(1, int(round(0.15 * s.rate_hz))))
    # the step judged is in its own median: a conservative reference (left out, the median of the neighbours
    # alone took a step of a bout on the real HA/002 course from the accelerometer alone: cadence -0.1 -> -4.0 %)
    ref = _window_median(span, max(1, int(s.ringing_window_steps)))
    keep = ~(span < s.ringing_fraction * ref)
    if s.ringing_peak_s > 0:
        from scipy.signal import argrelmax

        tops = sig.t_s[argrelmax(x)[0]]
        if tops.size == 0:
            return st[:0]
        near = np.clip(np.searchsorted(tops, st), 1, tops.size - 1)
        gap = np.minimum(np.abs(tops[near] - st), np.abs(tops[near - 1] - st))
        keep &= gap <= s.ringing_peak_s + DURATION_TOLERANCE_S  # 5 samples at 50 Hz is 0.1 s, whatever t is
    return st[keep]


def _ptp_about(x: NDArray[np.float64], idx: NDArray[np.intp], w: int) -> NDArray[np.float64]:
    """Peak-to-peak of ``x`` over the ``w`` samples either side of each index in ``idx`` (truncated at the
    ends; NaN for an index beyond ``x``)."""
    return np.array([np.ptp(x[max(0, k - w) : min(x.size, k + w + 1)]) if k < x.size else np.nan for k in idx])


def _window_median(x: NDArray[np.float64], half: int) -> NDArray[np.float64]:
    """The median of each element and the ``half`` elements either side of it (fewer at the ends)."""
    pad = np.r_[np.full(half, np.nan), x, np.full(half, np.nan)]
    return np.asarray(np.nanmedian(np.lib.stride_tricks.sliding_window_view(pad, 2 * half + 1), axis=1), dtype=float)


def bouts_from_steps(
    steps_s: ArrayLike, sig: TrunkSignals | None = None, settings: ActivitySettings = DEFAULT_ACTIVITY_SETTINGS,
    *, still: NDArray[np.bool_] | None = None, handled: NDArray[np.bool_] | None = None,
) -> tuple[Bout, ...]:
    """Walking bouts (>= ``min_steps`` steps, breaks shorter than ``max_break_s`` joined), with cadences.
    ``still``: :func:`_still_samples` of ``sig`` when the caller has it (computed here when the edge search
    needs it). ``handled``: per sample of ``sig``, the trunk reoriented (:func:`_handled_samples`): steps there
    are dropped, and so are the few steps a handled stretch cuts off a bout's ends
    (:func:`_without_handled_edges`)."""
    st = np.asarray(steps_s, dtype=float)
    if handled is not None and sig is not None and st.size:
        st = st[~_still_at(handled, sig.t_s, st)]
    gap, t_sig = (None, None) if sig is None else (sig.gap, sig.t_s)
    if gap is not None and t_sig is not None and st.size:
        st = st[~_still_at(gap, t_sig, st)]
    if st.size == 0:
        return ()
    if still is None and sig is not None and sig.kind == "angles" and settings.edge_search_steps > 0:
        still = _still_samples(sig, settings)  # once for all the bouts' edge searches
    brk = np.diff(st) > settings.max_break_s
    if gap is not None and t_sig is not None:  # no bout spans a gap in the recording: its steps are not known
        lost = np.concatenate([[0], np.cumsum(gap)])[np.searchsorted(t_sig, st)]
        brk |= lost[1:] > lost[:-1]
    breaks = np.flatnonzero(brk)
    groups = np.split(st, breaks + 1)
    amp = _step_amplitudes(st, sig, settings)
    amps = np.split(amp, breaks + 1)
    if handled is not None and sig is not None and handled.any():
        done = np.concatenate([[0], np.cumsum(handled)])  # handled samples before each index of sig.t_s
        kept = [_without_handled_edges(g, a, sig.t_s, done, settings) for g, a in zip(groups, amps, strict=True)]
        groups, amps = [g for g, _ in kept], [a for _, a in kept]
    out = []
    for g, a in zip(groups, amps, strict=True):
        mend = sig is None or sig.kind != "angles"
        g, a = _trim_initiation(g, a, settings)
        while mend:  # events that are steps (a camera's pitch may repeat per stride)
            i0, i1 = _stride_edges(g, settings.stride_s[1])
            if (i0, i1) == (0, g.size):
                break
            # the edge a lone step leaves may be a closing half step the short-interval rule takes
            g, a = g[i0:i1], a[i0:i1]
            i0, i1 = _trim_edges(g)
            g, a = g[i0:i1], a[i0:i1]
        if g.size < settings.min_steps:
            continue
        g = _extend_edges(g, sig, settings, still, handled)
        if mend and float(np.median(np.diff(g))) > 0.5 * settings.stride_s[1]:
            # trunk acceleration's events are steps (a stride-long lag is halved, see _detect): events so far
            # apart that two make no stride (longer than stride_s, Mobilise-D's 3 s) are another rhythm (a phone
            # handled, a chair rocking every 1.6-2 s read as 36 s of walking), not a walk. Slower than any step
            # but within that (1.1-1.5 s: 40-55 steps/min, a very slow walker) the bout stays, without a
            # cadence; so does a camera's, whose pitch may repeat per stride
            continue
        if _tilt_wanders(g, sig, handled, settings):
            continue
        cadence = cadence_from_steps(g, settings, mend=mend, sig=sig)
        out.append(Bout(float(g[0]), float(g[-1]), tuple(float(v) for v in g), cadence,
                        _spectral_cadence(sig, float(g[0]), float(g[-1]), settings)))
    return tuple(out)


def _tilt_wanders(
    g: NDArray[np.float64], sig: TrunkSignals | None, handled: NDArray[np.bool_] | None, s: ActivitySettings,
) -> bool:
    """Whether gravity's direction in the sensor wanders over the bout (steps ``g``): in each stretch between
    handled ones (and gaps), the sensor's own orientation there, it lies more than ``reorient_deg`` from that
    stretch's median direction for more than ``TILT_WANDER_FRACTION`` of the stretches' time in all. Then the
    bout is a sensor turned over slowly by hand (its rhythm read as steps), not a trunk that walks. The fast turns
    of handling (the ``reorient_window_s`` rule) drop their own steps and separate the stretches, so a sensor
    knocked or set to a new angle mid-walk walks on in its new orientation (review: against one median for the
    whole bout, a 70 deg turn in the first 70 % of a 40 s walk dropped all of it); a rotation slower than the
    rule, whose tilt spreads less than ``reorient_deg`` in any 1.5 s, passed: BROAD's slow hand-held rotations and
    its tapped sensor read as 211 s of walking in 10 bouts (60-137 deg from their median direction a quarter of
    the time). A walking trunk's tilt stays near its median: on the Mobilise-D lower-back recordings (turns, a
    course's sitting and standing between bouts) and the simulated unkind sessions (bends, pick-ups, sitting), at
    most 7.8 deg half of a bout's time and 17.1 deg three quarters of it, so the test leaves those unchanged.
    Known weakness: a trunk that leans 50-60 deg further over a few seconds, too slowly for the handling rule, and
    walks on leaned for more than a quarter of the bout loses the bout. From an IMU or an accelerometer
    (``gravity_up``); a camera's angles have no gravity of their own."""
    if sig is None or sig.gravity_up is None or g.size == 0:
        return False
    i0, i1 = np.searchsorted(sig.t_s, [g[0], g[-1]])
    up = sig.gravity_up[i0:i1 + 1]
    cut = np.zeros(len(up), dtype=bool)
    for mask in (handled, sig.gap):
        if mask is not None:
            cut |= mask[i0:i1 + 1]
    far = total = 0
    for a, b in _runs(~cut):
        mid = np.median(up[a:b], axis=0)
        norm = float(np.linalg.norm(mid))
        off = np.degrees(np.arccos(np.clip(up[a:b] @ (mid / max(norm, 1e-9)), -1.0, 1.0)))
        far += int(np.count_nonzero(off > s.reorient_deg))
        total += b - a
    return total > 0 and far > TILT_WANDER_FRACTION * total


def _step_amplitudes(st: NDArray[np.float64], sig: TrunkSignals | None, s: ActivitySettings) -> NDArray[np.float64]:
    """Peak-to-peak of the gait-band step signal within +-0.3 s of each step (NaN without the signal)."""
    if sig is None or st.size == 0:
        return np.full(st.shape, np.nan)
    x = gait_band(sig, s.rate_hz)
    return _ptp_about(x, np.searchsorted(sig.t_s, st), int(round(0.3 * s.rate_hz)))


def _without_handled_edges(
    g: NDArray[np.float64], a: NDArray[np.float64], t_s: NDArray[np.float64], done: NDArray[np.int64],
    s: ActivitySettings, near_s: float = 0.5,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A group of steps (no break > ``max_break_s``) and their amplitudes ``a`` without what a handled stretch
    (:func:`_handled_samples`; ``done``: the count of handled samples of ``t_s`` before each index) leaves at its
    ends: leading and trailing pieces of fewer than ``min_steps`` steps that such a stretch cuts off (a step or
    two before the sensor is put on or after it is taken off, or before sitting down), then a lone first or last
    step within ``near_s`` (about a step) of such a stretch and more than the edge search's upper bound
    (``edge_rhythm``) x the median step from its neighbour: the jolt as a sensor settles after handling, or the
    trunk swinging back up after picking something up (found in review: such a step 20 ms after a handled
    stretch started a bout 1.7 s early). Inside a bout, a handled stretch shorter than ``max_break_s`` is a
    pause, and pauses join bouts (the convention above)."""
    if g.size == 0:
        return g, a
    k = np.searchsorted(t_s, g)
    cut = np.flatnonzero(done[k[1:]] > done[k[:-1]]) + 1  # a handled stretch lies before g[i] for i in cut
    i0, i1 = 0, g.size
    for c in cut:
        if c - i0 < s.min_steps:
            i0 = int(c)
        else:
            break
    for c in cut[::-1]:
        if c >= i0 and i1 - c < s.min_steps:
            i1 = int(c)
        else:
            break
    if i1 - i0 >= 4:
        m = float(np.median(np.diff(g[i0:i1])))

        def near(t: float) -> bool:
            j0, j1 = np.searchsorted(t_s, [t - near_s, t + near_s])
            return bool(done[j1] > done[j0])

        if g[i0 + 1] - g[i0] > s.edge_rhythm[1] * m and near(float(g[i0])):
            i0 += 1
        if g[i1 - 1] - g[i1 - 2] > s.edge_rhythm[1] * m and near(float(g[i1 - 1])):
            i1 -= 1
    return g[i0:i1], a[i0:i1]


def _trim_weak_edges(g: NDArray[np.float64], a: NDArray[np.float64], fraction: float) -> tuple[int, int]:
    """The bounds ``(i0, i1)`` of ``g`` without leading/trailing 'steps' whose amplitude ``a`` is below
    ``fraction`` x the bout's median step amplitude: a weight shift before gait initiation or the sway after
    stopping moves the trunk once or twice at about a step's rhythm but far more weakly than a heel strike."""
    if g.size < 3 or not np.all(np.isfinite(a)):
        return 0, g.size
    med = float(np.median(a))
    i0, i1 = 0, g.size
    while i1 - i0 >= 3 and a[i0] < fraction * med:
        i0 += 1
    while i1 - i0 >= 3 and a[i1 - 1] < fraction * med:
        i1 -= 1
    return i0, i1


def _extend_edges(
    g: NDArray[np.float64], sig: TrunkSignals | None, s: ActivitySettings, still: NDArray[np.bool_] | None,
    handled: NDArray[np.bool_] | None = None,
) -> NDArray[np.float64]:
    """Camera angles: the steps of gait initiation and termination that a posture change hides, added back.

    A walker bends or straightens the trunk while starting and stopping (the first steps lean into the walk, the
    last ones come upright; 10-15 deg within a second for a stooped walker). The step signal of the angles (pitch
    about its 1 s running median) loses the 1-2 deg step rhythm there: where the posture ramp makes the pitch
    monotonic over the median's window, the median is the sample itself and the signal is flat; the first steps
    give no maximum at all, the last ones weak ones, and the bout starts late and ends early. Here the pitch
    is taken about its mean over one step period of the bout instead: that mean removes a linear posture ramp
    exactly and none of the step rhythm (one full period of it averages out). Maxima of that signal (low-passed
    like the steps, :func:`_detect`) before the first step and after the last are added one at a time while
    each lies ``edge_rhythm`` x the bout's median step from its neighbour, has a prominence of at least
    ``edge_prominence`` x the bout's RMS of the signal and the trunk is not still there (:func:`_still_at`), at
    most ``edge_search_steps`` at each end. IMU input is left as it is: trunk acceleration has no posture ramp,
    and on the real lower-back recordings the bouts are, if anything, too long already.
    """
    if (sig is None or still is None or sig.kind != "angles" or sig.pitch_deg is None or s.edge_search_steps <= 0
            or g.size < max(3, s.min_steps)):
        return g
    from scipy.ndimage import uniform_filter1d
    from scipy.signal import find_peaks

    fs = sig.rate_hz
    m = float(np.median(np.diff(g)))
    lo, hi = s.edge_rhythm
    reach = (s.edge_search_steps + 1) * hi * m + 1.0
    i0 = int(np.searchsorted(sig.t_s, g[0] - reach))
    i1 = int(np.searchsorted(sig.t_s, g[-1] + reach))
    if i1 - i0 < 16:
        return g
    p = sig.pitch_deg[i0:i1]
    x = p - uniform_filter1d(p, size=max(3, int(round(m * fs))), mode="nearest")
    y = _butter(x - np.mean(x), fs, (0.25, s.lowpass_factor / m), "band")
    tt = sig.t_s[i0:i1]
    inside = (tt >= g[0]) & (tt <= g[-1])
    amp = float(np.sqrt(np.mean(y[inside] ** 2))) if inside.any() else 0.0
    if amp <= 0:
        return g
    pk, _ = find_peaks(y, distance=max(1, int(s.min_step_fraction * m * fs)), prominence=s.edge_prominence * amp)
    pt = tt[pk]
    pt = pt[~_still_at(still, sig.t_s, pt)] if pt.size else pt
    if handled is not None and pt.size:  # nor where the sensor is handled (:func:`_handled_samples`)
        pt = pt[~_still_at(handled, sig.t_s, pt)]
    before: list[float] = []
    after: list[float] = []
    first, last = float(g[0]), float(g[-1])
    for _ in range(s.edge_search_steps):
        c = pt[(pt >= first - hi * m) & (pt <= first - lo * m)]
        if c.size == 0:
            break
        first = float(c[np.argmin(np.abs(first - m - c))])
        before.insert(0, first)
    for _ in range(s.edge_search_steps):
        c = pt[(pt >= last + lo * m) & (pt <= last + hi * m)]
        if c.size == 0:
            break
        last = float(c[np.argmin(np.abs(c - last - m))])
        after.append(last)
    if not before and not after:
        return g
    return np.concatenate([np.asarray(before, dtype=float), g, np.asarray(after, dtype=float)])


def _running_rms(x: ArrayLike, half: int) -> NDArray[np.float64]:
    """RMS of ``x`` over the ``half`` samples either side of each (truncated at the ends; any length of ``x``)."""
    x = np.asarray(x, dtype=float)
    csum = np.concatenate([[0.0], np.cumsum(x * x)])
    idx = np.arange(len(x))
    lo, hi = np.clip(idx - half, 0, len(x)), np.clip(idx + half, 0, len(x))
    return np.asarray(np.sqrt((csum[hi] - csum[lo]) / np.maximum(hi - lo, 1)), dtype=float)


def _still_samples(sig: TrunkSignals, s: ActivitySettings) -> NDArray[np.bool_]:
    """The trunk still about each sample of ``sig`` (the timeline's standing test, :func:`segment`): the
    gait-band RMS of the step signal over ``STILL_WINDOW_S`` below the source's still limit, or the measurement
    itself spreading less than a sinusoid of that RMS does (2 sqrt 2 x the limit, peak to peak) there; and, with
    a gyro or angles, the RMS angular rate below ``still_gyro_deg_s``.

    The spread rescues what the filters make up: for a second or more after the trunk stops moving (stands up,
    sits down, puts a camera back), the step signal (about its running median, or about gravity's low-passed
    direction) and its band-pass ring on over a trunk that stands still, and that read as ``unknown``. With the
    spread, the simulated unkind sessions' activity per second: 96.8 -> 97.5 % right from the IMU, 94.8 -> 95.2 %
    from the video (seeds 1-5; held out, 6-10: 97.0 -> 97.5 %, 94.96 -> 95.3 %). Mobilise-D's courses: the IMU's
    and the accelerometer's timelines unchanged; through the video path (the IMU's orientation as angles) 9 of
    their 0.1 s points just before the first bout now standing. Only a spread that small: a walking trunk spreads
    far more, a still one far less."""
    fs = s.rate_hz
    x = gait_band(sig, fs)
    half = max(1, int(round(0.5 * STILL_WINDOW_S * fs)))  # as _window_range sizes the spread's window
    limit = s.still_rms_deg if sig.kind == "angles" else s.still_rms_acc
    still = _running_rms(x, half) < limit
    if sig.spread is not None:
        still |= sig.spread < 2.0 * math.sqrt(2.0) * limit
    if sig.gyro_norm_deg_s is not None:
        still &= _running_rms(sig.gyro_norm_deg_s, half) < s.still_gyro_deg_s
    return np.asarray(still, dtype=bool)


def _handled_samples(sig: TrunkSignals, s: ActivitySettings, turns: tuple[Turn, ...]) -> NDArray[np.bool_] | None:
    """Per sample of ``sig``: the trunk's tilt spreading over more than ``reorient_deg`` within
    ``reorient_window_s`` (:func:`tilt_change_deg`), outside ``turns`` and half a window about them: a turn is
    no handling, though a tight one spreads a lower back's tilt by up to 50 deg (Mobilise-D HA/002's course) and a
    tilted camera's start-relative pitch/roll by up to twice its tilt. Also, turns or not, where a gyroscope's
    angular rate has an RMS over that window (truncated at the recording's ends) above ``spin_deg_s``: faster
    than any trunk turns (rhythmic hand-held rotation about gravity passed as steps and turns: BROAD's
    fast-rotation trials). None without the signal."""
    if sig.tilt_change_deg is None:
        return None
    handled = np.asarray(sig.tilt_change_deg > s.reorient_deg, dtype=bool)
    for u in turns:
        handled[(sig.t_s >= u.start_s - 0.5 * s.reorient_window_s)
                & (sig.t_s <= u.end_s + 0.5 * s.reorient_window_s)] = False
    if sig.kind == "imu" and sig.gyro_norm_deg_s is not None:
        # a gyroscope's rate only: a camera's comes from differentiated angle estimates, where one frame's
        # correction of 60 deg reads as a spin (review)
        half = max(1, int(round(0.5 * s.reorient_window_s * s.rate_hz)))
        handled |= _running_rms(sig.gyro_norm_deg_s, half) > s.spin_deg_s
    return handled


def _still_at(still: NDArray[np.bool_], t_s: NDArray[np.float64], times: NDArray[np.float64]) -> NDArray[np.bool_]:
    """:func:`_still_samples` (``still`` on the grid ``t_s``) at arbitrary times (the sample at or after each)."""
    return still[np.clip(np.searchsorted(t_s, times), 0, len(still) - 1)]


def _trim_initiation(
    g: NDArray[np.float64], a: NDArray[np.float64], s: ActivitySettings
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A bout's steps ``g`` and amplitudes ``a`` without gait initiation and termination: weak edge steps
    (:func:`_trim_weak_edges`), then a short first or last interval (:func:`_trim_edges`)."""
    i0, i1 = _trim_weak_edges(g, a, s.weak_step_fraction)
    g, a = g[i0:i1], a[i0:i1]
    i0, i1 = _trim_edges(g)
    return g[i0:i1], a[i0:i1]


def _stride_edges(g: NDArray[np.float64], longest_s: float) -> tuple[int, int]:
    """The bounds ``(i0, i1)`` of ``g`` without a first or last step that ends or starts no stride: Mobilise-D
    assembles walking bouts from strides (a contact to the next of the same foot, two steps on) of at most
    ``longest_s``, and a bout runs from its first stride's start to its last stride's end, so a lone step more
    than ``longest_s`` after the step two before it (a shuffle or a weight shift after a pause of 2-3 s) is no
    part of the bout, though the step rule's break (``max_break_s`` between steps) would join it."""
    i0, i1 = 0, g.size
    while i1 - i0 >= 3 and g[i1 - 1] - g[i1 - 3] > longest_s + DURATION_TOLERANCE_S:
        i1 -= 1
    while i1 - i0 >= 3 and g[i0 + 2] - g[i0] > longest_s + DURATION_TOLERANCE_S:
        i0 += 1
    return i0, i1


def _trim_edges(g: NDArray[np.float64]) -> tuple[int, int]:
    """The bounds ``(i0, i1)`` of ``g`` without leading/trailing steps of gait initiation/termination: a first or
    last step interval shorter than 0.6 x the bout's median (a weight shift before the first step, a closing half
    step)."""
    i0, i1 = 0, g.size
    while i1 - i0 >= 3:
        d = np.diff(g[i0:i1])
        med = float(np.median(d))
        if d[0] < 0.6 * med:
            i0 += 1
        elif d[-1] < 0.6 * med:
            i1 -= 1
        else:
            break
    return i0, i1


def corrected_step_times(
    steps_s: ArrayLike, settings: ActivitySettings = DEFAULT_ACTIVITY_SETTINGS, *, quiet: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Step durations (s) of a bout with missed and extra steps accounted for. ``quiet`` (one per interval, from
    :func:`quiet_intervals`): the trunk hardly moved in that interval, a pause, never mended as a missed step.

    In turns and slow, shuffling walking the trunk's vertical acceleration loses a heel strike now and then
    (an interval about twice its neighbours) or shows two peaks for one (two short intervals summing to about
    one). Against the bout's median step duration ``m`` (for a missed step at least ``missed_step_ratio[0]`` x the
    longer of the alternating steps' medians too, so that a limp's long steps are not taken for missed ones): an interval of ``missed_step_ratio`` x ``m`` (1.6-2.5)
    counts as two steps of half its length when its neighbouring intervals are each one ordinary step (shorter
    than ``ordinary_step_ratio`` x ``m``), as the Hampel filter of Mobilise-D's cadence drops an isolated outlier
    and keeps a run. A run of long intervals is slow stepping, not steps missed in a row: on the real courses,
    once the steps were found per step (see :func:`_detect`), INDIP had no contact inside 11 of the 16 long
    intervals (1.6-2.5 steps) within its bouts, and mending runs read a turning bout of MS/001 at +55 %. A
    neighbour of any other length means no steady rhythm there (standing up, a pause); two consecutive intervals
    both shorter than ``extra_step_fraction`` x ``m`` whose sum lies within 0.7-1.3 x ``m`` count as one step.
    Longer gaps (pauses) are kept as they are.
    The idea follows mobgap's ``CadFromIc`` (Mobilise-D: step times cleaned of outliers before cadence, a
    Hampel filter there); here the outliers are mended as the missed/extra steps they are, which keeps the step
    count consistent. Needs >= 3 intervals (fewer: the raw durations).
    """
    d = np.diff(np.asarray(steps_s, dtype=float))
    if d.size < 3:
        return d
    m = float(np.median(d))
    # A limp alternates long and short steps (up to 2x): with an odd number of intervals the median step is the
    # short one, every long step would read as 1.6-2.5 x it and be split, and a 96 steps/min limp would read 144.
    # When the steps alternate throughout (>= 90 % sign changes; independent jitter gives 2/3) with the medians
    # of the two sides >= 1.3x apart, a missed step must be that long against the longer side's median too.
    # (Against half the median stride, or the longer side's median always, HA/002's course, full of real missed
    # steps in turns, read -4.5 / -3.3 % instead of +0.7 %.)
    m_long = m
    if d.size >= 4:
        dd = np.sign(np.diff(d))
        sides = sorted((float(np.median(d[0::2])), float(np.median(d[1::2]))))
        if np.mean(dd[1:] * dd[:-1] < 0) >= 0.9 and sides[1] >= 1.3 * sides[0]:
            m_long = max(m, sides[1])
    lo, hi = settings.missed_step_ratio
    f = settings.extra_step_fraction
    q = None if quiet is None else np.asarray(quiet, dtype=bool)
    if q is not None and q.size != d.size:
        msg = f"quiet: one value per interval ({d.size}), got {q.size}"
        raise ValueError(msg)
    out: list[float] = []
    i = 0
    while i < d.size:
        if (i + 1 < d.size and d[i] < f * m and d[i + 1] < f * m and 0.7 * m <= d[i] + d[i + 1] <= 1.3 * m):
            out.append(float(d[i] + d[i + 1]))
            i += 2
            continue
        # a missed step lies among steps: its neighbours are each one ordinary step; a run of long intervals is
        # slow stepping (a turn, shuffling), and a neighbour of any other length means no steady rhythm there
        # (standing up, a pause)
        neighbours = np.concatenate([d[max(0, i - 1) : i], d[i + 1 : i + 2]])
        if lo * m_long <= d[i] <= hi * m and bool(np.all(neighbours < settings.ordinary_step_ratio * m)) \
                and not (q is not None and q[i]):
            out.extend([0.5 * float(d[i])] * 2)
        else:
            out.append(float(d[i]))
        i += 1
    return np.asarray(out, dtype=float)


def quiet_intervals(
    steps_s: ArrayLike, sig: TrunkSignals, settings: ActivitySettings = DEFAULT_ACTIVITY_SETTINGS
) -> NDArray[np.bool_]:
    """Per interval between consecutive steps: whether the trunk hardly moved in its middle half (the gait-band
    RMS of the step signal there below ``quiet_interval_ratio`` x the median of every interval's): a pause, not a
    heel strike the detector missed. Until 2026-11-28 a 0.6-1 s stop within a bout was mended as a missed step
    and its cadence read 5-8 % high, above the steady pace itself (user review: three 4 s walks at 100 steps/min
    split by 0.7 s stops read 101.7, truly 93.8 by the mean over strides)."""
    st = np.asarray(steps_s, dtype=float)
    if st.size < 2:
        return np.zeros(0, bool)
    x = gait_band(sig, sig.rate_hz)
    lo = np.searchsorted(sig.t_s, st[:-1] + 0.25 * np.diff(st))
    hi = np.searchsorted(sig.t_s, st[1:] - 0.25 * np.diff(st))
    rms = np.array([math.sqrt(float(np.mean(x[a:b] ** 2))) if b > a else math.nan for a, b in zip(lo, hi, strict=True)])
    typical = float(np.nanmedian(rms)) if np.isfinite(rms).any() else math.nan
    if not math.isfinite(typical) or typical <= 0:
        return np.zeros(st.size - 1, bool)
    return np.asarray(np.isfinite(rms) & (rms < settings.quiet_interval_ratio * typical), dtype=bool)


def _local_median(x: NDArray[np.float64], half: int, within: float) -> NDArray[np.float64]:
    """The median of each element's neighbourhood of ``half`` elements either side (fewer at the ends), kept
    within ``within`` x the median of all of ``x`` (a run of odd values must not become the local rhythm)."""
    whole = float(np.median(x))
    if x.size <= 2 * half + 1:
        return np.full(x.size, whole)
    return np.clip(_window_median(x, half), whole / within, whole * within)


def cadence_from_steps(
    steps_s: ArrayLike, settings: ActivitySettings = DEFAULT_ACTIVITY_SETTINGS, *, mend: bool = True,
    sig: TrunkSignals | None = None,
) -> float:
    """Cadence of a bout as Mobilise-D reports it: the mean over strides (two consecutive steps) of
    120 / stride duration. Falls back to 60 / step duration with fewer than 3 steps.

    * **Trunk acceleration** (``mend=True``): missed and extra steps mended first
      (:func:`corrected_step_times`; with ``sig``, the signals the steps came from, an interval the trunk was
      nearly still in is a pause and stays one), then every stride of ``stride_s`` (over 0.2 s, up to 3.0 s) counts: the
      duration half of Mobilise-D's stride selection (mobgap's ``IntervalDurationCriteria(0.2, 3.0)``; its
      other half, a stride length >= 0.15 m, walkmon cannot apply). INDIP's bout cadence is the mean of 120 /
      stride over the strides it selects, and 6 of its 9 bouts on the shared courses hold strides of 2.4-2.7 s
      (turns, hesitations). Until 2026-11-27 strides beyond 1.3 x the median stride about them were left out as
      pauses: a turning bout's slow strides went with them, and the courses' bouts read up to 25 % fast
      (MS/001). The same rule holds for a posture segment's and a live window's cadence (both call this), so a
      short stop within them counts too.
    * **Camera angles** (``mend=False``): the video's pitch maxima are not heel strikes; mending them made bout
      cadence worse (unkind video sessions: within 1 % 84 -> 77 % of bouts, scored with a fixed 0.25 s edge
      window). Where the pitch waveform changes phase (a posture change, a turn) a maximum goes missing or
      doubles, leaving an interval 1.5 or 0.5 steps long that no mending describes. So every stride with an
      interval off the rhythm about it (more than ``rhythm_ratio`` x or less than 1 / ``rhythm_ratio`` x the
      median interval of ``rhythm_window_steps`` either side, that median kept within ``rhythm_ratio`` x the
      bout's so that a run of missed steps does not become the rhythm) is left out, pauses included; with fewer
      than 2 strides left, strides beyond ``pause_factor`` x the local median stride or below it /
      ``hurried_factor`` are left out.

    NaN (not measured) when the median interval is longer than the longest step (``step_period_s``): the
    events are then not the steps (the rotation of a real daily-living course, short strides and constant
    turning, gave maxima 1.1-1.8 s apart where INDIP counted steps 0.65-0.75 s apart, a cadence read at half)."""
    st = np.asarray(steps_s, dtype=float)
    st = st[np.isfinite(st)]
    if st.size < 2:
        return float("nan")
    s = settings
    if sig is not None and sig.holes_s and st.size >= 3:
        # no stride across a hole in the samples (its steps are not known): the mean over the strides of the runs
        # of steps between holes, each run's mean weighted by its strides
        holed = np.zeros(st.size - 1, dtype=bool)
        for a, b in sig.holes_s:
            holed |= (st[:-1] < b) & (st[1:] > a)
        # only where the interval across the hole is longer than a step (it hid one); a hole between two steps of
        # the rhythm hid none (review: a Bluetooth IMU losing 0.27 s every second left no run, no cadence)
        d = np.diff(st)
        clean = d[~holed]  # against the intervals no hole touches: frequent holes inflate the median (review)
        holed &= d >= s.ordinary_step_ratio * float(np.median(clean if clean.size >= 2 else d))
        if holed.any():
            runs = [r for r in np.split(st, np.flatnonzero(holed) + 1) if r.size >= 3]
            values = [(cadence_from_steps(r, s, mend=mend, sig=replace(sig, holes_s=())), r.size - 2) for r in runs]
            values = [(v, n) for v, n in values if math.isfinite(v)]
            # no run of 3 steps between holes that hid steps: not measured (review: the fallback to every stride
            # read such a bout 32 % slow, the strides across the holes among them)
            return float(sum(v * n for v, n in values) / sum(n for _, n in values)) if values else float("nan")
    d = corrected_step_times(st, s, quiet=None if sig is None else quiet_intervals(st, sig, s)) if mend \
        else np.diff(st)
    if float(np.median(d)) > s.step_period_s[1]:
        return float("nan")
    if d.size < 2:
        return float(60.0 / d[0])
    if not mend and d.size >= 5:
        local = _local_median(d, s.rhythm_window_steps, s.rhythm_ratio)
        regular = (d <= s.rhythm_ratio * local) & (d >= local / s.rhythm_ratio)
        stride = (d[1:] + d[:-1])[regular[1:] & regular[:-1]]
        if stride.size >= 2:
            return float(np.mean(120.0 / stride))
    stride = d[1:] + d[:-1]
    if mend:
        tol = DURATION_TOLERANCE_S
        stride = stride[(stride > s.stride_s[0] + tol) & (stride <= s.stride_s[1] + tol)]
        return float(np.mean(120.0 / stride)) if stride.size else float("nan")
    # local, but within pause_factor of the bout's: two hesitations a step apart make four long strides in a
    # row, which must not become the rhythm
    med = _local_median(stride, s.pause_window_strides, s.pause_factor)
    stride = stride[(stride <= s.pause_factor * med) & (stride >= med / s.hurried_factor)]
    return float(np.mean(120.0 / stride)) if stride.size else float("nan")


def _spectral_cadence(sig: TrunkSignals | None, t0: float, t1: float, s: ActivitySettings) -> float:
    if sig is None:
        return float("nan")
    from walkmon.gait.spectrum import refined_peak

    m = (sig.t_s >= t0) & (sig.t_s <= t1)
    if m.sum() < 2 * s.rate_hz:
        return float("nan")
    x = sig.step[m] - sig.step[m].mean()
    lo, hi = 60.0 / (60.0 / s.step_period_s[0]), 60.0 / (60.0 / s.step_period_s[1])
    peak = refined_peak(x, s.rate_hz, (1.0 / hi, 1.0 / lo), pad_factor=8)
    return 60.0 * float(peak.frequency_hz)


def detect_turns(sig: TrunkSignals, settings: ActivitySettings = DEFAULT_ACTIVITY_SETTINGS) -> tuple[Turn, ...]:
    """Turns from the heading rate (El-Gohary et al. 2013 thresholds); () without a heading rate."""
    if sig.heading_rate_deg_s is None:
        return ()
    s = settings
    fs = s.rate_hz
    h = _butter(sig.heading_rate_deg_s - np.median(sig.heading_rate_deg_s), fs, 1.5, "low")
    out = []
    for sign in (1.0, -1.0):
        for i0, i1 in _runs(sign * h > s.turn_edge_deg_s):
            seg = h[i0:i1]
            dur = (i1 - i0) / fs
            angle = float(np.sum(seg) / fs)
            if (np.max(np.abs(seg)) >= s.turn_peak_deg_s and abs(angle) >= s.turn_min_deg
                    and s.turn_duration_s[0] <= dur <= s.turn_duration_s[1]):
                out.append(Turn(float(sig.t_s[i0]), float(sig.t_s[i1 - 1]), angle))
    return tuple(sorted(out, key=lambda u: u.start_s))


def segment(sig: TrunkSignals, settings: ActivitySettings = DEFAULT_ACTIVITY_SETTINGS) -> Segmentation:
    """Bouts, turns, steps and the activity timeline of one recording (see the module text)."""
    s = settings
    steps, tc, gait = _detect(sig, s)
    still_samples = _still_samples(sig, s)
    turns = detect_turns(sig, s)
    notes = []
    if sig.gap is not None:
        # nothing is known in a gap of the recording: neither standing, nor a step, nor a turn (the heading
        # rate bridged over it by a straight line)
        still_samples &= ~sig.gap
        steps = steps[~_still_at(sig.gap, sig.t_s, steps)]
        turns = tuple(u for u in turns if not any(a < u.end_s and b > u.start_s for a, b in sig.gaps_s))
        notes.append(_gap_note(sig.gaps_s, sig.kind))
    handled = _handled_samples(sig, s, turns)
    if handled is not None and steps.size:
        steps = steps[~_still_at(handled, sig.t_s, steps)]
    bouts = bouts_from_steps(steps, sig, s, still=still_samples, handled=handled)
    grid = np.arange(sig.t_s[0], sig.t_s[-1] + 1e-9, s.hop_s)
    act = np.full(grid.shape, "unknown", dtype=object)
    # still: low step-signal RMS or a raw spread below the still limit (and low angular rate with a gyro) over 1 s
    still = _still_at(still_samples, sig.t_s, grid)
    act[still] = "standing"
    for b in bouts:
        act[(grid >= b.start_s) & (grid <= b.end_s)] = "walking"
    for u in turns:
        act[(grid >= u.start_s) & (grid <= u.end_s)] = "turning"
    handled_grid = _still_at(handled, sig.t_s, grid) if handled is not None else np.zeros(grid.shape, bool)
    act[handled_grid] = "unknown"
    gap_grid = _still_at(sig.gap, sig.t_s, grid) if sig.gap is not None else np.zeros(grid.shape, bool)
    act[gap_grid] = "unknown"
    steady = steady_state_steps(bouts, turns, s)
    if sig.heading_rate_deg_s is None:
        notes.append("no heading (accelerometer only): turns not detected, no yaw")
    return Segmentation(tuple(bouts), turns, steps, grid, tuple(str(a) for a in act), sig.kind, tuple(notes), steady,
                        tuple(bool(v) for v in still), tuple(bool(v) for v in handled_grid),
                        tuple(bool(v) for v in gap_grid))


def _gap_note(found: tuple[tuple[float, float], ...], kind: str) -> str:
    """The input note on a recording's gaps (:attr:`TrunkSignals.gaps_s`); ``kind``: the signals' source."""
    what = "unknown there, with no steps, turns or standing, and no bout spans one"
    why = "frames missing, or held by the rotation estimator" if kind == "angles" else "samples missing"
    if len(found) == 1:
        a, b = found[0]
        return f"nothing measured for {b - a:.1f} s from t={a:.1f} s (a gap in the recording: {why}): {what}"
    a, b = max(found, key=lambda g: g[1] - g[0])
    total = sum(e - s for s, e in found)
    return (f"{len(found)} gaps in the recording ({why}; {total:.1f} s in all, the longest {b - a:.1f} s from "
            f"t={a:.1f} s): {what}")


def steady_state_steps(
    bouts: tuple[Bout, ...], turns: tuple[Turn, ...], settings: ActivitySettings = DEFAULT_ACTIVITY_SETTINGS
) -> NDArray[np.float64]:
    """Steps of steady walking: each bout's steps without its first and last ``edge_steps`` (the accelerating
    steps of gait initiation and the slowing ones of termination differ from steady gait and from each other,
    so they would fake a left/right difference) and without steps within ``turn_margin_s`` of a turn."""
    e = max(0, int(settings.edge_steps))
    keep: list[float] = []
    for b in bouts:
        st = np.asarray(b.steps_s, dtype=float)
        st = st[e : st.size - e] if st.size > 2 * e else st[:0]
        for u in turns:
            st = st[(st < u.start_s - settings.turn_margin_s) | (st > u.end_s + settings.turn_margin_s)]
        keep.extend(st.tolist())
    return np.asarray(keep, dtype=float)
