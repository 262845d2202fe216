"""A phone's portrait video: the file says to show its frames turned 90 deg, OpenCV turns them, and a calibration
made of the unturned (landscape) sensor is turned to fit; a calibration of another image shape is refused instead
of stretched (which gave silently wrong angles)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from walkmon.camera.model import CameraModel, camera_for_frames, read_camera_yaml, turned_axes
from walkmon.commands.cli import main
from walkmon.consts import angles_deg_from_rotation, rotation_from_angles_deg
from walkmon.errors import InvalidInputError

#: camera axes after one clockwise quarter turn of the image, in the unturned camera's: x = y', y = -x'
TURN = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


def _turn_pixels(uv: np.ndarray, height: int) -> np.ndarray:
    """Pixels of a ``W x H`` image after cv2.rotate(ROTATE_90_CLOCKWISE): (u, v) -> (H - 1 - v, u)."""
    return np.column_stack([height - 1 - uv[:, 1], uv[:, 0]])


@pytest.mark.parametrize(("model", "coeffs"), [("plumb_bob", [-0.21, 0.06, 0.004, -0.003, -0.01]),
                                               ("equidistant", [0.05, -0.02, 0.01, -0.004])])
def test_a_turned_calibration_projects_where_the_turned_image_shows(model: str, coeffs: list[float]) -> None:
    """Against OpenCV's own projection and image rotation: every 3-D point projects, through the turned model in
    the turned camera's axes, to where cv2.rotate moves its pixel in the unturned image; four turns are none."""
    K = np.array([[610.0, 0.0, 331.7], [0.0, 604.0, 229.2], [0.0, 0.0, 1.0]])
    cam = CameraModel(640, 480, K, model, np.array(coeffs))
    rng = np.random.default_rng(1)
    P = np.column_stack([rng.uniform(-1.5, 1.5, 200), rng.uniform(-1.0, 1.0, 200), rng.uniform(2.0, 6.0, 200)])
    uv = cam.pixels_from_camera_points(P)
    img = np.zeros((480, 640), np.uint8)
    img[100, 200] = 255  # the pixel mapping is cv2.rotate's
    assert tuple(np.argwhere(cv2.rotate(img, cv2.ROTATE_90_CLOCKWISE) == 255)[0][::-1]) == tuple(
        _turn_pixels(np.array([[200, 100]]), 480)[0])
    turned = cam.rotated(1)
    assert (turned.width_px, turned.height_px) == (480, 640)
    got = turned.pixels_from_camera_points(P @ TURN)  # the turned camera's coordinates: p' = TURN^T p
    assert np.allclose(got, _turn_pixels(uv, 480), atol=1e-6)
    twice = cam.rotated(2)
    got2 = twice.pixels_from_camera_points(P @ TURN @ TURN)
    assert np.allclose(got2, _turn_pixels(_turn_pixels(uv, 480), 640), atol=1e-6)
    thrice = cam.rotated(3)
    got3 = thrice.pixels_from_camera_points(P @ TURN @ TURN @ TURN)
    assert np.allclose(got3, _turn_pixels(_turn_pixels(_turn_pixels(uv, 480), 640), 480), atol=1e-6)
    assert np.allclose(turned_axes(1), TURN.T) and np.allclose(turned_axes(3), TURN)
    back = cam.rotated(4)
    assert np.allclose(back.camera_matrix, cam.camera_matrix) and np.allclose(back.distortion_coefficients, coeffs)


def test_another_image_shape_is_refused_not_stretched() -> None:
    cam = CameraModel(1920, 1080, np.array([[1400.0, 0, 959.5], [0, 1400.0, 539.5], [0, 0, 1]]))
    assert camera_for_frames(cam, 960, 540).fx == pytest.approx(700.0)  # the same shape: scaled
    assert camera_for_frames(cam, 1920, 1088).height_px == 1088  # codec padding: the same shape
    with pytest.raises(InvalidInputError, match="calibration is for 1920x1080 images but the frames are 640x480"):
        camera_for_frames(cam, 640, 480)
    with pytest.raises(InvalidInputError, match="another shape"):
        camera_for_frames(cam, 1080, 1920)  # portrait frames, but the file said no turn
    turned = camera_for_frames(cam, 1080, 1920, rotation_deg=90.0)
    assert (turned.fx, turned.cx, turned.cy) == (1400.0, 1080 - 1 - 539.5, 959.5)
    back = camera_for_frames(cam, 540, 960, rotation_deg=270.0)  # 3 turns: (u, v) -> (v, W - 1 - u)
    assert (back.width_px, back.fx, back.cx, back.cy) == (540, 700.0, 539.5 / 2, (1919 - 959.5) / 2)
    rolling = CameraModel(1920, 1080, cam.camera_matrix, readout_s=0.02)
    for frames, degrees in (((1080, 1920), 90.0), ((1920, 1080), 180.0), ((1080, 1920), 270.0)):
        with pytest.raises(InvalidInputError, match="readout runs (across|up) its frames.*--readout-ms 0, or a "
                                                    "calibration without readout_s"):
            camera_for_frames(rolling, *frames, degrees)  # the correction models top-to-bottom rows only
    assert camera_for_frames(rolling, 960, 540).readout_s == 0.02


@pytest.fixture(scope="module")
def portrait(tmp_path_factory: pytest.TempPathFactory, set_display_rotation, simulated_videos) -> Path:  # noqa: ANN001
    d = simulated_videos.render(tmp_path_factory.mktemp("portrait"), "normal:6", 320, 240, seed=2)
    (d / "portrait.mp4").write_bytes((d / "video.mp4").read_bytes())
    set_display_rotation(d / "portrait.mp4", 90)
    return d


@pytest.mark.parametrize("calibrated", [True, False])
def test_a_portrait_video_with_its_sensors_calibration_gives_the_turned_cameras_true_angles(
    portrait: Path, tmp_path: Path, calibrated: bool
) -> None:
    """The simulated walk's video marked as shown turned 90 deg: OpenCV gives 240x320 frames turned clockwise, and
    the 320x240 calibration is turned to fit them (it was stretched: fx x 0.75, fy x 1.33). The angles are the
    turned camera's (pitch about its x axis, the unturned camera's -y): the truth turned with it, within what
    the estimator reaches on the unturned video. Without a calibration, the default's 70 deg lie across the frames'
    longer side, the sensor's width (the simulated camera's 70 deg; across the 240 columns, every angle read
    1.33x too large)."""
    from walkmon.drivers.video_file import VideoFile

    with VideoFile(portrait / "portrait.mp4") as video:
        assert (video.width_px, video.height_px, video.rotation_deg) == (240, 320, 90.0)
    out = tmp_path / "out"
    calib = ["--calib", str(portrait / "camera.yaml")] if calibrated else []
    assert main(["analyze", str(portrait / "portrait.mp4"), *calib, "--out", str(out), "--no-progress"]) == 0
    est = np.loadtxt(out / "angles.csv", delimiter=",", skiprows=1, usecols=(1, 2, 3))
    truth = np.loadtxt(portrait / "truth.csv", delimiter=",", skiprows=1, usecols=(1, 2, 3))[: len(est)]
    R = rotation_from_angles_deg(truth[:, 0], truth[:, 1], truth[:, 2])
    rel = np.einsum("ji,njk->nik", R[0], R)  # start-relative, the unturned camera's axes
    want = angles_deg_from_rotation(np.einsum("ji,njk,kl->nil", TURN, rel, TURN))
    err = np.sqrt(np.mean((est - want) ** 2, axis=0))
    assert np.all(err < 0.3), err
    assert read_camera_yaml(portrait / "camera.yaml").width_px == 320  # the file given is not changed
