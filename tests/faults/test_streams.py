"""Fault injection, streams: a stream fault is a counted and skipped sample, never an exception, never a wrong or
NULL angle (issue 12, items 2 and 4). Fuzzing is seeded so a failure reproduces."""

from __future__ import annotations

import math
import sqlite3
from pathlib import Path

import numpy as np
import pytest

from walkmon.drivers.imu_checks import ImuPlausibility, implausible_reason
from walkmon.drivers.imu_protocols import Bno08xRvcParser, CsvLineParser, WitMotionParser

G = 9.80665


def _line(t: float, gyr: tuple[float, ...], acc: tuple[float, ...]) -> bytes:
    return (",".join(f"{v:.6g}" for v in (t, *gyr, *acc)) + "\n").encode()


def test_csv_stream_counts_and_skips_every_implausible_or_corrupted_line() -> None:
    rng = np.random.default_rng(12)
    good: list[float] = []
    stream = bytearray()
    n_implausible = n_malformed = 0
    t = 0.0
    for _ in range(3000):
        t += 0.01
        kind = rng.integers(0, 10)
        if kind <= 6:  # a real walking sample
            gyr = tuple(rng.normal(0, 1.0, 3))
            stream += _line(t, gyr, (rng.normal(0, 2), -G + rng.normal(0, 2), rng.normal(0, 2)))
            good.append(tuple(float(f"{v:.6g}") for v in gyr))
        elif kind == 7:  # well-formed but impossible: dead sensor, 1e300, nan, time back
            bad = [(t, (0, 0, 0), (0, 0, 0)), (t, (1e300, 0, 0), (0, -G, 0)), (t, (0, 0, 0), (0, -G * 40, 0)),
                   (t - 5.0, (0, 0, 0), (0, -G, 0))][rng.integers(0, 4)]
            stream += _line(bad[0], bad[1], bad[2])
            n_implausible += 1
        elif kind == 8:
            stream += f"{t:.6g},nan,0,0,0,-9.8,0\n".encode()
            n_malformed += 1
        else:  # a line hit by noise: bytes flipped
            line = bytearray(_line(t, (0.1, 0.2, 0.3), (0.0, -G, 0.0)))
            line[rng.integers(0, len(line) - 1)] = int(rng.choice([0xFF, 0x00, ord("#"), ord(",")]))
            stream += line
            n_malformed += 1  # counted as malformed or implausible below; never a wrong sample
    parser = CsvLineParser()
    samples = []
    pos = 0
    while pos < len(stream):  # random chunking, as a serial port delivers
        k = int(rng.integers(1, 300))
        pos += k
        # the host clock: each line is made 10 ms after the one before and arrives 2 ms after the chunk's last
        arrival = 1000.0 + 0.01 * bytes(stream[:pos]).count(b"\n") + 0.002
        samples += parser.feed(bytes(stream[pos - k : pos]), t_s=arrival)
    st = parser.stats
    assert all(implausible_reason(s.t_s, s.gyroscope_rad_s, s.accelerometer_m_s2) is None for s in samples)
    assert set(good) <= {s.gyroscope_rad_s for s in samples}  # every real sample came through
    t = np.array([s.t_s for s in samples])
    assert np.all(np.diff(t) > 0) and 1000.0 <= t[0] and t[-1] <= 1030.01  # in order, on the host clock
    assert st.samples == len(samples)
    assert st.implausible_samples >= n_implausible
    assert st.samples + st.implausible_samples + st.bad_checksums + st.ignored_packets == 3000


@pytest.mark.parametrize("parser_cls", [WitMotionParser, Bno08xRvcParser])
def test_binary_parsers_survive_seeded_random_bytes(parser_cls) -> None:
    """Seeded random bytes (1 MB here) in random chunks: no exception, every sample within the sensor's range."""
    rng = np.random.default_rng(7)
    parser = parser_cls()
    n = 0
    for _ in range(64):
        chunk = rng.integers(0, 256, int(rng.integers(1, 32768)), dtype=np.uint8).tobytes()
        for s in parser.feed(chunk, t_s=float(n)):
            n += 1
            acc = s.accelerometer_m_s2
            assert all(math.isfinite(v) and abs(v) <= 16 * G + 1e-9 for v in acc)
    assert parser.stats.skipped_bytes > 0


def test_running_check_rejects_time_going_back_and_keeps_its_reference() -> None:
    chk = ImuPlausibility()
    up = (0.0, -G, 0.0)
    assert chk.check(1.0, (0, 0, 0), up)
    assert not chk.check(0.5, (0, 0, 0), up)  # back in time
    assert chk.check(1.0, (0, 0, 0), up)  # same time stamp: fine (several samples per serial chunk)
    assert not chk.check(1.1, None, (0.0, 0.0, 0.0))  # no gyro (BNO08x RVC) but a dead accelerometer
    assert chk.check(1.2, None, up)
    assert chk.rejected == {"time_back": 1, "no_gravity": 1} and chk.accepted == 3


@pytest.mark.parametrize(("value", "reason"), [("0", "no_gravity"), ("1e300", "accel_range")])
def test_live_with_a_dead_or_insane_imu_falls_back_to_camera_only(tmp_path: Path, cli, value: str, reason: str) -> None:
    imu = tmp_path / "imu.csv"
    imu.write_text("t,gx,gy,gz,ax,ay,az\n" + "".join(f"{i / 100:.2f},0,0,0,{value},{value},{value}\n"
                                                     for i in range(700)))
    data = tmp_path / "data"
    res = cli("live", "--camera", "sim:normal:3?width=96&height=72", "--imu", f"file:{imu}", "--data-dir", data,
              "--status", "none")
    assert res.rc == 0, res.err
    assert f"700 samples rejected as implausible ({reason} 700)" in res.out
    conn = sqlite3.connect(data / "walkmon.sqlite")
    try:
        n, n_null, n_fused = conn.execute(
            "SELECT COUNT(*), SUM(pitch IS NULL OR yaw IS NULL OR roll IS NULL), SUM(fused) FROM frames").fetchone()
        (n_imu,) = conn.execute("SELECT COUNT(*) FROM imu").fetchone()
        (ended,) = conn.execute("SELECT ended_utc FROM sessions").fetchone()
    finally:
        conn.close()
    assert n > 100 and n_null == 0 and n_fused == 0 and n_imu == 0 and ended


def test_live_skips_corrupted_rows_of_a_real_imu_and_still_fuses(walk: Path, tmp_path: Path, cli) -> None:
    lines = (walk / "imu.csv").read_text().splitlines()
    rng = np.random.default_rng(3)
    bad = sorted(rng.choice(np.arange(10, len(lines) - 10), 40, replace=False))
    for i in bad[:20]:
        t = lines[i].split(",")[0]
        lines[i] = f"{t},0,0,0,0,0,0"  # dropped-out sensor
    for i in bad[20:]:
        lines[i] = lines[i].replace(",", ",9e9", 1)  # a digit burst: gyro x = 9e9...
    imu = tmp_path / "imu.csv"
    imu.write_text("\n".join(lines) + "\n")
    data = tmp_path / "data"
    res = cli("live", "--camera", "sim:normal:2?width=160&height=120", "--imu", f"file:{imu}", "--data-dir", data,
              "--status", "none")
    assert res.rc == 0, res.err
    assert "40 samples rejected as implausible" in res.out
    conn = sqlite3.connect(data / "walkmon.sqlite")
    try:
        n, n_null, n_fused = conn.execute(
            "SELECT COUNT(*), SUM(pitch IS NULL), SUM(fused) FROM frames").fetchone()
        (n_imu,) = conn.execute("SELECT COUNT(*) FROM imu").fetchone()
    finally:
        conn.close()
    assert n_null == 0 and n_fused > n / 2
    assert n_imu == len(lines) - 1 - 40
