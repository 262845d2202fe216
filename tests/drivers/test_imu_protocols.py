"""Byte-level tests of the IMU protocol parsers: values, splits at every offset, garbage, bad checksums,
truncated tails and random bursts. Parsers must never raise on bad bytes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from walkmon.consts import GRAVITY_MS2
from walkmon.drivers.imu_protocols import (
    Bno08xRvcParser,
    CsvLineParser,
    CsvUnits,
    WitMotionParser,
    bno08x_rvc_frame,
    parser_for_protocol,
    witmotion_packet,
)
from walkmon.errors import ConfigError

G = GRAVITY_MS2


def wit_group(i: int) -> bytes:
    """One WitMotion sample: accel, rate, angle packets with values that depend on i."""
    return (
        witmotion_packet(0x51, (2048, -1024, 512 + i, 0))  # 1 g, -0.5 g, (512+i)/2048 g
        + witmotion_packet(0x52, (16384, -8192, i, 0))  # 1000, -500, i*2000/32768 deg/s
        + witmotion_packet(0x53, (8192, -4096, 100 * i, 0))  # 45, -22.5, ... deg
    )


def wit_expected(i: int) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]:
    accel = (G, -0.5 * G, (512 + i) / 2048 * G)
    gyro = tuple(math.radians(v) for v in (1000.0, -500.0, i * 2000 / 32768))
    angles = (45.0, -22.5, 100 * i / 32768 * 180)
    return accel, gyro, angles


def wit_stream(n: int) -> bytes:
    return b"".join(wit_group(i) for i in range(n))


def check_wit_samples(samples: list, first: int = 0) -> None:
    for k, s in enumerate(samples):
        accel, gyro, angles = wit_expected(first + k)
        assert s.accelerometer_m_s2 == pytest.approx(accel)
        assert s.gyroscope_rad_s == pytest.approx(gyro)
        assert s.device_angles_deg == pytest.approx(angles)


def feed_in_pieces(parser, data: bytes, cuts: list[int]) -> list:  # noqa: ANN001
    out = []
    edges = [0, *cuts, len(data)]
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        out += parser.feed(data[a:b], t_s=float(a))
    return out


# ---------------------------------------------------------------------------------------------- WitMotion
def test_witmotion_decodes_values_and_units() -> None:
    p = WitMotionParser()
    samples = p.feed(wit_stream(3), t_s=1.5)
    assert len(samples) == 3
    check_wit_samples(samples)
    assert all(s.t_s == 1.5 for s in samples)
    assert p.stats.good_packets == 9 and p.stats.bad_checksums == 0 and p.stats.skipped_bytes == 0


def test_witmotion_split_at_every_offset() -> None:
    data = wit_stream(4)
    for cut in range(len(data) + 1):
        p = WitMotionParser()
        samples = feed_in_pieces(p, data, [cut])
        assert len(samples) == 4, cut
        check_wit_samples(samples)
    p = WitMotionParser()  # one byte at a time
    samples = feed_in_pieces(p, data, list(range(1, len(data))))
    assert len(samples) == 4
    check_wit_samples(samples)


def test_witmotion_garbage_between_packets_is_skipped_and_counted() -> None:
    rng = np.random.default_rng(1)
    garbage = [bytes(b for b in rng.integers(0, 256, 7 + i).astype(np.uint8).tobytes() if b != 0x55) for i in range(5)]
    data = b"".join(g + wit_group(i) for i, g in enumerate(garbage))
    p = WitMotionParser()
    samples = p.feed(data, 0.0)
    assert len(samples) == 5
    check_wit_samples(samples)
    assert p.stats.skipped_bytes == sum(len(g) for g in garbage)


def test_witmotion_bad_checksum_drops_only_that_packet() -> None:
    data = bytearray(wit_stream(3))
    data[33 + 11 + 10] ^= 0xFF  # checksum of the rate packet of sample 1
    p = WitMotionParser()
    samples = p.feed(bytes(data), 0.0)
    assert p.stats.bad_checksums == 1
    assert len(samples) == 2  # sample 1 has no rate: not emitted, counted
    assert p.stats.incomplete_samples == 1
    check_wit_samples(samples[:1], 0)
    check_wit_samples(samples[1:], 2)


def test_witmotion_truncated_tail_waits_for_the_rest() -> None:
    data = wit_stream(2)
    p = WitMotionParser()
    assert len(p.feed(data[:-5], 0.0)) == 1
    assert p.stats.bad_checksums == 0
    rest = p.feed(data[-5:], 1.0)
    assert len(rest) == 1
    check_wit_samples(rest, 1)


def test_witmotion_other_packet_types_are_ignored_and_groups_flush_on_repeat() -> None:
    # a device configured for accel + rate only (no angle packet): a sample per repeat of the group
    data = b"".join(witmotion_packet(0x51, (2048, 0, 0, 0)) + witmotion_packet(0x52, (0, 0, 0, 0)) for _ in range(3))
    data += witmotion_packet(0x54, (1, 2, 3, 0))  # magnetometer: valid but unused
    p = WitMotionParser()
    samples = p.feed(data, 0.0)
    assert len(samples) == 2  # the third waits for the next group
    assert samples[0].device_angles_deg is None
    assert p.stats.ignored_packets == 1


def test_witmotion_random_burst_never_raises_and_resyncs() -> None:
    rng = np.random.default_rng(7)
    burst = rng.integers(0, 256, 20000).astype(np.uint8).tobytes()
    p = WitMotionParser()
    for k in range(0, len(burst), 97):
        p.feed(burst[k : k + 97], 0.0)
    assert p.stats.skipped_bytes > 0
    samples = p.feed(wit_stream(6), 1.0)
    # the parser may still hold a partial false group from the burst; at least 5 of 6 real samples come through
    assert len(samples) >= 5
    check_wit_samples(samples[-5:], 1)


# ----------------------------------------------------------------------------------------------- BNO08x RVC
def rvc(i: int) -> bytes:
    return bno08x_rvc_frame(i, (12345 - i, -1500, 250 + i), (0, -1000, 20 * i))


def check_rvc(samples: list, first: int = 0) -> None:
    for k, s in enumerate(samples):
        i = first + k
        assert s.index == i & 0xFF
        assert s.gyroscope_rad_s is None
        assert s.device_angles_deg == pytest.approx(((12345 - i) / 100, -15.0, (250 + i) / 100))
        assert s.accelerometer_m_s2 == pytest.approx((0.0, -G, 20 * i / 1000 * G))


def test_rvc_split_at_every_offset_and_values() -> None:
    data = b"".join(rvc(i) for i in range(3))
    for cut in range(len(data) + 1):
        p = Bno08xRvcParser()
        samples = feed_in_pieces(p, data, [cut])
        assert len(samples) == 3, cut
        check_rvc(samples)
        assert p.stats.bad_checksums == 0


def test_rvc_garbage_bad_checksum_and_truncated_tail() -> None:
    frames = [rvc(i) for i in range(4)]
    bad = bytearray(frames[1])
    bad[18] ^= 0x5A
    data = b"\x01\x02\xaa\x03" + frames[0] + bytes(bad) + b"\x00" * 5 + frames[2] + frames[3][:10]
    p = Bno08xRvcParser()
    samples = p.feed(data, 0.0)
    assert [s.index for s in samples] == [0, 2]
    assert p.stats.bad_checksums == 1
    samples = p.feed(frames[3][10:], 1.0)
    check_rvc(samples, 3)


def test_rvc_random_burst_never_raises() -> None:
    rng = np.random.default_rng(3)
    p = Bno08xRvcParser()
    p.feed(rng.integers(0, 256, 20000).astype(np.uint8).tobytes(), 0.0)
    samples = p.feed(b"".join(rvc(i) for i in range(5)), 1.0)
    assert len(samples) >= 4
    check_rvc(samples[-4:], 1)


# ------------------------------------------------------------------------------------------------------- CSV
def test_csv_units_time_column_and_host_time() -> None:
    p = CsvLineParser(CsvUnits(gyroscope="deg/s", accelerometer="g", time="ms"))
    data = b"t,gx,gy,gz,ax,ay,az\r\n1500,90,0,-180,0,-1,0\r\n0,0,45,1,0,0\n"
    samples = p.feed(data, t_s=99.0)
    assert len(samples) == 2
    assert samples[0].t_s == pytest.approx(99.0)  # the device's 1.5 s, arrived at 99 s of the host clock
    assert samples[0].gyroscope_rad_s == pytest.approx((math.pi / 2, 0.0, -math.pi))
    assert samples[0].accelerometer_m_s2 == pytest.approx((0.0, -G, 0.0))
    assert samples[1].t_s == 99.0  # no t column: the host time of the chunk
    assert p.stats.ignored_packets == 1


def test_csv_split_at_every_offset_and_bad_lines() -> None:
    data = b"0.1,1,2,3,4,5,6\nnot,a,number\n0.2,1,2,3,4,5,6\n\xff\xfe\n1,2,3\n0.3,1,2,3,4,5,nan\n0.4,1,2,3,4,5,6\n"
    for cut in range(len(data) + 1):
        p = CsvLineParser()
        samples = [p.feed(data[:cut], 10.0), p.feed(data[cut:], 10.5)]
        got = samples[0] + samples[1]
        assert [s.gyroscope_rad_s for s in got] == [(1.0, 2.0, 3.0)] * 3, cut
        t = [s.t_s for s in got]
        assert all(b > a for a, b in zip(t, t[1:], strict=False)), (cut, t)  # the device's order, on the host clock
        assert p.stats.bad_checksums == 4


def test_csv_overlong_garbage_line_is_skipped() -> None:
    p = CsvLineParser()
    samples = p.feed(b"x" * 1000, 0.0) + p.feed(b"yyy\n0.5,0,0,0,0,0,-9.81\n", 0.0)
    assert [s.accelerometer_m_s2 for s in samples] == [(0.0, 0.0, -9.81)]
    assert p.stats.skipped_bytes >= 1000


def test_protocol_factory_and_unit_validation() -> None:
    assert isinstance(parser_for_protocol("witmotion"), WitMotionParser)
    assert isinstance(parser_for_protocol("bno08x-rvc"), Bno08xRvcParser)
    assert isinstance(parser_for_protocol("csv"), CsvLineParser)
    with pytest.raises(ConfigError):
        parser_for_protocol("nmea")
    with pytest.raises(ConfigError):
        CsvUnits(gyroscope="rpm")


def test_reset_forgets_partial_packets_and_counters() -> None:
    p = WitMotionParser()
    p.feed(wit_stream(1)[:15] + b"\x00\x01", 0.0)
    p.reset()
    assert p.stats.good_packets == 0 and p.stats.skipped_bytes == 0
    samples = p.feed(wit_stream(2), 0.0)
    assert len(samples) == 2
