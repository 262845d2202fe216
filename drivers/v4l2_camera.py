"""USB/CSI cameras through Video4Linux2 (OpenCV ``CAP_V4L2``): ``v4l2:/dev/video0?width=640&height=480&fps=30``.

Timestamps: the driver's buffer timestamp (``CAP_PROP_POS_MSEC``) when it gives one, else the monotonic clock
when the frame was dequeued. A failed read (unplugged camera) raises SourceDisconnected; the pipeline reopens
the device with backoff (``reconnectable``).
"""

from __future__ import annotations

import logging
import os
import time

from walkmon.drivers.camera_base import CameraSource, Frame
from walkmon.errors import SourceDisconnected, SourceError

__all__ = ["V4l2Camera"]

_log = logging.getLogger(__name__)


class V4l2Camera(CameraSource):
    reconnectable = True

    def __init__(self, url: str, device: str, width: int = 640, height: int = 480, fps: float = 30.0) -> None:
        super().__init__(url)
        self.device = device
        self.width, self.height, self.fps = width, height, fps
        self._cap = None
        self._index = 0
        self._t0_ms: float | None = None

    def _open(self) -> None:
        import cv2  # noqa: PLC0415

        target: int | str = int(self.device) if self.device.isdigit() else self.device
        if isinstance(target, str) and not os.path.exists(target):
            # said here in one line: OpenCV would first print a warning of its own about the missing device
            msg = f"{self.url}: no such device {self.device} (is the camera plugged in?)"
            raise SourceError(msg)
        cap = cv2.VideoCapture(target, cv2.CAP_V4L2)
        if not cap.isOpened():
            cap.release()
            msg = f"{self.url}: cannot open {self.device} (is the camera plugged in, and is it a V4L2 device?)"
            raise SourceError(msg)
        cap.set(cv2.CAP_PROP_FRAME_WIDTH, self.width)
        cap.set(cv2.CAP_PROP_FRAME_HEIGHT, self.height)
        cap.set(cv2.CAP_PROP_FPS, self.fps)
        cap.set(cv2.CAP_PROP_BUFFERSIZE, 1)
        got = (int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT)))
        if got != (self.width, self.height):
            _log.warning("%s: asked for %dx%d, camera gives %dx%d", self.url, self.width, self.height, *got)
        self._cap = cap
        self._t0_ms = None

    def _read(self) -> Frame:
        import cv2  # noqa: PLC0415

        assert self._cap is not None
        ok, image = self._cap.read()
        now = time.monotonic()
        if not ok or image is None:
            msg = f"{self.url}: camera stopped delivering frames (unplugged?)"
            raise SourceDisconnected(msg)
        pos_ms = float(self._cap.get(cv2.CAP_PROP_POS_MSEC) or 0.0)
        t_s = pos_ms / 1000.0 if pos_ms > 0 else now
        frame = Frame(t_s, image, self._index)
        self._index += 1
        return frame

    def _close(self) -> None:
        if self._cap is not None:
            self._cap.release()
            self._cap = None
