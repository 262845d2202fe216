"""A video file as a camera: ``file:walk.mp4?realtime=1&loop=0``.

Wraps :class:`walkmon.drivers.video_file.VideoFile` (the reader ``walkmon analyze`` uses), so a frame's capture
time is its presentation time in the file exactly as offline and both analyses see the same frames and timestamps.
With ``realtime=1`` frames are released at their times on the monotonic clock, as if the camera were live
(frames are never skipped here: if the consumer is slow, the pipeline's frame queue drops them and counts).
With ``loop=1`` the file restarts at its end with time running on (long soak tests; 1/fps between the last frame
and the first again). ``fps=`` replays faster or slower: the file's times scaled by its mean rate over ``fps``
(a variable-rate file keeps its own rhythm, sped up). At the end of the file :meth:`read` raises
SourceDisconnected ("end of stream").
"""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import Any

from walkmon.drivers.camera_base import CameraSource, Frame
from walkmon.errors import InvalidInputError, SourceDisconnected, SourceError

__all__ = ["FileCamera"]

_log = logging.getLogger(__name__)


class FileCamera(CameraSource):
    def __init__(self, url: str, path: str, realtime: bool = False, loop: bool = False, fps: float = 0.0,
                 decode_threads: int = 1) -> None:
        super().__init__(url)
        self.path = Path(path)
        self.realtime = realtime
        self.live = realtime
        self.host_clock = False  # the video's own times
        self.loop = loop
        self._fps_override = fps
        self._decode_threads = decode_threads
        self._video: Any = None  # a VideoFile while open
        self._index = 0
        self._t_offset_s = 0.0
        self._last_t_s = 0.0
        self._t0_mono = 0.0
        self.rotation_deg = 0.0

    def _open_video(self):  # noqa: ANN202 - a VideoFile
        from walkmon.drivers.video_file import VideoFile  # noqa: PLC0415

        try:
            return VideoFile(self.path, decode_threads=self._decode_threads)
        except InvalidInputError as exc:
            raise SourceError(f"{self.url}: {exc}") from exc

    def _open(self) -> None:
        self._video = self._open_video()
        self.fps = self._fps_override or self._video.fps
        #: the file's display rotation, which its frames come turned by (VideoFile.rotation_deg)
        self.rotation_deg = self._video.rotation_deg
        self._t0_mono = time.monotonic()

    def _read(self) -> Frame:
        assert self._video is not None
        item = self._video.read()
        if item is None and self.loop and self._index > 0:
            self._video.close()
            self._t_offset_s = self._last_t_s + 1.0 / self.fps
            self._video = self._open_video()
            item = self._video.read()
        if item is None:
            msg = f"{self.url}: end of stream after {self._index} frames"
            raise SourceDisconnected(msg)
        t_in_file, image = item
        if self._fps_override:
            t_in_file *= self._video.fps / self._fps_override
        t_s = self._t_offset_s + t_in_file
        self._last_t_s = t_s
        if self.realtime:
            delay = self._t0_mono + t_s - time.monotonic()
            if delay > 0:
                time.sleep(delay)
        frame = Frame(t_s, image, self._index)
        self._index += 1
        return frame

    def _close(self) -> None:
        if self._video is not None:
            self._video.close()
            self._video = None
