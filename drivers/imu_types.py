"""The IMU sample every IMU driver and parser produces, the batch every IMU source returns, and the
:class:`ImuSource` contract (beside :class:`~walkmon.drivers.camera_base.CameraSource`).

Units are in the field names: seconds, rad/s, m/s², degrees. Accelerations are specific force (at rest with y
pointing down a sensor reads ``ay = -9.81``), the convention of :mod:`walkmon.consts`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

__all__ = ["ImuBatch", "ImuSample", "ImuSource", "ParserStats"]

Vector3 = tuple[float, float, float]


@dataclass(frozen=True, slots=True)
class ImuSample:
    """One IMU reading in the sensor's own axes.

    ``t_s``
        Timestamp in seconds on the host clock the caller passes to ``feed``: a device clock (CSV ``t`` column)
        mapped onto it (:class:`walkmon.drivers.imu_clock.DeviceClock`), otherwise the value passed with the
        bytes that completed the sample (the serial reader spreads a chunk's samples over their interval).
    ``gyroscope_rad_s``
        Body angular rate (x, y, z), rad/s; ``None`` for protocols without a gyroscope (BNO08x UART-RVC).
    ``accelerometer_m_s2``
        Specific force (x, y, z), m/s².
    ``device_angles_deg``
        Orientation angles computed on the device, in the device's own order and convention (WitMotion:
        roll, pitch, yaw; BNO08x RVC: yaw, pitch, roll); ``None`` when the device does not send them.
    ``index``
        The device's frame counter where the protocol has one (BNO08x RVC, 0-255), else ``None``.
    """

    t_s: float
    gyroscope_rad_s: Vector3 | None
    accelerometer_m_s2: Vector3
    device_angles_deg: Vector3 | None = None
    index: int | None = None


@dataclass(frozen=True, slots=True)
class ParserStats:
    """Counters a protocol parser keeps; a parser never raises on bad bytes, it counts them here."""

    #: Packets (or lines) with a valid checksum / format.
    good_packets: int = 0
    #: Packets whose checksum did not match (the parser then resynchronises one byte further).
    bad_checksums: int = 0
    #: Bytes discarded while looking for a packet header (garbage, line noise, partial packets).
    skipped_bytes: int = 0
    #: Valid packets of a type walkmon does not use (e.g. WitMotion magnetometer), or CSV header lines.
    ignored_packets: int = 0
    #: Valid packets that could not be assembled into a sample (e.g. a rate packet with no acceleration).
    incomplete_samples: int = 0
    #: Samples produced.
    samples: int = 0
    #: Well-formed samples that cannot be real (non-finite, beyond a MEMS sensor's range, no gravity, time going
    #: back: :mod:`walkmon.drivers.imu_checks`), skipped; CSV lines have no checksum to catch their corruption.
    implausible_samples: int = 0
    #: Times a device clock (a CSV ``t`` column) restarted or jumped, each starting a new mapping onto the host
    #: clock (:class:`walkmon.drivers.imu_clock.DeviceClock`).
    clock_restarts: int = 0


@dataclass(frozen=True, slots=True)
class ImuBatch:
    """What one :meth:`ImuSource.read` returns: the samples in arrival order (possibly none), and what went wrong
    since the previous batch: ``overflow`` / ``dropped_samples`` when the driver's queue was full; a parser's
    totals where there is one (serial IMUs)."""

    samples: tuple[ImuSample, ...]
    overflow: bool = False
    dropped_samples: int = 0
    parser_stats: ParserStats | None = None


@runtime_checkable
class ImuSource(Protocol):
    """Every IMU source (serial, file, OAK/depthai): ``open()``, then ``read()`` until ``close()``.

    ``read()`` returns an :class:`ImuBatch`; it raises :class:`~walkmon.errors.SourceTimeout` when nothing came
    for a while (the caller retries) and :class:`~walkmon.errors.SourceDisconnected` when the device went away
    or a recording ended. ``live``: a real-time device (a consumer that falls behind drops samples) or, False, a
    recording read as fast as possible (the consumer waits, drops nothing). ``reconnectable``: whether the
    consumer may reopen it after a disconnection.
    """

    url: str
    live: bool
    reconnectable: bool

    def open(self) -> None: ...

    def read(self) -> ImuBatch: ...

    def close(self) -> None: ...
