"""``walkmon simulate``: a synthetic walking session with ground truth (video, truth, IMU, calibration, meta)."""

from __future__ import annotations

import argparse
import sys

NAME = "simulate"
HELP = "simulate a chest-camera walk: video.mp4, truth.csv, imu.csv, camera.yaml and meta.json in --out DIR"

_WALK_HELP = (
    "walk type (normal, left_shoulder_down, right_foot_drag, bend) lasting --seconds, or a script of "
    "TYPE:SECONDS segments such as normal:10,bend:10 (stand:S pauses); 2 s of standing start and end every session, "
    "except in session scripts, taken literally: those with turn:DEGREES[:SECONDS] (> 0 right) or pause:SECONDS "
    "segments, e.g. stand:3,normal:10,turn:180,normal:8,pause:2,bend:10 (starts standing, ends mid-walk); "
    "mount:PITCH[:ROLL] anywhere tilts the camera (and its IMU) on the trunk, degrees (e.g. mount:-15: pointing "
    "15 deg down); lr:X anywhere makes the trunk pitch differently on the left and right steps (a stride rhythm X "
    "times the pitch's step amplitude, 0-3); with --unkind, the walk type a random unkind session is built around"
)


def _even_size(text: str) -> int:
    """A positive, even image size: the video encoder makes an odd one even (user review: '--width 321' printed and
    wrote a 321x241 camera.yaml beside a 320x240 video)."""
    value = _positive_int(text)
    if value % 2:
        msg = f"must be even (a video's width and height are), got {value}"
        raise argparse.ArgumentTypeError(msg)
    return value


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        msg = f"expected a whole number, got {text!r}"
        raise argparse.ArgumentTypeError(msg) from None
    if value <= 0:
        msg = f"must be positive, got {value}"
        raise argparse.ArgumentTypeError(msg)
    return value


def _seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        msg = f"expected a whole number, got {text!r}"
        raise argparse.ArgumentTypeError(msg) from None
    if value < 0:
        msg = f"must be >= 0, got {value}"
        raise argparse.ArgumentTypeError(msg)
    return value


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        msg = f"expected a number, got {text!r}"
        raise argparse.ArgumentTypeError(msg) from None
    if not value > 0 or value == float("inf"):
        msg = f"must be a positive number, got {text}"
        raise argparse.ArgumentTypeError(msg)
    return value


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--walk", default="normal", help=_WALK_HELP + " (default normal)")
    p.add_argument("--seconds", type=_positive_float, default=16.0,
                   help="session length incl. standing, for a single walk type (default 16)")
    p.add_argument("--seed", type=_seed, default=0, help="random seed: same seed, same session (default 0)")
    p.add_argument("--out", required=True, help="output folder (created; files in it are overwritten)")
    p.add_argument("--width", type=_even_size, default=640, help="image width in pixels, even (default 640)")
    p.add_argument("--height", type=_even_size, default=480, help="image height in pixels, even (default 480)")
    p.add_argument("--fps", type=_positive_float, default=30.0, help="frame rate (default 30)")
    p.add_argument("--distortion", action="store_true", help="render through a lens with barrel distortion")
    p.add_argument("--rolling-shutter-ms", type=float, default=0.0, metavar="MS",
                   help="rolling-shutter readout time top to bottom, 0-100 ms (default 0: global shutter)")
    p.add_argument("--no-video", action="store_true", help="write truth, IMU, camera and meta only (fast)")
    p.add_argument("--unkind", action="store_true",
                   help="a random session as unkind as life, drawn from --seed around the --walk type: random "
                        "standing or mid-walk start and end, pauses, 90/180 degree turns, gait initiation and "
                        "termination, a posture change mid-walk (the script is printed and kept in meta.json)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar even on a terminal")


def run(args: argparse.Namespace) -> int:
    from walkmon.commands.progress import Progress  # noqa: PLC0415
    from walkmon.simulate import RenderSettings, simulate  # noqa: PLC0415

    settings = RenderSettings(rolling_shutter_s=args.rolling_shutter_ms / 1000.0)
    walk = args.walk
    if args.unkind:
        from walkmon.simulate.unkind import unkind_script  # noqa: PLC0415

        walk = unkind_script(args.seed, args.walk)
    with Progress(None, "rendering", "frame", enabled=False if args.no_progress else None) as progress:
        result = _simulate(simulate, args, walk, settings, progress)
    what = f"{result.n_frames} frames rendered in {result.render_time_s:.1f} s" if result.video_path else "no video"
    sys.stdout.write(
        f"simulated {walk!r} seed {args.seed}: {result.duration_s:.2f} s at {result.fps:g} fps "
        f"({result.camera.width_px}x{result.camera.height_px}), {what} -> {result.out_dir}\n"
    )
    return 0


def _simulate(simulate, args: argparse.Namespace, walk: str, settings, progress):  # noqa: ANN001, ANN202
    return simulate(
        args.out,
        walk=walk,
        seconds=args.seconds,
        seed=args.seed,
        width=args.width,
        height=args.height,
        fps=args.fps,
        distortion=args.distortion,
        video=not args.no_video,
        render_settings=settings,
        on_frame=progress.set,
    )
