"""The tilt a turn past a facade leaves in the fast method is taken out by the vertical lines after it (issue 14,
and issue 11's video posture after turns).

On this simulated walk (320x240, seed 3, the camera 4 deg down and 1.6 deg rolled on the trunk; two quarter turns
towards a facade 1-3 m away with one second of walking between them) the odometry came out of the second turn
6.7 deg off in tilt and stayed so to the end: the error was beyond the lines' 3 deg limit. Now the turn's frames
add doubt and the lines correct it as soon as the turn is over (1.0-1.4 deg left).
"""

from __future__ import annotations

import numpy as np
import pytest

from walkmon.rotation import EstimateStatus

SCRIPT = "mount:-4:1.6,stand:2,normal:5,turn:-90,normal:1,turn:-90,normal:6"


@pytest.fixture(scope="module")
def two_turns(tmp_path_factory, script_renderer):
    return script_renderer(tmp_path_factory, "two_turns", SCRIPT, seed=3)


def test_tilt_left_by_turns_is_corrected_after_them(two_turns, clip_run) -> None:
    run = clip_run(two_turns)
    out, n, truth = run.out, run.n, run.relative_truth
    tilt_err = run.tilt_error_deg()
    t = run.t
    assert np.median(tilt_err[t < 7.5]) < 0.3  # before the turns: the odometry itself
    after = t > 11.0  # the second turn is over by 10.5 s
    assert np.median(tilt_err[after]) < 2.0, np.median(tilt_err[after])  # 6.7 deg without the correction
    # the correction is a jump of the estimate: its frame is flagged, and no frame reported ok jumps
    assert any(o.reason == "keyframe_correction" for o, tt in zip(out[:n], t, strict=True) if 10.0 < tt < 12.0)
    rot = run.est
    for i in range(1, n):
        if t[i] > 10.0 and out[i].status is EstimateStatus.OK:
            step_err = (truth[i - 1].T @ truth[i]).T @ (rot[i - 1].T @ rot[i])
            assert np.degrees(np.arccos(np.clip((np.trace(step_err) - 1) / 2, -1, 1))) < 1.0, t[i]
