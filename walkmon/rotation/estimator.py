"""Camera rotation from video, one frame in, one estimate out: the stage the offline and live pipelines share.

``RotationEstimator(camera, settings).push(frame, t_s) -> RotationEstimate`` gives the orientation of the
camera at ``t_s`` relative to the first frame (conventions of :mod:`walkmon.consts`). Two methods:

``fast`` (default)
    Corners tracked with pyramidal Lucas-Kanade at reduced resolution, re-detected only when tracks thin out.
    Every frame is compared with the current *keyframe* (not only the previous frame), so per-frame errors do
    not pile up; keyframes are chained. For each frame both a rotation-only model and an essential-matrix model
    (refined from the rotation-only fit, so it never flips to the ~180 degree twisted pair) are fitted and
    GRIC picks the one the data support: rotation-only while standing or at short baselines, essential when
    the walker's translation shows as parallax. A frame whose essential rotation strays from the
    rotation-only one further than the parallax explains is LOW_QUALITY (rotation-only used). See
    :mod:`walkmon.rotation.geometry`.

``paper``
    The reference paper's pipeline as written (AKAZE, LK to find the matching area, FLANN, 5-point RANSAC,
    bundle adjustment, chained frame to frame); see :mod:`walkmon.rotation.paper`.

Degenerate input (black or uniform frames, a repeated frame, too few features, a lens cap) never raises and
never jumps: the estimate holds the last orientation and says why in ``status``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from walkmon.camera.model import CameraModel
from walkmon.errors import ConfigError, InvalidInputError
from walkmon.rotation.types import (
    DEFAULT_ROTATION_SETTINGS,
    RotationEstimate,
    RotationSettings,
    grey_from_frame,
)

__all__ = ["RotationEstimator"]


class RotationEstimator:
    """Incremental camera-rotation estimator: ``push(frame, t_s) -> RotationEstimate``, ``reset()``.

    ``camera`` gives the intrinsics; frames of another size are handled by scaling the camera (same lens).
    No threads, no I/O, no clock reads.
    """

    def __init__(self, camera: CameraModel, settings: RotationSettings = DEFAULT_ROTATION_SETTINGS) -> None:
        if not isinstance(camera, CameraModel):
            msg = f"camera must be a CameraModel, got {type(camera).__name__}"
            raise ConfigError(msg)
        if not isinstance(settings, RotationSettings):
            msg = f"settings must be RotationSettings, got {type(settings).__name__}"
            raise ConfigError(msg)
        self.camera = camera
        self.settings = settings
        self._engine = self._make_engine(camera)

    def _make_engine(self, camera: CameraModel):  # noqa: ANN202
        if self.settings.method == "paper":
            from walkmon.rotation.paper import PaperEngine  # noqa: PLC0415

            return PaperEngine(camera, self.settings)
        from walkmon.rotation.fast import FastEngine  # noqa: PLC0415

        return FastEngine(camera, self.settings)

    def push(self, frame: NDArray[np.uint8], t_s: float) -> RotationEstimate:
        """Estimate the orientation at ``t_s`` from ``frame`` (BGR or grey uint8)."""
        grey = grey_from_frame(frame)
        h, w = grey.shape
        if (w, h) != (self._engine.camera.width_px, self._engine.camera.height_px):
            if self._engine.started:
                msg = (
                    f"frame size changed mid-stream to {w}x{h} from "
                    f"{self._engine.camera.width_px}x{self._engine.camera.height_px}"
                )
                raise InvalidInputError(msg)
            self._engine = self._make_engine(self.camera.scaled_to(w, h))
        return self._engine.push(grey, float(t_s))

    def reset(self) -> None:
        """Forget everything: the next frame becomes the new reference (identity)."""
        self._engine = self._make_engine(self.camera)
