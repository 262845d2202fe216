"""Plausibility of IMU samples: what a real body-worn MEMS IMU can report, checked before a sample is used.

CSV lines carry no checksum, a serial link can deliver a dead sensor's zeros, and a file may hold a corrupted
row: such samples would go into the attitude filter and come out as wrong (or NaN) angles. Every IMU reader
(:class:`~walkmon.drivers.file_imu.FileImu`, the serial CSV parser, the live pipeline's IMU buffer, the
``imu.csv`` reader of ``walkmon analyze``) passes its samples through :func:`implausible_reason`; a sample that
fails is skipped and counted under its reason, never fed to the filter.

A sample is implausible when (limits in :class:`ImuLimits`):

* ``non_finite``: any value is NaN or infinite;
* ``gyro_range``: a rate component beyond ±4000 °/s (MEMS gyroscopes top out at ±2000 or ±4000 °/s);
* ``accel_range``: a specific-force component beyond ±32 g (MEMS accelerometers: ±2 .. ±32 g);
* ``no_gravity``: the specific force is under 0.1 g: a worn sensor always feels gravity plus the walk's
  accelerations (a walk's lowest is about 0.5 g); an all-zero sensor (dead, unpowered, not initialised) fails;
* ``time_back``: the time stamp is earlier than the previous accepted sample's (a corrupted or reordered line);
  in a stream (:class:`ImuPlausibility`), :data:`CLOCK_RESTART_SAMPLES` samples in a row that go back but move
  forward among themselves are a clock that restarted (a device rebooted, a microsecond counter wrapped, a
  corrupted time far ahead that every later sample is behind): the stream follows the new clock from there
  (``clock_restarts``), as it would otherwise have refused every later sample of the session (user review);
* ``time_jump`` (a recording, :func:`plausible_rows`): one row's time stamp far ahead of the rows around it, the
  next row continuing from the one before (a corrupted time in one line); without this rule every row after it
  read as going back, and one bad line refused a whole file as a clock reset (user review).
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from walkmon.consts import GRAVITY_MS2

__all__ = ["DEFAULT_IMU_LIMITS", "ImuLimits", "ImuPlausibility", "implausible_reason", "plausible_rows", "time_jumps"]


@dataclass(frozen=True, slots=True)
class ImuLimits:
    """Bounds of a plausible sample (see the module docstring)."""

    max_rate_rad_s: float = math.radians(4000.0)
    max_accel_m_s2: float = 32.0 * GRAVITY_MS2
    min_accel_norm_m_s2: float = 0.1 * GRAVITY_MS2


DEFAULT_IMU_LIMITS = ImuLimits()

#: Consecutive samples behind the stream's time but in order among themselves that make a clock restart.
CLOCK_RESTART_SAMPLES = 5


def implausible_reason(t_s: float, gyroscope_rad_s: Sequence[float] | None, accelerometer_m_s2: Sequence[float],
                       previous_t_s: float = -math.inf, limits: ImuLimits = DEFAULT_IMU_LIMITS) -> str | None:
    """Why this sample cannot be real (one of the reasons in the module docstring), or None if plausible."""
    gyr = () if gyroscope_rad_s is None else tuple(gyroscope_rad_s)
    acc = tuple(accelerometer_m_s2)
    if not (math.isfinite(t_s) and all(math.isfinite(v) for v in (*gyr, *acc))):
        return "non_finite"
    if any(abs(v) > limits.max_rate_rad_s for v in gyr):
        return "gyro_range"
    if any(abs(v) > limits.max_accel_m_s2 for v in acc):
        return "accel_range"
    if math.sqrt(sum(v * v for v in acc)) < limits.min_accel_norm_m_s2:
        return "no_gravity"
    if t_s < previous_t_s:
        return "time_back"
    return None


class ImuPlausibility:
    """A stream's running check: :meth:`check` each sample in order; rejected ones are counted by reason."""

    def __init__(self, limits: ImuLimits = DEFAULT_IMU_LIMITS) -> None:
        self.limits = limits
        self.rejected: Counter[str] = Counter()
        self.accepted = 0
        #: times the stream's clock restarted (see ``time_back`` in the module docstring)
        self.clock_restarts = 0
        self._last_t = -math.inf
        self._behind: list[float] = []  # the current run of samples behind the stream's time, in order

    def check(self, t_s: float, gyroscope_rad_s: Sequence[float] | None, accelerometer_m_s2: Sequence[float]) -> bool:
        """True if the sample is plausible (and becomes the time reference), False if it was counted and skipped."""
        why = implausible_reason(t_s, gyroscope_rad_s, accelerometer_m_s2, self._last_t, self.limits)
        if why == "time_back":
            if self._behind and not t_s > self._behind[-1]:
                self._behind = []
            self._behind.append(t_s)
            if len(self._behind) >= CLOCK_RESTART_SAMPLES:
                self.clock_restarts += 1
                why = None
        elif why is None:
            self._behind = []
        if why is not None:
            self.rejected[why] += 1
            return False
        self._behind = []
        self._last_t = t_s
        self.accepted += 1
        return True

    @property
    def n_rejected(self) -> int:
        return sum(self.rejected.values())

    def summary(self) -> str:
        """``"3 of 120 IMU samples rejected (2 no_gravity, 1 time_back)"``."""
        n = self.n_rejected
        why = ", ".join(f"{k} {v}" for k, v in sorted(self.rejected.items()))
        restarts = f"; the clock restarted {self.clock_restarts} time(s)" if self.clock_restarts else ""
        return f"{n} of {n + self.accepted} IMU samples rejected as implausible" + (f" ({why})" if n else "") + restarts


def plausible_rows(t_s: NDArray[np.float64], gyroscope_rad_s: NDArray[np.float64] | None,
                   accelerometer_m_s2: NDArray[np.float64],
                   limits: ImuLimits = DEFAULT_IMU_LIMITS) -> tuple[NDArray[np.bool_], Counter[str]]:
    """Vectorised :class:`ImuPlausibility` over a recording: (mask of the rows kept, rejected counts by reason).

    ``time_back`` compares with the last *kept* row, as the streaming check does; a repeated time stamp (same
    as the last kept) is rejected too here, as a recording's rows must strictly increase in time.
    """
    t = np.asarray(t_s, dtype=float).reshape(-1)
    acc = np.asarray(accelerometer_m_s2, dtype=float).reshape(len(t), 3)
    gyr = None if gyroscope_rad_s is None else np.asarray(gyroscope_rad_s, dtype=float).reshape(len(t), 3)
    reasons = np.full(len(t), "", dtype=object)
    with np.errstate(invalid="ignore", over="ignore"):
        finite = np.isfinite(t) & np.all(np.isfinite(acc), axis=1)
        if gyr is not None:
            finite &= np.all(np.isfinite(gyr), axis=1)
        reasons[~finite] = "non_finite"
        if gyr is not None:
            bad = finite & np.any(np.abs(gyr) > limits.max_rate_rad_s, axis=1) & (reasons == "")
            reasons[bad] = "gyro_range"
        bad = finite & np.any(np.abs(acc) > limits.max_accel_m_s2, axis=1) & (reasons == "")
        reasons[bad] = "accel_range"
        norm = np.sqrt(np.sum(np.where(np.isfinite(acc), acc, 0.0) ** 2, axis=1))
        bad = finite & (norm < limits.min_accel_norm_m_s2) & (reasons == "")
        reasons[bad] = "no_gravity"
    keep = reasons == ""
    jump = np.flatnonzero(keep)[time_jumps(t[keep])]
    keep[jump] = False
    reasons[jump] = "time_jump"
    idx = np.flatnonzero(keep)
    if idx.size:  # against the newest earlier candidate: a row rejected for time never raises that maximum
        before = np.maximum.accumulate(np.concatenate([[-math.inf], t[idx][:-1]]))
        back = idx[t[idx] <= before]
        keep[back] = False
        reasons[back] = "time_back"
    return keep, Counter(str(r) for r in reasons[~keep])


def time_jumps(t_s: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Rows of the sequence ``t_s`` whose time is ahead of the next row's while the next row continues after the
    row before: one corrupted time stamp, not the rows after it going back (see ``time_jump``)."""
    t = np.asarray(t_s, dtype=float).reshape(-1)
    out = np.zeros(t.size, dtype=bool)
    if t.size >= 3:
        with np.errstate(invalid="ignore"):
            out[1:-1] = (t[1:-1] > t[2:]) & (t[2:] > t[:-2])
    return out
