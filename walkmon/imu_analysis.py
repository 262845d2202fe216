"""IMU file analysis: imu.csv alone, or imu.csv fused with a video's visual rotations -> angles.csv columns.

``walkmon analyze --imu imu.csv --out DIR`` (IMU only) and ``walkmon analyze VIDEO --imu imu.csv --out DIR``
(fused) call :func:`imu_only_columns` / :func:`fused_columns` and write what they return. Both give the usual
``t,pitch,yaw,roll`` (start-relative, degrees) plus ``pitch_abs,roll_abs`` (relative to gravity, from the
estimated gravity direction in the camera frame; with no extrinsics, in the IMU's own axes).

imu.csv: header ``t,gx,gy,gz,ax,ay,az`` (s, rad/s, m/s², specific force), on the video's clock unless a time
offset is given.
"""

from __future__ import annotations

import argparse
import json
import logging
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TextIO

import numpy as np
from numpy.typing import ArrayLike, NDArray

from walkmon.consts import (
    IMU_COLUMNS,
    angles_deg_from_rotation,
    gravity_angles_deg_from_gravity,
    rotation_from_angles_deg,
)
from walkmon.errors import ConfigError, InvalidInputError
from walkmon.fusion import DEFAULT_FUSION_SETTINGS, FusionSettings, FusionTrack, fuse_recording
from walkmon.imu_attitude import HANDHELD_ATTITUDE_SETTINGS
from walkmon.imu_extrinsics import ExtrinsicsEstimate, estimate_extrinsics
from walkmon.tables import read_table, write_table

__all__ = [
    "ABS_COLUMNS",
    "IMU_FILTERS",
    "ImuRecording",
    "add_imu_arguments",
    "analyze_imu_only",
    "extrinsics_from_angles",
    "fuse_video_columns",
    "fused_columns",
    "imu_only_columns",
    "read_imu_csv",
    "rotation_matrices_from_quaternions_wxyz",
    "vqf_attitude",
]

_log = logging.getLogger(__name__)

#: Columns angles.csv gains with an IMU.
ABS_COLUMNS = ("pitch_abs", "roll_abs")

#: Highest output rate of IMU-only analysis (the IMU is decimated to this), Hz.
IMU_ONLY_MAX_RATE_HZ = 100.0


@dataclass(frozen=True, slots=True)
class ImuRecording:
    """An IMU recording: times (N,) s, gyroscope (N,3) rad/s, accelerometer (N,3) m/s²."""

    t_s: NDArray[np.float64]
    gyroscope_rad_s: NDArray[np.float64]
    accelerometer_m_s2: NDArray[np.float64]

    def __post_init__(self) -> None:
        for name in self.__slots__:  # type: ignore[attr-defined]
            getattr(self, name).setflags(write=False)

    @property
    def rate_hz(self) -> float:
        return (len(self.t_s) - 1) / max(float(self.t_s[-1] - self.t_s[0]), 1e-9)


def read_imu_csv(path: str | Path) -> ImuRecording:
    """Read imu.csv (``t,gx,gy,gz,ax,ay,az``); malformed files raise InvalidInputError with one line."""
    cols = read_table(path, IMU_COLUMNS)
    t = cols["t"]
    if len(t) < 10:
        msg = f"{path}: only {len(t)} IMU samples; need at least 10"
        raise InvalidInputError(msg)
    if np.any(np.diff(t) <= 0):
        msg = f"{path}: IMU timestamps must strictly increase"
        raise InvalidInputError(msg)
    gyro = np.column_stack([cols["gx"], cols["gy"], cols["gz"]])
    accel = np.column_stack([cols["ax"], cols["ay"], cols["az"]])
    return ImuRecording(t, gyro, accel)


def _columns(track: FusionTrack, t_out: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
    return {
        "t": t_out,
        "pitch": track.angles_deg[:, 0],
        "yaw": track.angles_deg[:, 1],
        "roll": track.angles_deg[:, 2],
        "pitch_abs": track.abs_angles_deg[:, 0],
        "roll_abs": track.abs_angles_deg[:, 1],
    }


#: IMU-only attitude filters: walkmon's error-state Kalman filter with its walking defaults (simulated walks:
#: ~0.03 deg), the same with the hand-held preset for real hand-held IMUs (gyro samples as interval means,
#: gravity low-passed over 2 s in the gyro frame: on the BROAD trials no worse than vqf online and imufusion),
#: or VQF (offline variant; ``pip install vqf``), the best on BROAD offline but 1-2 deg off in pitch on walks
#: (its 3 s accelerometer low-pass takes the start and stop of walking for tilt; benchmarks/results/fusion.md).
IMU_FILTERS = ("eskf", "eskf-handheld", "vqf")


def imu_only_columns(
    imu: ImuRecording,
    settings: FusionSettings = DEFAULT_FUSION_SETTINGS,
    *,
    max_rate_hz: float = IMU_ONLY_MAX_RATE_HZ,
    imu_filter: str = "eskf",
) -> dict[str, NDArray[np.float64]]:
    """IMU-only attitude at the IMU's sample times (decimated to at most ``max_rate_hz``), t from the first
    sample; angles relative to the first sample; ``imu_filter`` one of :data:`IMU_FILTERS`."""
    if imu_filter not in IMU_FILTERS:
        msg = f"unknown IMU filter {imu_filter!r}; expected one of {', '.join(IMU_FILTERS)}"
        raise ConfigError(msg)
    step = max(1, int(np.ceil(imu.rate_hz / max_rate_hz - 1e-9)))
    t_video = imu.t_s[::step] + settings.time_offset_s
    if imu_filter == "vqf":
        R_ci = settings.camera_from_imu_matrix
        rotations, down = vqf_attitude(imu.gyroscope_rad_s @ R_ci.T, imu.accelerometer_m_s2 @ R_ci.T, imu.rate_hz)
        rel = np.einsum("ji,njk->nik", rotations[0], rotations[::step])
        cols = {"t": t_video - t_video[0]}
        angles = angles_deg_from_rotation(rel)
        absolute = gravity_angles_deg_from_gravity(down[::step])
        cols.update(pitch=angles[:, 0], yaw=angles[:, 1], roll=angles[:, 2])
        cols.update(pitch_abs=absolute[:, 0], roll_abs=absolute[:, 1])
        return cols
    if imu_filter == "eskf-handheld":
        settings = replace(settings, attitude=HANDHELD_ATTITUDE_SETTINGS)
    track = fuse_recording(imu.t_s, imu.gyroscope_rad_s, imu.accelerometer_m_s2, t_video, settings=settings)
    _log.info("IMU-only attitude: %d samples at %.1f Hz -> %d rows", len(imu.t_s), imu.rate_hz, len(t_video))
    return _columns(track, t_video - t_video[0])


def vqf_attitude(
    gyroscope_rad_s: NDArray[np.float64], accelerometer_m_s2: NDArray[np.float64], rate_hz: float, *, offline: bool = True
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """VQF (Laidig & Seel 2023) 6-D attitude: sensor->earth rotations (N,3,3) and gravity down in the sensor
    frame (N,3). Needs the ``vqf`` package."""
    try:
        import vqf  # noqa: PLC0415
    except ImportError:
        msg = "the vqf IMU filter needs the vqf package: pip install vqf (or walkmon[imu])"
        raise ConfigError(msg) from None
    gyr = np.ascontiguousarray(gyroscope_rad_s, dtype=float)
    acc = np.ascontiguousarray(accelerometer_m_s2, dtype=float)
    if offline:
        quat = vqf.offlineVQF(gyr, acc, None, 1.0 / rate_hz)["quat6D"]
    else:
        quat = vqf.VQF(1.0 / rate_hz).updateBatch(gyr, acc)["quat6D"]
    rotations = rotation_matrices_from_quaternions_wxyz(quat)
    return rotations, -rotations[:, 2, :]


def rotation_matrices_from_quaternions_wxyz(quat: ArrayLike) -> NDArray[np.float64]:
    """(N,4) unit quaternions w,x,y,z -> (N,3,3) rotation matrices."""
    q = np.asarray(quat, dtype=float)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )


def fused_columns(
    imu: ImuRecording,
    frame_t_s: ArrayLike,
    visual_angles_deg: ArrayLike,
    visual_ok: ArrayLike | None = None,
    settings: FusionSettings = DEFAULT_FUSION_SETTINGS,
) -> tuple[dict[str, NDArray[np.float64]], FusionTrack]:
    """Fuse the video's per-frame start-relative angles (N,3 pitch,yaw,roll) with the IMU; rows at the frame
    times (``t`` as given). ``visual_ok`` marks frames the rotation estimator measured (others are not used)."""
    ft = np.asarray(frame_t_s, dtype=float).reshape(-1)
    a = np.asarray(visual_angles_deg, dtype=float)
    if a.shape != (len(ft), 3):
        msg = f"visual angles must have shape ({len(ft)}, 3), got {a.shape}"
        raise InvalidInputError(msg)
    rotations = rotation_from_angles_deg(a[:, 0], a[:, 1], a[:, 2])
    track = fuse_recording(
        imu.t_s, imu.gyroscope_rad_s, imu.accelerometer_m_s2, ft, rotations, visual_ok, settings=settings
    )
    used = int(track.visual_used.sum())
    _log.info("fusion: %d frames, %d visual increments used, %d rejected", len(ft), used, track.frames_rejected)
    cols = _columns(track, ft)
    cols["visual_used"] = track.visual_used.astype(int)
    return cols, track


def extrinsics_from_angles(
    imu: ImuRecording, frame_t_s: ArrayLike, visual_angles_deg: ArrayLike, visual_ok: ArrayLike | None = None
) -> ExtrinsicsEstimate:
    """IMU-to-camera rotation and time offset of a recording (see :mod:`walkmon.imu_extrinsics`)."""
    a = np.asarray(visual_angles_deg, dtype=float)
    rotations = rotation_from_angles_deg(a[:, 0], a[:, 1], a[:, 2])
    return estimate_extrinsics(imu.t_s, imu.gyroscope_rad_s, frame_t_s, rotations, visual_ok)


# --------------------------------------------------------------------------------------- walkmon analyze
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
