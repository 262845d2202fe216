"""The walking simulator as a live camera: ``sim:normal:10,bend:10?seed=0&width=640&height=480&realtime=1``.

Frames come from :func:`walkmon.simulate.iter_frames` (rendered on the fly), with the simulation time as
capture time and the true angles attached (``Frame.truth_angles_deg``). ``realtime=1`` (default) paces them at
``fps`` on the monotonic clock; ``realtime=0`` runs as fast as rendering allows (accelerated sessions).
``seconds`` defaults to the walk script's total (the simulator adds its standing phases).
"""

from __future__ import annotations

import inspect
import logging
import re
import time
from collections.abc import Iterator
from typing import Any

from walkmon.camera.model import CameraModel
from walkmon.drivers.camera_base import CameraSource, Frame
from walkmon.errors import ConfigError, SourceDisconnected, SourceError

__all__ = ["SimCamera", "script_seconds"]

_log = logging.getLogger(__name__)


def script_seconds(walk: str) -> float | None:
    """Total of the durations in a walk script like ``normal:10,bend:10``; None for a bare walk name."""
    parts = [p.strip() for p in walk.split(",")]
    total = 0.0
    for p in parts:
        m = re.fullmatch(r"([A-Za-z_]+)(?::([+-]?\d+(?:\.\d+)?))?(?::(\d+(?:\.\d+)?))?", p)
        if not m:
            msg = f"sim: bad walk script part {p!r} (expected name, name:seconds or turn:degrees[:seconds])"
            raise ConfigError(msg)
        if m.group(1).lower() == "mount":  # the camera's tilt on the trunk, not a segment
            continue
        if m.group(2) is None:
            return None
        if m.group(1).lower() != "turn":  # a turn's number is its angle (the simulator checks the script)
            total += float(m.group(2))
    return total or None


class SimCamera(CameraSource):
    def __init__(self, url: str, walk: str, seconds: float | None = None, seed: int = 0, width: int = 640,
                 height: int = 480, fps: float = 30.0, realtime: bool = True, distortion: bool = False) -> None:
        super().__init__(url)
        self.walk = walk
        self.seconds = seconds if seconds is not None else (script_seconds(walk) or 16.0)
        self.seed, self.width, self.height, self.fps = seed, width, height, fps
        self.realtime, self.distortion = realtime, distortion
        self.live = realtime
        self.host_clock = False  # the simulated walk's own times, from 0
        self._it: Iterator[tuple[float, object, object]] | None = None
        self._index = 0
        self._t0_mono = 0.0
        self._camera: CameraModel | None = None

    def _open(self) -> None:
        try:
            from walkmon import simulate  # noqa: PLC0415
        except ImportError as exc:
            msg = f"{self.url}: the simulator (walkmon.simulate) is not available: {exc}"
            raise SourceError(msg) from exc
        kwargs: dict[str, Any] = {"seed": self.seed, "width": self.width, "height": self.height,
                                     "fps": self.fps, "distortion": self.distortion}
        params = inspect.signature(simulate.iter_frames).parameters
        if not any(p.kind is p.VAR_KEYWORD for p in params.values()):
            kwargs = {k: v for k, v in kwargs.items() if k in params}
        try:
            self._it = iter(simulate.iter_frames(self.walk, self.seconds, **kwargs))
        except (ValueError, KeyError) as exc:
            msg = f"{self.url}: {exc}"
            raise ConfigError(msg) from exc
        self._camera = self._simulated_camera(simulate)
        self._t0_mono = time.monotonic()

    def _simulated_camera(self, simulate: object) -> CameraModel | None:
        for name in ("simulation_camera", "simulated_camera", "camera_model"):
            fn = getattr(simulate, name, None)
            if callable(fn):
                try:
                    cam = fn(width=self.width, height=self.height, distortion=self.distortion)
                except TypeError:
                    try:
                        cam = fn(self.width, self.height)
                    except TypeError:
                        continue
                if isinstance(cam, CameraModel):
                    return cam
        return None

    def camera_model(self) -> CameraModel | None:
        return self._camera

    def _read(self) -> Frame:
        assert self._it is not None
        try:
            t_s, image, truth = next(self._it)
        except StopIteration:
            msg = f"{self.url}: end of simulated session after {self._index} frames"
            raise SourceDisconnected(msg) from None
        if self.realtime:
            delay = self._t0_mono + float(t_s) - time.monotonic()
            if delay > 0:
                time.sleep(delay)
        truth_t = tuple(float(v) for v in truth) if truth is not None else None  # type: ignore[attr-defined]
        frame = Frame(float(t_s), image, self._index, truth_t)  # type: ignore[arg-type]
        self._index += 1
        return frame

    def _close(self) -> None:
        it, self._it = self._it, None
        close = getattr(it, "close", None)
        if callable(close):
            try:
                close()
            except ValueError:  # still rendering a frame in the grabber thread: it ends with that thread
                _log.debug("%s: generator busy in another thread; left to finish", self.url)
