"""Spectrum helpers: sub-bin frequency accuracy, agreement with np.fft, detrending, step vs stride frequency."""

from __future__ import annotations

import numpy as np
import pytest

from walkmon.errors import InvalidInputError
from walkmon.gait.spectrum import (
    amplitude_spectrum,
    detrend_least_squares,
    hamming_taper,
    line_through,
    refined_peak,
    step_frequency_hz,
)

FS = 30.0


def _t(seconds: float = 10.0) -> np.ndarray:
    return np.arange(0.0, seconds, 1.0 / FS)


@pytest.mark.parametrize("freq_hz", [0.83, 1.234, 1.5, 1.777, 2.2, 2.71])
def test_refined_peak_is_well_below_a_bin(freq_hz: float) -> None:
    rng = np.random.default_rng(int(freq_hz * 1000))
    t = _t(10.0)
    x = 1.3 * np.sin(2 * np.pi * freq_hz * t + rng.uniform(0, 6.28)) + 0.1 * rng.standard_normal(t.size)
    d, _ = detrend_least_squares(t, x)
    peak = refined_peak(d, FS, (0.5, 3.5))
    assert peak.found
    assert peak.bin_hz == pytest.approx(FS / t.size)
    # a tenth of a bin (0.01 Hz here, 0.4-1.2 % of the frequency) at the very least; typically 1/100
    assert abs(peak.frequency_hz - freq_hz) < 0.05 * peak.bin_hz
    assert peak.amplitude == pytest.approx(1.3, rel=0.05)
    # the unrefined argmax of the plain FFT is off by up to half a bin: refinement must beat it
    f, a = amplitude_spectrum(d, FS, pad_factor=1)
    band = (f >= 0.5) & (f <= 3.5)
    coarse = f[band][np.argmax(a[band])]
    if abs(coarse - freq_hz) > 0.2 * peak.bin_hz:  # off-bin tones: several times better than the argmax
        assert abs(peak.frequency_hz - freq_hz) < 0.25 * abs(coarse - freq_hz)


def test_amplitude_spectrum_matches_numpy_fft_on_random_input() -> None:
    rng = np.random.default_rng(7)
    x = rng.standard_normal(301)
    f, a = amplitude_spectrum(x, FS, pad_factor=1)
    w = np.hamming(301)  # numpy's symmetric Hamming window is the paper's Eq. 8
    assert np.allclose(hamming_taper(301), w)
    ref = 2 * np.abs(np.fft.rfft(x * w)) / w.sum()
    assert np.allclose(a, ref)
    assert np.allclose(f, np.fft.rfftfreq(301, 1 / FS))
    f4, a4 = amplitude_spectrum(x, FS, pad_factor=4)
    assert np.allclose(a4, 2 * np.abs(np.fft.rfft(x * w, n=4 * 301)) / w.sum())
    assert np.allclose(a4[::4], a)  # zero-padding interpolates the same spectrum


def test_detrend_removes_exactly_the_least_squares_line() -> None:
    t = _t(8.0)
    rng = np.random.default_rng(1)
    x = 0.7 + 0.4 * t + np.sin(2 * np.pi * 1.8 * t) + 0.05 * rng.standard_normal(t.size)
    d, trend = detrend_least_squares(t, x)
    slope, intercept = np.polyfit(t, x, 1)
    assert np.allclose(trend, slope * t + intercept)
    assert np.allclose(d + trend, x)
    two = np.column_stack([x, -x])
    d2, _ = detrend_least_squares(t, two)
    assert np.allclose(d2[:, 0], d) and np.allclose(d2[:, 1], -d)


def test_line_through_two_anchors() -> None:
    t = np.array([0.0, 1.0, 2.0, 4.0])
    y = line_through(t, 1.0, np.array([1.0, 0.0, 2.0]), 3.0, np.array([3.0, 0.0, 2.0]))
    assert y.shape == (4, 3)
    assert np.allclose(y[:, 0], [0.0, 1.0, 2.0, 4.0])
    assert np.allclose(y[:, 2], 2.0)
    assert np.allclose(line_through(t, 1.0, 5.0, 1.0, 9.0), 5.0)


@pytest.mark.parametrize("axes", [("pitch",), ("roll",), ("yaw",), ("pitch", "yaw", "roll")])
def test_cadence_from_step_or_stride_axes(axes: tuple[str, ...]) -> None:
    step_hz = 1.83
    t = _t(10.0)
    waves = {
        "pitch": 1.0 * np.cos(2 * np.pi * step_hz * t) + 0.2 * np.cos(2 * np.pi * 2 * step_hz * t + 1.0),
        "roll": 2.0 * np.sin(np.pi * step_hz * t) + 0.4 * np.cos(2 * np.pi * step_hz * t),
        "yaw": 1.5 * np.sin(np.pi * step_hz * t + 0.5) + 0.3 * np.sin(3 * np.pi * step_hz * t),
    }
    sel = {a: detrend_least_squares(t, waves[a])[0] for a in axes}
    est = step_frequency_hz(sel, FS)
    assert est.found
    assert est.cadence_spm == pytest.approx(60 * step_hz, rel=0.003)


def test_limping_pitch_with_a_stride_component_still_gives_the_step_frequency() -> None:
    step_hz = 1.4
    t = _t(10.0)
    pitch = np.cos(2 * np.pi * step_hz * t) + 0.6 * np.cos(np.pi * step_hz * t)
    roll = 3.0 * np.sin(np.pi * step_hz * t)
    est = step_frequency_hz({"pitch": pitch, "roll": roll}, FS)
    assert est.cadence_spm == pytest.approx(60 * step_hz, rel=0.005)


def test_flat_signal_has_no_peak_and_bad_input_raises() -> None:
    t = _t(5.0)
    assert not refined_peak(np.zeros(t.size), FS, (1.0, 3.0)).found
    assert not step_frequency_hz({"pitch": np.zeros(t.size)}, FS).found
    with pytest.raises(InvalidInputError, match="at least 4"):
        amplitude_spectrum(np.zeros(2), FS)
    with pytest.raises(InvalidInputError):
        hamming_taper(0)
