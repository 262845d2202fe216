"""The OAK's on-board IMU through the depthai v3 API, tested with a fake ``depthai`` module at the outermost
boundary (no OAK here): a fake device plays the simulator's rendered frames and its IMU samples, in real time,
with device timestamps (``getTimestampDevice``) on a clock other than the host-synchronised one
(``getTimestamp``), and IMU axes rotated against the camera's. ``walkmon live --camera depthai:?imu=1`` with the
matching ``[imu] extrinsics`` must then fuse: angles close to the truth, pitch_abs/roll_abs close to the truth's
gravity angles. Also: the packet conversion, the URL options, and ``--imu depthai:`` needing a depthai camera.
"""

from __future__ import annotations

import datetime as dt
import sys
import time
import types
from pathlib import Path

import numpy as np
import pytest

from walkmon.consts import gravity_angles_deg_from_gravity, rotation_from_angles_deg
from walkmon.errors import ConfigError

WALK, SEED, W, H, FPS = "normal:2", 4, 320, 240, 30.0
DEVICE_CLOCK_S = 1000.0  # device clock at the session's t = 0
HOST_CLOCK_S = 5000.0  # host-synchronised clock at t = 0 (must not be used when the IMU is on)
#: the fake OAK's IMU axes: camera_from_imu (IMU x = camera -y, IMU y = camera x, IMU z = camera z)
R_CI = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


class _Vec:
    def __init__(self, xyz: np.ndarray, t_s: float) -> None:
        self.x, self.y, self.z = (float(v) for v in xyz)
        self._t = t_s

    def getTimestampDevice(self) -> dt.timedelta:  # noqa: N802 - depthai's name
        return dt.timedelta(seconds=DEVICE_CLOCK_S + self._t)

    def getTimestamp(self) -> dt.timedelta:  # noqa: N802
        return dt.timedelta(seconds=HOST_CLOCK_S + self._t)


class _Packet:
    def __init__(self, t_s: float, gyro: np.ndarray, accel: np.ndarray) -> None:
        self.gyroscope = _Vec(gyro, t_s)
        self.acceleroMeter = _Vec(accel, t_s)  # noqa: N815 - depthai's name


class _ImuData:
    def __init__(self, packets: list[_Packet]) -> None:
        self.packets = packets


class _ImgFrame:
    class Type:
        BGR888i = "BGR888i"

    def __init__(self, t_s: float, image: np.ndarray) -> None:
        self._t, self._image = t_s, image

    def getCvFrame(self) -> np.ndarray:  # noqa: N802
        return self._image

    def getTimestampDevice(self) -> dt.timedelta:  # noqa: N802
        return dt.timedelta(seconds=DEVICE_CLOCK_S + self._t)

    def getTimestamp(self) -> dt.timedelta:  # noqa: N802
        return dt.timedelta(seconds=HOST_CLOCK_S + self._t)


class _PacedQueue:
    """Messages become available at their time after the pipeline started (a real device's pace)."""

    def __init__(self, items: list[tuple[float, object]], pipeline: _Pipeline) -> None:
        self._items, self._i, self._pipeline = items, 0, pipeline

    def tryGet(self) -> object | None:  # noqa: N802
        if self._i >= len(self._items) or time.monotonic() - self._pipeline.t0 < self._items[self._i][0]:
            return None
        self._i += 1
        return self._items[self._i - 1][1]


class _Output:
    def __init__(self, make_items: object, pipeline: _Pipeline) -> None:
        self._make, self._pipeline = make_items, pipeline

    def createOutputQueue(self, maxSize: int = 4, blocking: bool = False) -> _PacedQueue:  # noqa: N802, N803
        q = _PacedQueue(self._make(), self._pipeline)
        self._pipeline.queues.append(q)
        return q


class _Pipeline:
    def __init__(self, device: object) -> None:
        self.fake = device.fake  # type: ignore[attr-defined]
        self.t0 = 0.0
        self.queues: list[_PacedQueue] = []
        self.imu_config: dict[str, object] = {}
        self.running = False

    def create(self, node_type: type) -> object:
        return node_type(self)

    def start(self) -> None:
        self.t0 = time.monotonic()
        self.running = True

    def isRunning(self) -> bool:  # noqa: N802
        end = self.fake.frames[-1][0] + 0.3
        return self.running and time.monotonic() - self.t0 < end

    def stop(self) -> None:
        self.running = False


class FakeOak:
    """What the fake depthai module plays: frames [(t, image)] and IMU [(t, gyro, accel)] in the IMU's axes."""

    def __init__(self, frames: list[tuple[float, np.ndarray]], imu: list[tuple[float, np.ndarray, np.ndarray]]):
        self.frames, self.imu = frames, imu
        self.opened = 0
        self.pipelines: list[_Pipeline] = []

    def module(self) -> types.ModuleType:
        fake = self
        dai = types.ModuleType("depthai")

        class Device:
            def __init__(self, info: object) -> None:
                self.fake = fake
                fake.opened += 1

            @staticmethod
            def getAnyAvailableDevice(timeout: dt.timedelta) -> tuple[bool, object]:  # noqa: N802
                return (fake.opened == 0, object())  # found once: a reconnection after the end finds nothing

        class Camera:
            def __init__(self, pipeline: _Pipeline) -> None:
                self.pipeline = pipeline

            def build(self) -> Camera:
                return self

            def requestOutput(self, size: tuple[int, int], type: object = None, fps: float = 30.0) -> _Output:  # noqa: A002, N802
                return _Output(lambda: [(t, _ImgFrame(t, img)) for t, img in fake.frames], self.pipeline)

        class IMU:
            def __init__(self, pipeline: _Pipeline) -> None:
                self.pipeline = pipeline
                self.out = _Output(self._items, pipeline)

            def enableIMUSensor(self, sensor: str, rate: int) -> None:  # noqa: N802
                self.pipeline.imu_config[sensor] = rate

            def setBatchReportThreshold(self, n: int) -> None:  # noqa: N802
                self.pipeline.imu_config["batch"] = n

            def setMaxBatchReports(self, n: int) -> None:  # noqa: N802
                self.pipeline.imu_config["max_batch"] = n

            def _items(self) -> list[tuple[float, _ImuData]]:
                n = int(self.pipeline.imu_config["batch"])
                out = []
                for k in range(0, len(fake.imu), n):
                    chunk = fake.imu[k:k + n]
                    out.append((chunk[-1][0], _ImuData([_Packet(t, g, a) for t, g, a in chunk])))
                return out

        def pipeline_factory(device: object) -> _Pipeline:
            p = _Pipeline(device)
            fake.pipelines.append(p)
            return p

        dai.Device = Device
        dai.DeviceInfo = lambda device_id: object()
        dai.Pipeline = pipeline_factory
        dai.node = types.SimpleNamespace(Camera=Camera, IMU=IMU)
        dai.ImgFrame = _ImgFrame
        dai.IMUSensor = types.SimpleNamespace(ACCELEROMETER_RAW="ACCELEROMETER_RAW", GYROSCOPE_RAW="GYROSCOPE_RAW")
        return dai


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    from walkmon.simulate import iter_frames, simulate
    from walkmon.tables import read_table

    out = tmp_path_factory.mktemp("oak")
    simulate(out, WALK, seed=SEED, width=W, height=H, fps=FPS, video=False)
    imu = read_table(out / "imu.csv", ("t", "gx", "gy", "gz", "ax", "ay", "az"))
    gyro = np.column_stack([imu[k] for k in ("gx", "gy", "gz")]) @ R_CI  # camera axes -> IMU axes: R_CI^T v
    accel = np.column_stack([imu[k] for k in ("ax", "ay", "az")]) @ R_CI
    frames, truth = [], []
    for t, img, angles in iter_frames(WALK, 6.0, seed=SEED, width=W, height=H, fps=FPS):
        frames.append((float(t), img))
        truth.append((float(t), *np.asarray(angles, float)))
    return {"frames": frames, "truth": np.array(truth),
            "imu": [(float(t), g, a) for t, g, a in zip(imu["t"], gyro, accel, strict=True)]}


def test_live_on_a_fake_oak_fuses_its_imu_on_the_device_clock(recorded: dict, tmp_path: Path,
                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    from walkmon.commands.cli import main
    from walkmon.live.session_log import open_database, read_session_table

    fake = FakeOak(recorded["frames"], recorded["imu"])
    monkeypatch.setitem(sys.modules, "depthai", fake.module())
    cfg = tmp_path / "walkmon.toml"
    cfg.write_text(f"[imu]\nextrinsics = {[float(v) for v in R_CI.ravel()]}\n"
                   "[pipeline]\nreconnect_initial_s = 0.05\nreconnect_give_up_s = 0.3\n")
    url = f"depthai:?imu=1&width={W}&height={H}&imu_rate_hz=200"
    assert main(["live", "--camera", url, "--config", str(cfg), "--data-dir", str(tmp_path / "db"),
                 "--status", "none"]) == 0
    assert fake.pipelines[0].imu_config == {"ACCELEROMETER_RAW": 200, "GYROSCOPE_RAW": 200, "batch": 2,
                                            "max_batch": 20}
    conn = open_database(tmp_path / "db", create=False)
    try:
        frames = read_session_table(conn, 1, "frames")
        n_imu = len(read_session_table(conn, 1, "imu")["t_s"])
    finally:
        conn.close()
    t = np.array(frames["t_s"]) - DEVICE_CLOCK_S  # device clock, not the host-synchronised one
    assert len(t) > 150 and t.min() >= -1e-6 and t.max() < 6.1
    assert n_imu >= 0.95 * len(recorded["imu"])
    fused = np.array(frames["fused"]) == 1
    assert fused.sum() > 0.7 * len(t)
    tr = recorded["truth"]
    truth = np.column_stack([np.interp(t, tr[:, 0], tr[:, k]) for k in (1, 2, 3)])
    ang = np.column_stack([np.array(frames[k], float) for k in ("pitch", "yaw", "roll")])
    err = np.abs(ang - truth)
    assert err.max() < 0.3, err.max(axis=0)
    R = rotation_from_angles_deg(truth[:, 0], truth[:, 1], truth[:, 2])
    truth_abs = gravity_angles_deg_from_gravity(np.einsum("nji,j->ni", R, [0.0, 1.0, 0.0]))
    got_abs = np.column_stack([np.array(frames["pitch_abs"], float), np.array(frames["roll_abs"], float)])
    assert np.abs(got_abs[fused] - truth_abs[fused]).max() < 0.5  # wrong extrinsics would be ~90 deg off


def test_imu_packets_convert_to_samples_at_the_gyro_device_time() -> None:
    from walkmon.drivers.depthai_camera import samples_from_imu_data

    data = _ImuData([_Packet(0.5, np.array([0.1, 0.2, 0.3]), np.array([0.0, -9.81, 0.5]))])
    (s,) = samples_from_imu_data(data)
    assert s.t_s == pytest.approx(DEVICE_CLOCK_S + 0.5)
    assert s.gyroscope_rad_s == pytest.approx((0.1, 0.2, 0.3)) and s.accelerometer_m_s2 == pytest.approx((0.0, -9.81, 0.5))


def test_imu_depthai_url_needs_a_depthai_camera_and_turns_its_imu_on() -> None:
    from walkmon.drivers.depthai_camera import DepthaiImu
    from walkmon.drivers.sources import open_camera, open_imu

    cam = open_camera("depthai:?width=320&height=240")
    assert cam.imu is False
    imu = open_imu("depthai:?rate_hz=100", camera=cam)
    assert isinstance(imu, DepthaiImu) and cam.imu is True and cam.imu_rate_hz == 100
    assert open_camera("depthai:?imu=1").imu is True
    with pytest.raises(ConfigError, match="depthai: camera"):
        open_imu("depthai:", camera=open_camera("sim:normal:2"))
    with pytest.raises(ConfigError, match="depthai: camera"):
        open_imu("depthai:")
    with pytest.raises(ConfigError, match="unknown option"):
        open_imu("depthai:?rate=100", camera=cam)
