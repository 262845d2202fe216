"""IMU protocol parsers against byte vectors from the manufacturers' datasheets, not the module's own encoder:
a checksum or scale changed in the encoder and the decoder together passes round-trip tests but fails here.

* BNO08x UART-RVC: the example message of the BNO08X datasheet (CEVA/Hillcrest, section "UART-RVC": "An example
  complete message and checksum calculation"): ``AA AA DE 01 00 92 FF 25 08 8D FE EC FF D1 03 00 00 00 E7`` =
  index 222, yaw 0.01 deg, pitch -1.10 deg, roll 20.85 deg, acceleration -371, -20, 977 mg.
* WitMotion WT901: the datasheet documents the packets (``0x55 0x51 AxL AxH AyL AyH AzL AzH TL TH SUM``, signed
  shorts low byte first, a = raw / 32768 x 16 g, w = raw / 32768 x 2000 deg/s, angle = raw / 32768 x 180 deg,
  ``SUM = 0x55 + 0x51 + AxH + AxL + ... + TH + TL`` (low byte)) but prints no worked example; the packets below
  were written out by hand from those formulas, the sums added up in the comments.
"""

from __future__ import annotations

import math

import pytest

from walkmon.drivers.imu_protocols import Bno08xRvcParser, WitMotionParser

G_DATASHEET = 9.8  # the datasheets' g (WitMotion: 9.8; BNO08x: -371 mg = -3.638 m/s2); walkmon uses 9.81

# a = (0, 0, +1 g): AzL AzH = 0x00 0x08 (2048 = 32768 / 16); T = 25.00 C: TL TH = 0xC4 0x09 (2500)
# SUM = 0x55 + 0x51 + 0x08 + 0xC4 + 0x09 = 0x17B -> 0x7B
WIT_ACCEL = bytes.fromhex("55 51 00 00 00 00 00 08 C4 09 7B")
# w = (+500, -1000, 0) deg/s: 0x2000 (8192), 0xC000 (-16384); T = 0
# SUM = 0x55 + 0x52 + 0x20 + 0xC0 = 0x187 -> 0x87
WIT_RATE = bytes.fromhex("55 52 00 20 00 C0 00 00 00 00 87")
# roll, pitch, yaw = (+90, -45, 0) deg: 0x4000 (16384), 0xE000 (-8192); version bytes 0xD2 0x04
# SUM = 0x55 + 0x53 + 0x40 + 0xE0 + 0xD2 + 0x04 = 0x29E -> 0x9E
WIT_ANGLE = bytes.fromhex("55 53 00 40 00 E0 00 00 D2 04 9E")

BNO_EXAMPLE = bytes.fromhex("AA AA DE 01 00 92 FF 25 08 8D FE EC FF D1 03 00 00 00 E7")


def test_witmotion_datasheet_packets_decode_to_their_values() -> None:
    parser = WitMotionParser()
    (s,) = parser.feed(WIT_ACCEL + WIT_RATE + WIT_ANGLE, t_s=1.5)
    assert parser.stats.bad_checksums == 0 and parser.stats.good_packets == 3
    assert s.accelerometer_m_s2[:2] == (0.0, 0.0)
    assert s.accelerometer_m_s2[2] == pytest.approx(G_DATASHEET, rel=2e-3)
    assert s.gyroscope_rad_s == pytest.approx((math.radians(500), math.radians(-1000), 0.0), abs=1e-12)
    assert s.device_angles_deg == pytest.approx((90.0, -45.0, 0.0), abs=1e-12)


def test_bno08x_rvc_datasheet_example_decodes_to_its_values() -> None:
    parser = Bno08xRvcParser()
    (s,) = parser.feed(BNO_EXAMPLE, t_s=0.0)
    assert parser.stats.bad_checksums == 0
    assert s.index == 222 and s.gyroscope_rad_s is None
    assert s.device_angles_deg == pytest.approx((0.01, -1.10, 20.85), abs=1e-9)
    assert [v / G_DATASHEET * 1000 for v in s.accelerometer_m_s2] == pytest.approx([-371, -20, 977], rel=2e-3)


@pytest.mark.parametrize(("parser_cls", "packets"), [
    (WitMotionParser, [WIT_ACCEL, WIT_RATE, WIT_ANGLE]),
    (Bno08xRvcParser, [BNO_EXAMPLE]),
])
def test_one_flipped_bit_anywhere_after_the_header_is_rejected(parser_cls, packets) -> None:
    """The datasheet checksum covers every byte after the header (BNO08x) or every byte (WitMotion)."""
    header = 2 if parser_cls is Bno08xRvcParser else 1
    for k, packet in enumerate(packets):
        for i in range(header, len(packet)):
            for bit in (0, 7):
                parser = parser_cls()
                bad = bytearray(packet)
                bad[i] ^= 1 << bit
                stream = b"".join(packets[:k]) + bytes(bad) + b"".join(packets[k + 1 :])
                samples = parser.feed(stream, t_s=0.0)
                assert parser.stats.bad_checksums >= 1, (k, i, bit)
                assert not samples or parser_cls is WitMotionParser  # a WitMotion group may complete without it
