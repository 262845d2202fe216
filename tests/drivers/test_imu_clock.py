"""A streamed IMU's times on the host clock: device clocks mapped (restarts, wraps, glitches), chunks spread."""

from __future__ import annotations

import numpy as np
import pytest

from walkmon.drivers.imu_checks import CLOCK_RESTART_SAMPLES, ImuPlausibility
from walkmon.drivers.imu_clock import ChunkStamps, DeviceClock
from walkmon.drivers.imu_protocols import CsvLineParser, CsvUnits
from walkmon.drivers.imu_types import ImuSample

G = 9.80665


def _stream(sent_s: np.ndarray, device_s: np.ndarray, rng: np.random.Generator,
            chunk: int = 3) -> list[tuple[bytes, float]]:
    """CSV lines timed ``device_s`` (the device's clock, microseconds) sent at host times ``sent_s``, delivered in
    chunks of ``chunk`` lines at the last one's send time plus a USB latency of 1-4 ms."""
    out = []
    for k in range(0, len(sent_s), chunk):
        lines = b"".join(f"{int(d)},{i * 1e-4:.4f},0,0,0.1,0,9.81\n".encode()  # gx: the sample's number
                         for i, d in enumerate(device_s[k : k + chunk], start=k))
        out.append((lines, float(sent_s[min(k + chunk, len(sent_s)) - 1] + rng.uniform(0.001, 0.004))))
    return out


def _feed(parser: CsvLineParser, chunks: list[tuple[bytes, float]]) -> tuple[np.ndarray, np.ndarray]:
    """The samples' host times and numbers."""
    got = [(s.t_s, round(s.gyroscope_rad_s[0] / 1e-4)) for data, arrival in chunks for s in parser.feed(data, arrival)]
    return np.array([t for t, _ in got]), np.array([i for _, i in got])


@pytest.mark.parametrize("case", ["steady", "reboot", "wrap", "glitch", "glitch 0.05", "glitch 0.3", "glitch 0.9"])
def test_a_device_clock_lands_on_the_host_clock_whatever_it_does(case: str) -> None:
    """200 Hz for 20 s from a microcontroller whose micros() starts at power-up (host clock at 5000 s): the samples
    land within the transfer's latency of when they were sent, in order, and a reboot (its clock restarts at 0),
    a wrap of the 32-bit microsecond counter or one corrupted time loses at most a few samples (every later one
    was refused as going back in time)."""
    rng = np.random.default_rng(3)
    sent = 5000.0 + np.arange(4000) * 0.005
    device = (sent - 5000.0 + 12.0) * 1e6  # powered up 12 s before
    if case == "reboot":
        device[2000:] = (sent[2000:] - sent[2000] + 0.3) * 1e6
    elif case == "wrap":
        device = (device + 2**32 - 13e6) % 2**32  # wraps 1 s in
    elif case == "glitch":
        device[1500] = 9e14
    elif case.startswith("glitch "):  # corrupted forward by less than a restart: its delay must not become the map's
        device[1500] += float(case.split()[1]) * 1e6
    parser = CsvLineParser(CsvUnits(time="us"))
    t, k = _feed(parser, _stream(sent, device, rng))
    assert np.all(np.diff(t) > 0)
    assert 4000 - t.size <= {"steady": 0, "reboot": CLOCK_RESTART_SAMPLES, "wrap": CLOCK_RESTART_SAMPLES}.get(case, 1)
    # when each sample was sent plus the smallest latency seen (1-4 ms) from the first read of a mapping on; the
    # corrupted time's sample has a mapping of its own
    err = (t - sent[k])[k != 1500 if case.startswith("glitch") else np.ones(k.size, bool)]
    assert err.min() > 0.0009 and err.max() < 0.0041
    assert err[-1000:].max() < 0.0015  # the smallest latency found by then
    assert parser.stats.clock_restarts == {"reboot": 1, "wrap": 1}.get(case, 0)  # a glitch: 1 sample refused
    if case.startswith("glitch"):
        assert parser.stats.implausible_samples == 1
        # the reason too, for the session's meta and end line (user review: 'imu_rejected: {}' beside the count)
        assert sum(parser.rejected.values()) == 1


def test_samples_of_one_read_are_spread_over_their_interval() -> None:
    """Three WitMotion-like samples per 16 ms read (a USB adapter's latency timer) at ~190 Hz: all got the read's
    time, and the fusion kept one in three; now 60 distinct times, about one interval apart."""
    stamps = ChunkStamps()
    out = []
    for k in range(20):
        arrival = 100.0 + 0.016 * k
        chunk = [ImuSample(arrival, (0.0, 0.0, 0.0), (0.0, -G, 0.0)) for _ in range(3)]
        out += stamps.spread(chunk, arrival)
    t = np.array([s.t_s for s in out])
    assert np.unique(t).size == 60 and np.all(np.diff(t) > 0)
    assert np.median(np.diff(t[15:])) == pytest.approx(0.016 / 3, rel=0.1)
    assert t[-1] == pytest.approx(100.0 + 0.016 * 19)  # the last sample of a read at its arrival


def test_a_device_time_already_on_the_host_clock_stays_put() -> None:
    clock = DeviceClock()
    for k in range(100):
        sent = 50.0 + 0.01 * k
        assert clock.host_times([sent], sent + 0.002) == [pytest.approx(sent + 0.002)]
    assert clock.restarts == 0


def test_stream_check_follows_a_restarted_clock_but_not_one_bad_line() -> None:
    check = ImuPlausibility()
    acc = (0.0, -G, 0.0)
    assert all(check.check(10.0 + 0.01 * k, (0.0, 0.0, 0.0), acc) for k in range(10))
    assert not check.check(5.0, (0.0, 0.0, 0.0), acc)  # one line timed 5 s back: refused
    assert check.check(10.1, (0.0, 0.0, 0.0), acc)
    verdicts = [check.check(0.01 * k, (0.0, 0.0, 0.0), acc) for k in range(10)]  # the clock restarted at 0
    assert verdicts == [False] * (CLOCK_RESTART_SAMPLES - 1) + [True] * (11 - CLOCK_RESTART_SAMPLES)
    assert check.clock_restarts == 1 and check.rejected["time_back"] == CLOCK_RESTART_SAMPLES
    assert "clock restarted 1 time" in check.summary()
