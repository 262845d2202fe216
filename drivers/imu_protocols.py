"""Byte-level IMU protocol parsers: pure logic, no I/O, no clock reads.

Every parser has the same incremental interface::

    parser = WitMotionParser()
    samples = parser.feed(chunk, t_s=host_time_s)   # -> list[ImuSample], possibly empty
    parser.stats                                     # -> ParserStats (bad checksums, skipped bytes, ...)
    parser.reset()

Bytes may arrive split at any offset and mixed with garbage: parsers keep a partial packet between calls,
resynchronise on the next header after bad bytes, verify checksums and count every problem in
:class:`~walkmon.drivers.imu_types.ParserStats`. They never raise on bad input.

Protocols
---------
``witmotion``
    WitMotion WT901/JY901 binary: 11-byte packets ``0x55, type, 4 x int16 LE, checksum`` with
    checksum = sum of the first 10 bytes & 0xFF. Type 0x51 acceleration (raw/32768·16 g), 0x52 angular rate
    (raw/32768·2000 °/s), 0x53 angles (raw/32768·180°, roll, pitch, yaw). A sample is emitted once a group
    holds acceleration and rate: when the angle packet closes the group, or when a packet type repeats.
``bno08x-rvc``
    BNO08x UART-RVC: 19-byte frames ``0xAA 0xAA, index, yaw, pitch, roll (int16 LE, 0.01°), x, y, z
    acceleration (int16 LE, mg), 3 reserved bytes, checksum`` (checksum = sum of bytes 2..17 mod 256), 100 Hz.
    RVC mode sends **no gyroscope**: samples have ``gyroscope_rad_s = None`` and the device's own fused angles.
``csv``
    Text lines ``t,gx,gy,gz,ax,ay,az`` or ``gx,gy,gz,ax,ay,az`` (then the host time is used), with units set by
    :class:`CsvUnits`. Header and malformed lines are counted, not fatal. A line has no checksum, so a
    well-formed sample that cannot be real (:mod:`walkmon.drivers.imu_checks`) is skipped and counted as
    ``implausible_samples``.
"""

from __future__ import annotations

import logging
import math
import struct
from dataclasses import dataclass, replace
from typing import Protocol

from walkmon.consts import GRAVITY_MS2
from walkmon.drivers.imu_checks import ImuPlausibility
from walkmon.drivers.imu_clock import DeviceClock
from walkmon.drivers.imu_types import ImuSample, ParserStats
from walkmon.errors import ConfigError

__all__ = [
    "PROTOCOLS",
    "Bno08xRvcParser",
    "CsvLineParser",
    "CsvUnits",
    "ImuParser",
    "WitMotionParser",
    "bno08x_rvc_frame",
    "parser_for_protocol",
    "witmotion_packet",
]

_log = logging.getLogger(__name__)

PROTOCOLS = ("witmotion", "bno08x-rvc", "csv")

_DEG = math.pi / 180.0


class ImuParser(Protocol):
    """What every protocol parser offers."""

    @property
    def stats(self) -> ParserStats: ...

    def feed(self, data: bytes, t_s: float) -> list[ImuSample]: ...

    def reset(self) -> None: ...


# ------------------------------------------------------------------------------------------ framed binary packets


class _FramedParser:
    """The resynchronising scan the binary parsers share: fixed-length packets that start with ``_HEADER`` and end
    with a checksum byte, ``sum(packet[_CHECKSUM_FROM:-1]) & 0xFF``.

    Bytes before a header are skipped (a trailing partial header is kept: it may be completed by the next chunk);
    a packet whose checksum fails counts as bad and only its first byte is skipped, so a header inside it is
    found next; a tail shorter than a packet waits for more bytes. Subclasses decode good packets in
    :meth:`_decode` and say which packet types they ignore in :meth:`_wanted`.
    """

    _HEADER: bytes
    _LENGTH: int
    _CHECKSUM_FROM: int

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self._buffer = bytearray()
        self._stats = ParserStats()

    @property
    def stats(self) -> ParserStats:
        return self._stats

    def _wanted(self, buf: bytearray, i: int) -> bool:  # noqa: ARG002 - every packet by default
        """False for a well-formed packet (at ``buf[i]``) of a type this parser does not use."""
        return True

    def _decode(self, buf: bytearray, i: int, t_s: float) -> ImuSample | None:
        """The sample the good packet at ``buf[i]`` completes, if any."""
        raise NotImplementedError

    def feed(self, data: bytes, t_s: float) -> list[ImuSample]:
        buf = self._buffer
        buf.extend(data)
        header, length, checksum_from = self._HEADER, self._LENGTH, self._CHECKSUM_FROM
        out: list[ImuSample] = []
        good = bad = skipped = ignored = 0
        i = 0
        n = len(buf)
        while n - i >= length:
            if not buf.startswith(header, i):
                j = buf.find(header, i + 1)
                j = n - (len(header) - 1) if j < 0 else j  # keep a partial header at the end
                skipped += j - i
                i = j
                continue
            if (sum(buf[i + checksum_from : i + length - 1]) & 0xFF) != buf[i + length - 1]:
                bad += 1
                skipped += 1
                i += 1
                continue
            start = i
            i += length
            good += 1
            if not self._wanted(buf, start):
                ignored += 1
            elif (sample := self._decode(buf, start, t_s)) is not None:
                out.append(sample)
        del buf[:i]
        self._stats = replace(
            self._stats,
            good_packets=self._stats.good_packets + good,
            bad_checksums=self._stats.bad_checksums + bad,
            skipped_bytes=self._stats.skipped_bytes + skipped,
            ignored_packets=self._stats.ignored_packets + ignored,
            samples=self._stats.samples + len(out),
        )
        return out


# --------------------------------------------------------------------------------------------------- WitMotion

_WIT_HEADER = 0x55
_WIT_LEN = 11
_WIT_ACCEL, _WIT_RATE, _WIT_ANGLE = 0x51, 0x52, 0x53
#: Packet types WitMotion devices send that walkmon does not use (time, magnetometer, pressure, ...).
_WIT_KNOWN_OTHER = frozenset(range(0x50, 0x60)) - {_WIT_ACCEL, _WIT_RATE, _WIT_ANGLE}


def witmotion_packet(packet_type: int, values: tuple[int, int, int, int]) -> bytes:
    """Encode one WitMotion packet (used by tests and the serial emulator)."""
    body = bytes([_WIT_HEADER, packet_type]) + struct.pack("<4h", *values)
    return body + bytes([sum(body) & 0xFF])


class WitMotionParser(_FramedParser):
    """Incremental parser for WitMotion WT901/JY901 binary packets."""

    _HEADER = bytes([_WIT_HEADER])
    _LENGTH = _WIT_LEN
    _CHECKSUM_FROM = 0

    def reset(self) -> None:
        super().reset()
        self._group: dict[int, tuple[int, int, int, int]] = {}

    def _wanted(self, buf: bytearray, i: int) -> bool:
        return buf[i + 1] in (_WIT_ACCEL, _WIT_RATE, _WIT_ANGLE)

    def _decode(self, buf: bytearray, i: int, t_s: float) -> ImuSample | None:
        return self._add_to_group(buf[i + 1], struct.unpack_from("<4h", buf, i + 2), t_s)

    def _add_to_group(self, kind: int, values: tuple[int, int, int, int], t_s: float) -> ImuSample | None:
        sample = None
        if kind in self._group:
            sample = self._flush(t_s)
        self._group[kind] = values
        if kind == _WIT_ANGLE:
            flushed = self._flush(t_s)
            sample = sample or flushed
        return sample

    def _flush(self, t_s: float) -> ImuSample | None:
        group, self._group = self._group, {}
        if _WIT_ACCEL not in group or _WIT_RATE not in group:
            if group:
                self._stats = replace(self._stats, incomplete_samples=self._stats.incomplete_samples + 1)
            return None
        a, w = group[_WIT_ACCEL], group[_WIT_RATE]
        accel = tuple(v / 32768.0 * 16.0 * GRAVITY_MS2 for v in a[:3])
        gyro = tuple(v / 32768.0 * 2000.0 * _DEG for v in w[:3])
        angles = None
        if _WIT_ANGLE in group:
            angles = tuple(v / 32768.0 * 180.0 for v in group[_WIT_ANGLE][:3])
        return ImuSample(t_s, gyro, accel, angles)  # type: ignore[arg-type]


# ------------------------------------------------------------------------------------------------ BNO08x RVC

_RVC_HEADER = b"\xaa\xaa"
_RVC_LEN = 19


def bno08x_rvc_frame(index: int, yaw_pitch_roll_cdeg: tuple[int, int, int], accel_mg: tuple[int, int, int]) -> bytes:
    """Encode one BNO08x UART-RVC frame (used by tests and the serial emulator)."""
    body = bytes([index & 0xFF]) + struct.pack("<3h3h", *yaw_pitch_roll_cdeg, *accel_mg) + b"\x00\x00\x00"
    return _RVC_HEADER + body + bytes([sum(body) & 0xFF])


class Bno08xRvcParser(_FramedParser):
    """Incremental parser for BNO08x UART-RVC frames (100 Hz, angles + acceleration, no gyroscope)."""

    _HEADER = _RVC_HEADER
    _LENGTH = _RVC_LEN
    _CHECKSUM_FROM = len(_RVC_HEADER)

    def _decode(self, buf: bytearray, i: int, t_s: float) -> ImuSample | None:
        index = buf[i + 2]
        yaw, pitch, roll, ax, ay, az = struct.unpack_from("<3h3h", buf, i + 3)
        accel = (ax / 1000.0 * GRAVITY_MS2, ay / 1000.0 * GRAVITY_MS2, az / 1000.0 * GRAVITY_MS2)
        return ImuSample(t_s, None, accel, (yaw / 100.0, pitch / 100.0, roll / 100.0), index)


# ------------------------------------------------------------------------------------------------------- CSV

_GYRO_SCALE = {"rad/s": 1.0, "deg/s": _DEG}
_ACCEL_SCALE = {"m/s2": 1.0, "g": GRAVITY_MS2, "mg": GRAVITY_MS2 / 1000.0}
_TIME_SCALE = {"s": 1.0, "ms": 1e-3, "us": 1e-6}


@dataclass(frozen=True, slots=True)
class CsvUnits:
    """Units of the CSV protocol's columns: gyroscope ``rad/s|deg/s``, accelerometer ``m/s2|g|mg``,
    time column ``s|ms|us``."""

    gyroscope: str = "rad/s"
    accelerometer: str = "m/s2"
    time: str = "s"

    def __post_init__(self) -> None:
        for name, value, allowed in (
            ("gyroscope unit", self.gyroscope, _GYRO_SCALE),
            ("accelerometer unit", self.accelerometer, _ACCEL_SCALE),
            ("time unit", self.time, _TIME_SCALE),
        ):
            if value not in allowed:
                msg = f"unknown {name} {value!r}; expected one of {', '.join(allowed)}"
                raise ConfigError(msg)


#: Longest line accepted; longer runs of bytes without a newline are garbage and are skipped.
CSV_MAX_LINE_BYTES = 256


class CsvLineParser:
    """Incremental parser for ``t,gx,gy,gz,ax,ay,az`` (or ``gx,...,az``) text lines."""

    def __init__(self, units: CsvUnits = CsvUnits()) -> None:
        self._gyro_scale = _GYRO_SCALE[units.gyroscope]
        self._accel_scale = _ACCEL_SCALE[units.accelerometer]
        self._time_scale = _TIME_SCALE[units.time]
        self.reset()

    def reset(self) -> None:
        self._buffer = bytearray()
        self._discarding = False
        self._stats = ParserStats()
        self._plausible = ImuPlausibility()
        self._ahead = 0  # samples refused for a device time ahead of their own arrival
        self._clock = DeviceClock()
        self._device_timed: list[bool] = []  # per sample of the current read: timed by the device
        self._arrival = 0.0

    @property
    def stats(self) -> ParserStats:
        return self._stats

    @property
    def rejected(self) -> dict[str, int]:
        """The implausible samples (``stats.implausible_samples``) by reason (:mod:`walkmon.drivers.imu_checks`'
        reasons, and ``time_ahead_of_arrival``: a device time mapped after the line's own arrival)."""
        out = dict(self._plausible.rejected)
        if self._ahead:
            out["time_ahead_of_arrival"] = self._ahead
        return out

    def feed(self, data: bytes, t_s: float) -> list[ImuSample]:
        self._buffer.extend(data)
        self._arrival = t_s
        out: list[ImuSample] = []
        while True:
            k = self._buffer.find(b"\n")
            if k < 0:
                if len(self._buffer) > CSV_MAX_LINE_BYTES:
                    self._count(skipped_bytes=len(self._buffer))
                    self._buffer.clear()
                    self._discarding = True  # the rest of this over-long line is garbage too
                break
            line = bytes(self._buffer[:k])
            del self._buffer[: k + 1]
            if self._discarding:
                self._discarding = False
                self._count(skipped_bytes=len(line) + 1)
                continue
            sample = self._parse_line(line, t_s)
            if sample is not None:
                out.append(sample)
        return self._on_host_clock(out)

    def _count(self, **increments: int) -> None:
        self._stats = replace(self._stats, **{k: getattr(self._stats, k) + v for k, v in increments.items()})

    def _parse_line(self, line: bytes, t_s: float) -> ImuSample | None:
        text = line.strip(b"\r \t")
        if not text:
            return None
        try:
            fields = text.decode("ascii").split(",")
        except UnicodeDecodeError:
            self._count(skipped_bytes=len(line) + 1, bad_checksums=1)
            return None
        if fields and fields[0].strip().lstrip("#").strip().lower() in ("t", "gx", "time", "t_s"):
            self._count(ignored_packets=1)
            return None
        try:
            values = [float(f) for f in fields]
        except ValueError:
            values = []
        if len(values) not in (6, 7) or not all(math.isfinite(v) for v in values):
            self._count(skipped_bytes=len(line) + 1, bad_checksums=1)
            return None
        device = len(values) == 7
        if device:
            t_s = values[0] * self._time_scale
            values = values[1:]
        g, a = self._gyro_scale, self._accel_scale
        gyro = (values[0] * g, values[1] * g, values[2] * g)
        accel = (values[3] * a, values[4] * a, values[5] * a)
        # no checksum: a corrupted line is caught here, its time judged on the device's clock (a run of samples
        # behind it is a restarted clock: walkmon.drivers.imu_checks), and against its arrival (a time corrupted
        # forward: drivers/imu_clock.py)
        if device:
            restarts = self._clock.restarts
            ahead = self._clock.ahead(t_s, self._arrival)
            self._count(clock_restarts=self._clock.restarts - restarts)
            if ahead:
                self._ahead += 1
                self._count(good_packets=1, implausible_samples=1)
                return None
        if not self._plausible.check(t_s, gyro, accel):
            self._count(good_packets=1, implausible_samples=1)
            return None
        self._count(good_packets=1, samples=1)
        self._device_timed.append(device)
        return ImuSample(t_s, gyro, accel)

    def _on_host_clock(self, samples: list[ImuSample]) -> list[ImuSample]:
        """The read's device-timed samples (a ``t`` column) mapped onto the host clock the camera's frames are on
        (:class:`~walkmon.drivers.imu_clock.DeviceClock`), all of the read at once."""
        idx = [i for i, dev in enumerate(self._device_timed) if dev]
        self._device_timed = []
        if not idx:
            return samples
        restarts = self._clock.restarts
        mapped = self._clock.host_times([samples[i].t_s for i in idx], self._arrival)
        self._count(clock_restarts=self._clock.restarts - restarts)
        out = list(samples)
        for i, t in zip(idx, mapped, strict=True):
            out[i] = replace(samples[i], t_s=t)
        return out


def parser_for_protocol(protocol: str, csv_units: CsvUnits = CsvUnits()) -> ImuParser:
    """A fresh parser for ``protocol`` (one of :data:`PROTOCOLS`); unknown names raise ConfigError."""
    if protocol == "witmotion":
        return WitMotionParser()
    if protocol == "bno08x-rvc":
        return Bno08xRvcParser()
    if protocol == "csv":
        return CsvLineParser(csv_units)
    msg = f"unknown IMU protocol {protocol!r}; expected one of {', '.join(PROTOCOLS)}"
    raise ConfigError(msg)
