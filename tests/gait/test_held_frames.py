"""Frames the rotation estimator holds measure nothing: a lens cap mid-walk is no standing (simulator truth)."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from walkmon.commands.cli import main

CAP = (6.0, 10.0)  # the lens is covered (black frames) from 6 to 10 s of an 18 s session (walking 2-16 s)


@pytest.fixture(scope="module")
def capped(tmp_path_factory: pytest.TempPathFactory, simulated_videos) -> Path:  # noqa: ANN001
    d = simulated_videos.render(tmp_path_factory.mktemp("capped"), "normal:14", 160, 120, seed=4)
    fps, frames = simulated_videos.frames(d / "video.mp4")
    out = cv2.VideoWriter(str(d / "capped.mp4"), cv2.VideoWriter_fourcc(*"mp4v"), fps, (160, 120))
    for i, frame in enumerate(frames):
        out.write(np.zeros_like(frame) if CAP[0] <= i / fps < CAP[1] else frame)
    out.release()
    return d


def _timeline(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as fh:
        return list(csv.DictReader(fh))


def _truth_walking(d: Path, t: float) -> bool:
    with (d / "truth_timeline.csv").open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    k = min(range(len(rows)), key=lambda i: abs(float(rows[i]["t"]) - t))
    return rows[k]["activity"] == "walking"


@pytest.mark.parametrize("command", ["analyze", "indicators"])
def test_a_lens_cap_mid_walk_is_unknown_not_standing(capped: Path, tmp_path: Path, command: str) -> None:
    """The walker walks on behind a covered lens; the estimator holds the orientation (featureless). Those
    flat angles read as 4 s of standing, which the person never did. Now the held frames are left out of the
    session analysis: the stretch is a gap (unknown, no timeline row inside it) and no bout spans it; the walking
    before and after is still found."""
    assert all(_truth_walking(capped, t) for t in np.arange(*CAP, 0.5))  # the truth: walking all along
    out = tmp_path / "out"
    assert main(["analyze", str(capped / "capped.mp4"), "--calib", str(capped / "camera.yaml"), "--out", str(out),
                 "--no-progress"]) == 0
    if command == "indicators":  # the same from the angles.csv analyze wrote (its model column says 'hold')
        out2 = tmp_path / "out2"
        assert main(["indicators", str(out / "angles.csv"), "--out", str(out2)]) == 0
        out = out2
    rows = _timeline(out / "timeline.csv")
    inside = [r for r in rows if CAP[0] + 0.5 < float(r["t"]) < CAP[1] - 0.5]
    assert not inside, inside  # no second inside the cap has a row: nothing was measured there
    edges = [r["activity"] for r in rows if CAP[0] - 0.1 < float(r["t"]) < CAP[1] + 0.1]
    assert "standing" not in edges, edges
    walking = [r for r in rows if r["activity"] == "walking"]
    assert any(float(r["t"]) < CAP[0] for r in walking) and any(float(r["t"]) > CAP[1] for r in walking)
    gait = json.loads((out / "indicators.json").read_text())
    assert all(b["end_s"] <= CAP[0] + 0.1 or b["start_s"] >= CAP[1] - 0.1 for b in gait["bouts"]), gait["bouts"]


def test_held_rows_are_left_out_unless_an_imu_carried_them() -> None:
    """measured_rows against its rule: a held row (model 'hold') is left out, unless its fused flag is 1 (a live
    session's camera-only frames log fused 0); a recording with fewer than 10 measured rows is refused in words
    (review: an all-black video failed with 'need at least 10 samples, got 0')."""
    from walkmon.api import measured_rows
    from walkmon.errors import InvalidInputError

    model = ["identity"] + ["rotation"] * 19 + ["hold"] * 10 + ["rotation"] * 10
    keep = measured_rows(model)
    assert keep is not None and keep.tolist() == [True] * 20 + [False] * 10 + [True] * 10
    fused = [1.0] * 25 + [0.0] * 15  # the IMU carried the first five held frames, not the last five
    keep = measured_rows(model, fused)
    assert keep is not None and keep.tolist() == [True] * 25 + [False] * 5 + [True] * 10
    assert measured_rows(["rotation"] * 40) is None and measured_rows(None) is None
    with pytest.raises(InvalidInputError, match="only 5 of 40 frames were measured"):
        measured_rows(["rotation"] * 5 + ["hold"] * 35)
    # a frame carried on through a turn at the last rate (model 'coast') measured nothing either
    keep = measured_rows(["identity"] + ["essential"] * 19 + ["coast", "hold"] + ["essential"] * 10)
    assert keep is not None and keep.tolist() == [True] * 20 + [False] * 2 + [True] * 10


def test_live_monitor_reads_a_lens_cap_as_unknown_not_standing(
    capped: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The same covered lens through ``walkmon live`` (the clip replayed): the held frames measure nothing, so the
    hops inside the cap say the activity is unknown (why in the reasons, and on the wearer's status line), never
    standing, and the walking before and after it is found. Before, every held frame went into the live
    indicators as a real sample: the monitor told a walking person 'standing' from 1.5 s into the cap on."""
    from walkmon.live.session_log import list_sessions, open_database, read_session_table

    data = tmp_path / "data"
    assert main(["live", "--camera", f"file:{capped / 'capped.mp4'}", "--calib", str(capped / "camera.yaml"),
                 "--data-dir", str(data), "--status", "lines"]) == 0
    out = capsys.readouterr().err  # the status goes to stderr
    status = {round(float(ln.split("s ")[0][2:])): ln for ln in out.splitlines()
              if ln.startswith("t=")}
    assert 9 in status, out[-2000:]
    assert "unknown (nothing measured for" in status[9] and "standing" not in status[9], status[9]
    assert " walking " in status[5], status[5]
    (s,) = list_sessions(data)
    conn = open_database(data, create=False)
    hops = read_session_table(conn, s.id, "hops")
    conn.close()
    got = [(float(t), json.loads(j)) for t, j in zip(hops["t_s"], hops["json"], strict=True)]
    inside = [(t, d["activity"], d["classification"]["reasons"]) for t, d in got if CAP[0] + 1.5 <= t <= CAP[1]]
    assert inside and all(a == "unknown" for _, a, _ in inside), inside
    assert all(any("nothing measured" in r for r in why) for _, _, why in inside), inside  # and why
    assert not [t for t, d in got if CAP[0] <= t <= CAP[1] + 0.5 and d["activity"] == "standing"]
    assert any(d["activity"] == "walking" for t, d in got if t < CAP[0])
    assert any(d["activity"] == "walking" for t, d in got if t > CAP[1] + 2.0)
