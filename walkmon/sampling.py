"""Sample times of a recording: its sampling rate and its gaps (samples dropped, the logger paused).

A recording's rate is not ``(n - 1) / duration``. A minute without samples in a 100 Hz recording of 160 s read 62
Hz that way, and VQF, a fixed-rate filter, then integrated every gyroscope sample over 16 ms instead of 10: the
start-relative angles of the whole recording wrong, before the gap as after it (a Mobilise-D course with 60 s cut
out: yaw 4.7 instead of 141.7 deg ten seconds in). Here the rate is one over the mean interval without the gaps,
and a gap is an interval longer than :data:`GAP_FACTOR` x the mean of the intervals up to their 99th percentile.

The mean, not the median: a logger that stamps samples as they arrive in bursts (1, 1, 28 ms) samples at 100 Hz,
not 1000, and its 28 ms intervals are no gaps. The 99th percentile keeps the yardstick off the gaps themselves,
which may be long enough to dominate a mean of all intervals (a clock that jumps a day), as long as they are
fewer than 1 % of the intervals: a logger that pauses after every few samples (10 samples at 100 Hz, then 1 s)
has its pauses in its rate (9 Hz) and no gaps.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["GAP_FACTOR", "gap_threshold_s", "gaps", "longest_usual_interval_s", "sampling_rate_hz"]

#: An interval longer than this x the recording's usual interval is a gap.
GAP_FACTOR = 10.0


def _intervals(t_s: ArrayLike) -> NDArray[np.float64]:
    t = np.asarray(t_s, dtype=float).reshape(-1)
    d = np.diff(t)
    return d[np.isfinite(d) & (d > 0)]


def _threshold(d: NDArray[np.float64]) -> float:
    """:func:`gap_threshold_s` of the intervals ``d`` (computed once by each public function)."""
    if d.size < 2:
        return float("inf")
    return GAP_FACTOR * float(np.mean(d[d <= np.quantile(d, 0.99)]))


def longest_usual_interval_s(t_s: ArrayLike) -> float:
    """The 99th percentile of the intervals between samples (s; inf with fewer than two intervals): the longest
    a recording usually leaves between two samples, a bursty logger's pauses included, its gaps not."""
    d = _intervals(t_s)
    return float(np.quantile(d, 0.99)) if d.size >= 2 else float("inf")


def gap_threshold_s(t_s: ArrayLike) -> float:
    """The shortest interval between two samples that is a gap (s): over :data:`GAP_FACTOR` x the mean of the
    intervals up to :func:`longest_usual_interval_s`; inf with fewer than two intervals."""
    return _threshold(_intervals(t_s))


def sampling_rate_hz(t_s: ArrayLike) -> float:
    """Samples per second while the recording records: one over its mean interval, gaps left out (0 with
    fewer than two samples)."""
    d = _intervals(t_s)
    if d.size == 0:
        return 0.0
    kept = d[d <= _threshold(d)]
    return 1.0 / float(np.mean(kept if kept.size else d))


def gaps(t_s: ArrayLike, min_s: float = 0.0) -> list[tuple[float, float]]:
    """``(last sample before, first sample after)`` of every gap (:func:`gap_threshold_s`) at least ``min_s``
    long, in time order."""
    t = np.asarray(t_s, dtype=float).reshape(-1)
    if t.size < 3:
        return []
    d = np.diff(t)
    return [(float(t[i]), float(t[i + 1])) for i in np.flatnonzero((d > _threshold(_intervals(t))) & (d >= min_s))]
