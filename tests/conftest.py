"""Shared test fixtures. Area-specific fixtures live in the test modules that use them."""

from __future__ import annotations

import os
import random
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

#: The project's shared data (../shared/data beside the checkout, as CI lays it out); WALKMON_SHARED_DATA overrides.
SHARED_DATA = Path(os.environ.get("WALKMON_SHARED_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"))


@pytest.fixture(autouse=True)
def _reset_random_seed() -> None:
    """Seed the global RNGs before every test, so no test depends on another's draws."""
    random.seed(0)
    np.random.seed(0)  # noqa: NPY002  (legacy global RNG, for any library that still uses it)


@pytest.fixture
def broad_trial_7() -> Path:
    """BROAD trial 7 (fast rotations, optical truth; Laidig et al. 2021, CC BY 4.0) from the shared data."""
    path = SHARED_DATA / "broad" / "07_undisturbed_fast_rotation_B.hdf5"
    if not path.is_file():
        pytest.skip(f"BROAD data not present at {path}")
    return path


@pytest.fixture
def unit_settings() -> dict[str, list[str]]:
    """systemd/walkmon.service as ``{key: [values]}`` (comments and section headers left out)."""
    out: dict[str, list[str]] = {}
    unit = Path(__file__).resolve().parents[1] / "systemd" / "walkmon.service"
    for line in unit.read_text().splitlines():
        if "=" in line and not line.lstrip().startswith(("#", "[")):
            k, v = line.split("=", 1)
            out.setdefault(k.strip(), []).append(v.strip())
    return out


def _boxes(data: bytes, start: int, end: int) -> list[tuple[bytes, int, int]]:
    """(type, payload start, end) of the ISO/IEC 14496-12 boxes in ``data[start:end]``, by walkmon's own box
    walker (:mod:`walkmon.drivers.mp4_edits`; 64-bit and to-the-end sizes), as a list."""
    from walkmon.drivers.mp4_edits import _boxes as walk

    return list(walk(data, start, end))


def write_display_rotation(path: Path, degrees: int) -> None:
    """Mark an mp4's video track to be shown turned ``degrees`` clockwise, as a phone marks a portrait video: its
    'tkhd' display matrix (9 big-endian 32-bit values a b u c d v x y w, 16.16 fixed point, u v w 2.30), written
    in place in the track whose 'hdlr' is 'vide'."""
    c, s = {0: (1, 0), 90: (0, 1), 180: (-1, 0), 270: (0, -1)}[degrees % 360]
    matrix = (c * 0x10000, s * 0x10000, 0, -s * 0x10000, c * 0x10000, 0, 0, 0, 0x40000000)
    data = bytearray(path.read_bytes())
    (moov,) = [(a, b) for kind, a, b in _boxes(data, 0, len(data)) if kind == b"moov"]
    for kind, a, b in _boxes(data, *moov):
        if kind != b"trak":
            continue
        inner = {k: (x, y) for k, x, y in _boxes(data, a, b)}
        mdia = {k: (x, y) for k, x, y in _boxes(data, *inner[b"mdia"])}
        hdlr = mdia[b"hdlr"][0]
        if bytes(data[hdlr + 8 : hdlr + 12]) != b"vide":  # version/flags, pre_defined, then the handler type
            continue
        tkhd = inner[b"tkhd"][0]
        off = tkhd + 4 + (20 if data[tkhd] == 0 else 32) + 16  # times, track id, duration; reserved..volume
        data[off : off + 36] = struct.pack(">9i", *matrix)
        path.write_bytes(bytes(data))
        return
    msg = f"{path}: no video track"
    raise ValueError(msg)


@pytest.fixture(scope="session")
def set_display_rotation():  # noqa: ANN201
    """:func:`write_display_rotation` for tests (mark an mp4 as shown turned)."""
    return write_display_rotation


def write_edits(path: Path, edits: list[tuple[float | None, float]]) -> None:
    """Give every track of an mp4 the edit list ``edits``, as a phone's trim or ``ffmpeg -ss START -t SHOWN -c
    copy`` does without re-encoding: (media start s, shown s) per edit, start None for an empty edit (a delay);
    every sample stays in the file. Each track's 'edts' is replaced by a new one after its 'tkhd' (durations in
    the movie's timescale, media times in the track's, rate 1), the 'trak' and 'moov' sizes changed to fit (the
    'moov' must follow the media data, as FFmpeg's and GoPro's do, so no chunk offset moves; or the file be
    fragmented)."""
    data = bytearray(path.read_bytes())
    top = _boxes(data, 0, len(data))
    (moov,) = [(a, b) for kind, a, b in top if kind == b"moov"]

    def child(span: tuple[int, int], kind: bytes) -> tuple[int, int]:
        (found,) = [(a, b) for k, a, b in _boxes(data, *span) if k == kind]
        return found

    def scale(box: tuple[int, int]) -> int:  # version 0 'mvhd' / 'mdhd'
        assert data[box[0]] == 0
        return int.from_bytes(data[box[0] + 12 : box[0] + 16], "big")

    # a fragmented file's fragments address their data from their own 'moof' (FFmpeg's default_base_moof)
    fragmented = any(k == b"mvex" for k, _, _ in _boxes(data, *moov))
    assert fragmented or [k for k, _, _ in top].index(b"moov") > [k for k, _, _ in top].index(b"mdat")

    def grow(heads: list[int], by: int) -> None:  # 32-bit box sizes
        for head in heads:
            data[head : head + 4] = struct.pack(">I", int.from_bytes(data[head : head + 4], "big") + by)

    movie = scale(child(moov, b"mvhd"))
    for a, b in reversed([(a, b) for kind, a, b in _boxes(data, *moov) if kind == b"trak"]):
        media = scale(child(child((a, b), b"mdia"), b"mdhd"))
        entries = b"".join(struct.pack(">Ii", round(shown * movie), -1 if start is None else round(start * media))
                           + struct.pack(">I", 0x10000) for start, shown in edits)
        elst = struct.pack(">I4sII", 16 + len(entries), b"elst", 0, len(edits)) + entries
        edts = struct.pack(">I4s", 8 + len(elst), b"edts") + elst
        old = [(x, y) for k, x, y in _boxes(data, a, b) if k == b"edts"]
        if old:
            x, y = old[0]
            del data[x - 8 : y]
            grow([a - 8, moov[0] - 8], -(y - x + 8))
            b -= y - x + 8
        at = child((a, b), b"tkhd")[1]
        data[at:at] = edts
        grow([a - 8, moov[0] - 8], len(edts))
    path.write_bytes(bytes(data))


@pytest.fixture(scope="session")
def mp4_boxes():  # noqa: ANN201
    """:func:`_boxes` for tests (the boxes of an mp4, to edit one in place)."""
    return _boxes


@pytest.fixture(scope="session")
def edit_mp4():  # noqa: ANN201
    """:func:`write_edits` for tests (trim an mp4 by its edit lists)."""
    return write_edits


class SimulatedVideos:
    """Helpers for tests that make a simulated walk's video into another one (a covered lens, a variable frame
    rate, a display rotation): render it through the CLI, and read its frames back."""

    @staticmethod
    def render(out: Path, walk: str, width: int, height: int, seed: int) -> Path:
        """``walkmon simulate`` into ``out`` (video.mp4, camera.yaml, truth files); returns ``out``."""
        subprocess.run([sys.executable, "-m", "walkmon", "simulate", "--walk", walk, "--width", str(width),
                        "--height", str(height), "--seed", str(seed), "--out", str(out)],
                       check=True, capture_output=True, timeout=300)
        return out

    @staticmethod
    def frames(path: Path) -> tuple[float, list[np.ndarray]]:
        """The container's frame rate and every frame of the video at ``path``, in order."""
        import cv2

        src = cv2.VideoCapture(str(path))
        fps = float(src.get(cv2.CAP_PROP_FPS))
        frames = []
        while True:
            ok, frame = src.read()
            if not ok:
                break
            frames.append(frame)
        src.release()
        return fps, frames


@pytest.fixture(scope="session")
def simulated_videos() -> SimulatedVideos:
    """:class:`SimulatedVideos`."""
    return SimulatedVideos()
