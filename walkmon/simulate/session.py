"""A simulated walking session: gait model + street scene + renderer + IMU, written to files or streamed.

``simulate(out_dir, ...)`` writes ``video.mp4``, ``truth.csv``, ``imu.csv``, ``camera.yaml`` and ``meta.json``, and
the true timeline: ``truth_timeline.csv`` (per frame: activity, posture label, trunk pitch/roll and heading) and
``truth_steps.csv`` (initial contacts); meta.json's ``pieces`` and ``bouts`` hold the timeline's pieces and bouts;
``iter_frames(...)`` yields ``(t_s, frame_bgr, truth_angles_deg)`` in memory (the live ``sim:`` source).
Frame ``i`` is at ``t = i / fps``; the IMU shares that clock.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import logging
import os
import platform
import tempfile
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from walkmon.camera.model import CameraModel, default_camera, write_camera_yaml
from walkmon.consts import TRUTH_COLUMNS
from walkmon.errors import InvalidInputError
from walkmon.safe_io import check_not_symlink, prepare_dir, write_text
from walkmon.simulate._version import SIMULATOR_VERSION
from walkmon.simulate.gait import STANDING_S, GaitModel
from walkmon.simulate.imu import (
    DEFAULT_IMU_SETTINGS,
    ImuSamples,
    ImuSettings,
    simulate_imu,
)
from walkmon.simulate.render import DEFAULT_RENDER_SETTINGS, Renderer, RenderSettings
from walkmon.simulate.scene import StreetScene, build_street_scene
from walkmon.tables import write_table

__all__ = [
    "SIMULATION_DISTORTION",
    "SimulatedSession",
    "SimulationResult",
    "iter_frames",
    "simulate",
    "simulation_camera",
]

_log = logging.getLogger(__name__)

#: plumb_bob coefficients (k1, k2, p1, p2, k3) of the simulated lens when ``distortion=True``: clear barrel.
SIMULATION_DISTORTION = (-0.28, 0.09, 0.0, 0.0, 0.0)

#: Horizontal field of view of the simulated camera, degrees.
SIMULATION_HFOV_DEG = 70.0


def simulation_camera(width: int = 640, height: int = 480, distortion: bool = False) -> CameraModel:
    """The simulated camera: 70° field of view across the longer image side (horizontal for landscape sizes),
    square pixels, optional barrel distortion."""
    if not (16 <= int(width) <= 4096 and 16 <= int(height) <= 4096):
        msg = f"image size must be between 16 and 4096 pixels a side, got {width}x{height}"
        raise InvalidInputError(msg)
    cam = default_camera(int(width), int(height), SIMULATION_HFOV_DEG)
    coeffs = np.array(SIMULATION_DISTORTION if distortion else (0.0,) * 5)
    return CameraModel(cam.width_px, cam.height_px, cam.camera_matrix, "plumb_bob", coeffs, "walkmon_sim")


class SimulatedSession:
    """Everything needed to produce a session's frames, truth and IMU samples, deterministically per seed."""

    def __init__(
        self,
        walk: str = "normal",
        seconds: float = 16.0,
        seed: int = 0,
        width: int = 640,
        height: int = 480,
        fps: float = 30.0,
        distortion: bool = False,
        *,
        stand_s: float = STANDING_S,
        render_settings: RenderSettings = DEFAULT_RENDER_SETTINGS,
        imu_settings: ImuSettings = DEFAULT_IMU_SETTINGS,
    ) -> None:
        if not (np.isfinite(fps) and 1.0 <= fps <= 240.0):
            msg = f"fps must be in [1, 240], got {fps}"
            raise InvalidInputError(msg)
        self.seed = int(seed)
        self.fps = float(fps)
        self.distortion = bool(distortion)
        self.model = GaitModel(walk, seconds, self.seed, stand_s=stand_s)
        self.camera = simulation_camera(width, height, distortion)
        self.render_settings = render_settings
        self.imu_settings = imu_settings
        self._scene: StreetScene | None = None
        self._renderer: Renderer | None = None

    @property
    def n_frames(self) -> int:
        return int(np.floor(self.model.duration_s * self.fps + 1e-9))

    @property
    def frame_times_s(self) -> NDArray[np.float64]:
        return np.arange(self.n_frames) / self.fps

    @property
    def scene(self) -> StreetScene:
        if self._scene is None:
            if self.model.literal:
                self._scene = self._session_scene()
            else:
                z_max = float(self.model.position_m(np.linspace(0, self.model.duration_s, 200))[:, 2].max())
                self._scene = build_street_scene(self.seed, camera_height_m=self.model.camera_height_m, z_max_m=z_max)
        return self._scene

    def _session_scene(self) -> StreetScene:
        """The street of a session script, fitted around its path: the walker keeps to one side (the near facade
        1-2 m beyond the path's extreme, so turns sweep across it at 1-3 m) and the street's far end and (after
        a U-turn) its other end have buildings."""
        pos = self.model.position_m(np.arange(0.0, self.model.duration_s + 0.05, 0.05))
        rng = np.random.default_rng([self.seed, 0xFACADE])
        near, far = float(rng.uniform(1.0, 2.0)), float(rng.uniform(3.0, 5.5))
        x_lo, x_hi = float(pos[:, 0].min()), float(pos[:, 0].max())
        walls = (x_lo - far, x_hi + near) if rng.uniform() < 0.5 else (x_lo - near, x_hi + far)
        return build_street_scene(
            self.seed, camera_height_m=self.model.camera_height_m, z_max_m=float(pos[:, 2].max()),
            walls_x_m=walls, z_min_m=float(pos[:, 2].min()),
        )

    def timeline(self) -> dict[str, NDArray[Any]]:
        """truth_timeline.csv columns per frame: t, activity, label (walk type while walking, else empty), and the
        trunk's heading-free posture: trunk_pitch (< 0 bent forward), trunk_roll (> 0 right side down) and
        heading (the walking direction plus the stride's yaw swing, unwrapped), degrees."""
        t = self.frame_times_s
        activity, label = self.model.timeline(t)
        body = self.model.body_angles_deg(t) if t.size else np.zeros((0, 3))
        return {"t": t, "activity": activity, "label": label, "trunk_pitch": body[:, 0], "trunk_roll": body[:, 2],
                "heading": body[:, 1]}

    def steps(self) -> dict[str, NDArray[Any]]:
        """truth_steps.csv columns: t (initial contact, s), foot (R/L), bout (index into meta.json's bouts)."""
        times, feet = self.model.step_times_s()
        bouts = self.model.bouts()
        idx = np.full(times.shape, -1, int)
        for i, b in enumerate(bouts):
            idx[(times >= b["start_s"] - 1e-3) & (times <= b["end_s"] + 1e-3)] = i
        return {"t": times, "foot": feet, "bout": idx}

    @property
    def renderer(self) -> Renderer:
        if self._renderer is None:
            self._renderer = Renderer(self.camera, self.scene, self.render_settings)
        return self._renderer

    def truth(self) -> dict[str, NDArray[np.float64]]:
        """truth.csv columns: t, pitch, yaw, roll (degrees: the camera's orientation in the world, the upright
        trunk's frame at the start, so relative to frame 0 unless the script tilts the camera with ``mount:`` or
        starts bent: then the first row holds that tilt), x, y, z (metres)."""
        t = self.frame_times_s
        angles = _unwrap_yaw(self.model.truth_angles_deg(t))
        pos = self.model.position_m(t)
        cols = (t, angles[:, 0], angles[:, 1], angles[:, 2], pos[:, 0], pos[:, 1], pos[:, 2])
        return dict(zip(TRUTH_COLUMNS, cols, strict=True))

    def imu(self) -> ImuSamples:
        return simulate_imu(self.model, self.imu_settings)

    def _blur_px(self, t_s: float) -> float:
        """Image motion (pixels) during the exposure around ``t_s``."""
        e = self.render_settings.exposure_s
        return self._motion_px(t_s - e / 2, t_s + e / 2) if e > 0 else 0.0

    def _motion_px(self, t0_s: float, t1_s: float) -> float:
        """Image motion (pixels) from t0 to t1: rotation plus translation seen at ~2 m depth."""
        R, p = self.model.pose([t0_s, t1_s])
        rel = R[0].T @ R[1]
        angle = float(np.arccos(np.clip((np.trace(rel) - 1.0) / 2.0, -1.0, 1.0)))
        f = self.camera.fx
        return f * angle + f * float(np.linalg.norm(p[1] - p[0])) / 2.0

    def render(self, t_s: float, rng: np.random.Generator) -> NDArray[np.uint8]:
        """The video frame at ``t_s`` (motion blur over the exposure, defocus, vignetting, noise), BGR uint8."""
        r = self.renderer
        n_taps = r.blur_taps(self._blur_px(t_s))
        e = self.render_settings.exposure_s
        R, p = self.model.pose([t_s - e / 2, t_s, t_s + e / 2])
        readout = self.render_settings.rolling_shutter_s
        if readout <= 0:
            return r.finish(r.render_blurred(R, p, n_taps), rng)
        # rolling shutter: row bands thin enough that the image moves < rolling_shutter_step_px between them
        motion_px = self._motion_px(t_s - readout / 2, t_s + readout / 2)
        step_px = self.render_settings.rolling_shutter_step_px
        n_bands = int(np.clip(np.ceil(motion_px / step_px), 1, self.camera.height_px))
        edges = r.band_rows(n_bands)
        centres = 0.5 * (edges[:-1] + edges[1:]) / self.camera.height_px - 0.5
        band_R, band_p = self.model.pose(t_s + readout * centres)
        return r.finish(r.render_blurred(R, p, n_taps, band_rotations=band_R, band_positions_m=band_p), rng)

    def frames(self) -> Iterator[tuple[float, NDArray[np.uint8], NDArray[np.float64]]]:
        """``(t_s, frame_bgr, truth_angles_deg (3,))`` for every frame, in order."""
        t_all = self.frame_times_s
        angles = _unwrap_yaw(self.model.truth_angles_deg(t_all)) if t_all.size else np.zeros((0, 3))
        for i, t in enumerate(t_all):
            rng = np.random.default_rng([self.seed, 0xF4A3E, i])
            yield float(t), self.render(float(t), rng), angles[i]

    def meta(self) -> dict[str, Any]:
        """meta.json content (without file names and timings)."""
        from walkmon._version import __version__  # noqa: PLC0415

        cam = self.camera
        imu = self.imu_settings
        meta: dict[str, Any] = {
            "generator": "walkmon simulate",
            "simulator_version": SIMULATOR_VERSION,
            "versions": {
                "walkmon": __version__,
                "numpy": np.__version__,
                "opencv": cv2.__version__,
                "python": platform.python_version(),
            },
            **self.model.meta(),
            "session_script": self.model.literal,
            "pieces": [
                {"start_s": round(p.start_s, 4), "end_s": round(p.end_s, 4), "activity": p.activity, "label": p.label,
                 **({"turn_deg": p.turn_deg} if p.activity == "turning" else {})}
                for p in self.model.pieces
            ],
            "bouts": self.model.bouts(),
            "fps": self.fps,
            "n_frames": self.n_frames,
            "width": cam.width_px,
            "height": cam.height_px,
            "distortion": self.distortion,
            "camera": {
                "fx": cam.fx,
                "fy": cam.fy,
                "cx": cam.cx,
                "cy": cam.cy,
                "hfov_deg": round(cam.hfov_deg, 4),
                "distortion_model": cam.distortion_model,
                "distortion_coefficients": [float(v) for v in cam.distortion_coefficients],
            },
            "render": {
                "exposure_s": self.render_settings.exposure_s,
                "max_blur_taps": self.render_settings.max_blur_taps,
                "rolling_shutter_s": self.render_settings.rolling_shutter_s,
                "defocus_sigma_px": self.render_settings.defocus_sigma_px,
                "read_noise_dn": self.render_settings.read_noise_dn,
                "shot_noise_gain": self.render_settings.shot_noise_gain,
                "codec": "mp4v",
            },
            "imu": {"frame": "camera (x right, y down, z forward)", **imu.to_dict()},
            "conventions": "R = Rz(roll) Rx(pitch) Ry(yaw), orientation of camera t relative to camera 0; "
            "degrees; world frame = camera 0 frame (y down); accelerometer = specific force",
        }
        return meta


@dataclass(frozen=True, slots=True)
class SimulationResult:
    """What :func:`simulate` wrote, and how long rendering took."""

    out_dir: Path
    video_path: Path | None
    truth_path: Path
    imu_path: Path
    camera_path: Path
    meta_path: Path
    n_frames: int
    duration_s: float
    fps: float
    camera: CameraModel
    render_time_s: float
    meta: dict[str, Any] = field(repr=False)


def simulate(
    out_dir: str | Path,
    walk: str = "normal",
    seconds: float = 16.0,
    seed: int = 0,
    width: int = 640,
    height: int = 480,
    fps: float = 30.0,
    distortion: bool = False,
    *,
    video: bool = True,
    stand_s: float = STANDING_S,
    render_settings: RenderSettings = DEFAULT_RENDER_SETTINGS,
    imu_settings: ImuSettings = DEFAULT_IMU_SETTINGS,
    on_frame: Callable[[int, int], None] | None = None,
) -> SimulationResult:
    """Simulate a walk and write video.mp4 (unless ``video=False``), truth.csv, imu.csv, camera.yaml, meta.json.

    ``walk`` is a walk type (``normal``, ``left_shoulder_down``, ``right_foot_drag``, ``bend``) lasting
    ``seconds`` in total, or a script like ``"normal:10,bend:10"`` (walking seconds per segment; ``seconds`` is
    then ignored). Every session starts and ends with ``stand_s`` (2 s) of standing still. ``on_frame(done,
    total)`` is called after each rendered frame (progress bars).
    """
    session = SimulatedSession(
        walk, seconds, seed, width, height, fps, distortion,
        stand_s=stand_s, render_settings=render_settings, imu_settings=imu_settings,
    )
    out = prepare_dir(out_dir)  # a symlinked folder is refused, as by every writer (user review)
    truth_path, imu_path = out / "truth.csv", out / "imu.csv"
    timeline_path, steps_path = out / "truth_timeline.csv", out / "truth_steps.csv"
    camera_path, meta_path, video_path = out / "camera.yaml", out / "meta.json", out / "video.mp4"

    # round before writing, and add 0.0 so values that round to zero are written as 0.000000, not -0.000000
    write_table(truth_path, {k: np.round(v, 6) + 0.0 for k, v in session.truth().items()}, default_precision=6)
    samples = session.imu()
    write_table(imu_path, {k: np.round(v, 7) + 0.0 for k, v in samples.columns().items()}, default_precision=7)
    # the camera's rolling-shutter readout in its calibration, as a user's camera.yaml carries it (user review:
    # '--rolling-shutter-ms 30' wrote none, so 'analyze --calib camera.yaml' corrected nothing: 3.2 deg RMS, 1.2 with
    # the readout given)
    write_camera_yaml(dataclasses.replace(session.camera, readout_s=session.render_settings.rolling_shutter_s),
                      camera_path)
    timeline = session.timeline()
    timeline = {k: (np.round(v, 4) + 0.0 if k != "t" and v.dtype.kind == "f" else v) for k, v in timeline.items()}
    write_table(timeline_path, timeline, precision={"t": 6}, default_precision=4)
    write_table(steps_path, session.steps(), precision={"t": 4, "bout": 0})

    render_time = 0.0
    if video:
        t0 = time.perf_counter()
        _write_video(session, video_path, on_frame)
        render_time = time.perf_counter() - t0
        _log.info("rendered %d frames in %.1f s", session.n_frames, render_time)

    meta = session.meta()
    meta["seconds_requested"] = float(seconds)
    meta["imu"].update(
        {
            "gyroscope_bias_rps": [round(float(v), 8) for v in samples.gyroscope_bias_rps],
            "gyroscope_bias_dps": [round(float(v), 6) for v in np.degrees(samples.gyroscope_bias_rps)],
            "accelerometer_bias_mps2": [round(float(v), 6) for v in samples.accelerometer_bias_mps2],
            "n_samples": int(samples.t_s.size),
        }
    )
    meta["scene"] = session.scene.describe() if video else {"camera_height_m": session.model.camera_height_m}
    meta["files"] = {
        "video": video_path.name if video else None,
        "truth": truth_path.name,
        "imu": imu_path.name,
        "camera": camera_path.name,
        "timeline": timeline_path.name,
        "steps": steps_path.name,
    }
    meta["render_time_s"] = round(render_time, 3)
    write_text(meta_path, json.dumps(meta, indent=2) + "\n")
    return SimulationResult(
        out, video_path if video else None, truth_path, imu_path, camera_path, meta_path,
        session.n_frames, session.model.duration_s, session.fps, session.camera, render_time, meta,
    )


def _write_video(session: SimulatedSession, path: Path,
                 on_frame: Callable[[int, int], None] | None = None) -> None:
    """The video into a file of our own (0600, made here: OpenCV's writer honoured the umask, 0644, and followed
    a link planted at video.mp4), moved onto ``path`` when complete, as safe_io's writers do."""
    cam = session.camera
    check_not_symlink(path)
    fd, tmp_name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=path.suffix)
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        writer = cv2.VideoWriter(tmp_name, cv2.VideoWriter_fourcc(*"mp4v"), session.fps, (cam.width_px, cam.height_px))
        if not writer.isOpened():
            msg = f"cannot write {path}: OpenCV has no working mp4v encoder here"
            raise OSError(msg)
        try:
            for i, (_, frame, _) in enumerate(session.frames()):
                writer.write(frame)
                if on_frame is not None:
                    on_frame(i + 1, session.n_frames)
        finally:
            writer.release()
        check_not_symlink(path)
        os.replace(tmp, path)
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink()


def _unwrap_yaw(angles: NDArray[np.float64]) -> NDArray[np.float64]:
    """Yaw made continuous across ±180° (turns); angles that never jump are returned unchanged, bit for bit."""
    if angles.shape[0] > 1 and np.abs(np.diff(angles[:, 1])).max() > 180.0:
        angles = angles.copy()
        angles[:, 1] = np.unwrap(angles[:, 1], period=360.0)
    return angles


def iter_frames(
    walk: str = "normal",
    seconds: float = 16.0,
    seed: int = 0,
    width: int = 640,
    height: int = 480,
    fps: float = 30.0,
    distortion: bool = False,
    *,
    stand_s: float = STANDING_S,
    render_settings: RenderSettings = DEFAULT_RENDER_SETTINGS,
) -> Iterator[tuple[float, NDArray[np.uint8], NDArray[np.float64]]]:
    """Yield ``(t_s, frame_bgr uint8 (H, W, 3), truth_angles_deg (pitch, yaw, roll))`` for each frame, in memory.

    The frames are identical to the ones :func:`simulate` encodes for the same arguments (before compression).
    Bad arguments raise :class:`InvalidInputError` here, not at the first frame.
    """
    session = SimulatedSession(
        walk, seconds, seed, width, height, fps, distortion, stand_s=stand_s, render_settings=render_settings
    )
    return session.frames()
