"""The units of a recorded IMU file, checked from the data before anything is computed from it.

``imu.csv`` is documented as seconds, rad/s and m/s², but recordings from other tools come in other units: the
Mobilise-D files hold g and deg/s, many loggers and phones g, and a few milliseconds. Read as SI, an
accelerometer in g has a gravity of 1 m/s² and a gyroscope in deg/s turns 57 times too fast: the analysis then ran
and reported nothing (no step, no bout) or nonsense, with exit code 0. The data says which units they are, judged
on the rows that could be real in any of the units (finite, within every unit's sensor range, some gravity, time
stamps strictly later than every earlier such row: one corrupted or repeated row must not decide):

* **accelerometer**: a worn sensor feels gravity, so over a recording the median magnitude of the specific force
  is about 1 g (walking adds accelerations both ways; BROAD's hand-held trials 9.8-9.9, the Mobilise-D lower-back
  walks 9.6 m/s²). Between 0.5 and 2, with gravity in it (the 10th percentile at least 0.35 x the median; every
  recording at hand 0.5 or more, a phone's gravity-free 'linear acceleration', whose median can lie there too,
  0.13), it is in g; anything else is left as it is (the plausibility rules refuse a dead sensor).
* **gyroscope**: the accelerometer's own gravity direction ``u`` turns as the gyroscope says, ``du/dt = -w x u``
  (both low-passed at 1 Hz, the gyroscope's median, its bias, taken out first). Over the recording, the path the
  gyroscope gives that direction (the sum of ``|w x u|``) against the path the accelerometer shows (the sum of
  ``|du/dt|``; each without its highest 2 %, so that one corrupted row spread by the low-pass does not decide)
  is 0.19-1.47 in rad/s on every recording at hand (the Mobilise-D walks, BROAD's hand-held trials including the
  fast translations whose linear accelerations swamp gravity's direction, and 132 simulated walks) and 57.3
  times that in deg/s (10.9 and more): above 4.3, about the geometric middle of the gap, it is deg/s. Magnitudes
  only, so it holds where the two directions hardly correlate (a straight walk's small tilts: the least-squares
  scale of one against the other was tried first and missed two of the simulated walks in deg/s). A recording
  whose gravity direction hardly moves (95 % of it within 1.5 deg of the median: a sensor lying still; every
  walk and hand-held trial at hand tilts 2.5 deg or more) cannot tell, and nothing is converted (the documented
  rad/s): a quiet recording in deg/s is not recognised.
* **time**: an IMU sampled more slowly than 10 Hz cannot time steps; a median interval above 0.1 s is refused
  with a hint (milliseconds or nanoseconds are the usual cause) rather than guessed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from walkmon.consts import GRAVITY_MS2
from walkmon.errors import InvalidInputError

__all__ = ["Units", "infer_units"]

#: Gyroscope path over accelerometer path above this: deg/s (rad/s recordings 0.19-1.47, deg/s 10.9 and more).
_DEG_PATH_RATIO = 4.3
#: Below this 95th percentile tilt away from the median gravity direction (degrees) the recording is too still to
#: tell (a still sensor's noise: 0.1; every walk and hand-held trial at hand: 2.5 and more).
_MIN_TILT_DEG = 1.5
_MAX_INTERVAL_S = 0.1
#: Beyond any MEMS sensor in any of the units (4000 deg/s; 32 g in m/s2), or without gravity (0.01 g in m/s2).
_MAX_RATE = 4000.0
_MAX_ACC = 32.0 * GRAVITY_MS2
_MIN_ACC = 0.01 * GRAVITY_MS2
_MIN_GRAVITY_SHARE = 0.35


@dataclass(frozen=True, slots=True)
class Units:
    """Factors that bring a file's columns to m/s² and rad/s, and what was found (one line each, for the log)."""

    acc_scale: float = 1.0
    gyro_scale: float = 1.0
    notes: tuple[str, ...] = ()


def _path_ratio(t: np.ndarray, gyro: np.ndarray, acc: np.ndarray) -> float:
    """The path the gyroscope gives gravity's direction over the path the accelerometer shows (see the module
    text); nan when it cannot be measured (too few samples, below 2.5 Hz, too still)."""
    from scipy.signal import butter, sosfiltfilt  # noqa: PLC0415

    if len(t) < 30:
        return float("nan")
    fs = 1.0 / float(np.median(np.diff(t)))
    if fs <= 2.5:
        return float("nan")
    sos = butter(2, 1.0, fs=fs, output="sos")
    a = sosfiltfilt(sos, acc, axis=0)
    u = a / np.linalg.norm(a, axis=1, keepdims=True)
    centre = np.median(u, axis=0)
    centre /= float(np.linalg.norm(centre)) or 1.0
    if np.degrees(np.arccos(np.clip(np.percentile(u @ centre, 5), -1.0, 1.0))) < _MIN_TILT_DEG:
        return float("nan")  # gravity's direction hardly moves: too still to tell
    w = sosfiltfilt(sos, gyro - np.median(gyro, axis=0), axis=0)  # the bias out: it is no rotation
    shown = np.linalg.norm(np.gradient(u, t, axis=0), axis=1)
    given = np.linalg.norm(np.cross(w, u), axis=1)
    # the highest 2 % of each left out: one corrupted row (a rate of 500 'rad/s' the plausibility rules skip only
    # later) is spread over a second by the low-pass and must not decide the units of the whole file
    shown_sum = float(np.sum(shown[shown <= np.percentile(shown, 98)]))
    given_sum = float(np.sum(given[given <= np.percentile(given, 98)]))
    return given_sum / shown_sum if shown_sum > 0 else float("nan")


def _usable(t: np.ndarray, gyro: np.ndarray | None, acc: np.ndarray, *, in_order: bool = True) -> np.ndarray:
    """Rows that could be real in any of the units (finite, within every unit's sensor range, some gravity,
    time stamps strictly later than every earlier usable row unless ``in_order`` is False): one corrupted or
    repeated row must not decide."""
    ok = np.isfinite(t) & np.isfinite(acc).all(axis=1) & (np.abs(acc) <= _MAX_ACC).all(axis=1)
    if gyro is not None:
        ok &= np.isfinite(gyro).all(axis=1) & (np.abs(gyro) <= _MAX_RATE).all(axis=1)
    ok &= np.linalg.norm(np.where(ok[:, None], acc, 0.0), axis=1) >= _MIN_ACC
    if in_order:
        latest = np.maximum.accumulate(np.where(ok, t, -np.inf))
        ok &= t > np.r_[-np.inf, latest[:-1]]
    return ok


def infer_units(t_s: ArrayLike, gyro: ArrayLike | None, acc: ArrayLike, *, source: str = "IMU file") -> Units:
    """The factors to m/s² and rad/s of a recording's columns (see the module text); InvalidInputError (one
    line) for time stamps too far apart to be seconds of a gait recording."""
    t = np.asarray(t_s, dtype=float)
    a = np.asarray(acc, dtype=float)
    g = None if gyro is None else np.asarray(gyro, dtype=float)
    ok = _usable(t, g, a)
    notes: list[str] = []
    anyhow = _usable(t, g, a, in_order=False)  # rows out of order (shuffled) are the order check's to name
    if anyhow.sum() >= 2:
        dt = float(np.median(np.diff(np.unique(t[anyhow]))))  # (unique: rows written twice are no 0 s interval)
        if dt > _MAX_INTERVAL_S:
            msg = (f"{source}: samples {dt:g} apart on median ({1.0 / dt:.3g} per unit of t): t must be in seconds "
                   f"and the IMU sampled at 10 Hz or more (is t in milliseconds or nanoseconds?)")
            raise InvalidInputError(msg)
    acc_scale = 1.0
    if ok.sum() >= 10:
        mag = np.linalg.norm(a[ok], axis=1)
        med = float(np.median(mag))
        # in g only where gravity is in it: a phone's 'linear acceleration' (gravity taken out) has a median of
        # 0.3-1.5 m/s2 too, but keeps falling to near zero (10th percentile 0.13 x its median; with gravity
        # every recording at hand stays above 0.5 x)
        if 0.5 <= med <= 2.0 and float(np.percentile(mag, 10)) >= _MIN_GRAVITY_SHARE * med:
            acc_scale = GRAVITY_MS2
            notes.append(f"{source}: accelerometer in g (median magnitude {med:.2f}): converted to m/s2")
    gyro_scale = 1.0
    if g is not None and ok.sum() >= 10:
        ratio = _path_ratio(t[ok], g[ok], a[ok] * acc_scale)
        if ratio > _DEG_PATH_RATIO:
            gyro_scale = float(np.pi / 180.0)
            notes.append(f"{source}: gyroscope in deg/s (it turns gravity's direction {ratio:.3g} times as far as "
                         "the accelerometer sees it turn): converted to rad/s")
    return Units(acc_scale, gyro_scale, tuple(notes))
