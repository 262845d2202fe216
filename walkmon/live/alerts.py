"""Posture alerts: conditions that must hold for a delay, with hysteresis and a cool-down.

A stage (no threads, no I/O, no clock reads): :meth:`AlertStage.push` takes one hop's
:class:`~walkmon.gait.live.LiveIndicators` and returns the :class:`AlertEvent` list it caused (usually
empty). Each condition

* ``lean_forward``: posture pitch below ``-lean_forward_deg`` (bent forward);
* ``shoulder_down``: posture roll beyond ``shoulder_down_deg`` either side (sign tells which shoulder);

  both on what the posture is at least: the measured tilt less its doubt on that axis (``posture_doubt_pitch_deg``
  / ``posture_doubt_roll_deg``: a camera-only monitor that does not know gravity's direction well enough at the
  wearer's heading, a video's pitch drift since the reference, or no upright reference yet, before the first still
  stance; the value reported is that lower bound);
* ``unsteady_gait``: roll swing above ``unsteady_roll_swing_deg``;
* ``asymmetric_gait``: step asymmetry above ``asymmetry_ratio``;

is *raised* once it has held continuously for ``delay_s`` (default 5 s), and *cleared* once it has been back
inside its threshold minus the hysteresis margin for ``clear_delay_s``. After a clear, the same condition is
not raised again before ``cooldown_s``. While the wearer is not walking nothing is raised, and an active alert
clears once the wearer has not walked (or has been back inside) for ``clear_delay_s``. Sinks that deliver events
(terminal, sound, command hook) live in :mod:`walkmon.live.sinks`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass

from walkmon.gait.live import LiveIndicators, unmeasured_why

__all__ = ["CONDITIONS", "DEFAULT_ALERT_SETTINGS", "AlertEvent", "AlertSettings", "AlertStage"]

#: Condition names, in evaluation order.
CONDITIONS = ("lean_forward", "shoulder_down", "unsteady_gait", "asymmetric_gait")


_THRESHOLD_PAIRS = (
    ("lean_forward_deg", "lean_forward_hysteresis_deg"),
    ("shoulder_down_deg", "shoulder_down_hysteresis_deg"),
    ("unsteady_roll_swing_deg", "unsteady_hysteresis_deg"),
    ("asymmetry_ratio", "asymmetry_hysteresis"),
)


@dataclass(frozen=True, slots=True)
class AlertSettings:
    """Alert thresholds and timing (degrees, seconds)."""

    #: Conditions that may raise alerts.
    enabled: tuple[str, ...] = CONDITIONS
    #: A condition must hold this long before it is raised, s.
    delay_s: float = 5.0
    #: ... and be back within threshold - hysteresis this long before it is cleared, s.
    clear_delay_s: float = 2.0
    #: After a clear, the same condition is not raised again for this long, s.
    cooldown_s: float = 60.0
    lean_forward_deg: float = 10.0
    lean_forward_hysteresis_deg: float = 3.0
    shoulder_down_deg: float = 5.0
    shoulder_down_hysteresis_deg: float = 2.0
    unsteady_roll_swing_deg: float = 8.0
    unsteady_hysteresis_deg: float = 2.0
    asymmetry_ratio: float = 0.35
    asymmetry_hysteresis: float = 0.1

    def __post_init__(self) -> None:
        unknown = [c for c in self.enabled if c not in CONDITIONS]
        if unknown:
            msg = f"alerts.enabled: unknown condition(s) {unknown}; known: {list(CONDITIONS)}"
            raise ValueError(msg)
        for name in ("delay_s", "clear_delay_s", "cooldown_s"):
            if getattr(self, name) < 0:
                msg = f"alerts.{name} must be >= 0, got {getattr(self, name)}"
                raise ValueError(msg)
        for thr_name, hyst_name in _THRESHOLD_PAIRS:
            thr, hyst = getattr(self, thr_name), getattr(self, hyst_name)
            if not 0 <= hyst < thr:
                msg = f"alerts.{hyst_name} must be >= 0 and below alerts.{thr_name} ({hyst} vs {thr})"
                raise ValueError(msg)


DEFAULT_ALERT_SETTINGS = AlertSettings()


@dataclass(frozen=True, slots=True)
class AlertEvent:
    """An alert raised or cleared at capture time ``t_s``."""

    t_s: float
    kind: str
    state: str  # "raised" or "cleared"
    value: float
    threshold: float
    message: str

    def to_dict(self) -> dict[str, object]:
        return {
            "t_s": round(self.t_s, 3),
            "kind": self.kind,
            "state": self.state,
            "value": None if not math.isfinite(self.value) else round(self.value, 3),
            "threshold": self.threshold,
            "message": self.message,
        }

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), sort_keys=True)


@dataclass(slots=True)
class _State:
    active: bool = False
    pending_since: float | None = None
    # walking back inside the threshold: the time so far (None: not counting). Each such hop adds its own
    # interval (since the hop before it, of any kind) but the first; a hop not walking adds nothing and pauses
    # it, a walking hop outside the threshold ends it (review: a reset at every hop not walking kept an alert raised
    # through upright walking that flickered, and crediting only consecutive inside hops kept it raised when
    # walking alternated hop by hop)
    inside_s: float | None = None
    last_hop_t: float | None = None
    idle_since: float | None = None  # not walking since (a timer of its own: review)
    last_cleared: float | None = None


def _measures(s: AlertSettings) -> dict[str, tuple[Callable[[LiveIndicators], float], float, float, str]]:
    """condition -> (value from indicators, raise threshold, clear threshold, message template)."""

    def doubt(ind: LiveIndicators, axis: str) -> float:
        d = float(getattr(ind, f"posture_doubt_{axis}_deg", math.nan))
        if not math.isfinite(d):
            d = float(getattr(ind, "posture_doubt_deg", 0.0))
        return d if math.isfinite(d) and d > 0 else 0.0

    # what the posture is at least: the measured tilt less its doubt on that axis (LiveIndicators.
    # posture_doubt_pitch_deg / _roll_deg: gravity's direction not known well enough at this heading, the video's
    # pitch drift since the reference, no upright reference yet), so that a doubtful tilt raises nothing
    def lean(ind: LiveIndicators) -> float:
        return -ind.posture_deg[0] - doubt(ind, "pitch")

    def shoulder(ind: LiveIndicators) -> float:
        return abs(ind.posture_deg[2]) - doubt(ind, "roll")

    return {
        "lean_forward": (lean, s.lean_forward_deg, s.lean_forward_deg - s.lean_forward_hysteresis_deg,
                         "leaning forward {v:.0f} deg: straighten up"),
        "shoulder_down": (shoulder, s.shoulder_down_deg, s.shoulder_down_deg - s.shoulder_down_hysteresis_deg,
                          "{side} shoulder down {v:.0f} deg: level your shoulders"),
        "unsteady_gait": (lambda i: i.swing_deg[2], s.unsteady_roll_swing_deg,
                          s.unsteady_roll_swing_deg - s.unsteady_hysteresis_deg,
                          "unsteady gait: side-to-side sway {v:.0f} deg"),
        "asymmetric_gait": (lambda i: i.step_asymmetry, s.asymmetry_ratio, s.asymmetry_ratio - s.asymmetry_hysteresis,
                            "asymmetric gait: left/right steps differ by {p:.0f}%"),
    }


def _not_walking_why(ind: LiveIndicators) -> str:
    """Why a hop is no walking, in a few words: 'not walking', or that nothing was measured (a covered lens)."""
    return unmeasured_why(ind.activity, ind.reasons) or "not walking"


class AlertStage:
    """``push(indicators) -> list[AlertEvent]`` and ``reset()``; :attr:`active` lists raised conditions."""

    def __init__(self, settings: AlertSettings = DEFAULT_ALERT_SETTINGS) -> None:
        self.settings = settings
        self._measures = _measures(settings)
        self.reset()

    def reset(self) -> None:
        self._states = {c: _State() for c in self.settings.enabled}

    @property
    def active(self) -> tuple[str, ...]:
        """Conditions currently raised."""
        return tuple(c for c, st in self._states.items() if st.active)

    def push(self, ind: LiveIndicators) -> list[AlertEvent]:
        events: list[AlertEvent] = []
        t = ind.t_s
        for cond, st in self._states.items():
            measure, on_thr, off_thr, template = self._measures[cond]
            value = measure(ind)
            finite = math.isfinite(value)
            if not ind.walking:
                # nothing raised; a raised alert clears once the wearer has not walked (or been back inside) for
                # clear_delay_s: one unknown hop mid-walk, or a U-turn, cleared it at once, and the cooldown then
                # kept the posture that still held from being said again (user review: a bent walker's alert
                # cleared at a 1.7 s turn, 15 s more of bent walking unsaid)
                st.pending_since = None  # 1 s inside and 1 s not walking are neither 2 s
                st.last_hop_t = t
                if st.active:
                    if st.idle_since is None:
                        st.idle_since = t
                    if t - st.idle_since >= self.settings.clear_delay_s - 1e-9:
                        why = f"{_not_walking_why(ind)}: alert cleared"
                        events.append(self._clear(cond, st, t, value, off_thr, why))
                continue
            st.idle_since = None
            if not st.active:
                if finite and value > on_thr:
                    if st.pending_since is None:
                        st.pending_since = t
                    cooled = st.last_cleared is None or t - st.last_cleared >= self.settings.cooldown_s
                    if t - st.pending_since >= self.settings.delay_s - 1e-9 and cooled:
                        st.active, st.inside_s = True, None
                        side = "right" if ind.posture_deg[2] > 0 else "left"
                        msg = template.format(v=value, p=100 * value, side=side)
                        events.append(AlertEvent(t, cond, "raised", value, on_thr, msg))
                else:
                    st.pending_since = None
            elif finite and value > off_thr:
                st.inside_s = None
            else:
                if st.inside_s is None:
                    st.inside_s = 0.0
                elif st.last_hop_t is not None:
                    st.inside_s += t - st.last_hop_t
                if st.inside_s >= self.settings.clear_delay_s - 1e-9:
                    events.append(self._clear(cond, st, t, value, off_thr, f"{cond.replace('_', ' ')}: cleared"))
            st.last_hop_t = t
        return events

    def close(self, t_s: float) -> list[AlertEvent]:
        """The session ends at capture time ``t_s``: clear every raised alert (so the log never keeps an alert
        raised forever) and return those ``cleared`` events."""
        events = []
        for cond, st in self._states.items():
            if st.active:
                _measure, _on, off_thr, _template = self._measures[cond]
                events.append(self._clear(cond, st, t_s, math.nan, off_thr, "session ended: alert cleared"))
        return events

    @staticmethod
    def _clear(cond: str, st: _State, t: float, value: float, thr: float, msg: str) -> AlertEvent:
        st.active, st.pending_since, st.idle_since, st.last_cleared = False, None, None, t
        st.inside_s = None
        return AlertEvent(t, cond, "cleared", value, thr, msg)
