"""The IMU options and IMU file handling of ``walkmon analyze`` (argparse and printing; the maths is in
:mod:`walkmon.imu.recordings`)."""

from __future__ import annotations

import argparse
import json
import logging
from pathlib import Path
from typing import TextIO

import numpy as np
from numpy.typing import ArrayLike, NDArray

from walkmon.errors import ConfigError, InvalidInputError
from walkmon.imu.fusion import FusionSettings
from walkmon.imu.recordings import (
    IMU_FILTERS,
    extrinsics_from_angles,
    fused_columns,
    imu_only_columns,
)
from walkmon.tables import read_imu_csv, write_table

__all__ = ["add_imu_arguments", "analyze_imu_only", "fuse_video_columns"]

_log = logging.getLogger(__name__)


def add_imu_arguments(p: argparse.ArgumentParser) -> None:
    """The IMU options of ``walkmon analyze`` (VIDEO becomes optional when --imu is given)."""
    g = p.add_argument_group("IMU (optional)")
    g.add_argument("--imu", metavar="IMU_CSV", help="imu.csv (t,gx,gy,gz,ax,ay,az; s, rad/s, m/s2): fused with the "
                   "video, or IMU-only analysis when no VIDEO is given; adds pitch_abs,roll_abs to angles.csv")
    g.add_argument("--imu-filter", choices=IMU_FILTERS, default="eskf",
                   help="IMU-only attitude filter (default eskf; vqf needs the vqf package)")
    g.add_argument("--imu-offset-s", type=float, default=0.0, metavar="S",
                   help="seconds added to IMU timestamps to put them on the video clock (default 0)")
    g.add_argument("--imu-extrinsics", choices=("identity", "estimate"), default="identity",
                   help="IMU-to-camera rotation: identity (IMU axes = camera axes) or estimate it and the time "
                   "offset from this recording (gyro vs visual rates; result and residual in OUT/imu.json)")


def _settings(args: argparse.Namespace) -> FusionSettings:
    return FusionSettings(time_offset_s=float(args.imu_offset_s))


def analyze_imu_only(args: argparse.Namespace, stream: TextIO) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``walkmon analyze --imu imu.csv --out DIR``: writes DIR/angles.csv; returns (t_s, angles_deg (N,3))."""
    if args.imu_extrinsics == "estimate":
        msg = "--imu-extrinsics estimate needs a VIDEO (the camera's rotation is what the IMU is aligned to)"
        raise ConfigError(msg)
    imu = read_imu_csv(args.imu)
    cols = imu_only_columns(imu, _settings(args), imu_filter=args.imu_filter)
    out_dir = Path(args.out)
    out_dir.mkdir(parents=True, exist_ok=True)
    write_table(out_dir / "angles.csv", cols, precision=dict.fromkeys(cols, 4))
    info = {"mode": "imu_only", "imu": str(args.imu), "imu_filter": args.imu_filter, "samples": len(imu.t_s),
            "rate_hz": round(imu.rate_hz, 3), "rows": len(cols["t"]),
            "axes": "IMU's own axes (no camera extrinsics)"}
    (out_dir / "imu.json").write_text(json.dumps(info, indent=1), encoding="utf-8")
    stream.write(f"{len(cols['t'])} IMU rows ({imu.rate_hz:.0f} Hz, {args.imu_filter}) -> {out_dir / 'angles.csv'}\n")
    return cols["t"], np.column_stack([cols["pitch"], cols["yaw"], cols["roll"]])


def fuse_video_columns(
    args: argparse.Namespace, columns: dict[str, object], measured: ArrayLike, frame_t0_s: float, stream: TextIO
) -> dict[str, object]:
    """``walkmon analyze VIDEO --imu imu.csv``: the video's angles.csv columns with pitch/yaw/roll replaced by
    the fused angles, plus pitch_abs, roll_abs, visual_used and the video-only angles as pitch_video, ...;
    writes OUT/imu.json (mode, extrinsics estimate and residual, increments used)."""
    imu = read_imu_csv(args.imu)
    t = np.asarray(columns["t"], dtype=float)
    ft = t + frame_t0_s
    visual = np.column_stack([np.asarray(columns[k], dtype=float) for k in ("pitch", "yaw", "roll")])
    ok = np.asarray(measured, dtype=bool)
    settings = _settings(args)
    info: dict[str, object] = {"mode": "fused", "imu": str(args.imu), "samples": len(imu.t_s),
                               "rate_hz": round(imu.rate_hz, 3)}
    try:
        ext = extrinsics_from_angles(imu, ft, visual, ok)
        info["extrinsics_estimate"] = ext.to_dict()
    except InvalidInputError as exc:
        ext = None
        info["extrinsics_estimate"] = f"not estimated: {exc}"
        if args.imu_extrinsics == "estimate":
            raise
    if args.imu_extrinsics == "estimate" and ext is not None and not ext.well_conditioned:
        msg = (f"cannot estimate the IMU-camera rotation from this recording (it rotated about one axis only: "
               f"excitation {ext.axis_excitation:.3f}, correlation {ext.correlation:.2f}); walk longer or give none")
        raise InvalidInputError(msg)
    if args.imu_extrinsics == "estimate" and ext is not None:
        settings = FusionSettings(camera_from_imu=tuple(ext.camera_from_imu.ravel()), time_offset_s=ext.time_offset_s)
        _log.info("using the estimated extrinsics (residual %.2f deg/s)", ext.residual_deg_s)
    info["extrinsics_used"] = {"camera_from_imu": settings.camera_from_imu_matrix.round(6).tolist(),
                               "time_offset_s": settings.time_offset_s}
    cols, track = fused_columns(imu, ft, visual, ok, settings)
    out: dict[str, object] = {"t": t}
    out.update({k: cols[k] for k in ("pitch", "yaw", "roll", "pitch_abs", "roll_abs")})
    out["visual_used"] = [str(int(v)) for v in cols["visual_used"]]  # 0/1, written as integers
    out.update({"pitch_video": visual[:, 0], "yaw_video": visual[:, 1], "roll_video": visual[:, 2]})
    out.update({k: v for k, v in columns.items() if k not in ("t", "pitch", "yaw", "roll")})
    info["visual_increments_used"] = int(track.visual_used.sum())
    info["visual_increments_rejected"] = int(track.frames_rejected)
    Path(args.out).mkdir(parents=True, exist_ok=True)
    (Path(args.out) / "imu.json").write_text(json.dumps(info, indent=1), encoding="utf-8")
    stream.write(f"fused with {args.imu}: {info['visual_increments_used']} visual increments used, "
                 f"{info['visual_increments_rejected']} rejected\n")
    return out
