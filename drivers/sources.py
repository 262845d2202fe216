"""One factory for every camera and IMU source, named by a URL-like spec.

Cameras (:func:`open_camera`)::

    v4l2:/dev/video0?width=640&height=480&fps=30     USB/CSI camera through OpenCV CAP_V4L2
    depthai:[DEVICE_ID]?width=640&height=480&fps=30&timeout_s=3&imu=0&imu_rate_hz=200
                                                       Luxonis OAK (pip install walkmon[depthai]); imu=1
                                                       also reads its on-board IMU (see depthai_camera)
    file:walk.mp4?realtime=1&loop=0                    a video replayed at its own frame rate
    sim:normal:10,bend:10?seed=0&width=640&height=480&fps=30&realtime=1   the simulator, live

IMUs (:func:`open_imu`)::

    serial:/dev/ttyACM0?baud=115200&...                the serial IMU driver (walkmon.drivers.serial_imu)
    file:imu.csv?realtime=0                            a recorded imu.csv
    telemetry:clip.mp4?realtime=0                      an action camera's IMU stored in its video file
                                                       (walkmon.drivers.telemetry_imu; walkmon[telemetry])
    depthai:?rate_hz=200                               the OAK's on-board IMU: needs the depthai: camera,
                                                       whose imu=1 option it turns on (one device)

The factory only parses and constructs: nothing is opened (and no hardware probed) until the pipeline calls
``open()``. Unknown schemes and unknown or malformed options raise ConfigError.
"""

from __future__ import annotations

import collections
import dataclasses
import importlib
import logging
from collections.abc import Callable
from typing import Any
from urllib.parse import parse_qsl

from walkmon.drivers.imu_types import ImuBatch, ImuSource, ParserStats
from walkmon.errors import ConfigError

__all__ = ["CAMERA_SCHEMES", "IMU_SCHEMES", "open_camera", "open_imu", "parse_source_url"]

_log = logging.getLogger(__name__)


def _bool(text: str) -> bool:
    t = text.strip().lower()
    if t in ("1", "true", "yes", "on"):
        return True
    if t in ("0", "false", "no", "off"):
        return False
    raise ValueError(text)


def _pos_int(text: str) -> int:
    v = int(text)
    if v <= 0:
        raise ValueError(text)
    return v


def _pos_float(text: str) -> float:
    v = float(text)
    if not v > 0:
        raise ValueError(text)
    return v


#: scheme -> option -> parser.
_CAMERA_OPTIONS: dict[str, dict[str, Callable[[str], Any]]] = {
    "v4l2": {"width": _pos_int, "height": _pos_int, "fps": _pos_float},
    "depthai": {"width": _pos_int, "height": _pos_int, "fps": _pos_float, "timeout_s": _pos_float, "imu": _bool,
                "imu_rate_hz": _pos_float},
    "file": {"realtime": _bool, "loop": _bool, "fps": _pos_float},
    "sim": {"seed": int, "width": _pos_int, "height": _pos_int, "fps": _pos_float, "realtime": _bool,
            "seconds": _pos_float, "distortion": _bool},
}
CAMERA_SCHEMES = tuple(_CAMERA_OPTIONS)
IMU_SCHEMES = ("serial", "file", "depthai", "telemetry")


def parse_source_url(url: str, options: dict[str, dict[str, Callable[[str], Any]]]) -> tuple[str, str, dict[str, Any]]:
    """Split ``scheme:target?k=v&...`` into (scheme, target, parsed options); ConfigError on anything unknown."""
    if not isinstance(url, str) or ":" not in url:
        msg = f"source {url!r}: expected SCHEME:TARGET[?OPTIONS] with SCHEME one of {', '.join(options)}"
        raise ConfigError(msg)
    scheme, rest = url.split(":", 1)
    scheme = scheme.strip().lower()
    if scheme not in options:
        msg = f"source {url!r}: unknown scheme {scheme!r}; known: {', '.join(options)}"
        raise ConfigError(msg)
    target, _, query = rest.partition("?")
    if target.startswith("//"):
        target = target[2:]
    parsed: dict[str, Any] = {}
    for key, value in parse_qsl(query, keep_blank_values=True, strict_parsing=False):
        allowed = options[scheme]
        if key not in allowed:
            known = ", ".join(allowed) or "none"
            msg = f"source {url!r}: unknown option {key!r} for {scheme}: (known: {known})"
            raise ConfigError(msg)
        try:
            parsed[key] = allowed[key](value)
        except ValueError:
            msg = f"source {url!r}: bad value {value!r} for option {key!r}"
            raise ConfigError(msg) from None
    if query and not parsed and "=" not in query:
        msg = f"source {url!r}: malformed options {query!r} (expected key=value&...)"
        raise ConfigError(msg)
    return scheme, target, parsed


def open_camera(url: str):  # noqa: ANN201 - a CameraSource
    """A (not yet opened) camera source for ``url``; see the module docstring for the schemes."""
    scheme, target, opts = parse_source_url(url, _CAMERA_OPTIONS)
    if scheme == "v4l2":
        from walkmon.drivers.v4l2_camera import V4l2Camera  # noqa: PLC0415

        if not target:
            msg = f"source {url!r}: v4l2 needs a device, e.g. v4l2:/dev/video0"
            raise ConfigError(msg)
        return V4l2Camera(url, target, **opts)
    if scheme == "depthai":
        from walkmon.drivers.depthai_camera import DepthaiCamera  # noqa: PLC0415

        return DepthaiCamera(url, target, **opts)
    if scheme == "file":
        from walkmon.drivers.file_camera import FileCamera  # noqa: PLC0415

        if not target:
            msg = f"source {url!r}: file needs a path, e.g. file:walk.mp4"
            raise ConfigError(msg)
        return FileCamera(url, target, **opts)
    from walkmon.drivers.sim_camera import SimCamera, script_seconds  # noqa: PLC0415

    if not target:
        msg = f"source {url!r}: sim needs a walk, e.g. sim:normal:10,bend:10"
        raise ConfigError(msg)
    script_seconds(target)  # validates the script's syntax
    try:
        from walkmon.simulate.gait import parse_walk_script  # noqa: PLC0415
    except ImportError:
        pass
    else:
        try:
            parse_walk_script(target, opts.get("seconds", 16.0))  # validates walk types and durations
        except ValueError as exc:
            msg = f"source {url!r}: {exc}"
            raise ConfigError(msg) from exc
    return SimCamera(url, target, **opts)


def open_imu(url: str, camera: Any = None) -> ImuSource:
    """A (not yet opened) IMU source for ``url``: ``serial:`` (serial IMU driver), ``file:imu.csv``, or
    ``depthai:`` (the on-board IMU of ``camera``, which must be a ``depthai:`` camera source)."""
    if isinstance(url, str) and url.lower().startswith("serial:"):
        try:
            serial_imu = importlib.import_module("walkmon.drivers.serial_imu")
        except ImportError as exc:
            msg = f"source {url!r}: the serial IMU driver is not available ({exc})"
            raise ConfigError(msg) from exc
        return _SerialImuSource(url, serial_imu.SerialImu(serial_imu.settings_from_url(url)))
    scheme, target, opts = parse_source_url(url, {"serial": {}, "file": {"realtime": _bool},
                                                  "depthai": {"rate_hz": _pos_float},
                                                  "telemetry": {"realtime": _bool}})
    if scheme == "depthai":
        if target or camera is None or not hasattr(camera, "imu_source"):
            msg = (f"source {url!r}: the OAK's IMU is read through its camera: use it with a depthai: camera "
                   f"(or add imu=1 to the camera URL)")
            raise ConfigError(msg)
        camera.enable_imu(opts.get("rate_hz"))
        return camera.imu_source()
    if scheme == "telemetry":
        from walkmon.drivers.telemetry_imu import TelemetryImu  # noqa: PLC0415

        if not target:
            msg = f"source {url!r}: telemetry needs a file, e.g. telemetry:clip.mp4"
            raise ConfigError(msg)
        return TelemetryImu(url, target, **opts)
    from walkmon.drivers.file_imu import FileImu  # noqa: PLC0415

    if not target:
        msg = f"source {url!r}: file needs a path, e.g. file:imu.csv"
        raise ConfigError(msg)
    return FileImu(url, target, **opts)


class _SerialImuSource:
    """Adapts :class:`walkmon.drivers.serial_imu.SerialImu` (start/read batches/close) to the
    :class:`~walkmon.drivers.imu_types.ImuSource` contract (open/read/close). Reconnectable: each ``open()`` after
    the first starts a fresh reader on the same port (a device unplugged and plugged back, its udev name the same;
    the live pipeline retries with backoff)."""

    reconnectable = True
    live = True
    host_clock = True  # the serial reader's samples: on the host's monotonic clock (drivers/imu_clock.py)

    def __init__(self, url: str, imu: Any) -> None:
        self.url = url
        self._imu = imu
        self._opened = False
        self._before: ParserStats | None = None  # the counts of the readers before this one (reconnections)
        self._rejected_before: collections.Counter[str] = collections.Counter()

    @property
    def rejected(self) -> dict[str, int]:
        """The samples the parsers refused as implausible, by reason, over the session (every reader's)."""
        return dict(self._rejected_before + collections.Counter(getattr(self._imu, "rejected", None) or {}))

    def open(self) -> None:
        if self._opened:  # a reader runs once: a new one for the port (its parser and clock afresh)
            self._before = _sum_stats(self._before, self._imu.parser_stats)
            self._rejected_before.update(getattr(self._imu, "rejected", None) or {})
            self._imu = type(self._imu)(self._imu.settings)
        self._imu.start()
        self._opened = True

    def read(self) -> ImuBatch:
        """An ``ImuBatch`` (samples + overflow flag; the parser's counts over the session, every reconnection's
        reader included: review); SourceDisconnected when the device went away."""
        batch: ImuBatch = self._imu.read(0.2)
        if self._before is not None:
            batch = dataclasses.replace(batch, parser_stats=_sum_stats(self._before, batch.parser_stats))
        return batch

    def close(self) -> None:
        self._imu.close()


def _sum_stats(a: ParserStats | None, b: ParserStats | None) -> ParserStats | None:
    if a is None or b is None:
        return a or b
    return ParserStats(**{f.name: getattr(a, f.name) + getattr(b, f.name) for f in dataclasses.fields(ParserStats)})
