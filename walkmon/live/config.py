"""One frozen :class:`Config` tree, read from TOML once (in the ``live`` command), written back for round trips.

Every section is a frozen settings dataclass owned by the stage it configures (``indicators`` →
:class:`~walkmon.gait.live.LiveIndicatorSettings`, ``alerts`` → :class:`~walkmon.live.alerts.AlertSettings`,
``sinks`` → :class:`~walkmon.live.sinks.SinkSettings`) or defined here (``camera``, ``imu``, ``rotation``,
``pipeline``, ``session``, ``serve``). Unknown sections or keys, wrong types and out-of-range values raise
:class:`~walkmon.errors.ConfigError` naming the key. See ``deploy/walkmon.toml`` for every key with its default.
"""

from __future__ import annotations

import dataclasses
import ipaddress
import math
import tomllib
import typing
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from walkmon.errors import ConfigError
from walkmon.gait.live import LiveIndicatorSettings
from walkmon.live.alerts import AlertSettings
from walkmon.live.sinks import SinkSettings

__all__ = [
    "DEFAULT_CONFIG",
    "CameraSettings",
    "Config",
    "ImuSettings",
    "PipelineSettings",
    "RotationMethodSettings",
    "ServeSettings",
    "SessionSettings",
    "config_from_dict",
    "config_to_dict",
    "config_to_toml",
    "read_config",
]


@dataclass(frozen=True, slots=True)
class CameraSettings:
    """The camera source URL (see :func:`walkmon.drivers.sources.open_camera`) and its calibration file."""

    url: str = "v4l2:/dev/video0?width=640&height=480&fps=30"
    #: ROS camera_info YAML; empty: default intrinsics from ``hfov_deg``.
    calib: str = ""
    hfov_deg: float = 70.0

    def __post_init__(self) -> None:
        if not 10 < self.hfov_deg < 180:
            msg = f"camera.hfov_deg must be in (10, 180), got {self.hfov_deg}"
            raise ValueError(msg)


@dataclass(frozen=True, slots=True)
class ImuSettings:
    """Optional IMU source URL (``serial:...``, ``file:imu.csv`` or ``depthai:``); empty: no IMU.

    With an IMU the live angles are the camera-IMU fusion's (:class:`walkmon.imu.fusion.LiveFusion`).
    ``time_offset_s``: added to IMU timestamps to put them on the camera's clock (file and sim sources share
    one clock: 0; real devices: the host-side timestamps of both drivers are assumed on one clock, so this is
    the residual latency difference, IMU minus camera). IMU-to-camera rotation (maps IMU axes to camera
    axes, camera x right, y down, z forward): ``extrinsics`` = 9 numbers of the row-major matrix, or
    ``rotation_deg`` = [pitch, yaw, roll] (``walkmon.consts.rotation_from_angles_deg``); not both; default
    identity. ``warmup_s``: IMU data gathered before fusing (initial gravity and, if still, gyro bias);
    ``max_gap_s``: IMU samples further apart restart the filter; ``max_lag_s``: a frame later than the newest
    IMU sample by more than this is camera-only (the live loop waits up to ``max_gap_s`` for an IMU that is
    slightly behind before giving up on a frame). ``filter``: the IMU attitude core under the fusion, the same
    names and meaning as ``walkmon analyze --imu-filter`` (``vqf``, default; ``eskf``, ``eskf-handheld``), with its
    knobs ``tau_acc_s`` / ``rest_min_s`` (:class:`walkmon.imu.attitude.ImuFilterSettings`). ``calibration``: an
    accelerometer calibration file of ``walkmon calibrate-imu`` (as ``analyze --imu-calib``); empty: none.
    """

    url: str = ""
    filter: str = "vqf"
    tau_acc_s: float = 3.0
    rest_min_s: float = 1.5
    calibration: str = ""
    time_offset_s: float = 0.0
    extrinsics: tuple[float, ...] = ()
    rotation_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    warmup_s: float = 1.0
    max_gap_s: float = 0.1
    max_lag_s: float = 0.02

    def __post_init__(self) -> None:
        if self.extrinsics:
            if len(self.extrinsics) != 9:
                msg = f"imu.extrinsics must be 9 numbers (row-major 3x3 rotation), got {len(self.extrinsics)}"
                raise ValueError(msg)
            m = [self.extrinsics[i * 3:(i + 1) * 3] for i in range(3)]
            det = (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                   + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))
            ortho = all(abs(sum(m[i][k] * m[j][k] for k in range(3)) - (i == j)) < 1e-3 for i in range(3) for j in range(3))
            if not ortho or abs(det - 1.0) > 1e-3:
                msg = f"imu.extrinsics must be a rotation matrix (orthonormal, det +1), got {list(self.extrinsics)}"
                raise ValueError(msg)
            if any(self.rotation_deg):
                msg = "imu.extrinsics and imu.rotation_deg are alternatives: give one"
                raise ValueError(msg)
        from walkmon.imu.attitude import ImuFilterSettings  # noqa: PLC0415 - validates filter and knobs

        try:
            ImuFilterSettings(filter=self.filter, tau_acc_s=self.tau_acc_s, rest_min_s=self.rest_min_s)
        except ConfigError as exc:
            raise ValueError(f"[imu] {exc}") from None
        if not abs(self.time_offset_s) < 10.0:
            msg = f"imu.time_offset_s must be within +-10 s, got {self.time_offset_s}"
            raise ValueError(msg)
        if not 0 <= self.warmup_s <= 10.0:
            msg = f"imu.warmup_s must be in [0, 10], got {self.warmup_s}"
            raise ValueError(msg)
        if not 0 < self.max_gap_s <= 5.0:
            msg = f"imu.max_gap_s must be in (0, 5], got {self.max_gap_s}"
            raise ValueError(msg)
        if not 0 <= self.max_lag_s <= self.max_gap_s:
            msg = f"imu.max_lag_s must be in [0, max_gap_s], got {self.max_lag_s}"
            raise ValueError(msg)

    @property
    def camera_from_imu(self) -> tuple[float, ...]:
        """The IMU-to-camera rotation as 9 row-major numbers."""
        if self.extrinsics:
            return tuple(float(v) for v in self.extrinsics)
        from walkmon.consts import rotation_from_angles_deg  # noqa: PLC0415

        return tuple(float(v) for v in rotation_from_angles_deg(*self.rotation_deg).ravel())


@dataclass(frozen=True, slots=True)
class RotationMethodSettings:
    """Which rotation estimator method to run (``fast`` or ``paper``)."""

    method: str = "fast"

    def __post_init__(self) -> None:
        if self.method not in ("fast", "paper"):
            msg = f"rotation.method must be 'fast' or 'paper', got {self.method!r}"
            raise ValueError(msg)


@dataclass(frozen=True, slots=True)
class PipelineSettings:
    """Threads and queues of :mod:`walkmon.live.pipeline`."""

    #: Frames waiting for processing; when full the oldest is dropped (and counted).
    queue_size: int = 4
    #: Reconnection backoff for sources that can reconnect (v4l2), s: first wait, doubled up to the max.
    reconnect_initial_s: float = 0.5
    reconnect_max_s: float = 10.0
    #: Give up after this long without frames from a reconnecting source (0: never), s.
    reconnect_give_up_s: float = 0.0
    #: A camera that delivers nothing for this long (not reconnecting) stops the systemd watchdog pings, s.
    frame_timeout_s: float = 5.0

    def __post_init__(self) -> None:
        if self.queue_size < 1:
            msg = f"pipeline.queue_size must be >= 1, got {self.queue_size}"
            raise ValueError(msg)
        if not 0 < self.reconnect_initial_s <= self.reconnect_max_s:
            msg = "pipeline.reconnect_initial_s must be > 0 and <= reconnect_max_s"
            raise ValueError(msg)
        if self.reconnect_give_up_s < 0 or self.frame_timeout_s <= 0:
            msg = "pipeline.reconnect_give_up_s must be >= 0 and frame_timeout_s > 0"
            raise ValueError(msg)


@dataclass(frozen=True, slots=True)
class SessionSettings:
    """The session log (:mod:`walkmon.live.session_log`)."""

    #: Data directory; empty: ~/.local/share/walkmon (the service uses /var/lib/walkmon).
    data_dir: str = ""
    #: Commit buffered rows at least this often, s (a crash loses at most about this much).
    flush_interval_s: float = 0.5
    #: Store per-frame angles (False keeps only hops, alerts and calibrations).
    log_frames: bool = True
    #: When ``walkmon live`` starts, delete ended sessions that started more than this many days ago (as
    #: ``walkmon sessions prune --older-than``); 0: keep everything.
    retention_days: float = 0.0
    #: Who is walking (stored with each session; one device or clinic database may hold several people).
    person: str = ""

    def __post_init__(self) -> None:
        if not 0 < self.flush_interval_s <= 1.0:
            msg = f"session.flush_interval_s must be in (0, 1], got {self.flush_interval_s}"
            raise ValueError(msg)
        if not self.retention_days >= 0:
            msg = f"session.retention_days must be >= 0 (0: keep everything), got {self.retention_days}"
            raise ValueError(msg)


def is_loopback(host: str) -> bool:
    """True for localhost and loopback addresses (127.0.0.0/8, ::1), the dashboard's and its config's one test."""
    if host.lower() in ("localhost", "localhost."):
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


@dataclass(frozen=True, slots=True)
class ServeSettings:
    """The local dashboard (``walkmon serve``; with ``enabled``, ``walkmon live`` also serves it in a thread)."""

    enabled: bool = False
    #: Address to listen on; anything but loopback (127.0.0.1, ::1, localhost) needs ``token``.
    host: str = "127.0.0.1"
    port: int = 8765
    #: Required on every request when set (Authorization: Bearer TOKEN, or ?token=TOKEN once); >= 12 characters.
    token: str = ""

    def __post_init__(self) -> None:
        if not 0 < self.port < 65536:
            msg = f"serve.port must be in 1..65535, got {self.port}"
            raise ValueError(msg)
        if self.token and len(self.token) < 12:
            msg = "serve.token must have at least 12 characters"
            raise ValueError(msg)
        if not is_loopback(self.host) and not self.token:  # '127.example.com' is no loopback (user review)
            msg = f"serve.host = {self.host!r} is not loopback: set serve.token too (requests without it get 401)"
            raise ValueError(msg)


@dataclass(frozen=True, slots=True)
class Config:
    """The whole configuration of ``walkmon live``."""

    camera: CameraSettings = field(default_factory=CameraSettings)
    imu: ImuSettings = field(default_factory=ImuSettings)
    rotation: RotationMethodSettings = field(default_factory=RotationMethodSettings)
    pipeline: PipelineSettings = field(default_factory=PipelineSettings)
    session: SessionSettings = field(default_factory=SessionSettings)
    indicators: LiveIndicatorSettings = field(default_factory=LiveIndicatorSettings)
    alerts: AlertSettings = field(default_factory=AlertSettings)
    sinks: SinkSettings = field(default_factory=SinkSettings)
    serve: ServeSettings = field(default_factory=ServeSettings)


DEFAULT_CONFIG = Config()


def _coerce(value: object, hint: object, where: str) -> object:
    origin = typing.get_origin(hint)
    if hint is bool:
        if isinstance(value, bool):
            return value
    elif hint is int:
        if isinstance(value, int) and not isinstance(value, bool):
            return value
    elif hint is float:
        if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
            return float(value)
    elif hint is str:
        if isinstance(value, str):
            return value
    elif origin is tuple:
        args = typing.get_args(hint)
        if isinstance(value, (list, tuple)):
            if len(args) == 2 and args[1] is Ellipsis:
                return tuple(_coerce(v, args[0], f"{where}[{i}]") for i, v in enumerate(value))
            if len(value) == len(args):
                return tuple(_coerce(v, a, f"{where}[{i}]") for i, (v, a) in enumerate(zip(value, args, strict=True)))
    # TOML words: a tuple is written as an array (user review: 'expected tuple' for hook_command = "x")
    type_name = {"tuple": "an array", "str": "a string", "float": "a number", "int": "a whole number",
                 "bool": "true or false"}.get(getattr(hint, "__name__", ""), str(hint))
    if origin is tuple:
        args = typing.get_args(hint)
        type_name = (f"an array of {len(args)}" if not (len(args) == 2 and args[1] is Ellipsis) else "an array")
    msg = f"{where}: expected {type_name}, got {value!r}"
    raise ConfigError(msg)


def _section(cls: type, data: object, name: str) -> object:
    if not isinstance(data, dict):
        msg = f"[{name}] must be a table, got {data!r}"
        raise ConfigError(msg)
    hints = typing.get_type_hints(cls)
    known = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - known)
    if unknown:
        msg = f"[{name}]: unknown key(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}"
        raise ConfigError(msg)
    kwargs = {k: _coerce(v, hints[k], f"{name}.{k}") for k, v in data.items()}
    try:
        return cls(**kwargs)
    except ValueError as exc:
        raise ConfigError(str(exc)) from exc


def config_from_dict(data: dict[str, object]) -> Config:
    """Build a :class:`Config` from nested dicts (as from TOML); missing keys take their defaults."""
    sections = {f.name: f for f in dataclasses.fields(Config)}
    unknown = sorted(set(data) - set(sections))
    if unknown:
        msg = f"unknown config section(s) {', '.join(unknown)}; known: {', '.join(sections)}"
        raise ConfigError(msg)
    hints = typing.get_type_hints(Config)
    cfg = Config(**{k: _section(hints[k], v, k) for k, v in data.items()})  # type: ignore[arg-type]
    _check_ranges(cfg)
    return cfg


#: Sane ranges of the settings whose extremes break the monitor rather than tune it: a 1e7 Hz resampling
#: starves the systemd watchdog, a huge window holds the memory, a huge hook timeout lets hooks pile up.
_RANGES: dict[tuple[str, str], tuple[float, float]] = {
    ("indicators", "resample_hz"): (5.0, 200.0),
    ("indicators", "window_s"): (1.0, 120.0),
    ("indicators", "hop_s"): (0.05, 60.0),
    ("indicators", "posture_window_s"): (0.1, 120.0),
    ("indicators", "walking_window_s"): (0.1, 120.0),
    ("indicators", "calibration_s"): (0.1, 120.0),
    ("indicators", "max_gap_s"): (0.05, 120.0),
    ("indicators", "uncalibrated_doubt_deg"): (0.0, 90.0),
    ("indicators", "tilt_drift_deg"): (0.0, 90.0),
    ("sinks", "hook_timeout_s"): (0.1, 600.0),
    ("session", "retention_days"): (0.0, 36500.0),
    ("pipeline", "queue_size"): (1, 1000),
    ("pipeline", "reconnect_max_s"): (0.01, 3600.0),
    ("pipeline", "reconnect_give_up_s"): (0.0, 7 * 86400.0),
    ("pipeline", "frame_timeout_s"): (0.1, 600.0),
}


def _check_ranges(cfg: Config) -> None:
    for (section, key), (lo, hi) in _RANGES.items():
        value = getattr(getattr(cfg, section, None), key, None)
        if value is not None and not lo <= value <= hi:
            msg = f"{section}.{key} must be in [{lo:g}, {hi:g}], got {value!r}"
            raise ConfigError(msg)


def read_config(path: str | Path) -> Config:
    """Read a TOML config file; ConfigError on syntax errors, unknown keys or bad values."""
    from walkmon.errors import InvalidInputError  # noqa: PLC0415
    from walkmon.safe_io import read_bounded  # noqa: PLC0415

    p = Path(path)
    if not p.exists():
        msg = f"{p}: no such config file"
        raise ConfigError(msg)
    try:
        text = read_bounded(p, 1 << 20, "config file").decode("utf-8")  # a config is < 10 kB; /dev/zero is refused
    except InvalidInputError as exc:
        msg = f"cannot read config: {exc}"
        raise ConfigError(msg) from None
    except UnicodeDecodeError as exc:
        msg = f"{p}: cannot read config ({exc})"
        raise ConfigError(msg) from exc
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        msg = f"{p}: invalid TOML: {exc}"
        raise ConfigError(msg) from exc
    except RecursionError:
        msg = f"{p}: nested too deeply to be a walkmon config"
        raise ConfigError(msg) from None
    try:
        return config_from_dict(data)
    except ConfigError as exc:
        msg = f"{p}: {exc}"
        raise ConfigError(msg) from exc


def config_to_dict(config: Config) -> dict[str, dict[str, object]]:
    """Nested plain dicts (tuples as lists), the inverse of :func:`config_from_dict`."""
    out: dict[str, dict[str, object]] = {}
    for f in dataclasses.fields(config):
        sec = getattr(config, f.name)
        out[f.name] = {
            g.name: list(v) if isinstance(v := getattr(sec, g.name), tuple) else v for g in dataclasses.fields(sec)
        }
    return out


#: Shown instead of a secret in a stored or served configuration.
REDACTED = "<redacted>"


def redacted(config: Mapping[str, object]) -> dict[str, object]:
    """A copy of a :func:`config_to_dict` document without its secrets, as the session record keeps it and the
    dashboard serves it (user review: an apprise URL's password and the dashboard token were stored in the
    database and served by a loopback dashboard that needs no token): ``serve.token``, every apprise URL past its
    scheme (services carry their keys in the host or path: ``tgram://BOT_TOKEN/CHAT``), and the hook's arguments
    past the program (``curl -H 'Authorization: ...'``). Anything not shaped as expected is passed through."""
    out: dict[str, object] = {k: dict(v) if isinstance(v, Mapping) else v for k, v in config.items()}
    serve, sinks = out.get("serve"), out.get("sinks")
    if isinstance(serve, dict) and serve.get("token"):
        serve["token"] = REDACTED
    if isinstance(sinks, dict):
        urls = sinks.get("apprise_urls")
        if isinstance(urls, (list, tuple)):
            sinks["apprise_urls"] = [f"{str(u).split('://', 1)[0]}://{REDACTED}" if "://" in str(u) else REDACTED
                                     for u in urls]
        hook = sinks.get("hook_command")
        if isinstance(hook, (list, tuple)) and len(hook) > 1:
            sinks["hook_command"] = [hook[0], *([REDACTED] * (len(hook) - 1))]
    return out


def _toml_value(v: object) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    msg = f"cannot write {v!r} as TOML"
    raise ConfigError(msg)


def config_to_toml(config: Config) -> str:
    """TOML text that :func:`read_config` reads back into an equal :class:`Config`."""
    lines: list[str] = []
    for name, sec in config_to_dict(config).items():
        lines.append(f"[{name}]")
        lines.extend(f"{k} = {_toml_value(v)}" for k, v in sec.items())
        lines.append("")
    return "\n".join(lines)
