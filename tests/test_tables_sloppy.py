"""Real-world CSV exports of IMU data: read as the plain imu.csv they hold, or refused with the reason named.

User review, with the Mobilise-D and Oxford recordings: semicolon- and tab-separated exports, a decimal comma, a
header with units ('t [s]'), in capitals or with 'time', a '#' line above it were all refused as 'missing
column(s) t,ax,ay,az' although the header named them; shuffled rows read as 't in milliseconds?', ISO dates as
'a dead sensor reads all zeros'.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from walkmon.errors import InvalidInputError
from walkmon.tables import IMU_COLUMNS, read_imu_file, read_table

ROWS = [(0.01 * i, 0.1, -0.2, 0.05 * i, 0.3, -9.7, 0.4) for i in range(300)]


def _text(sep: str = ",", header: str = "t,gx,gy,gz,ax,ay,az", decimal: str = ".", before: str = "") -> str:
    lines = [header.replace(",", sep)]
    lines += [sep.join(f"{v:.4f}".replace(".", decimal) for v in row) for row in ROWS]
    return before + "\n".join(lines) + "\n"


@pytest.mark.parametrize("variant", [
    {"sep": ";"}, {"sep": "\t"}, {"sep": ";", "decimal": ","},
    {"header": "t [s],gx [rad/s],gy [rad/s],gz [rad/s],ax [m/s2],ay [m/s2],az [m/s2]"},
    {"header": "T,GX,GY,GZ,AX,AY,AZ"}, {"header": "time,gx,gy,gz,ax,ay,az"},
    {"before": "# logger v2, 100 Hz\n# sensor 17\n"},
], ids=["semicolon", "tab", "decimal comma", "units", "capitals", "time", "comments"])
def test_a_sloppy_export_reads_as_the_plain_file(tmp_path: Path, variant: dict) -> None:
    plain = tmp_path / "plain.csv"
    plain.write_text(_text(), encoding="utf-8")
    sloppy = tmp_path / "sloppy.csv"
    sloppy.write_text(_text(**variant), encoding="utf-8")
    want = read_table(plain, IMU_COLUMNS)
    got = read_table(sloppy, IMU_COLUMNS, skip_bad_rows=True)
    for name in IMU_COLUMNS:
        assert np.array_equal(got[name], want[name]), name


def test_exact_headers_keep_their_names(tmp_path: Path) -> None:
    """The loose reading is a fallback: a file that has the columns is read as written (other columns' names too)."""
    p = tmp_path / "a.csv"
    p.write_text("t,pitch,Yaw_Video\n0,1,2\n1,2,3\n", encoding="utf-8")
    assert set(read_table(p, ("t", "pitch"))) == {"t", "pitch", "Yaw_Video"}


def test_rows_out_of_order_and_dates_are_named(tmp_path: Path) -> None:
    shuffled = tmp_path / "shuffled.csv"
    order = np.random.default_rng(1).permutation(len(ROWS))
    shuffled.write_text("t,gx,gy,gz,ax,ay,az\n" + "".join(",".join(f"{v:.4f}" for v in ROWS[i]) + "\n" for i in order),
                        encoding="utf-8")
    with pytest.raises(InvalidInputError, match="out of time order .* sort the file by t"):
        read_imu_file(shuffled)
    dates = tmp_path / "dates.csv"
    dates.write_text("t,gx,gy,gz,ax,ay,az\n" + "".join(f"2024-05-01T10:00:{i % 60:02d},0,0,0,0,-9.8,0\n"
                                                         for i in range(50)), encoding="utf-8")
    with pytest.raises(InvalidInputError, match="column t holds no numbers"):
        read_imu_file(dates)
