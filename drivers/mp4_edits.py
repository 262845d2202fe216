"""The edit lists of an MP4/MOV (ISO/IEC 14496-12 base media file): which part of each track a player shows, and
when.

A clip trimmed without re-encoding (a phone's trim, ``ffmpeg -ss ... -c copy``) keeps every sample from the
keyframe before its cut and gives each track an edit list ('elst' in 'edts'): the movie shows the track's media
from a media time on, for a duration. FFmpeg (so OpenCV) decodes what the video track's edits show, while the
container's frame count is every sample's; and a camera's telemetry track read sample by sample (telemetry-parser
reads them all, times from the track's media start, and applies no edit list) is then off the shown frames by the
trim. This module reads the boxes (the 'moov' box only, never the media data) so that
:mod:`walkmon.drivers.video_file` expects the frames the edits show and :mod:`walkmon.drivers.telemetry_imu`
puts the samples on the frames' clock.

What FFmpeg does not follow is not followed here either: a fragmented file's edit lists (a 'moov' with 'mvex':
FFmpeg decodes every sample), and edits at a playback rate other than 1 (a dwell or a speed change: left alone,
with a warning, the telemetry on its own clock). Malformed or hostile boxes count as no edit list.
"""

from __future__ import annotations

import functools
import logging
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["TrackEdits", "edited_duration_s", "read_track_edits", "shown_video_frames", "telemetry_times_s"]

_log = logging.getLogger(__name__)

#: The largest 'moov' box read (it indexes the samples: ~10 MB for an hour of 60 fps video with audio and
#: telemetry); a larger one is not read and the file is taken as having no edit lists.
MAX_MOOV_BYTES = 64 * 1024 * 1024
#: More edits than this in one track, or more samples than this in the video track, is no trimmed clip.
MAX_EDITS = 10_000
MAX_SAMPLES = 5_000_000  # 23 h at 60 fps; the tables then take ~200 MB for the count

#: Sample formats of the timed-metadata tracks action cameras write their IMU to: GoPro GPMF, Google's camera
#: motion metadata (also Insta360 and others), DJI, Sony.
TELEMETRY_FORMATS = (b"gpmd", b"camm", b"djmd", b"dbgi", b"rtmd")

#: Top-level box types an ISO base media file starts with.
_FIRST_BOXES = (b"ftyp", b"moov", b"mdat", b"free", b"skip", b"wide", b"pnot")


@dataclass(frozen=True, slots=True)
class TrackEdits:
    """One track's edit list. ``handler``: its 'hdlr' type (b"vide", b"soun", b"meta", ...); ``sample_format``:
    the first sample entry's type in 'stsd' (b"avc1", b"gpmd", ...); ``edits``: (duration in the movie's
    timescale, media time in the track's timescale; -1: an empty edit, a delay showing nothing; playback rate)
    in order, empty when the track has no edit list (it shows all its media from movie time 0);
    ``shown_samples``: for a video track with an edit list, the samples whose composition time an edit shows (the
    frames FFmpeg decodes), else None."""

    handler: bytes
    sample_format: bytes
    movie_scale: int
    media_scale: int
    edits: tuple[tuple[int, int, float], ...]
    shown_samples: int | None = None

    @property
    def shown_s(self) -> float | None:
        """The time the track shows media through its edits (s); None without an edit list."""
        if not self.edits:
            return None
        return sum(d for d, m, _ in self.edits if m != -1) / self.movie_scale

    @property
    def plain(self) -> bool:
        """Every edit plays at rate 1 (or is empty): the edits map media time to movie time by shifts."""
        return all(m == -1 or r == 1.0 for _, m, r in self.edits)

    @property
    def first_shown_s(self) -> float:
        """The movie time the track's first shown media is at (the empty edits before it), s."""
        start = 0
        for d, m, _ in self.edits:
            if m != -1:
                break
            start += d
        return start / self.movie_scale

    def to_movie_s(self, t_media_s: ArrayLike) -> NDArray[np.float64]:
        """The movie times (s) the track's media times ``t_media_s`` (s from its media start) are shown at; NaN
        for one no edit shows (cut away). Without an edit list the media time is the movie time. Plain edits only
        (:attr:`plain`)."""
        t = np.asarray(t_media_s, dtype=float)
        if not self.edits:
            return t.copy()
        out = np.full(t.shape, np.nan)
        start = 0.0
        for d, m, _ in self.edits:
            length = d / self.movie_scale
            if m != -1:
                m0 = m / self.media_scale
                inside = (t >= m0) & (t < m0 + length)
                out[inside] = t[inside] - m0 + start
            start += length
        return out


def _boxes(data: bytes, start: int, end: int) -> Iterator[tuple[bytes, int, int]]:
    """(type, payload start, end) of the boxes in ``data[start:end]``; stops at a malformed one."""
    i = start
    while i + 8 <= end:
        size = int.from_bytes(data[i : i + 4], "big")
        kind, header = bytes(data[i + 4 : i + 8]), 8
        if size == 1 and i + 16 <= end:
            size, header = int.from_bytes(data[i + 8 : i + 16], "big"), 16
        elif size == 0:
            size = end - i
        if size < header or i + size > end:
            return
        yield kind, i + header, i + size
        i += size


def _child(data: bytes, span: tuple[int, int] | None, kind: bytes) -> tuple[int, int] | None:
    if span is None:
        return None
    return next(((a, b) for k, a, b in _boxes(data, *span) if k == kind), None)


def _read_moov(path: Path) -> bytes | None:
    """The 'moov' box's payload, read by seeking past the others; None for a file that is no ISO base media file
    or has none."""
    with path.open("rb") as fh:
        total = os.fstat(fh.fileno()).st_size
        pos = 0
        while pos + 8 <= total:
            fh.seek(pos)
            head = fh.read(16)
            size, kind, header = int.from_bytes(head[:4], "big"), head[4:8], 8
            if size == 1 and len(head) == 16:
                size, header = int.from_bytes(head[8:16], "big"), 16
            elif size == 0:
                size = total - pos
            if (pos == 0 and kind not in _FIRST_BOXES) or size < header:
                return None
            if kind == b"moov":
                if size - header > MAX_MOOV_BYTES:
                    return None
                fh.seek(pos + header)
                return fh.read(size - header)
            pos += size
    return None


class _Malformed(ValueError):
    """A box too short for its fields or counts: the file is taken as having no edit lists."""


def _full_box(data: bytes, span: tuple[int, int], entry: int, fixed: int = 0) -> tuple[int, int]:
    """(version, entry count) of a full box with a 4-byte count after ``fixed`` bytes of its own, checked to hold
    that many entries of ``entry`` bytes."""
    a, end = span
    if end - a < 8 + fixed:
        raise _Malformed
    count = int.from_bytes(data[a + 4 + fixed : a + 8 + fixed], "big")
    if a + 8 + fixed + count * entry > end:
        raise _Malformed
    return data[a], count


def _timescale(data: bytes, span: tuple[int, int] | None) -> int:
    """The timescale of an 'mvhd' or 'mdhd' box (version 0: after 4 + 4 + 4 bytes; version 1: 4 + 8 + 8)."""
    if span is None or span[1] - span[0] < 24:
        raise _Malformed
    a = span[0]
    off = a + 12 if data[a] == 0 else a + 20
    return int.from_bytes(data[off : off + 4], "big")


def _edits(data: bytes, span: tuple[int, int] | None) -> tuple[tuple[int, int, float], ...]:
    """The entries of an 'elst' box (none without one)."""
    if span is None:
        return ()
    a = span[0]
    version = data[a] if span[1] > a else 0
    n = 8 if version == 1 else 4
    _, count = _full_box(data, span, 2 * n + 4)
    if count > MAX_EDITS:
        raise _Malformed
    out = []
    for j in range(count):
        e = a + 8 + j * (2 * n + 4)
        duration = int.from_bytes(data[e : e + n], "big")
        media = int.from_bytes(data[e + n : e + 2 * n], "big", signed=True)
        rate = int.from_bytes(data[e + 2 * n : e + 2 * n + 4], "big", signed=True) / 65536.0
        out.append((duration, media, rate))
    return tuple(out)


def _table(data: bytes, span: tuple[int, int], signed: bool = False) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """(sample counts, values) of an 'stts' or 'ctts' box: pairs of 32-bit integers."""
    version, count = _full_box(data, span, 8)
    raw = np.frombuffer(data, dtype=">u4", count=2 * count, offset=span[0] + 8).astype(np.int64).reshape(-1, 2)
    values = raw[:, 1]
    if signed or version == 1:
        values = np.where(values >= 2**31, values - 2**32, values)
    return raw[:, 0], values


def _shown_samples(data: bytes, stbl: tuple[int, int] | None, edits: tuple[tuple[int, int, float], ...],
                   movie_scale: int, media_scale: int) -> int | None:
    """The video samples whose composition time (decode time from 'stts' plus offset from 'ctts') one of
    ``edits`` shows; None without the tables or with too many samples."""
    stts = _child(data, stbl, b"stts")
    if stts is None or not edits:
        return None
    counts, deltas = _table(data, stts)
    if int(counts.sum()) > MAX_SAMPLES:
        return None
    decode = np.concatenate([[0], np.cumsum(np.repeat(deltas, counts))[:-1]]) if counts.sum() else np.zeros(0)
    ctts = _child(data, stbl, b"ctts")
    composition = decode
    if ctts is not None:
        c_counts, offsets = _table(data, ctts, signed=True)  # as FFmpeg reads them, whatever the version
        if int(c_counts.sum()) == decode.size:  # else a table that does not describe these samples: left out
            composition = decode + np.repeat(offsets, c_counts)
    shown = np.zeros(composition.shape, dtype=bool)
    for d, m, _ in edits:
        if m != -1:
            shown |= (composition >= m) & (composition < m + d * media_scale / movie_scale)
    return int(shown.sum())


@functools.lru_cache(maxsize=16)
def _cached_edits(path: str, _mtime_ns: int, _size: int) -> tuple[TrackEdits, ...]:
    moov = _read_moov(Path(path))
    if moov is None:
        return ()
    top = (0, len(moov))
    if _child(moov, top, b"mvex") is not None:
        return ()  # a fragmented file: FFmpeg follows no edit list there
    movie_scale = _timescale(moov, _child(moov, top, b"mvhd"))
    if movie_scale <= 0:
        return ()
    out = []
    for kind, a, b in _boxes(moov, *top):
        if kind != b"trak":
            continue
        mdia = _child(moov, (a, b), b"mdia")
        hdlr = _child(moov, mdia, b"hdlr")
        if hdlr is None or hdlr[1] - hdlr[0] < 12:
            continue
        media_scale = _timescale(moov, _child(moov, mdia, b"mdhd"))
        if media_scale <= 0:
            continue
        stbl = _child(moov, _child(moov, mdia, b"minf"), b"stbl")
        stsd = _child(moov, stbl, b"stsd")
        fmt = bytes(moov[stsd[0] + 12 : stsd[0] + 16]) if stsd and stsd[1] - stsd[0] >= 16 else b""
        edits = _edits(moov, _child(moov, _child(moov, (a, b), b"edts"), b"elst"))
        handler = bytes(moov[hdlr[0] + 8 : hdlr[0] + 12])
        shown = _shown_samples(moov, stbl, edits, movie_scale, media_scale) if handler == b"vide" else None
        out.append(TrackEdits(handler, fmt, movie_scale, media_scale, edits, shown))
    return tuple(out)


def read_track_edits(path: str | Path) -> list[TrackEdits]:
    """Every track of the MP4/MOV ``path`` with its edit list; empty for another format, a fragmented file, a
    file that cannot be read, or malformed boxes (the caller then does what it would do without edit lists)."""
    try:
        st = os.stat(path)
        return list(_cached_edits(str(path), st.st_mtime_ns, st.st_size))
    except (OSError, _Malformed, IndexError, ValueError, MemoryError):
        return []


def _video(tracks: list[TrackEdits]) -> TrackEdits | None:
    return next((tr for tr in tracks if tr.handler == b"vide"), None)


def edited_duration_s(path: str | Path) -> float | None:
    """The time the video track of the MP4/MOV ``path`` shows through its edit list (s: its edits that show
    media; an empty edit delays the track and shows no frame). None when the file is no ISO base media file, its
    video track has no edit list, or the boxes cannot be read."""
    video = _video(read_track_edits(path))
    shown = None if video is None else video.shown_s
    return shown if shown else None


def shown_video_frames(path: str | Path, fps: float) -> int | None:
    """The frames the video track's edit list shows: its samples whose composition time an edit shows, else
    (no sample tables) the shown duration at ``fps``; None without an edit list (or a plain one, FFmpeg shows
    every frame then too)."""
    video = _video(read_track_edits(path))
    if video is None or not video.edits:
        return None
    if video.shown_samples is not None:
        return video.shown_samples or None  # none shown: FFmpeg decodes none either, the count says nothing
    shown = video.shown_s
    return max(1, round(shown * fps)) if shown else None


def telemetry_times_s(path: str | Path, t_media_s: ArrayLike) -> NDArray[np.float64]:
    """The times of ``path``'s embedded telemetry samples, ``t_media_s`` from its track's media start
    (telemetry-parser's times), on the clock of the shown video frames (s from the first shown frame, the time
    :class:`walkmon.drivers.video_file.VideoFile` gives it): mapped by the telemetry track's edit list to the
    movie's time, less the movie time the video's first shown frame is at; NaN for a sample no edit shows. As
    given when the file has no edit lists or no telemetry track (a camera that writes its IMU after the media,
    or another file than a video), and, with a warning, when an edit plays at another rate than 1."""
    t = np.asarray(t_media_s, dtype=float)
    tracks = read_track_edits(path)
    video = _video(tracks)
    tele = next((tr for f in TELEMETRY_FORMATS for tr in tracks if tr.sample_format == f), None)
    if video is None or tele is None or not (video.edits or tele.edits):
        return t.copy()
    if not (video.plain and tele.plain):
        _log.warning("%s: an edit list plays at another rate than 1; the camera's IMU is left on its own clock",
                     path)
        return t.copy()
    return tele.to_movie_s(t) - video.first_shown_s
