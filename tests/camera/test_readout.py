"""The camera's rolling-shutter readout (``readout_s``): camera YAML, Gyroflow lens profiles, validation, the CLI."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest
import yaml

from walkmon.camera.lens_profile import read_lens_profile
from walkmon.camera.model import default_camera, read_camera_yaml, write_camera_yaml
from walkmon.errors import ConfigError

PROFILE = {
    "camera_brand": "DJI", "camera_model": "Osmo Action 4", "camera_setting": "Wide",
    "calib_dimension": {"w": 3840, "h": 2160},
    "frame_readout_time": 21.817,
    "fisheye_params": {"camera_matrix": [[1800.0, 0.0, 1919.5], [0.0, 1800.0, 1079.5], [0.0, 0.0, 1.0]],
                       "distortion_coeffs": [0.03, 0.01, -0.004, 0.001]},
}


def test_readout_round_trips_through_the_camera_yaml(tmp_path: Path) -> None:
    cam = dataclasses.replace(default_camera(640, 480), readout_s=0.03)
    write_camera_yaml(cam, tmp_path / "camera.yaml")
    raw = yaml.safe_load((tmp_path / "camera.yaml").read_text(encoding="utf-8"))
    assert raw["readout_s"] == 0.03
    back = read_camera_yaml(tmp_path / "camera.yaml")
    assert back.readout_s == 0.03 and back.scaled_to(320, 240).readout_s == 0.03  # a time: no scaling
    # a global-shutter camera's file stays a plain ROS camera_info
    write_camera_yaml(default_camera(640, 480), tmp_path / "global.yaml")
    assert "readout_s" not in yaml.safe_load((tmp_path / "global.yaml").read_text(encoding="utf-8"))
    assert read_camera_yaml(tmp_path / "global.yaml").readout_s == 0.0


@pytest.mark.parametrize("bad", [-0.001, 0.5, ".nan", "fast", "true", "[0.01]"])
def test_an_impossible_readout_is_a_one_line_config_error(tmp_path: Path, bad: str) -> None:
    text = yaml.safe_dump(default_camera(640, 480).to_dict(), sort_keys=False) + f"readout_s: {bad}\n"
    (tmp_path / "camera.yaml").write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError, match="readout_s") as err:
        read_camera_yaml(tmp_path / "camera.yaml")
    assert "\n" not in str(err.value)


def test_lens_profile_readout_time_becomes_the_camera_readout(tmp_path: Path) -> None:
    p = tmp_path / "profile.json"
    p.write_text(json.dumps(PROFILE), encoding="utf-8")
    assert read_lens_profile(p).readout_s == pytest.approx(0.021817)
    p.write_text(json.dumps({**PROFILE, "frame_readout_time": None}), encoding="utf-8")
    assert read_lens_profile(p).readout_s == 0.0
    p.write_text(json.dumps({**PROFILE, "frame_readout_direction": "BottomToTop"}), encoding="utf-8")
    with pytest.raises(ConfigError, match="frame_readout_direction"):
        read_lens_profile(p)
    p.write_text(json.dumps({**PROFILE, "frame_readout_time": "fast"}), encoding="utf-8")
    with pytest.raises(ConfigError, match="frame_readout_time"):
        read_lens_profile(p)


def test_analyze_refuses_an_impossible_readout_with_exit_2(tmp_path: Path, capsys) -> None:
    import cv2  # noqa: PLC0415
    import numpy as np  # noqa: PLC0415

    from walkmon.commands.cli import main  # noqa: PLC0415

    video = tmp_path / "clip.mp4"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"mp4v"), 30.0, (160, 120))
    rng = np.random.default_rng(0)
    for _ in range(5):
        writer.write(rng.integers(0, 255, (120, 160, 3), dtype=np.uint8))
    writer.release()
    rc = main(["analyze", str(video), "--readout-ms", "500", "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert rc == 2 and "readout" in err and "Traceback" not in err
