"""Reading a video file frame by frame: ``VideoFile(path)`` iterates ``(t_s, frame_bgr)``.

A frame's time is its presentation time in the container (``t`` starts at 0 with the first frame; two analyses of
one file agree). Phones record at a variable frame rate (fewer frames in dim light): ``i / fps`` with the
container's mean rate put frame 60 of a clip that went from 30 to 15 fps at 2.64 s instead of 2.00 s, and read
its cadence 24 % low then 51 % high. Where the container gives no usable time for a frame (none, not after the
previous frame's, or more than :data:`MAX_FRAME_INTERVAL_S` after it: a reset or a corrupt time), that frame is
``1 / fps`` after the previous one and the frames after it keep their own intervals from there (one bad time
does not shift the rest of the video, and joined files do not fall back to ``1 / fps``); such frames are counted
in ``times_guessed`` and, beyond the two a decoder's last buffered frames may lack, logged once at the end. A missing file raises :class:`~walkmon.errors.InvalidInputError`; a
file OpenCV cannot open or that yields no frame raises :class:`~walkmon.errors.SourceError`; a file whose
decoding stops well before the frame count its container lists (damaged mid-file) raises
:class:`~walkmon.errors.InvalidInputError` when the reader gets there; all carry one line naming the file. ``decode_threads`` limits FFmpeg's decoder threads (1 for single-core benchmarks;
0 lets FFmpeg choose).
"""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Iterator
from pathlib import Path
from types import TracebackType

import numpy as np
from numpy.typing import NDArray

from walkmon.errors import InvalidInputError, SourceError

__all__ = ["DEFAULT_FPS", "VideoFile"]

_log = logging.getLogger(__name__)

#: Frame rate assumed when the container does not give a plausible one.
DEFAULT_FPS = 30.0
#: A frame more than this after the previous one is timed 1 / fps after it instead (module docstring), s: a phone
#: in darkness records a few frames a second; a longer interval is a corrupt or reset time, not a pause.
MAX_FRAME_INTERVAL_S = 1.0


class VideoFile:
    """An open video file. Iterate for ``(t_s, frame)``; use as a context manager or call :meth:`close`."""

    def __init__(self, path: str | Path, *, decode_threads: int = 0) -> None:
        import cv2  # noqa: PLC0415

        # FFmpeg prints its own lines ("moov atom not found") straight to stderr; users get our one line
        # instead. Set OPENCV_FFMPEG_LOGLEVEL yourself to see them (it is only defaulted here).
        os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")
        self.path = Path(path)
        if not self.path.exists():
            msg = f"{self.path}: no such video file"
            raise InvalidInputError(msg)
        if not self.path.is_file():
            msg = f"{self.path}: not a file"
            raise InvalidInputError(msg)
        params = [cv2.CAP_PROP_N_THREADS, int(decode_threads)] if decode_threads > 0 else []
        cap = cv2.VideoCapture(str(self.path), cv2.CAP_ANY, params)
        if not cap.isOpened():
            cap.release()
            msg = f"{self.path}: cannot open as a video (unknown format or corrupt file)"
            raise SourceError(msg)
        fps = float(cap.get(cv2.CAP_PROP_FPS) or 0.0)
        if not (math.isfinite(fps) and 1.0 <= fps <= 1000.0):
            _log.warning("%s: container reports %.3g fps; assuming %g", self.path, fps, DEFAULT_FPS)
            fps = DEFAULT_FPS
        self.fps = fps
        self.width_px = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH))
        self.height_px = int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
        #: Frame count from the container header (may be 0 or approximate for some formats).
        self.frame_count = max(0, int(cap.get(cv2.CAP_PROP_FRAME_COUNT)))
        #: The file's display rotation, degrees clockwise (a phone's portrait video: 90), which OpenCV applies to
        #: the frames (and to ``width_px``/``height_px``): a calibration made on the unturned frames is turned to
        #: fit (:func:`walkmon.camera.model.camera_for_frames`). 0 when the file gives none.
        rotation = float(cap.get(cv2.CAP_PROP_ORIENTATION_META) or 0.0)
        self.rotation_deg = float(round(rotation / 90.0) * 90 % 360) if math.isfinite(rotation) else 0.0
        self._cap = cap
        self._index = 0
        self._pts0_s: float | None = None  # the presentation time that is t = 0 (moved by a bad time)
        self._last_t_s = 0.0
        #: frames whose container time was missing or not after the previous frame's (timed 1 / fps after it)
        self.times_guessed = 0

    def read(self) -> tuple[float, NDArray[np.uint8]] | None:
        """The next ``(t_s, frame_bgr)``, or None at the end of the file."""
        if self._cap is None:
            msg = f"{self.path}: video is closed"
            raise SourceError(msg)
        ok, frame = self._cap.read()
        if not ok or frame is None:
            if self._index == 0:
                msg = f"{self.path}: no decodable frames (corrupt or empty video)"
                raise SourceError(msg)
            if self._index < self.frame_count - max(2, self.frame_count // 100):
                # the container lists more frames than could be decoded: damaged mid-file. Analysing the first
                # part as if it were the whole walk would be silently wrong, so it is an error.
                msg = (f"{self.path}: the video is damaged: decoding failed at frame {self._index} of "
                       f"{self.frame_count} ({self._index / self.fps:.1f} s of {self.frame_count / self.fps:.1f} s); "
                       "re-encode the readable part (e.g. ffmpeg -i VIDEO -c:v libx264 fixed.mp4) and analyse that")
                raise InvalidInputError(msg)
            return None
        t_s = self._frame_time_s()
        self._index += 1
        return t_s, frame

    def _frame_time_s(self) -> float:
        """The frame just read: its presentation time from the first frame's (module docstring)."""
        import cv2  # noqa: PLC0415

        assert self._cap is not None
        pts = float(self._cap.get(cv2.CAP_PROP_POS_MSEC)) / 1000.0
        if self._pts0_s is None:
            self._pts0_s = pts if math.isfinite(pts) else 0.0
            self._last_t_s = 0.0
            return 0.0
        t = pts - self._pts0_s
        if not (math.isfinite(t) and 0.0 < t - self._last_t_s <= max(MAX_FRAME_INTERVAL_S, 2.0 / self.fps)):
            self.times_guessed += 1
            t = self._last_t_s + 1.0 / self.fps
            if math.isfinite(pts):
                self._pts0_s = pts - t  # the frames after it keep their own intervals from here
        self._last_t_s = t
        return t

    def _report_guessed(self) -> None:
        if self.times_guessed > 2:  # a decoder's last buffered frames may lack a time (an AVI with B-frames)
            _log.warning("%s: %d frames had no usable time in the container (none, going back, or over %g s after "
                         "the frame before): each timed 1/%g s after the frame before it", self.path,
                         self.times_guessed, MAX_FRAME_INTERVAL_S, self.fps)

    def __iter__(self) -> Iterator[tuple[float, NDArray[np.uint8]]]:
        while (item := self.read()) is not None:
            yield item

    def close(self) -> None:
        if self._cap is not None:
            self._cap.release()
            self._cap = None
            self._report_guessed()

    def __enter__(self) -> VideoFile:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()
