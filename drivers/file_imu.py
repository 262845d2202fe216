"""An IMU recording as a live IMU: ``file:imu.csv?realtime=0`` (columns t,gx,gy,gz,ax,ay,az; rad/s, m/s²).

:func:`read_imu_file` is the one reader of imu.csv files (``walkmon live --imu file:...`` and ``walkmon analyze
--imu``): a CSV line has no checksum, so every row goes through the plausibility check of
:mod:`walkmon.drivers.imu_checks`; malformed and implausible rows are skipped and counted (one warning line
with the counts), and a file with too few plausible rows is refused.
"""

from __future__ import annotations

import logging
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from walkmon.consts import IMU_COLUMNS
from walkmon.drivers.imu_checks import plausible_rows
from walkmon.drivers.imu_types import ImuBatch, ImuSample
from walkmon.errors import InvalidInputError, SourceDisconnected, SourceError

__all__ = ["FileImu", "ImuFile", "read_imu_file"]

_log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class ImuFile:
    """The plausible rows of an imu.csv and the count of rows skipped per reason."""

    t_s: NDArray[np.float64]
    gyroscope_rad_s: NDArray[np.float64]
    accelerometer_m_s2: NDArray[np.float64]
    rejected: dict[str, int]

    @property
    def n_rejected(self) -> int:
        return sum(self.rejected.values())


def read_imu_file(path: str | Path, *, min_rows: int = 1) -> ImuFile:
    """Read imu.csv keeping only plausible rows (see the module docstring); InvalidInputError (one line) for
    an unreadable file or one with fewer than ``min_rows`` plausible rows."""
    rejected: Counter[str] = Counter()
    cols = read_table_skipping(path, rejected)
    t = cols["t"]
    gyro = np.column_stack([cols["gx"], cols["gy"], cols["gz"]]) if len(t) else np.zeros((0, 3))
    accel = np.column_stack([cols["ax"], cols["ay"], cols["az"]]) if len(t) else np.zeros((0, 3))
    n_total = len(t) + sum(rejected.values())  # rows read + rows read_table skipped as malformed
    keep, why = plausible_rows(t, gyro, accel)
    rejected.update(why)
    if rejected:
        _log.warning("%s: %d of %d IMU rows skipped as implausible (%s)", path, sum(rejected.values()), n_total,
                     ", ".join(f"{k} {v}" for k, v in sorted(rejected.items())))
    if int(keep.sum()) < min_rows:
        detail = f" ({', '.join(f'{k} {v}' for k, v in sorted(rejected.items()))})" if rejected else ""
        msg = (f"{path}: {int(keep.sum())} plausible IMU rows of {n_total}{detail}; need at least {min_rows} "
               "(a dead sensor reads all zeros; columns are t,gx,gy,gz,ax,ay,az in s, rad/s, m/s2)")
        raise InvalidInputError(msg)
    return ImuFile(t[keep], gyro[keep], accel[keep], dict(rejected))


def read_table_skipping(path: str | Path, rejected: Counter[str]) -> dict[str, NDArray[np.float64]]:
    """The imu.csv columns with malformed rows skipped and counted in ``rejected``."""
    from walkmon.tables import read_table  # noqa: PLC0415

    return read_table(path, IMU_COLUMNS, skip_bad_rows=True, rejected=rejected)


class FileImu:
    """Reads the whole CSV at open; ``read()`` returns the next sample (a batch of one) or raises
    SourceDisconnected at the end (an :class:`~walkmon.drivers.imu_types.ImuSource`)."""

    reconnectable = False

    def __init__(self, url: str, path: str, realtime: bool = False) -> None:
        self.url, self.path, self.realtime = url, path, realtime
        #: realtime=0 reads as fast as possible: the pipeline then takes samples up to each frame's time
        self.live = realtime
        self._rows: dict[str, Any] | None = None
        self.rejected: dict[str, int] = {}
        self._i = 0
        self._t0_mono = 0.0

    def open(self) -> None:
        try:
            f = read_imu_file(self.path, min_rows=0)  # all rows implausible: no sample, camera-only (counted)
        except (InvalidInputError, OSError) as exc:
            msg = f"{self.url}: {exc}"
            raise SourceError(msg) from exc
        #: rows of the file skipped as malformed or implausible, per reason
        self.rejected = dict(f.rejected)
        self._rows = {"t": f.t_s, **{c: f.gyroscope_rad_s[:, k] for k, c in enumerate(("gx", "gy", "gz"))},
                      **{c: f.accelerometer_m_s2[:, k] for k, c in enumerate(("ax", "ay", "az"))}}
        self._i = 0
        self._t0_mono = time.monotonic()

    def read(self) -> ImuBatch:
        if self._rows is None:
            msg = f"{self.url}: not open"
            raise SourceError(msg)
        r = self._rows
        if self._i >= len(r["t"]):
            msg = f"{self.url}: end of IMU recording"
            raise SourceDisconnected(msg)
        i = self._i
        self._i += 1
        t = float(r["t"][i])
        if self.realtime:
            delay = self._t0_mono + t - time.monotonic()
            if delay > 0:
                time.sleep(delay)
        gyr = (float(r["gx"][i]), float(r["gy"][i]), float(r["gz"][i]))
        acc = (float(r["ax"][i]), float(r["ay"][i]), float(r["az"][i]))
        return ImuBatch((ImuSample(t, gyr, acc),))

    def close(self) -> None:
        self._rows = None

    def __enter__(self) -> FileImu:
        self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
