"""Luxonis OAK cameras through the depthai v3 API: ``depthai:`` or ``depthai:DEVICE_ID?width=640&height=480``.

depthai is optional (``pip install walkmon[depthai]``) and imported only when the source is opened. The
device search is bounded by ``timeout_s`` (default 3 s, also exported as ``DEPTHAI_SEARCH_TIMEOUT`` before
the import), so a missing device fails within a few seconds with a clear message. Timestamps are the
device's capture timestamps synchronised to the host's monotonic clock (``ImgFrame.getTimestamp()``).
"""

from __future__ import annotations

import datetime as _dt
import logging
import os
import time

from walkmon.drivers.camera_base import CameraSource, Frame
from walkmon.errors import SourceDisconnected, SourceError, SourceTimeout

__all__ = ["DepthaiCamera", "import_depthai"]

_log = logging.getLogger(__name__)


def import_depthai(search_timeout_s: float = 3.0):  # noqa: ANN201 - the depthai module
    """Import depthai lazily, with a bounded device search; SourceError with the install hint if missing."""
    os.environ.setdefault("DEPTHAI_SEARCH_TIMEOUT", str(int(search_timeout_s * 1000)))
    try:
        import depthai  # noqa: PLC0415
    except ImportError as exc:
        msg = "depthai: the depthai package is not installed (pip install 'walkmon[depthai]')"
        raise SourceError(msg) from exc
    return depthai


class DepthaiCamera(CameraSource):
    reconnectable = True

    def __init__(self, url: str, device_id: str = "", width: int = 640, height: int = 480, fps: float = 30.0,
                 timeout_s: float = 3.0) -> None:
        super().__init__(url)
        self.device_id = device_id
        self.width, self.height, self.fps = width, height, fps
        self.timeout_s = timeout_s
        self._pipeline = None
        self._queue = None
        self._index = 0

    def _open(self) -> None:
        dai = import_depthai(self.timeout_s)
        timeout = _dt.timedelta(seconds=self.timeout_s)
        try:
            if self.device_id:
                info = dai.DeviceInfo(self.device_id)
            else:
                found, info = dai.Device.getAnyAvailableDevice(timeout)
                if not found:
                    msg = f"{self.url}: no OAK device found within {self.timeout_s:g} s (plugged in? udev rule?)"
                    raise SourceError(msg)
            device = dai.Device(info)
            pipeline = dai.Pipeline(device)
            cam = pipeline.create(dai.node.Camera).build()
            out = cam.requestOutput((self.width, self.height), type=dai.ImgFrame.Type.BGR888i, fps=self.fps)
            self._queue = out.createOutputQueue(maxSize=4, blocking=False)
            pipeline.start()
            self._pipeline = pipeline
        except SourceError:
            raise
        except Exception as exc:  # depthai raises RuntimeError for most device problems
            msg = f"{self.url}: cannot start the OAK camera: {exc}"
            raise SourceError(msg) from exc

    def _read(self) -> Frame:
        assert self._queue is not None and self._pipeline is not None
        if not self._pipeline.isRunning():
            msg = f"{self.url}: the OAK pipeline stopped (device unplugged?)"
            raise SourceDisconnected(msg)
        deadline = time.monotonic() + max(1.0, 3.0 / max(self.fps, 1.0))
        msg_ = None
        try:
            while msg_ is None and time.monotonic() < deadline:
                msg_ = self._queue.tryGet()  # polled: portable across depthai 3.x bindings
                if msg_ is None:
                    time.sleep(0.002)
        except Exception as exc:
            msg = f"{self.url}: lost the OAK device: {exc}"
            raise SourceDisconnected(msg) from exc
        if msg_ is None:
            msg = f"{self.url}: no frame within the timeout"
            raise SourceTimeout(msg)
        image = msg_.getCvFrame()
        t_s = msg_.getTimestamp().total_seconds()
        frame = Frame(t_s, image, self._index)
        self._index += 1
        return frame

    def _close(self) -> None:
        if self._pipeline is not None:
            try:
                self._pipeline.stop()
            finally:
                self._pipeline = None
                self._queue = None
