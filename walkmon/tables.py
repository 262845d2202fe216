"""Reading and writing the files walkmon exchanges: CSV tables (angles.csv, truth.csv, imu.csv, ...) and
indicators.json.

A table is a header line of column names, then one row of numbers per sample. Reading validates: the file
exists and is text, the required columns are present, every value is a finite number, there is at least one
row and ``t`` never decreases. Every problem raises :class:`~walkmon.errors.InvalidInputError` with one line
that names the file (and the row, where there is one).
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from walkmon.consts import IMU_COLUMNS
from walkmon.errors import InvalidInputError

if TYPE_CHECKING:
    from walkmon.gait.indicators import Indicators
    from walkmon.imu.calibration import AccelerometerCalibration
    from walkmon.imu.recordings import ImuRecording

__all__ = ["read_accelerometer_calibration", "read_imu_csv", "read_indicators", "read_table", "write_indicators",
           "write_table"]


def read_table(
    path: str | Path, required: Sequence[str], *, optional_numeric: bool = True
) -> dict[str, NDArray[np.float64]]:
    """Read a CSV table into ``{column: float array}``.

    ``required`` columns must be present; other numeric columns are returned as well, and non-numeric extra
    columns are skipped when ``optional_numeric`` is True (e.g. a ``model`` text column in angles.csv).
    """
    p = Path(path)
    try:
        with p.open(newline="", encoding="utf-8") as fh:
            rows = list(csv.reader(fh))
    except FileNotFoundError:
        msg = f"{p}: no such file"
        raise InvalidInputError(msg) from None
    except IsADirectoryError:
        msg = f"{p}: is a directory, expected a CSV file"
        raise InvalidInputError(msg) from None
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        msg = f"{p}: cannot read as CSV ({exc})"
        raise InvalidInputError(msg) from None
    rows = [r for r in rows if r and any(c.strip() for c in r)]
    if not rows:
        msg = f"{p}: empty file, expected a header with columns {','.join(required)}"
        raise InvalidInputError(msg)
    header = [c.strip() for c in rows[0]]
    missing = [c for c in required if c not in header]
    if missing:
        msg = f"{p}: missing column(s) {','.join(missing)}; header is {','.join(header)}"
        raise InvalidInputError(msg)
    body = rows[1:]
    if not body:
        msg = f"{p}: no data rows"
        raise InvalidInputError(msg)
    columns: dict[str, list[float]] = {name: [] for name in header}
    skipped: set[str] = set()
    for line_no, row in enumerate(body, start=2):
        if len(row) != len(header):
            msg = f"{p}: line {line_no} has {len(row)} values, the header has {len(header)}"
            raise InvalidInputError(msg)
        for name, cell in zip(header, row, strict=True):
            if name in skipped:
                continue
            try:
                value = float(cell)
            except ValueError:
                if name in required or not optional_numeric:
                    msg = f"{p}: line {line_no}, column {name}: {cell!r} is not a number"
                    raise InvalidInputError(msg) from None
                skipped.add(name)
                continue
            if not math.isfinite(value) and name in required:
                msg = f"{p}: line {line_no}, column {name}: {cell!r} is not a finite number"
                raise InvalidInputError(msg)
            columns[name].append(value)
    out = {name: np.asarray(vals, dtype=float) for name, vals in columns.items() if name not in skipped}
    if "t" in out and np.any(np.diff(out["t"]) < 0):
        bad = int(np.argmax(np.diff(out["t"]) < 0)) + 3
        msg = f"{p}: column t decreases at line {bad}"
        raise InvalidInputError(msg)
    return out


def write_table(
    path: str | Path,
    columns: Mapping[str, ArrayLike | Sequence[str]],
    *,
    precision: Mapping[str, int] | None = None,
    default_precision: int = 6,
) -> None:
    """Write ``{column: values}`` as CSV; numbers get ``precision[column]`` decimals (default 6)."""
    names = list(columns)
    cols = [np.asarray(columns[n]) for n in names]
    lengths = {len(c) for c in cols}
    if len(lengths) > 1:
        msg = f"columns differ in length: {dict(zip(names, (len(c) for c in cols), strict=True))}"
        raise ValueError(msg)
    precision = dict(precision or {})
    formatted = []
    for name, col in zip(names, cols, strict=True):
        if col.dtype.kind in "fiub":
            digits = precision.get(name, default_precision)
            formatted.append([f"{v:.{digits}f}" for v in col.astype(float)])
        else:
            formatted.append([str(v) for v in col])
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    with Path(path).open("w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(names)
        writer.writerows(zip(*formatted, strict=True))


def read_imu_csv(path: str | Path) -> ImuRecording:
    """Read imu.csv (``t,gx,gy,gz,ax,ay,az``); malformed files raise InvalidInputError with one line."""
    from walkmon.imu.recordings import ImuRecording  # noqa: PLC0415  (the IMU package does no I/O)

    cols = read_table(path, IMU_COLUMNS)
    t = cols["t"]
    if len(t) < 10:
        msg = f"{path}: only {len(t)} IMU samples; need at least 10"
        raise InvalidInputError(msg)
    if np.any(np.diff(t) <= 0):
        msg = f"{path}: IMU timestamps must strictly increase"
        raise InvalidInputError(msg)
    gyro = np.column_stack([cols["gx"], cols["gy"], cols["gz"]])
    accel = np.column_stack([cols["ax"], cols["ay"], cols["az"]])
    return ImuRecording(t, gyro, accel)


def read_accelerometer_calibration(path: str | Path) -> AccelerometerCalibration:
    """A ``walkmon calibrate-imu`` JSON file; malformed files raise InvalidInputError with one line."""
    from walkmon.imu.calibration import AccelerometerCalibration  # noqa: PLC0415  (the IMU package does no I/O)

    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        msg = f"{path}: not a JSON calibration file ({exc.msg}, line {exc.lineno})"
        raise InvalidInputError(msg) from None
    except UnicodeDecodeError:
        msg = f"{path}: not a JSON calibration file (not UTF-8 text)"
        raise InvalidInputError(msg) from None
    if not isinstance(data, dict):
        msg = f"{path}: not an accelerometer calibration (expected a JSON object)"
        raise InvalidInputError(msg)
    try:
        return AccelerometerCalibration.from_dict(data)
    except InvalidInputError as exc:
        msg = f"{path}: {exc}"
        raise InvalidInputError(msg) from None


def write_indicators(path: str | Path, indicators: Indicators) -> None:
    """Write indicators.json (UTF-8, indented, keys in schema order, NaN as null)."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(json.dumps(indicators.to_dict(), indent=2, allow_nan=False) + "\n", encoding="utf-8")


def read_indicators(path: str | Path) -> Indicators:
    """Read an indicators.json; a missing, unreadable or malformed file raises InvalidInputError (one line)."""
    p = Path(path)
    try:
        doc = json.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        msg = f"{p}: no such file"
        raise InvalidInputError(msg) from None
    except IsADirectoryError:
        msg = f"{p}: is a directory, expected indicators.json"
        raise InvalidInputError(msg) from None
    except (OSError, UnicodeDecodeError) as exc:
        msg = f"{p}: cannot read ({exc})"
        raise InvalidInputError(msg) from None
    except json.JSONDecodeError as exc:
        msg = f"{p}: not valid JSON ({exc.msg} at line {exc.lineno})"
        raise InvalidInputError(msg) from None
    from walkmon.gait.indicators import indicators_from_dict  # noqa: PLC0415  (gait does no I/O)

    return indicators_from_dict(doc, str(p))
