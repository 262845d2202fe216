"""Gyroflow lens profiles (the published profile database's JSON format) as walkmon cameras."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from walkmon.camera.lens_profile import read_camera_file, read_lens_profile
from walkmon.camera.model import read_camera_yaml
from walkmon.commands.cli import main
from walkmon.errors import ConfigError

# Written by hand in Gyroflow's lens profile format (values of the order of a GoPro Wide 4K profile).
PROFILE = {
    "name": "GoPro_HERO9 Black_Wide_4k_16by9",
    "camera_brand": "GoPro",
    "camera_model": "HERO9 Black",
    "lens_model": "",
    "camera_setting": "Wide",
    "calib_dimension": {"w": 3840, "h": 2160},
    "orig_dimension": {"w": 3840, "h": 2160},
    "output_dimension": {"w": 3840, "h": 2160},
    "frame_readout_time": 8.9,
    "input_horizontal_stretch": 1.0,
    "input_vertical_stretch": 1.0,
    "fisheye_params": {
        "RMS_error": 0.61,
        "camera_matrix": [[1790.0, 0.0, 1919.5], [0.0, 1788.0, 1079.5], [0.0, 0.0, 1.0]],
        "distortion_coeffs": [0.046, 0.021, -0.006, 0.0012],
    },
    "calibrator_version": "1.5.4",
}


def _write(tmp_path: Path, profile: dict, name: str = "profile.json") -> Path:
    p = tmp_path / name
    p.write_text(json.dumps(profile), encoding="utf-8")
    return p


def test_fisheye_profile_projects_as_the_equidistant_formula(tmp_path: Path) -> None:
    cam = read_lens_profile(_write(tmp_path, PROFILE))
    assert cam.distortion_model == "equidistant" and (cam.width_px, cam.height_px) == (3840, 2160)
    assert cam.name == "GoPro HERO9 Black Wide"
    # independent: r_d = theta (1 + k1 t^2 + k2 t^4 + k3 t^6 + k4 t^8), pixel = f * r_d * (x, y) / r + c
    k1, k2, k3, k4 = PROFILE["fisheye_params"]["distortion_coeffs"]
    pts = np.array([[0.3, -0.2, 1.0], [1.5, 0.8, 1.0], [-2.0, 1.0, 1.0]])
    got = cam.pixels_from_camera_points(pts)
    for (x, y, z), (u, v) in zip(pts, got, strict=True):
        r = math.hypot(x, y) / z
        t = math.atan(r)
        rd = t * (1 + k1 * t**2 + k2 * t**4 + k3 * t**6 + k4 * t**8)
        assert u == pytest.approx(1790.0 * rd * x / (z * r) + 1919.5, abs=1e-6)
        assert v == pytest.approx(1788.0 * rd * y / (z * r) + 1079.5, abs=1e-6)
    # a 1920x1080 video of the same lens mode: intrinsics halve
    half = cam.scaled_to(1920, 1080)
    assert half.fx == pytest.approx(895.0) and half.distortion_model == "equidistant"


def test_standard_profile_and_refusals(tmp_path: Path) -> None:
    std = dict(PROFILE, distortion_model="opencv_standard",
               fisheye_params={"camera_matrix": PROFILE["fisheye_params"]["camera_matrix"],
                               "distortion_coeffs": [-0.2, 0.05, 0.001, 0.0, 0.01, 0.0, 0.0, 0.0, 0.0]})
    cam = read_lens_profile(_write(tmp_path, std))
    assert cam.distortion_model == "plumb_bob"
    assert np.allclose(cam.distortion_coefficients, [-0.2, 0.05, 0.001, 0.0, 0.01, 0.0, 0.0, 0.0])
    with pytest.raises(ConfigError, match="not supported"):
        read_lens_profile(_write(tmp_path, dict(PROFILE, distortion_model="gopro_superview")))
    with pytest.raises(ConfigError, match="stretch"):
        read_lens_profile(_write(tmp_path, dict(PROFILE, input_horizontal_stretch=1.33)))
    with pytest.raises(ConfigError, match="calib_dimension"):
        read_lens_profile(_write(tmp_path, {k: v for k, v in PROFILE.items() if k != "calib_dimension"}))
    bad = tmp_path / "bad.json"
    bad.write_text("{not json", encoding="utf-8")
    with pytest.raises(ConfigError, match="not valid JSON"):
        read_lens_profile(bad)


def test_calibrate_converts_a_profile_to_camera_info_yaml(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    src = _write(tmp_path, PROFILE)
    out = tmp_path / "gopro.yaml"
    assert main(["calibrate", str(src), "--out", str(out)]) == 0
    assert "equidistant" in capsys.readouterr().out
    back = read_camera_yaml(out)
    direct = read_camera_file(src)
    assert np.allclose(back.camera_matrix, direct.camera_matrix)
    assert np.allclose(back.distortion_coefficients, direct.distortion_coefficients)
    assert back.distortion_model == "equidistant"
    assert main(["calibrate", str(tmp_path / "missing.json"), "--out", str(out)]) == 2
    assert "cannot read lens profile" in capsys.readouterr().err


def test_profiles_walkmon_cannot_read_right_are_refused_and_harmless_forms_read(tmp_path: Path) -> None:
    """User review: a digital lens (GoPro SuperView: a non-radial stretch after the fisheye) and a zoom lens's
    interpolated intrinsics were silently taken as the plain fisheye; a null coefficient got a contradictory
    message; a profile saved with a BOM was refused; calib_dimension 1920.7 was cut to 1920."""
    with pytest.raises(ConfigError, match="digital lens 'gopro_superview'"):
        read_lens_profile(_write(tmp_path, dict(PROFILE, digital_lens="gopro_superview")))
    with pytest.raises(ConfigError, match="zoom lens"):
        read_lens_profile(_write(tmp_path, dict(PROFILE, interpolations={"24": {}, "35": {}})))
    null = dict(PROFILE, fisheye_params=dict(PROFILE["fisheye_params"], distortion_coeffs=[0.046, None, 0, 0]))
    with pytest.raises(ConfigError, match="distortion_coeffs must hold numbers only"):
        read_lens_profile(_write(tmp_path, null))
    with pytest.raises(ConfigError, match="whole number of pixels"):
        read_lens_profile(_write(tmp_path, dict(PROFILE, calib_dimension={"w": 1920.7, "h": 1080})))
    assert read_lens_profile(_write(tmp_path, dict(PROFILE, digital_lens=None))).width_px == 3840
    bom = tmp_path / "bom.json"
    bom.write_bytes(b"\xef\xbb\xbf" + json.dumps(PROFILE).encode())
    assert read_lens_profile(bom).fx == pytest.approx(1790.0)


@pytest.mark.parametrize("option", [["--model", "plumb_bob"], ["--board", "7x5"], ["--every", "3"]])
def test_calibrate_refuses_chessboard_options_with_a_profile(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                             option: list[str]) -> None:
    """They were silently ignored: '--model plumb_bob' wrote the profile's equidistant camera."""
    out = tmp_path / "cam.yaml"
    assert main(["calibrate", str(_write(tmp_path, PROFILE)), "--out", str(out), *option]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and option[0] in err and not out.exists()
