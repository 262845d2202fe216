"""Luxonis OAK cameras through the depthai v3 API: ``depthai:`` or ``depthai:DEVICE_ID?width=640&height=480``.

depthai is optional (``pip install walkmon[depthai]``) and imported only when the source is opened. The
device search is bounded by ``timeout_s`` (default 3 s, also exported as ``DEPTHAI_SEARCH_TIMEOUT`` before
the import), so a missing device fails within a few seconds with a clear message. Timestamps are the
device's capture timestamps synchronised to the host's monotonic clock (``ImgFrame.getTimestamp()``).

The OAK's on-board IMU (BMI270 or BNO086): ``depthai:?imu=1&imu_rate_hz=200`` (or ``walkmon live --imu depthai:``
with a ``depthai:`` camera, which turns the same option on) adds a depthai ``IMU`` node with
``ACCELEROMETER_RAW`` and ``GYROSCOPE_RAW`` to the camera's own pipeline (one device, one pipeline: a second
``dai.Device`` could not open the OAK) and :meth:`DepthaiCamera.imu_source` reads it. Then **both** frames and
IMU samples carry the device's own clock (``getTimestampDevice()``), so they need no host synchronisation and
``[imu] time_offset_s`` stays 0. Sample time = the gyroscope report's time (the fusion integrates the gyro);
units: rad/s and m/s² as specific force (at rest an axis pointing up reads +9.81), walkmon's convention.
Axes: the samples are passed on in the IMU chip's own axes; walkmon assumes they are the camera's (x right,
y down, z forward) unless ``[imu] extrinsics`` / ``rotation_deg`` says otherwise. That holds for no OAK model
by design, so check it once: with the camera upright and still, the session's imu table must read
``ay`` close to -9.81 (``walkmon sessions export``); otherwise set the extrinsics (the IMU-to-camera rotation,
from the OAK's mechanical drawing or ``walkmon analyze VIDEO --imu imu.csv --imu-extrinsics estimate``).
"""

from __future__ import annotations

import collections
import datetime as _dt
import logging
import os
import time
from typing import Any

from walkmon.drivers.camera_base import CameraSource, Frame
from walkmon.drivers.imu_types import ImuBatch, ImuSample
from walkmon.errors import SourceDisconnected, SourceError, SourceTimeout

__all__ = ["DepthaiCamera", "DepthaiImu", "import_depthai"]

#: IMU packets per batch before the device sends (1 report = 5 ms at 200 Hz), and the most it may hold.
_IMU_BATCH_THRESHOLD = 2
_IMU_MAX_BATCH_REPORTS = 20

_log = logging.getLogger(__name__)


def import_depthai(search_timeout_s: float = 3.0):  # noqa: ANN201 - the depthai module
    """Import depthai lazily, with a bounded device search; SourceError with the install hint if missing."""
    os.environ.setdefault("DEPTHAI_SEARCH_TIMEOUT", str(int(search_timeout_s * 1000)))
    try:
        import depthai  # noqa: PLC0415
    except ImportError as exc:
        msg = "depthai: the depthai package is not installed (pip install 'walkmon[depthai]')"
        raise SourceError(msg) from exc
    return depthai


class DepthaiCamera(CameraSource):
    reconnectable = True

    @property
    def host_clock(self) -> bool:  # type: ignore[override]
        """With the on-board IMU the frames carry the device's clock (as its samples do), else the host's."""
        return not self.imu

    def __init__(self, url: str, device_id: str = "", width: int = 640, height: int = 480, fps: float = 30.0,
                 timeout_s: float = 3.0, imu: bool = False, imu_rate_hz: float = 200.0) -> None:
        super().__init__(url)
        self.device_id = device_id
        self.width, self.height, self.fps = width, height, fps
        self.timeout_s = timeout_s
        self.imu, self.imu_rate_hz = imu, imu_rate_hz
        self._pipeline = None
        self._queue = None
        self.imu_queue: Any = None  # the IMU node's output queue while open with imu=1
        self._index = 0

    def enable_imu(self, rate_hz: float | None = None) -> None:
        """Read the on-board IMU too (before ``open()``): what ``imu=1`` in the URL does."""
        self.imu = True
        if rate_hz is not None:
            self.imu_rate_hz = rate_hz

    def imu_source(self) -> DepthaiImu:
        """The IMU source reading this camera's on-board IMU (``imu=1``)."""
        return DepthaiImu(self)

    def _open(self) -> None:
        dai = import_depthai(self.timeout_s)
        timeout = _dt.timedelta(seconds=self.timeout_s)
        try:
            if self.device_id:
                info = dai.DeviceInfo(self.device_id)
            else:
                found, info = dai.Device.getAnyAvailableDevice(timeout)
                if not found:
                    msg = f"{self.url}: no OAK device found within {self.timeout_s:g} s (plugged in? udev rule?)"
                    raise SourceError(msg)
            device = dai.Device(info)
            pipeline = dai.Pipeline(device)
            cam = pipeline.create(dai.node.Camera).build()
            out = cam.requestOutput((self.width, self.height), type=dai.ImgFrame.Type.BGR888i, fps=self.fps)
            self._queue = out.createOutputQueue(maxSize=4, blocking=False)
            if self.imu:
                imu = pipeline.create(dai.node.IMU)
                rate = int(round(self.imu_rate_hz))
                imu.enableIMUSensor(dai.IMUSensor.ACCELEROMETER_RAW, rate)
                imu.enableIMUSensor(dai.IMUSensor.GYROSCOPE_RAW, rate)
                imu.setBatchReportThreshold(_IMU_BATCH_THRESHOLD)
                imu.setMaxBatchReports(_IMU_MAX_BATCH_REPORTS)
                self.imu_queue = imu.out.createOutputQueue(maxSize=50, blocking=False)
            pipeline.start()
            self._pipeline = pipeline
        except SourceError:
            raise
        except Exception as exc:  # depthai raises RuntimeError for most device problems
            msg = f"{self.url}: cannot start the OAK camera: {exc}"
            raise SourceError(msg) from exc

    def _read(self) -> Frame:
        assert self._queue is not None and self._pipeline is not None
        if not self._pipeline.isRunning():
            msg = f"{self.url}: the OAK pipeline stopped (device unplugged?)"
            raise SourceDisconnected(msg)
        deadline = time.monotonic() + max(1.0, 3.0 / max(self.fps, 1.0))
        msg_ = None
        try:
            while msg_ is None and time.monotonic() < deadline:
                msg_ = self._queue.tryGet()  # polled: portable across depthai 3.x bindings
                if msg_ is None:
                    time.sleep(0.002)
        except Exception as exc:
            msg = f"{self.url}: lost the OAK device: {exc}"
            raise SourceDisconnected(msg) from exc
        if msg_ is None:
            msg = f"{self.url}: no frame within the timeout"
            raise SourceTimeout(msg)
        image = msg_.getCvFrame()
        # with the IMU both streams are on the device clock; without it the host-synchronised one as before
        t_s = (msg_.getTimestampDevice() if self.imu else msg_.getTimestamp()).total_seconds()
        frame = Frame(t_s, image, self._index)
        self._index += 1
        return frame

    def _close(self) -> None:
        if self._pipeline is not None:
            try:
                self._pipeline.stop()
            finally:
                self._pipeline = None
                self._queue = None
                self.imu_queue = None


class DepthaiImu:
    """The on-board IMU of an open :class:`DepthaiCamera` (``imu=1``) as an IMU source: ``read()`` returns the
    :class:`~walkmon.drivers.imu_types.ImuSample` s received (device clock, IMU axes) as an
    :class:`~walkmon.drivers.imu_types.ImuBatch`, or raises SourceTimeout when none
    came within 0.2 s, also while the camera is closed or reconnecting (the camera owns the device; its
    reconnection brings the IMU back)."""

    reconnectable = False
    live = True
    host_clock = False  # the device's clock, as the camera's frames then are

    def __init__(self, camera: DepthaiCamera) -> None:
        self.camera = camera
        self.url = f"{camera.url} (IMU)"
        self._pending: collections.deque[ImuSample] = collections.deque()

    def open(self) -> None:
        if not self.camera.imu:
            msg = f"{self.camera.url}: the OAK IMU needs imu=1 (or enable_imu()) before the camera opens"
            raise SourceError(msg)
        self._pending.clear()

    def read(self) -> ImuBatch:
        deadline = time.monotonic() + 0.2
        while not self._pending:
            queue = self.camera.imu_queue
            if queue is None or time.monotonic() > deadline:
                if queue is None:
                    time.sleep(0.05)
                msg = f"{self.url}: no IMU data"
                raise SourceTimeout(msg)
            try:
                data = queue.tryGet()
            except Exception as exc:  # the device went away: the camera's reconnection handles it
                msg = f"{self.url}: {exc}"
                raise SourceTimeout(msg) from exc
            if data is None:
                time.sleep(0.002)
                continue
            self._pending.extend(samples_from_imu_data(data))
        batch = ImuBatch(tuple(self._pending))
        self._pending.clear()
        return batch

    def close(self) -> None:
        self._pending.clear()


def samples_from_imu_data(data: Any) -> list[ImuSample]:
    """``dai.IMUData`` -> samples: one per packet with both reports, at the gyroscope report's device time."""
    out = []
    for packet in data.packets:
        gyro, acc = packet.gyroscope, packet.acceleroMeter
        t_s = gyro.getTimestampDevice().total_seconds()
        out.append(ImuSample(float(t_s), (float(gyro.x), float(gyro.y), float(gyro.z)),
                             (float(acc.x), float(acc.y), float(acc.z))))
    return out
