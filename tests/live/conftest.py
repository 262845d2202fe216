"""Test doubles shared by the live tests, given to tests as fixtures (the classes themselves): a camera that
plays a scripted walk from the simulator's gait model, and a rotation estimator that returns the true angles,
so the threads, stages and session log are checked independently of image processing."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import pytest

from walkmon.drivers.camera_base import CameraSource, Frame
from walkmon.errors import SourceDisconnected, SourceError
from walkmon.simulate.gait import GaitModel

FPS = 30.0
TINY = np.zeros((4, 4), np.uint8)


class GaitSource(CameraSource):
    """Frames at 30 fps of a scripted walk (tiny blank images; the truth travels via the gait model)."""

    def __init__(self, model: GaitModel, stop_after_s: float | None = None, realtime: bool = False) -> None:
        super().__init__("test:gait")
        self.model, self.stop_after_s, self.realtime = model, stop_after_s, realtime
        self.live = realtime
        self.fps = FPS
        self.produced = 0

    def _open(self) -> None:
        self._i = 0
        self._t0 = time.monotonic()

    def _read(self) -> Frame:
        t = self._i / FPS
        end = self.model.duration_s if self.stop_after_s is None else self.stop_after_s
        if t > end:
            raise SourceDisconnected("test:gait: end of stream")
        if self.realtime:
            time.sleep(max(0.0, self._t0 + t - time.monotonic()))
        self._i += 1
        self.produced += 1
        return Frame(t, TINY, self._i - 1)

    def _close(self) -> None:
        pass


@dataclass(frozen=True)
class _Estimate:
    t_s: float
    angles_deg: np.ndarray
    n_inliers: int = 100
    model: str = "truth"
    status: str = "ok"


class TruthEstimator:
    """The rotation-estimator double: the gait model's true angles, optionally after a delay."""

    def __init__(self, model: GaitModel, delay_s: float = 0.0) -> None:
        self.model, self.delay_s = model, delay_s

    def push(self, frame: np.ndarray, t_s: float) -> _Estimate:
        if self.delay_s:
            time.sleep(self.delay_s)
        return _Estimate(t_s, np.asarray(self.model.truth_angles_deg(t_s)).reshape(3))

    def reset(self) -> None:
        pass


class FlakySource(GaitSource):
    """Disconnects at 2 s; the first two reopen attempts fail (device not back yet)."""

    reconnectable = True

    def __init__(self, model: GaitModel) -> None:
        super().__init__(model, stop_after_s=4.0)
        self.opens = 0
        self.failed_reopens = 0
        self._resume_i = 0

    def _open(self) -> None:
        self.opens += 1
        if self.opens in (2, 3):
            self.failed_reopens += 1
            raise SourceError("test: device not there yet")
        self._i = self._resume_i

    def _read(self) -> Frame:
        if self.opens == 1 and self._i == int(2 * FPS):
            self._resume_i = self._i + 5  # frames lost while unplugged
            raise SourceDisconnected("test: unplugged")
        if self._i / FPS > self.stop_after_s:
            self.reconnectable = False
        return super()._read()


class BrokenSource(GaitSource):
    def _read(self) -> Frame:
        if self._i == 10:
            raise RuntimeError("driver bug")
        return super()._read()



@pytest.fixture(name="GaitSource")
def _gait_source() -> type[GaitSource]:
    return GaitSource


@pytest.fixture(name="TruthEstimator")
def _truth_estimator() -> type[TruthEstimator]:
    return TruthEstimator


@pytest.fixture(name="FlakySource")
def _flaky_source() -> type[FlakySource]:
    return FlakySource


@pytest.fixture(name="BrokenSource")
def _broken_source() -> type[BrokenSource]:
    return BrokenSource
