"""Timestamps of a streamed IMU on the host's monotonic clock, the clock the live camera's frames are on.

Two problems of real serial IMUs (user review, reproduced on pseudo-terminals):

* **Device clocks** (a CSV stream's ``t`` column: a microcontroller's ``millis()``/``micros()``) count from the
  device's power-up, not on the host's clock: fused with a V4L2 camera, no frame ever had an IMU sample near it.
  They restart when the device reboots and wrap (``micros()`` every 71.6 min); before this every later sample read
  as going back in time and was refused for the rest of the session. :class:`DeviceClock` maps device times onto
  the host clock with the smallest delay seen (``arrival - device time``, its minimum over ``window_s``: the
  transfer's fixed latency, and it follows a device clock's drift), and starts a new mapping when the device time
  jumps back by more than ``restart_s`` or ahead by more than ``jump_s`` (``restarts``).
* **Chunks**: a USB serial adapter delivers bytes in chunks (a 16 ms latency timer), and samples without a device
  clock were all given the chunk's arrival time: at 200 Hz three samples shared one time stamp and the fusion kept
  one of them. :class:`ChunkStamps` spreads the samples of one chunk back from its arrival at the stream's sample
  interval (a running estimate of arrival time per sample), each after the one before.
"""

from __future__ import annotations

import collections
import dataclasses
import math

from walkmon.drivers.imu_checks import CLOCK_RESTART_SAMPLES
from walkmon.drivers.imu_types import ImuSample

__all__ = ["ChunkStamps", "DeviceClock"]

#: The smallest step between two samples made distinct (s).
_EPS_S = 1e-6


class DeviceClock:
    """Device time (s) -> host time (s) of one stream (see the module docstring)."""

    def __init__(self, window_s: float = 30.0, restart_s: float = 1.0, jump_s: float = 60.0,
                 ahead_s: float = 0.02) -> None:
        self.window_s, self.restart_s, self.jump_s, self.ahead_s = window_s, restart_s, jump_s, ahead_s
        self.restarts = 0
        self._delays: collections.deque[tuple[float, float]] = collections.deque()  # (arrival, offset), offset rising
        self._last_device: float | None = None
        self._last_out = -math.inf
        self._ahead_run = 0

    def ahead(self, device_t_s: float, arrival_s: float) -> bool:
        """True for a sample the current mapping would place more than ``ahead_s`` after its own arrival: a time
        corrupted forward by less than ``restart_s`` (its delay, the smallest ever seen, would have become the
        mapping's and placed every sample up to that much early for ``window_s``: review). Refuse it; the
        :data:`~walkmon.drivers.imu_checks.CLOCK_RESTART_SAMPLES`-th in a row is a clock set forward: a new
        mapping from it (``restarts``)."""
        if not self._delays or device_t_s + self._delays[0][1] <= arrival_s + self.ahead_s:
            self._ahead_run = 0
            return False
        self._ahead_run += 1
        if self._ahead_run < CLOCK_RESTART_SAMPLES:
            return True
        self._delays.clear()
        self.restarts += 1
        self._last_out = -math.inf
        self._last_device = None
        self._ahead_run = 0
        return False

    def host_times(self, device_t_s: list[float], arrival_s: float) -> list[float]:
        """The host times of the samples of one read, timed ``device_t_s`` by the device, that arrived at
        ``arrival_s``: the read's last sample waited least, so all of the read's delays count before any is
        mapped (one by one, a read's first samples were mapped to its arrival)."""
        out: list[float] = []
        start = 0
        for i, d in enumerate(device_t_s):
            last = self._last_device
            if last is not None and not (last - self.restart_s <= d <= last + self.jump_s):
                out += self._map(device_t_s[start:i], arrival_s)  # before the restart: the old mapping
                self._delays.clear()  # rebooted, wrapped or a corrupted time: a new mapping from here
                self.restarts += 1
                self._last_out = -math.inf
                start = i
            self._last_device = d
        return out + self._map(device_t_s[start:], arrival_s)

    def _map(self, device_t_s: list[float], arrival_s: float) -> list[float]:
        if not device_t_s:
            return []
        for d in device_t_s:
            offset = arrival_s - d
            while self._delays and self._delays[-1][1] >= offset:
                self._delays.pop()
            self._delays.append((arrival_s, offset))
        while self._delays[0][0] < arrival_s - self.window_s:
            self._delays.popleft()
        out = []
        prev_d = None
        for d in device_t_s:
            t = d + self._delays[0][1]
            if t <= self._last_out and (prev_d is None or d > prev_d):
                # a smaller delay seen just now moved the mapping back: the device says this sample is later
                t = self._last_out + _EPS_S
            self._last_out = max(self._last_out, t)
            prev_d = d
            out.append(t)
        return out


class ChunkStamps:
    """Spreads the host-timed samples of one read (all stamped with its arrival) over the time they took."""

    def __init__(self) -> None:
        self._interval_s: float | None = None
        self._last_arrival: float | None = None
        self._last_out = -math.inf

    def spread(self, samples: list[ImuSample], arrival_s: float) -> list[ImuSample]:
        """``samples`` with those stamped ``arrival_s`` given times that end there, one interval apart, each
        after the one before; samples with a time of their own (a device clock mapped) are left as they are."""
        host = [i for i, s in enumerate(samples) if s.t_s == arrival_s]
        if not host:
            return samples
        n = len(host)
        if self._last_arrival is not None and arrival_s > self._last_arrival:
            per = (arrival_s - self._last_arrival) / n
            self._interval_s = per if self._interval_s is None else 0.9 * self._interval_s + 0.1 * per
        self._last_arrival = arrival_s
        step = self._interval_s or 0.0
        out = list(samples)
        for k, i in enumerate(host):
            t = max(arrival_s - (n - 1 - k) * step, self._last_out + _EPS_S)
            self._last_out = t
            out[i] = dataclasses.replace(samples[i], t_s=t)
        return out
