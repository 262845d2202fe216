"""Plain sentences for the wearer and the clinician (units always written out)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from walkmon.views.history import DayStats, SessionStats
from walkmon.views.render import ALERT_WORDS, describe_label

__all__ = ["alerts_phrase", "history_summary", "posture_times", "session_summary"]


def _plural(n: int, word: str) -> str:
    return f"{n} {word}" + ("" if n == 1 else "s")


def alerts_phrase(alerts: Mapping[str, int]) -> str:
    """'no alerts' / '3 lean-forward alerts and 1 shoulder-down alert'."""
    parts = [_plural(n, f"{ALERT_WORDS.get(k, k.replace('_', ' '))} alert") for k, n in sorted(alerts.items()) if n]
    if not parts:
        return "no alerts"
    return parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]


def _minutes(seconds: float) -> str:
    """'12 min', '1.5 min', or under a minute '17 s' ('0.0 min walked' for 2.5 s: user review)."""
    if seconds < 59.5:
        return f"{seconds:.0f} s"
    m = seconds / 60.0
    return f"{m:.0f} min" if m >= 10 else f"{m:.1f} min"


def session_summary(s: SessionStats, baseline: SessionStats | DayStats | None = None, baseline_what: str = "",
                    *, in_bouts_s: float | None = None) -> str:
    """'12 min walked, 78 % upright (within the alert thresholds), 3 lean-forward alerts, cadence 104 steps/min.
    Compared with ...'. The walking time is the straight walking the history counts and the posture figures are
    over (turns and stops left out); ``in_bouts_s``, an offline analysis's time in walking bouts (turns and short
    stops included, its indicators' walking_s), is given beside it where longer (user review: the report said
    '1.0 min walked' and the history 0.28 min for the same recording, unsaid why)."""
    if s.walking_s <= 0 and not in_bouts_s:
        return (f"No walking detected in {_minutes(s.recorded_s)} recorded; {alerts_phrase(s.alerts)}.")
    walked = f"{_minutes(s.walking_s)} walked"
    if in_bouts_s is not None and in_bouts_s > s.walking_s + s.hop_s:
        walked = (f"{_minutes(s.walking_s)} of straight walking ({_minutes(in_bouts_s)} in walking bouts, turns and "
                  f"stops included)")
    parts = [walked]
    if math.isfinite(s.upright_pct):
        # the walking time whose posture stays within the alert thresholds: not the share labelled normal, which
        # the report's classification gives beside it (review: '56 % upright' beside 'normal over 51 %', unsaid)
        parts.append(f"{s.upright_pct:.0f} % upright (within the alert thresholds)")
    parts.append(alerts_phrase(s.alerts))
    if math.isfinite(s.cadence_spm):
        parts.append(f"cadence {s.cadence_spm:.0f} steps/min")
    text = ", ".join(parts) + "."
    if baseline is not None:
        text += " " + compare(s.upright_pct, s.cadence_spm, s.pitch_deg, baseline, baseline_what)
    return text


def compare(upright_pct: float, cadence_spm: float, pitch_deg: float, baseline: Any, what: str) -> str:
    """'Compared with <what>: upright 85 % (now 78 %, less), cadence 101 steps/min (now 104), ...'."""
    b_up = baseline.upright_pct
    b_cad = baseline.cadence_spm
    b_pitch = baseline.pitch_deg
    bits = []
    if math.isfinite(b_up) and math.isfinite(upright_pct):
        trend = "about the same" if abs(upright_pct - b_up) < 5 else ("more" if upright_pct > b_up else "less")
        bits.append(f"upright {b_up:.0f} % (now {upright_pct:.0f} %, {trend})")
    if math.isfinite(b_cad) and math.isfinite(cadence_spm):
        bits.append(f"cadence {b_cad:.0f} steps/min (now {cadence_spm:.0f})")
    if math.isfinite(b_pitch) and math.isfinite(pitch_deg):
        lean = "more bent forward" if pitch_deg < b_pitch - 2 else (
            "more upright" if pitch_deg > b_pitch + 2 else "about the same lean")
        bits.append(f"mean forward lean {b_pitch:+.1f} deg (now {pitch_deg:+.1f} deg, {lean})")
    if not bits:
        return f"No comparison with {what}: too little walking in one of them."
    return f"Compared with {what}: " + "; ".join(bits) + "."


def posture_times(tl: Mapping[str, Any]) -> list[tuple[str, float, float]]:
    """(posture or activity in words, seconds, % of the recorded time) from a timeline, longest first."""
    hops = tl["hops"]
    hop_s = float(tl.get("hop_s", 1.0))
    counts: dict[str, int] = {}
    for walking, label, activity in zip(hops["walking"], hops["label"], hops["activity"], strict=True):
        name = f"walking: {describe_label(label)}" if walking and label else str(activity or "unknown")
        counts[name] = counts.get(name, 0) + 1
    total = sum(counts.values())
    return [(k, n * hop_s, 100.0 * n / total) for k, n in sorted(counts.items(), key=lambda kv: -kv[1])]


def history_summary(days: Sequence[DayStats]) -> str:
    """One sentence over a period: totals and the change from its first half to its second half."""
    if not days:
        return "No sessions in this period."
    walk = sum(d.walking_min for d in days)
    text = f"{_minutes(walk * 60)} walked on {_plural(len(days), 'day')}"
    up = [(d.upright_pct, d.walking_min) for d in days if math.isfinite(d.upright_pct) and d.walking_min > 0]
    if up:
        mean_up = sum(v * w for v, w in up) / sum(w for _, w in up)
        text += f", {mean_up:.0f} % of walking time upright"
    text += "."
    if len(up) >= 4:
        half = len(up) // 2
        first = sum(v * w for v, w in up[:half]) / sum(w for _, w in up[:half])
        second = sum(v * w for v, w in up[half:]) / sum(w for _, w in up[half:])
        change = second - first
        trend = ("about the same" if abs(change) < 5 else "better" if change > 0 else "worse")
        text += (f" Upright time in the second half of the period: {second:.0f} % against {first:.0f} % in the first "
                 f"half ({trend}).")
    return text
