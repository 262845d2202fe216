"""``walkmon live``: monitor walking posture from a live camera (and IMU), alert, and log the session."""

from __future__ import annotations

import argparse
import dataclasses
import logging
import math
import sys
from pathlib import Path
from typing import Any, TextIO

from walkmon.commands import _signals
from walkmon.commands.sessions import printable
from walkmon.errors import WalkmonError

NAME = "live"
HELP = "monitor posture live from a camera (v4l2:, depthai:, file:, sim:), raise alerts, log the session"

_log = logging.getLogger(__name__)


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--camera", metavar="SOURCE",
                   help="camera source, e.g. v4l2:/dev/video0?width=640&height=480&fps=30, depthai:, "
                        "file:walk.mp4?realtime=1, sim:normal:10,bend:10 (default: from the config)")
    p.add_argument("--imu", metavar="SOURCE", help="IMU source, e.g. serial:/dev/ttyACM0?baud=115200, file:imu.csv, "
                   "or depthai: (the OAK camera's own IMU; same as imu=1 in the depthai: camera URL); "
                   "with an IMU the live angles are camera-IMU fused")
    p.add_argument("--config", metavar="TOML", help="configuration file (every key: 'walkmon config --example')")
    p.add_argument("--calib", metavar="YAML", help="camera intrinsics (ROS camera_info YAML)")
    p.add_argument("--method", choices=("fast", "paper"), help="rotation estimator method (default: config, fast)")
    p.add_argument("--data-dir", metavar="DIR", help="session database folder (default ~/.local/share/walkmon)")
    p.add_argument("--person", metavar="NAME", help="who is walking, stored with the session (default: config "
                   "[session] person); 'walkmon history --person NAME' shows one person's sessions")
    p.add_argument("--duration", type=float, metavar="S", help="stop after S seconds (default: until the source "
                   "ends or SIGINT/SIGTERM)")
    p.add_argument("--status", choices=("auto", "line", "lines", "none"), default="auto",
                   help="status each hop: 'line' refreshes one terminal line, 'lines' prints one per hop, "
                        "'auto' = line on a terminal, none otherwise")


def status_line(h: Any) -> str:
    """One-line live status: frames/s, dropped, cadence, posture angles, label, alerts."""
    from walkmon.gait.live import unmeasured_why  # noqa: PLC0415

    ind = h.indicators

    def f(v: float, fmt: str) -> str:
        return format(v, fmt) if math.isfinite(v) else "  -  "

    p, y, r = ind.posture_deg
    alerts = ",".join(h.active_alerts) or "-"
    fusion = getattr(h, "fusion", None)
    imu = ""
    if fusion:
        cam = sum(fusion["frames_camera_only"].values())
        imu = f" imu={fusion['mode'] or '-'} (fused {fusion['frames_fused']}, camera-only {cam})"
    activity = str(getattr(ind, "activity", "") or "-")
    why = unmeasured_why(activity, ind.reasons)  # the camera saw nothing: say so, not just 'unknown'
    if why:
        activity = f"unknown ({'measuring again' if why.startswith('measuring again') else why})"
    return (f"t={ind.t_s:7.1f}s {f(h.fps, '4.1f')}fps drop={h.dropped:<4d} cad={f(ind.cadence_spm, '5.1f')}spm "
            f"pitch={f(p, '+5.1f')} yaw={f(y, '+5.1f')} roll={f(r, '+5.1f')} {activity:<8s} {ind.label:<18s} "
            f"alert={alerts}{imu}")


def live_fusion_settings(imu: Any) -> Any:
    """:class:`walkmon.imu.fusion.LiveFusionSettings` from the config's ``[imu]`` section."""
    from walkmon.imu.attitude import ImuFilterSettings  # noqa: PLC0415
    from walkmon.imu.fusion import FusionSettings, LiveFusionSettings  # noqa: PLC0415

    core = ImuFilterSettings(filter=imu.filter, tau_acc_s=imu.tau_acc_s, rest_min_s=imu.rest_min_s)
    calib = None
    if imu.calibration:
        from walkmon.tables import read_accelerometer_calibration  # noqa: PLC0415

        calib = read_accelerometer_calibration(imu.calibration)
    return LiveFusionSettings(
        fusion=FusionSettings(camera_from_imu=imu.camera_from_imu, time_offset_s=imu.time_offset_s, imu_filter=core,
                              accelerometer_calibration=calib),
        warmup_s=imu.warmup_s, max_gap_s=imu.max_gap_s, max_lag_s=imu.max_lag_s)


class _Status:
    def __init__(self, mode: str, stream: TextIO) -> None:
        if mode == "auto":
            mode = "line" if stream.isatty() else "none"
        self.mode, self.stream, self.width = mode, stream, 0

    def __call__(self, h: Any) -> None:
        if self.mode == "none":
            return
        line = status_line(h)
        if self.mode == "line":
            self.stream.write("\r" + line.ljust(self.width))
            self.width = len(line)
        else:
            self.stream.write(line + "\n")
        self.stream.flush()

    def end(self) -> None:
        if self.mode == "line" and self.width:
            self.stream.write("\n")
            self.stream.flush()


class CameraAwareEstimator:
    """Builds the rotation estimator on the first frame, when the frame size is known.

    Intrinsics: ``--calib``/config file (scaled to the frame size), else the source's own (simulator, OAK),
    else the documented default for ``hfov_deg``.
    """

    def __init__(self, source: Any, calib: Any, method: str, hfov_deg: float) -> None:
        self._source, self._calib, self._method, self._hfov = source, calib, method, hfov_deg
        self._est: Any = None

    def _build(self, frame: Any) -> Any:
        from walkmon.camera.model import camera_for_frames, default_camera  # noqa: PLC0415
        from walkmon.live.pipeline import make_estimator  # noqa: PLC0415

        h, w = frame.shape[:2]
        cam = self._calib or self._source.camera_model()
        if cam is None:
            cam = default_camera(w, h, self._hfov)
            _log.info("no calibration: default intrinsics for a %g deg field of view across the frames' longer side",
                      self._hfov)
        elif (cam.width_px, cam.height_px) != (w, h):
            _log.info("calibration is for %dx%d, frames are %dx%d: fitted", cam.width_px, cam.height_px, w, h)
        # a replayed file's display rotation (a phone's portrait video) turns a calibration of its sensor
        cam = camera_for_frames(cam, w, h, float(getattr(self._source, "rotation_deg", 0.0) or 0.0))
        return make_estimator(cam, self._method)

    def push(self, frame: Any, t_s: float) -> Any:
        if self._est is None:
            self._est = self._build(frame)
        return self._est.push(frame, t_s)

    def reset(self) -> None:
        if self._est is not None:
            self._est.reset()


def run(args: argparse.Namespace) -> int:
    try:
        return _run(args)
    except (WalkmonError, OSError, KeyboardInterrupt):
        raise
    except Exception as exc:
        _log.debug("unexpected error", exc_info=True)
        msg = f"unexpected error: {exc!r} (run with -vv for details)"
        raise WalkmonError(msg) from exc


def _prune_old_sessions(db_path: Path, retention_days: float) -> None:
    """``[session] retention_days``: delete older ended sessions as this one starts (it has no end time, so it
    is never pruned); a failure is logged and the session goes on (monitoring matters more than the disk)."""
    import sqlite3  # noqa: PLC0415

    from walkmon.live.session_log import prune_sessions  # noqa: PLC0415

    try:
        ids = prune_sessions(db_path, retention_days)
    except (sqlite3.Error, WalkmonError) as exc:
        _log.warning("session retention: pruning sessions older than %g days failed: %s", retention_days, exc)
        return
    _log.info("session retention: deleted %d ended session(s) older than %g days%s", len(ids), retention_days,
              f" ({', '.join(map(str, ids))})" if ids else "")


def _start_dashboard(cfg: Any, db_path: Path) -> Any:
    """``[serve] enabled``: the dashboard in a thread of this process; a failure is logged, monitoring goes on."""
    if not cfg.serve.enabled:
        return None
    try:
        from walkmon.serve.server import DashboardThread  # noqa: PLC0415

        dashboard = DashboardThread(db_path, cfg.serve.host, cfg.serve.port, cfg.serve.token).start()
    except (WalkmonError, ImportError, OSError) as exc:
        _log.warning("dashboard not started: %s", exc)
        return None
    _log.info("dashboard on %s", dashboard.url)
    return dashboard


def _run(args: argparse.Namespace) -> int:
    from walkmon.camera.model import read_camera_yaml  # noqa: PLC0415
    from walkmon.drivers.sources import open_camera, open_imu  # noqa: PLC0415
    from walkmon.gait.live import LiveIndicatorStage  # noqa: PLC0415
    from walkmon.live.alerts import AlertStage  # noqa: PLC0415
    from walkmon.live.config import DEFAULT_CONFIG, config_to_dict, read_config, redacted  # noqa: PLC0415
    from walkmon.live.pipeline import LivePipeline  # noqa: PLC0415
    from walkmon.live.sdnotify import Notifier  # noqa: PLC0415
    from walkmon.live.session_log import SessionLog, default_data_dir  # noqa: PLC0415
    from walkmon.live.sinks import AlertSinks, check_sinks  # noqa: PLC0415

    cfg = read_config(args.config) if args.config else DEFAULT_CONFIG
    cfg = dataclasses.replace(
        cfg,
        camera=dataclasses.replace(cfg.camera, url=args.camera or cfg.camera.url, calib=args.calib or cfg.camera.calib),
        imu=dataclasses.replace(cfg.imu, url=args.imu if args.imu is not None else cfg.imu.url),
        rotation=dataclasses.replace(cfg.rotation, method=args.method or cfg.rotation.method),
        session=dataclasses.replace(cfg.session, data_dir=args.data_dir or cfg.session.data_dir,
                                    person=cfg.session.person if args.person is None else args.person),
    )
    if args.duration is not None and not args.duration > 0:
        msg = f"--duration must be > 0, got {args.duration}"
        raise WalkmonError(msg)
    camera = open_camera(cfg.camera.url)
    if cfg.imu.url:
        imu = open_imu(cfg.imu.url, camera=camera)
    elif getattr(camera, "imu", False) and hasattr(camera, "imu_source"):  # depthai:?imu=1
        imu = camera.imu_source()
    else:
        imu = None
    fusion = None
    if imu is not None:
        from walkmon.imu.fusion import LiveFusion  # noqa: PLC0415

        fusion = LiveFusion(live_fusion_settings(cfg.imu))
    calib = read_camera_yaml(cfg.camera.calib) if cfg.camera.calib else None
    check_sinks(cfg.sinks)  # a hook or URL that cannot work stops the start, not the first alert
    data_dir = Path(cfg.session.data_dir).expanduser() if cfg.session.data_dir else default_data_dir()
    stream = sys.stderr
    status = _Status(args.status, stream)
    indicators = LiveIndicatorStage(cfg.indicators)
    alerts = AlertStage(cfg.alerts)
    # From here to the end a signal never raises: SIGINT/SIGTERM stop the pipeline (which closes the session),
    # SIGUSR1 asks for a calibration; what arrives before the pipeline exists is held and passed on.
    with _signals.deliver_to(_signals.PendingStop()) as pending:
        log = SessionLog(data_dir, kind="live", camera=cfg.camera.url, imu=cfg.imu.url or (imu.url if imu else ""),
                         config=redacted(config_to_dict(cfg)), flush_interval_s=cfg.session.flush_interval_s,
                         log_frames=cfg.session.log_frames, person=cfg.session.person)
        sinks = None
        try:
            sinks = AlertSinks(cfg.sinks, stream=stream if cfg.sinks.terminal else None,
                               session_id=log.session_id, person=cfg.session.person)
            pipeline = LivePipeline(
                camera,
                lambda src: CameraAwareEstimator(src, calib, cfg.rotation.method, cfg.camera.hfov_deg),
                indicators=indicators,
                alerts=alerts,
                session_log=log,
                sinks=sinks,
                imu_source=imu,
                fusion=fusion,
                settings=cfg.pipeline,
                notifier=Notifier(),
                on_hop=status,
            )
            pending.forward_to(pipeline)
            if cfg.session.retention_days > 0:
                _prune_old_sessions(log.path, cfg.session.retention_days)
            _log.info("session %d: %s -> %s", log.session_id, printable(cfg.camera.url), log.path)
            dashboard = _start_dashboard(cfg, log.path)
            try:
                res = pipeline.run(args.duration)  # closes the session (or discards it when the start failed)
            finally:
                if dashboard is not None:
                    dashboard.stop()
        except BaseException as exc:
            if not log.closed:  # failed before the pipeline ran: nothing recorded
                log.discard(f"start failed: {exc!r}")
                if sinks is not None:
                    sinks.close()
            raise
        finally:
            status.end()
    # a session that ended before any frame has no latency: said, not printed as 'nan ms' (user review)
    latency = (f"latency p99 {res.latency_p99_ms:.0f} ms" if math.isfinite(res.latency_p99_ms)
               else "no frame processed")
    sys.stdout.write(
        f"session {res.session_id}: {res.duration_s:.1f} s, {res.frames} frames, {res.dropped} dropped, "
        f"{res.hops} hops, {res.alerts_raised} alerts, {latency} "
        f"({printable(res.end_reason)}) -> {log.path}\n")
    if res.fusion is not None:
        cam = res.fusion["frames_camera_only"]
        rejected = res.fusion.get("imu_rejected") or {}
        sys.stdout.write(f"IMU fusion: {res.fusion['frames_fused']} frames fused, camera-only: {cam['no_imu']} before "
                         f"any IMU sample, {cam['warmup']} in the IMU warm-up, {cam['imu_gap']} in IMU gaps; "
                         f"{res.fusion['filter_restarts']} filter restarts, {res.fusion.get('gravity_resets', 0)} gravity resets, "
                         f"{res.imu_samples} IMU samples\n")
        if rejected:
            sys.stdout.write(f"IMU: {sum(rejected.values())} samples rejected as implausible ("
                             f"{', '.join(f'{k} {v}' for k, v in sorted(rejected.items()))}): not fused\n")
    stream_line = imu_stream_line(res.imu_stream, res.imu_samples)
    if stream_line:
        sys.stdout.write(stream_line + "\n")
    return 0


def imu_stream_line(stream: dict[str, int] | None, imu_samples: int) -> str:
    """The end-of-session line on an IMU stream's health (a parser's counts, clock restarts), or "" when all was
    well. A stream that gave bytes but no sample is named as such: a wrong protocol or baud rate reads as that."""
    if not stream:
        return ""
    bad = stream.get("bad_checksums", 0)
    skipped = stream.get("skipped_bytes", 0)
    restarts = stream.get("clock_restarts", 0)
    reconnects = stream.get("reconnects", 0)
    parts = [f"{bad} bad packets or lines"] if bad else []
    parts += [f"reconnected {reconnects} time(s)"] if reconnects else []
    parts += [f"{skipped} bytes skipped"] if skipped else []
    parts += [f"the device clock restarted {restarts} time(s), followed"] if restarts else []
    if imu_samples == 0 and (bad or skipped):
        return (f"IMU stream: no sample read ({', '.join(parts)}): check the URL's protocol and baud rate "
                f"against the device")
    return f"IMU stream: {', '.join(parts)}" if parts else ""
