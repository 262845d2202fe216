"""Alert stage (delay, hysteresis, cool-down, not walking) and alert sinks (command hook gets the JSON)."""

from __future__ import annotations

import dataclasses
import io
import json
import math
import sys
import wave
from pathlib import Path

import pytest

from walkmon.gait.live import LiveIndicators
from walkmon.live.alerts import (
    DEFAULT_ALERT_SETTINGS,
    AlertEvent,
    AlertSettings,
    AlertStage,
)
from walkmon.live.sinks import AlertSinks, SinkSettings, beep_wav_bytes


def ind(t: float, pitch: float = 0.0, roll: float = 0.0, walking: bool = True, roll_swing: float = 2.0,
        asym: float = 0.05) -> LiveIndicators:
    return LiveIndicators(
        t_s=t, window_s=8.0, n_samples=240, walking=walking, gait_rms_deg=0.5, cadence_spm=110.0,
        swing_deg=(2.0, 2.0, roll_swing), inclination_deg=(pitch, 0.0, roll), posture_deg=(pitch, 0.0, roll),
        step_asymmetry=asym, label="normal", reasons=(), calibrated=True,
    )


def feed(stage: AlertStage, series: list[LiveIndicators]) -> list[AlertEvent]:
    out: list[AlertEvent] = []
    for i in series:
        out += stage.push(i)
    return out


def test_lean_forward_raised_once_after_delay_then_cleared_with_hysteresis() -> None:
    st = AlertStage(AlertSettings(delay_s=5.0, clear_delay_s=2.0, cooldown_s=60.0))
    pitch = [0.0] * 5 + [-15.0] * 12 + [-8.5] * 4 + [-5.0] * 5  # -8.5: inside the 10 - 3 hysteresis band
    ev = feed(st, [ind(float(t), p) for t, p in enumerate(pitch)])
    assert [(e.kind, e.state, e.t_s) for e in ev] == [("lean_forward", "raised", 10.0), ("lean_forward", "cleared", 23.0)]
    assert "leaning forward 15" in ev[0].message
    assert json.loads(ev[0].to_json())["kind"] == "lean_forward"


def test_condition_shorter_than_delay_raises_nothing_and_flapping_does_not_accumulate() -> None:
    st = AlertStage()
    pitch = ([-15.0] * 4 + [0.0]) * 6
    assert feed(st, [ind(float(t), p) for t, p in enumerate(pitch)]) == []


def test_cooldown_suppresses_a_repeat_then_allows_it() -> None:
    st = AlertStage(AlertSettings(delay_s=2.0, clear_delay_s=0.0, cooldown_s=20.0))
    seq = [-15.0] * 4 + [0.0] * 2 + [-15.0] * 30
    ev = feed(st, [ind(float(t), p) for t, p in enumerate(seq)])
    raised = [e.t_s for e in ev if e.state == "raised"]
    cleared = [e.t_s for e in ev if e.state == "cleared"]
    assert raised[0] == 2.0 and cleared == [4.0]
    assert raised[1] == 24.0  # held since t=6, but not before the cool-down ends at 4 + 20


def test_no_alert_while_not_walking_and_active_alert_cleared_when_stopping() -> None:
    st = AlertStage(AlertSettings(delay_s=2.0))
    assert feed(st, [ind(float(t), -30.0, walking=False) for t in range(20)]) == []
    ev = feed(st, [ind(float(t), -30.0) for t in range(20, 25)] + [ind(t, -30.0, walking=False) for t in (25.0, 26.0)])
    assert [e.state for e in ev] == ["raised"]  # not walking for 1 s: still raised
    (ev,) = st.push(ind(27.0, -30.0, walking=False))
    assert ev.state == "cleared" and ev.t_s == 27.0  # not walking for clear_delay_s (2 s)
    assert st.active == ()


def test_one_hop_not_walking_mid_walk_does_not_clear_an_alert_that_holds() -> None:
    """User review: one 'unknown' hop (or a 1.7 s U-turn) while the wearer walked on bent cleared the alert at
    once, telling them 'not walking', and the cooldown then kept the bent walk after it unsaid."""
    st = AlertStage()
    raised = feed(st, [ind(float(t), pitch=-16.0) for t in range(0, 8)])
    assert [e.state for e in raised] == ["raised"]
    blip = dataclasses.replace(ind(8.0, -16.0, walking=False), activity="unknown")
    assert st.push(blip) == []
    assert feed(st, [ind(float(t), pitch=-16.0) for t in range(9, 20)]) == []
    assert st.active == ("lean_forward",)
    # not walking, then back inside: neither for 2 s yet, so still raised (review: cleared after 1 s inside)
    assert st.push(dataclasses.replace(ind(20.0, -16.0, walking=False), activity="unknown")) == []
    assert feed(st, [ind(21.0, pitch=-5.0)]) == []
    (ev,) = feed(st, [ind(22.0, pitch=-5.0), ind(23.0, pitch=-5.0)])
    assert ev.state == "cleared" and ev.t_s == 23.0  # 2 s back inside
    # upright walking that flickers to 'not walking' one hop in three clears it too (review: raised for a minute)
    st = AlertStage()
    feed(st, [ind(float(t), pitch=-16.0) for t in range(10)])
    ev = feed(st, [ind(float(t), pitch=-3.0, walking=t % 3 != 0) for t in range(10, 70)])
    assert [e.state for e in ev] == ["cleared"] and ev[0].t_s <= 16.0 and st.active == ()
    for walking_every in (2, 3):  # walking one hop in two, or in three: each walking hop counts its own second
        st = AlertStage()
        feed(st, [ind(float(t), pitch=-16.0) for t in range(10)])
        ev = feed(st, [ind(float(t), pitch=-3.0, walking=t % walking_every == 0) for t in range(10, 40)])
        assert [e.state for e in ev] == ["cleared"] and st.active == (), walking_every


def test_shoulder_unsteady_asymmetry_conditions() -> None:
    st = AlertStage(AlertSettings(delay_s=1.0))
    ev = feed(st, [ind(float(t), roll=-7.0, roll_swing=12.0, asym=0.8) for t in range(3)])
    kinds = sorted(e.kind for e in ev)
    assert kinds == ["asymmetric_gait", "shoulder_down", "unsteady_gait"]
    assert any("left shoulder down" in e.message for e in ev)
    nan_ind = dataclasses.replace(ind(10.0), step_asymmetry=math.nan)
    assert AlertStage(AlertSettings(delay_s=0.0)).push(nan_ind) == []


def test_settings_validation_and_reset() -> None:
    with pytest.raises(ValueError, match="hysteresis"):
        AlertSettings(lean_forward_hysteresis_deg=20.0)
    with pytest.raises(ValueError, match="unknown condition"):
        AlertSettings(enabled=("slouching",))
    st = AlertStage(dataclasses.replace(DEFAULT_ALERT_SETTINGS, delay_s=0.0))
    st.push(ind(0.0, -20.0))
    assert st.active == ("lean_forward",)
    st.reset()
    assert st.active == ()


def test_command_hook_receives_alert_json_on_stdin(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import datetime as dt
    import time
    from zoneinfo import ZoneInfo

    monkeypatch.setenv("TZ", "America/New_York")
    time.tzset()
    try:
        out = tmp_path / "hook.json"
        script = f"import sys; open({str(out)!r}, 'w').write(sys.stdin.read())"
        sinks = AlertSinks(SinkSettings(terminal=True, hook_command=(sys.executable, "-c", script)),
                           stream=io.StringIO(), session_id=7, person="Ann")
        ev = AlertEvent(12.0, "lean_forward", "raised", 15.0, 10.0, "leaning forward 15 deg: straighten up")
        sinks.deliver([ev])
        sinks.close(wait_s=10.0)
    finally:
        monkeypatch.delenv("TZ")
        time.tzset()
    doc = json.loads(out.read_text())
    local = dt.datetime.fromisoformat(doc.pop("time_local"))
    assert doc == {**ev.to_dict(), "session_id": 7, "person": "Ann"}
    # ISO 8601 with the wearer's UTC offset (New York's, -5 or -4 h), and the wall-clock time of delivery
    now_ny = dt.datetime.now(ZoneInfo("America/New_York"))
    assert local.utcoffset() == now_ny.utcoffset()
    assert abs((now_ny - local).total_seconds()) < 30


def test_failing_sinks_are_logged_not_fatal(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    stream = io.StringIO()
    sinks = AlertSinks(SinkSettings(sound=True, sound_command=(str(tmp_path / "no-player"),),
                                    hook_command=(str(tmp_path / "no-hook"),)), stream=stream)
    sinks.deliver([AlertEvent(1.0, "lean_forward", "raised", 15.0, 10.0, "msg")])
    sinks.close()
    assert "ALERT raised: msg" in stream.getvalue()
    assert sum("failed to start" in r.message for r in caplog.records) == 2


def test_slow_hook_is_killed_after_its_timeout() -> None:
    sinks = AlertSinks(SinkSettings(terminal=False, hook_command=(sys.executable, "-c", "import time; time.sleep(60)"),
                                    hook_timeout_s=0.2))
    sinks.deliver([AlertEvent(1.0, "lean_forward", "raised", 15.0, 10.0, "msg")])
    procs = [c[0] for c in sinks._children]
    assert len(procs) == 1 and procs[0].poll() is None
    sinks.close(wait_s=0.3)
    assert procs[0].returncode is not None  # killed, not left behind


def test_beep_is_a_valid_wav() -> None:
    with wave.open(io.BytesIO(beep_wav_bytes(duration_s=0.1)), "rb") as w:
        assert w.getnchannels() == 1 and w.getframerate() == 16000 and w.getnframes() == 1600


@pytest.mark.parametrize(("doubt", "raised"), [(0.0, True), (2.0, True), (4.0, False), (float("nan"), True)])
def test_posture_alerts_compare_what_the_posture_is_at_least(doubt: float, raised: bool) -> None:
    """A shoulder 8 deg down for 10 s: raised (5 deg threshold) unless the posture's doubt (a camera-only monitor
    that does not know gravity's direction well enough at this heading) could bring it within 5 deg; the value
    reported is that lower bound. A NaN doubt counts as none."""
    st = AlertStage(AlertSettings(delay_s=5.0, clear_delay_s=2.0, cooldown_s=60.0))
    series = [dataclasses.replace(ind(float(t), roll=-8.0), posture_doubt_deg=doubt) for t in range(12)]
    ev = [e for e in feed(st, series) if e.state == "raised"]
    assert [e.kind for e in ev] == (["shoulder_down"] if raised else [])
    if raised:
        assert ev[0].value == pytest.approx(8.0 - (doubt if doubt == doubt else 0.0))
        assert "left shoulder down" in ev[0].message


def test_an_alert_cleared_by_a_covered_lens_says_so() -> None:
    """A raised alert is cleared when the wearer stops walking; when the hop is unknown because the camera measured
    nothing (LiveIndicatorStage.push_unmeasured), the clearing says that, not 'not walking'."""
    stage = AlertStage()
    raised = feed(stage, [ind(float(t), pitch=-15.0) for t in range(0, 8)])
    assert [e.state for e in raised] == ["raised"]
    why = "nothing measured for 2.0 s: the camera's view held (covered, dark or featureless)"
    blind = dataclasses.replace(ind(8.0, walking=False), activity="unknown", label="not_walking", reasons=(why,))
    assert stage.push(blind) == []  # cleared after clear_delay_s (2 s) without walking
    (ev,) = stage.push(dataclasses.replace(blind, t_s=10.0))
    assert ev.state == "cleared" and ev.message == "nothing measured for 2.0 s: alert cleared"
    stage = AlertStage()
    feed(stage, [ind(float(t), pitch=-15.0) for t in range(0, 8)])
    standing = dataclasses.replace(ind(8.0, walking=False), activity="standing")
    assert stage.push(standing) == []
    (ev,) = stage.push(dataclasses.replace(standing, t_s=10.0))
    assert ev.message == "not walking: alert cleared"
