"""The unkind-session scores on synthetic inputs whose right answers are worked out by hand."""

from __future__ import annotations

import numpy as np
import pytest

from walkmon.simulate.scoring import (
    activity_per_second,
    cadence_errors,
    change_points,
    posture_change_errors,
    segment_label_accuracy,
    true_posture_segments,
    truth_cadence_between,
    truth_stride_cadence_between,
)

FPS = 10.0


def _truth(pieces: list[tuple[float, str, str]]) -> tuple[np.ndarray, list[str], list[str]]:
    """Per-sample truth at FPS from (duration, activity, label) pieces."""
    t, act, lab = [], [], []
    t0 = 0.0
    for dur, a, label in pieces:
        n = round(dur * FPS)
        t += list(t0 + np.arange(n) / FPS)
        act += [a] * n
        lab += [label] * n
        t0 += dur
    return np.array(t), act, lab


def test_activity_per_second() -> None:
    t, act, _ = _truth([(3, "standing", ""), (5, "walking", "normal"), (2, "turning", "")])
    grid = np.arange(10) + 0.5  # rows at 0.5, 1.5, ...: each window holds one activity
    est = ["standing"] * 3 + ["walking"] * 5 + ["turning"] * 2
    assert activity_per_second(t, act, grid, est) == (100.0, 10)
    est_late = ["standing"] * 4 + ["walking"] * 4 + ["walking", "unknown"]
    pct, n = activity_per_second(t, act, grid, est_late)
    assert n == 10 and pct == pytest.approx(70.0)  # rows 3.5, 8.5 and 9.5 wrong
    # a window split half and half: the earlier activity is the truth
    assert activity_per_second(t, act, [3.0], ["standing"]) == (100.0, 1)
    # rows beyond the truth are not scored
    assert activity_per_second(t, act, [20.0], ["walking"])[1] == 0


def test_true_posture_segments_and_change_points() -> None:
    t, _, lab = _truth([(2, "standing", ""), (6, "walking", "normal"), (6, "walking", "bend"),
                        (2, "turning", ""), (1, "walking", "bend"), (3, "standing", "")])
    segs = true_posture_segments(t, lab)
    assert [(round(a, 1), round(b, 1), s) for a, b, s in segs] == [(2.0, 7.9, "normal"), (8.0, 13.9, "bend"),
                                                                   (16.0, 16.9, "bend")]
    assert len(true_posture_segments(t, lab, min_s=4.0)) == 2
    assert change_points(segs) == pytest.approx([7.95])  # the bend after the turn is no change
    far = [(0.0, 5.0, "normal"), (8.0, 12.0, "bend")]
    assert change_points(far).size == 0  # 3 s apart: across a pause, not during a walk
    assert change_points(far, max_gap_s=3.0) == pytest.approx([6.5])


def test_posture_change_errors() -> None:
    err, false = posture_change_errors([10.0, 30.0], [10.8, 29.0, 50.0])
    assert err == pytest.approx([0.8, 1.0])
    assert false == 1
    err, false = posture_change_errors([10.0], [])
    assert np.isinf(err).all() and false == 0
    assert posture_change_errors([], [5.0])[1] == 1


def test_segment_label_accuracy() -> None:
    truth = [(0.0, 10.0, "normal"), (10.0, 20.0, "bend"), (25.0, 30.0, "bend")]
    est = [(0.0, 11.0, "normal"), (11.0, 20.0, "bend"), (24.0, 27.0, "normal"), (27.0, 31.0, "bend")]
    assert segment_label_accuracy(truth, est) == (pytest.approx(100.0), 3)
    est_wrong = [(0.0, 20.0, "normal"), (26.0, 27.0, "bend")]
    # the bend segment is mostly covered by "normal"; the last one has 1 s of 5 covered: not enough
    assert segment_label_accuracy(truth, est_wrong) == (pytest.approx(100.0 / 3), 3)
    assert np.isnan(segment_label_accuracy([], est)[0])


def test_segments_labelled_otherwise_counts_wrong_labels_not_withheld_ones() -> None:
    from walkmon.simulate.scoring import segments_labelled_otherwise

    truth = [(0.0, 10.0, "normal"), (10.0, 20.0, "bend"), (25.0, 30.0, "bend"), (30.0, 40.0, "normal")]
    est = [(0.0, 10.0, "normal"), (10.0, 20.0, "left_shoulder_down"), (25.0, 30.0, "unclassified"),
           (30.0, 32.0, "bend")]  # the last covers 2 s of 10: not the segment's label
    assert segments_labelled_otherwise(truth, est) == 1
    assert segments_labelled_otherwise(truth, []) == 0


def test_truth_cadence_skips_pauses_and_cadence_errors() -> None:
    steps = np.r_[np.arange(10) * 0.5 + 1.0, np.arange(8) * 0.6 + 10.0]  # 120 spm, pause, 100 spm
    bout = np.r_[np.zeros(10, int), np.ones(8, int)]
    assert truth_cadence_between(steps, bout, 0.0, 6.0) == (pytest.approx(120.0), 9)
    # across the pause: 9 intervals of 0.5 s and 7 of 0.6 s, the 5.5 s pause left out
    cad, n = truth_cadence_between(steps, bout, 0.0, 20.0)
    assert n == 16 and cad == pytest.approx(60.0 * 16 / (9 * 0.5 + 7 * 0.6))
    assert np.isnan(truth_cadence_between(steps, bout, 7.0, 9.0)[0])
    errs = cadence_errors([(1.0, 5.5, 121.2), (10.0, 14.2, 99.0), (7.0, 9.0, 100.0), (10.0, 11.0, 100.0)],
                          steps, bout)
    assert [round(e.error_pct, 3) for e in errs] == [1.0, -1.0]  # the last two have < 4 true steps
    assert errs[0].n_true_steps == 10 and errs[1].true_cadence_spm == pytest.approx(100.0)


def test_stride_cadence_is_the_mean_over_strides_not_steps_over_time() -> None:
    # 8 steps at 110 spm then 8 at 80 spm in one true bout: the field's definition (INDIP, Mobilise-D) averages
    # 120 / stride over the 14 strides; steps over time divides 15 intervals by their total duration.
    d = np.r_[np.full(8, 60.0 / 110.0), np.full(7, 60.0 / 80.0)]
    steps = np.r_[0.0, np.cumsum(d)] + 2.0
    bout = np.zeros(steps.size, int)
    strides = steps[2:] - steps[:-2]
    by_hand = sum(120.0 / s for s in strides) / strides.size
    cad, n = truth_stride_cadence_between(steps, bout, 0.0, 30.0)
    assert n == 14 and cad == pytest.approx(by_hand)
    steps_over_time = 60.0 * 15 / (steps[-1] - steps[0])
    assert by_hand - steps_over_time > 1.0  # the two definitions really differ here
    err_stride = cadence_errors([(steps[0], steps[-1], by_hand)], steps, bout)
    err_steps = cadence_errors([(steps[0], steps[-1], by_hand)], steps, bout, definition="steps")
    assert abs(err_stride[0].error_pct) < 1e-9 and err_steps[0].error_pct > 1.0
    # Mobilise-D's stride selection (0.2-3.0 s), not the true bouts, decides what a stride is: the strides
    # across a stop of 1.2 s (2.0 and 2.1 s) count, as INDIP counts its 2.4-2.7 s ones; across 3 s they do not
    bout2 = np.r_[np.zeros(8, int), np.ones(8, int)]
    assert truth_stride_cadence_between(steps, bout2, 0.0, 30.0)[1] == 14
    for stop_s, n in ((1.2, 14), (3.0, 12)):
        stopped = np.r_[steps[:8], steps[8:] + stop_s]
        strides = stopped[2:] - stopped[:-2]
        cad, got = truth_stride_cadence_between(stopped, bout2, 0.0, 40.0)
        assert got == n and cad == pytest.approx(float(np.mean(120.0 / strides[strides <= 3.0])))
    with pytest.raises(ValueError, match="definition"):
        cadence_errors([(0.0, 1.0, 100.0)], steps, bout, definition="median")


def test_cadence_errors_match_the_bout_edges_to_the_true_steps_they_time() -> None:
    # gait initiation: a slow first stride; the estimate detects the first step 20 ms late and starts there
    d = np.r_[0.8, 0.7, np.full(12, 0.5)]
    steps = np.r_[0.0, np.cumsum(d)] + 1.0
    bout = np.zeros(steps.size, int)
    strides = steps[2:] - steps[:-2]
    whole = float(np.mean(120.0 / strides))
    err = cadence_errors([(steps[0] + 0.02, steps[-1], whole)], steps, bout)
    assert err[0].n_true_steps == steps.size and abs(err[0].error_pct) < 1e-9
    # strictly inside the bout's ends the first true step falls out and the truth reads faster than the walk
    strict = cadence_errors([(steps[0] + 0.02, steps[-1], whole)], steps, bout, match_edges=False)
    assert strict[0].error_pct < -1.0
    # a step the estimate missed altogether (0.8 s before its first detected step) stays outside
    late = cadence_errors([(steps[1] + 0.02, steps[-1], whole)], steps, bout)
    assert late[0].n_true_steps == steps.size - 1
    # video: every detected step a phase of 0.2 s (0.4 step) after its contact; the true steps are still the
    # bout's own, one for one
    err = cadence_errors([(steps[2] + 0.2, steps[-3] + 0.2, 120.0)], steps, bout)
    assert err[0].n_true_steps == steps.size - 4
    assert err[0].true_cadence_spm == pytest.approx(float(np.mean(120.0 / strides[2:-2])))
