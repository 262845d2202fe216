"""Activity segmentation, steps, bouts and turns (walkmon.gait.activity) against synthetic and real truth."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from walkmon.errors import InvalidInputError
from walkmon.gait.activity import (
    bouts_from_steps,
    cadence_from_steps,
    corrected_step_times,
    segment,
    signals_from_angles,
    signals_from_imu,
)

DATA = Path(__file__).resolve().parents[3] / "shared" / "data"
if not DATA.is_dir():
    DATA = Path("/work/shared/data")


def _matched(found: np.ndarray, truth: np.ndarray, tol: float) -> int:
    return int(sum(np.min(np.abs(found - s)) <= tol for s in truth)) if found.size else 0


def test_walk_without_standing_start_with_pause_and_turns(synthetic_imu) -> None:
    """Starts mid-walk, a 2 s pause (joins the bout), a 180 deg and a 90 deg turn, a 5 s stop (splits bouts)."""
    imu = synthetic_imu([("walk", 8), ("turn", 2.5), ("walk", 5), ("stand", 2), ("walk", 6), ("stand", 5),
                         ("walk", 4), ("turn", 2), ("walk", 6), ("stand", 3)], seed=1)
    seg = segment(signals_from_imu(imu.t, imu.acc, imu.gyr))
    assert len(seg.bouts) == 2  # the 2 s pause joins, the 5 s stop splits (Mobilise-D: breaks < 3 s join)
    # steps: nearly all true steps found, at a constant small delay at most (one step per step)
    assert _matched(seg.steps_s, imu.steps, 0.12) >= 0.95 * imu.steps.size
    assert abs(seg.steps_s.size - imu.steps.size) <= 3
    for b, (s, e) in zip(seg.bouts, [(imu.bouts[0][0], imu.bouts[1][1]), imu.bouts[2]], strict=True):
        assert b.start_s == pytest.approx(s, abs=0.6) and b.end_s == pytest.approx(e, abs=0.6)
        assert b.spectral_cadence_spm == pytest.approx(60 / 0.55, rel=0.03)
    assert seg.bouts[1].cadence_spm == pytest.approx(60 / 0.55, rel=0.01)
    assert [round(u.angle_deg / 10) * 10 for u in seg.turns] == [180, 180]
    for u, (s, e, _) in zip(seg.turns, imu.turns, strict=True):
        assert u.start_s == pytest.approx(s, abs=0.6) and u.end_s == pytest.approx(e, abs=0.6)
    act = seg.activity_at(np.array([5.0, 9.2, 13.0, 27.5, 33.5]))
    assert act.tolist() == ["walking", "turning", "walking", "standing", "turning"]


@pytest.mark.parametrize(("walk", "seed"), [("right_foot_drag", 1), ("bend", 3), ("normal", 1)])
def test_no_step_is_found_while_the_wearer_stands_in_a_pause(walk: str, seed: int) -> None:
    """The simulator's unkind sessions (IMU only): where the wearer stands still in a pause, half a second or more
    from its ends, no step is found. Each of these three sessions had one there (mid-pause, 1-2 s from the steps
    about it): the band-pass about the step frequency rang over the quiet trunk, and the stride of 2-3 s the
    'step' made counted in the bout's cadence (a bout 1.9 % slow)."""
    from walkmon.simulate.gait import GaitModel
    from walkmon.simulate.imu import simulate_imu
    from walkmon.simulate.unkind import unkind_script

    model = GaitModel(unkind_script(seed, walk), seed=seed, stand_s=0.0)
    imu = simulate_imu(model)
    found = segment(signals_from_imu(imu.t_s, imu.accelerometer_mps2, imu.gyroscope_rps)).steps_s
    still = [(p.start_s + 0.5, p.end_s - 0.5) for p in model.pieces if p.activity == "standing"]
    assert [float(t) for t in found if any(a <= t <= b for a, b in still)] == []


@pytest.mark.parametrize(("walk", "seed"), [("normal", 6), ("left_shoulder_down", 9), ("bend", 9)])
def test_the_wearer_standing_still_beside_sitting_or_handling_is_standing(walk: str, seed: int) -> None:
    """The simulator's unkind sessions, from the IMU, its accelerometer alone and the trunk's true angles (what a
    camera would measure): where the wearer stands still just before or after sitting down, picking something up
    or handling the camera (half a second or more from the standing's ends), the timeline says ``standing`` at
    least 90 % of the time. Before the raw spread counted, 62-83 % of it did from one input or more in each of
    these sessions: the step signal and its band-pass rang on after the movement over a trunk already still."""
    from walkmon.simulate.gait import GaitModel
    from walkmon.simulate.imu import simulate_imu
    from walkmon.simulate.unkind import unkind_script

    model = GaitModel(unkind_script(seed, walk), seed=seed, stand_s=0.0)
    pieces = model.pieces
    beside = [b if a.activity == "unknown" else a for a, b in zip(pieces[:-1], pieces[1:], strict=True)
              if {a.activity, b.activity} == {"unknown", "standing"}]
    t = np.concatenate([np.arange(p.start_s + 0.5, p.end_s - 0.5, 0.02) for p in beside])
    assert t.size >= 20
    imu = simulate_imu(model)
    tt = np.arange(0.0, model.duration_s, 1 / 30)
    for sig in (signals_from_imu(imu.t_s, imu.accelerometer_mps2, imu.gyroscope_rps),
                signals_from_imu(imu.t_s, imu.accelerometer_mps2),
                signals_from_angles(tt, model.truth_angles_deg(tt))):
        act = segment(sig).activity_at(t)
        assert np.mean(act == "standing") >= 0.9, (sig.kind, [(float(a), str(b)) for a, b in zip(t, act, strict=True)])


@pytest.mark.xfail(strict=True, reason=(
    "not met: -2.9 %. The band-pass rings after the last step before the 2 s stop and before the first after it, "
    "and each swing was taken for a 'step' (0.37 x a step's amplitude): the stop's 2.65 s interval read 0.44 + "
    "1.74 + 0.48 s (-2.1 %). The ringing rule (2026-11-28) drops the later one, where the acceleration hardly moves "
    "(0.07 of its neighbours' span), but not the earlier, 0.44 s after the last step, whose window still holds the "
    "end of that step's bounce (0.29): 0.44 + 2.22 s, whose strides of 2.7-2.8 s count by Mobilise-D's rule "
    "(0.2-3.0 s) where the truth's of 3.2 s do not. Until 2026-11-27 strides beyond 1.3 x the local median were "
    "dropped, which hid this and also dropped real slow strides that INDIP counts"))
def test_cadence_of_a_bout_with_a_stop_is_the_fields(synthetic_imu) -> None:
    """The bout that joins walking, a 180 deg turn and a 2 s stop (the first of
    :func:`test_walk_without_standing_start_with_pause_and_turns`) has the field's cadence of its true steps:
    the strides over the stop (3.2 s) are no strides, the rest count."""
    imu = synthetic_imu([("walk", 8), ("turn", 2.5), ("walk", 5), ("stand", 2), ("walk", 6), ("stand", 5),
                         ("walk", 4), ("turn", 2), ("walk", 6), ("stand", 3)], seed=1)
    b = segment(signals_from_imu(imu.t, imu.acc, imu.gyr)).bouts[0]
    true = imu.steps[(imu.steps >= imu.bouts[0][0]) & (imu.steps <= imu.bouts[1][1])]
    assert b.cadence_spm == pytest.approx(_mobilised_cadence(true), rel=0.01)


def test_turn_angles_follow_the_yaw_convention_from_imu_and_from_angles() -> None:
    """A simulated wearer turns right then left (``turn:+DEG`` > 0 right, as yaw > 0 turns right): the turns found
    from the IMU's gyro (about gravity's axis, sensor axes) and from the camera's angles carry the same signs."""
    from walkmon.simulate.gait import GaitModel
    from walkmon.simulate.imu import simulate_imu

    m = GaitModel("stand:2,normal:4,turn:90,normal:4,turn:-180,normal:4,stand:2", seed=4)
    imu = simulate_imu(m)
    t = np.arange(0.0, m.duration_s, 1 / 30)
    for sig in (signals_from_imu(imu.t_s, imu.accelerometer_mps2, imu.gyroscope_rps),
                signals_from_angles(t, m.truth_angles_deg(t))):
        turns = [u.angle_deg for u in segment(sig).turns]
        assert len(turns) == 2, (sig.kind, turns)
        assert turns[0] == pytest.approx(90.0, abs=20.0) and turns[1] == pytest.approx(-180.0, abs=25.0), sig.kind


def test_asymmetric_and_slow_gait_cadence(synthetic_imu) -> None:
    # alternating 0.5 / 0.7 s steps (a limp): 100 steps/min; and a slow walker at 72 steps/min
    imu = synthetic_imu([("stand", 2), ("walk", 20), ("stand", 2)], step_s=(0.5, 0.7), seed=2)
    (b,) = segment(signals_from_imu(imu.t, imu.acc, imu.gyr)).bouts
    assert b.cadence_spm == pytest.approx(100.0, rel=0.01)
    assert abs(b.n_steps - imu.steps.size) <= 2
    imu = synthetic_imu([("walk", 25)], step_s=60 / 72, seed=3)
    (b,) = segment(signals_from_imu(imu.t, imu.acc, None)).bouts  # accelerometer only
    assert b.cadence_spm == pytest.approx(72.0, rel=0.01)


def test_accelerometer_only_has_no_turns_and_says_so(synthetic_imu) -> None:
    imu = synthetic_imu([("walk", 6), ("turn", 2), ("walk", 6)], up=(0.6, -0.8, 0.0))  # tilted mounting
    seg = segment(signals_from_imu(imu.t, imu.acc, None))
    assert seg.turns == () and any("no heading" in n for n in seg.notes)
    assert len(seg.bouts) == 1 and seg.source == "acc"


def test_standing_still_and_short_shuffles_are_not_bouts(synthetic_imu) -> None:
    imu = synthetic_imu([("stand", 6), ("walk", 1.0), ("stand", 6)], seed=4)  # two steps: not a bout
    seg = segment(signals_from_imu(imu.t, imu.acc, imu.gyr))
    assert seg.bouts == ()
    assert seg.activity_at(np.array([2.0, 10.0])).tolist() == ["standing", "standing"]


def _true_cadence(steps: np.ndarray) -> float:
    """Mobilise-D's cadence of a step list: the mean over strides of 120 / stride duration."""
    return float(np.mean(120.0 / (steps[2:] - steps[:-2])))


def _mobilised_cadence(steps: np.ndarray) -> float:
    """The same over the strides Mobilise-D's stride selection keeps (0.2-3.0 s; INDIP's bouts hold strides
    of up to 2.4-2.7 s on the shared courses)."""
    stride = steps[2:] - steps[:-2]
    return float(np.mean(120.0 / stride[(stride >= 0.2) & (stride <= 3.0)]))


@pytest.mark.parametrize("pause_s", [1.5, 2.8])
def test_bout_rules_and_cadence_over_a_pause(pause_s: float) -> None:
    """A stop shorter than 3 s joins the bout; the strides over it count when they are strides by Mobilise-D's
    rule (0.2-3.0 s: over a 1.5 s stop, 2.0 s), not beyond (over 2.8 s, 3.3 s). Until 2026-11-27 any stride
    beyond 1.3 x the median about it was left out, which also left out a turning bout's slow strides that
    INDIP counts."""
    steps = np.r_[np.arange(10) * 0.5, 4.5 + pause_s + np.arange(10) * 0.5, 20 + np.arange(3) * 0.5]
    bouts = bouts_from_steps(steps)
    assert [(b.start_s, b.n_steps) for b in bouts] == [(0.0, 20)]  # pause joined; 3 steps: no bout
    # 16 strides of 1.0 s and, over a 1.5 s stop, two of 2.0 s: (16 x 120 + 2 x 60) / 18; over 2.8 s, none
    assert cadence_from_steps(steps[:20]) == pytest.approx(2040.0 / 18.0 if pause_s < 2.0 else 120.0)


@pytest.mark.parametrize(("gap_s", "kept"), [(2.0, True), (2.8, False)])
def test_a_lone_step_after_a_stop_is_in_the_bout_only_within_a_stride(gap_s: float, kept: bool) -> None:
    """Mobilise-D assembles bouts from strides (a contact to the next but one, at most 3 s): a lone step 2.8 s
    after a bout's last (a shuffle or weight shift after stopping; MS/001's course, 2.8 s after the last of an
    INDIP bout) starts or ends no stride (3.3 s from the step two before), so the bout ends at the last step
    before the stop; 2.0 s after, the stride is 2.5 s and the step belongs to it. The same at the start. Until
    2026-11-27 the step rule (breaks < 3 s join) took both into the bout."""
    walk = 10.0 + np.arange(10) * 0.5
    (bout,) = bouts_from_steps(np.r_[walk, walk[-1] + gap_s])
    assert bout.end_s == pytest.approx(walk[-1] + gap_s if kept else walk[-1])
    (bout,) = bouts_from_steps(np.r_[walk[0] - gap_s, walk])
    assert bout.start_s == pytest.approx(walk[0] - gap_s if kept else walk[0])


def test_a_closing_half_step_before_a_lone_step_is_still_gait_termination() -> None:
    """A closing half step 0.2 s after the last step is gait termination (dropped); a lone step 2.9 s after it
    starts or ends no stride (3.1 s from the step two before) and is dropped too, and then the half step must be
    judged again (review: it stayed, and the cadence read 125.7 for 120 steps/min)."""
    walk = 10.0 + np.arange(10) * 0.5
    (bout,) = bouts_from_steps(np.r_[walk, walk[-1] + 0.2, walk[-1] + 0.2 + 2.9])
    assert bout.end_s == pytest.approx(walk[-1])
    assert bout.cadence_spm == pytest.approx(120.0)


def test_weak_edge_steps_are_trimmed_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """Weak leading steps (a weight shift) are dropped against the bout's median step amplitude, once: a second
    pass against the median of what is left dropped more of a real start (review of the stride-edge loop: a
    16-step bout started 0.5 s late)."""
    from walkmon.gait import activity
    from walkmon.gait.activity import DEFAULT_ACTIVITY_SETTINGS

    t = np.arange(0.0, 30.0, 0.01)
    sig = signals_from_imu(t, np.tile([0.0, 0.0, 9.81], (t.size, 1)), np.zeros((t.size, 3)))
    steps = 10.0 + np.arange(16) * 0.5
    amps = np.r_[np.linspace(0.05, 0.6, 8), np.ones(8)]
    monkeypatch.setattr(activity, "_step_amplitudes", lambda st, sig, s: amps[: st.size])
    (bout,) = bouts_from_steps(steps, sig)
    limit = DEFAULT_ACTIVITY_SETTINGS.weak_step_fraction * float(np.median(amps))
    assert bout.start_s == pytest.approx(steps[np.argmax(amps >= limit)])


def test_cadence_mends_missed_and_extra_steps() -> None:
    """A heel strike lost in a turn (an interval twice its neighbours, even two in a row) or a double peak
    (two short intervals summing to one) must not move the cadence off the true steps' cadence."""
    rng = np.random.default_rng(3)
    truth = np.cumsum(0.8 + rng.normal(0.0, 0.03, 24))
    found = np.delete(truth, [5, 12, 13, 17])  # one missed step, two in a row (a turn), another one
    found = np.sort(np.r_[found, truth[8] + 0.35])  # and one extra peak
    want = _true_cadence(truth)
    assert cadence_from_steps(found) == pytest.approx(want, rel=0.01)
    assert cadence_from_steps(truth) == pytest.approx(want, rel=0.005)  # regular steps: nothing to mend


def test_a_short_stop_inside_a_bout_is_a_pause_not_a_missed_step() -> None:
    """Three 4 s walks at 100 steps/min split by 0.7 s stops: each stop's interval (about 2.2 steps) used to be
    mended as a missed heel strike, and the bout read 101.7 steps/min, above its steady pace, where the mean over
    strides (the field's definition, stops under 3 s counted) is 93.8. A missed step among steps stays mended."""
    fs, f = 100.0, 100.0 / 60.0
    parts = [(False, 5.0), (True, 4.0), (False, 0.7), (True, 4.0), (False, 0.7), (True, 4.0), (False, 5.0)]
    t = np.arange(0.0, sum(d for _, d in parts), 1.0 / fs)
    dyn, steps, t0 = np.zeros_like(t), [], 0.0
    for walking, d in parts:
        m = (t >= t0) & (t < t0 + d)
        if walking:
            x = t[m] - t0
            dyn[m] = 2.0 * np.sin(2 * np.pi * f * x) + 0.4 * np.sin(np.pi * f * x)
            steps += [t0 + (i + 0.25) / f for i in range(20) if (i + 0.25) / f < d]
        t0 += d
    rng = np.random.default_rng(0)
    acc = np.column_stack([0.05 * rng.standard_normal(t.size), -9.81 - dyn + 0.05 * rng.standard_normal(t.size),
                           0.05 * rng.standard_normal(t.size)])
    gyr = 0.002 * rng.standard_normal((t.size, 3))
    seg = segment(signals_from_imu(t, acc, gyr))
    (bout,) = seg.bouts
    assert bout.n_steps == len(steps)
    assert bout.cadence_spm == pytest.approx(_true_cadence(np.array(steps)), rel=0.01)


def test_no_stride_across_a_hole_in_the_samples_counts_in_the_cadence() -> None:
    """A 0.95 s dropout mid-walk (under the 1 s that splits bouts): the resampled line across it hid two steps, the
    stride over them counted as one slow stride and the bout read 2 % slow (user review). Strides across such a
    hole are left out; the walk's steady 100 steps/min is what the bout reads."""
    fs, f = 100.0, 100.0 / 60.0
    t = np.arange(0.0, 20.0, 1.0 / fs)
    walking = (t >= 3.0) & (t < 17.0)
    x = t - 3.0
    dyn = np.where(walking, 2.0 * np.sin(2 * np.pi * f * x) + 0.4 * np.sin(np.pi * f * x), 0.0)
    rng = np.random.default_rng(1)
    acc = np.column_stack([0.05 * rng.standard_normal(t.size), -9.81 - dyn + 0.05 * rng.standard_normal(t.size),
                           0.05 * rng.standard_normal(t.size)])
    gyr = 0.002 * rng.standard_normal((t.size, 3))
    keep = (t < 9.3) | (t >= 10.25)  # two steps' peaks inside: the interval across, 2.6 steps, is no missed step
    seg = segment(signals_from_imu(t[keep], acc[keep], gyr[keep]))
    (bout,) = seg.bouts
    assert bout.start_s < 9.3 < 10.25 < bout.end_s  # one bout across the hole (shorter than a gap)
    assert bout.cadence_spm == pytest.approx(100.0, rel=0.005)
    # holes between the steps of the rhythm hide none: a Bluetooth IMU losing 0.27 s every 1-1.2 s (review: every
    # run of steps between them too short, no cadence at all)
    for period in (1.0, 1.2, 2.0):
        keep = (t % period) <= period - 0.27
        (bout,) = segment(signals_from_imu(t[keep], acc[keep], gyr[keep])).bouts
        assert bout.cadence_spm == pytest.approx(100.0, rel=0.01), period
    # holes that hide steps so often that no 3 steps lie between two: no cadence, not one read from the strides
    # across them (review: 66-68 steps/min for this 100)
    keep = (t % 2.0) <= 2.0 - 0.8
    bouts = segment(signals_from_imu(t[keep], acc[keep], gyr[keep])).bouts
    assert all(not np.isfinite(b.cadence_spm) or b.cadence_spm == pytest.approx(100.0, rel=0.02) for b in bouts)


def test_a_run_of_slow_steps_is_not_mended_an_isolated_long_one_is() -> None:
    """Slow steps in a turn (four of 1.0 s among steps of 0.55 s: 1.8 median steps each) are steps, as the
    reference counts them; mending them as missed steps read a real turning bout 55 % fast. One such interval
    alone among ordinary steps is a missed heel strike and counts as two."""
    d = np.r_[np.full(8, 0.55), np.full(4, 1.0), np.full(8, 0.55)]
    turn = np.r_[0.0, np.cumsum(d)]
    assert corrected_step_times(turn) == pytest.approx(d)
    one = np.r_[np.full(8, 0.55), 1.0, np.full(8, 0.55)]
    mended = corrected_step_times(np.r_[0.0, np.cumsum(one)])
    assert mended == pytest.approx(np.r_[np.full(8, 0.55), 0.5, 0.5, np.full(8, 0.55)])


def _standing_up_before_the_first_step() -> tuple[np.ndarray, np.ndarray]:
    """True steps, and what was found: two trunk movements of standing up before the first step (intervals of
    1.6 and 2.2 steps; a simulator bout)."""
    truth = 11.44 + np.cumsum(np.r_[0.0, np.tile([0.8, 0.94], 4)])
    return truth, np.r_[8.14, 9.52, truth]


def test_cadence_does_not_split_a_gait_initiation_gap() -> None:
    """The long gap after standing up is no missed step (its neighbour is no ordinary step): no step is
    invented there."""
    _, found = _standing_up_before_the_first_step()
    assert corrected_step_times(found) == pytest.approx(np.diff(found))


@pytest.mark.xfail(strict=True, reason=(
    "not met: -4.5 %. The movements of standing up are no steps, but the stride from the second to the first "
    "true step (2.72 s) is a stride by Mobilise-D's duration rule and now counts; until 2026-11-27 the pause "
    "rule (1.3 x the local median stride) dropped it, and with it the real slow strides INDIP counts. Bouts "
    "drop such movements only when they are weak (0.3 x a step) or quick (0.6 x a step)"))
def test_cadence_of_steps_found_after_standing_up_is_the_true_one() -> None:
    truth, found = _standing_up_before_the_first_step()
    assert cadence_from_steps(found) == pytest.approx(_true_cadence(truth), rel=0.02)


def test_cadence_of_a_bout_that_changes_pace_keeps_the_slow_strides() -> None:
    """A limp giving way to a normal walk within one bout (strides of 1.46 and 1.09 s): every stride is walking
    and counts, and so do the strides about two hesitations of 0.9 s a step apart (2.0 s): strides by
    Mobilise-D's rule (0.2-3.0 s); those over a 2 s stop (3.1 s) are not."""
    limp = np.cumsum(np.tile([0.66, 0.80], 5))
    normal = limp[-1] + np.cumsum(np.full(24, 0.545))
    truth = np.r_[0.0, limp, normal] + 3.0
    assert cadence_from_steps(truth) == pytest.approx(_true_cadence(truth), rel=0.005)
    paused = np.r_[truth, truth[-1] + 2.0 + np.cumsum(np.full(12, 0.545))]
    assert cadence_from_steps(paused) == pytest.approx(_mobilised_cadence(paused), rel=0.002)
    d = np.full(24, 0.55)
    d[[10, 12]] += 0.9  # two hesitations of 0.9 s
    hesitant = np.r_[0.0, np.cumsum(d)]
    assert cadence_from_steps(hesitant) == pytest.approx(_true_cadence(hesitant), rel=0.002)


@pytest.mark.parametrize("mend", [True, False])
def test_cadence_is_not_measured_from_events_further_apart_than_any_step(mend: bool) -> None:
    """Events 1.3 s apart (a stride of a 92 steps/min walk, every other step missed) are no steps: no cadence,
    not 46 steps/min; events 0.65 s apart give 92."""
    t = 2.0 + np.cumsum(np.full(20, 1.3))
    assert np.isnan(cadence_from_steps(t, mend=mend))
    assert cadence_from_steps(2.0 + np.cumsum(np.full(20, 0.65)), mend=mend) == pytest.approx(120 / 1.3)


def test_video_cadence_leaves_out_strides_off_the_rhythm() -> None:
    """Camera angles (``mend=False``): where the pitch waveform changes phase a maximum goes missing (an
    interval of 1.5 steps) or a run of them does (every other step, for 3 s): those strides are left out, not
    mended, and not taken for the rhythm."""
    rng = np.random.default_rng(5)
    truth = 2.0 + np.cumsum(0.6 + rng.normal(0.0, 0.01, 40))
    want = _true_cadence(truth)
    assert cadence_from_steps(truth, mend=False) == pytest.approx(want, rel=0.005)
    phase = np.r_[truth[:15], truth[16:] - 0.3]  # one maximum lost, the rest half a step late
    assert cadence_from_steps(phase, mend=False) == pytest.approx(want, rel=0.003)
    run = np.delete(truth, [21, 23, 25, 27, 29])  # five maxima of one foot missing in a row
    assert cadence_from_steps(run, mend=False) == pytest.approx(want, rel=0.01)
    assert cadence_from_steps(np.r_[truth[:20], np.full(8, np.nan), truth[20:]], mend=False) == pytest.approx(
        want, rel=0.005)  # a run of missing step times is no step


@pytest.mark.skipif(not (DATA / "mobgap").is_dir(), reason="shared real data not present")
@pytest.mark.parametrize(("pid", "ref_bout_pct"), [
    ("HA/002", 5.0),
    pytest.param("MS/001", None, marks=pytest.mark.xfail(strict=True, reason=(
        "not met: +7.7 % (target 3 %; under 12 draws of noise at the sensor's own level +7.0 +- 0.9 %). Two "
        "stretches where INDIP has no bout read 128 and 134 steps/min, a turning bout +19 % (steps found between "
        "INDIP's), another -12 %. Before the steps were found per step (+8.0 %, +4.2 +- 3.4 % under noise) a bout "
        "found once per stride, 20 % slow, cancelled fast ones"))),
])
def test_daily_living_course_cadence_against_indip(pid: str, ref_bout_pct: float | None) -> None:
    """Real data (Mobilise-D consortium, mobgap example data, Apache-2.0), Test11 (a daily-living course full
    of turns and slow walking): the duration-weighted cadence of the bouts with a cadence within 3 % of the
    INDIP bouts'; on HA/002 (the participant the rules were chosen on) also every reference bout's cadence
    from our steps in it within 5 % (turns lose and double heel strikes there). HA/002 reads +0.4 %, its worst
    bout -2.0 %; under noise at the sensor's own level (bench_real_gait.py's spread table) +0.5 +- 0.6 %,
    -1.1 to +1.7 %. MS/001 misses it (strict xfail: it fails when the figure changes side)."""
    import scipy.io as sio

    m = sio.loadmat(DATA / "mobgap" / "lab" / pid / "data.mat", squeeze_me=True, struct_as_record=False)
    trial = m["data"].TimeMeasure1.Test11.Trial1
    su = trial.SU.LowerBack
    refs = [(float(w.Start), float(w.End), float(np.nanmean(np.atleast_1d(w.Cadence))))
            for w in np.atleast_1d(trial.Standards.INDIP.MicroWB)]
    t = np.arange(len(su.Acc)) / 100.0
    seg = segment(signals_from_imu(t, su.Acc * 9.80665, np.radians(su.Gyr)))
    measured = [b for b in seg.bouts if np.isfinite(b.cadence_spm)]
    ours = sum(b.duration_s * b.cadence_spm for b in measured) / sum(b.duration_s for b in measured)
    ref = sum((e - s) * c for s, e, c in refs) / sum(e - s for s, e, _ in refs)
    assert ours == pytest.approx(ref, rel=0.03)
    if ref_bout_pct is not None:
        for s, e, c in refs:
            st = seg.steps_s[(seg.steps_s >= s - 0.3) & (seg.steps_s <= e + 0.3)]
            assert cadence_from_steps(st) == pytest.approx(c, rel=ref_bout_pct / 100.0), (s, e)


@pytest.mark.skipif(not (DATA / "mobgap").is_dir(), reason="shared real data not present")
def test_course_steps_are_found_per_step_not_per_stride() -> None:
    """Real data (Mobilise-D, mobgap example data, Apache-2.0): on HA/002's daily-living course the steps inside
    INDIP's bouts match its initial contacts one to one within 0.25 s for >= 70 % of them (its 46 timed
    contacts). A gait run whose windows read a stride about half the time (turns, slow steps: the left and
    right steps differ) took a stride as its rhythm, and its low-pass and peak spacing kept one step per
    stride: 63 %."""
    import scipy.io as sio

    m = sio.loadmat(DATA / "mobgap" / "lab" / "HA/002" / "data.mat", squeeze_me=True, struct_as_record=False)
    trial = m["data"].TimeMeasure1.Test11.Trial1
    su = trial.SU.LowerBack
    t = np.arange(len(su.Acc)) / 100.0
    seg = segment(signals_from_imu(t, su.Acc * 9.80665, np.radians(su.Gyr)))
    wbs = np.atleast_1d(trial.Standards.INDIP.MicroWB)
    ref = np.unique(np.concatenate([np.atleast_1d(np.asarray(w.InitialContact_Event, float)) for w in wbs]))
    ref = ref[np.isfinite(ref)]
    inside = np.zeros(seg.steps_s.size, dtype=bool)
    for w in wbs:
        inside |= (seg.steps_s >= float(w.Start) - 0.25) & (seg.steps_s <= float(w.End) + 0.25)
    found = seg.steps_s[inside]
    free = np.ones(found.size, dtype=bool)
    hits = 0
    for r in ref:  # one to one: each detection matches one contact at most
        d = np.where(free, np.abs(found - r), np.inf)
        if d.size and d.min() <= 0.25:
            free[int(np.argmin(d))] = False
            hits += 1
    assert ref.size == 46
    assert hits >= 0.68 * ref.size  # 33 of 46 found; 29 before
    assert hits >= 0.6 * found.size  # not by finding more of everything


def test_video_angles_give_steps_and_bouts() -> None:
    from walkmon.simulate.gait import GaitModel

    model = GaitModel("normal:8,bend:8", seed=4)  # standing, normal, bend mid-walk, standing
    t = np.arange(0.0, model.duration_s, 1 / 30)
    seg = segment(signals_from_angles(t, model.truth_angles_deg(t)))
    assert len(seg.bouts) == 1  # the posture change mid-walk does not break the bout
    (b,) = seg.bouts
    phase = model.step_phase(np.array([b.start_s, b.end_s]))
    assert b.cadence_spm == pytest.approx(60 * (phase[1] - phase[0]) / (b.end_s - b.start_s), rel=0.02)
    assert b.start_s == pytest.approx(2.0, abs=1.2) and b.end_s == pytest.approx(18.0, abs=1.2)


def test_bad_input_is_one_clear_error() -> None:
    with pytest.raises(InvalidInputError, match="at least 10"):
        signals_from_imu(np.arange(5.0), np.zeros((5, 3)))
    with pytest.raises(InvalidInputError, match="strictly increase: sample 11 has t=5 after t=9"):
        signals_from_imu(np.r_[np.arange(10.0), 5.0], np.zeros((11, 3)))
    with pytest.raises(InvalidInputError, match="finite"):
        signals_from_imu(np.arange(20.0), np.full((20, 3), np.nan))


def _oxford(name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(t, acc, foot-switch step times)`` of an Oxford neck-pouch session, on the accelerometer's clock."""
    d = DATA / "oxford_neckpouch" / name
    a = np.loadtxt(d / "accelerometer.csv", delimiter=",")
    sc = np.loadtxt(d / "stepcounter.csv", delimiter=",")
    t = (a[:, 0] - a[0, 0]) * 1e-9
    keep = np.r_[True, np.diff(t) > 0]
    ts = (sc[1:, 0] - a[0, 0]) * 1e-9
    steps = np.sort(np.r_[ts[np.diff(sc[:, 1]) == 1], ts[np.diff(sc[:, 2]) == 1]])
    return t[keep], a[keep, 2:5], steps


_OXFORD = ("Pixel_Jamie_Hard_NeckPouch_1", "Pixel_Jamie_Hard_NeckPouch_2", "Samsung_Carmelo_Hard_NeckPouch_1",
           "Samsung_Carmelo_Hard_NeckPouch_2", "Samsung_Dario_Hard_NeckPouch_1", "Samsung_Dario_Hard_NeckPouch_2")


@pytest.mark.skipif(not (DATA / "oxford_neckpouch").is_dir(), reason="shared real data not present")
@pytest.mark.parametrize("name", _OXFORD)
def test_oxford_neck_pouch_step_count_within_3_percent_of_the_foot_switches(name: str) -> None:
    """Real data (Oxford Step Counter data set, CC BY 4.0): a phone accelerometer in a neck pouch; the issue's
    target, 3 %, on every session (held out: no threshold was chosen on them)."""
    t, acc, truth = _oxford(name)
    seg = segment(signals_from_imu(t, acc, None))
    assert sum(b.n_steps for b in seg.bouts) == pytest.approx(truth.size, rel=0.03)


@pytest.mark.skipif(not (DATA / "oxford_neckpouch").is_dir(), reason="shared real data not present")
@pytest.mark.parametrize("variant", ["rotated", "50 Hz", "uncalibrated"])
def test_steps_do_not_depend_on_how_the_sensor_sits_or_samples(variant: str) -> None:
    """Recordings walkmon has not seen come from other sensors: any mounting orientation, other sampling rates,
    an uncalibrated accelerometer (3 % scale, 0.2 m/s² offset). On a real session (Oxford, held out) the step
    count against the foot switches stays within 3 %, and within 1 % of the same session as recorded."""
    t, acc, truth = _oxford("Samsung_Carmelo_Hard_NeckPouch_1")
    if variant == "rotated":
        c, s = np.cos(np.radians([70.0, -35.0, 120.0])), np.sin(np.radians([70.0, -35.0, 120.0]))
        rx = np.array([[1, 0, 0], [0, c[0], -s[0]], [0, s[0], c[0]]])
        ry = np.array([[c[1], 0, s[1]], [0, 1, 0], [-s[1], 0, c[1]]])
        rz = np.array([[c[2], -s[2], 0], [s[2], c[2], 0], [0, 0, 1]])
        t2, acc2 = t, acc @ (rz @ ry @ rx).T
    elif variant == "50 Hz":
        t2 = np.arange(t[0], t[-1], 0.02)
        acc2 = np.column_stack([np.interp(t2, t, acc[:, k]) for k in range(3)])
    else:
        t2, acc2 = t, acc * 1.03 + 0.2
    n = sum(b.n_steps for b in segment(signals_from_imu(t2, acc2, None)).bouts)
    n0 = sum(b.n_steps for b in segment(signals_from_imu(t, acc, None)).bouts)
    assert n == pytest.approx(truth.size, rel=0.03)
    assert n == pytest.approx(n0, rel=0.01)


@pytest.mark.parametrize(("fs", "tone_hz"), [(100.0, 48.0), (100.0, 52.0), (200.0, 98.0)])
def test_vibration_above_the_gait_band_is_no_walking(fs: float, tone_hz: float) -> None:
    """Standing on a vibrating floor (a bus, a train: an engine's 48-98 Hz at 0.8 m/s²) is standing. Resampled to
    the analysis' 50 Hz without anti-aliasing the tone folded to 2 Hz, a perfect 120 steps/min rhythm: 30 s of
    walking, 60 steps."""
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 30.0, 1.0 / fs)
    acc = np.column_stack([np.zeros_like(t), np.full_like(t, -9.80665), np.zeros_like(t)])
    acc += rng.normal(0.0, 0.02, acc.shape)
    acc[:, 1] += 0.8 * np.sin(2.0 * np.pi * tone_hz * t)
    seg = segment(signals_from_imu(t, acc, rng.normal(0.0, 0.002, acc.shape)))
    assert seg.bouts == ()
    assert seg.steps_s.size == 0
    assert set(seg.activity) == {"standing"}


@pytest.mark.parametrize(("stamps", "vibration_hz"), [
    ("uniform 100 Hz", 48.0), ("uniform 200 Hz", 98.0), ("uniform 60 Hz", 12.0), ("bursts of 3 (1, 1, 28 ms)", None),
])
def test_resampling_keeps_the_gait_band_and_folds_nothing_into_it(stamps: str, vibration_hz: float | None) -> None:
    """The analysis grid (50 Hz) from a faster recording, against the signal itself: a 2 Hz trunk bounce comes
    through within 2 % of its amplitude, and a vibration on top of it (0.8x its amplitude) does not fold into
    the gait band. At 100 and 200 Hz the vibration is one that decimation folds to 2 Hz (48 and 98 Hz); at 60 Hz
    it is 12 Hz, which stays (it is below the analysis grid's half), but whose image at 48 Hz, from interpolating
    linearly straight onto the 50 Hz grid, folded to 2 Hz. Timestamps that arrive in bursts (a logger stamping
    samples as they reach it) are a 100 Hz recording, not a 1000 Hz one: read at the median interval's rate, the
    filter cut the bounce to half (review)."""
    from scipy import signal

    from walkmon.gait.activity import _resample

    if stamps.startswith("bursts"):
        t = np.cumsum(np.tile([0.001, 0.001, 0.028], 1000))
    else:
        t = np.arange(0.0, 30.0, 1.0 / float(stamps.split()[1]))
    x = np.sin(2 * np.pi * 2.0 * t)
    if vibration_hz is not None:
        x = x + 0.8 * np.sin(2 * np.pi * vibration_hz * t)
    grid, y = _resample(t, x, 50.0)
    # the gait band of what came through (the 12 Hz vibration itself may stay: it is no gait)
    band = signal.butter(4, 5.0, btype="low", fs=50.0, output="sos")
    inner = (grid > grid[0] + 2.0) & (grid < grid[-1] - 2.0)
    got = signal.sosfiltfilt(band, y)[inner]
    assert np.max(np.abs(got - np.sin(2 * np.pi * 2.0 * grid[inner]))) < 0.02


def test_dropped_samples_are_bridged_without_inventing_motion(synthetic_imu) -> None:
    """A logger that dropped 1.5 s of samples mid-walk: the anti-aliased resampling bridges the gap by a straight
    line (a cubic spline through the samples either side, as a first version had it, swung across the gap and
    invented a step there), so the steps either side are
    those of the complete recording and no step is invented (every step found is one of the complete
    recording's)."""
    x = synthetic_imu([("stand", 3.0), ("walk", 24.0), ("stand", 3.0)], noise=0.1)
    full = segment(signals_from_imu(x.t, x.acc, x.gyr)).steps_s
    keep = (x.t < 14.0) | (x.t >= 15.5)
    got = segment(signals_from_imu(x.t[keep], x.acc[keep], x.gyr[keep])).steps_s
    assert np.all(np.isfinite(got))
    assert _matched(full, got, 0.03) == got.size
    away = (full < 13.0) | (full > 16.5)
    assert _matched(got, full[away], 0.03) == int(away.sum())


@pytest.mark.skipif(not (DATA / "mobgap").is_dir(), reason="shared real data not present")
@pytest.mark.parametrize("rate", [(1, 2), (3, 5), (32, 25), (2, 1)], ids=["50 Hz", "60 Hz", "128 Hz", "200 Hz"])
def test_a_course_reads_the_same_at_any_sampling_rate(rate: tuple[int, int]) -> None:
    """Real data (Mobilise-D, mobgap example data, Apache-2.0): HA/002's daily-living course, recorded at 100 Hz,
    resampled band-limited (scipy's resample_poly) to the rates other sensors use. The bouts and their cadences
    are the same (before anti-aliasing, at 60 Hz: a bout 99.3 steps/min read 91.1, another 82.5 read 80.9)."""
    import scipy.io as sio
    from scipy.signal import resample_poly

    m = sio.loadmat(DATA / "mobgap" / "lab" / "HA/002" / "data.mat", squeeze_me=True, struct_as_record=False)
    su = m["data"].TimeMeasure1.Test11.Trial1.SU.LowerBack
    acc, gyr = np.asarray(su.Acc, float) * 9.80665, np.radians(np.asarray(su.Gyr, float))
    ref = segment(signals_from_imu(np.arange(len(acc)) / 100.0, acc, gyr)).bouts
    up, down = rate
    acc2 = resample_poly(acc, up, down, axis=0, padtype="line")
    gyr2 = resample_poly(gyr, up, down, axis=0, padtype="line")
    got = segment(signals_from_imu(np.arange(len(acc2)) * down / (100.0 * up), acc2, gyr2)).bouts
    assert len(ref) == 4
    assert len(got) == len(ref)
    for a, b in zip(got, ref, strict=True):
        assert a.start_s == pytest.approx(b.start_s, abs=0.1)
        assert a.end_s == pytest.approx(b.end_s, abs=0.1)
        assert a.cadence_spm == pytest.approx(b.cadence_spm, rel=0.005)


@pytest.mark.skipif(not (DATA / "oxford_neckpouch").is_dir(), reason="shared real data not present")
def test_handling_the_phone_is_no_walking() -> None:
    """Real data (Oxford Step Counter data set, CC BY 4.0): Pixel_Jamie_1 is put into its pouch before the first
    foot-switch step, taken out after the last, and handled in a 3 s stop mid-session; the phone turns by 60-75
    deg each time. Without the handling rule 2, 4 and 3 steps were counted there (+3.2 %); now at most one step
    in a stretch (at its edge, or where the phone is held out longer than the rule's window), and those
    stretches read ``unknown``."""
    t, acc, truth = _oxford("Pixel_Jamie_Hard_NeckPouch_1")
    seg = segment(signals_from_imu(t, acc, None))
    steps = np.concatenate([b.steps_s for b in seg.bouts])
    gaps = np.flatnonzero(np.diff(truth) > 2.5)
    assert gaps.size >= 1  # the stop in the middle
    quiet = [(0.0, truth[0] - 0.3), (truth[-1] + 0.3, t[-1])] + [(truth[i] + 0.3, truth[i + 1] - 0.3) for i in gaps]
    grid = np.arange(0.0, t[-1], 0.1)
    act = seg.activity_at(grid)
    for lo, hi in quiet:
        assert np.count_nonzero((steps > lo) & (steps < hi)) <= 1, (lo, hi, steps[(steps > lo) & (steps < hi)])
        assert "unknown" in set(act[(grid > lo) & (grid < hi)])
    # the jolt 0.4 s after the phone is in its pouch, 2.2 median steps before the first step, is no step either
    assert not np.any(steps < truth[0] - 0.3), steps[:3]
    assert steps.size == pytest.approx(truth.size, rel=0.01)


@pytest.mark.parametrize(("period_s", "harmonic"), [(1.6, 0.0), (1.6, 0.5), (2.0, 0.4)])
def test_a_slow_rhythm_of_the_trunk_is_no_walk(period_s: float, harmonic: float) -> None:
    """A trunk bouncing vertically every 1.6-2 s for 40 s (a chair rocking, a phone swung in the hand): two of
    its events make no stride (> 3 s, Mobilise-D's longest), so no bout and no walking (before: 36-37 s of
    walking, one bout of 19-24 'steps' without a cadence)."""
    fs = 100.0
    t = np.arange(0.0, 40.0, 1.0 / fs)
    rng = np.random.default_rng(0)
    v = 0.8 * np.cos(2 * np.pi * t / period_s) + harmonic * 0.8 * np.cos(4 * np.pi * t / period_s + 0.7)
    acc = np.column_stack([rng.normal(0, 0.05, t.size), 9.80665 + v + rng.normal(0, 0.05, t.size),
                           rng.normal(0, 0.05, t.size)])
    seg = segment(signals_from_imu(t, acc, rng.normal(0.0, 0.01, (t.size, 3))))
    assert seg.bouts == ()
    assert seg.walking_s == 0.0
    assert "walking" not in set(seg.activity_at(np.arange(1.0, 39.0, 0.5)))


@pytest.mark.parametrize("step_s", [1.15, 1.25, 1.4])
def test_a_very_slow_walk_is_walking_without_a_cadence(synthetic_imu, step_s: float) -> None:
    """Steps of 1.15-1.4 s (43-52 steps/min, a very slow walker): slower than the detector's longest step, so no
    cadence is measured, but two of them make a stride Mobilise-D accepts (<= 3 s): the walk is walking (review:
    a first version of the slow-rhythm rule dropped such walks whole)."""
    imu = synthetic_imu([("stand", 3), ("walk", 30), ("stand", 3)], step_s=step_s, seed=3)
    seg = segment(signals_from_imu(imu.t, imu.acc, imu.gyr))
    assert len(seg.bouts) == 1
    (b,) = seg.bouts
    assert b.start_s == pytest.approx(imu.bouts[0][0], abs=step_s)
    assert b.end_s == pytest.approx(imu.bouts[0][1], abs=step_s)
    assert np.isnan(b.cadence_spm)


@pytest.mark.parametrize("kind", ["imu", "acc", "angles"])
@pytest.mark.parametrize("seconds", [0.2, 1.0, 1.4])
def test_a_recording_shorter_than_the_windows_is_segmented(kind: str, seconds: float) -> None:
    """Shorter than the 1.5 s handling window (review: the spin rule's window broke the arrays' shapes): no bout,
    no crash, an activity for every hop."""
    t = np.arange(0.0, seconds, 0.01)
    rng = np.random.default_rng(0)
    if kind == "angles":
        sig = signals_from_angles(t, rng.normal(0.0, 0.1, (t.size, 3)))
    else:
        acc = np.column_stack([rng.normal(0, 0.05, t.size), 9.80665 + rng.normal(0, 0.05, t.size),
                               rng.normal(0, 0.05, t.size)])
        sig = signals_from_imu(t, acc, None if kind == "acc" else rng.normal(0.0, 0.01, (t.size, 3)))
    seg = segment(sig)
    assert seg.bouts == ()
    assert len(seg.activity) == len(seg.timeline_t_s) >= 1


def test_a_sensor_spun_by_hand_is_no_walk_or_turn(synthetic_imu) -> None:
    """8 s of walking, 6 s where the sensor spins about gravity at 400 deg/s on average (a hand turning it over
    and over, the bounce going on: BROAD's fast-rotation trials read such stretches as walking and turning),
    8 s of walking. No step is kept in the spin and it reads ``unknown``; the walks either side are two bouts.
    A walker's trunk turns at up to 115 deg/s (RMS over 1.5 s) on the real courses."""
    imu = synthetic_imu([("walk", 8), ("turn", 6), ("walk", 8)], turn_deg=2400.0, seed=2)
    seg = segment(signals_from_imu(imu.t, imu.acc, imu.gyr))
    spin = (seg.steps_s > 9.0) & (seg.steps_s < 13.0)
    assert not np.any(spin), seg.steps_s[spin]
    assert set(seg.activity_at(np.arange(9.5, 12.6, 0.5))) == {"unknown"}
    assert len(seg.bouts) == 2
    assert seg.bouts[0].end_s < 9.0 and seg.bouts[1].start_s > 13.0  # the spin ramps up and down over ~1 s


def _turned_about_x(imu, angle_deg: np.ndarray):
    """``imu``'s samples as a sensor turned about its x axis by ``angle_deg`` (one angle per sample): (acc, gyro)
    in the turning sensor's axes."""
    ang = np.radians(angle_deg)
    c, s = np.cos(ang), np.sin(ang)

    def turn(v: np.ndarray) -> np.ndarray:  # each row into the axes of a sensor turned by ang about x
        return np.column_stack([v[:, 0], c * v[:, 1] + s * v[:, 2], -s * v[:, 1] + c * v[:, 2]])

    gyr = turn(imu.gyr)
    gyr[:, 0] += np.gradient(ang, imu.t)
    return turn(imu.acc), gyr


@pytest.mark.parametrize("kind", ["imu", "acc"])
def test_a_bouncing_sensor_turned_over_slowly_is_no_walk(synthetic_imu, kind: str) -> None:
    """A step rhythm for 40 s from a sensor that turns over by 150 deg meanwhile, 3.75 deg/s: 5.6 deg in any
    1.5 s, far below the handling rule's 45, so before the tilt test all 40 s read as one bout of walking. No
    trunk walks while its tilt sweeps 150 deg (a hand turning a bouncing phone over): gravity lies more than 45
    deg from its median direction over the bout for 40 % of the time. No bout."""
    imu = synthetic_imu([("walk", 40.0)], seed=4)
    acc, gyr = _turned_about_x(imu, 150.0 * imu.t / imu.t[-1])
    seg = segment(signals_from_imu(imu.t, acc, None if kind == "acc" else gyr))
    assert seg.bouts == ()
    assert seg.walking_s == 0.0


@pytest.mark.parametrize("kind", ["imu", "acc"])
def test_a_walker_stooping_slowly_still_walks(synthetic_imu, kind: str) -> None:
    """The same walk whose trunk leans 30 deg further forward over its 40 s (a walker tiring into a stoop):
    its tilt stays within 15 deg of its median direction, and the walk is one bout with every true step."""
    imu = synthetic_imu([("walk", 40.0)], seed=4)
    acc, gyr = _turned_about_x(imu, 30.0 * imu.t / imu.t[-1])
    seg = segment(signals_from_imu(imu.t, acc, None if kind == "acc" else gyr))
    assert len(seg.bouts) == 1
    (b,) = seg.bouts
    assert b.start_s == pytest.approx(imu.bouts[0][0], abs=0.6)
    assert b.end_s == pytest.approx(imu.bouts[0][1], abs=0.6)
    assert b.cadence_spm == pytest.approx(60.0 / 0.55, rel=0.01)


@pytest.mark.parametrize("kind", ["imu", "acc"])
@pytest.mark.parametrize("at_s", [10.0, 20.0, 28.0])
def test_a_sensor_set_to_a_new_angle_mid_walk_walks_on(synthetic_imu, kind: str, at_s: float) -> None:
    """The walk of the tests above, its sensor turned by 70 deg within 1 s at ``at_s`` and walked on (a chest clip
    knocked, a phone moved): the handling rule takes that second out, and the walk on either side is walking,
    each stretch in its own orientation (review: judged against one median direction for the whole bout, the
    orientation held for the longer part, the whole walk was lost: 39.6 -> 0 s)."""
    imu = synthetic_imu([("walk", 40.0)], seed=4)
    acc, gyr = _turned_about_x(imu, 70.0 * np.clip(imu.t - at_s, 0.0, 1.0))
    seg = segment(signals_from_imu(imu.t, acc, None if kind == "acc" else gyr))
    assert seg.walking_s > 0.85 * (imu.bouts[0][1] - imu.bouts[0][0]), [(b.start_s, b.end_s) for b in seg.bouts]
    for lo, hi in ((2.0, at_s - 2.0), (at_s + 3.0, 38.0)):
        assert set(seg.activity_at(np.arange(lo, hi, 0.5))) == {"walking"}, (lo, hi)


@pytest.mark.skipif(not (DATA / "broad").is_dir(), reason="shared real data not present")
@pytest.mark.parametrize(("trial", "before_s"), [("03_undisturbed_slow_rotation_C", 85.0),
                                                 ("24_disturbed_tapping_A", 91.4)])
def test_real_hand_held_slow_rotations_are_no_walk(trial: str, before_s: float) -> None:
    """Real data (BROAD, Laidig, Caruso, Cereatti, Seel 2021, CC BY 4.0): an IMU turned over slowly by hand, and
    one turned while tapped; nobody walks in either. Their rhythm read as 85.0 and 91.4 s of walking from the IMU
    (four bouts each) before the tilt test; bouts whose gravity swept 60-137 deg from its median direction a
    quarter of the time. Now 25.2 s (three bouts) and 11.0 s (one) are left: stretches the handling rule's
    fast turns cut off, each of them steadier than a quarter of its time beyond 45 deg."""
    h5py = pytest.importorskip("h5py")
    with h5py.File(DATA / "broad" / f"{trial}.hdf5", "r") as f:
        rate = float(f.attrs["sampling_rate"])
        acc, gyr = np.asarray(f["imu_acc"]), np.asarray(f["imu_gyr"])
    seg = segment(signals_from_imu(np.arange(len(acc)) / rate, acc, gyr))
    assert seg.walking_s < 0.35 * before_s, [(b.start_s, b.end_s) for b in seg.bouts]


def test_tilt_change_across_gravity_not_about_it() -> None:
    """The gyro's rotation across gravity is the tilt change (30 deg/s for 1.5 s: 45 deg); a turn about gravity
    at 120 deg/s is none; with an accelerometer alone, gravity's direction turning at 30 deg/s gives 45 deg."""
    from walkmon.gait.activity import G, tilt_change_deg

    fs, n = 100.0, 600
    acc = np.tile([0.0, G, 0.0], (n, 1))
    across = tilt_change_deg(acc, np.tile([0.0, 0.0, np.radians(30.0)], (n, 1)), fs, 1.5)
    about = tilt_change_deg(acc, np.tile([0.0, np.radians(120.0), 0.0], (n, 1)), fs, 1.5)
    assert across[100:500] == pytest.approx(45.0, abs=0.5)
    assert np.max(about) < 0.5
    ang = np.radians(30.0) * np.arange(n) / fs
    turning = G * np.column_stack([np.sin(ang), np.cos(ang), np.zeros(n)])
    assert tilt_change_deg(turning, None, fs, 1.5)[200:400] == pytest.approx(45.0, abs=1.0)


def test_a_handled_stretch_cuts_off_edge_steps_and_pauses_a_bout() -> None:
    """Steps every 0.55 s for 12 s; the sensor handled over 0.8-2.0 s (two steps before it: cut off, not a bout
    of their own) and over 6.0-7.0 s (inside the bout: a pause shorter than 3 s, so one bout)."""
    from walkmon.gait.activity import TrunkSignals

    grid = np.arange(0.0, 12.0, 0.02)
    sig = TrunkSignals(grid, np.zeros_like(grid), None, "acc")
    steps = np.arange(0.0, 12.0, 0.55)
    handled = ((grid >= 0.8) & (grid <= 2.0)) | ((grid >= 6.0) & (grid <= 7.0))
    (b,) = bouts_from_steps(steps, sig, handled=handled)
    inside = steps[~(((steps >= 0.8) & (steps <= 2.0)) | ((steps >= 6.0) & (steps <= 7.0)))]
    assert b.steps_s == pytest.approx(inside[inside > 2.0])
    assert len(bouts_from_steps(steps, sig)) == 1 and bouts_from_steps(steps, sig)[0].start_s == 0.0


@pytest.mark.parametrize(("yaw_phase", "roll_phase"), [(0.0, 0.3), (np.pi / 2, 1.87)])
def test_camera_pitch_that_repeats_once_per_stride_still_gives_the_step_cadence(
    yaw_phase: float, roll_phase: float,
) -> None:
    """The left and right steps pitch the trunk differently (a stride rhythm dominates the pitch) while yaw and
    roll swing once per stride: the steps are the stride's halves, the cadence the true one (not half), whatever
    the sway's phase against the pitch (in phase with it, review found a correlation bound refusing it)."""
    rng = np.random.default_rng(7)
    t = np.arange(0.0, 24.0, 1 / 30)
    step = 0.55
    walking = (t >= 2.0) & (t < 22.0)
    env = np.clip(np.minimum(t - 2.0, 22.0 - t), 0.0, 0.5) / 0.5 * walking
    ph = 2 * np.pi * (t - 2.0) / (2 * step)  # stride phase
    pitch = env * (2.0 * np.cos(ph) + 0.6 * np.cos(2 * ph + 0.5))
    yaw = env * 2.0 * np.sin(ph + yaw_phase)
    roll = env * 1.5 * np.sin(ph + roll_phase)
    a = np.column_stack([pitch, yaw, roll]) + rng.normal(0.0, 0.03, (t.size, 3))
    (b,) = segment(signals_from_angles(t, a)).bouts
    assert b.cadence_spm == pytest.approx(60.0 / step, rel=0.01)
    assert b.n_steps == pytest.approx((b.end_s - b.start_s) / step + 1, abs=1)


@pytest.mark.parametrize("lr", [0.0, 1.0, 2.0])
def test_simulated_walker_whose_pitch_differs_left_and_right_keeps_the_true_cadence(lr: float) -> None:
    """The simulator's ``lr:X``: a trunk that pitches differently on the left and right steps (X = 2: the pitch
    repeats once per stride, as on the real Mobilise-D lower backs); the camera angles' bout cadence stays within
    2 % of the true contacts'."""
    from walkmon.simulate.gait import GaitModel

    m = GaitModel(f"lr:{lr},stand:2,normal:20,stand:2", seed=8)
    t = np.arange(0.0, m.duration_s, 1 / 30)
    (b,) = segment(signals_from_angles(t, m.truth_angles_deg(t))).bouts
    steps = m.step_times_s()[0]
    inside = steps[(steps >= b.start_s - 0.3) & (steps <= b.end_s + 0.3)]
    assert b.cadence_spm == pytest.approx(120.0 / np.median(inside[2:] - inside[:-2]), rel=0.02)


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_a_dragged_foot_that_gives_way_to_a_normal_walk_in_one_bout_keeps_both_cadences(seed: int) -> None:
    """The simulator's true angles of a trunk that pitches once per stride (``lr:2``): 6 s of a dragged foot
    (~85 steps/min, the pitch repeating per step) then 12 s of a normal walk (~110, repeating per stride) without
    a pause, one gait region. With one rhythm for the whole region the normal part's strides were taken for
    steps and the bout had no cadence (seeds 1 and 4; unkind video right_foot_drag seed 2: 26 % slow). The bout's
    cadence against its true contacts by the field's definition (mean of 120 / stride)."""
    from walkmon.simulate.gait import GaitModel
    from walkmon.simulate.scoring import truth_stride_cadence_between

    m = GaitModel("lr:2,stand:2,right_foot_drag:6,normal:12,stand:2", seed=seed)
    t = np.arange(0.0, m.duration_s, 1 / 30)
    (b,) = segment(signals_from_angles(t, m.truth_angles_deg(t))).bouts
    steps = m.step_times_s()[0]
    true, _ = truth_stride_cadence_between(steps, np.zeros(steps.size, int), b.start_s, b.end_s)
    assert b.cadence_spm == pytest.approx(true, rel=0.015)
    assert b.end_s - b.start_s > 15.0


@pytest.mark.parametrize("turn_deg", [0.0, 180.0])
def test_a_step_rhythm_is_not_halved_by_a_turn_or_a_side_bend_in_step_with_the_pitch(turn_deg: float) -> None:
    """The pitch repeats per step (80 steps/min), the roll moves with it (a camera yawed on the chest) and the
    yaw carries the stride's sway and a turn: the steps stay the steps (found in review: 160 with the turn)."""
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 30.0, 1 / 30)
    step = 0.75
    env = np.clip(np.minimum(t - 2.0, 28.0 - t), 0.0, 0.5) / 0.5 * ((t >= 2.0) & (t < 28.0))
    ph = 2 * np.pi * (t - 2.0) / (2 * step)
    pitch = env * (1.5 * np.cos(2 * ph) + 0.6 * np.cos(4 * ph + 0.8))
    yaw = env * 2.0 * np.sin(ph) + turn_deg * np.clip((t - 10.0) / 2.0, 0.0, 1.0)
    a = np.column_stack([pitch, yaw, 0.8 * pitch]) + rng.normal(0.0, 0.03, (t.size, 3))
    bouts = segment(signals_from_angles(t, a)).bouts
    assert bouts
    for b in bouts:
        assert b.cadence_spm == pytest.approx(60.0 / step, rel=0.02)


@pytest.mark.skipif(not (DATA / "mobgap").is_dir(), reason="shared real data not present")
@pytest.mark.parametrize("trial", ["Trial1", "Trial2"])
def test_mobilise_d_straight_walk_cadence_from_the_trunks_rotation_alone(trial: str) -> None:
    """Real data (Mobilise-D consortium, mobgap example data, Apache-2.0): MS/001 Test5, the lower-back IMU's
    orientation only, as a camera sees its own (start-relative pitch, yaw, roll): the pitch repeats once per
    stride there (it read half the cadence); the cadence is within 3 % of INDIP's."""
    import scipy.io as sio

    from walkmon.imu.recordings import ImuRecording, imu_only_columns

    m = sio.loadmat(DATA / "mobgap" / "lab" / "MS" / "001" / "data.mat", squeeze_me=True, struct_as_record=False)
    x = getattr(m["data"].TimeMeasure1.Test5, trial)
    su = x.SU.LowerBack
    ref = np.atleast_1d(x.Standards.INDIP.MicroWB)[0]
    to_camera = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # x up, y right, z forward
    t = np.arange(len(su.Acc)) / 100.0
    cols = imu_only_columns(ImuRecording(t, np.radians(su.Gyr) @ to_camera.T, su.Acc * 9.80665 @ to_camera.T))
    seg = segment(signals_from_angles(cols["t"], np.column_stack([cols["pitch"], cols["yaw"], cols["roll"]])))
    (b,) = seg.bouts
    assert b.cadence_spm == pytest.approx(float(ref.Cadence), rel=0.03)


@pytest.mark.skipif(not (DATA / "mobgap").is_dir(), reason="shared real data not present")
def test_mobilise_d_straight_walk_cadence_within_2_percent_of_indip() -> None:
    """Real data (Mobilise-D consortium, mobgap example data, Apache-2.0): MS/001 Test5 Trial1, lower back."""
    import scipy.io as sio

    m = sio.loadmat(DATA / "mobgap" / "lab" / "MS" / "001" / "data.mat", squeeze_me=True, struct_as_record=False)
    trial = m["data"].TimeMeasure1.Test5.Trial1
    su = trial.SU.LowerBack
    ref = np.atleast_1d(trial.Standards.INDIP.MicroWB)[0]
    t = np.arange(len(su.Acc)) / 100.0
    seg = segment(signals_from_imu(t, su.Acc * 9.80665, np.radians(su.Gyr)))
    (b,) = seg.bouts
    assert b.cadence_spm == pytest.approx(float(ref.Cadence), rel=0.02)
    assert b.start_s == pytest.approx(float(ref.Start), abs=0.5) and b.end_s == pytest.approx(float(ref.End), abs=1.0)


@pytest.mark.skipif(not (DATA / "mobgap").is_dir(), reason="shared real data not present")
@pytest.mark.parametrize(("pid", "trial", "system"), [
    ("HA/002", "Trial2", "Stereophoto"), ("MS/001", "Trial1", "INDIP"), ("MS/001", "Trial2", "INDIP"),
])
def test_mobilise_d_straight_walk_steps_are_the_references_initial_contacts(pid: str, trial: str, system: str) -> None:
    """Real data (Mobilise-D consortium, mobgap example data, Apache-2.0), Test5 straight walks, lower back: every
    initial contact the reference times (INDIP; Stereophoto for HA/002, which has no INDIP bout) is one detected
    step within 0.25 s (half the shortest step), no detected step inside the bout is left over, and the timing
    error averages under 0.1 s. A cadence can be right with a missed and an extra step cancelling; this cannot.
    MS/001 steps unevenly (0.35 s and 0.9 s in turn on Trial1); walkmon's steps are even, so they do not resolve
    that limp (half of it is their error here), but an even grid alone would be 0.33 s off on Trial1 (review)."""
    import scipy.io as sio

    m = sio.loadmat(DATA / "mobgap" / "lab" / pid / "data.mat", squeeze_me=True, struct_as_record=False)
    x = getattr(m["data"].TimeMeasure1.Test5, trial)
    (wb,) = np.atleast_1d(getattr(x.Standards, system).MicroWB)
    ics = np.atleast_1d(wb.InitialContact_Event).astype(float)
    assert np.isfinite(ics).all() and ics.size >= 6
    su = x.SU.LowerBack
    t = np.arange(len(su.Acc)) / 100.0
    steps = segment(signals_from_imu(t, su.Acc * 9.80665, np.radians(su.Gyr))).steps_s
    inside = steps[(steps >= float(wb.Start) - 0.25) & (steps <= float(wb.End) + 0.25)]
    assert inside.size == ics.size, (inside, ics)
    err = inside - ics  # both sorted and equally many: one to one in order
    assert np.all(np.abs(err) <= 0.25), err
    assert float(np.mean(np.abs(err))) <= 0.1, err


@pytest.mark.skipif(not (DATA / "mobgap").is_dir(), reason="shared real data not present")
def test_weight_shift_before_the_first_step_is_not_a_step() -> None:
    """Real data (Mobilise-D consortium, mobgap example data, Apache-2.0): HA/002 Test5 Trial2 shifts its weight
    twice (trunk bounces at a sixth and a quarter of a step's) before the first heel strike; the bout starts at
    the reference's first step (Stereophoto), and its cadence matches."""
    import scipy.io as sio

    m = sio.loadmat(DATA / "mobgap" / "lab" / "HA" / "002" / "data.mat", squeeze_me=True, struct_as_record=False)
    trial = m["data"].TimeMeasure1.Test5.Trial2
    su = trial.SU.LowerBack
    ref = np.atleast_1d(trial.Standards.Stereophoto.MicroWB)[0]
    t = np.arange(len(su.Acc)) / 100.0
    (b,) = segment(signals_from_imu(t, su.Acc * 9.80665, np.radians(su.Gyr))).bouts
    assert b.start_s == pytest.approx(float(ref.Start), abs=0.25)
    assert b.end_s == pytest.approx(float(ref.End), abs=0.25)
    assert b.cadence_spm == pytest.approx(float(np.nanmean(np.atleast_1d(ref.Cadence))), rel=0.02)


def test_steady_state_steps_leave_out_bout_edges_and_turns(synthetic_imu) -> None:
    from walkmon.gait.activity import DEFAULT_ACTIVITY_SETTINGS, Bout, Turn, steady_state_steps

    steps = tuple(0.5 * k for k in range(20))  # 0 .. 9.5 s
    bout = Bout(steps[0], steps[-1], steps, 120.0, 120.0)
    steady = steady_state_steps((bout,), (Turn(4.0, 5.0, 90.0),), DEFAULT_ACTIVITY_SETTINGS)
    assert steady.tolist() == [1.0, 1.5, 2.0, 2.5, 3.0, 6.0, 6.5, 7.0, 7.5, 8.0, 8.5]
    short = Bout(0.0, 1.5, (0.0, 0.5, 1.0, 1.5), 120.0, 120.0)
    assert steady_state_steps((short,), (), DEFAULT_ACTIVITY_SETTINGS).size == 0


@pytest.mark.parametrize("n", [10, 11, 12, 13])
@pytest.mark.parametrize("long_s", [0.6, 0.8, 0.9])
def test_a_limp_is_no_missed_step(n: int, long_s: float) -> None:
    # A limp alternates a short and a long step (here up to 2x): every interval is a real step, so the
    # cadence is the true one (120 / stride) whatever the number of intervals; none is split or merged.
    d = np.tile([0.45, long_s], n)[:n]
    steps = np.concatenate([[0.0], np.cumsum(d)])
    true_spm = 120.0 / (0.45 + long_s)
    assert cadence_from_steps(steps) == pytest.approx(true_spm, rel=0.01)
    assert corrected_step_times(steps).size == n



def _stooped_walk_angles(
    ramp_s: tuple[float, float] = (-0.3, 0.6), bend_deg: float = 15.0, seed: int = 0
) -> tuple[np.ndarray, ...]:
    """Camera (pitch, yaw, roll) at 30 fps of a walker who stands upright, bends ``bend_deg`` forward while taking the
    first steps (a smooth ramp from ``ramp_s[0]`` to ``ramp_s[1]`` s about the first step), walks stooped at 110
    steps/min (1 deg pitch rhythm, maxima at the steps) and straightens up while taking the last steps (the same
    ramp mirrored about the last step): times, angles and the true steps."""
    rng = np.random.default_rng(seed)
    step = 60.0 / 110.0
    steps = 3.0 + step * np.arange(22)
    t = np.arange(0.0, steps[-1] + 3.0, 1.0 / 30.0)
    walking = (t >= steps[0] - 0.5 * step) & (t <= steps[-1] + 0.5 * step)
    phase = 2 * np.pi * (t - steps[0]) / step

    def ramp(a: float, b: float) -> np.ndarray:  # 0 -> 1, raised cosine between a and b
        u = np.clip((t - a) / (b - a), 0.0, 1.0)
        return 0.5 - 0.5 * np.cos(np.pi * u)

    r0, r1 = ramp_s
    posture = -bend_deg * (ramp(steps[0] + r0, steps[0] + r1) - ramp(steps[-1] - r1, steps[-1] - r0))
    pitch = posture + np.where(walking, np.cos(phase), 0.0)
    roll = np.where(walking, 1.5 * np.sin(0.5 * phase), 0.0)  # sway and yaw: one cycle per stride
    yaw = np.where(walking, 1.5 * np.cos(0.5 * phase), 0.0)
    a = np.column_stack([pitch, yaw, roll]) + rng.normal(0.0, 0.03, (t.size, 3))
    return t, a, steps


def test_video_bout_edges_survive_a_posture_ramp_at_gait_initiation_and_termination() -> None:
    """Bending forward while taking the first steps (and straightening while taking the last) makes the pitch
    monotonic over its 1 s running median, which flattens the step signal there: without the edge search the
    bout starts ~1 step late and ends ~2 steps early; with it, both edges lie within half a step of the truth
    and the timeline says walking from the first to the last step."""
    from walkmon.gait.activity import ActivitySettings

    t, a, steps = _stooped_walk_angles()
    half_step = 0.5 * float(np.median(np.diff(steps)))
    seg = segment(signals_from_angles(t, a))
    assert len(seg.bouts) == 1
    (b,) = seg.bouts
    assert b.start_s == pytest.approx(steps[0], abs=half_step)
    assert b.end_s == pytest.approx(steps[-1], abs=half_step)
    assert b.cadence_spm == pytest.approx(110.0, rel=0.01)
    grid, act = np.asarray(seg.timeline_t_s), np.asarray(seg.activity)
    assert (act[(grid > steps[0] + half_step) & (grid < steps[-1] - half_step)] == "walking").all()
    assert not (act[(grid < steps[0] - half_step) | (grid > steps[-1] + half_step)] == "walking").any()
    (old,) = segment(signals_from_angles(t, a), ActivitySettings(edge_search_steps=0)).bouts
    assert old.start_s - steps[0] > half_step and steps[-1] - old.end_s > 2 * half_step  # the case mended here


def test_video_edge_search_leaves_bouts_without_a_posture_ramp_and_imu_alone(synthetic_imu) -> None:
    """Upright start and stop: the edge search adds nothing (standing around the bout is still); an IMU's
    segmentation never searches (its bouts are not extended)."""
    from walkmon.gait.activity import ActivitySettings

    t, a, _ = _stooped_walk_angles(bend_deg=0.0)
    sig = signals_from_angles(t, a)
    (b,) = segment(sig).bouts
    (b0,) = segment(sig, ActivitySettings(edge_search_steps=0)).bouts
    assert (b.start_s, b.end_s, b.n_steps) == (b0.start_s, b0.end_s, b0.n_steps)
    rec = synthetic_imu([("stand", 2), ("walk", 8), ("stand", 4), ("walk", 8), ("stand", 2)], seed=3)
    imu = signals_from_imu(rec.t, rec.acc, rec.gyr)
    assert [(x.start_s, x.end_s) for x in segment(imu).bouts] == \
        [(x.start_s, x.end_s) for x in segment(imu, ActivitySettings(edge_search_steps=0)).bouts]


def test_a_camera_estimates_correction_jump_does_not_move_the_steps() -> None:
    """The fast method corrects its tilt in one frame after a turn (the vertical lines: up to ~9 deg at once).
    The step rhythm must not see those jumps: the steps of angles with jumps are those of the same angles
    without them (the jump moved a step by 0.06 s before without_jumps), and gait alone is left untouched."""
    from walkmon.gait.activity import without_jumps
    from walkmon.simulate.gait import GaitModel

    model = GaitModel("normal:16", seed=4)
    t = np.arange(0.0, model.duration_s, 1 / 30)
    a = model.truth_angles_deg(t)
    assert np.array_equal(without_jumps(t, a[:, 0]), a[:, 0])  # no jump in gait itself
    clean = segment(signals_from_angles(t, a)).steps_s
    jumped = a.copy()
    jumped[t >= 8.0, 0] += 5.0
    jumped[t >= 12.0, 0] -= 3.0
    steps = segment(signals_from_angles(t, jumped)).steps_s
    assert steps.size == clean.size
    assert np.max(np.abs(steps - clean)) < 0.021  # one 50 Hz sample
    # the jumps are taken out, the motion around them kept (each leaves the error of its frame's own motion,
    # guessed from the frames either side: ~0.2 deg for a 1.5 deg pitch swing)
    fixed = without_jumps(t, jumped[:, 0])
    assert np.max(np.abs((fixed - fixed[0]) - (a[:, 0] - a[0, 0]))) < 0.5


def test_without_jumps_at_the_ends_and_across_a_gap_in_the_frames() -> None:
    """A jump in the first or the last frame is taken out too; a real lean across a gap in the frames (0.5 s of
    dropped frames, 1 deg) is a slow change, not a jump, and stays (both found in review)."""
    from walkmon.gait.activity import without_jumps

    t = np.arange(0.0, 5.0, 1 / 30)
    x = np.sin(2 * np.pi * 1.8 * t)  # a 1 deg step rhythm
    for k in (1, t.size - 1):
        y = x.copy()
        y[k:] += 4.0
        z = without_jumps(t, y)
        assert np.max(np.abs((z - z[0]) - (x - x[0]))) < 0.15, k
    gap = t.copy()
    gap[75:] += 0.5
    lean = np.sin(2 * np.pi * 1.8 * gap)
    lean[75:] += 1.0
    assert np.array_equal(without_jumps(gap, lean), lean)


@pytest.mark.parametrize("walk", ["normal", "left_shoulder_down", "right_foot_drag", "bend"])
def test_straight_walk_session_cadence_within_1_percent(walk: str) -> None:
    """Issue 11: the straight simulated walks' targets still hold for the session analysis: on the simulator's
    true angles (16 s, 5 seeds), each bout's cadence within 1 % of the cadence the true steps realise over it.
    A bent walker's gait initiation once gave the video edge search a 'step' 1.46 median steps before the first
    (bend seed 0: -1.6 %); the search now stops at 1.3 median steps."""
    from walkmon.gait.session import analyze_session
    from walkmon.simulate.gait import GaitModel
    from walkmon.simulate.scoring import truth_cadence_between

    for seed in range(5):
        model = GaitModel(walk, 16.0, seed)
        t = np.arange(0.0, model.duration_s, 1 / 30)
        steps = np.asarray(model.step_times_s()[0])
        (b,) = analyze_session(t, model.truth_angles_deg(t)).segmentation.bouts
        true, _ = truth_cadence_between(steps, np.zeros(steps.size), b.start_s, b.end_s)
        assert b.cadence_spm == pytest.approx(true, rel=0.01), (seed, b.start_s, b.end_s)


def _lifted(t: np.ndarray, angles: np.ndarray, at_s: float, deg: float = 50.0, width_s: float = 1.0) -> np.ndarray:
    """The camera lifted in pitch by ``deg`` and put back (a raised cosine ``width_s`` long centred on ``at_s``)."""
    out = angles.copy()
    x = np.clip((t - at_s) / width_s + 0.5, 0.0, 1.0)
    out[:, 0] += deg * 0.5 * (1.0 - np.cos(2.0 * np.pi * x))
    return out


@pytest.mark.parametrize("at_s", [2.5, 9.0])
def test_a_camera_lifted_and_put_back_is_handled_not_walked(at_s: float) -> None:
    """A 50 deg lift of the camera within a second, at gait initiation or mid-walk (simulator truth angles): no
    step of any bout lies in it, the edge search adds none back, and the timeline reads unknown at its top.
    Measured between the window's two ends, the top of such a lift read as no tilt change at all."""
    from walkmon.gait.session import analyze_session
    from walkmon.simulate.gait import GaitModel

    model = GaitModel("normal", 16.0, 2)
    t = np.arange(0.0, model.duration_s, 1 / 30)
    seg = segment(signals_from_angles(t, _lifted(t, model.truth_angles_deg(t), at_s)))
    steps = np.concatenate([b.steps_s for b in seg.bouts])
    assert not np.any(np.abs(steps - at_s) < 0.35), steps[np.abs(steps - at_s) < 1.0]
    handled = np.asarray(seg.timeline_t_s)[np.asarray(seg.handled)]
    assert handled.size and handled.min() < at_s < handled.max()
    near = np.abs(steps[:, None] - handled[None, :]).min(axis=1) < 0.05  # no step inside the handled stretch
    assert not near.any(), steps[near]
    assert seg.activity_at([at_s])[0] == "unknown"
    timeline = analyze_session(t, _lifted(t, model.truth_angles_deg(t), at_s)).timeline
    nearest = min(timeline, key=lambda row: abs(row[0] - at_s))
    assert nearest[1] == "unknown", nearest


def test_camera_roll_near_180_deg_is_no_handling() -> None:
    """Angles that wrap at +-180 deg (a camera mounted upside down: roll 180 +- a few degrees) are unwrapped:
    the walk's bout and the whole timeline are as with the camera upright (no handling, standing still reads
    standing)."""
    from walkmon.simulate.gait import GaitModel

    model = GaitModel("normal", 16.0, 2)
    t = np.arange(0.0, model.duration_s, 1 / 30)
    a = model.truth_angles_deg(t)
    upright = segment(signals_from_angles(t, a))
    wrapped = a.copy()
    wrapped[:, 2] = (wrapped[:, 2] + 180.0 + 180.0) % 360.0 - 180.0
    seg = segment(signals_from_angles(t, wrapped))
    assert len(upright.bouts) == 1 and len(seg.bouts) == 1 and seg.bouts[0].n_steps == upright.bouts[0].n_steps
    assert seg.activity == upright.activity  # standing still reads standing upside down too


@pytest.mark.skipif(not (DATA / "oxford_neckpouch").is_dir(), reason="shared real data not present")
def test_session_timeline_keeps_handling_unknown() -> None:
    """Real data (Oxford Step Counter data set, CC BY 4.0): the session timeline (what timeline.csv holds) leaves
    the phone going into its pouch before the first step ``unknown``; its rule that turns short unknown stretches
    beside a bout into standing or walking does not apply to handling."""
    from walkmon.gait.session import ImuInput, analyze_session

    t, acc, truth = _oxford("Pixel_Jamie_Hard_NeckPouch_1")
    keep = t > 0.5  # start just before the phone goes in: the handling lies between the edge and the first bout
    t, acc = t[keep] - t[keep][0], acc[keep]
    n = t.size
    res = analyze_session(t, np.zeros((n, 3)), imu=ImuInput(t, acc, None), abs_angles_deg=np.zeros((n, 2)),
                          no_yaw=True)
    first = truth[0] - 0.5
    before = [row[1] for row in res.timeline if row[0] < first - 0.5]
    assert before and "unknown" in before and "walking" not in before, before


def test_a_lone_step_just_after_handling_is_dropped() -> None:
    """Steps every 0.55 s from 3.0 s, and one 'step' at 2.2 s (1.45 median steps before them, the jolt of a sensor
    settling): dropped when a handled stretch ends 0.3 s before it, kept without one (a slow first step)."""
    from walkmon.gait.activity import TrunkSignals

    grid = np.arange(0.0, 12.0, 0.02)
    sig = TrunkSignals(grid, np.zeros_like(grid), None, "acc")
    steps = np.r_[2.2, np.arange(3.0, 12.0, 0.55)]
    handled = (grid >= 1.0) & (grid <= 1.9)
    (b,) = bouts_from_steps(steps, sig, handled=handled)
    assert b.start_s == pytest.approx(3.0)
    (b,) = bouts_from_steps(steps, sig)
    assert b.start_s == pytest.approx(2.2)


@pytest.mark.parametrize("lr", [1.0, 2.0])
def test_no_step_is_lost_where_a_gait_region_is_split(lr: float) -> None:
    """Where a region splits at a change of pace each piece filters its own step signal; a step at the edge can land
    just past it in both pieces. Found in review (seed 8): both left it out, a 1.22 s gap where the true step is
    0.57 s. Every interval between the bout's detected steps against the true contacts' there."""
    from walkmon.simulate.gait import GaitModel

    m = GaitModel(f"lr:{lr},normal:10,right_foot_drag:10", seed=8)
    t = np.arange(0.0, m.duration_s, 1 / 30)
    (b,) = segment(signals_from_angles(t, m.truth_angles_deg(t))).bouts
    true = m.step_times_s()[0]
    s = np.asarray(b.steps_s)
    for a, z in zip(s[:-1], s[1:], strict=True):
        near = true[(true >= a - 0.5) & (true <= z + 0.5)]
        assert z - a < 1.4 * float(np.median(np.diff(near))), (a, z)


@pytest.mark.parametrize("ratio", [1.0, 0.9, 1.5, float("nan")])
def test_a_pace_change_ratio_that_cannot_split_is_refused(ratio: float) -> None:
    from walkmon.errors import InvalidInputError
    from walkmon.gait.activity import ActivitySettings

    with pytest.raises(InvalidInputError, match="pace_change_ratio"):
        ActivitySettings(pace_change_ratio=ratio)


@pytest.mark.parametrize(("fraction", "window"), [(1.0, 4), (-0.1, 4), (float("nan"), 4), (0.1, 0), (0.1, 2.5),
                                                (0.1, float("nan"))])
def test_a_ringing_bound_that_would_drop_every_step_or_none_defined_is_refused(fraction: float, window: float) -> None:
    from walkmon.errors import InvalidInputError
    from walkmon.gait.activity import ActivitySettings

    with pytest.raises(InvalidInputError, match="ringing_fraction"):
        ActivitySettings(ringing_fraction=fraction, ringing_window_steps=window)


@pytest.mark.parametrize("gap_s", [2.0, 5.0])
def test_a_gap_in_the_recording_is_unknown_and_no_bout_spans_it(synthetic_imu, gap_s: float) -> None:
    """A 24 s walk whose samples from 10 s on are missing for ``gap_s`` (a dropout): nothing is known there, so
    the timeline reads unknown (a straight line bridged it, which read as standing), no step is found in it and
    no bout spans it (the steps lost in it are not known: a bout across a 2 s gap joined its two sides, as a
    pause does, and counted the gap as walking). The walking on either side is found with its cadence."""
    imu = synthetic_imu([("stand", 2), ("walk", 24), ("stand", 2)], seed=3)
    lo, hi = 10.0, 10.0 + gap_s
    keep = (imu.t < lo) | (imu.t > hi)
    seg = segment(signals_from_imu(imu.t[keep], imu.acc[keep], imu.gyr[keep]))
    assert len(seg.bouts) == 2, [(b.start_s, b.end_s) for b in seg.bouts]
    assert seg.bouts[0].end_s < lo and seg.bouts[1].start_s > hi
    assert not np.any((seg.steps_s > lo) & (seg.steps_s < hi))
    for b in seg.bouts:
        assert b.cadence_spm == pytest.approx(60 / 0.55, rel=0.01)
    outside = imu.steps[(imu.steps < lo - 0.5) | (imu.steps > hi + 0.5)]
    assert _matched(seg.steps_s, outside, 0.12) >= outside.size - 4  # a step lost at each edge of each bout
    grid = np.arange(lo + 0.1, hi, 0.1)
    assert set(seg.activity_at(grid)) == {"unknown"}
    assert seg.in_gap(grid).all() and not seg.in_gap(np.array([5.0, 20.0])).any()
    assert any(f"nothing measured for {gap_s:.1f} s from t=10.0 s (a gap in the recording: samples missing)" in n
               for n in seg.notes), seg.notes


def test_a_recording_whose_clock_jumps_by_months_is_refused_not_exhausted() -> None:
    """Times that jump by 1e7 s (a clock reset) made the analysis grid 5e8 samples long: a MemoryError after
    minutes. It is refused at once, naming the jump."""
    t = np.arange(0.0, 20.0, 0.01)
    t[1000:] += 1e7
    acc = np.tile([0.0, -9.81, 0.0], (t.size, 1))
    with pytest.raises(InvalidInputError, match=r"longest gap, 1e\+07 s after t=9\.99 s .* a clock that jumped"):
        signals_from_imu(t, acc, np.zeros((t.size, 3)))


def test_a_recording_longer_than_two_days_is_refused_without_blaming_its_clock() -> None:
    """A real 49 h recording (no gap): refused (the analysis grid spans it), asked to be split, not told its clock
    jumped (review: 'its clock jumps by 1 s')."""
    t = np.arange(0.0, 49 * 3600.0, 1.0)
    with pytest.raises(InvalidInputError, match="split it into recordings of at most that length") as exc:
        signals_from_imu(t, np.tile([0.0, -9.81, 0.0], (t.size, 1)))
    assert "jump" not in str(exc.value)


def test_a_stride_of_exactly_the_longest_counts_though_its_float_difference_is_longer() -> None:
    """Steps found on a sample grid make strides of exactly 3.00 s across a short stop; Mobilise-D counts strides
    up to 3.0 s, but 10.8 - 7.8 is 3.0000000000000004 in floats, which dropped one of the two and read this bout
    +9 % (a simulated session's bout: +1.5 %). Expected: five strides of 1.08 s and two of 3.00 s."""
    from walkmon.gait.activity import DEFAULT_ACTIVITY_SETTINGS, cadence_from_steps

    st = np.array([5.64, 6.18, 6.72, 7.26, 7.80, 10.26, 10.80, 11.34, 11.88])
    expected = (5 * 120.0 / 1.08 + 2 * 120.0 / 3.0) / 7
    assert cadence_from_steps(st, DEFAULT_ACTIVITY_SETTINGS, mend=True) == pytest.approx(expected, rel=1e-9)


def test_a_filter_maximum_without_a_maximum_of_the_acceleration_is_no_step(tmp_path) -> None:
    """An unkind simulated session (left shoulder down, seed 5 of the benchmark): after picking something up the
    wearer stands 2 s, then walks off at 64.42 s. The band-pass of the step signal swung on after the pick-up and
    its maximum at 62.38 s, where the acceleration itself has no maximum, was taken for a step that started the
    bout 2 s early (its cadence +2.1 % against the truth). A step is a maximum of the acceleration too: the bout
    starts at the first true step and has the field's cadence of the true steps."""
    from walkmon.simulate import simulate

    walk = ("mount:4.2:-0.2,lr:1.7,left_shoulder_down:7.1,pause:1.8,left_shoulder_down:8.9,normal:9.9,turn:-180,"
            "left_shoulder_down:3.8,pause:3.1,left_shoulder_down:6.5,turn:-180,left_shoulder_down:5.4,pause:5.1,"
            "pickup:4.3,pause:1.8,left_shoulder_down:6.0,turn:-180,left_shoulder_down:7.2")
    sim = simulate(tmp_path, walk=walk, seed=5, width=64, height=48, video=False)
    x = np.loadtxt(sim.imu_path, delimiter=",", skiprows=1)
    true = np.loadtxt(tmp_path / "truth_steps.csv", delimiter=",", skiprows=1, usecols=(0,))
    (b,) = [b for b in segment(signals_from_imu(x[:, 0], x[:, 4:7], x[:, 1:4])).bouts if 58.0 < b.start_s < 66.0]
    first = true[true > 58.0][0]
    assert b.start_s == pytest.approx(first, abs=0.1)
    assert b.cadence_spm == pytest.approx(_mobilised_cadence(true[(true >= first - 0.1) & (true <= b.end_s + 0.1)]),
                                          rel=0.01)


@pytest.mark.parametrize("peak_s", [-0.1, float("nan")])
def test_a_ringing_peak_window_that_is_no_duration_is_refused(peak_s: float) -> None:
    from walkmon.gait.activity import ActivitySettings

    with pytest.raises(InvalidInputError, match="ringing_peak_s"):
        ActivitySettings(ringing_peak_s=peak_s)


@pytest.mark.skipif(not (DATA / "broad").is_dir(), reason="shared real data not present")
def test_status_agrees_with_the_bouts_reported(tmp_path) -> None:  # noqa: ANN001
    """User review: BROAD trial 2 (hand-held, no walk) read 'status: no_gait' beside 3 walking bouts, 20 steps and
    a cadence of 85.5 steps/min: the status followed the posture figures (unmeasured), not the bouts. Bouts found
    are a gait rhythm found: 'ok', whatever their posture figures."""
    import contextlib
    import io
    import json

    from walkmon.commands.cli import main
    from walkmon.tables import write_table

    h5py = pytest.importorskip("h5py")
    with h5py.File(DATA / "broad" / "02_undisturbed_slow_rotation_B.hdf5", "r") as f:
        rate = float(f.attrs["sampling_rate"])
        acc, gyr = np.asarray(f["imu_acc"]), np.asarray(f["imu_gyr"])
    t = np.arange(len(acc)) / rate
    write_table(tmp_path / "imu.csv", {"t": t, "gx": gyr[:, 0], "gy": gyr[:, 1], "gz": gyr[:, 2],
                                       "ax": acc[:, 0], "ay": acc[:, 1], "az": acc[:, 2]})
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["analyze", "--imu", str(tmp_path / "imu.csv"), "--out", str(tmp_path / "out")]) == 0
    doc = json.loads((tmp_path / "out" / "indicators.json").read_text())
    if doc["bouts"]:
        assert doc["status"] == "ok" and doc["summary"]["n_steps"] > 0
    else:
        assert doc["status"] in ("no_gait", "too_short")
