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

    @property
    def relative_truth(self) -> np.ndarray:
        """(n, 3, 3) the true orientations relative to the first frame's, as the estimator reports its own."""
        return np.einsum("ji,njk->nik", self.truth[0], self.truth)

    def gravity(self) -> tuple[np.ndarray, np.ndarray]:
        """Gravity's direction in the camera frame at every frame, ``(estimated, true)`` (n, 3) each, both from the
        start frame's true gravity (the estimator reports start-relative orientations)."""
        down = self.truth[0].T @ np.array([0.0, 1.0, 0.0])
        return np.einsum("nji,j->ni", self.est, down), np.einsum("nji,j->ni", self.relative_truth, down)

    def tilt_error_deg(self) -> np.ndarray:
        """(n,) the angle between the estimated and the true gravity in the camera frame: the tilt error."""
        est, true = self.gravity()
        return np.degrees(np.arccos(np.clip(np.sum(est * true, axis=1), -1.0, 1.0)))


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


def render_script(tmp_path_factory: pytest.TempPathFactory, name: str, script: str, seed: int) -> Path:
    """A session script rendered by the simulator at 320x240 into a fresh temporary folder (its path)."""
    from walkmon.simulate.session import simulate

    out = tmp_path_factory.mktemp(name)
    simulate(out, walk=script, seed=seed, width=320, height=240)
    return out


@pytest.fixture(scope="session")
def script_renderer():
    """:func:`render_script`, as a fixture (module-scoped clip fixtures take it)."""
    return render_script


@pytest.fixture
def clip_run():
    """:func:`run_clip`, as a fixture."""
    return run_clip
