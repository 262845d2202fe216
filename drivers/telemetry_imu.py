"""An action camera's own gyroscope and accelerometer, read from its video file: ``--imu telemetry:VIDEO``.

GoPro (GPMF), Sony, Insta360, DJI and other cameras store their IMU in the video file. The PyPI package
``telemetry-parser`` (``pip install walkmon[telemetry]``) reads all of them and returns the samples in one
*normalised* axis convention whatever the brand (``Parser(path).normalized_imu()``: gyroscope in °/s,
accelerometer in m/s², time in ms). This module maps that convention onto walkmon's camera axes
(:mod:`walkmon.consts`: x right, y down, z forward) and returns the samples as the other IMU sources do: an
:class:`~walkmon.imu.recordings.ImuRecording` for offline analysis (:func:`read_telemetry_imu`) or
:class:`~walkmon.drivers.imu_types.ImuSample` one at a time for the live pipeline (:class:`TelemetryImu`).

The axis mapping (:data:`CAMERA_FROM_TELEMETRY`)
    telemetry-parser's normalised axes are X up, Y left, Z backward (out of the lens towards the operator)
    seen from behind the camera held level. So ``x_cam = -Y``, ``y_cam = -X``, ``z_cam = -Z``. Checked on a
    real GoPro HERO5 Black file (``karma.mp4``, a gimbal-levelled drone camera panning; see
    tests/drivers/test_telemetry_imu.py): the mean specific force points along -y (gravity down the image:
    fixes the y axis and its sign); the mapped gyroscope's yaw rate follows the yaw rate walkmon's visual
    estimator measures on the frames with correlation 0.997 (fixes y for the gyroscope too); the barely
    excited pitch and roll rates (0.2-0.3 °/s standard deviation, the gimbal holds them) still correlate
    positively with the visual ones (0.47 and 0.37: a sign flip would make them negative), and the residual
    rotation :func:`walkmon.imu.extrinsics.estimate_extrinsics` finds after the mapping is 4° (a
    permutation error would be 90° or 180°). Other brands rely on telemetry-parser's own per-camera
    normalisation (not checked here on a real file); ``--imu-extrinsics estimate`` measures the rotation from
    the recording instead when in doubt, and ``imu.json`` records the check for every fused run.

Accelerometer and gyroscope may be sampled at different rates (HERO5: 200 and 400 Hz); telemetry-parser then
returns samples with one of them missing. The accelerometer is linearly interpolated onto the gyroscope's
timestamps (its rate is the higher); gyroscope samples outside the accelerometer's span are dropped.

The slower stream's times (:func:`spread_bursts`): GPMF stores about a second of samples per payload, spread
evenly over it. telemetry-parser (0.3) gives a HERO5's 200 accelerometer samples of a payload the times of its
first 200 gyroscope samples: each second's accelerometer squeezed into its first half, 2.5 ms apart, then half
a second with none (karma.mp4: bursts of 196-200 samples starting 0.99-1.01 s apart). Interpolated as they came,
every step the accelerometer saw would be timed up to half a second early and a straight line would fill the
other half: the cadence of a walk filmed on a HERO5 read from nonsense. A stream whose samples come in bursts
faster than 1.5 x its rate over whole bursts, on consecutive gyroscope times, is re-timed: each burst spread
from its first sample at the stream's own rate; a stream with dropouts of its own is left as it is.

The clock: the timestamps are the telemetry track's, which starts with the video but is not frame-exact (a
frame or two on GoPro). telemetry-parser times every sample from its track's media start and applies no edit
list, so in a clip trimmed without re-encoding (its tracks' edit lists show them from the cut on) the samples
were off the frames by the trim (4 s on karma.mp4 trimmed at 4 s: the offset search, +-0.5 s, found no
agreement and fused samples from 4 s earlier): they are put on the shown frames' clock by the tracks' edit
lists, and those the edits cut away are dropped (:func:`walkmon.drivers.mp4_edits.telemetry_times_s`;
``shifted_s`` in imu.json). A camera that writes its IMU outside a track (after the media) is not moved.
``walkmon analyze`` estimates the remaining offset from gyro vs visual rates
(:func:`walkmon.imu.extrinsics.estimate_extrinsics`) unless ``--imu-offset-s`` is given.

Gravity: newer GoPros (HERO8+) also write a ``GRAV`` stream (the camera's own gravity estimate);
:func:`read_telemetry_imu` reports whether the file has one (``TelemetryImuFile.has_gravity_stream``). It is
not used by the fusion.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from walkmon.drivers.imu_types import ImuBatch, ImuSample
from walkmon.drivers.mp4_edits import telemetry_times_s
from walkmon.errors import (
    ConfigError,
    InvalidInputError,
    SourceDisconnected,
    SourceError,
)

__all__ = ["CAMERA_FROM_TELEMETRY", "TelemetryImu", "TelemetryImuFile", "read_telemetry_imu",
           "recording_from_normalized", "spread_bursts"]

#: telemetry-parser's normalised IMU axes -> walkmon camera axes (``v_camera = M @ v_normalised``).
CAMERA_FROM_TELEMETRY = np.array([[0.0, -1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
CAMERA_FROM_TELEMETRY.setflags(write=False)

#: Fewer samples than this is not an IMU recording.
_MIN_SAMPLES = 10


@dataclass(frozen=True, slots=True)
class TelemetryImuFile:
    """What :func:`read_telemetry_imu` found: the samples in camera axes and where they came from."""

    recording: Any  # walkmon.imu.recordings.ImuRecording (imported lazily: drivers do not import the IMU package)
    camera: str
    model: str
    has_gravity_stream: bool
    gyro_rate_hz: float
    accel_rate_hz: float
    #: the file's display rotation (clockwise), which its frames come turned by and the samples' axes with them
    axes_turned_deg: int = 0
    #: added to telemetry-parser's times to put the samples on the shown frames' clock (a trimmed clip's edit
    #: lists; 0 for an untrimmed one; the median over the samples kept when several edits show parts)
    shifted_s: float = 0.0

    def to_dict(self) -> dict[str, object]:
        return {"camera": self.camera, "model": self.model, "samples": len(self.recording.t_s),
                "gyro_rate_hz": round(self.gyro_rate_hz, 2), "accel_rate_hz": round(self.accel_rate_hz, 2),
                "gravity_stream": self.has_gravity_stream,
                "axes": "camera (x right, y down, z forward) from telemetry-parser's normalised axes",
                "axes_turned_deg": self.axes_turned_deg, "shifted_s": round(self.shifted_s, 6)}


def _parser(path: str | Path) -> Any:
    try:
        import telemetry_parser  # noqa: PLC0415
    except ImportError:
        msg = "reading a camera's embedded IMU needs the telemetry-parser package: pip install walkmon[telemetry]"
        raise ConfigError(msg) from None
    p = Path(path)
    if not p.is_file():
        msg = f"{path}: no such file"
        raise InvalidInputError(msg)
    try:
        return telemetry_parser.Parser(str(p))
    except Exception as exc:  # noqa: BLE001 - the Rust binding raises plain Exception/OSError for unknown files
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        msg = f"{path}: no camera telemetry found ({first})"
        raise InvalidInputError(msg) from None


def _rate(t: NDArray[np.float64]) -> float:
    """A stream's samples per second over its span. Not walkmon.sampling's rate without gaps: a HERO5's
    accelerometer samples (200 Hz) carry times 2.5 ms apart in bursts with half a second between them, which
    that rate reads as 400 Hz with gaps."""
    return (len(t) - 1) / max(float(t[-1] - t[0]), 1e-9) if len(t) > 1 else 0.0


def _has_gravity(parser: Any) -> bool:
    try:
        groups = parser.telemetry()
    except Exception:  # noqa: BLE001 - metadata we only report on
        return False
    return any(isinstance(g, dict) and "GravityVector" in g for g in groups or [])


def read_telemetry_imu(path: str | Path) -> TelemetryImuFile:
    """The embedded IMU of ``path`` in camera axes (rad/s, m/s², seconds from the telemetry's start).

    InvalidInputError (one line) when the file has no readable telemetry, no gyroscope or accelerometer, or
    fewer than 10 samples; ConfigError when telemetry-parser is not installed.
    """
    parser = _parser(path)
    try:
        samples = parser.normalized_imu()
    except Exception as exc:  # noqa: BLE001
        msg = f"{path}: cannot read the IMU from the telemetry ({str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__})"
        raise InvalidInputError(msg) from None
    t_g, g, t_a, a = [], [], [], []
    for s in samples or []:
        ts = s.get("timestamp_ms")
        if ts is None or not math.isfinite(float(ts)):
            continue
        gyro, accl = s.get("gyro"), s.get("accl")
        if gyro is not None and all(math.isfinite(float(v)) for v in gyro):
            t_g.append(float(ts))
            g.append(gyro)
        if accl is not None and all(math.isfinite(float(v)) for v in accl):
            t_a.append(float(ts))
            a.append(accl)
    camera = str(getattr(parser, "camera", "") or "")
    model = str(getattr(parser, "model", "") or "")
    name = f"{camera} {model}".strip() or "this file"
    if len(t_g) < _MIN_SAMPLES or len(t_a) < 2:
        msg = (f"{path}: {name} telemetry has {len(t_g)} gyroscope and {len(t_a)} accelerometer samples; "
               f"need a gyroscope and an accelerometer")
        raise InvalidInputError(msg)
    recording = recording_from_normalized(np.array(t_g) / 1e3, np.array(g, dtype=float), np.array(t_a) / 1e3,
                                          np.array(a, dtype=float), source=f"{path}: {name}")
    tg = recording.t_s
    shown = telemetry_times_s(path, recording.t_s)
    shift = float(np.nanmedian(shown - recording.t_s)) if np.isfinite(shown).any() else 0.0
    if not np.array_equal(shown, recording.t_s):
        # a clip trimmed by its edit lists: the samples onto the shown frames' clock, those cut away dropped
        # (module docstring)
        keep = np.isfinite(shown)
        if np.count_nonzero(keep) < _MIN_SAMPLES:
            msg = f"{path}: the clip's edit lists show {np.count_nonzero(keep)} of its {name} telemetry samples"
            raise InvalidInputError(msg)
        recording = type(recording)(shown[keep], recording.gyroscope_rad_s[keep], recording.accelerometer_m_s2[keep])
    quarter = _display_quarter_turns(path)
    if quarter:
        # the file is shown turned (a portrait video): OpenCV turns its frames, so the camera axes the angles are
        # in turn with them (walkmon.camera.model.camera_for_frames), and the samples must too
        from walkmon.camera.model import turned_axes  # noqa: PLC0415

        M = turned_axes(quarter)
        recording = type(recording)(recording.t_s, recording.gyroscope_rad_s @ M.T, recording.accelerometer_m_s2 @ M.T)
    return TelemetryImuFile(recording=recording, camera=camera, model=model, has_gravity_stream=_has_gravity(parser),
                            gyro_rate_hz=_rate(tg), accel_rate_hz=_rate(np.unique(np.array(t_a)) / 1e3),
                            axes_turned_deg=90 * quarter, shifted_s=shift)


def _display_quarter_turns(path: str | Path) -> int:
    """Clockwise quarter turns the video ``path`` is shown turned by (VideoFile.rotation_deg); 0 for a file that is
    no video OpenCV opens (telemetry from another file)."""
    from walkmon.drivers.video_file import VideoFile  # noqa: PLC0415

    try:
        with VideoFile(path) as video:
            return int(round(video.rotation_deg / 90.0)) % 4
    except (InvalidInputError, SourceError):
        return 0


def recording_from_normalized(
    t_gyro_s: NDArray[np.float64],
    gyro_dps: NDArray[np.float64],
    t_accel_s: NDArray[np.float64],
    accel_m_s2: NDArray[np.float64],
    *,
    source: str = "telemetry",
) -> Any:
    """An ImuRecording in camera axes from samples in telemetry-parser's normalised axes (°/s, m/s², s).

    The accelerometer is interpolated onto the gyroscope's times; gyroscope samples outside its span are dropped.
    """
    from walkmon.imu.recordings import ImuRecording  # noqa: PLC0415

    tg, gyro = _strictly_increasing(np.asarray(t_gyro_s, float), np.asarray(gyro_dps, float).reshape(-1, 3))
    ta, accel = _strictly_increasing(np.asarray(t_accel_s, float), np.asarray(accel_m_s2, float).reshape(-1, 3))
    ta = spread_bursts(ta, tg)  # a slower accelerometer given the gyroscope's times (HERO5)
    if len(tg) < _MIN_SAMPLES or len(ta) < 2:
        msg = f"{source}: {len(tg)} gyroscope and {len(ta)} accelerometer samples; need a gyroscope and an accelerometer"
        raise InvalidInputError(msg)
    inside = (tg >= ta[0]) & (tg <= ta[-1])
    tg, gyro = tg[inside], gyro[inside]
    if len(tg) < _MIN_SAMPLES:
        msg = f"{source}: gyroscope and accelerometer samples do not overlap in time"
        raise InvalidInputError(msg)
    accel_at_g = np.column_stack([np.interp(tg, ta, accel[:, j]) for j in range(3)])
    M = CAMERA_FROM_TELEMETRY
    return ImuRecording(np.ascontiguousarray(tg), np.radians(gyro) @ M.T, accel_at_g @ M.T)


def spread_bursts(t_s: NDArray[np.float64], reference_s: NDArray[np.float64] | None = None,
                  min_burst: int = 8) -> NDArray[np.float64]:
    """A stream's sample times with squeezed payloads spread out (see the module text), else as they are.

    Squeezed payloads have a signature: bursts (runs of intervals at most 10 x the median one), three or more of
    at least ``min_burst`` samples, whose samples carry *consecutive* times of the other stream (``reference_s``,
    the gyroscope's: telemetry-parser gave the slower stream the faster one's times) while that stream samples on
    between the bursts, and within which the rate is over 1.5 x the rate over whole bursts (the median over
    bursts of samples per span from one burst's first sample to the next one's: a missing payload's doubled span
    does not count). Each burst's samples are then spread from its first sample at that rate, never past the
    next burst's start. A stream with dropouts of its own (its times not the other's) keeps its times (review:
    re-timed by 0.4 s when the rate ratio was the only test)."""
    t = np.asarray(t_s, dtype=float)
    if reference_s is None or t.size < 3 * min_burst:
        return t
    ref = np.asarray(reference_s, dtype=float)
    d = np.diff(t)
    step = float(np.median(d))
    cuts = np.flatnonzero(d > 10.0 * step) + 1
    if step <= 0 or cuts.size < 2 or ref.size < 2:
        return t
    idx = np.clip(np.searchsorted(ref, t - 1e-9), 0, ref.size - 1)
    if not np.allclose(ref[idx], t, rtol=0.0, atol=1e-9):
        return t  # not the other stream's times
    starts, ends = np.r_[0, cuts], np.r_[cuts, t.size]
    n = ends - starts
    within = np.ones(t.size - 1, dtype=bool)
    within[cuts - 1] = False
    if n.min() < min_burst or not np.all(np.diff(idx)[within] == 1) or not np.all(np.diff(idx)[~within] > 1):
        return t
    rate = float(np.median(n[:-1] / np.diff(t[starts])))
    if 1.0 / step < 1.5 * rate:
        return t
    out = np.empty_like(t)
    nxt = np.r_[t[starts[1:]], np.inf]
    for i0, i1, t1 in zip(starts, ends, nxt, strict=True):
        # at the rate, but within the burst's own span: a burst with more samples than rate x span (payloads of
        # 196-200 samples over 0.99-1.01 s) must not reach past the next one's start (review: times went back)
        out[i0:i1] = t[i0] + np.arange(i1 - i0) * min(1.0 / rate, (t1 - t[i0]) / (i1 - i0))
    return out


def _strictly_increasing(t: NDArray[np.float64], v: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Sort by time and keep the first of samples with equal timestamps (np.interp and the fusion need it)."""
    order = np.argsort(t, kind="stable")
    t, v = t[order], v[order]
    keep = np.concatenate([[True], np.diff(t) > 0])
    return t[keep], v[keep]


class TelemetryImu:
    """The embedded IMU as a live IMU source (``telemetry:VIDEO?realtime=0``; an
    :class:`~walkmon.drivers.imu_types.ImuSource`): read at ``open()``, one :class:`ImuSample` (camera axes) per
    ``read()`` (a batch of one), SourceDisconnected at the end, like ``file:imu.csv``."""

    reconnectable = False

    def __init__(self, url: str, path: str, realtime: bool = False) -> None:
        self.url, self.path, self.realtime = url, path, realtime
        self.live = realtime
        self._data: TelemetryImuFile | None = None
        self._i = 0
        self._t0_mono = 0.0

    def open(self) -> None:
        try:
            self._data = read_telemetry_imu(self.path)
        except (InvalidInputError, ConfigError, OSError) as exc:
            msg = f"{self.url}: {exc}"
            raise SourceError(msg) from exc
        self._i = 0
        self._t0_mono = time.monotonic()

    def read(self) -> ImuBatch:
        if self._data is None:
            msg = f"{self.url}: not open"
            raise SourceError(msg)
        rec = self._data.recording
        if self._i >= len(rec.t_s):
            msg = f"{self.url}: end of the camera's IMU recording"
            raise SourceDisconnected(msg)
        i = self._i
        self._i += 1
        t = float(rec.t_s[i])
        if self.realtime:
            delay = self._t0_mono + t - time.monotonic()
            if delay > 0:
                time.sleep(delay)
        g, a = rec.gyroscope_rad_s[i], rec.accelerometer_m_s2[i]
        sample = ImuSample(t, (float(g[0]), float(g[1]), float(g[2])), (float(a[0]), float(a[1]), float(a[2])))
        return ImuBatch((sample,))

    def close(self) -> None:
        self._data = None

    def __enter__(self) -> TelemetryImu:
        self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
