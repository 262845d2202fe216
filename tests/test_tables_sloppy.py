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


def test_review_edges_of_the_loose_reading(tmp_path: Path) -> None:
    """Review of the loose reading: a header whose first name starts with '#' is the header (it was taken for a
    comment); empty t cells are the rows' fault, not 'no numbers' (a bare StopIteration escaped); t in milliseconds
    with every row written twice is still named (the duplicates made the median interval 0)."""
    hashed = tmp_path / "hashed.csv"
    hashed.write_text("#frame,t,pitch,yaw,roll\n0,0,1,2,3\n1,0.1,1,2,3\n", encoding="utf-8")
    assert read_table(hashed, ("t", "pitch", "roll"))["pitch"].tolist() == [1.0, 1.0]
    holes = tmp_path / "holes.csv"
    holes.write_text("t,ax,ay,az\n" + ",0,0,9.8\n" * 250 + "".join(f"{0.01 * i:.2f},0,0,9.8\n" for i in range(100)),
                     encoding="utf-8")
    assert len(read_table(holes, ("t", "ax", "ay", "az"), skip_bad_rows=True)["t"]) == 100
    twice = tmp_path / "twice_ms.csv"
    twice.write_text("t,gx,gy,gz,ax,ay,az\n" + "".join(f"{10.0 * i:.1f},0,0,0,0,-9.8,0\n" * 2 for i in range(500)),
                     encoding="utf-8")
    with pytest.raises(InvalidInputError, match="milliseconds"):
        read_imu_file(twice)


@pytest.mark.parametrize("variant", [{"sep": ";"}, {"sep": "\t", "decimal": ","}, {"before": "# note\n"},
                                     {"header": "T,GX [deg/s],GY,GZ,AX,AY,AZ"}], ids=["semicolon", "tab comma",
                                                                                       "comment", "loose"])
def test_empty_gyroscope_cells_in_an_export_keep_the_gyroscope(tmp_path: Path, variant: dict) -> None:
    """Review: the empty-gyroscope rule read the header as a plain comma file, so every other export with a few
    empty gx cells still became accelerometer-only."""
    from walkmon.tables import imu_file_kind

    text = _text(**variant).splitlines()
    sep = variant.get("sep", ",")
    start = len(text) - len(ROWS)
    for i in range(start + 10, start + 13):
        cells = text[i].split(sep)
        text[i] = sep.join([cells[0], "", *cells[2:]])
    p = tmp_path / "export.csv"
    p.write_text("\n".join(text) + "\n", encoding="utf-8")
    assert imu_file_kind(p) == "imu"
