"""Serial-port IMU driver: one pyserial reader thread per port, parsers from :mod:`imu_protocols`.

URL form (the live pipeline's ``open_imu`` dispatches ``serial:`` here)::

    serial:/dev/ttyUSB0?baud=115200&protocol=witmotion
    serial:///dev/ttyACM0?protocol=csv&gyro_unit=deg/s&accel_unit=g&time_unit=ms

Options: ``baud`` (default 115200), ``protocol`` (``witmotion`` | ``bno08x-rvc`` | ``csv``, default
``witmotion``), and for CSV ``gyro_unit`` (``rad/s`` | ``deg/s``), ``accel_unit`` (``m/s2`` | ``g`` | ``mg``),
``time_unit`` (``s`` | ``ms`` | ``us``). Unknown options raise :class:`~walkmon.errors.ConfigError`.

Samples are timestamped on the host's monotonic clock, the live camera's: a device clock (CSV ``t``) is mapped
onto it, and the samples of one read are spread over their interval (:mod:`walkmon.drivers.imu_clock`). They are never
dropped silently: when the consumer falls behind and the queue is full, the oldest samples are dropped, counted,
and the next :class:`ImuBatch` carries ``overflow=True`` and the count. A device that goes away (unplugged,
closed) makes :meth:`SerialImu.read` raise :class:`~walkmon.errors.SourceDisconnected` once the samples read
before it are consumed; the live pipeline then reopens the port with backoff (a fresh :class:`SerialImu`: a
reader runs once; :func:`reconnect_delays_s` is such a backoff for other callers).
"""

from __future__ import annotations

import collections
import logging
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from types import TracebackType
from typing import Any
from urllib.parse import parse_qsl, urlsplit

from walkmon.drivers.imu_clock import ChunkStamps
from walkmon.drivers.imu_protocols import (
    PROTOCOLS,
    CsvUnits,
    ImuParser,
    parser_for_protocol,
)
from walkmon.drivers.imu_types import ImuBatch, ImuSample, ParserStats
from walkmon.errors import ConfigError, SourceDisconnected, SourceError

__all__ = [
    "ImuBatch",
    "SerialImu",
    "SerialImuSettings",
    "open_serial_imu",
    "reconnect_delays_s",
    "settings_from_url",
]

_log = logging.getLogger(__name__)

_OPTIONS = ("baud", "protocol", "gyro_unit", "accel_unit", "time_unit")


@dataclass(frozen=True, slots=True)
class SerialImuSettings:
    """Settings of one serial IMU port.

    ``queue_samples``: samples kept for the consumer before the oldest are dropped (and counted);
    ``read_timeout_s``: how long one blocking serial read waits, i.e. how fast ``stop()`` is honoured.
    """

    port: str
    baud: int = 115200
    protocol: str = "witmotion"
    csv_units: CsvUnits = CsvUnits()
    queue_samples: int = 4000
    read_timeout_s: float = 0.05

    def __post_init__(self) -> None:
        if not self.port:
            msg = "serial IMU: no port given (expected e.g. serial:/dev/ttyUSB0)"
            raise ConfigError(msg)
        if self.baud <= 0:
            msg = f"serial IMU: baud must be positive, got {self.baud}"
            raise ConfigError(msg)
        if self.protocol not in PROTOCOLS:
            msg = f"serial IMU: unknown protocol {self.protocol!r}; expected one of {', '.join(PROTOCOLS)}"
            raise ConfigError(msg)
        if self.queue_samples < 1 or self.read_timeout_s <= 0:
            msg = "serial IMU: queue_samples must be >= 1 and read_timeout_s > 0"
            raise ConfigError(msg)


def settings_from_url(url: str) -> SerialImuSettings:
    """Parse ``serial:PORT?opt=value&...`` into settings; unknown schemes or options raise ConfigError."""
    parts = urlsplit(url)
    if parts.scheme != "serial":
        msg = f"not a serial IMU URL: {url!r} (expected serial:/dev/ttyUSB0?baud=115200&protocol=witmotion)"
        raise ConfigError(msg)
    port = (parts.netloc + parts.path) if parts.netloc else parts.path
    options = dict(parse_qsl(parts.query, keep_blank_values=True))
    unknown = sorted(set(options) - set(_OPTIONS))
    if unknown:
        msg = f"serial IMU URL {url!r}: unknown option(s) {', '.join(unknown)}; known: {', '.join(_OPTIONS)}"
        raise ConfigError(msg)
    try:
        baud = int(options.get("baud", "115200"))
    except ValueError:
        msg = f"serial IMU URL {url!r}: baud must be an integer, got {options['baud']!r}"
        raise ConfigError(msg) from None
    units = CsvUnits(
        gyroscope=options.get("gyro_unit", "rad/s"),
        accelerometer=options.get("accel_unit", "m/s2"),
        time=options.get("time_unit", "s"),
    )
    return SerialImuSettings(port=port, baud=baud, protocol=options.get("protocol", "witmotion"), csv_units=units)


class SerialImu:
    """A serial IMU with a reader thread. ``start()`` opens the port, ``read()`` returns batches, ``stop()``
    ends the thread, ``close()`` releases everything; also a context manager (``with SerialImu(s) as imu:``)."""

    def __init__(self, settings: SerialImuSettings, *, parser: ImuParser | None = None) -> None:
        self.settings = settings
        self._parser = parser or parser_for_protocol(settings.protocol, settings.csv_units)
        self._stamps = ChunkStamps()  # a chunk's samples over the time they took, not all at its arrival
        self._samples: collections.deque[ImuSample] = collections.deque()
        self._cond = threading.Condition()
        self._dropped = 0
        self._error: BaseException | None = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._serial: Any = None  # a serial.Serial once started

    # -- lifecycle -------------------------------------------------------------------------------------------
    def start(self) -> SerialImu:
        if self._thread is not None:
            msg = f"serial IMU {self.settings.port}: already running"
            raise SourceError(msg)
        import serial  # pyserial; imported here so importing walkmon never touches serial ports

        try:
            self._serial = serial.Serial(
                self.settings.port, self.settings.baud, timeout=self.settings.read_timeout_s
            )
        except (serial.SerialException, OSError, ValueError) as exc:
            msg = f"serial IMU {self.settings.port}: cannot open ({exc})"
            raise SourceError(msg) from None
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name=f"serial-imu:{self.settings.port}", daemon=True)
        self._thread.start()
        _log.info("serial IMU %s opened (%d baud, %s)", self.settings.port, self.settings.baud, self.settings.protocol)
        return self

    def stop(self, timeout_s: float = 2.0) -> None:
        """Ask the reader thread to end and wait for it (at most ``timeout_s``)."""
        self._stop.set()
        if self._serial is not None:
            try:
                self._serial.cancel_read()
            except Exception:  # noqa: BLE001 - cancel_read is best effort on closed/odd ports
                _log.debug("cancel_read failed", exc_info=True)
        if self._thread is not None:
            self._thread.join(timeout_s)
            if self._thread.is_alive():
                _log.warning("serial IMU %s: reader thread did not stop within %.1f s", self.settings.port, timeout_s)
        self._thread = None
        with self._cond:
            self._cond.notify_all()

    def close(self) -> None:
        self.stop()
        if self._serial is not None:
            try:
                self._serial.close()
            except OSError:
                _log.debug("closing serial port failed", exc_info=True)
            self._serial = None

    def __enter__(self) -> SerialImu:
        """Starts the reader unless it already runs (``with open_serial_imu(url) as imu:`` works too)."""
        return self if self._thread is not None else self.start()

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    # -- consumer side --------------------------------------------------------------------------------------
    @property
    def parser_stats(self) -> ParserStats:
        return self._parser.stats

    @property
    def rejected(self) -> dict[str, int]:
        """Samples the parser refused as implausible, by reason ({} for a parser without such a check)."""
        return dict(getattr(self._parser, "rejected", None) or {})

    def read(self, timeout_s: float = 0.2) -> ImuBatch:
        """All samples received so far (waiting up to ``timeout_s`` for the first one).

        Raises SourceDisconnected once the device has gone away and every sample read before that is consumed.
        An empty batch means nothing arrived within the timeout.
        """
        deadline = time.monotonic() + timeout_s
        with self._cond:
            while not self._samples and self._error is None and self._thread is not None:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    break
                self._cond.wait(remaining)
            samples = tuple(self._samples)
            self._samples.clear()
            dropped, self._dropped = self._dropped, 0
            error = self._error
        if not samples and error is not None:
            raise SourceDisconnected(str(error)) from None
        return ImuBatch(samples, dropped > 0, dropped, self._parser.stats)

    def __iter__(self) -> Iterator[ImuBatch]:
        """Batches until the device disconnects (then SourceDisconnected) or the reader is stopped."""
        while self._thread is not None or self._samples:
            yield self.read()

    # -- reader thread --------------------------------------------------------------------------------------
    def _run(self) -> None:
        import serial

        port = self._serial
        assert port is not None
        try:
            while not self._stop.is_set():
                data = port.read(max(1, port.in_waiting or 1))
                if not data:
                    continue
                arrival = time.monotonic()
                samples = self._stamps.spread(self._parser.feed(data, arrival), arrival)
                if samples:
                    self._enqueue(samples)
        except (serial.SerialException, OSError, TypeError) as exc:
            # pyserial raises SerialException ("device reports readiness to read but returned no data") or
            # OSError (EIO) when the device is unplugged or the other end closes; TypeError when the port is
            # closed under the reader.
            if not self._stop.is_set():
                _log.warning("serial IMU %s disconnected: %s", self.settings.port, exc)
                with self._cond:
                    self._error = SourceDisconnected(f"serial IMU {self.settings.port} disconnected ({exc})")
                    self._cond.notify_all()
        except Exception:
            _log.exception("serial IMU %s: reader thread failed", self.settings.port)
            with self._cond:
                self._error = SourceDisconnected(f"serial IMU {self.settings.port}: reader thread failed")
                self._cond.notify_all()
            raise

    def _enqueue(self, samples: list[ImuSample]) -> None:
        with self._cond:
            self._samples.extend(samples)
            excess = len(self._samples) - self.settings.queue_samples
            for _ in range(max(0, excess)):
                self._samples.popleft()
            if excess > 0:
                self._dropped += excess
            self._cond.notify_all()


def open_serial_imu(url: str) -> SerialImu:
    """Open and start a serial IMU from a ``serial:`` URL (see the module docstring)."""
    return SerialImu(settings_from_url(url)).start()


def reconnect_delays_s(initial_s: float = 0.5, maximum_s: float = 10.0, factor: float = 2.0) -> Iterator[float]:
    """Exponential backoff delays for reconnecting a disconnected source: 0.5, 1, 2, 4, 8, 10, 10, ..."""
    delay = initial_s
    while True:
        yield delay
        delay = min(maximum_s, delay * factor)
