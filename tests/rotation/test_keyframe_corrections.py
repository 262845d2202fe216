"""A keyframe whose refinement moves the orientation by a lot at once is flagged, never reported ok.

The fast method corrects a new keyframe's orientation from older keyframes (sliding-window refinement) and from
vertical lines. Applied in one frame, corrections of 0.5-0.6 deg were the largest frame-to-frame errors of the
wall scenario (seeds 2 and 4, while standing still), reported ok. Beyond 0.5 deg the frame is now flagged
``keyframe_correction``.
"""

from __future__ import annotations

import numpy as np
import pytest

from walkmon.camera.model import read_camera_yaml
from walkmon.consts import rotation_from_angles_deg
from walkmon.rotation import FLAG_REASONS, RotationEstimator, RotationSettings
from walkmon.rotation import fast as fast_module
from walkmon.rotation import geometry as geo
from walkmon.tables import read_table


@pytest.fixture(scope="module")
def walk_320(tmp_path_factory):
    simulate = pytest.importorskip("walkmon.simulate").simulate
    out = tmp_path_factory.mktemp("rotation_keyframe_corrections")
    return simulate(out, walk="normal", seconds=5.0, seed=2, width=320, height=240, stand_s=1.0)


def _run(result, monkeypatch, correction_deg: float):
    """Estimates, ok mask and frame-to-frame errors against the truth; the first keyframe refinement after 2 s
    adds ``correction_deg`` of pitch (a correction as large as a bad refinement's)."""
    original = fast_module.FastEngine._refined_keyframe_orientation
    done: list[float] = []

    def refined(self):
        R = original(self)
        if self._t_s > 2.0 and not done:
            done.append(self._t_s)
            return R @ rotation_from_angles_deg(correction_deg, 0.0, 0.0)
        return R

    monkeypatch.setattr(fast_module.FastEngine, "_refined_keyframe_orientation", refined)
    from walkmon.drivers.video_file import VideoFile

    est = RotationEstimator(read_camera_yaml(result.camera_path), RotationSettings())
    with VideoFile(result.video_path) as video:
        out = [est.push(frame, t_s) for t_s, frame in video]
    tr = read_table(result.truth_path, ["t", "pitch", "yaw", "roll"])
    n = min(len(out), len(tr["t"]))
    Rt = rotation_from_angles_deg(tr["pitch"], tr["yaw"], tr["roll"])[:n]
    Re = np.array([o.rotation for o in out[:n]])
    ok = np.array([o.status.value in ("ok", "first_frame") for o in out[:n]])
    step_err = np.array([0.0] + [geo.rotation_angle_deg((Rt[i - 1].T @ Rt[i]).T @ (Re[i - 1].T @ Re[i]))
                                 for i in range(1, n)])
    assert done, "no keyframe after 2 s"
    return out[:n], ok, step_err, done[0]


def test_a_large_keyframe_correction_is_flagged(walk_320, monkeypatch):
    out, ok, step_err, t_corr = _run(walk_320, monkeypatch, 1.5)
    i = next(k for k, o in enumerate(out) if o.t_s == t_corr)
    assert step_err[i] > 1.0  # the correction shows as a jump against the truth ...
    assert out[i].reason == "keyframe_correction"  # ... on a frame that says so
    assert "keyframe_correction" in FLAG_REASONS
    assert step_err[ok].max() < 0.5, step_err[ok].max()


def test_small_keyframe_corrections_stay_ok(walk_320, monkeypatch):
    out, ok, step_err, _ = _run(walk_320, monkeypatch, 0.0)
    assert not any(o.reason == "keyframe_correction" for o in out)  # a normal walk's refinements are small
    assert step_err[ok].max() < 0.5
