"""``walkmon calibrate``: camera intrinsics from chessboard views in a video or a folder of images."""

from __future__ import annotations

import argparse
import math
import os
import re
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from walkmon.errors import ConfigError, InvalidInputError

NAME = "calibrate"
HELP = "calibrate camera intrinsics from chessboard views (video file or image folder) into ROS camera_info YAML"

#: Most inner corners per board side (printed boards have < 30; 100000x100000 would allocate 112 GiB).
MAX_BOARD_CORNERS = 100

DESCRIPTION = """Camera intrinsics for walkmon, written as a ROS camera_info YAML (--calib of analyze and live).

From chessboard views: SOURCE is a video or a folder of images of a printed chessboard (--board inner corners,
--square-mm). --model plumb_bob (default) suits ordinary lenses up to ~90 deg; action cameras (GoPro, DJI,
Insta360, Sony action cams, RunCam) and other fisheye lenses need --model equidistant: OpenCV's fisheye
(Kannala-Brandt) model r = f*theta*(1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8), four coefficients.
Calibrate in the lens mode you record in (Wide/Linear/SuperView crop differently).

From a published lens profile: SOURCE is a Gyroflow lens profile .json (github.com/gyroflow/lens_profiles, CC0:
thousands of camera/lens-mode profiles). opencv_fisheye profiles become the equidistant model, opencv_standard
ones plumb_bob; the result is at the profile's calib_dimension and is scaled to each video's size (same
aspect ratio). 'walkmon analyze --calib PROFILE.json' reads such a profile directly too.
"""

_IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff"}


def _board(text: str) -> tuple[int, int]:
    m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not m:
        msg = f"board must look like 9x6 (inner corners), got {text!r}"
        raise argparse.ArgumentTypeError(msg)
    cols, rows = int(m.group(1)), int(m.group(2))
    if not (2 <= cols <= MAX_BOARD_CORNERS and 2 <= rows <= MAX_BOARD_CORNERS):
        msg = f"board needs 2..{MAX_BOARD_CORNERS} inner corners per side, got {cols}x{rows}"
        raise argparse.ArgumentTypeError(msg)
    return cols, rows


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        msg = f"expected a number, got {text!r}"
        raise argparse.ArgumentTypeError(msg) from None
    if not (math.isfinite(value) and 0 < value <= 10_000):
        msg = f"expected a size in mm in (0, 10000], got {text}"
        raise argparse.ArgumentTypeError(msg)
    return value


def _every(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        msg = f"expected a whole number, got {text!r}"
        raise argparse.ArgumentTypeError(msg) from None
    if not 1 <= value <= 100_000:
        msg = f"expected 1..100000, got {text}"
        raise argparse.ArgumentTypeError(msg)
    return value


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.description = DESCRIPTION
    p.formatter_class = argparse.RawDescriptionHelpFormatter
    p.add_argument("source", help="video file, a folder of chessboard images, or a Gyroflow lens profile .json")
    # chessboard options: None when not given, so that a lens profile (which states its own model) can refuse them
    p.add_argument("--board", type=_board, default=None, help="inner corners, COLSxROWS (default 9x6)")
    p.add_argument("--square-mm", type=_positive, default=None, help="chessboard square size in mm (default 25)")
    p.add_argument("--model", choices=("plumb_bob", "equidistant"), default=None,
                   help="distortion model: plumb_bob (ordinary lenses, the default) or equidistant (fisheye: action "
                        "cameras)")
    p.add_argument("--every", type=_every, default=None, help="use every Nth video frame (default 10)")
    p.add_argument("--out", required=True, help="output camera_info YAML path")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")


def _images(source: Path, every: int, progress: Any = None) -> Iterator[NDArray[np.uint8]]:
    """The grey images of a folder or every ``every``-th frame of a video; ``progress.set(done, total)`` per image."""
    import cv2  # noqa: PLC0415

    def tick(done: int, total: int | None) -> None:
        if progress is not None:
            progress.set(done, total)

    if source.is_dir():
        files = sorted(f for f in source.iterdir() if f.suffix.lower() in _IMAGE_SUFFIXES)
        if not files:
            msg = f"{source}: no images ({', '.join(sorted(_IMAGE_SUFFIXES))}) in this folder"
            raise InvalidInputError(msg)
        for k, f in enumerate(files):
            img = cv2.imread(str(f), cv2.IMREAD_GRAYSCALE)
            if img is None:
                msg = f"{f}: cannot decode image"
                raise InvalidInputError(msg)
            tick(k + 1, len(files))
            yield img
        return
    if not source.exists():
        msg = f"{source}: no such file or folder"
        raise InvalidInputError(msg)
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")  # FFmpeg's own lines: ours is the one (as VideoFile)
    cap = cv2.VideoCapture(str(source))
    if not cap.isOpened():
        msg = f"{source}: cannot open as a video"
        raise InvalidInputError(msg)
    n_frames = int(cap.get(cv2.CAP_PROP_FRAME_COUNT) or 0)
    total = -(-n_frames // max(every, 1)) if n_frames > 0 else None
    try:
        i = 0
        got_any = False
        while True:
            ok, frame = cap.read()
            if not ok:
                break
            got_any = True
            if i % max(every, 1) == 0:
                tick(i // max(every, 1) + 1, total)
                yield cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
            i += 1
        if not got_any:
            msg = f"{source}: no decodable frames"
            raise InvalidInputError(msg)
    finally:
        cap.release()


def run(args: argparse.Namespace) -> int:
    from walkmon.camera.chessboard import calibrate_chessboard  # noqa: PLC0415
    from walkmon.camera.model import write_camera_yaml  # noqa: PLC0415
    from walkmon.commands.progress import Progress  # noqa: PLC0415

    chessboard = {"--board": args.board, "--square-mm": args.square_mm, "--model": args.model, "--every": args.every}
    if str(args.source).lower().endswith(".json"):  # a published (Gyroflow) lens profile
        from walkmon.camera.lens_profile import read_lens_profile  # noqa: PLC0415

        given = [k for k, v in chessboard.items() if v is not None]
        if given:  # they were silently ignored (user review): the profile states its lens model itself
            msg = (f"{', '.join(given)} apply to chessboard calibration; a lens profile states its own model: "
                   f"give the profile alone")
            raise ConfigError(msg)
        cam = read_lens_profile(args.source)
        write_camera_yaml(cam, args.out)
        sys.stdout.write(f"lens profile {cam.name!r}: {cam.width_px}x{cam.height_px} {cam.distortion_model}, "
                         f"fx={cam.fx:.1f} fy={cam.fy:.1f} cx={cam.cx:.1f} cy={cam.cy:.1f} -> {args.out}\n")
        return 0

    board = (9, 6) if args.board is None else args.board
    square_mm = 25.0 if args.square_mm is None else args.square_mm
    every = 10 if args.every is None else args.every
    with Progress(None, "finding the chessboard", "image", enabled=False if args.no_progress else None) as progress:
        result = calibrate_chessboard(_images(Path(args.source), every, progress), board, square_mm,
                                      distortion_model=args.model or "plumb_bob")
    write_camera_yaml(result.camera, args.out)
    cam = result.camera
    sys.stdout.write(
        f"calibrated from {result.n_views} of {result.n_images} views: fx={cam.fx:.1f} fy={cam.fy:.1f} "
        f"cx={cam.cx:.1f} cy={cam.cy:.1f}, RMS reprojection error {result.rms_reprojection_px:.3f} px -> {args.out}\n"
    )
    return 0
