"""``walkmon analyze VIDEO --out DIR``: camera rotation of every frame of a walking video -> DIR/angles.csv.

angles.csv: ``t,pitch,yaw,roll`` (seconds from the first frame; degrees, orientation relative to the first
frame, conventions of walkmon.consts) then ``n_inliers,n_tracks,residual_px,model,status,keyframe``.
Later stages (gait indicators, report) read the same ``t_s``/``angles_deg`` arrays: see the marked place in
:func:`run`.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TextIO

import numpy as np
from numpy.typing import NDArray

from walkmon.errors import InvalidInputError

NAME = "analyze"
HELP = "estimate the camera rotation of every frame of a walking video -> OUT/angles.csv, indicators.json, report.html"

_log = logging.getLogger(__name__)

#: Extra columns of angles.csv after t,pitch,yaw,roll.
EXTRA_COLUMNS = ("n_inliers", "n_tracks", "residual_px", "model", "status", "keyframe")


_PRECISION = {"t": 4, "pitch": 4, "yaw": 4, "roll": 4, "residual_px": 3, "n_inliers": 0, "n_tracks": 0, "keyframe": 0}


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("video", nargs="?", help="video file (any format OpenCV/FFmpeg reads, e.g. mp4); optional with --imu")
    p.add_argument("--calib", metavar="CAMERA_YAML", help="ROS camera_info YAML (default: 70 deg HFOV pinhole)")
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
    """A one-line progress bar with frames/s on stderr, drawn only when stderr is a terminal."""

    def __init__(self, total: int, stream: TextIO | None = None, enabled: bool | None = None) -> None:
        self.stream = stream or sys.stderr
        self.enabled = self.stream.isatty() if enabled is None else enabled
        self.total = total
        self.count = 0
        self.t0 = time.perf_counter()
        self._last = 0.0

    def update(self, n: int = 1) -> None:
        self.count += n
        now = time.perf_counter()
        if self.enabled and (now - self._last > 0.2 or self.count == self.total):
            self._last = now
            fps = self.count / max(now - self.t0, 1e-9)
            if self.total > 0:
                frac = min(1.0, self.count / self.total)
                bar = "#" * int(30 * frac)
                self.stream.write(f"\r[{bar:<30}] {self.count}/{self.total} frames {fps:6.1f} frames/s")
            else:
                self.stream.write(f"\r{self.count} frames {fps:6.1f} frames/s")
            self.stream.flush()

    def close(self) -> None:
        if self.enabled:
            self.stream.write("\n")
            self.stream.flush()


def estimate_rotations(frames: Iterable[tuple[float, NDArray[np.uint8]]], estimator, on_frame: Callable[[], None] | None = None):  # noqa: ANN001, ANN201
    """Push every ``(t_s, frame)`` through ``estimator``; returns the list of RotationEstimate."""
    out = []
    for t_s, frame in frames:
        out.append(estimator.push(frame, t_s))
        if on_frame is not None:
            on_frame()
    return out


def angle_columns(estimates) -> dict[str, object]:  # noqa: ANN001
    """The angles.csv columns of a list of RotationEstimate (t from the first frame)."""
    if not estimates:
        msg = "no frames to write"
        raise InvalidInputError(msg)
    t = np.array([e.t_s for e in estimates]) - estimates[0].t_s
    a = np.array([e.angles_deg for e in estimates]).reshape(-1, 3)
    return {
        "t": t,
        "pitch": a[:, 0],
        "yaw": a[:, 1],
        "roll": a[:, 2],
        "n_inliers": np.array([e.n_inliers for e in estimates], dtype=int),
        "n_tracks": np.array([e.n_tracks for e in estimates], dtype=int),
        "residual_px": np.array([e.residual_px for e in estimates]),
        "model": [e.model for e in estimates],
        "status": [e.status.value for e in estimates],
        "keyframe": np.array([int(e.keyframe) for e in estimates], dtype=int),
    }


def status_summary(estimates) -> str:  # noqa: ANN001
    """``"480 frames: 470 ok, 8 low_quality (rotation-only), 2 held (too_few_features)"``.

    ok counts the measured frames (``ok`` and the ``first_frame``); a frame whose status is not ok is either
    still estimated (``low_quality`` with the rotation-only fit) and counted under its status, or held (model
    ``hold``: the last orientation repeated) and counted under "held" with its statuses. Zero counts are left out.
    """
    from collections import Counter  # noqa: PLC0415

    n_ok = sum(e.status.is_measured for e in estimates)
    estimated = Counter(e.status.value for e in estimates if not e.status.is_measured and e.model != "hold")
    held = Counter(e.status.value for e in estimates if not e.status.is_measured and e.model == "hold")
    parts = [f"{n_ok} ok"] if n_ok else []
    parts += [f"{n} {status}{' (rotation-only)' if status == 'low_quality' else ''}"
              for status, n in sorted(estimated.items())]
    if held:
        why = ", ".join(status if len(held) == 1 else f"{n} {status}" for status, n in sorted(held.items()))
        parts.append(f"{sum(held.values())} held ({why})")
    return f"{len(estimates)} frames: {', '.join(parts) or 'none'}"


def run(args: argparse.Namespace) -> int:
    from walkmon.camera.model import default_camera, read_camera_yaml  # noqa: PLC0415
    from walkmon.drivers.video_file import VideoFile  # noqa: PLC0415
    from walkmon.rotation import RotationEstimator, RotationSettings  # noqa: PLC0415
    from walkmon.tables import write_table  # noqa: PLC0415

    out_dir = Path(args.out)
    if args.video is None:  # IMU-only analysis (IMU engineer): angles.csv from imu.csv, then the same gait stages
        if not args.imu:
            msg = "give a VIDEO, or --imu IMU_CSV for IMU-only analysis"
            raise InvalidInputError(msg)
        from walkmon.commands.imu_args import analyze_imu_only  # noqa: PLC0415

        t_s, angles_deg = analyze_imu_only(args, sys.stdout)
        from walkmon.tables import read_table  # noqa: PLC0415

        absolute = read_table(out_dir / "angles.csv", ("pitch_abs", "roll_abs"))
        return _later_stages(args, out_dir, t_s, angles_deg, [],
                             np.column_stack([absolute["pitch_abs"], absolute["roll_abs"]]))
    camera = read_camera_yaml(args.calib) if args.calib else None
    with VideoFile(args.video) as video:
        if camera is None:
            camera = default_camera(video.width_px, video.height_px)
        elif (camera.width_px, camera.height_px) != (video.width_px, video.height_px):
            _log.warning(
                "calibration is for %dx%d, video is %dx%d: scaling the intrinsics",
                camera.width_px, camera.height_px, video.width_px, video.height_px,
            )
            camera = camera.scaled_to(video.width_px, video.height_px)
        estimator = RotationEstimator(camera, RotationSettings(method=args.method))
        progress = _Progress(video.frame_count, enabled=False if args.no_progress else None)
        try:
            estimates = estimate_rotations(video, estimator, progress.update)
        finally:
            progress.close()
    columns = angle_columns(estimates)
    if args.imu:  # camera-IMU fusion (IMU engineer): fused pitch/yaw/roll, + pitch_abs/roll_abs, *_video kept
        from walkmon.commands.imu_args import fuse_video_columns  # noqa: PLC0415

        measured = [e.status.is_measured for e in estimates]
        columns = fuse_video_columns(args, columns, measured, estimates[0].t_s, sys.stdout)
    out_dir.mkdir(parents=True, exist_ok=True)
    angles_path = out_dir / "angles.csv"
    write_table(angles_path, columns, precision={**_PRECISION})
    sys.stdout.write(f"{status_summary(estimates)} -> {angles_path}\n")

    t_s = np.asarray(columns["t"], dtype=float)
    angles_deg = np.column_stack([columns["pitch"], columns["yaw"], columns["roll"]])
    absolute = (np.column_stack([columns["pitch_abs"], columns["roll_abs"]]).astype(float)
                if "pitch_abs" in columns else None)
    return _later_stages(args, out_dir, t_s, angles_deg, estimates, absolute)


def _later_stages(args: argparse.Namespace, out_dir: Path, t_s, angles_deg, estimates,  # noqa: ANN001
                  abs_angles_deg: np.ndarray | None = None) -> int:
    """indicators.json / report.html and the optional session record, from (t_s, angles_deg) (and the fused
    absolute pitch/roll for the report when an IMU was fused)."""
    # ---- later stages: indicators.json / report.html from (t_s, angles_deg) go here (gait engineer) ----
    from walkmon.commands.indicators import gait_outputs, summary_line  # noqa: PLC0415

    source = str(args.video) if args.video is not None else f"IMU only: {args.imu}"
    gait = gait_outputs(out_dir, t_s, angles_deg, baseline_path=args.baseline, mode=args.mode,
                        meta={"video": source, "rotation method": args.method},
                        abs_angles_deg=abs_angles_deg)
    sys.stdout.write(summary_line(*gait))
    if getattr(args, "save", False):  # live engineer: offline checks land in the same session history
        from walkmon.live.session_log import default_data_dir, record_offline_session  # noqa: PLC0415

        data_dir = Path(args.data_dir).expanduser() if args.data_dir else default_data_dir()
        # with an IMU, the frames' pitch_abs/roll_abs as 'walkmon live' stores them, so 'walkmon report ID'
        # shows their section; fused (1: the IMU covered the frame, 0: camera only) only when a video was fused
        fused = (None if abs_angles_deg is None or args.video is None
                 else np.all(np.isfinite(abs_angles_deg), axis=1).tolist())
        sid = record_offline_session(
            data_dir, t_s, angles_deg, source=source, imu=str(args.imu or ""),
            config={"method": args.method}, meta={"out_dir": str(out_dir), "baseline": args.baseline},
            extra=[(e.n_inliers, e.model, e.status.value) for e in estimates] or None,  # none: IMU-only
            abs_angles_deg=abs_angles_deg, fused=fused,
        )
        sys.stdout.write(f"saved as session {sid} in {data_dir}\n")
    return 0
