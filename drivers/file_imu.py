"""An IMU recording as a live IMU: ``file:imu.csv?realtime=0`` (columns t,gx,gy,gz,ax,ay,az; rad/s, m/s², or g
and deg/s, recognised from the data).

:func:`walkmon.tables.read_imu_file` is the one reader of imu.csv files (``walkmon live --imu file:...`` and ``walkmon analyze
--imu``): its units are checked from the data first (:mod:`walkmon.imu.units`: g and deg/s converted, with a
warning line each; time stamps that cannot be seconds refused); a CSV line has no checksum, so every row goes
through the plausibility check of :mod:`walkmon.drivers.imu_checks`; malformed and implausible rows are skipped
and counted (one warning line with the counts), and a file with too few plausible rows is refused.
"""

from __future__ import annotations

import logging
import time
from typing import Any

from walkmon.drivers.imu_types import ImuBatch, ImuSample
from walkmon.errors import InvalidInputError, SourceDisconnected, SourceError
from walkmon.tables import ImuFile, read_imu_file

__all__ = ["FileImu", "ImuFile", "read_imu_file"]  # ImuFile, read_imu_file: from walkmon.tables (the file I/O module)

_log = logging.getLogger(__name__)


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
