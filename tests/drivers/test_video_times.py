"""Frame times of a video come from the container, so a variable-frame-rate video (as phones record in dim light)
is timed right: the reader against the times the file was written with, and a simulated walk's cadence against
its true steps (the walk rendered at 30 fps, then written with every other frame dropped after 6 s, each kept
frame at its true time)."""

from __future__ import annotations

import json
from fractions import Fraction
from pathlib import Path

import cv2
import numpy as np
import pytest

av = pytest.importorskip("av")  # a test dependency (pyproject [test])

from walkmon.commands.cli import main  # noqa: E402
from walkmon.drivers.mp4_edits import edited_duration_s  # noqa: E402
from walkmon.drivers.video_file import VideoFile  # noqa: E402
from walkmon.errors import InvalidInputError  # noqa: E402


def write_video(path: Path, frames: list[np.ndarray], times_s: list[float], *, fmt: str | None = None,
                bad_packet: tuple[int, float] | None = None) -> None:
    """An mp4 (or ``fmt``: 'mpegts') of MPEG-4 part 2 holding ``frames`` with presentation times ``times_s`` (ms
    resolution); ``bad_packet`` (index, seconds): that packet's presentation time moved by that much (a corrupt
    time; no B-frames, so packets are frames in order)."""
    h, w = frames[0].shape[:2]
    with av.open(str(path), mode="w", format=fmt) as out:
        stream = out.add_stream("mpeg4", rate=30)
        stream.width, stream.height, stream.pix_fmt = w, h, "yuv420p"
        stream.time_base = stream.codec_context.time_base = Fraction(1, 1000)
        stream.codec_context.bit_rate = 2_000_000
        n = 0

        def mux(packet: av.Packet) -> None:
            nonlocal n
            if bad_packet is not None and n == bad_packet[0]:
                packet.pts += int(round(bad_packet[1] / packet.time_base))
            n += 1
            out.mux(packet)

        for img, t in zip(frames, times_s, strict=True):
            frame = av.VideoFrame.from_ndarray(img, format="bgr24")
            frame.pts, frame.time_base = int(round(t * 1000)), Fraction(1, 1000)
            for packet in stream.encode(frame):
                mux(packet)
        for packet in stream.encode():
            mux(packet)


def test_a_variable_frame_rate_video_is_read_at_its_frames_times(tmp_path: Path) -> None:
    """30 fps for 2 s, then 15 fps for 2 s: every frame at the time it was written with (the container's mean rate,
    22.7 fps, put frame 60 at 2.64 s instead of 2.00 s); a constant-rate file reads as i / fps, as before."""
    times = [*(k / 30 for k in range(60)), *(2.0 + k / 15 for k in range(30))]
    frames = [np.full((48, 64, 3), (7 * k) % 255, np.uint8) for k in range(len(times))]
    write_video(tmp_path / "vfr.mp4", frames, times)
    with VideoFile(tmp_path / "vfr.mp4") as video:
        got = [t for t, _ in video]
        assert video.times_guessed == 0
    assert np.allclose(got, times, atol=0.0011)
    cfr = [k / 30 for k in range(45)]
    write_video(tmp_path / "cfr.mp4", frames[:45], cfr)
    with VideoFile(tmp_path / "cfr.mp4") as video:
        assert np.allclose([t for t, _ in video], cfr, atol=0.0011)


def test_one_corrupt_time_or_a_time_reset_does_not_move_the_rest(tmp_path: Path) -> None:
    """Review cases: one frame's time 100 s late (a corrupt packet) shifted every later frame by 100 s, and two
    files joined (times starting again at 0) fell back to 1 / fps for the whole second part; now the bad frames
    are timed 1 / fps after the one before and the rest keep their own intervals."""
    times = [k / 30 for k in range(60)]
    frames = [np.full((48, 64, 3), (7 * k) % 255, np.uint8) for k in range(60)]
    write_video(tmp_path / "jump.mp4", frames, times, bad_packet=(20, 100.0))
    with VideoFile(tmp_path / "jump.mp4") as video:
        got = np.array([t for t, _ in video])
        assert video.times_guessed == 1  # the late frame; the next is measured from the last good one
    assert np.allclose(got, times, atol=0.0011)
    vfr = [k / 15 for k in range(30)]  # 15 fps: a guess at the container's mean rate would not give these
    write_video(tmp_path / "a.ts", frames[:30], vfr, fmt="mpegts")
    (tmp_path / "ab.ts").write_bytes((tmp_path / "a.ts").read_bytes() * 2)
    with VideoFile(tmp_path / "ab.ts") as video:
        got = np.array([t for t, _ in video])
    assert got.size == 60 and np.all(np.diff(got) > 0)
    assert np.allclose(np.diff(got[31:]), 1 / 15, atol=0.0011)  # the joined part keeps its own intervals


class _ScriptedTimes:
    """OpenCV's capture with scripted presentation times (ms; None: what FFmpeg reports for a frame without one,
    0): the times a muxer will not write (a time earlier than the frame's decoding time)."""

    def __init__(self, times_ms: list[float | None]) -> None:
        self.times, self.i = times_ms, 0

    def read(self) -> tuple[bool, np.ndarray | None]:
        if self.i >= len(self.times):
            return False, None
        self.i += 1
        return True, np.zeros((8, 8, 3), np.uint8)

    def get(self, prop: int) -> float:
        assert prop == cv2.CAP_PROP_POS_MSEC
        ms = self.times[self.i - 1]
        return 0.0 if ms is None else float(ms)

    def release(self) -> None:
        pass


def _scripted(tmp_path: Path, times_ms: list[float | None]) -> VideoFile:
    """A VideoFile whose capture gives ``times_ms`` (the container's other facts from a real 3-frame file)."""
    write_video(tmp_path / "v.mp4", [np.zeros((48, 64, 3), np.uint8)] * 3, [0.0, 1 / 30, 2 / 30])
    video = VideoFile(tmp_path / "v.mp4")
    video._cap.release()
    video._cap = _ScriptedTimes(times_ms)  # the capture's times, scripted
    return video


@pytest.mark.parametrize(("case", "edit"), [
    ("a time 0.5 s early", {20: -500.0}),
    ("no time (FFmpeg's 0)", {15: None}),
    ("a time 0.3 s late", {40: 300.0}),
    ("a NaN time", {10: float("nan")}),
    ("two times 0.3 s late", {40: 300.0, 41: 300.0}),
    ("two times 0.5 s early", {40: -500.0, 41: -500.0}),
    ("two times 0.1 s early", {40: -100.0, 41: -100.0}),
    ("a late time, then none", {40: 300.0, 41: None}),
    ("two late times", {40: 300.0, 41: 600.0}),
    ("the next time a little early", {31: -50.0}),
])
def test_a_short_run_of_bad_times_moves_no_other_frame(tmp_path: Path, case: str, edit: dict) -> None:
    """Review cases: a frame time a little early or late, or missing (FFmpeg reports 0), and then two in a row,
    had re-based the rest of the video on them (every later frame 0.1-0.6 s off, silently). The reader looks four
    frames ahead: the bad frames are spread between the good times either side (here their true times), and the
    rest keep their own."""
    true = [k * 1000 / 30 for k in range(90)]
    times = [true[k] + edit[k] if k in edit and edit[k] is not None else (None if k in edit else true[k])
             for k in range(90)]
    with _scripted(tmp_path, times) as video:
        got = np.array([t for t, _ in video])
        assert video.times_guessed == len(edit), case
    assert np.allclose(got, np.array(true) / 1000, atol=1e-9), case


def test_a_corrupt_late_time_does_not_hide_a_damaged_file(tmp_path: Path) -> None:
    """Review case: the container lists 300 frames, 150 decode, one of them 100 s late: the check for a damaged
    file measured the decoded frames' span with that time and let half a walk pass as the whole one."""
    times: list[float | None] = [k * 1000 / 30 for k in range(150)]
    times[100] = float(times[100] or 0.0) + 100_000.0
    video = _scripted(tmp_path, times)
    video.frame_count = 300
    with video, pytest.raises(InvalidInputError, match="damaged: decoding failed at frame 150 of 300"):
        for _ in video:
            pass


@pytest.mark.parametrize("fmt", ["mpegts", "matroska"])
def test_a_whole_file_with_a_pause_over_a_second_is_not_damaged(tmp_path: Path, fmt: str) -> None:
    """User review: an MKV or MPEG-TS whose frames pause 1.2 s (frames 150-185 of 300 dropped) was refused as
    'damaged: decoding failed at frame 264 of 300': its frame count comes from its duration, and the pause, a new
    time line to the frames' times, was missing from the span checked against it. The same frames in an MP4 read."""
    times = [k / 30 for k in range(300) if not 150 <= k < 186]
    frames = [np.full((48, 64, 3), (7 * k) % 255, np.uint8) for k in range(len(times))]
    path = tmp_path / ("gap.ts" if fmt == "mpegts" else "gap.mkv")
    write_video(path, frames, times, fmt=fmt)
    with VideoFile(path) as video:
        got = [t for t, _ in video]
    assert len(got) == len(times)


def test_a_pause_does_not_hide_a_damaged_mp4(tmp_path: Path) -> None:
    """Review: the pause added back for an MKV's count (made from its duration) was added for an MP4 too, whose
    count is its frames': 150 of 300 frames with a 6 s pause among them read as whole, half a walk analysed."""
    times: list[float | None] = [k * 1000 / 30 + (6000.0 if k >= 50 else 0.0) for k in range(150)]
    video = _scripted(tmp_path, times)
    video.frame_count = 300
    with video, pytest.raises(InvalidInputError, match="damaged: decoding failed at frame 150 of 300"):
        for _ in video:
            pass
    # an older QuickTime file starts with another box than 'ftyp' (review: taken for an MKV, the pause excused)
    from walkmon.drivers.video_file import _is_iso_media

    head = (tmp_path / "v.mp4").read_bytes()
    assert head[4:8] == b"ftyp"
    (tmp_path / "old.mov").write_bytes(head[:4] + b"wide" + head[8:])
    (tmp_path / "x.mkv").write_bytes(b"\x1aE\xdf\xa3" + bytes(40))  # an EBML (Matroska) header
    assert _is_iso_media(tmp_path / "old.mov") and not _is_iso_media(tmp_path / "x.mkv")


def test_a_time_lapse_below_one_frame_a_second_keeps_its_times(tmp_path: Path) -> None:
    """Review case: a 0.5 fps video was taken for a broken container rate (30 fps assumed) and its 2 s intervals
    for corrupt times (60 x too fast)."""
    times = [2.0 * k for k in range(10)]
    write_video(tmp_path / "lapse.mp4", [np.full((48, 64, 3), 20 * k, np.uint8) for k in range(10)], times)
    with VideoFile(tmp_path / "lapse.mp4") as video:
        assert np.allclose([t for t, _ in video], times, atol=0.0011)
        assert video.times_guessed == 0


def test_a_clip_trimmed_by_its_edit_list_is_read_not_refused(
    tmp_path: Path, mp4_boxes, edit_mp4  # noqa: ANN001
) -> None:
    """A 3 s clip trimmed to 1.0-2.5 s without re-encoding: FFmpeg decodes the 45 frames shown, the container
    lists 90, and the reader refused it as damaged ("decoding failed at frame 45 of 90"). It reads the shown
    frames, in order, timed from 0; a trimmed clip damaged mid-file is still refused."""
    rng = np.random.default_rng(1)
    frames = [rng.integers(0, 255, (48, 64, 3), dtype=np.uint8) for _ in range(90)]
    write_video(tmp_path / "clip.mp4", frames, [k / 30 for k in range(90)])
    assert edited_duration_s(tmp_path / "clip.mp4") == pytest.approx(3.0, abs=0.002)
    edit_mp4(tmp_path / "clip.mp4", [(1.0, 1.5)])
    assert edited_duration_s(tmp_path / "clip.mp4") == pytest.approx(1.5)
    with VideoFile(tmp_path / "clip.mp4") as video:
        assert video.frame_count == 45
        got = list(video)
    assert np.allclose([t for t, _ in got], [k / 30 for k in range(45)], atol=0.0011)
    # each decoded frame is the written frame it shows (lossy codec: nearest of the 90 by mean difference)
    shown = [int(np.argmin([np.abs(f.astype(int) - g.astype(int)).mean() for g in frames])) for _, f in got]
    assert shown == list(range(30, 75))

    data = bytearray((tmp_path / "clip.mp4").read_bytes())
    (mdat,) = [(a, b) for k, a, b in mp4_boxes(data, 0, len(data)) if k == b"mdat"]
    n = mdat[1] - mdat[0]
    data[mdat[0] + int(0.45 * n) : mdat[0] + int(0.75 * n)] = bytes(int(0.75 * n) - int(0.45 * n))
    (tmp_path / "damaged.mp4").write_bytes(bytes(data))
    with VideoFile(tmp_path / "damaged.mp4") as video, pytest.raises(InvalidInputError, match=r"damaged.* of 45 "):
        for _ in video:
            pass


def test_a_file_without_an_edit_list_has_no_edited_duration(tmp_path: Path) -> None:
    frames = [np.full((48, 64, 3), 9 * k, np.uint8) for k in range(10)]
    write_video(tmp_path / "clip.ts", frames, [k / 30 for k in range(10)], fmt="mpegts")
    assert edited_duration_s(tmp_path / "clip.ts") is None  # no ISO base media file
    (tmp_path / "junk.mp4").write_bytes(b"\x00\x00\x00\x08moov" + bytes(3))  # a box cut short
    assert edited_duration_s(tmp_path / "junk.mp4") is None
    assert edited_duration_s(tmp_path / "missing.mp4") is None


@pytest.fixture(scope="module")
def walk_vfr(tmp_path_factory: pytest.TempPathFactory, simulated_videos) -> Path:  # noqa: ANN001
    d = simulated_videos.render(tmp_path_factory.mktemp("vfr-walk"), "normal:16", 320, 240, seed=3)
    fps, all_frames = simulated_videos.frames(d / "video.mp4")
    kept = [i for i in range(len(all_frames)) if i / fps < 6.0 or i % 2 == 0]  # 30 fps, then 15 (dim light)
    write_video(d / "vfr.mp4", [all_frames[i] for i in kept], [i / fps for i in kept])
    return d


def _true_cadence_spm(d: Path) -> float:
    """The mean over the true walk's strides of 120 / stride duration (the field's definition)."""
    with (d / "truth_steps.csv").open() as fh:
        t = np.array([float(line.split(",")[0]) for line in fh.readlines()[1:]])
    return float(np.mean(120.0 / (t[2:] - t[:-2])))


def test_the_cadence_of_a_variable_frame_rate_walk_is_the_true_one(walk_vfr: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    assert main(["analyze", str(walk_vfr / "vfr.mp4"), "--calib", str(walk_vfr / "camera.yaml"), "--out", str(out),
                 "--no-progress"]) == 0
    doc = json.loads((out / "indicators.json").read_text())
    assert doc["cadence_spm"] == pytest.approx(_true_cadence_spm(walk_vfr), rel=0.02)
    with (out / "angles.csv").open() as fh:
        t = np.array([float(line.split(",")[0]) for line in fh.readlines()[1:]])
    assert t[-1] == pytest.approx(16.0 + 4.0 - 1 / 15, abs=0.07)  # the walk's length, not frames / mean rate


def test_an_edit_list_with_a_delay_and_two_cuts_maps_media_times_onto_the_movie() -> None:
    """0.5 s of nothing, then 1.0 s of the media from 2.0 s, then 0.5 s from 5.0 s: media 2.0-3.0 s are shown
    at movie 0.5-1.5 s, media 5.0-5.5 s at 1.5-2.0 s, the rest not at all."""
    from walkmon.drivers.mp4_edits import TrackEdits

    tr = TrackEdits(b"meta", b"gpmd", 1000, 90000, ((500, -1, 1.0), (1000, 180000, 1.0), (500, 450000, 1.0)))
    assert tr.shown_s == pytest.approx(1.5) and tr.first_shown_s == pytest.approx(0.5) and tr.plain
    got = tr.to_movie_s([1.9, 2.0, 2.5, 2.999, 3.2, 5.0, 5.25, 5.6])
    want = [np.nan, 0.5, 1.0, 1.499, np.nan, 1.5, 1.75, np.nan]
    assert np.allclose(got, want, equal_nan=True)
    untrimmed = TrackEdits(b"vide", b"avc1", 1000, 90000, ())
    assert untrimmed.shown_s is None and np.array_equal(untrimmed.to_movie_s([0.0, 7.0]), [0.0, 7.0])
    assert not TrackEdits(b"vide", b"avc1", 1000, 90000, ((1000, 0, 0.0),)).plain  # a dwell


def _frame_index(got: list, frames: list) -> list[int]:
    """Which written frame each decoded one is (lossy codec: the nearest by mean difference)."""
    return [int(np.argmin([np.abs(f.astype(int) - g.astype(int)).mean() for g in frames])) for _, f in got]


def test_a_clip_with_two_cuts_shows_both_parts_on_one_clock(tmp_path: Path, edit_mp4) -> None:  # noqa: ANN001
    """Edits 0.0-1.0 s and 2.0-2.5 s of a 3 s clip: FFmpeg shows frames 0-29 then 60-74 at 30 fps on, and the
    reader expects the 45 frames the edits show (counted from the sample tables)."""
    rng = np.random.default_rng(2)
    frames = [rng.integers(0, 255, (48, 64, 3), dtype=np.uint8) for _ in range(90)]
    write_video(tmp_path / "clip.mp4", frames, [k / 30 for k in range(90)])
    edit_mp4(tmp_path / "clip.mp4", [(0.0, 1.0), (2.0, 0.5)])
    with VideoFile(tmp_path / "clip.mp4") as video:
        assert video.frame_count == 45
        got = list(video)
    assert _frame_index(got, frames) == [*range(30), *range(60, 75)]
    assert np.allclose([t for t, _ in got], [k / 30 for k in range(45)], atol=0.0011)


def test_a_fragmented_files_edit_list_is_not_followed(tmp_path: Path, edit_mp4) -> None:  # noqa: ANN001
    """FFmpeg follows no edit list in a fragmented mp4 (it decodes every sample): neither does the reader, so a
    damaged fragmented file is still measured against all its frames (review: a trimmed fragmented file damaged
    in its last fragments passed as whole)."""
    from walkmon.drivers.mp4_edits import read_track_edits

    rng = np.random.default_rng(3)
    frames = [rng.integers(0, 255, (48, 64, 3), dtype=np.uint8) for _ in range(90)]
    path = tmp_path / "frag.mp4"
    with av.open(str(path), "w", format="mp4",
                 options={"movflags": "frag_keyframe+empty_moov+default_base_moof"}) as out:
        stream = out.add_stream("mpeg4", rate=30)
        stream.width, stream.height, stream.pix_fmt = 64, 48, "yuv420p"
        stream.codec_context.bit_rate, stream.options = 2_000_000, {"g": "15"}
        for k, img in enumerate(frames):
            frame = av.VideoFrame.from_ndarray(img, format="bgr24")
            frame.pts, frame.time_base = k, Fraction(1, 30)
            for packet in stream.encode(frame):
                out.mux(packet)
        for packet in stream.encode():
            out.mux(packet)
    edit_mp4(path, [(1.0, 1.5)])
    assert read_track_edits(path) == [] and edited_duration_s(path) is None
    with VideoFile(path) as video:
        assert video.frame_count in (0, 90)  # the container's own count (none in an empty 'moov')
        assert len(list(video)) == 90


def test_malformed_edit_lists_are_no_edit_lists(tmp_path: Path, mp4_boxes) -> None:  # noqa: ANN001
    """A track whose 'elst' has no room for its fields, appended to a clip's 'moov' (review: IndexError out of
    VideoFile and the CLI): the file reads as without edit lists."""
    from walkmon.drivers.mp4_edits import read_track_edits

    def box(kind: bytes, payload: bytes) -> bytes:
        return len(payload).__add__(8).to_bytes(4, "big") + kind + payload

    frames = [np.full((48, 64, 3), 9 * k % 255, np.uint8) for k in range(30)]
    write_video(tmp_path / "clip.mp4", frames, [k / 30 for k in range(30)])
    data = bytearray((tmp_path / "clip.mp4").read_bytes())
    (moov,) = [(a, b) for k, a, b in mp4_boxes(data, 0, len(data)) if k == b"moov"]
    assert moov[1] == len(data)
    mdhd = box(b"mdhd", bytes(12) + (1000).to_bytes(4, "big") + bytes(8))
    hdlr = box(b"hdlr", bytes(8) + b"vide" + bytes(13))
    for elst in (b"", bytes(4), bytes(4) + (10**6).to_bytes(4, "big")):  # no fields, no count, a count too large
        bad = bytearray(data) + box(b"trak", box(b"mdia", mdhd + hdlr) + box(b"edts", box(b"elst", elst)))
        size = int.from_bytes(bad[moov[0] - 8 : moov[0] - 4], "big") + len(bad) - len(data)
        bad[moov[0] - 8 : moov[0] - 4] = size.to_bytes(4, "big")
        (tmp_path / "bad.mp4").write_bytes(bytes(bad))
        assert read_track_edits(tmp_path / "bad.mp4") == []
        with VideoFile(tmp_path / "bad.mp4") as video:
            assert len(list(video)) == 30


def test_a_composition_table_that_counts_more_samples_than_there_are_is_left_out(
    tmp_path: Path, mp4_boxes, edit_mp4  # noqa: ANN001
) -> None:
    """B-frames give an mp4 a 'ctts' table of composition offsets. Its first entry's sample count patched to
    2^32 - 1 (review: np.repeat then asked for 32 GiB, and MemoryError came out of VideoFile and the CLI): the
    table does not describe the samples, so the frames shown are counted from the decode times alone."""
    path = tmp_path / "bframes.mp4"
    rng = np.random.default_rng(5)
    with av.open(str(path), "w") as out:
        stream = out.add_stream("libx264", rate=30)
        stream.width, stream.height, stream.pix_fmt = 64, 48, "yuv420p"
        stream.codec_context.options = {"bf": "2", "g": "15"}
        for _ in range(60):
            for packet in stream.encode(av.VideoFrame.from_ndarray(rng.integers(0, 255, (48, 64, 3), np.uint8),
                                                                   format="bgr24")):
                out.mux(packet)
        for packet in stream.encode():
            out.mux(packet)
    edit_mp4(path, [(0.5, 1.0)])
    with VideoFile(path) as video:
        assert video.frame_count == 30 and len(list(video)) == 30  # the table as written: counted exactly
    data = bytearray(path.read_bytes())

    def child(span: tuple[int, int], kind: bytes) -> tuple[int, int]:
        (found,) = [(a, b) for k, a, b in mp4_boxes(data, *span) if k == kind]
        return found

    moov = child((0, len(data)), b"moov")
    stbl = child(child(child(child(moov, b"trak"), b"mdia"), b"minf"), b"stbl")
    ctts = child(stbl, b"ctts")
    data[ctts[0] + 8 : ctts[0] + 12] = (2**32 - 1).to_bytes(4, "big")  # the first entry's sample count
    path.write_bytes(bytes(data))
    with VideoFile(path) as video:
        assert 28 <= video.frame_count <= 32 and len(list(video)) == 30
