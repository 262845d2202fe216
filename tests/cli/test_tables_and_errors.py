"""Calibration files, CSV tables and the CLI's error paths."""

from __future__ import annotations

import numpy as np
import pytest

from walkmon.camera.model import (
    CameraModel,
    default_camera,
    read_camera_yaml,
    write_camera_yaml,
)
from walkmon.commands.cli import main
from walkmon.errors import ConfigError, InvalidInputError
from walkmon.tables import read_table, write_table


def test_default_camera_from_hfov() -> None:
    cam = default_camera(640, 480, hfov_deg=90.0)
    assert cam.fx == pytest.approx(320.0)
    assert cam.hfov_deg == pytest.approx(90.0)
    assert not cam.has_distortion


@pytest.mark.parametrize(
    ("model", "coeffs"), [("plumb_bob", [-0.2, 0.05, 0.001, -0.002, 0.01]), ("equidistant", [0.1, -0.02, 0.0, 0.001])]
)
def test_camera_yaml_round_trip(tmp_path, model, coeffs) -> None:
    K = np.array([[501.5, 0, 322.25], [0, 499.0, 241.0], [0, 0, 1]])
    cam = CameraModel(640, 480, K, model, np.array(coeffs), "test_cam")
    write_camera_yaml(cam, tmp_path / "c.yaml")
    back = read_camera_yaml(tmp_path / "c.yaml")
    np.testing.assert_allclose(back.camera_matrix, K)
    np.testing.assert_allclose(back.distortion_coefficients, coeffs)
    assert (back.width_px, back.height_px, back.distortion_model, back.name) == (640, 480, model, "test_cam")


def test_undistort_inverts_projection() -> None:
    K = np.array([[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]])
    cam = CameraModel(640, 480, K, "plumb_bob", np.array([-0.25, 0.08, 0, 0, 0]))
    rng = np.random.default_rng(0)
    P = np.column_stack([rng.uniform(-0.4, 0.4, 50), rng.uniform(-0.3, 0.3, 50), np.ones(50)])
    px = cam.pixels_from_camera_points(P)
    np.testing.assert_allclose(cam.normalized_from_pixels(px), P[:, :2], atol=1e-6)


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("image_width: 640\nimage_height: [", "not valid YAML"),
        ("- just\n- a list\n", "expected a ROS camera_info mapping"),
        ("image_width: 640\nimage_height: 480\n", "missing key 'camera_matrix'"),
        ("image_width: 640\nimage_height: 480\ncamera_matrix: {data: [1, 2, 3]}\n", "needs 9 values"),
        (
            "image_width: 640\nimage_height: 480\ncamera_matrix: {data: [0, 0, 320, 0, 500, 240, 0, 0, 1]}\n",
            "fx > 0",
        ),
        (
            "image_width: 640\nimage_height: 480\ncamera_matrix: {data: [500, 0, 320, 0, 500, 240, 0, 0, 1]}\n"
            "distortion_model: rational_polynomial\n",
            "distortion_model must be one of",
        ),
    ],
)
def test_malformed_calibration_is_one_clear_error(tmp_path, text, fragment) -> None:
    p = tmp_path / "bad.yaml"
    p.write_text(text)
    with pytest.raises(ConfigError, match=fragment):
        read_camera_yaml(p)


def test_missing_calibration_file(tmp_path) -> None:
    with pytest.raises(ConfigError, match="cannot read calibration file"):
        read_camera_yaml(tmp_path / "nope.yaml")


def test_table_round_trip(tmp_path) -> None:
    t = np.arange(5) / 30.0
    write_table(tmp_path / "a.csv", {"t": t, "pitch": t * 2, "yaw": -t, "roll": t, "model": ["E"] * 5})
    got = read_table(tmp_path / "a.csv", ("t", "pitch", "yaw", "roll"))
    np.testing.assert_allclose(got["pitch"], t * 2, atol=1e-6)
    assert "model" not in got  # non-numeric extra columns are skipped


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("", "empty file"),
        ("t,pitch,yaw\n0,1,2\n", "missing column"),
        ("t,pitch,yaw,roll\n", "no data rows"),
        ("t,pitch,yaw,roll\n0,1,2,x\n", "line 2, column roll: 'x' is not a number"),
        ("t,pitch,yaw,roll\n0,1,2\n", "line 2 has 3 values"),
        ("t,pitch,yaw,roll\n1,0,0,0\n0,0,0,0\n", "column t decreases at line 3"),
        ("t,pitch,yaw,roll\n0,nan,0,0\n", "not a finite number"),
    ],
)
def test_malformed_tables(tmp_path, text, fragment) -> None:
    p = tmp_path / "bad.csv"
    p.write_text(text)
    with pytest.raises(InvalidInputError, match=fragment):
        read_table(p, ("t", "pitch", "yaw", "roll"))


def test_binary_file_is_not_a_table(tmp_path) -> None:
    p = tmp_path / "bin.csv"
    p.write_bytes(b"\xff\xfe\x00\x81" * 100)
    with pytest.raises(InvalidInputError, match="cannot read as CSV"):
        read_table(p, ("t",))


def test_cli_usage_errors_exit_2(capsys) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["no-such-command"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "invalid choice" in err


def test_cli_calibrate_missing_source_exit_2(tmp_path, capsys) -> None:
    assert main(["calibrate", str(tmp_path / "missing.mp4"), "--out", str(tmp_path / "c.yaml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no such file" in err
    assert "Traceback" not in err


def test_cli_calibrate_corrupt_video_exit_2(tmp_path, capsys) -> None:
    bad = tmp_path / "corrupt.mp4"
    bad.write_bytes(b"\x00\x00\x00\x18ftypmp42" + bytes(range(256)) * 20)
    assert main(["calibrate", str(bad), "--out", str(tmp_path / "c.yaml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(bad) in err


def test_cli_calibrate_folder_without_board_exit_2(tmp_path, capsys) -> None:
    import cv2

    for i in range(5):
        cv2.imwrite(str(tmp_path / f"{i}.png"), np.full((120, 160), 128, np.uint8))
    assert main(["calibrate", str(tmp_path), "--out", str(tmp_path / "c.yaml")]) == 2
    assert "chessboard was found in 0 of 5 images" in capsys.readouterr().err


def test_chessboard_corners_land_on_the_true_corners() -> None:
    """Detected, sub-pixel refined corners sit where the simulator's projection puts the true corners."""
    from walkmon.camera.chessboard import find_chessboard
    from walkmon.simulate.calibration_views import render_chessboard_views

    cam = default_camera(320, 240)
    errors = []
    for view in render_chessboard_views(cam, (9, 6), n_views=4, seed=3, supersample=2):
        corners = find_chessboard(view.image, (9, 6))
        assert corners is not None
        errors.append(np.linalg.norm(corners.reshape(-1, 2) - view.corners_px.reshape(-1, 2), axis=1))
    err = np.concatenate(errors)
    assert np.median(err) < 0.15
    assert err.max() < 0.6


def test_drivers_import_as_walkmon_drivers_from_a_checkout_and_never_as_drivers() -> None:
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    code = (
        "import importlib.util, walkmon, walkmon.drivers.sources; "
        "print(walkmon.drivers.__name__, walkmon.drivers.sources.__name__)"
    )
    # From the repository root, `python -c` puts the checkout first on sys.path: drivers/ must still be
    # walkmon.drivers there, as it is once installed.
    out = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True, text=True, timeout=60, check=True)
    assert out.stdout.split() == ["walkmon.drivers", "walkmon.drivers.sources"]
    # Away from the checkout nothing named plain `drivers` is importable (the installer maps it under walkmon).
    # (PYTHONPATH is dropped: a developer's PYTHONPATH=<checkout> puts the checkout root, drivers/ and all, on the
    # path by hand.)
    import os

    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    code = "import importlib.util; print(importlib.util.find_spec('drivers') is None)"
    out = subprocess.run([sys.executable, "-c", code], cwd="/", capture_output=True, text=True, timeout=60, check=True,
                         env=env)
    assert out.stdout.strip() == "True"
