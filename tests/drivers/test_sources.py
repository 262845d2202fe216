"""Source URLs: parsing and clear errors, file and sim cameras, file IMU, and no hardware probing on import."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from walkmon.drivers.sources import open_camera, open_imu
from walkmon.errors import ConfigError, SourceDisconnected, SourceError


@pytest.mark.parametrize(
    ("url", "match"),
    [
        ("webcam:0", "unknown scheme 'webcam'"),
        ("no-scheme", "expected SCHEME:TARGET"),
        ("v4l2:/dev/video0?zoom=2", "unknown option 'zoom' for v4l2"),
        ("v4l2:/dev/video0?width=-5", "bad value '-5' for option 'width'"),
        ("v4l2:", "needs a device"),
        ("file:walk.mp4?realtime=perhaps", "bad value 'perhaps'"),
        ("file:", "needs a path"),
        ("sim:", "needs a walk"),
        ("sim:normal:10,,bend?seed=1", "bad walk script part"),
        ("depthai:?fps=0", "bad value '0' for option 'fps'"),
    ],
)
def test_bad_camera_urls_are_config_errors(url: str, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        open_camera(url)


def test_imu_urls() -> None:
    with pytest.raises(ConfigError, match="unknown scheme"):
        open_imu("usb:/dev/ttyACM0")
    with pytest.raises(ConfigError, match="unknown option"):
        open_imu("file:imu.csv?baud=9600")
    src = open_imu("serial:/dev/walkmon-no-such-port?baud=115200")  # constructed, nothing opened yet
    with pytest.raises(SourceError, match="cannot open"):
        src.open()


def test_import_probes_no_hardware() -> None:
    code = ("import sys, walkmon, walkmon.drivers.sources, walkmon.live.pipeline, walkmon.commands.live; "
            "open_ = walkmon.drivers.sources.open_camera('depthai:'); "
            "print(sorted(m for m in ('depthai', 'serial') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=60)
    assert out.stdout.strip() == "[]"


def test_depthai_without_the_package_fails_fast_with_the_install_hint() -> None:
    pytest.importorskip  # noqa: B018 - documents that this test wants depthai *absent*
    try:
        import depthai  # noqa: F401
    except ImportError:
        pass
    else:
        pytest.skip("depthai is installed here; a missing device is tested on the hardware")
    with pytest.raises(SourceError, match=r"pip install 'walkmon\[depthai\]'"):
        open_camera("depthai:?timeout_s=1").open()


def test_v4l2_missing_device_is_a_source_error() -> None:
    """Said by walkmon before OpenCV is asked, which printed a warning line of its own first (user review)."""
    src = open_camera("v4l2:/dev/walkmon-no-such-camera?width=320&height=240")
    assert src.reconnectable
    with pytest.raises(SourceError, match="no such device /dev/walkmon-no-such-camera"):
        src.open()


@pytest.fixture(scope="module")
def tiny_video(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("video") / "tiny.avi"
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 25.0, (64, 48))
    for i in range(10):
        w.write(np.full((48, 64, 3), i * 20, np.uint8))
    w.release()
    return path


def test_file_camera_timestamps_end_and_loop(tiny_video: Path) -> None:
    with open_camera(f"file:{tiny_video}") as cam:
        assert not cam.live and cam.fps == pytest.approx(25.0)
        frames = [cam.read() for _ in range(10)]
        with pytest.raises(SourceDisconnected, match="end of stream"):
            cam.read()
    assert [f.t_s for f in frames] == pytest.approx([i / 25.0 for i in range(10)])
    assert [f.index for f in frames] == list(range(10))
    with open_camera(f"file:{tiny_video}?loop=1") as cam:
        t = [cam.read().t_s for _ in range(25)]
    assert t == pytest.approx([i / 25.0 for i in range(25)])  # time runs on across the loops
    assert open_camera(f"file:{tiny_video}?realtime=1").live


def test_file_camera_missing_file(tmp_path: Path) -> None:
    with pytest.raises(SourceError, match="no such video file"):
        open_camera(f"file:{tmp_path / 'nope.mp4'}").open()


def test_sim_camera_gives_truth_and_its_own_intrinsics() -> None:
    with open_camera("sim:normal:1?width=160&height=120&realtime=0&seed=3") as cam:
        f0, f1 = cam.read(), cam.read()
        assert cam.camera_model() is not None and cam.camera_model().width_px == 160
    assert f0.image.shape == (120, 160, 3) and f1.t_s == pytest.approx(1 / 30)
    assert f0.truth_angles_deg == pytest.approx((0.0, 0.0, 0.0), abs=1e-9)
    with pytest.raises(ConfigError, match="unknown walk type"):
        open_camera("sim:moonwalk:3?realtime=0")


def test_sim_camera_takes_a_tilted_mount_and_its_seconds_leave_the_mount_out() -> None:
    from walkmon.drivers.sim_camera import script_seconds

    assert script_seconds("mount:-15:2,normal:3,turn:90,normal:2") == 5.0  # the -15 and 2 are degrees
    with open_camera("sim:mount:-15:2,normal:1?width=160&height=120&realtime=0") as cam:
        first = cam.read()
    assert first.truth_angles_deg == pytest.approx((-15.0, 0.0, 2.0), abs=1e-9)  # standing upright, camera tilted
    with pytest.raises(ConfigError, match="mount"):
        open_camera("sim:mount:-60,normal:3?realtime=0")


def test_file_imu_reads_samples_then_ends(tmp_path: Path) -> None:
    p = tmp_path / "imu.csv"
    p.write_text("t,gx,gy,gz,ax,ay,az\n0.0,0.1,0.2,0.3,0,-9.81,0\n0.005,0.1,0.2,0.3,0,-9.81,0.1\n")
    imu = open_imu(f"file:{p}")
    imu.open()
    (a,), (b,) = imu.read().samples, imu.read().samples  # an ImuBatch of one sample per read
    with pytest.raises(SourceDisconnected):
        imu.read()
    imu.close()
    assert a.gyroscope_rad_s == (0.1, 0.2, 0.3) and b.accelerometer_m_s2 == (0.0, -9.81, 0.1) and b.t_s == 0.005
    with pytest.raises(SourceError, match="imu.csv"):
        open_imu(f"file:{tmp_path / 'missing' / 'imu.csv'}").open()


@pytest.mark.hardware
@pytest.mark.parametrize("url", ["v4l2:/dev/video0?width=640&height=480&fps=30", "depthai:?width=640&height=480"])
def test_real_camera_delivers_timestamped_frames(url: str) -> None:
    """On the device (pytest -m hardware): 60 frames, increasing capture timestamps, about the asked rate."""
    with open_camera(url) as cam:
        frames = [cam.read() for _ in range(60)]
    t = np.array([f.t_s for f in frames])
    assert np.all(np.diff(t) > 0)
    assert frames[0].image.shape[:2] == (480, 640)
    assert 20.0 < 59 / (t[-1] - t[0]) < 40.0
