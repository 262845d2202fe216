"""walkmon.sampling: a recording's rate and gaps, against sample times built with a known rate and known gaps."""

from __future__ import annotations

import numpy as np
import pytest

from walkmon.sampling import gap_threshold_s, gaps, sampling_rate_hz


def test_a_gap_is_left_out_of_the_rate() -> None:
    t = np.arange(0.0, 160.0, 0.01)
    t = t[(t < 40.0) | (t > 100.0)]  # a minute without samples: (n - 1) / duration reads 62.5 Hz
    assert sampling_rate_hz(t) == pytest.approx(100.0, rel=1e-6)
    assert gaps(t) == [pytest.approx((39.99, 100.01), abs=1e-6)]


def test_bursts_are_no_gaps() -> None:
    """A logger that stamps samples as they arrive, in bursts of 1, 1 and 28 ms, samples at 100 Hz, not 1000."""
    t = np.cumsum(np.tile([0.001, 0.001, 0.028], 1000))
    assert sampling_rate_hz(t) == pytest.approx(100.0, rel=1e-3)
    assert gaps(t) == []
    assert gap_threshold_s(t) == pytest.approx(0.1, rel=1e-3)


def test_a_clock_jump_does_not_become_the_yardstick() -> None:
    t = np.arange(0.0, 20.0, 0.005)
    t[2000:] += 1e7
    assert sampling_rate_hz(t) == pytest.approx(200.0, rel=1e-6)
    assert len(gaps(t)) == 1


def test_gaps_shorter_than_asked_are_not_listed_and_short_inputs_have_none() -> None:
    t = np.arange(1000) / 100.0
    t = t[(t < 2.0) | (t > 2.505)]  # 1.99 -> 2.51
    t = t[(t < 6.0) | (t > 8.005)]  # 5.99 -> 8.01
    assert [b - a for a, b in gaps(t)] == pytest.approx([0.52, 2.02], abs=1e-6)
    assert [b - a for a, b in gaps(t, min_s=1.0)] == pytest.approx([2.02], abs=1e-6)
    assert gaps([0.0, 1.0]) == [] and sampling_rate_hz([0.0]) == 0.0
    assert sampling_rate_hz([0.0, 0.5]) == pytest.approx(2.0)


def test_a_gap_exactly_as_long_as_asked_is_listed() -> None:
    """'at least min_s' (review: a 1.0 s gap was left out with min_s=1.0); binary-exact times."""
    t = np.r_[np.arange(256) / 128.0, 255 / 128.0 + 1.0 + np.arange(128) / 128.0]
    assert [b - a for a, b in gaps(t, min_s=1.0)] == [1.0]
