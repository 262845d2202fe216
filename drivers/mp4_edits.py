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
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

__all__ = ["TrackEdits", "edited_duration_s", "read_track_edits", "telemetry_shift_s"]

#: The largest 'moov' box read (it indexes the samples: ~10 MB for an hour of 60 fps video with audio and
#: telemetry); a larger one is not read and the file is taken as having no edit lists.
MAX_MOOV_BYTES = 64 * 1024 * 1024

#: Sample formats of the timed-metadata tracks action cameras write their IMU to: GoPro GPMF, Google's camera
#: motion metadata (also Insta360 and others), DJI, Sony.
TELEMETRY_FORMATS = (b"gpmd", b"camm", b"djmd", b"dbgi", b"rtmd")

#: Top-level box types an ISO base media file starts with.
_FIRST_BOXES = (b"ftyp", b"moov", b"mdat", b"free", b"skip", b"wide", b"pnot")


@dataclass(frozen=True, slots=True)
class TrackEdits:
    """One track's edit list. ``handler``: its 'hdlr' type (b"vide", b"soun", b"meta", ...); ``sample_format``:
    the first sample entry's type in 'stsd' (b"avc1", b"gpmd", ...); ``edits``: (duration in the movie's
    timescale, media time in the track's timescale; -1: an empty edit, a delay showing nothing) in order, empty
    when the track has no edit list (it shows all its media from movie time 0)."""

    handler: bytes
    sample_format: bytes
    movie_scale: int
    media_scale: int
    edits: tuple[tuple[int, int], ...]

    @property
    def shown_s(self) -> float | None:
        """The time the track shows media through its edits (s); None without an edit list."""
        if not self.edits:
            return None
        return sum(d for d, m in self.edits if m != -1) / self.movie_scale

    @property
    def media_to_movie_s(self) -> float:
        """Add to a time on the track's media timeline (s from its media start) to get the movie time it is shown
        at (s), by the first edit that shows media: its movie start (the empty edits before it) less its media
        time. 0 without an edit list."""
        start = 0
        for d, m in self.edits:
            if m == -1:
                start += d
                continue
            return start / self.movie_scale - m / self.media_scale
        return 0.0


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


def _child(data: bytes, span: tuple[int, int], kind: bytes) -> tuple[int, int] | None:
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


def _timescale(data: bytes, span: tuple[int, int] | None) -> int:
    """The timescale of an 'mvhd' or 'mdhd' box (version 0: after 4 + 4 + 4 bytes; version 1: 4 + 8 + 8)."""
    if span is None or span[1] - span[0] < 24:
        return 0
    a = span[0]
    off = a + 12 if data[a] == 0 else a + 20
    return int.from_bytes(data[off : off + 4], "big")


def _edits(data: bytes, span: tuple[int, int] | None) -> tuple[tuple[int, int], ...] | None:
    """The entries of an 'elst' box; None when malformed."""
    if span is None:
        return ()
    a, end = span
    version, count = data[a], int.from_bytes(data[a + 4 : a + 8], "big")
    width = 20 if version == 1 else 12
    if a + 8 + count * width > end:
        return None
    out = []
    for j in range(count):
        e = a + 8 + j * width
        n = 8 if version == 1 else 4
        duration = int.from_bytes(data[e : e + n], "big")
        out.append((duration, int.from_bytes(data[e + n : e + 2 * n], "big", signed=True)))
    return tuple(out)


def read_track_edits(path: str | Path) -> list[TrackEdits]:
    """Every track of the MP4/MOV ``path`` with its edit list; empty for another format, a file that cannot be
    read, or malformed boxes (the caller then keeps what it would do without edit lists)."""
    try:
        moov = _read_moov(Path(path))
    except OSError:
        return []
    if moov is None:
        return []
    movie_scale = _timescale(moov, _child(moov, (0, len(moov)), b"mvhd"))
    if movie_scale <= 0:
        return []
    out = []
    for kind, a, b in _boxes(moov, 0, len(moov)):
        if kind != b"trak":
            continue
        mdia = _child(moov, (a, b), b"mdia")
        hdlr = _child(moov, mdia, b"hdlr") if mdia else None
        media_scale = _timescale(moov, _child(moov, mdia, b"mdhd")) if mdia else 0
        if hdlr is None or hdlr[1] - hdlr[0] < 12 or media_scale <= 0:
            continue
        stbl = None
        minf = _child(moov, mdia, b"minf") if mdia else None
        if minf is not None:
            stbl = _child(moov, minf, b"stbl")
        stsd = _child(moov, stbl, b"stsd") if stbl else None
        fmt = bytes(moov[stsd[0] + 12 : stsd[0] + 16]) if stsd and stsd[1] - stsd[0] >= 16 else b""
        edts = _child(moov, (a, b), b"edts")
        edits = _edits(moov, _child(moov, edts, b"elst") if edts else None)
        if edits is None:
            return []
        out.append(TrackEdits(bytes(moov[hdlr[0] + 8 : hdlr[0] + 12]), fmt, movie_scale, media_scale, edits))
    return out


def edited_duration_s(path: str | Path) -> float | None:
    """The time the video track of the MP4/MOV ``path`` shows through its edit list (s: its edits that show
    media; an empty edit delays the track and shows no frame). None when the file is no ISO base media file, its
    video track has no edit list, or the boxes cannot be read."""
    video = next((tr for tr in read_track_edits(path) if tr.handler == b"vide"), None)
    shown = None if video is None else video.shown_s
    return shown if shown else None


def telemetry_shift_s(path: str | Path) -> float:
    """Add to the times of ``path``'s embedded telemetry, read from its track's media start (telemetry-parser's
    times), to get the time of the shown video frame taken with them (s from the first shown frame, the time
    :class:`walkmon.drivers.video_file.VideoFile` gives it): the telemetry track's media-to-movie shift less the
    video track's. 0 when the file has no edit lists (an untrimmed clip) or no telemetry track (e.g. a camera
    that writes its IMU after the media, or another file than a video)."""
    tracks = read_track_edits(path)
    video = next((tr for tr in tracks if tr.handler == b"vide"), None)
    tele = next((tr for f in TELEMETRY_FORMATS for tr in tracks if tr.sample_format == f), None)
    if video is None or tele is None:
        return 0.0
    # the video's first shown frame is t = 0: the movie time of its first edit that shows media
    first_shown = 0.0
    for d, m in video.edits:
        if m != -1:
            break
        first_shown += d / video.movie_scale
    return tele.media_to_movie_s - first_shown
