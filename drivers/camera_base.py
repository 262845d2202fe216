"""What every camera driver delivers: :class:`Frame` objects from a :class:`CameraSource`.

A source is opened with :meth:`CameraSource.open`, read frame by frame with :meth:`CameraSource.read` (which
blocks at most about one frame period plus the driver's timeout), and closed with :meth:`CameraSource.close`;
it is also a context manager. :meth:`read` raises :class:`~walkmon.errors.SourceDisconnected` when the stream
ends or the device goes away, and :class:`~walkmon.errors.SourceTimeout` when no frame came in time. Frame
timestamps come from the capture (device clock, video position or simulation time), in seconds.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from walkmon.camera.model import CameraModel
from walkmon.errors import SourceError

__all__ = ["CameraSource", "Frame"]

_log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class Frame:
    """One captured image: capture time ``t_s``, BGR or grey uint8 ``image``, running ``index``.

    ``truth_angles_deg`` (pitch, yaw, roll) is only set by the simulator source.
    """

    t_s: float
    image: NDArray[np.uint8]
    index: int
    truth_angles_deg: tuple[float, float, float] | None = None


class CameraSource:
    """Base class of camera drivers; subclasses implement ``_open``, ``_read`` and ``_close``."""

    #: Whether the pipeline should try to reopen this source after a disconnect (real devices: yes).
    reconnectable: bool = False
    #: Whether frames arrive on their own clock (cameras, realtime replays): then the newest frame wins and
    #: late frames are dropped. A source read as fast as possible (``realtime=0``) gets back-pressure instead.
    live: bool = True
    #: Whether frame times are on the host's monotonic clock (V4L2's buffer times, the OAK's host-synchronised
    #: ones), as a serial IMU's samples are; a replay or the simulator count from its own start (the live
    #: pipeline then puts a host-clocked IMU on the frames' clock at the first frame).
    host_clock: bool = True

    def clock_origin_s(self) -> float | None:
        """For a source not on the host clock that releases its frames in real time: the host monotonic time its
        t = 0 stands for (a replay's or the simulator's start); None when it has none (read as fast as possible).
        """
        origin = getattr(self, "_t0_mono", None)
        return float(origin) if getattr(self, "realtime", False) and origin is not None else None

    def __init__(self, url: str) -> None:
        self.url = url
        self.fps: float = 0.0
        self._is_open = False

    @property
    def is_open(self) -> bool:
        return self._is_open

    def open(self) -> None:
        if self._is_open:
            msg = f"{self.url}: already open"
            raise SourceError(msg)
        self._open()
        self._is_open = True

    def read(self) -> Frame:
        if not self._is_open:
            msg = f"{self.url}: not open"
            raise SourceError(msg)
        return self._read()

    def close(self) -> None:
        if self._is_open:
            self._is_open = False
            try:
                self._close()
            except Exception:  # noqa: BLE001 - closing must not mask the reason we close
                _log.exception("%s: error while closing", self.url)

    def camera_model(self) -> CameraModel | None:
        """Intrinsics known to the source itself (simulator, OAK factory calibration), else ``None``."""
        return None

    def __enter__(self) -> CameraSource:
        self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _open(self) -> None:
        raise NotImplementedError

    def _read(self) -> Frame:
        raise NotImplementedError

    def _close(self) -> None:
        raise NotImplementedError
