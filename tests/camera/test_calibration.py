"""Camera calibration against the simulator: chessboard views rendered with a known K and plumb_bob distortion
must be recovered by ``walkmon calibrate``; the simulator's camera.yaml round-trips; bad YAML is exit 2."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from walkmon.camera.model import read_camera_yaml, write_camera_yaml
from walkmon.commands.cli import main
from walkmon.errors import ConfigError
from walkmon.simulate import simulation_camera
from walkmon.simulate.calibration_views import render_chessboard_views


@pytest.fixture(scope="module")
def true_camera():
    return simulation_camera(640, 480, distortion=True)


@pytest.fixture(scope="module")
def board_folder(tmp_path_factory, true_camera):
    folder = tmp_path_factory.mktemp("chessboard")
    views = render_chessboard_views(true_camera, board=(9, 6), square_m=0.025, n_views=15, seed=3, supersample=2)
    for i, view in enumerate(views):
        cv2.imwrite(str(folder / f"view_{i:02d}.png"), view.image)
    return folder, views


def test_rendered_corners_are_where_the_projection_puts_them(board_folder, true_camera) -> None:
    """The renderer and CameraModel's projection agree: OpenCV finds the corners at the projected positions."""
    from walkmon.camera.chessboard import find_chessboard

    _, views = board_folder
    errors = []
    for view in views:
        corners = find_chessboard(view.image, (9, 6))
        assert corners is not None
        errors.append(np.linalg.norm(corners.reshape(-1, 2) - view.corners_px, axis=1))
    errors = np.concatenate(errors)
    # sub-pixel agreement; a few corners of steeply tilted boards are pulled by cornerSubPix's window
    assert np.median(errors) < 0.15
    assert np.percentile(errors, 95) < 0.5


def test_calibrate_recovers_known_intrinsics(board_folder, true_camera, tmp_path, capsys) -> None:
    folder, _ = board_folder
    out = tmp_path / "cam.yaml"
    rc = main(["calibrate", str(folder), "--board", "9x6", "--square-mm", "25", "--out", str(out)])
    assert rc == 0
    assert "reprojection error" in capsys.readouterr().out
    cam = read_camera_yaml(out)
    for got, want in ((cam.fx, true_camera.fx), (cam.fy, true_camera.fy)):
        assert abs(got - want) / want < 0.01
    assert abs(cam.cx - true_camera.cx) < 0.01 * true_camera.width_px
    assert abs(cam.cy - true_camera.cy) < 0.01 * true_camera.height_px
    k1_true = true_camera.distortion_coefficients[0]
    assert abs(cam.distortion_coefficients[0] - k1_true) < 0.03
    # the fitted lens maps rays to the same pixels as the true one over the image (k2/k3 trade off, the map must not)
    rng = np.random.default_rng(0)
    pts = rng.uniform([20, 20], [620, 460], (200, 2))
    rays_true = np.column_stack([true_camera.normalized_from_pixels(pts), np.ones(len(pts))])
    err = np.linalg.norm(cam.pixels_from_camera_points(rays_true) - pts, axis=1)
    assert np.median(err) < 1.0
    assert err.max() < 2.5  # the far corners, which no board covered, are extrapolated


def test_calibration_with_wrong_board_size_is_a_clear_error(board_folder, tmp_path, capsys) -> None:
    folder, _ = board_folder
    rc = main(["calibrate", str(folder), "--board", "7x5", "--out", str(tmp_path / "cam.yaml")])
    assert rc == 2
    err = capsys.readouterr().err
    assert "error" in err
    assert "Traceback" not in err


def test_images_of_different_sizes_are_refused_not_mixed(board_folder, tmp_path, capsys) -> None:
    """User review: one 320x240 image among 640x480 ones gave exit 0 and a file saying 320x240 with a 640-wide
    camera's intrinsics (fx 440 for 457), which 'analyze' then scaled: 4 deg errors on frames reported ok."""
    import shutil

    folder, _ = board_folder
    mixed = tmp_path / "mixed"
    shutil.copytree(folder, mixed)
    small = cv2.resize(cv2.imread(str(mixed / "view_00.png")), (320, 240))
    cv2.imwrite(str(mixed / "zz_small.png"), small)
    rc = main(["calibrate", str(mixed), "--board", "9x6", "--out", str(tmp_path / "cam.yaml"), "--no-progress"])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1
    assert "different sizes" in err and "640x480 (15)" in err and "320x240 (1)" in err
    assert not (tmp_path / "cam.yaml").exists()


def test_simulator_camera_yaml_round_trip(tmp_path, true_camera) -> None:
    path = tmp_path / "camera.yaml"
    write_camera_yaml(true_camera, path)
    back = read_camera_yaml(path)
    np.testing.assert_allclose(back.camera_matrix, true_camera.camera_matrix)
    np.testing.assert_allclose(back.distortion_coefficients, true_camera.distortion_coefficients)
    assert (back.width_px, back.height_px, back.distortion_model) == (640, 480, "plumb_bob")


@pytest.mark.parametrize(
    "text",
    [
        "image_width: [640\n",  # not YAML
        "image_width: 640\nimage_height: 480\n",  # missing keys
        "image_width: 640\nimage_height: 480\ncamera_matrix: {data: [1, 2, 3]}\n"
        "distortion_model: plumb_bob\ndistortion_coefficients: {data: [0, 0, 0, 0, 0]}\n",  # wrong K size
    ],
)
def test_malformed_camera_yaml_exit_2(tmp_path, capsys, text) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError):
        read_camera_yaml(bad)
    video = tmp_path / "v.mp4"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"mp4v"), 30.0, (64, 48))
    for _ in range(3):
        writer.write(np.zeros((48, 64, 3), np.uint8))
    writer.release()
    rc = main(["analyze", str(video), "--calib", str(bad), "--out", str(tmp_path / "out")])
    assert rc == 2
    err = capsys.readouterr().err
    assert str(bad) in err or "bad.yaml" in err
    assert "Traceback" not in err
