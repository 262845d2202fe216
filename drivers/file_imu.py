"""An IMU recording as a live IMU: ``file:imu.csv?realtime=0`` (columns t,gx,gy,gz,ax,ay,az; rad/s, m/s²)."""

from __future__ import annotations

import time

from walkmon.drivers.imu_types import ImuSample

from walkmon.consts import IMU_COLUMNS
from walkmon.errors import SourceDisconnected, SourceError

__all__ = ["FileImu"]


class FileImu:
    """Reads the whole CSV at open; ``read()`` returns the next sample or raises SourceDisconnected at the end."""

    reconnectable = False

    def __init__(self, url: str, path: str, realtime: bool = False) -> None:
        self.url, self.path, self.realtime = url, path, realtime
        #: realtime=0 reads as fast as possible: the pipeline then takes samples up to each frame's time
        self.live = realtime
        self._rows: dict[str, object] | None = None
        self._i = 0
        self._t0_mono = 0.0

    def open(self) -> None:
        from walkmon.errors import InvalidInputError  # noqa: PLC0415
        from walkmon.tables import read_table  # noqa: PLC0415

        try:
            self._rows = read_table(self.path, IMU_COLUMNS)
        except (InvalidInputError, OSError) as exc:
            msg = f"{self.url}: {exc}"
            raise SourceError(msg) from exc
        self._i = 0
        self._t0_mono = time.monotonic()

    def read(self) -> ImuSample:
        if self._rows is None:
            msg = f"{self.url}: not open"
            raise SourceError(msg)
        r = self._rows
        if self._i >= len(r["t"]):  # type: ignore[arg-type]
            msg = f"{self.url}: end of IMU recording"
            raise SourceDisconnected(msg)
        i = self._i
        self._i += 1
        t = float(r["t"][i])  # type: ignore[index]
        if self.realtime:
            delay = self._t0_mono + t - time.monotonic()
            if delay > 0:
                time.sleep(delay)
        return ImuSample(t, tuple(float(r[c][i]) for c in ("gx", "gy", "gz")),  # type: ignore[arg-type,index]
                         tuple(float(r[c][i]) for c in ("ax", "ay", "az")))  # type: ignore[index]

    def close(self) -> None:
        self._rows = None

    def __enter__(self) -> FileImu:
        self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
