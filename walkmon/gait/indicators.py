"""Walking-posture indicators from angle waveforms (the paper's Sec. 4-5, Eq. 8-15), and indicators.json.

Input: time stamps ``t_s`` (N,) and angles ``angles_deg`` (N, 3) as (pitch, yaw, roll) in degrees, relative to
the first frame (see :mod:`walkmon.consts`). Output: :class:`Indicators` (frozen), whose :meth:`Indicators.to_dict`
is the stable ``indicators.json`` schema of issue 4.

Two processing modes (``IndicatorSettings.mode``):

``"paper"``
    Exactly the paper: subtract the least-squares line of the whole recording, taper with a Hamming window, FFT
    for the dominant frequency of each axis, local maxima/minima of the detrended waveform, drop the extremums
    in the first and last 3 s, then per axis the means of Eq. 9-15. The line also removes true posture offsets
    (a walk bent forward all along reads pitch inclination ~0 once the standing phases are short).

``"walkmon"`` (default)
    * Finds the standing phases at the start and at the end automatically (low angular activity) and analyses
      only the walk between them (minus ``transition_s`` at each side, where the trunk settles).
    * Pitch and roll are referenced to the upright standing stance at the start; estimation drift is removed by
      a straight line anchored on the standing phases at *both* ends (the wearer stands upright at both, so any
      difference is drift), which keeps true posture offsets: a walk bent forward 18 deg reads about -18.
      Without a standing phase at the start (a sliding window) the ``reference_deg`` argument, or zero, is the
      upright stance and no drift is removed (an end stance then is not assumed upright).
    * Yaw has no gravity reference and slowly follows the walking direction: it is detrended with the
      least-squares line of the walking part; its inclination is the twist relative to that heading line.
    * Cadence from the FFT peak refined below the bin width, combining pitch (step frequency) with roll and yaw
      (stride frequency) (:func:`walkmon.gait.spectrum.step_frequency_hz`).
    * A zero-phase low-pass at ``lowpass_factor`` times the step frequency before the extremums (estimation
      noise would otherwise inflate every maximum and deflate every minimum).
    * Exactly one maximum and one minimum per gait cycle: maxima at least 0.6 cycles apart, each paired with the
      minimum up to the next maximum. Cycles are steps for pitch, strides for roll and yaw.
    * Left/right asymmetry: consecutive pitch cycles are alternate steps, so swings and step times of even and
      odd steps are compared (a dragged foot or a limp shows up as alternating values).

The heavy lifting is in :func:`analyze_gait`, which also returns the intermediate waveforms the report plots;
:func:`compute_indicators` is the public one-call entry point.
"""

from __future__ import annotations

import copy
import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from enum import Enum
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from walkmon.consts import AXES
from walkmon.errors import ConfigError, InvalidInputError
from walkmon.gait.posture import Classification, classify
from walkmon.gait.spectrum import (
    STEP_FACTOR_BY_AXIS,
    amplitude_spectrum,
    detrend_least_squares,
    hamming_taper,
    line_through,
    refined_peak,
    sample_rate_hz_from_times,
    step_frequency_hz,
)

__all__ = [
    "DEFAULT_INDICATOR_SETTINGS",
    "SCHEMA_VERSION",
    "AxisIndicators",
    "Classification",
    "GaitAnalysis",
    "IndicatorSettings",
    "IndicatorStatus",
    "Indicators",
    "analyze_gait",
    "classified",
    "compute_indicators",
    "cycle_extremums",
    "detect_standing",
    "indicators_from_dict",
    "refined_extremum_values",
    "step_asymmetry",
]

_log = logging.getLogger(__name__)

#: Version of the indicators.json layout; bumped only when a field changes meaning or disappears.
SCHEMA_VERSION = 2
# 2: bouts, segments, summary, timeline-related fields (upright_reference, activity_s, input); the top-level
#    indicators are the duration-weighted aggregate over walking bouts in walkmon mode (issue 11)

MODES = ("walkmon", "paper")

#: indicators.json keys of the session-level additions (schema 2), kept as plain JSON values.
SESSION_KEYS = ("upright_reference", "input", "activity_s", "summary", "bouts", "segments", "turns")

_NAN = float("nan")


@dataclass(frozen=True, slots=True)
class IndicatorSettings:
    """Settings of the indicator computation. Durations in seconds, frequencies in Hz, angles in degrees.

    ============================  ===========  =====================================================================
    field                         default      meaning
    ============================  ===========  =====================================================================
    mode                          "walkmon"    "walkmon" (fixed flaws) or "paper" (exactly the paper's processing)
    step_band_hz                  (1.0, 3.0)   where the step frequency may lie (60-180 steps/min)
    pad_factor                    8            FFT zero-padding factor for the refined peak
    paper_trim_s                  3.0          paper mode: extremums in the first/last seconds are dropped
    standing_window_s             0.5          walkmon: window of the moving standard deviation (activity)
    standing_threshold_deg        0.05         walkmon: activity below max(this, relative x walking) is standing
    standing_relative             0.2          walkmon: ... relative to the median activity of the middle half
    standing_min_s                0.75         walkmon: shortest standing phase that counts
    transition_s                  1.0          walkmon: skipped after/before each standing phase (trunk settling)
    lowpass_factor                3.0          walkmon: low-pass cutoff = factor x step frequency (0: none)
    min_cycle_fraction            0.6          nearest two maxima of an axis, in cycles of that axis
    min_walking_s                 3.0          shorter walking parts give status TOO_SHORT
    max_drift_deg                 8.0          walkmon: an end stance further than this (pitch/roll) from the
                                               start one is not taken as upright (no drift line)
    find_standing                 True         walkmon: look for standing phases at the ends (False: the span
                                               is all walking, e.g. a bout found by walkmon.gait.activity)
    ============================  ===========  =====================================================================
    """

    mode: str = "walkmon"
    step_band_hz: tuple[float, float] = (1.0, 3.0)
    pad_factor: int = 8
    paper_trim_s: float = 3.0
    standing_window_s: float = 0.5
    standing_threshold_deg: float = 0.05
    standing_relative: float = 0.2
    standing_min_s: float = 0.75
    transition_s: float = 1.0
    lowpass_factor: float = 3.0
    min_cycle_fraction: float = 0.6
    min_walking_s: float = 3.0
    max_drift_deg: float = 8.0
    find_standing: bool = True

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            msg = f"indicator mode must be one of {', '.join(MODES)}, got {self.mode!r}"
            raise ConfigError(msg)
        lo, hi = self.step_band_hz
        if not (0 < lo < hi):
            msg = f"step_band_hz must be (low, high) with 0 < low < high, got {self.step_band_hz}"
            raise ConfigError(msg)
        if int(self.pad_factor) != self.pad_factor or self.pad_factor < 1:
            msg = f"pad_factor must be an integer >= 1, got {self.pad_factor}"
            raise ConfigError(msg)
        for name in ("paper_trim_s", "standing_threshold_deg", "transition_s", "lowpass_factor", "min_walking_s",
                     "max_drift_deg"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                msg = f"{name} must be a finite number >= 0, got {value}"
                raise ConfigError(msg)
        for name in ("standing_window_s", "standing_relative", "standing_min_s", "min_cycle_fraction"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                msg = f"{name} must be a finite number > 0, got {value}"
                raise ConfigError(msg)
        if self.min_cycle_fraction >= 1:
            msg = f"min_cycle_fraction must be below 1, got {self.min_cycle_fraction}"
            raise ConfigError(msg)


DEFAULT_INDICATOR_SETTINGS = IndicatorSettings()


class IndicatorStatus(Enum):
    """How trustworthy the indicators are."""

    OK = "ok"
    TOO_SHORT = "too_short"  # not enough walking (or samples) to measure
    NO_GAIT = "no_gait"  # no gait rhythm found in the spectrum, or no full cycle


@dataclass(frozen=True, slots=True)
class AxisIndicators:
    """Eq. 9-15 for one axis (degrees), plus extras: cycle frequency and spreads."""

    lmax_mean: float
    lmin_mean: float
    swing_mean: float
    inclination_mean: float
    n_cycles: int
    swing_std: float = float("nan")
    inclination_std: float = float("nan")
    frequency_hz: float = float("nan")

    def to_dict(self) -> dict[str, Any]:
        return {
            "lmax_mean": _num(self.lmax_mean),
            "lmin_mean": _num(self.lmin_mean),
            "swing_mean": _num(self.swing_mean),
            "inclination_mean": _num(self.inclination_mean),
            "n_cycles": int(self.n_cycles),
            "swing_std": _num(self.swing_std),
            "inclination_std": _num(self.inclination_std),
            "frequency_hz": _num(self.frequency_hz),
        }


@dataclass(frozen=True, slots=True)
class Indicators:
    """The indicators of one walk (or one window). :meth:`to_dict` is the indicators.json schema."""

    cadence_spm: float
    duration_s: float
    walking_s: float
    axes: Mapping[str, AxisIndicators]
    asymmetry: Mapping[str, float]
    classification: Classification = Classification()
    status: IndicatorStatus = IndicatorStatus.OK
    mode: str = "walkmon"
    walking_interval_s: tuple[float, float] = (float("nan"), float("nan"))
    standing_start_s: tuple[float, float] | None = None
    standing_end_s: tuple[float, float] | None = None
    reference_deg: Mapping[str, float] = field(default_factory=dict)
    drift_removed_deg: Mapping[str, float] = field(default_factory=dict)
    #: Session-level additions (schema 2): bouts, segments, summary, upright_reference, activity_s, input ...
    #: as JSON-ready values, written after the fields above.
    session: Mapping[str, Any] = field(default_factory=dict)

    @property
    def step_frequency_hz(self) -> float:
        return self.cadence_spm / 60.0

    def with_classification(self, classification: Classification) -> Indicators:
        """A copy with another classification."""
        return replace(self, classification=classification)

    def with_session(self, session: Mapping[str, Any]) -> Indicators:
        """A copy with the session-level additions (bouts, segments, summary, ...)."""
        return replace(self, session=dict(session))

    def to_dict(self) -> dict[str, Any]:
        """The indicators.json document (NaN becomes null)."""
        return {
            "schema_version": SCHEMA_VERSION,
            "cadence_spm": _num(self.cadence_spm),
            "duration_s": _num(self.duration_s),
            "walking_s": _num(self.walking_s),
            "axes": {a: self.axes[a].to_dict() for a in AXES},
            "asymmetry": {k: _num(v) for k, v in self.asymmetry.items()},
            "classification": self.classification.to_dict(),
            "status": self.status.value,
            "mode": self.mode,
            "walking_interval_s": [_num(v) for v in self.walking_interval_s],
            "standing_start_s": None if self.standing_start_s is None else [_num(v) for v in self.standing_start_s],
            "standing_end_s": None if self.standing_end_s is None else [_num(v) for v in self.standing_end_s],
            "reference_deg": {k: _num(v) for k, v in self.reference_deg.items()},
            "drift_removed_deg": {k: _num(v) for k, v in self.drift_removed_deg.items()},
            # a deep copy: the session's nested bouts and segments are this object's, and a caller editing the
            # returned dict changed the analysis, its write() and save() (review of the Python API)
            **copy.deepcopy(dict(self.session)),
        }


@dataclass(frozen=True, slots=True)
class GaitAnalysis:
    """Indicators plus the intermediate waveforms (for the report's figures). Arrays are read-only.

    ``raw_deg`` (N,3) input angles; ``trend_deg`` (N,3) what was subtracted (least-squares line in paper mode,
    reference + drift line / yaw heading line in walkmon mode); ``corrected_deg`` = raw - trend;
    ``smoothed_deg`` what the extremums were picked on; ``windowed_deg`` (N,3) the Hamming-tapered, detrended
    analysis span (zero outside it); ``spectra`` axis -> (frequencies_hz, amplitudes); ``peak_hz`` axis ->
    dominant frequency; ``maxima_idx``/``minima_idx`` axis -> paired sample indices (one pair per cycle).
    """

    indicators: Indicators
    t_s: NDArray[np.float64]
    raw_deg: NDArray[np.float64]
    trend_deg: NDArray[np.float64]
    corrected_deg: NDArray[np.float64]
    smoothed_deg: NDArray[np.float64]
    windowed_deg: NDArray[np.float64]
    analysis_span: tuple[int, int]
    spectra: Mapping[str, tuple[NDArray[np.float64], NDArray[np.float64]]]
    peak_hz: Mapping[str, float]
    maxima_idx: Mapping[str, NDArray[np.intp]]
    minima_idx: Mapping[str, NDArray[np.intp]]


# --------------------------------------------------------------------------------------------- helpers
def _num(value: float) -> float | None:
    v = float(value)
    return round(v, 6) if math.isfinite(v) else None


def _frozen(a: NDArray[Any]) -> NDArray[Any]:
    a = np.array(a)
    a.setflags(write=False)
    return a


def _check_inputs(t_s: ArrayLike, angles_deg: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    t = np.asarray(t_s, dtype=float)
    a = np.asarray(angles_deg, dtype=float)
    if t.ndim != 1 or a.ndim != 2 or a.shape != (t.size, 3):
        msg = f"expected t_s of shape (N,) and angles_deg of shape (N, 3), got {t.shape} and {a.shape}"
        raise InvalidInputError(msg)
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(a))):
        msg = "t_s and angles_deg must be finite numbers"
        raise InvalidInputError(msg)
    if t.size >= 2 and np.any(np.diff(t) <= 0):
        msg = "t_s must increase strictly"
        raise InvalidInputError(msg)
    return t, a


def _uniform(t: NDArray[np.float64], a: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Resample onto a uniform grid at the mean rate when the time stamps are irregular (>10 % jitter)."""
    dt = np.diff(t)
    if dt.size == 0 or np.max(np.abs(dt - dt.mean())) <= 0.1 * dt.mean():
        return t, a
    grid = np.linspace(t[0], t[-1], t.size)
    return grid, np.column_stack([np.interp(grid, t, a[:, k]) for k in range(a.shape[1])])


def _moving_std(x: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    """Centred moving standard deviation over ``n`` samples (columns independent), same length as ``x``."""
    n = max(int(n), 2)
    kernel = np.ones(n) / n
    pad = ((n // 2, n - 1 - n // 2), (0, 0))
    xp = np.pad(x, pad, mode="edge")
    mean = np.column_stack([np.convolve(xp[:, k], kernel, mode="valid") for k in range(x.shape[1])])
    mean2 = np.column_stack([np.convolve(xp[:, k] ** 2, kernel, mode="valid") for k in range(x.shape[1])])
    return np.sqrt(np.maximum(mean2 - mean**2, 0.0))


def detect_standing(
    t_s: NDArray[np.float64], angles_deg: NDArray[np.float64], settings: IndicatorSettings
) -> tuple[tuple[int, int] | None, tuple[int, int] | None]:
    """Index ranges ``[i0, i1)`` of the standing phase at the start and at the end (None where there is none).

    Activity = moving standard deviation of the angles (all axes combined); a sample is standing when its
    activity is below ``max(standing_threshold_deg, standing_relative x median activity of the middle half)``.
    The start phase is the initial run of standing samples, the end phase the final run, each at least
    ``standing_min_s`` long.
    """
    n = t_s.size
    fs = sample_rate_hz_from_times(t_s)
    activity = np.sqrt(np.sum(_moving_std(angles_deg, round(settings.standing_window_s * fs)) ** 2, axis=1))
    middle = activity[n // 4 : max(3 * n // 4, n // 4 + 1)]
    threshold = max(settings.standing_threshold_deg, settings.standing_relative * float(np.median(middle)))
    still = activity < threshold
    min_len = max(round(settings.standing_min_s * fs), 2)
    start = end = None
    moving = np.flatnonzero(~still)
    if moving.size == 0:
        return (0, n), None
    first, last = int(moving[0]), int(moving[-1])
    if first >= min_len:
        start = (0, first)
    if n - 1 - last >= min_len:
        end = (last + 1, n)
    return start, end


def _lowpass(x: NDArray[np.float64], cutoff_hz: float, fs: float) -> NDArray[np.float64]:
    if not (cutoff_hz > 0) or cutoff_hz >= 0.45 * fs or x.shape[0] < 16:
        return x.copy()
    from scipy import signal  # noqa: PLC0415 - scipy.signal takes ~1 s to import; keep `import walkmon` light

    sos = signal.butter(4, cutoff_hz, btype="low", fs=fs, output="sos")
    return signal.sosfiltfilt(sos, x, axis=0)


def cycle_extremums(
    x: NDArray[np.float64],
    min_distance: int,
    lo: int = 0,
    hi: int | None = None,
    *,
    min_swing_fraction: float = 0.25,
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """One (maximum, minimum) index pair per cycle of ``x`` within ``[lo, hi)``.

    Maxima are local maxima at least ``min_distance`` samples apart (the larger wins); each maximum is paired
    with the lowest sample between it and the next maximum (or the end of the span), when that stretch holds a
    local minimum. Pairs whose swing is below ``min_swing_fraction`` of the median swing are dropped (edge
    wiggles). Returns ``(maxima_idx, minima_idx)`` of equal length.
    """
    hi = x.size if hi is None else hi
    from scipy import signal  # noqa: PLC0415 - scipy.signal takes ~1 s to import; keep `import walkmon` light

    seg = x[lo:hi]
    if seg.size < 3:
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    peaks, _ = signal.find_peaks(seg, distance=max(int(min_distance), 1))
    maxima, minima = [], []
    for j, p in enumerate(peaks):
        stop = peaks[j + 1] if j + 1 < peaks.size else seg.size
        if stop - p < 3:
            continue
        q = p + int(np.argmin(seg[p:stop]))
        if stop == seg.size and (stop - p < min_distance or q == stop - 1):
            continue  # the span ends before this cycle's minimum: a partial cycle would read a small swing
        maxima.append(lo + p)
        minima.append(lo + q)
    imax, imin = np.asarray(maxima, np.intp), np.asarray(minima, np.intp)
    if imax.size >= 3:
        # a wiggle at the span's edge (the trunk settling) passes the distance test but is no gait cycle
        swing = x[imax] - x[imin]
        keep = swing >= min_swing_fraction * float(np.median(swing))
        imax, imin = imax[keep], imin[keep]
    return imax, imin


def paper_extremums(x: NDArray[np.float64], min_distance: int, keep: NDArray[np.bool_]) -> tuple[NDArray, NDArray]:
    """The paper's extremums: local maxima and minima (``min_distance`` apart) whose time is kept, paired in order.

    Each maximum is paired with the next minimum that follows it (adjacent extremums, Eq. 9-10).
    """
    from scipy import signal  # noqa: PLC0415 - scipy.signal takes ~1 s to import; keep `import walkmon` light

    maxima, _ = signal.find_peaks(x, distance=max(int(min_distance), 1))
    minima, _ = signal.find_peaks(-x, distance=max(int(min_distance), 1))
    maxima = maxima[keep[maxima]]
    minima = minima[keep[minima]]
    pairs_a, pairs_b = [], []
    j = 0
    for p in maxima:
        while j < minima.size and minima[j] < p:
            j += 1
        if j >= minima.size:
            break
        pairs_a.append(p)
        pairs_b.append(minima[j])
        j += 1
    return np.asarray(pairs_a, np.intp), np.asarray(pairs_b, np.intp)


def refined_extremum_values(x: NDArray[np.float64], idx: NDArray[np.intp]) -> NDArray[np.float64]:
    """Values of the extremums at ``idx`` refined by a parabola through each sample and its two neighbours.

    A 1.8 Hz swing sampled at 30 fps can peak up to a sixth of a sample period away from its largest sample,
    which would lose up to ~2 % of the swing; the parabola's vertex recovers it.
    """
    idx = np.asarray(idx, dtype=np.intp)
    out = x[idx].astype(float)
    inner = (idx > 0) & (idx < x.size - 1)
    i = idx[inner]
    ym, y0, yp = x[i - 1], x[i], x[i + 1]
    denom = ym - 2.0 * y0 + yp
    with np.errstate(divide="ignore", invalid="ignore"):
        delta = np.where(denom != 0, 0.5 * (ym - yp) / denom, 0.0)
    delta = np.clip(delta, -0.5, 0.5)
    out[inner] = y0 - 0.25 * (ym - yp) * delta
    return out


def _axis_indicators(
    x: NDArray[np.float64], imax: NDArray, imin: NDArray, frequency_hz: float, *, refine: bool
) -> AxisIndicators:
    if imax.size == 0:
        nan = float("nan")
        return AxisIndicators(nan, nan, nan, nan, 0, nan, nan, frequency_hz)
    if refine:
        a, b = refined_extremum_values(x, imax), refined_extremum_values(x, imin)
    else:
        a, b = x[imax], x[imin]
    swing, incl = a - b, 0.5 * (a + b)
    return AxisIndicators(
        lmax_mean=float(a.mean()),
        lmin_mean=float(b.mean()),
        swing_mean=float(swing.mean()),
        inclination_mean=float(incl.mean()),
        n_cycles=int(a.size),
        swing_std=float(swing.std()),
        inclination_std=float(incl.std()),
        frequency_hz=float(frequency_hz),
    )


def _peak_centroids(x: NDArray[np.float64], idx: NDArray[np.intp], depth: NDArray[np.float64]) -> NDArray:
    """Sample positions (fractional) of the peaks of ``x`` at ``idx``: centroid of the part within ``depth``."""
    out = np.empty(idx.size)
    reach = max(int(np.median(np.diff(idx))) // 2, 1) if idx.size > 1 else 1  # stay within the own cycle
    for j, (p, d) in enumerate(zip(idx, depth, strict=True)):
        level = x[p] - max(float(d), 1e-9)
        lo = p
        while lo > max(0, p - reach) and x[lo - 1] > level:
            lo -= 1
        hi = p
        while hi < min(x.size - 1, p + reach) and x[hi + 1] > level:
            hi += 1
        w = x[lo : hi + 1] - level
        out[j] = float(np.sum(w * np.arange(lo, hi + 1)) / np.sum(w))
    return out


def step_asymmetry(x: NDArray[np.float64], imax: NDArray, imin: NDArray, fs: float) -> dict[str, float]:
    """Left/right asymmetry from consecutive pitch (step) cycles, which alternate sides.

    ``step_swing_ratio``: mean swing of the larger-swing side over the other (1 = symmetric);
    ``step_time_ratio``: same for the step durations (between maxima or between minima, the larger);
    ``*_ratio_ci_low``: the ratio at the low end of the 95 % confidence interval of the side difference, and
    ``step_time_n_pairs`` the step pairs it rests on (:func:`walkmon.gait.posture.alternation`: trend removed);
    ``*_asymmetry_pct``: 100 |A - B| / mean(A, B). Sides are "even" and "odd" steps: which one is the left foot
    is unknown.
    """
    from walkmon.gait.posture import alternation

    nan = float("nan")
    out = {
        "n_steps": float(imax.size),
        "step_swing_ratio": nan,
        "step_swing_ratio_ci_low": nan,
        "swing_asymmetry_pct": nan,
        "step_time_ratio": nan,
        "step_time_ratio_ci_low": nan,
        "step_time_n_pairs": 0.0,
        "step_time_asymmetry_pct": nan,
    }
    if imax.size >= 4:
        swing = x[imax] - x[imin]
        alt = alternation(swing, min_pairs=2)
        if math.isfinite(alt["ratio"]):
            out["step_swing_ratio"] = alt["ratio"]
            out["step_swing_ratio_ci_low"] = alt["ratio_ci_low"]
            out["swing_asymmetry_pct"] = 200.0 * (alt["ratio"] - 1) / (alt["ratio"] + 1)
    if imax.size >= 5:
        # Intervals between maxima and between minima: the extremums sit at some phase of the step, and an
        # interval spans parts of two steps, so each estimate underrates the asymmetry; keep the larger one.
        # Extremum times are the centroids of their peaks' top fifth, not the argmax: a flat, double-humped
        # peak would otherwise hop between its humps and fake an alternation.
        best = (1.0, 1.0, 0.0)
        swing_all = x[imax] - x[imin]
        for marks, sign in ((imax, 1.0), (imin, -1.0)):
            times = _peak_centroids(sign * x, marks, 0.2 * swing_all)
            alt = alternation(np.diff(times) / fs, min_pairs=2)
            if math.isfinite(alt["ratio"]) and alt["ratio"] >= best[0]:
                best = (alt["ratio"], alt["ratio_ci_low"], alt["n_pairs"])
        out["step_time_ratio"], out["step_time_ratio_ci_low"], out["step_time_n_pairs"] = best
        out["step_time_asymmetry_pct"] = 200.0 * (best[0] - 1) / (best[0] + 1)
    return out


# --------------------------------------------------------------------------------------------- main
def analyze_gait(
    t_s: ArrayLike,
    angles_deg: ArrayLike,
    settings: IndicatorSettings = DEFAULT_INDICATOR_SETTINGS,
    *,
    reference_deg: ArrayLike | None = None,
) -> GaitAnalysis:
    """Indicators and the intermediate waveforms. See the module docstring for the two modes.

    ``reference_deg`` (pitch, yaw, roll): the upright stance, for windows without a standing phase at their
    start (walkmon mode). Defaults to the start standing phase when one is found, else zero (walkmon's angles
    are relative to the first frame, which is the upright calibration stance).
    Degenerate input (too short, no rhythm) is reported through ``indicators.status``, never an exception;
    malformed arrays raise :class:`InvalidInputError`.
    """
    t, raw = _check_inputs(t_s, angles_deg)
    n = t.size
    duration = float(t[-1] - t[0]) if n else 0.0
    if n < 16 or duration <= 0:
        return _empty_analysis(t, raw, settings, duration, IndicatorStatus.TOO_SHORT)
    t, raw = _uniform(t, raw)
    fs = sample_rate_hz_from_times(t)
    if settings.mode == "paper":
        return _analyze_paper(t, raw, fs, settings, duration)
    return _analyze_walkmon(t, raw, fs, settings, duration, reference_deg)


def _empty_analysis(
    t: NDArray, raw: NDArray, settings: IndicatorSettings, duration: float, status: IndicatorStatus
) -> GaitAnalysis:
    nan = float("nan")
    axes = {a: AxisIndicators(nan, nan, nan, nan, 0) for a in AXES}
    no_steps = np.zeros(0, np.intp)
    asym = step_asymmetry(np.zeros(0), no_steps, no_steps, 1.0)
    ind = Indicators(nan, duration, 0.0, axes, asym, status=status, mode=settings.mode)
    z = np.zeros_like(raw)
    empty = {a: np.zeros(0, np.intp) for a in AXES}
    return GaitAnalysis(ind, _frozen(t), _frozen(raw), _frozen(z), _frozen(raw), _frozen(raw), _frozen(z), (0, 0),
                        {}, {a: nan for a in AXES}, empty, empty)


def _spectra(
    detrended: NDArray[np.float64], fs: float, settings: IndicatorSettings, span: tuple[int, int]
) -> tuple[NDArray, dict, dict, Any]:
    """Windowed waveform over the span, per-axis spectra and peaks, and the combined step frequency."""
    i0, i1 = span
    windowed = np.zeros_like(detrended)
    w = hamming_taper(i1 - i0)
    spectra, peaks = {}, {}
    seg = {}
    for k, axis in enumerate(AXES):
        y = detrended[i0:i1, k]
        windowed[i0:i1, k] = y * w
        spectra[axis] = amplitude_spectrum(y, fs, pad_factor=settings.pad_factor)
        factor = STEP_FACTOR_BY_AXIS[axis]
        band = (settings.step_band_hz[0] / factor, settings.step_band_hz[1] / factor)
        peaks[axis] = refined_peak(y, fs, band, pad_factor=settings.pad_factor).frequency_hz
        seg[axis] = y
    step = step_frequency_hz(seg, fs, step_band_hz=settings.step_band_hz, pad_factor=settings.pad_factor)
    return windowed, spectra, peaks, step


def _analyze_walkmon(
    t: NDArray, raw: NDArray, fs: float, settings: IndicatorSettings, duration: float, reference_deg: ArrayLike | None
) -> GaitAnalysis:
    n = t.size
    start, end = detect_standing(t, raw, settings) if settings.find_standing else (None, None)
    margin = round(settings.transition_s * fs)
    i0 = start[1] + margin if start else 0
    i1 = end[0] - margin if end else n
    if start is not None and start[1] >= n:  # standing all along
        return _empty_analysis(t, raw, settings, duration, IndicatorStatus.NO_GAIT)
    # reference (upright stance) and drift line for pitch and roll
    if reference_deg is not None:
        ref0 = np.asarray(reference_deg, dtype=float).reshape(3)
    elif start is not None:
        ref0 = np.median(raw[start[0] : start[1]], axis=0)
    else:
        ref0 = np.zeros(3)
    t0 = float(np.mean(t[start[0] : start[1]])) if start else float(t[0])
    ref1, t1 = ref0, t0
    if end is not None and start is not None:
        # Both ends are the upright stance only in a whole session (standing at start and end); a window that
        # merely ends with the wearer standing still may end in any posture, so it gets no drift line.
        end_ref = np.median(raw[end[0] : end[1]], axis=0)
        k_tilt = [AXES.index("pitch"), AXES.index("roll")]
        gap = float(np.max(np.abs(end_ref[k_tilt] - ref0[k_tilt])))
        if gap <= settings.max_drift_deg:
            ref1, t1 = end_ref, float(np.mean(t[end[0] : end[1]]))
        else:
            _log.warning(
                "end stance differs from the start by %.1f deg (> max_drift_deg %.1f): not used as upright",
                gap, settings.max_drift_deg,
            )
    trend = line_through(t, t0, ref0, t1, ref1)
    drift = ref1 - ref0
    walking_s = max(0.0, float(t[i1 - 1] - t[i0])) if i1 > i0 else 0.0
    if i1 - i0 < 16 or walking_s < settings.min_walking_s:
        a = _empty_analysis(t, raw, settings, duration, IndicatorStatus.TOO_SHORT)
        return a
    # yaw: heading line of the walking part (no gravity reference for yaw)
    k_yaw = AXES.index("yaw")
    _, yaw_line = detrend_least_squares(t[i0:i1], raw[i0:i1, k_yaw])
    slope = (yaw_line[-1] - yaw_line[0]) / (t[i1 - 1] - t[i0]) if i1 - 1 > i0 else 0.0
    trend[:, k_yaw] = yaw_line[0] + slope * (t - t[i0])
    corrected = raw - trend
    detrended_span = np.zeros_like(corrected)
    detrended_span[i0:i1], _ = detrend_least_squares(t[i0:i1], corrected[i0:i1])
    windowed, spectra, peaks, step = _spectra(detrended_span, fs, settings, (i0, i1))
    waves = _Waveforms(t, raw, trend, corrected, corrected, windowed, (i0, i1), fs)
    stance = _Stance(start, end, ref0, drift)
    if not step.found:
        no_gait = _Found(spectra, peaks, walking_s, _NAN, IndicatorStatus.NO_GAIT)
        return _finish(waves, no_gait, stance, settings, duration)
    f_step = step.frequency_hz
    smoothed = _lowpass(corrected, settings.lowpass_factor * f_step, fs) if settings.lowpass_factor > 0 else corrected
    maxima, minima = {}, {}
    for k, axis in enumerate(AXES):
        period = STEP_FACTOR_BY_AXIS[axis] / f_step
        maxima[axis], minima[axis] = cycle_extremums(
            smoothed[:, k], round(settings.min_cycle_fraction * period * fs), i0, i1
        )
    found = _Found(spectra, peaks, walking_s, 60.0 * f_step, IndicatorStatus.OK, maxima, minima)
    return _finish(replace(waves, smoothed=smoothed), found, stance, settings, duration)


def _analyze_paper(t: NDArray, raw: NDArray, fs: float, settings: IndicatorSettings, duration: float) -> GaitAnalysis:
    n = t.size
    corrected, trend = detrend_least_squares(t, raw)
    windowed, spectra, peaks, step = _spectra(corrected, fs, settings, (0, n))
    keep = (t >= t[0] + settings.paper_trim_s) & (t <= t[-1] - settings.paper_trim_s)
    walking_s = float(np.sum(keep)) / fs
    if walking_s < settings.min_walking_s or not step.found:
        status = IndicatorStatus.TOO_SHORT if walking_s < settings.min_walking_s else IndicatorStatus.NO_GAIT
        waves = _Waveforms(t, raw, trend, corrected, corrected, windowed, (0, n), fs)
        return _finish(waves, _Found(spectra, peaks, walking_s, _NAN, status), _no_stance(), settings, duration)
    maxima, minima = {}, {}
    for k, axis in enumerate(AXES):
        f_axis = peaks[axis] if np.isfinite(peaks[axis]) else step.frequency_hz / STEP_FACTOR_BY_AXIS[axis]
        maxima[axis], minima[axis] = paper_extremums(
            corrected[:, k], round(settings.min_cycle_fraction * fs / f_axis), keep
        )
    idx = np.flatnonzero(keep)
    waves = _Waveforms(t, raw, trend, corrected, corrected, windowed, (int(idx[0]), int(idx[-1]) + 1), fs)
    found = _Found(spectra, peaks, walking_s, 60.0 * step.frequency_hz, IndicatorStatus.OK, maxima, minima)
    return _finish(waves, found, _no_stance(), settings, duration)


@dataclass(frozen=True, slots=True)
class _Waveforms:
    """The analysis's waveforms (rows of ``t``) and the span of the walk they were measured on."""

    t: NDArray
    raw: NDArray
    trend: NDArray
    corrected: NDArray
    #: the waveform the cycles are found on (low-passed, or ``corrected`` itself)
    smoothed: NDArray
    windowed: NDArray
    span: tuple[int, int]
    fs: float


@dataclass(frozen=True, slots=True)
class _Stance:
    """The standing stances found (row spans, or None), the upright reference and the drift removed."""

    start: tuple[int, int] | None
    end: tuple[int, int] | None
    ref0: NDArray
    drift: NDArray


def _no_stance() -> _Stance:
    """No stance searched (the paper's mode): no reference, no drift."""
    return _Stance(None, None, np.zeros(3), np.zeros(3))


@dataclass(frozen=True, slots=True)
class _Found:
    """What the analysis found: spectra and peaks per axis, the walk's duration and cadence, its status and the
    cycles' extremums per axis (none when no gait was found)."""

    spectra: dict[str, Any]
    peaks: dict[str, float]
    walking_s: float
    cadence_spm: float
    status: IndicatorStatus
    maxima: dict[str, NDArray] = field(default_factory=dict)
    minima: dict[str, NDArray] = field(default_factory=dict)


def _finish(
    waves: _Waveforms, found: _Found, stance: _Stance, settings: IndicatorSettings, duration: float
) -> GaitAnalysis:
    t, smoothed, span, fs = waves.t, waves.smoothed, waves.span, waves.fs
    peaks, maxima, minima, status = found.peaks, found.maxima, found.minima, found.status
    start, end, ref0, drift = stance.start, stance.end, stance.ref0, stance.drift
    axes = {}
    empty = np.zeros(0, np.intp)
    for k, axis in enumerate(AXES):
        imax, imin = maxima.get(axis, empty), minima.get(axis, empty)
        axes[axis] = _axis_indicators(
            smoothed[:, k], imax, imin, peaks.get(axis, float("nan")), refine=settings.mode == "walkmon"
        )
    k_p = AXES.index("pitch")
    asym = step_asymmetry(smoothed[:, k_p], maxima.get("pitch", empty), minima.get("pitch", empty), fs)
    if status is IndicatorStatus.OK and all(axes[a].n_cycles == 0 for a in AXES):
        status = IndicatorStatus.NO_GAIT
    ind = Indicators(
        cadence_spm=float(found.cadence_spm),
        duration_s=duration,
        walking_s=found.walking_s,
        axes=axes,
        asymmetry=asym,
        status=status,
        mode=settings.mode,
        walking_interval_s=(float(t[span[0]]), float(t[span[1] - 1])) if span[1] > span[0] else (_NAN, _NAN),
        standing_start_s=None if start is None else (float(t[start[0]]), float(t[start[1] - 1])),
        standing_end_s=None if end is None else (float(t[end[0]]), float(t[end[1] - 1])),
        reference_deg=dict(zip(AXES, (float(v) for v in ref0), strict=True)),
        drift_removed_deg={a: float(drift[k]) for k, a in enumerate(AXES) if a != "yaw"},
    )
    return GaitAnalysis(
        indicators=ind,
        t_s=_frozen(t),
        raw_deg=_frozen(waves.raw),
        trend_deg=_frozen(waves.trend),
        corrected_deg=_frozen(waves.corrected),
        smoothed_deg=_frozen(smoothed),
        windowed_deg=_frozen(waves.windowed),
        analysis_span=span,
        spectra={a: (_frozen(f), _frozen(m)) for a, (f, m) in found.spectra.items()},
        peak_hz=dict(peaks),
        maxima_idx={a: _frozen(v) for a, v in maxima.items()},
        minima_idx={a: _frozen(v) for a, v in minima.items()},
    )


def compute_indicators(
    t_s: ArrayLike,
    angles_deg: ArrayLike,
    settings: IndicatorSettings = DEFAULT_INDICATOR_SETTINGS,
    baseline: Indicators | Mapping[str, Any] | None = None,
    *,
    reference_deg: ArrayLike | None = None,
) -> Indicators:
    """The paper's indicators of a walk, classified (see :mod:`walkmon.gait.posture`).

    ``baseline``: the same person's normal walk (an :class:`Indicators` or an indicators.json dict); the
    classification is then relative to it. ``reference_deg``: see :func:`analyze_gait`.
    """
    return classified(analyze_gait(t_s, angles_deg, settings, reference_deg=reference_deg).indicators, baseline)


def classified(indicators: Indicators, baseline: Indicators | Mapping[str, Any] | None = None) -> Indicators:
    """``indicators`` with its classification (relative to ``baseline`` when given)."""

    base = baseline.to_dict() if isinstance(baseline, Indicators) else baseline
    return indicators.with_classification(classify(indicators.to_dict(), base))


# --------------------------------------------------------------------------------------------- json
def indicators_from_dict(doc: Mapping[str, Any], source: str = "indicators") -> Indicators:
    """Rebuild :class:`Indicators` from an indicators.json document; raises InvalidInputError when malformed."""

    def num(v: Any, where: str) -> float:
        if v is None:
            return float("nan")
        if isinstance(v, bool) or not isinstance(v, int | float):
            msg = f"{source}: {where} must be a number, got {v!r}"
            raise InvalidInputError(msg)
        return float(v)

    if not isinstance(doc, Mapping):
        msg = f"{source}: expected a JSON object"
        raise InvalidInputError(msg)
    missing = [k for k in ("cadence_spm", "duration_s", "walking_s", "axes") if k not in doc]
    if missing:
        msg = f"{source}: missing field(s) {', '.join(missing)}"
        raise InvalidInputError(msg)
    axes_doc = doc["axes"]
    if not isinstance(axes_doc, Mapping) or any(a not in axes_doc for a in AXES):
        msg = f"{source}: 'axes' must hold pitch, yaw and roll"
        raise InvalidInputError(msg)
    axes = {}
    for a in AXES:
        d = axes_doc[a]
        if not isinstance(d, Mapping):
            msg = f"{source}: axes.{a} must be an object"
            raise InvalidInputError(msg)
        fields = ("lmax_mean", "lmin_mean", "swing_mean", "inclination_mean")
        lacking = [f for f in fields if f not in d]
        if lacking:
            msg = f"{source}: axes.{a} lacks {', '.join(lacking)}"
            raise InvalidInputError(msg)
        axes[a] = AxisIndicators(  # type: ignore[misc]  # the 4 positional fields, then the keywords
            *(num(d[f], f"axes.{a}.{f}") for f in fields),  # type: ignore[arg-type]
            n_cycles=int(num(d.get("n_cycles", 0), f"axes.{a}.n_cycles") or 0),
            swing_std=num(d.get("swing_std"), f"axes.{a}.swing_std"),
            inclination_std=num(d.get("inclination_std"), f"axes.{a}.inclination_std"),
            frequency_hz=num(d.get("frequency_hz"), f"axes.{a}.frequency_hz"),
        )
    cls = doc.get("classification") or {}
    status_text = doc.get("status", "ok")
    try:
        status = IndicatorStatus(status_text)
    except ValueError:
        msg = f"{source}: unknown status {status_text!r}"
        raise InvalidInputError(msg) from None

    def pair(v: Any, where: str) -> tuple[float, float] | None:
        if v is None:
            return None
        if not isinstance(v, list | tuple) or len(v) != 2:
            msg = f"{source}: {where} must be [start, end]"
            raise InvalidInputError(msg)
        return (num(v[0], where), num(v[1], where))

    return Indicators(
        cadence_spm=num(doc["cadence_spm"], "cadence_spm"),
        duration_s=num(doc["duration_s"], "duration_s"),
        walking_s=num(doc["walking_s"], "walking_s"),
        axes=axes,
        asymmetry={str(k): num(v, f"asymmetry.{k}") for k, v in (doc.get("asymmetry") or {}).items()},
        classification=Classification(str(cls.get("label", "unclassified")), tuple(map(str, cls.get("reasons", [])))),
        status=status,
        mode=str(doc.get("mode", "walkmon")),
        walking_interval_s=pair(doc.get("walking_interval_s"), "walking_interval_s") or (float("nan"),) * 2,
        standing_start_s=pair(doc.get("standing_start_s"), "standing_start_s"),
        standing_end_s=pair(doc.get("standing_end_s"), "standing_end_s"),
        reference_deg={str(k): num(v, f"reference_deg.{k}") for k, v in (doc.get("reference_deg") or {}).items()},
        drift_removed_deg={
            str(k): num(v, f"drift_removed_deg.{k}") for k, v in (doc.get("drift_removed_deg") or {}).items()
        },
        session={k: doc[k] for k in SESSION_KEYS if k in doc},
    )
