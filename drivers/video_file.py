"""Reading a video file frame by frame: ``VideoFile(path)`` iterates ``(t_s, frame_bgr)``.

A frame's time is its presentation time in the container (``t`` starts at 0 with the first frame; two analyses of
one file agree). Phones record at a variable frame rate (fewer frames in dim light): ``i / fps`` with the
container's mean rate put frame 60 of a clip that went from 30 to 15 fps at 2.64 s instead of 2.00 s, and read
its cadence 24 % low then 51 % high. The reader decodes :data:`LOOKAHEAD_FRAMES` frames ahead and judges each
frame's time against the frames before and after it: an unusable one (none, which FFmpeg reports as 0; not after
the frame before; more than :func:`max_interval_s` after the last good one; or later than most of the frames
after it) is spread evenly between the good times either side, so a short run of bad times moves no other frame
(one corrupt time 100 s late had shifted the rest of a video by 100 s; a missing one, or two late ones, by a few
tenths of a second). When no good time follows within the look-ahead but the next frame follows on from the bad
one (joined files, a reset clock), the times go on from ``1 / fps`` after the frame before with their own
intervals. Such frames are counted in ``times_guessed`` and, beyond the two a decoder's last buffered frames may
lack, reported in one warning line when the file is read to its end or closed. A real pause longer than
:func:`max_interval_s` inside one file is shortened to ``1 / fps`` (the frames after it are then early against an
IMU's clock), and the last frame's time cannot be checked against a later one.

A file that decodes to fewer frames than its container lists is damaged and refused, unless an MP4/MOV edit
list says so: a clip trimmed without re-encoding (a phone's trim, ``ffmpeg -ss ... -c copy``) keeps all the
samples from the keyframe before its cut and shows only the edited part, which is what FFmpeg decodes. The
frames expected are then the samples the edits show (:func:`walkmon.drivers.mp4_edits.shown_video_frames`).
``decode_threads`` limits FFmpeg's decoder threads (1 for single-core benchmarks;
0 lets FFmpeg choose).
"""

from __future__ import annotations

import collections
import logging
import math
import os
from collections.abc import Iterator
from pathlib import Path
from types import TracebackType

import numpy as np
from numpy.typing import NDArray

from walkmon.drivers.mp4_edits import shown_video_frames
from walkmon.errors import InvalidInputError, SourceError

__all__ = ["DEFAULT_FPS", "VideoFile"]

_log = logging.getLogger(__name__)

#: Frame rate assumed when the container does not give a plausible one.
DEFAULT_FPS = 30.0
#: A frame more than this after the last good one has a bad time (module docstring), s: a phone in darkness
#: records a few frames a second; a longer interval is a corrupt or reset time.
MAX_FRAME_INTERVAL_S = 1.0
#: Frames decoded ahead of the one returned: a run of up to this many frames with bad times is found as such (its
#: frames put between the good times either side) instead of being taken for a new time line.
LOOKAHEAD_FRAMES = 4


#: First box types of an ISO base media / QuickTime file (an older MOV starts with 'wide', 'moov' or 'mdat', not
#: 'ftyp': review)
_ISO_FIRST_BOXES = (b"ftyp", b"moov", b"mdat", b"wide", b"free", b"skip", b"pnot")


def _is_iso_media(path: Path) -> bool:
    """An ISO base media or QuickTime file (MP4, MOV, 3GP), whose header lists its frames."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(12)
    except OSError:
        return False
    return len(head) >= 8 and head[4:8] in _ISO_FIRST_BOXES


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
        #: Whether that count is the frames' own (an MP4 / MOV lists its samples), not one made from the duration (an
        #: MKV's, a TS's): a pause in the frames' times then says nothing about frames missing
        self.count_is_exact = _is_iso_media(self.path)
        shown = shown_video_frames(self.path, fps)
        if shown is not None and self.frame_count:
            # an edit list shows part of the samples (a trim without re-encoding): those frames are the video
            self.frame_count = min(self.frame_count, shown)
        #: The file's display rotation, degrees clockwise (a phone's portrait video: 90), which OpenCV applies to
        #: the frames (and to ``width_px``/``height_px``): a calibration made on the unturned frames is turned to
        #: fit (:func:`walkmon.camera.model.camera_for_frames`). 0 when the file gives none.
        rotation = float(cap.get(cv2.CAP_PROP_ORIENTATION_META) or 0.0)
        self.rotation_deg = float(round(rotation / 90.0) * 90 % 360) if math.isfinite(rotation) else 0.0
        self._cap = cap
        self._index = 0  # frames returned
        self._decoded = 0  # frames decoded (up to LOOKAHEAD_FRAMES ahead of those returned)
        self._ahead: collections.deque[tuple[float, NDArray[np.uint8]]] = collections.deque()
        self._eof = False
        self._pts0_s: float | None = None  # the presentation time that is t = 0 (moved by a new time line)
        self._last_t_s = 0.0  # the frame before's time
        self._skipped_s = 0.0  # forward jumps over max_interval_s that became a new time line (a pause in the file)
        self._good_t_s = 0.0  # the last frame whose own time was used
        self._reported = False
        #: frames whose container time was unusable (none, going back, off the frames either side: module docstring)
        self.times_guessed = 0

    def read(self) -> tuple[float, NDArray[np.uint8]] | None:
        """The next ``(t_s, frame_bgr)``, or None at the end of the file."""
        if self._cap is None:
            msg = f"{self.path}: video is closed"
            raise SourceError(msg)
        while not self._eof and len(self._ahead) <= LOOKAHEAD_FRAMES:  # a frame's time is judged against those after
            item = self._decode()
            if item is None:
                self._eof = True
            else:
                self._ahead.append(item)
        if not self._ahead:
            self._check_complete()
            return None
        pts, frame = self._ahead.popleft()
        t_s = self._frame_time_s(pts, [p for p, _ in self._ahead])
        self._index += 1
        return t_s, frame

    def _decode(self) -> tuple[float, NDArray[np.uint8]] | None:
        """The next decoded frame with its presentation time in the container (s; NaN when none), or None at the
        end of the file."""
        import cv2  # noqa: PLC0415

        assert self._cap is not None
        ok, frame = self._cap.read()
        if not ok or frame is None:
            return None
        self._decoded += 1
        pts = float(self._cap.get(cv2.CAP_PROP_POS_MSEC)) / 1000.0
        # FFmpeg reports a frame without a time as 0: only the first frame may have it
        return (pts if math.isfinite(pts) and (pts != 0.0 or self._decoded == 1) else math.nan), frame

    def _check_complete(self) -> None:
        """At the end: refuse a file with no frame, or one that ends well before its container says (damaged)."""
        if self._decoded == 0:
            msg = f"{self.path}: no decodable frames (corrupt or empty video)"
            raise SourceError(msg)
        # the frames' time (a container's count may be an estimate from its duration, as an MPEG-TS's is), with the
        # pauses forward over max_interval_s that became new time lines: the duration an MKV's or a TS's count comes
        # from holds them (user review: a 1.2 s gap in an MKV, whole, refused as damaged; the same frames in an MP4,
        # whose count is the frames', analysed)
        # (review: for an MP4, whose count is its frames', the pause hid half the frames missing: not there)
        span = self._last_t_s + (0.0 if self.count_is_exact else self._skipped_s) + 1.0 / self.fps
        expected = self.frame_count / self.fps
        if (self._decoded < self.frame_count - max(2, self.frame_count // 100)
                and span < expected - max(2.0 / self.fps, 0.01 * expected)):
            # the container lists more frames than could be decoded: damaged mid-file. Analysing the first part as
            # if it were the whole walk would be silently wrong, so it is an error.
            msg = (f"{self.path}: the video is damaged: decoding failed at frame {self._decoded} of "
                   f"{self.frame_count} ({self._decoded / self.fps:.1f} s of {self.frame_count / self.fps:.1f} s); "
                   "re-encode the readable part (e.g. ffmpeg -i VIDEO -c:v libx264 fixed.mp4) and analyse that")
            raise InvalidInputError(msg)

    def _frame_time_s(self, pts: float, following: list[float]) -> float:
        """A frame's time from its presentation time ``pts`` and those of the frames after it (``following``, up to
        :data:`LOOKAHEAD_FRAMES`): module docstring."""
        if self._pts0_s is None:
            self._pts0_s = pts if math.isfinite(pts) else 0.0
            return 0.0
        limit, step = max_interval_s(self.fps), 1.0 / self.fps
        last, good = self._last_t_s, self._good_t_s
        t = pts - self._pts0_s
        later = [f - self._pts0_s for f in following]

        def fits(x: float) -> bool:  # after the frame before, and not too far after the last good one
            return math.isfinite(x) and last < x <= good + limit

        def outrun(i: int, x: float) -> bool:  # most of the frames after it have earlier times: x is too late
            after = [y for y in later[i:] if math.isfinite(y)]
            return 2 * sum(y < x for y in after) > len(after)

        if fits(t) and not outrun(0, t):
            self._last_t_s = self._good_t_s = t  # its own time
            return t
        self.times_guessed += 1
        anchor = next(((i, y) for i, y in enumerate(later) if fits(y) and not outrun(i + 1, y)), None)
        if anchor is not None:
            i, y = anchor  # a bad run between good times: spread evenly between them
            t = last + (y - last) / (i + 2)
        elif math.isfinite(pts) and following and 0.0 < following[0] - pts <= limit:
            # the frames after follow on from this one, not from the frames before: a new time line (joined files,
            # a reset clock); it goes on from here with its own intervals
            t = last + step
            self._skipped_s += max(0.0, (pts - self._pts0_s) - t)  # a pause forward, not a clock gone back
            self._pts0_s = pts - t
            self._good_t_s = t
        else:
            t = last + step
        self._last_t_s = t
        return t

    def _report_guessed(self) -> None:
        if self.times_guessed > 2 and not self._reported:  # a decoder's last buffered frames may lack a time
            self._reported = True
            _log.warning("%s: %d frames had no usable time in the container (none, going back, over %g s after the "
                         "one before, or after the frames that follow): each put between the good times either side",
                         self.path, self.times_guessed, max_interval_s(self.fps))

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
