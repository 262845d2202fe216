"""``walkmon analyze VIDEO --out DIR``: camera rotation of every frame of a walking video -> DIR/angles.csv,
indicators.json, report.html.

angles.csv: ``t,pitch,yaw,roll`` (seconds from the first frame; degrees, orientation relative to the first
frame, conventions of walkmon.consts) then ``n_inliers,n_tracks,residual_px,model,status,keyframe``.
The analysis itself is :func:`walkmon.api.analyze` (the Python API); this module holds the options, the
progress bar and the printing.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TextIO

from walkmon.api import status_summary

__all__ = ["add_arguments", "run", "status_summary"]

NAME = "analyze"
HELP = "estimate the camera rotation of every frame of a walking video -> OUT/angles.csv, indicators.json, report.html"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("video", nargs="?", help="video file (any format OpenCV/FFmpeg reads, e.g. mp4); optional with --imu")
    p.add_argument("--calib", metavar="CAMERA", help="ROS camera_info YAML, or a Gyroflow lens profile .json (action "
                   "cameras: fisheye lenses; see 'walkmon calibrate --help'); default: 70 deg HFOV pinhole")
    p.add_argument("--readout-ms", type=float, default=None, metavar="MS",
                   help="the camera's rolling-shutter readout time, top row to bottom, 0-100 ms (phones, action and USB "
                   "cameras: 5-30 ms; 0: global shutter); default: the calibration file's readout_s, else 0")
    p.add_argument("--method", choices=("fast", "paper"), default="fast", help="rotation method (default fast)")
    p.add_argument("--out", required=True, help="output folder (created) for angles.csv")
    p.add_argument("--no-progress", action="store_true", help="no progress bar even on a terminal")
    from walkmon.commands.indicators import add_gait_arguments  # noqa: PLC0415

    add_gait_arguments(p)  # --baseline, --mode: indicators.json + report.html (gait engineer)
    p.add_argument("--save", action="store_true", help="also record the result as a session in the session log")
    p.add_argument("--data-dir", metavar="DIR", help="session database folder for --save (default ~/.local/share/walkmon)")
    from walkmon.commands.imu_args import add_imu_arguments  # noqa: PLC0415

    add_imu_arguments(p)  # --imu [--imu-filter --imu-offset-s --imu-extrinsics]: IMU-only or fused (IMU engineer)


class _Progress:
    """The frames progress bar (tqdm: count, rate and ETA) on stderr, drawn only when stderr is a terminal."""

    def __init__(self, total: int, stream: TextIO | None = None, enabled: bool | None = None,
                 delay_s: float = 0.5) -> None:
        from walkmon.commands.progress import Progress  # noqa: PLC0415

        self._p = Progress(total if total > 0 else None, "analysing", "frames", enabled=enabled, stream=stream,
                           delay_s=delay_s)
        self.enabled = self._p.enabled
        self.total = total

    @property
    def count(self) -> int:
        return self._p.count

    def update(self, n: int = 1) -> None:
        self._p.update(n)

    def __call__(self, done: int, total: int) -> None:
        """The progress callback of :func:`walkmon.api.analyze`: ``done`` of ``total`` frames."""
        self.total = total
        self.update(done - self.count)

    def close(self) -> None:
        self._p.close()


def run(args: argparse.Namespace) -> int:
    from walkmon.api import analyze  # noqa: PLC0415

    out_dir = Path(args.out)
    if args.save:  # a data folder that cannot hold the session refused before anything is analysed or written
        from walkmon.live.session_log import check_database_usable, default_data_dir  # noqa: PLC0415

        check_database_usable(Path(args.data_dir).expanduser() if args.data_dir else default_data_dir())
    progress = _Progress(0, enabled=False if args.no_progress or args.video is None else None)
    try:
        result = analyze(args.video, imu=args.imu, calib=args.calib, method=args.method, baseline=args.baseline,
                         mode=args.mode, imu_filter=args.imu_filter, imu_offset_s=args.imu_offset_s,
                         imu_extrinsics=args.imu_extrinsics, imu_calib=args.imu_calib, progress=progress,
                         readout_s=None if args.readout_ms is None else args.readout_ms / 1000.0)
    finally:
        progress.close()
    files = result.write(out_dir)
    info = result.imu_info or {}
    if info.get("mode") == "imu_only":
        sys.stdout.write(f"{info['samples']} IMU samples ({info['rate_hz']:.0f} Hz, {info['imu_filter']}) -> "
                         f"{info['rows']} rows of {files['angles.csv']}\n")
    if info.get("mode") == "accelerometer_only":
        sys.stdout.write(f"{info['samples']} accelerometer samples ({info['rate_hz']:.0f} Hz; no gyroscope: no yaw, "
                         f"no turns) -> {info['rows']} rows of {files['angles.csv']}\n")
    if info.get("mode") == "fused":
        sys.stdout.write(f"fused with {info['imu']}: {info['visual_increments_used']} visual increments used, "
                         f"{info['visual_increments_rejected']} rejected\n")
    if info.get("gaps"):
        g = info["gaps"]
        sys.stdout.write(f"note: the IMU has {g['n']} gap(s) without samples, {g['total_s']:.1f} s in all (the "
                         f"longest {g['longest_s']:.1f} s; imu.json lists them)\n")
    if result.estimates:
        sys.stdout.write(f"{result.status_summary()} -> {files['angles.csv']}\n")
    from walkmon.commands.indicators import summary_line  # noqa: PLC0415

    sys.stdout.write(summary_line(files["indicators.json"], files["report.html"], result.gait))
    if args.save:  # offline checks land in the same session history as 'walkmon live'
        from walkmon.live.session_log import default_data_dir  # noqa: PLC0415

        data_dir = Path(args.data_dir).expanduser() if args.data_dir else default_data_dir()
        sid = result.save(data_dir, meta={"out_dir": str(out_dir), "baseline": args.baseline})
        sys.stdout.write(f"saved as session {sid} in {data_dir}\n")
    return 0
