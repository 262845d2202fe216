"""Scoring a session analysis against the simulator's true timeline (issue 11's "simulated unkind sessions" target).

Pure functions (no I/O) on plain arrays and lists, so that any estimator can be scored:

* :func:`activity_per_second` - the share of seconds whose estimated activity is the true one;
* :func:`posture_change_errors` - how far each true posture change point is from the nearest estimated one;
* :func:`segment_label_accuracy` - the share of true posture segments whose overlapping estimate has their label;
* :func:`segments_labelled_otherwise` - how many of them it gives another label (a wrong label, not a withheld one);
* :func:`cadence_errors` - each estimated bout's cadence against the true steps of its stretch, by the field's
  definition (Mobilise-D and the INDIP reference: the mean over strides of 120 / stride duration) or as steps
  over walking time.

Segments and bouts are ``(start_s, end_s, label)`` / ``(start_s, end_s, cadence_spm)`` tuples.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import pairwise

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "CadenceError",
    "activity_per_second",
    "cadence_errors",
    "change_points",
    "posture_change_errors",
    "segment_label_accuracy",
    "segments_labelled_otherwise",
    "true_posture_segments",
    "truth_cadence_between",
    "truth_stride_cadence_between",
]


def activity_per_second(
    truth_t: ArrayLike, truth_activity: Sequence[str], est_t: ArrayLike, est_activity: Sequence[str],
    step_s: float = 1.0,
) -> tuple[float, int]:
    """``(percent right, seconds scored)``: for every estimate row at time g (a 1 s timeline), the true activity
    is the majority over the truth samples in ``[g - step/2, g + step/2)``; rows with no truth sample are not
    scored. An estimate of ``unknown`` where the truth is known counts as wrong."""
    tt = np.asarray(truth_t, dtype=float)
    ta = np.asarray(list(truth_activity), dtype=object)
    right = scored = 0
    for g, act in zip(np.asarray(est_t, dtype=float), est_activity, strict=True):
        inside = (tt >= g - step_s / 2) & (tt < g + step_s / 2)
        if not inside.any():
            continue
        true = Counter(ta[inside]).most_common(1)[0][0]
        scored += 1
        right += int(true == act)
    return (100.0 * right / scored if scored else float("nan")), scored


def true_posture_segments(
    truth_t: ArrayLike, truth_label: Sequence[str], min_s: float = 0.0
) -> list[tuple[float, float, str]]:
    """Maximal runs of one non-empty label in a per-sample truth timeline, at least ``min_s`` long."""
    t = np.asarray(truth_t, dtype=float)
    labels = list(truth_label)
    out: list[tuple[float, float, str]] = []
    i = 0
    while i < len(labels):
        j = i
        while j + 1 < len(labels) and labels[j + 1] == labels[i]:
            j += 1
        if labels[i] and t[j] - t[i] >= min_s:
            out.append((float(t[i]), float(t[j]), labels[i]))
        i = j + 1
    return out


def change_points(segments: Sequence[tuple[float, float, str]], max_gap_s: float = 2.0) -> NDArray[np.float64]:
    """Posture change points: between consecutive segments (sorted by start) with different labels that are at
    most ``max_gap_s`` apart (a change across a pause or a long turn is not a change *during* a walk); the point
    is the middle of the gap."""
    segs = sorted(segments, key=lambda s: s[0])
    pts = [
        0.5 * (a[1] + b[0])
        for a, b in pairwise(segs)
        if a[2] != b[2] and b[0] - a[1] <= max_gap_s
    ]
    return np.array(pts, dtype=float)


def posture_change_errors(
    true_points: ArrayLike, est_points: ArrayLike, tolerance_s: float = 1.5
) -> tuple[NDArray[np.float64], int]:
    """``(error per true change point in s (inf where nothing was estimated), estimated points farther than
    tolerance_s from every true point)``."""
    tp = np.asarray(true_points, dtype=float)
    ep = np.asarray(est_points, dtype=float)
    if ep.size == 0:
        return np.full(tp.size, np.inf), 0
    err = np.array([np.min(np.abs(ep - p)) for p in tp], dtype=float)
    false = int(sum(tp.size == 0 or np.min(np.abs(tp - p)) > tolerance_s for p in ep))
    return err, false


def segment_label_accuracy(
    true_segments: Sequence[tuple[float, float, str]], est_segments: Sequence[tuple[float, float, str]]
) -> tuple[float, int]:
    """``(percent right, segments scored)``: a true segment is right when the estimated label covering most of
    its time is its own label (time covered by no estimate counts for no label)."""
    right = sum(int(_covering_label(a, b, est_segments) == label) for a, b, label in true_segments)
    n = len(true_segments)
    return (100.0 * right / n if n else float("nan")), n


def segments_labelled_otherwise(
    true_segments: Sequence[tuple[float, float, str]], est_segments: Sequence[tuple[float, float, str]],
    withheld: Sequence[str] = ("unclassified",),
) -> int:
    """How many true segments the estimate gives another posture label: the label covering most of the segment's
    time (more than the time no estimate covers) is a label, not one of ``withheld`` (no label given), and not
    the true one. A wrong label, where :func:`segment_label_accuracy` counts a withheld one as not right too."""
    return sum(int(_covering_label(a, b, est_segments) not in (label, "", *withheld)) for a, b, label in true_segments)


def _covering_label(a: float, b: float, est_segments: Sequence[tuple[float, float, str]]) -> str:
    """The estimated label covering most of ``[a, b]``, when it covers more than the time no estimate covers;
    else ``""``."""
    cover: dict[str, float] = {}
    for c, d, est in est_segments:
        overlap = min(b, d) - max(a, c)
        if overlap > 0:
            cover[est] = cover.get(est, 0.0) + overlap
    uncovered = (b - a) - sum(cover.values())
    best = max(cover.items(), key=lambda kv: kv[1]) if cover else ("", 0.0)
    return best[0] if best[1] > uncovered else ""


_TOLERANCE_S = 1e-9  # how far a float difference of times may pass a bound and still meet it
# the duration rule of Mobilise-D's stride selection (mobgap's IntervalDurationCriteria(min_duration_s=0.2,
# max_duration_s=3.0), over 0.2 s and up to 3.0 s): the strides a walking bout's cadence averages, whichever stretch
# of walking they join (its other rule, a stride length >= 0.15 m, the simulator's steps all pass)
MOBILISED_STRIDE_S = (0.2, 3.0)


def _spans(step_times_s: ArrayLike, step_bout: ArrayLike, start_s: float, end_s: float, k: int,
           *, within_s: tuple[float, float] | None = None) -> NDArray[np.float64]:
    """Durations from each true step in ``[start_s, end_s]`` to the one ``k`` steps later (1: steps, 2:
    strides): of the same true bout only, or (``within_s``: over the first, up to the second) any of that length,
    across true bouts too (``step_bout`` is then not used)."""
    t = np.asarray(step_times_s, dtype=float)
    bout = np.asarray(step_bout)
    inside = (t >= start_s) & (t <= end_s)
    t, bout = t[inside], bout[inside]
    if t.size <= k:
        return np.zeros(0)
    span = t[k:] - t[:-k]
    if within_s is not None:  # a float difference must not decide the bound (10.8 - 7.8 > 3.0)
        return span[(span > within_s[0] + _TOLERANCE_S) & (span <= within_s[1] + _TOLERANCE_S)]
    return span[bout[k:] == bout[:-k]]


def truth_cadence_between(
    step_times_s: ArrayLike, step_bout: ArrayLike, start_s: float, end_s: float
) -> tuple[float, int]:
    """``(cadence in steps/min, intervals)`` of the true steps in ``[start_s, end_s]``, from the intervals between
    consecutive steps of the same true bout only (an estimated bout spanning a pause is scored on the walking
    either side of it, not on the pause). nan when fewer than 2 steps."""
    dt = _spans(step_times_s, step_bout, start_s, end_s, 1)
    if dt.size == 0:
        return float("nan"), 0
    return 60.0 * dt.size / float(dt.sum()), int(dt.size)


def truth_stride_cadence_between(
    step_times_s: ArrayLike, step_bout: ArrayLike, start_s: float, end_s: float
) -> tuple[float, int]:
    """``(cadence in steps/min, strides)`` of the true steps in ``[start_s, end_s]`` by the field's definition:
    the mean over strides (a step and the one two later) of 120 / stride duration, every stride of 0.2-3.0 s
    counted (the duration rule of Mobilise-D's stride selection), so a stride across a short stop counts and
    one across a longer stop does not. This is how Mobilise-D defines a walking bout's cadence and how the INDIP
    reference reports it (its cadence equals the mean over the strides it selects, 2.4-2.7 s ones included in 6
    of its 9 bouts on the shared courses; its strides run from a foot's contact to that foot's next, which is
    the step two later wherever the feet alternate, as the simulator's do), and what walkmon reports. Until
    2026-11-27 only strides within one true bout counted (a stop of any length left out), which is not
    Mobilise-D's rule. It differs from steps over time (:func:`truth_cadence_between`) where the
    cadence changes within a bout: half 110 and half 80 steps/min gives 95 here and 92.6 there. nan with no
    whole stride."""
    stride = _spans(step_times_s, step_bout, start_s, end_s, 2, within_s=MOBILISED_STRIDE_S)
    if stride.size == 0:
        return float("nan"), 0
    return float(np.mean(120.0 / stride)), int(stride.size)


@dataclass(frozen=True, slots=True)
class CadenceError:
    """One estimated bout scored against the truth."""

    start_s: float
    end_s: float
    est_cadence_spm: float
    true_cadence_spm: float
    error_pct: float
    n_true_steps: int


def _edge_step(t: NDArray[np.float64], x: float) -> float:
    """The true step nearest ``x`` when ``x`` lies within half a step of it (the step an estimated edge step
    times), else ``x`` itself (an edge before the first or after the last true step)."""
    if t.size == 0:
        return x
    i = int(np.argmin(np.abs(t - x)))
    gaps = [abs(float(t[j] - t[i])) for j in (i - 1, i + 1) if 0 <= j < t.size]
    return float(t[i]) if not gaps or abs(float(t[i]) - x) <= 0.5 * min(gaps) else x


def cadence_errors(
    est_bouts: Sequence[tuple[float, float, float]], step_times_s: ArrayLike, step_bout: ArrayLike,
    min_steps: int = 4, *, definition: str = "stride", match_edges: bool = True,
) -> list[CadenceError]:
    """Every estimated bout with at least ``min_steps`` true steps of its own, with its cadence error in percent
    (estimate / truth - 1). A bout starts and ends at detected steps; its true steps run from the true step its
    first detected step times (the nearest, within half a step) to the one its last times. Taking only the
    true steps strictly inside ``[start_s, end_s]`` (``match_edges=False``), a first step detected 20 ms after
    the true one dropped that true step, and the slow first stride of gait initiation with it, from the truth;
    and the video's steps (pitch maxima) lie a bout-specific phase of up to a quarter of a step off the
    contacts, so no fixed tolerance fits them. ``definition`` is ``"stride"``
    (:func:`truth_stride_cadence_between`, the field's definition and walkmon's) or ``"steps"``
    (:func:`truth_cadence_between`, steps over walking time)."""
    if definition not in ("stride", "steps"):
        msg = f"definition must be 'stride' or 'steps', not {definition!r}"
        raise ValueError(msg)
    t = np.asarray(step_times_s, dtype=float)
    out = []
    for a, b, cad in est_bouts:
        lo, hi = (_edge_step(t, a) - 1e-9, _edge_step(t, b) + 1e-9) if match_edges else (a, b)
        n_steps = int(np.sum((t >= lo) & (t <= hi)))
        _, n = truth_cadence_between(t, step_bout, lo, hi)
        if n + 1 < min_steps:
            continue
        if definition == "stride":
            true, _ = truth_stride_cadence_between(t, step_bout, lo, hi)
        else:
            true, _ = truth_cadence_between(t, step_bout, lo, hi)
        if not np.isfinite(true):
            continue
        err = 100.0 * (cad / true - 1.0) if cad is not None and np.isfinite(cad) else float("inf")
        out.append(CadenceError(float(a), float(b), float(cad) if cad is not None else float("nan"), true, err,
                                n_steps))
    return out
