"""Shared helpers of the gait tests: a synthetic trunk IMU with known steps, bouts and turns."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pytest

G = 9.80665


@dataclass(frozen=True)
class SyntheticImu:
    t: np.ndarray
    acc: np.ndarray  # m/s², sensor axes
    gyr: np.ndarray  # rad/s
    steps: np.ndarray  # true step (initial contact) times, s
    bouts: list[tuple[float, float]]  # true walking bouts (first to last step), s
    turns: list[tuple[float, float, float]]  # (start, end, angle deg)


def _make(
    plan: list[tuple[str, float]],
    *,
    step_s: float | tuple[float, float] = 0.55,
    turn_deg: float = 180.0,
    rate_hz: float = 100.0,
    noise: float = 0.15,
    seed: int = 0,
    up: tuple[float, float, float] = (0.0, -1.0, 0.0),
) -> SyntheticImu:
    """``plan``: ("stand"|"walk"|"turn", seconds) pieces in order; a turn is walked through (steps continue).
    ``step_s``: step duration, or (a, b) alternating durations (asymmetric gait). ``up``: the sensor axis that
    points up (camera frame: -y). ``turn_deg`` > 0 turns right (clockwise seen from above), as yaw does."""
    rng = np.random.default_rng(seed)
    total = sum(d for _, d in plan)
    t = np.arange(0.0, total, 1.0 / rate_hz)
    vert = np.zeros_like(t)
    heading_rate = np.zeros_like(t)
    steps: list[float] = []
    bouts: list[tuple[float, float]] = []
    turns: list[tuple[float, float, float]] = []
    durations = step_s if isinstance(step_s, tuple) else (step_s, step_s)
    t0 = 0.0
    k = 0
    bout_start = None
    ts = 0.0
    for kind, dur in plan:
        if kind in ("walk", "turn"):
            if bout_start is None:
                ts = t0 + 0.5 * durations[k % 2]
            while ts < t0 + dur:
                d = durations[k % 2]
                m = (t >= ts - 0.5 * d) & (t < ts + 0.5 * d)
                # one vertical bounce per step, peaking at the step, plus a smaller second harmonic
                vert[m] += 2.0 * np.cos(2 * np.pi * (t[m] - ts) / d) + 0.5 * np.cos(4 * np.pi * (t[m] - ts) / d)
                steps.append(ts)
                if bout_start is None:
                    bout_start = ts
                ts += d
                k += 1
            if kind == "turn":
                m = (t >= t0) & (t < t0 + dur)
                heading_rate[m] = np.radians(turn_deg) / dur * (1 - np.cos(2 * np.pi * (t[m] - t0) / dur))
                turns.append((t0, t0 + dur, turn_deg))
        elif bout_start is not None:
            bouts.append((bout_start, steps[-1]))
            bout_start = None
        t0 += dur
    if bout_start is not None:
        bouts.append((bout_start, steps[-1]))
    u = np.asarray(up, dtype=float)
    acc = (G + vert)[:, None] * u + rng.normal(0.0, noise, (t.size, 3))
    gyr = -heading_rate[:, None] * u + rng.normal(0.0, 0.01, (t.size, 3))  # about the down axis: > 0 turns right
    return SyntheticImu(t, acc, gyr, np.asarray(steps), bouts, turns)


@pytest.fixture
def synthetic_imu() -> Callable[..., SyntheticImu]:
    return _make
