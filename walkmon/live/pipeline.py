"""The live pipeline: the only module of walkmon that starts threads.

::

    camera source ──grabber thread──▶ FrameQueue (newest wins, drops counted)
                                            │
    IMU source ──IMU thread──▶ IMU buffer   ▼   processing loop (the caller's thread)
                                  rotation estimator → [LiveFusion] → LiveIndicatorStage → AlertStage → sinks
                                            └──▶ session-log thread: SessionLog (batched commits) ◀──┘

* The grabber thread reads frames with their capture timestamps and puts them in a bounded
  :class:`~walkmon.live.frame_queue.FrameQueue`; when processing falls behind the oldest frames are dropped and
  counted. On :class:`~walkmon.errors.SourceDisconnected` a reconnectable source (v4l2, depthai) is reopened
  with exponential backoff; any other source ends the session cleanly ("end of stream").
* Threads are stoppable (a stop Event, blocking calls with timeouts, ``join`` with a timeout) and never die
  silently: an unexpected exception is logged with its traceback and re-raised in the caller by :meth:`run`.
* The processing loop pings the systemd watchdog, sends READY=1 once the first frame arrived, and calls
  ``on_hop`` once per hop (status line). Session-log writes go to their own thread, which commits at least every
  ``flush_interval_s``: an fsync that takes hundreds of milliseconds (SD cards, busy disks) never stalls the
  frames.
* With an IMU source the processing loop drains the IMU buffer before each frame (an IMU read as fast as
  possible, e.g. ``file:imu.csv``, only up to the frame's time, and its reader waits while the buffer is full)
  and feeds the samples and the frame's rotation estimate to a :class:`~walkmon.imu.fusion.LiveFusion` stage: the
  live angles (status, indicators, alerts, frames table) are the fused ones, plus pitch_abs/roll_abs. Frames
  before the IMU's first samples or its warm-up, and during IMU gaps or after it disconnected, are
  camera-only (counted per reason in the hop JSON, the status and the session's meta).
"""

from __future__ import annotations

import collections
import contextlib
import dataclasses
import logging
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from walkmon.drivers.imu_checks import ImuPlausibility
from walkmon.errors import (
    SourceDisconnected,
    SourceError,
    SourceTimeout,
    WalkmonError,
)
from walkmon.gait.live import LiveIndicators, LiveIndicatorStage
from walkmon.live.alerts import AlertEvent, AlertStage
from walkmon.live.config import PipelineSettings
from walkmon.live.frame_queue import FrameQueue, QueueClosed
from walkmon.live.sdnotify import Notifier
from walkmon.live.session_log import SessionLog
from walkmon.live.sinks import AlertSinks

if TYPE_CHECKING:
    from walkmon.drivers.imu_types import ImuSample, ImuSource, ParserStats

__all__ = [
    "DEFAULT_PIPELINE_SETTINGS",
    "FrameResult",
    "HopReport",
    "LatencyHistogram",
    "LivePipeline",
    "PipelineResult",
    "make_estimator",
]

_log = logging.getLogger(__name__)

DEFAULT_PIPELINE_SETTINGS = PipelineSettings()
_GET_TIMEOUT_S = 0.2
_JOIN_TIMEOUT_S = 3.0
_IMU_CATCH_UP_S = 2.0


class Estimator(Protocol):
    def push(self, frame: Any, t_s: float) -> Any: ...
    def reset(self) -> None: ...


def make_estimator(camera: Any, method: str = "fast") -> Estimator:
    """The rotation estimator of ``walkmon analyze`` (``walkmon.rotation.RotationEstimator``) for ``camera``."""
    from walkmon.rotation import DEFAULT_ROTATION_SETTINGS, RotationEstimator  # noqa: PLC0415

    return RotationEstimator(camera, dataclasses.replace(DEFAULT_ROTATION_SETTINGS, method=method))


class LatencyHistogram:
    """Constant-memory latency distribution (0.5 ms bins up to 5 s) with percentiles."""

    BIN_MS = 0.5
    MAX_MS = 5000.0

    def __init__(self) -> None:
        self._counts = np.zeros(int(self.MAX_MS / self.BIN_MS) + 1, dtype=np.int64)
        self.n = 0
        self.max_ms = 0.0
        self.sum_ms = 0.0

    def add(self, ms: float) -> None:
        self._counts[min(int(ms / self.BIN_MS), len(self._counts) - 1)] += 1
        self.n += 1
        self.sum_ms += ms
        self.max_ms = max(self.max_ms, ms)

    def percentile(self, q: float) -> float:
        """Upper edge of the bin holding the q-th percentile (q in 0..100); NaN if empty."""
        if self.n == 0:
            return math.nan
        k = int(np.searchsorted(np.cumsum(self._counts), math.ceil(q / 100.0 * self.n)))
        return min((k + 1) * self.BIN_MS, self.max_ms)

    @property
    def mean_ms(self) -> float:
        return self.sum_ms / self.n if self.n else math.nan


@dataclass(frozen=True, slots=True)
class FrameResult:
    """What the processing loop made of one frame (passed to ``on_frame``)."""

    t_s: float
    angles_deg: tuple[float, float, float]
    latency_ms: float
    estimate: Any
    truth_angles_deg: tuple[float, float, float] | None
    #: (pitch_abs, roll_abs) from the fusion (NaN on camera-only frames); None without an IMU
    abs_angles_deg: tuple[float, float] | None = None
    #: "fused" or "camera:<reason>" with an IMU; "" without
    fusion_mode: str = ""


@dataclass(frozen=True, slots=True)
class HopReport:
    """One hop, for the status line: indicators, alert events, counters."""

    indicators: LiveIndicators
    events: tuple[AlertEvent, ...]
    active_alerts: tuple[str, ...]
    frames: int
    dropped: int
    fps: float
    latency_p99_ms: float
    last_angles_deg: tuple[float, float, float]
    wall_s: float
    #: the fusion's counters (LiveFusion.counters() + "mode" of the last frame); None without an IMU
    fusion: dict[str, Any] | None = None


@dataclass(frozen=True, slots=True)
class PipelineResult:
    """Summary of a finished session."""

    session_id: int
    end_reason: str
    frames: int
    dropped: int
    hops: int
    alerts_raised: int
    duration_s: float
    wall_s: float
    latency_p50_ms: float
    latency_p99_ms: float
    latency_max_ms: float
    reconnects: int
    imu_samples: int
    imu_overflows: int
    #: the fusion's final counters; None without an IMU
    fusion: dict[str, Any] | None = None
    #: the IMU stream's own counters where it has a parser (a serial IMU: bad checksums or lines, bytes skipped,
    #: implausible samples, device clock restarts; :class:`~walkmon.drivers.imu_types.ParserStats`) and the
    #: clock restarts the pipeline's plausibility check followed; None without an IMU
    imu_stream: dict[str, int] | None = None


@dataclass(frozen=True, slots=True)
class _Grabbed:
    frame: Any
    grabbed_s: float


@dataclass(slots=True)
class _RunState:
    """What :meth:`LivePipeline.run` counts while it runs (its steps update it)."""

    wall0: float
    hops: int = 0
    alerts_raised: int = 0
    n_frames: int = 0
    first_t: float = math.nan
    last_t: float = math.nan
    last_angles: tuple[float, float, float] = (math.nan, math.nan, math.nan)
    #: before the first frame: TimeoutStartSec's business
    last_frame_mono: float | None = None
    fps_window: collections.deque[float] = dataclasses.field(default_factory=lambda: collections.deque(maxlen=61))


def _angles(estimate: Any) -> tuple[float, float, float]:
    a = getattr(estimate, "angles_deg", None)
    if a is None:
        from walkmon.consts import angles_deg_from_rotation  # noqa: PLC0415

        a = angles_deg_from_rotation(estimate.rotation)
    return tuple(float(v) for v in a)  # type: ignore[return-value]


def _rotation(estimate: Any) -> Any:
    R = getattr(estimate, "rotation", None)
    if R is None:
        from walkmon.consts import rotation_from_angles_deg  # noqa: PLC0415

        R = rotation_from_angles_deg(*_angles(estimate))
    return R


def _status_text(status: Any) -> str:
    if status is None:
        return ""
    return str(getattr(status, "name", None) or getattr(status, "value", None) or status)


class _LogWriter:
    """The session log's own thread: database commits (fsync, up to hundreds of ms on SD cards and busy disks)
    never stall the processing loop. Calls are queued in order and applied by the thread, which also commits
    at least every ``flush_interval_s``. The backlog is bounded; calls beyond it are dropped and counted.
    """

    MAX_BACKLOG = 100_000

    def __init__(self, log: SessionLog, errors: list[BaseException], on_error: Callable[[], None]) -> None:
        self.log = log
        self._calls: collections.deque[tuple[Callable[..., Any], tuple[Any, ...]] | None] = collections.deque()
        self._cond = threading.Condition()
        self._errors, self._on_error = errors, on_error
        self.dropped_calls = 0
        self._thread = threading.Thread(target=self._run, name="walkmon-session-log", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def call(self, fn: Callable[..., Any], *args: Any) -> None:
        with self._cond:
            if len(self._calls) >= self.MAX_BACKLOG:
                self.dropped_calls += 1
                return
            self._calls.append((fn, args))
            self._cond.notify()

    def _run(self) -> None:
        try:
            while True:
                with self._cond:
                    if not self._calls:
                        self._cond.wait(min(0.1, self.log.flush_interval_s / 2))
                    batch = list(self._calls)
                    self._calls.clear()
                for item in batch:
                    if item is None:
                        return
                    fn, args = item
                    fn(*args)
                self.log.maybe_flush()
        except WalkmonError as exc:  # a deleted session, a full or damaged database: one line, no traceback
            _log.debug("session log: %s", exc)  # run() raises it: the caller reports it once
            self._errors.append(exc)
            self._on_error()
        except BaseException as exc:
            _log.exception("session log thread failed")
            self._errors.append(exc)
            self._on_error()

    def stop(self, timeout_s: float) -> None:
        """Apply everything queued, then end the thread (the caller closes the log afterwards)."""
        with self._cond:
            self._calls.append(None)
            self._cond.notify()
        if self._thread.is_alive():
            self._thread.join(timeout_s)
            if self._thread.is_alive():
                _log.error("session log thread did not finish within %.0f s", timeout_s)


class LivePipeline:
    """Run one live session: ``run(duration_s)`` in the calling thread; ``stop()`` from anywhere.

    Collaborators are injected: an opened-on-run camera source (:mod:`walkmon.drivers.sources`), an
    ``estimator_factory(camera_source) -> estimator`` called once the source is open (so it can use the
    source's own intrinsics), the indicator and alert stages, alert sinks, the session log, an optional IMU
    source and a :class:`~walkmon.live.sdnotify.Notifier`.
    """

    def __init__(
        self,
        camera_source: Any,
        estimator_factory: Callable[[Any], Estimator],
        *,
        indicators: LiveIndicatorStage,
        alerts: AlertStage,
        session_log: SessionLog,
        sinks: AlertSinks | None = None,
        imu_source: ImuSource | None = None,
        fusion: Any = None,
        settings: PipelineSettings = DEFAULT_PIPELINE_SETTINGS,
        notifier: Notifier | None = None,
        on_hop: Callable[[HopReport], None] | None = None,
        on_frame: Callable[[FrameResult], None] | None = None,
    ) -> None:
        self.camera = camera_source
        self.imu: ImuSource | None = imu_source
        if imu_source is not None and fusion is None:
            from walkmon.imu.fusion import LiveFusion  # noqa: PLC0415

            fusion = LiveFusion()
        #: the camera-IMU fusion stage (:class:`walkmon.imu.fusion.LiveFusion`), used when there is an IMU source
        self.fusion = fusion if imu_source is not None else None
        self._fusion_mode = ""
        self._estimator_factory = estimator_factory
        self.indicators = indicators
        self.alerts = alerts
        self.log = session_log
        self._stop = threading.Event()
        self._thread_errors: list[BaseException] = []
        self._writer = _LogWriter(session_log, self._thread_errors, self._stop.set)
        self.sinks = sinks
        self.settings = settings
        self.notifier = notifier or Notifier({})
        self.on_hop = on_hop
        self.on_frame = on_frame
        self.queue: FrameQueue[_Grabbed] = FrameQueue(settings.queue_size)
        self._calibrate = threading.Event()
        self._end_reason = ""
        self._reconnects = 0
        self._reconnecting = False
        self._stalled = False
        self._imu_buffer: collections.deque[ImuSample] = collections.deque()
        self._imu_lock = threading.Lock()
        self._imu_max = 20000
        self._imu_overflows = 0
        self._imu_count = 0
        self._imu_ended = threading.Event()
        self._imu_newest_t = -math.inf  # video clock: the newest IMU sample taken from the buffer
        #: plausibility of every IMU sample (finite, in a MEMS sensor's range, feels gravity, time not going
        #: back): rejected ones are counted per reason and skipped, so a dead IMU leaves camera-only frames
        self.imu_check = ImuPlausibility()
        self._parser_stats: ParserStats | None = None
        self._imu_shift_s = 0.0  # subtracted from the IMU's times: onto the frames' clock (_bridge_clocks)
        self._imu_reconnects = 0
        self._bridged = False
        self._warned_no_samples = False
        self._imu_rejected_since_log = 0
        self._imu_rejected_logged_mono = -math.inf
        #: frames whose fused angles were not finite: the camera's angles were used instead
        self._fusion_invalid = 0
        self._started = False
        self.latency = LatencyHistogram()

    # -- requests from other threads / signal handlers -------------------------------------------------
    def stop(self, reason: str = "stopped") -> None:
        """Ask the session to finish (thread- and signal-safe)."""
        if not self._end_reason:
            self._end_reason = reason
        self._stop.set()

    def request_calibration(self) -> None:
        """Take a new upright reference from the next still stance (thread- and signal-safe)."""
        self._calibrate.set()

    # -- threads --------------------------------------------------------------------------------------
    def _grabber(self) -> None:
        src = self.camera
        try:
            while not self._stop.is_set():
                try:
                    frame = src.read()
                except SourceTimeout as exc:
                    _log.warning("%s", exc)
                    continue
                except SourceDisconnected as exc:
                    if not getattr(src, "reconnectable", False):
                        self._end_reason = self._end_reason or f"end of stream ({exc})"
                        _log.info("%s", exc)
                        return
                    _log.warning("%s; reconnecting", exc)
                    if not self._reconnect():
                        return
                    continue
                item = _Grabbed(frame, time.monotonic())
                if getattr(src, "live", True):
                    self.queue.put(item)  # newest wins: a late consumer loses the oldest frames (counted)
                else:
                    while not self._stop.is_set() and not self.queue.put_wait(item, _GET_TIMEOUT_S):
                        pass  # back-pressure for sources read as fast as possible
        except WalkmonError as exc:  # e.g. a video file damaged mid-way: one line, the session ends with it
            _log.debug("camera: %s", exc)  # run() raises it: the caller reports it once
            self._thread_errors.append(exc)
        except BaseException as exc:
            _log.exception("camera grabber thread failed")
            self._thread_errors.append(exc)  # the queue closes below: frames already grabbed are still processed
        finally:
            self.queue.close()

    def _reconnect(self) -> bool:
        self._reconnecting = True
        try:
            return self._reconnect_loop()
        finally:
            self._reconnecting = False

    def _reconnect_loop(self) -> bool:
        s = self.settings
        self.camera.close()
        opened = self._reopen(self.camera, "", s.reconnect_give_up_s, logging.WARNING)
        if opened is None:
            self._end_reason = self._end_reason or f"camera lost for more than {s.reconnect_give_up_s:g} s"
            return False
        if opened:
            self._reconnects += 1
            _log.warning("%s: reconnected", self.camera.url)
        return opened

    def _reconnect_imu(self) -> bool:
        """Reopen a reconnectable IMU (a serial device unplugged) with the camera's backoff, until it opens or the
        session stops (user review: an unplugged serial IMU was never reopened; under systemd the process ran on
        camera-only for good). The frames meanwhile are camera-only (the fusion's IMU gap)."""
        assert self.imu is not None
        with contextlib.suppress(Exception):
            self.imu.close()
        opened = bool(self._reopen(self.imu, "IMU ", 0.0, logging.DEBUG))
        if opened:
            self._imu_reconnects += 1
            _log.warning("IMU %s: reconnected", getattr(self.imu, "url", ""))
        return opened

    def _reopen(self, src: Any, what: str, give_up_s: float, failed_level: int) -> bool | None:
        """Open ``src`` again, waiting ``reconnect_initial_s`` doubling up to ``reconnect_max_s`` between tries:
        True when it opened, False when the session stopped, None after ``give_up_s`` (0: never give up)."""
        s = self.settings
        backoff = s.reconnect_initial_s
        since = time.monotonic()
        while not self._stop.is_set():
            if give_up_s and time.monotonic() - since > give_up_s:
                return None
            if self._stop.wait(backoff):
                return False
            try:
                src.open()
            except SourceError as exc:
                backoff = min(backoff * 2, s.reconnect_max_s)
                _log.log(failed_level, "%sreconnect failed (%s); next try in %.1f s", what, exc, backoff)
                continue
            return True
        return False

    def _imu_reader(self) -> None:
        try:
            self._imu_reader_loop()
        finally:
            self._imu_ended.set()

    def _imu_reader_loop(self) -> None:
        try:
            assert self.imu is not None
            while not self._stop.is_set():
                try:
                    batch = self.imu.read()
                except SourceTimeout:
                    continue
                except SourceDisconnected as exc:
                    if not getattr(self.imu, "reconnectable", False):
                        _log.warning("IMU: %s; continuing without IMU", exc)
                        return
                    _log.warning("IMU: %s; camera-only until it is back", exc)
                    if not self._reconnect_imu():
                        return
                    continue
                if batch.parser_stats is not None:
                    self._parser_stats = st = batch.parser_stats  # the parser's totals so far
                    if not self._warned_no_samples and st.samples == 0 and st.skipped_bytes + st.bad_checksums > 1000:
                        self._warned_no_samples = True  # bytes arrive, nothing parses: said now, not at the end
                        _log.warning("IMU %s: %d bytes and no sample so far: check the URL's protocol and baud "
                                     "rate against the device", getattr(self.imu, "url", ""), st.skipped_bytes)
                if batch.overflow:
                    self._imu_overflows += 1
                    _log.warning("IMU: %d samples dropped by the driver", batch.dropped_samples)
                if not self.imu.live:  # read as fast as possible: wait for room, drop nothing
                    while not self._stop.is_set() and len(self._imu_buffer) >= self._imu_max:
                        self._stop.wait(0.01)
                with self._imu_lock:
                    for smp in batch.samples:
                        if len(self._imu_buffer) >= self._imu_max:
                            self._imu_buffer.popleft()
                            self._imu_overflows += 1
                        self._imu_buffer.append(smp)
        except WalkmonError as exc:
            _log.debug("IMU: %s", exc)  # run() raises it: the caller reports it once
            self._thread_errors.append(exc)
            self._stop.set()
        except BaseException as exc:
            _log.exception("IMU reader thread failed")
            self._thread_errors.append(exc)
            self._stop.set()

    def _watchdog(self, last_frame_mono: float | None) -> None:
        """Ping the systemd watchdog while frames flow (or the camera is being reconnected).

        A grabber stuck inside a driver call for more than ``frame_timeout_s`` stops the pings, so systemd
        (WatchdogSec) restarts a service whose camera hung; the loop itself hanging stops them too.
        """
        stalled = (last_frame_mono is not None and not self._reconnecting and not self.queue.closed
                   and time.monotonic() - last_frame_mono > self.settings.frame_timeout_s)
        if stalled != self._stalled:
            self._stalled = stalled
            if stalled:
                _log.error("no frame from %s for %.0f s: camera hung? watchdog pings stopped",
                           self.camera.url, self.settings.frame_timeout_s)
                self.notifier.status(f"stalled: no frame for {self.settings.frame_timeout_s:g} s")
            else:
                _log.warning("frames flow again from %s", self.camera.url)
        if not stalled:
            self.notifier.watchdog()

    def _drain_imu(self, until_t_s: float | None = None) -> None:
        """Log the buffered IMU samples and feed them to the fusion; with ``until_t_s`` (an IMU that is not
        live) only those up to that time on the video clock, the rest stay buffered."""
        live = self.imu is None or self.imu.live
        with self._imu_lock:
            if until_t_s is not None and math.isfinite(until_t_s) and self.fusion is not None:
                self._wait_for_imu(until_t_s, live)
            if until_t_s is None or live:
                samples = list(self._imu_buffer)
                self._imu_buffer.clear()
            else:
                offset = self.fusion.settings.fusion.time_offset_s if self.fusion is not None else 0.0
                samples = []
                while self._imu_buffer and self._imu_t(self._imu_buffer[0]) + offset <= until_t_s:
                    samples.append(self._imu_buffer.popleft())
        if samples and self.fusion is not None:
            self._imu_newest_t = self._imu_t(samples[-1]) + self.fusion.settings.fusion.time_offset_s
        for smp in samples:
            gyr0, acc = smp.gyroscope_rad_s, smp.accelerometer_m_s2
            gyr = gyr0 or (math.nan, math.nan, math.nan)
            t_imu = self._imu_t(smp)
            if not self.imu_check.check(t_imu, gyr0, acc):
                self._imu_rejected_since_log += 1  # dead or insane IMU: counted, never fed to the fusion
                continue
            self._writer.call(self.log.add_imu, t_imu, gyr, acc)
            self._imu_count += 1
            if self.fusion is not None and until_t_s is not None:
                self.fusion.push_imu(t_imu, gyr0, acc)

    def _imu_t(self, smp: ImuSample) -> float:
        """A sample's time on the camera's clock (see :meth:`_bridge_clocks`)."""
        return float(smp.t_s) - self._imu_shift_s

    def _clocks_to_bridge(self) -> bool:
        """An IMU on the host's clock and a camera on its own, not bridged yet (see :meth:`_bridge_clocks`)."""
        return (not self._bridged and self.imu is not None and bool(getattr(self.imu, "host_clock", False))
                and not getattr(self.camera, "host_clock", True))

    def _bridge_clocks(self, frame_t_s: float, grabbed_s: float) -> None:
        """At the first frame: an IMU on the host's monotonic clock (a serial IMU) with a camera on its own (the
        simulator, a replay) is put on the frames' clock, the frame's grab time its time (its samples matched
        no frame: 'before any IMU sample' for a whole session; user review). Same clocks: nothing to do."""
        if not self._clocks_to_bridge():
            return
        origin = getattr(self.camera, "clock_origin_s", lambda: None)()
        # the replay's own start when it has one (its first frame may come late: the simulator's first render)
        self._imu_shift_s = grabbed_s - frame_t_s if origin is None else origin
        self._bridged = True
        _log.info("IMU on the host clock, %s on its own: IMU times shifted by %.3f s onto the frames' clock",
                  self.camera.url, -self._imu_shift_s)

    def _wait_for_imu(self, until_t_s: float, live: bool) -> None:
        """With the IMU lock held: wait (bounded) for the IMU reader to deliver past ``until_t_s`` (video clock).

        A replayed IMU (not live) must not fall behind a replayed video: up to ``_IMU_CATCH_UP_S``. A live IMU
        that is slightly behind the frame (delivery latency, batching) gets up to ``max_gap_s`` of wall time,
        but only while its newest sample is within ``max_gap_s`` of the frame: a silent IMU costs no waiting.
        """
        assert self.fusion is not None
        offset = self.fusion.settings.fusion.time_offset_s
        max_gap = self.fusion.settings.max_gap_s
        deadline = time.monotonic() + (max_gap if live else _IMU_CATCH_UP_S)
        while not self._imu_ended.is_set() and not self._stop.is_set() and time.monotonic() < deadline:
            newest = self._imu_t(self._imu_buffer[-1]) + offset if self._imu_buffer else self._imu_newest_t
            if newest >= until_t_s or (live and not until_t_s - newest <= max_gap):
                return
            self._imu_lock.release()
            try:
                time.sleep(0.0005)
            finally:
                self._imu_lock.acquire()

    def _fusion_counters(self) -> dict[str, Any] | None:
        if self.fusion is None:
            return None
        return {**self.fusion.counters(), "mode": self._fusion_mode,
                "imu_rejected": self._imu_rejected(), "frames_fusion_invalid": self._fusion_invalid}

    def _imu_rejected(self) -> dict[str, int]:
        """IMU samples rejected as implausible, per reason: by the source's reader (a file's rows) and here."""
        out = collections.Counter(self.imu_check.rejected)
        out.update(getattr(self.imu, "rejected", None) or {})
        return dict(out)

    def _log_imu_rejections(self) -> None:
        """One warning at most every 10 s while IMU samples are being rejected (with the counts so far)."""
        if self._imu_rejected_since_log and time.monotonic() - self._imu_rejected_logged_mono >= 10.0:
            _log.warning("IMU: %s; frames without plausible IMU data are camera-only", self.imu_check.summary())
            self._imu_rejected_since_log = 0
            self._imu_rejected_logged_mono = time.monotonic()

    # -- the session ----------------------------------------------------------------------------------
    def run(self, duration_s: float | None = None) -> PipelineResult:
        """Open the sources, run until the source ends, ``stop()`` or ``duration_s`` (wall clock); summary."""
        if self._started:
            msg = "this pipeline already ran; make a new one"
            raise RuntimeError(msg)
        self._started = True
        st = _RunState(wall0=time.monotonic())
        threads: list[threading.Thread] = []
        error: BaseException | None = None
        self._writer.start()
        try:
            estimator = self._start_session(threads)
            self._loop(estimator, st, duration_s)
            if not self._end_reason:
                self._end_reason = "source ended" if self.queue.closed else "stopped"
        except BaseException as exc:
            error = exc
            self._end_reason = f"error: {exc}" if not isinstance(exc, KeyboardInterrupt) else "interrupted"
            raise
        finally:
            self._close_session(threads, st, error)
        self._raise_thread_error()
        return self._result(st)

    def _start_session(self, threads: list[threading.Thread]) -> Estimator:
        """Open the IMU and the camera, make the estimator and start the threads (appended to ``threads`` as
        they are made, so the session's closing joins whatever was made even when a later step fails)."""
        if self.imu is not None:
            # opened first: a replayed IMU (file:...?realtime=1) then starts its clock before the camera's
            # and is never behind the frames (the loop would wait for it, adding latency)
            self.imu.open()
            threads.append(threading.Thread(target=self._imu_reader, name="walkmon-imu", daemon=True))
        self.camera.open()
        estimator = self._estimator_factory(self.camera)
        threads.insert(0, threading.Thread(target=self._grabber, name="walkmon-grabber", daemon=True))
        for th in threads:
            th.start()
        self.notifier.status(f"waiting for frames from {self.camera.url}")
        return estimator

    def _loop(self, estimator: Estimator, st: _RunState, duration_s: float | None) -> None:
        """The processing loop: until ``stop()``, ``duration_s`` or the frame queue closing."""
        while not self._stop.is_set():
            self._watchdog(st.last_frame_mono)
            if duration_s is not None and time.monotonic() - st.wall0 >= duration_s:
                self._end_reason = self._end_reason or f"duration {duration_s:g} s reached"
                break
            if self._calibrate.is_set():
                self._calibrate.clear()
                self.indicators.request_calibration()
                _log.info("upright calibration requested: stand still and upright")
            try:
                item = self.queue.get(_GET_TIMEOUT_S)
            except QueueClosed:
                break
            if item is None:
                # (an IMU to be put on the frames' clock waits for the first frame: _bridge_clocks)
                if self.imu is not None and getattr(self.imu, "live", True) and not self._clocks_to_bridge():
                    self._drain_imu(math.inf)
                continue
            self._process_frame(estimator, item, st)

    def _frame_angles(self, frame: Any, estimate: Any) -> tuple[tuple[float, float, float], tuple[float, float] | None]:
        """The frame's angles (fused with an IMU, else the camera's) and the fusion's absolute ones."""
        if self.fusion is None:
            return _angles(estimate), None
        status = getattr(estimate, "status", None)
        fused = self.fusion.push_frame(frame.t_s, _rotation(estimate), bool(getattr(status, "is_measured", True)))
        angles, abs_angles = fused.angles_deg, fused.abs_angles_deg
        self._fusion_mode = fused.mode if fused.mode == "fused" else f"camera:{fused.reason}"
        if not all(math.isfinite(v) for v in angles):  # never NULL angles from the fusion
            self._fusion_invalid += 1
            angles, abs_angles = _angles(estimate), (math.nan, math.nan)
            self._fusion_mode = "camera:fusion_invalid"
        return angles, abs_angles

    def _process_frame(self, estimator: Estimator, item: _Grabbed, st: _RunState) -> None:
        """One frame: IMU up to its time, estimate, angles, counters, session log, ``on_frame``, indicators."""
        frame = item.frame
        if math.isnan(st.first_t):
            self._bridge_clocks(float(frame.t_s), item.grabbed_s)
        if self.imu is not None:
            self._drain_imu(float(frame.t_s))
            self._log_imu_rejections()
        estimate = estimator.push(frame.image, frame.t_s)
        angles, abs_angles = self._frame_angles(frame, estimate)
        done = time.monotonic()
        latency_ms = (done - item.grabbed_s) * 1000.0
        self.latency.add(latency_ms)
        st.last_angles = angles
        if math.isnan(st.first_t):
            st.first_t = frame.t_s
            self.notifier.ready(f"monitoring {self.camera.url}")
        st.last_t = frame.t_s
        st.last_frame_mono = done
        st.fps_window.append(frame.t_s)
        st.n_frames += 1
        self._writer.call(setattr, self.log, "n_dropped", self.queue.dropped)
        self._writer.call(self.log.add_frame, frame.t_s, angles,
                          int(getattr(estimate, "n_inliers", -1) or -1),
                          str(getattr(estimate, "model", "") or ""),
                          _status_text(getattr(estimate, "status", None)), latency_ms, abs_angles,
                          None if self.fusion is None else self._fusion_mode == "fused")
        if self.on_frame is not None:
            self.on_frame(FrameResult(frame.t_s, angles, latency_ms, estimate, frame.truth_angles_deg,
                                      abs_angles, self._fusion_mode))
        from walkmon.rotation.types import UNMEASURED_MODELS  # noqa: PLC0415  (cached after the first frame)

        if str(getattr(estimate, "model", "")) in UNMEASURED_MODELS and self._fusion_mode != "fused":
            # held (a covered lens, darkness, a lost frame) or carried on through a turn, and no IMU carried it: it
            # measured nothing (flat angles that read as standing); the offline analysis leaves the same frames out
            # (api.measured_rows)
            ind = self.indicators.push_unmeasured(frame.t_s)
        else:
            ind = self.indicators.push(frame.t_s, angles, abs_angles)
        if ind is not None:
            self._hop(ind, st)

    def _hop(self, ind: LiveIndicators, st: _RunState) -> None:
        """One hop of the indicators: alerts, session log, sinks, ``on_hop``."""
        st.hops += 1
        events = self.alerts.push(ind)
        fusion_counters = self._fusion_counters()
        self._writer.call(self.log.add_hop, ind, None if fusion_counters is None else {"fusion": fusion_counters})
        for ev in events:
            self._writer.call(self.log.add_alert, ev)
            st.alerts_raised += ev.state == "raised"
        if events and self.sinks is not None:
            self.sinks.deliver(events)
        w = st.fps_window
        fps = (len(w) - 1) / (w[-1] - w[0]) if len(w) > 1 and w[-1] > w[0] else math.nan
        if self.on_hop is not None:
            self.on_hop(HopReport(ind, tuple(events), self.alerts.active, st.n_frames,
                                  self.queue.dropped, fps, self.latency.percentile(99), st.last_angles,
                                  time.monotonic() - st.wall0, fusion_counters))

    def _close_session(self, threads: list[threading.Thread], st: _RunState, error: BaseException | None) -> None:
        """On every path out of :meth:`run`: stop the threads, close the sources, clear the alerts, close the log."""
        self._stop.set()
        self.notifier.stopping()
        for th in threads:
            if th.ident is None:  # made but never started: a later step of the start failed (the camera's open)
                continue
            th.join(_JOIN_TIMEOUT_S)
            if th.is_alive():
                _log.error("thread %s did not stop within %.0f s", th.name, _JOIN_TIMEOUT_S)
        self.camera.close()
        if self.imu is not None:
            self.imu.close()
            self._drain_imu()
        self._close_alerts(st.last_t)
        if self._thread_errors and error is None:
            self._end_reason = f"error: {self._thread_errors[0]}"
        self._writer.stop(_JOIN_TIMEOUT_S + 10.0)
        self.log.n_dropped = self.queue.dropped
        if self._writer.dropped_calls:
            _log.error("session log fell behind: %d writes dropped", self._writer.dropped_calls)
        self._close_log(error)

    def _close_alerts(self, last_t: float) -> None:
        """Alerts still raised when the session ends are cleared in the log (and told to the sinks)."""
        closing = self.alerts.close(last_t if math.isfinite(last_t) else 0.0)
        for ev in closing:
            self._writer.call(self.log.add_alert, ev)
        if self.sinks is not None:
            if closing:
                try:
                    self.sinks.deliver(closing)
                except Exception:  # a sink must not hide why the session ended
                    _log.exception("delivering the session-end alert clears failed")
            self.sinks.close()

    def _close_log(self, error: BaseException | None) -> None:
        """Close the session log with its meta, or discard a session whose start failed."""
        try:
            if self.log.n_frames == 0 and (error is not None or self._thread_errors) \
                    and not isinstance(error, KeyboardInterrupt):
                # the start failed (camera missing, IMU unreadable): no frame was recorded, so no session
                self.log.discard(self._end_reason)
            else:
                self.log.close(self._end_reason, meta={
                    "log_writes_dropped": self._writer.dropped_calls,
                    "dropped_frames": self.queue.dropped, "reconnects": self._reconnects,
                    "latency_p99_ms": self.latency.percentile(99), "imu_overflows": self._imu_overflows,
                    **({} if self.imu is None else {"imu_rejected": self._imu_rejected(),
                                                    "imu_stream": self._imu_stream()}),
                    **({} if self.fusion is None else {"fusion": self._fusion_counters()})})
        except Exception:  # a broken database must not hide why the session ended
            _log.exception("closing the session log failed")

    def _raise_thread_error(self) -> None:
        """Re-raise in the caller the first exception of a pipeline thread (a WalkmonError as it is)."""
        if self._thread_errors:
            exc0 = self._thread_errors[0]
            if isinstance(exc0, WalkmonError):
                raise exc0
            msg = f"a pipeline thread failed: {exc0!r}"
            raise WalkmonError(msg) from exc0

    def _result(self, st: _RunState) -> PipelineResult:
        return PipelineResult(
            session_id=self.log.session_id,
            end_reason=self._end_reason,
            frames=self.log.n_frames,
            dropped=self.queue.dropped,
            hops=st.hops,
            alerts_raised=st.alerts_raised,
            duration_s=0.0 if math.isnan(st.first_t) else float(st.last_t - st.first_t),
            wall_s=time.monotonic() - st.wall0,
            latency_p50_ms=self.latency.percentile(50),
            latency_p99_ms=self.latency.percentile(99),
            latency_max_ms=self.latency.max_ms,
            reconnects=self._reconnects,
            imu_samples=self._imu_count,
            imu_overflows=self._imu_overflows,
            fusion=self._fusion_counters(),
            imu_stream=self._imu_stream(),
        )

    def _imu_stream(self) -> dict[str, int] | None:
        """The IMU stream's counters (see :attr:`PipelineResult.imu_stream`); None without an IMU."""
        if self.imu is None:
            return None
        out = {} if self._parser_stats is None else dataclasses.asdict(self._parser_stats)
        out["clock_restarts"] = out.get("clock_restarts", 0) + self.imu_check.clock_restarts
        out["reconnects"] = self._imu_reconnects
        return out
