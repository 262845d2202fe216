"""Shared helpers of the rotation tests."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from walkmon.camera.model import read_camera_yaml
from walkmon.consts import rotation_from_angles_deg
from walkmon.rotation import EstimateStatus, RotationEstimate, RotationEstimator
from walkmon.tables import read_table


@dataclass(frozen=True)
class ClipRun:
    """The fast method run over a simulated clip, beside the clip's truth (first ``n`` frames of both)."""

    out: list[RotationEstimate]
    t: np.ndarray  # (n,) truth times
    truth: np.ndarray  # (n, 3, 3) true camera orientations (absolute, truth.csv)
    est: np.ndarray  # (n, 3, 3) estimated orientations (start-relative)
    ok: np.ndarray  # (n,) frames reported ok (or the first frame)

    @property
    def n(self) -> int:
        return len(self.t)


def run_clip(clip: Path) -> ClipRun:
    """Push every frame of ``clip/video.mp4`` through a RotationEstimator made from ``clip/camera.yaml``."""
    from walkmon.drivers.video_file import VideoFile

    est = RotationEstimator(read_camera_yaml(clip / "camera.yaml"))
    with VideoFile(clip / "video.mp4") as video:
        out = [est.push(frame, t) for t, frame in video]
    tr = read_table(clip / "truth.csv", ["t", "pitch", "yaw", "roll"])
    n = min(len(out), len(tr["t"]))
    return ClipRun(
        out[:n], np.asarray(tr["t"][:n], dtype=float),
        rotation_from_angles_deg(tr["pitch"], tr["yaw"], tr["roll"])[:n],
        np.array([o.rotation for o in out[:n]]),
        np.array([o.status in (EstimateStatus.OK, EstimateStatus.FIRST_FRAME) for o in out[:n]]),
    )


@pytest.fixture
def clip_run():
    """:func:`run_clip`, as a fixture."""
    return run_clip
