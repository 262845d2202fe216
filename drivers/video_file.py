"""Reading a video file frame by frame: ``VideoFile(path)`` iterates ``(t_s, frame_bgr)``.

A frame's time is its presentation time in the container (``t`` starts at 0 with the first frame; two analyses of
one file agree). Phones record at a variable frame rate (fewer frames in dim light): ``i / fps`` with the
container's mean rate put frame 60 of a clip that went from 30 to 15 fps at 2.64 s instead of 2.00 s, and read
its cadence 24 % low then 51 % high. The reader decodes one frame ahead, so a frame's time is judged against both
its neighbours: an unusable one (none, which FFmpeg reports as 0; not after the frame before; more than
:func:`max_interval_s` after the last good one; or after the next frame's, which itself fits) is put halfway
between its neighbours, so one bad time moves no other frame (it had shifted the rest of a video: +100 s after
one corrupt time, +0.5 s after a missing one); when the next frame follows on from the bad one instead (joined
files, a reset clock), the times go on from ``1 / fps`` after the frame before with their own intervals. Such
frames are counted in ``times_guessed`` and, beyond the two a decoder's last buffered frames may lack, reported
in one warning line when the file is read to its end or closed. A real pause longer than :func:`max_interval_s`
inside one file is shortened to ``1 / fps`` (the frames after it are then early against an IMU's clock).
``decode_threads`` limits FFmpeg's decoder threads (1 for single-core benchmarks;
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
#: A frame more than this after the last good one is timed 1 / fps after the frame before instead (module
#: docstring), s: a phone in darkness records a few frames a second; a longer interval is a corrupt or reset time.
MAX_FRAME_INTERVAL_S = 1.0


def max_interval_s(fps: float) -> float:
    """The longest interval between frames taken as real: :data:`MAX_FRAME_INTERVAL_S`, or three frames of a
    slower video (a time-lapse)."""
    return max(MAX_FRAME_INTERVAL_S, 3.0 / fps)


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
        if not (math.isfinite(fps) and 0.1 <= fps <= 1000.0):
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
        self._index = 0  # frames returned
        self._decoded = 0  # frames decoded (one ahead of those returned)
        self._pts_first_s: float | None = None
        self._pts_span_s = 0.0  # the decoded frames' latest time from the first's (the damage check)
        self._ahead: tuple[float, NDArray[np.uint8]] | None | bool = False  # the next frame (False: none read yet)
        self._pts0_s: float | None = None  # the presentation time that is t = 0 (moved by a new time line)
        self._last_t_s = 0.0  # the frame before's time
        self._good_t_s = 0.0  # the last frame whose own time was used
        self._reported = False
        #: frames whose container time was unusable (none, going back, off the frames either side: module docstring)
        self.times_guessed = 0

    def read(self) -> tuple[float, NDArray[np.uint8]] | None:
        """The next ``(t_s, frame_bgr)``, or None at the end of the file."""
        if self._cap is None:
            msg = f"{self.path}: video is closed"
            raise SourceError(msg)
        if self._ahead is False:
            self._ahead = self._decode()
        current = self._ahead
        if not isinstance(current, tuple):
            return None
        self._ahead = self._decode()  # one frame ahead: a frame's time is judged against both its neighbours
        following = self._ahead[0] if isinstance(self._ahead, tuple) else None
        t_s = self._frame_time_s(current[0], following)
        self._index += 1
        return t_s, current[1]

    def _decode(self) -> tuple[float, NDArray[np.uint8]] | None:
        """The next decoded frame with its presentation time in the container (s; NaN when none), or None at the
        end of the file."""
        import cv2  # noqa: PLC0415

        assert self._cap is not None
        ok, frame = self._cap.read()
        if not ok or frame is None:
            if self._decoded == 0:
                msg = f"{self.path}: no decodable frames (corrupt or empty video)"
                raise SourceError(msg)
            span = self._pts_span_s + 1.0 / self.fps  # the decoded frames' time (a container's count may be an
            expected = self.frame_count / self.fps  # estimate from its duration, as an MPEG-TS's is)
            if (self._decoded < self.frame_count - max(2, self.frame_count // 100)
                    and span < expected - max(2.0 / self.fps, 0.01 * expected)):
                # the container lists more frames than could be decoded: damaged mid-file. Analysing the first
                # part as if it were the whole walk would be silently wrong, so it is an error.
                msg = (f"{self.path}: the video is damaged: decoding failed at frame {self._decoded} of "
                       f"{self.frame_count} ({self._decoded / self.fps:.1f} s of {self.frame_count / self.fps:.1f} s); "
                       "re-encode the readable part (e.g. ffmpeg -i VIDEO -c:v libx264 fixed.mp4) and analyse that")
                raise InvalidInputError(msg)
            return None
        self._decoded += 1
        pts = float(self._cap.get(cv2.CAP_PROP_POS_MSEC)) / 1000.0
        # FFmpeg reports a frame without a time as 0: only the first frame may have it
        pts = pts if math.isfinite(pts) and (pts != 0.0 or self._decoded == 1) else math.nan
        if math.isfinite(pts):
            self._pts_first_s = pts if self._pts_first_s is None else self._pts_first_s
            self._pts_span_s = max(self._pts_span_s, pts - self._pts_first_s)
        return pts, frame

    def _frame_time_s(self, pts: float, following: float | None) -> float:
        """A frame's time from its presentation time ``pts`` and the next frame's (``following``; None at the end):
        module docstring."""
        if self._pts0_s is None:
            self._pts0_s = pts if math.isfinite(pts) else 0.0
            return 0.0
        limit, step = max_interval_s(self.fps), 1.0 / self.fps
        last, good = self._last_t_s, self._good_t_s
        t = pts - self._pts0_s
        nxt = math.nan if following is None else following - self._pts0_s

        def fits(x: float) -> bool:  # after the frame before, and not too far after the last good one
            return math.isfinite(x) and last < x <= good + limit

        if fits(t) and not (fits(nxt) and nxt < t):
            self._last_t_s = self._good_t_s = t  # its own time (the next frame's, if any, comes after it)
            return t
        self.times_guessed += 1
        if fits(nxt) and nxt - last > 1e-9:
            t = 0.5 * (last + nxt)  # one bad time between two that fit: between them
        elif math.isfinite(pts) and following is not None and 0.0 < following - pts <= limit:
            # the next frame follows on from this one, not from the frames before: a new time line (joined files,
            # a reset clock); it goes on from here with its own intervals
            t = last + step
            self._pts0_s = pts - t
            self._good_t_s = t
        else:
            t = last + step
        self._last_t_s = t
        return t

    def _report_guessed(self) -> None:
        if self.times_guessed > 2 and not self._reported:  # a decoder's last buffered frames may lack a time
            self._reported = True
            _log.warning("%s: %d frames had no usable time in the container (none, going back, or over %g s after "
                         "the one before): each timed 1/%g s after the frame before it", self.path,
                         self.times_guessed, max_interval_s(self.fps), self.fps)

    def __iter__(self) -> Iterator[tuple[float, NDArray[np.uint8]]]:
        while (item := self.read()) is not None:
            yield item
        self._report_guessed()

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
