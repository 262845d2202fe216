"""Spectral tools for gait waveforms: detrending, Hamming taper, amplitude spectrum, refined gait frequency.

The paper (Sec. 4.1) removes the accumulated error with a least-squares line, tapers the waveform with a
Hamming window (its Eq. 8) and reads the gait rhythm from the largest peak of the amplitude spectrum. The bin
width of a 10 s window is 0.1 Hz, i.e. 6 steps/min, far too coarse for cadence; :func:`refined_peak` zero-pads
the FFT and fits a parabola to the log-amplitude around the largest bin, which brings a pure tone to well under
1 % of a bin.

Trunk rotations follow two rhythms: pitch (and the vertical bob) repeat every *step*; roll and yaw (lateral lean
and twist) repeat every *stride* = two steps. :func:`step_frequency_hz` combines the axes so that the cadence in
steps/min comes out right whichever axis carries the clearest rhythm.

Pure functions on numpy arrays; no I/O.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from walkmon.errors import InvalidInputError

__all__ = [
    "SpectralPeak",
    "StepFrequency",
    "amplitude_spectrum",
    "detrend_least_squares",
    "hamming_taper",
    "line_through",
    "refined_peak",
    "sample_rate_hz_from_times",
    "step_frequency_hz",
]

_log = logging.getLogger(__name__)

#: Pitch repeats every step, roll and yaw every stride (two steps): step frequency = factor x axis frequency.
STEP_FACTOR_BY_AXIS = {"pitch": 1.0, "yaw": 2.0, "roll": 2.0}


@dataclass(frozen=True, slots=True)
class SpectralPeak:
    """The largest peak of an amplitude spectrum inside a band.

    ``frequency_hz`` is refined below the bin width; ``bin_hz`` is the bin width of the unpadded FFT;
    ``amplitude`` is the (taper-corrected) peak amplitude in the signal's unit; ``prominence`` is the peak
    amplitude divided by the median amplitude in the band (a unitless confidence, large for a clear rhythm).
    ``found`` is False when the band holds no local maximum (e.g. a flat signal).
    """

    frequency_hz: float
    amplitude: float
    bin_hz: float
    prominence: float
    found: bool = True


@dataclass(frozen=True, slots=True)
class StepFrequency:
    """The step frequency (cadence / 60) and the per-axis estimates it was combined from."""

    frequency_hz: float
    per_axis_hz: dict[str, float]
    weights: dict[str, float]
    found: bool

    @property
    def cadence_spm(self) -> float:
        """Cadence in steps per minute."""
        return 60.0 * self.frequency_hz


def sample_rate_hz_from_times(t_s: ArrayLike) -> float:
    """Mean sample rate of increasing time stamps (at least two), in Hz."""
    t = np.asarray(t_s, dtype=float)
    if t.ndim != 1 or t.size < 2:
        msg = f"need at least 2 time stamps, got shape {t.shape}"
        raise InvalidInputError(msg)
    span = float(t[-1] - t[0])
    if not span > 0:
        msg = "time stamps do not increase"
        raise InvalidInputError(msg)
    return (t.size - 1) / span


def detrend_least_squares(t_s: ArrayLike, x: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The paper's detrend: subtract the least-squares line; returns ``(detrended, trend)`` (last axis = time).

    ``x`` may be (N,) or (N, K): each column gets its own line.
    """
    t = np.asarray(t_s, dtype=float)
    y = np.asarray(x, dtype=float)
    design = np.column_stack([np.ones_like(t), t - t.mean()])
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    trend = design @ coef
    return y - trend, trend


def line_through(t_s: ArrayLike, t0_s: float, y0: ArrayLike, t1_s: float, y1: ArrayLike) -> NDArray[np.float64]:
    """Values at ``t_s`` of the straight line through ``(t0, y0)`` and ``(t1, y1)`` (y may be vectors, shape (K,)).

    With ``t1 == t0`` the line is the constant ``y0``.
    """
    t = np.asarray(t_s, dtype=float)[:, None] if np.ndim(y0) else np.asarray(t_s, dtype=float)
    a, b = np.asarray(y0, dtype=float), np.asarray(y1, dtype=float)
    if t1_s == t0_s:
        return np.broadcast_to(a, np.broadcast_shapes(t.shape, a.shape)).astype(float)
    return a + (b - a) * (t - t0_s) / (t1_s - t0_s)


def hamming_taper(n: int) -> NDArray[np.float64]:
    """The paper's Eq. 8 over ``n`` samples: ``0.54 - 0.46 cos(2 pi x)``, x from 0 to 1 (symmetric)."""
    if n < 1:
        msg = f"taper length must be >= 1, got {n}"
        raise InvalidInputError(msg)
    if n == 1:
        return np.ones(1)
    x = np.arange(n) / (n - 1)
    return 0.54 - 0.46 * np.cos(2.0 * np.pi * x)


def amplitude_spectrum(
    x: ArrayLike, sample_rate_hz: float, *, pad_factor: int = 1, taper: bool = True
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """One-sided amplitude spectrum ``(frequencies_hz, amplitudes)`` of a (detrended) waveform.

    The waveform is tapered with :func:`hamming_taper` (when ``taper``) and zero-padded to ``pad_factor`` times
    its length. Amplitudes are scaled so that a sinusoid of amplitude A reads A at its peak (the taper's
    coherent gain is divided out).
    """
    y = np.asarray(x, dtype=float)
    if y.ndim != 1 or y.size < 4:
        msg = f"need a 1-D waveform of at least 4 samples, got shape {y.shape}"
        raise InvalidInputError(msg)
    if not sample_rate_hz > 0 or pad_factor < 1:
        msg = f"sample rate must be > 0 and pad factor >= 1, got {sample_rate_hz} and {pad_factor}"
        raise InvalidInputError(msg)
    w = hamming_taper(y.size) if taper else np.ones(y.size)
    n_fft = int(pad_factor) * y.size
    spec = np.fft.rfft(y * w, n=n_fft)
    amps = 2.0 * np.abs(spec) / w.sum()
    freqs = np.fft.rfftfreq(n_fft, d=1.0 / sample_rate_hz)
    return freqs.astype(np.float64, copy=False), amps


def refined_peak(
    x: ArrayLike, sample_rate_hz: float, band_hz: tuple[float, float], *, pad_factor: int = 8
) -> SpectralPeak:
    """The largest spectral peak of ``x`` inside ``band_hz``, refined below the bin width.

    Zero-padding by ``pad_factor`` samples the spectrum finely; a parabola through the log-amplitudes of the
    largest padded bin and its two neighbours locates the peak (exact for a Gaussian-shaped main lobe, which the
    Hamming window's closely is). The signal should already be detrended.
    """
    y = np.asarray(x, dtype=float)
    freqs, amps = amplitude_spectrum(y, sample_rate_hz, pad_factor=pad_factor)
    bin_hz = sample_rate_hz / y.size
    lo, hi = band_hz
    idx = np.flatnonzero((freqs >= lo) & (freqs <= hi))
    if idx.size < 3 or not np.any(amps[idx] > 0):
        return SpectralPeak(float("nan"), 0.0, bin_hz, 0.0, found=False)
    # Local maxima inside the band (a band edge sitting on a slope is not a peak).
    inner = idx[(idx > 0) & (idx < amps.size - 1)]
    is_max = (amps[inner] >= amps[inner - 1]) & (amps[inner] > amps[inner + 1])
    candidates = inner[is_max]
    if candidates.size == 0:
        return SpectralPeak(float("nan"), 0.0, bin_hz, 0.0, found=False)
    k = int(candidates[np.argmax(amps[candidates])])
    la, lb, lc = np.log(np.maximum(amps[k - 1 : k + 2], 1e-300))
    denom = la - 2.0 * lb + lc
    delta = 0.5 * (la - lc) / denom if denom < 0 else 0.0
    delta = float(np.clip(delta, -0.5, 0.5))
    df = freqs[1] - freqs[0]
    frequency = float(freqs[k] + delta * df)
    amplitude = float(np.exp(lb - 0.25 * (la - lc) * delta))
    median = float(np.median(amps[idx]))
    prominence = amplitude / median if median > 0 else float("inf")
    return SpectralPeak(frequency, amplitude, bin_hz, prominence)


def step_frequency_hz(
    detrended: dict[str, NDArray[np.float64]],
    sample_rate_hz: float,
    *,
    step_band_hz: tuple[float, float] = (1.0, 3.0),
    pad_factor: int = 8,
) -> StepFrequency:
    """Step frequency from detrended pitch/yaw/roll waveforms (any subset of the axes).

    Pitch is searched in ``step_band_hz``; roll and yaw, which repeat every stride, in half that band, and their
    peak doubled. Each axis votes with weight ``prominence`` (peak over band median); axes whose estimate
    disagrees by more than 12 % with the strongest vote are dropped (e.g. a pitch peak at the stride frequency
    of a limping walk), and the remaining estimates are averaged with their weights.
    """
    estimates: dict[str, float] = {}
    weights: dict[str, float] = {}
    for axis, y in detrended.items():
        factor = STEP_FACTOR_BY_AXIS[axis]
        band = (step_band_hz[0] / factor, step_band_hz[1] / factor)
        peak = refined_peak(y, sample_rate_hz, band, pad_factor=pad_factor)
        if not peak.found or not np.isfinite(peak.prominence):
            continue
        estimates[axis] = factor * peak.frequency_hz
        weights[axis] = peak.prominence
    if not estimates:
        return StepFrequency(float("nan"), {}, {}, found=False)
    best = max(weights, key=weights.__getitem__)
    ref = estimates[best]
    kept = {a: f for a, f in estimates.items() if abs(f - ref) <= 0.12 * ref}
    total = sum(weights[a] for a in kept)
    frequency = sum(weights[a] * f for a, f in kept.items()) / total
    used = {a: (weights[a] if a in kept else 0.0) for a in estimates}
    return StepFrequency(float(frequency), estimates, used, found=True)
