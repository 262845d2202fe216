"""History across sessions: per-session statistics and their per-day aggregate (pure: no I/O).

Definitions (each from the hops the live monitor logs once per ``hop_s``, default 1 s):

* **recorded** time: hops x ``hop_s``; **walking** time: hops marked walking x ``hop_s``;
* **upright**: a walking hop whose posture (mean angles of the last 1.5 s, relative to the upright reference)
  is inside that session's alert thresholds: leaning forward no more than ``alerts.lean_forward_deg`` and
  roll within +-``alerts.shoulder_down_deg``; the % upright is of walking hops whose posture is known;
* **alerts per hour**: alerts *raised* per hour of recorded time, by kind;
* **cadence, pitch, roll, asymmetry**: means over walking hops (per day: weighted by walking time).

Days are local calendar days (the machine's time zone) of each session's start.
"""

from __future__ import annotations

import datetime as _dt
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

__all__ = ["CSV_COLUMNS", "DayStats", "SessionStats", "csv_rows", "daily", "local_time", "parse_since"]


@dataclass(frozen=True, slots=True)
class SessionStats:
    """What one session adds to the history. Times in seconds, angles in degrees; NaN where unknown."""

    id: int
    kind: str
    person: str
    started_utc: str
    ended_utc: str | None
    end_reason: str | None
    camera: str
    hop_s: float
    recorded_s: float
    walking_s: float
    upright_s: float
    posture_known_s: float
    cadence_spm: float
    pitch_deg: float
    roll_deg: float
    asymmetry: float
    alerts: dict[str, int] = field(default_factory=dict)

    @property
    def started_local(self) -> _dt.datetime:
        return local_time(self.started_utc)

    @property
    def upright_pct(self) -> float:
        return 100.0 * self.upright_s / self.posture_known_s if self.posture_known_s > 0 else math.nan

    @property
    def n_alerts(self) -> int:
        return sum(self.alerts.values())

    def to_dict(self) -> dict[str, object]:
        return {
            "id": self.id, "kind": self.kind, "person": self.person or None, "started_utc": self.started_utc,
            "started_local": self.started_local.isoformat(timespec="seconds"), "ended_utc": self.ended_utc,
            "end_reason": self.end_reason, "camera": self.camera, "recorded_min": _r(self.recorded_s / 60, 2),
            "walking_min": _r(self.walking_s / 60, 2), "upright_pct": _r(self.upright_pct, 1),
            "cadence_spm": _r(self.cadence_spm, 1), "pitch_deg": _r(self.pitch_deg, 2),
            "roll_deg": _r(self.roll_deg, 2), "asymmetry": _r(self.asymmetry, 3), "alerts": dict(self.alerts),
        }


@dataclass(frozen=True, slots=True)
class DayStats:
    """One local calendar day of sessions."""

    day: _dt.date
    n_sessions: int
    recorded_min: float
    walking_min: float
    upright_pct: float
    alerts_per_hour: dict[str, float]
    cadence_spm: float
    pitch_deg: float
    roll_deg: float
    asymmetry: float

    def to_dict(self) -> dict[str, object]:
        return {
            "day": self.day.isoformat(), "sessions": self.n_sessions, "recorded_min": _r(self.recorded_min, 2),
            "walking_min": _r(self.walking_min, 2), "upright_pct": _r(self.upright_pct, 1),
            "alerts_per_hour": {k: _r(v, 2) for k, v in self.alerts_per_hour.items()},
            "cadence_spm": _r(self.cadence_spm, 1), "pitch_deg": _r(self.pitch_deg, 2),
            "roll_deg": _r(self.roll_deg, 2), "asymmetry": _r(self.asymmetry, 3),
        }


def _r(v: float, digits: int) -> float | None:
    return round(float(v), digits) if v is not None and math.isfinite(v) else None


def local_time(utc_iso: str) -> _dt.datetime:
    """An ISO-8601 UTC time stamp (as the session log stores them) in the machine's local time zone."""
    t = _dt.datetime.fromisoformat(utc_iso)
    if t.tzinfo is None:
        t = t.replace(tzinfo=_dt.UTC)
    return t.astimezone()


#: The longest span ``--since`` stands for, days (a century: every session there is); longer ones are cut to it.
MAX_SINCE_DAYS = 36525.0


def parse_since(text: str) -> _dt.timedelta:
    """``30d``, ``12h``, ``2w`` or a plain number of days -> a time span; ValueError with the accepted forms."""
    s = text.strip().lower()
    units = {"d": 1.0, "w": 7.0, "h": 1 / 24}
    factor = units.get(s[-1:], None)
    number = s[:-1] if factor is not None else s
    try:
        value = float(number)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        msg = f"--since {text!r}: expected a positive span such as 30d, 2w, 12h or 7"
        raise ValueError(msg)
    # longer than any history: all of it (a span beyond the calendar made 'now - span' overflow: a traceback, a 500)
    return _dt.timedelta(days=min(value * (factor or 1.0), MAX_SINCE_DAYS))


def _wmean(pairs: Iterable[tuple[float, float]]) -> float:
    num = den = 0.0
    for value, weight in pairs:
        if math.isfinite(value) and weight > 0:
            num += value * weight
            den += weight
    return num / den if den > 0 else math.nan


def daily(sessions: Sequence[SessionStats], kinds: Sequence[str] = ()) -> list[DayStats]:
    """Per local day (oldest first) of ``sessions``; ``kinds``: alert kinds always listed (0 when absent)."""
    by_day: dict[_dt.date, list[SessionStats]] = {}
    for s in sessions:
        by_day.setdefault(s.started_local.date(), []).append(s)
    out = []
    for day in sorted(by_day):
        ss = by_day[day]
        recorded = sum(s.recorded_s for s in ss)
        known = sum(s.posture_known_s for s in ss)
        counts: dict[str, int] = dict.fromkeys(kinds, 0)
        for s in ss:
            for k, n in s.alerts.items():
                counts[k] = counts.get(k, 0) + n
        per_hour = {k: (n / (recorded / 3600.0) if recorded > 0 else math.nan) for k, n in sorted(counts.items())}
        out.append(DayStats(
            day=day, n_sessions=len(ss), recorded_min=recorded / 60.0,
            walking_min=sum(s.walking_s for s in ss) / 60.0,
            upright_pct=100.0 * sum(s.upright_s for s in ss) / known if known > 0 else math.nan,
            alerts_per_hour=per_hour,
            cadence_spm=_wmean((s.cadence_spm, s.walking_s) for s in ss),
            pitch_deg=_wmean((s.pitch_deg, s.walking_s) for s in ss),
            roll_deg=_wmean((s.roll_deg, s.walking_s) for s in ss),
            asymmetry=_wmean((s.asymmetry, s.walking_s) for s in ss),
        ))
    return out


#: Columns of history.csv (alert columns ``alerts_per_hour_<kind>`` follow, one per kind).
CSV_COLUMNS = ("day", "sessions", "recorded_min", "walking_min", "upright_pct", "cadence_spm", "pitch_deg",
               "roll_deg", "asymmetry")


def csv_rows(days: Sequence[DayStats]) -> tuple[list[str], list[list[object]]]:
    """(header, rows) of history.csv; empty cells where a value is unknown."""
    kinds = sorted({k for d in days for k in d.alerts_per_hour})
    header = [*CSV_COLUMNS, *(f"alerts_per_hour_{k}" for k in kinds)]
    rows = []
    for d in days:
        doc = d.to_dict()
        row = [doc[c if c != "sessions" else "sessions"] for c in CSV_COLUMNS]
        per_hour = d.alerts_per_hour
        row += [round(per_hour[k], 2) if k in per_hour and math.isfinite(per_hour[k]) else None for k in kinds]
        rows.append(["" if v is None else v for v in row])
    return header, rows
