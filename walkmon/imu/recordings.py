"""IMU file analysis: imu.csv alone, or imu.csv fused with a video's visual rotations -> angles.csv columns.

``walkmon analyze --imu imu.csv --out DIR`` (IMU only) and ``walkmon analyze VIDEO --imu imu.csv --out DIR``
(fused; :mod:`walkmon.commands.imu_args`, files read by :func:`walkmon.tables.read_imu_csv`) call :func:`imu_only_columns` / :func:`fused_columns` and write what they return. Both give the usual
``t,pitch,yaw,roll`` (start-relative, degrees) plus ``pitch_abs,roll_abs`` (relative to gravity, from the
estimated gravity direction in the camera frame; with no extrinsics, in the IMU's own axes).

imu.csv: header ``t,gx,gy,gz,ax,ay,az`` (s, rad/s, m/s², specific force), on the video's clock unless a time
offset is given.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from walkmon.consts import (
    rotation_from_angles_deg,
)
from walkmon.errors import ConfigError, InvalidInputError
from walkmon.imu.attitude import IMU_FILTERS
from walkmon.imu.extrinsics import ExtrinsicsEstimate, estimate_extrinsics
from walkmon.imu.fusion import (
    DEFAULT_FUSION_SETTINGS,
    FusionSettings,
    FusionTrack,
    fuse_recording,
)
from walkmon.sampling import sampling_rate_hz

__all__ = [
    "ABS_COLUMNS",
    "IMU_FILTERS",
    "ImuRecording",
    "extrinsics_from_angles",
    "fused_columns",
    "imu_only_columns",
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
        return sampling_rate_hz(self.t_s)  # gaps left out (walkmon.sampling)


def _columns(track: FusionTrack, t_out: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
    return {
        "t": t_out,
        "pitch": track.angles_deg[:, 0],
        "yaw": track.angles_deg[:, 1],
        "roll": track.angles_deg[:, 2],
        "pitch_abs": track.abs_angles_deg[:, 0],
        "roll_abs": track.abs_angles_deg[:, 1],
    }


def imu_only_columns(
    imu: ImuRecording,
    settings: FusionSettings = DEFAULT_FUSION_SETTINGS,
    *,
    max_rate_hz: float = IMU_ONLY_MAX_RATE_HZ,
    imu_filter: str | None = None,
) -> dict[str, NDArray[np.float64]]:
    """IMU-only attitude (the attitude core of ``settings.imu_filter``, default VQF) at the IMU's sample times
    (decimated to at most ``max_rate_hz``), t from the first sample; angles relative to the first sample;
    ``imu_filter`` (one of :data:`IMU_FILTERS`) overrides the settings' filter."""
    if imu_filter is not None:
        settings = replace(settings, imu_filter=replace(settings.imu_filter, filter=imu_filter))
    step = max(1, int(np.ceil(imu.rate_hz / max_rate_hz - 1e-9)))
    t_video = imu.t_s[::step] + settings.time_offset_s
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
    """IMU-to-camera rotation and time offset of a recording (see :mod:`walkmon.imu.extrinsics`)."""
    a = np.asarray(visual_angles_deg, dtype=float)
    rotations = rotation_from_angles_deg(a[:, 0], a[:, 1], a[:, 2])
    return estimate_extrinsics(imu.t_s, imu.gyroscope_rad_s, frame_t_s, rotations, visual_ok)
