"""Frame times of a video come from the container, so a variable-frame-rate video (as phones record in dim light)
is timed right: the reader against the times the file was written with, and a simulated walk's cadence against
its true steps (the walk rendered at 30 fps, then written with every other frame dropped after 6 s, each kept
frame at its true time)."""

from __future__ import annotations

import json
import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import cv2
import numpy as np
import pytest

av = pytest.importorskip("av")  # a test dependency (pyproject [test])

from walkmon.commands.cli import main  # noqa: E402
from walkmon.drivers.video_file import VideoFile  # noqa: E402


def write_video(path: Path, frames: list[np.ndarray], times_s: list[float]) -> None:
    """An mp4 (MPEG-4 part 2) holding ``frames`` with presentation times ``times_s`` (ms resolution)."""
    h, w = frames[0].shape[:2]
    with av.open(str(path), mode="w") as out:
        stream = out.add_stream("mpeg4", rate=30)
        stream.width, stream.height, stream.pix_fmt = w, h, "yuv420p"
        stream.time_base = stream.codec_context.time_base = Fraction(1, 1000)
        stream.codec_context.bit_rate = 2_000_000
        for img, t in zip(frames, times_s, strict=True):
            frame = av.VideoFrame.from_ndarray(img, format="bgr24")
            frame.pts, frame.time_base = int(round(t * 1000)), Fraction(1, 1000)
            for packet in stream.encode(frame):
                out.mux(packet)
        for packet in stream.encode():
            out.mux(packet)


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


@pytest.fixture(scope="module")
def walk_vfr(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("vfr-walk")
    subprocess.run([sys.executable, "-m", "walkmon", "simulate", "--walk", "normal:16", "--width", "320",
                    "--height", "240", "--seed", "3", "--out", str(d)], check=True, capture_output=True, timeout=300)
    src = cv2.VideoCapture(str(d / "video.mp4"))
    fps = src.get(cv2.CAP_PROP_FPS)
    frames, times = [], []
    i = 0
    while True:
        ok, img = src.read()
        if not ok:
            break
        t = i / fps
        if t < 6.0 or i % 2 == 0:  # 30 fps, then 15 fps (a phone in dim light)
            frames.append(img)
            times.append(t)
        i += 1
    write_video(d / "vfr.mp4", frames, times)
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
