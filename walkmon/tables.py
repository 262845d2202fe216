"""Reading and writing the files walkmon exchanges: CSV tables (angles.csv, truth.csv, imu.csv, ...) and
indicators.json.

A table is a header line of column names, then one row of numbers per sample. Reading validates: the file
exists and is text, the required columns are present, every value is a finite number, there is at least one
row and ``t`` never decreases. Every problem raises :class:`~walkmon.errors.InvalidInputError` with one line
that names the file (and the row, where there is one).
"""

from __future__ import annotations

import csv
import io
import json
import logging
import math
import re
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from walkmon.consts import IMU_COLUMNS
from walkmon.errors import InvalidInputError

if TYPE_CHECKING:
    from walkmon.gait.indicators import Indicators
    from walkmon.imu.calibration import AccelerometerCalibration
    from walkmon.imu.recordings import ImuRecording

__all__ = ["ACC_COLUMNS", "TIMELINE_COLUMNS", "ImuFile", "imu_file_kind", "read_acc_csv", "read_accelerometer_calibration",
           "read_imu_csv", "read_imu_file", "read_indicators", "read_table", "read_text_column", "write_indicators",
           "write_table"]

_log = logging.getLogger(__name__)


def read_table(
    path: str | Path,
    required: Sequence[str],
    *,
    optional_numeric: bool = True,
    skip_bad_rows: bool = False,
    rejected: Counter[str] | None = None,
    max_bytes: int | None = None,
) -> dict[str, NDArray[np.float64]]:
    """Read a CSV table into ``{column: float array}``.

    ``required`` columns must be present; other numeric columns are returned as well, and non-numeric extra
    columns are skipped when ``optional_numeric`` is True (e.g. a ``model`` text column in angles.csv).

    At most ``max_bytes`` (default :data:`walkmon.safe_io.MAX_TABLE_BYTES`) are read: ``/dev/zero`` or a huge
    file ends in one error line. With ``skip_bad_rows`` (streams of samples without checksums, e.g. imu.csv),
    a row with the wrong number of values or a non-numeric / non-finite required value is skipped and counted
    in ``rejected`` (reasons ``malformed``, ``non_finite``) instead of failing the file, and ``t`` is not checked
    for order (the caller's plausibility check does it).
    """
    from walkmon.safe_io import MAX_TABLE_BYTES, read_bounded  # noqa: PLC0415

    p = Path(path)
    data = read_bounded(p, MAX_TABLE_BYTES if max_bytes is None else max_bytes, "CSV table")
    try:
        text = data.decode("utf-8-sig")  # a spreadsheet's "CSV UTF-8" starts with a byte-order mark (user review)
    except UnicodeDecodeError:
        msg = f"{p}: cannot read as CSV (not UTF-8 text)"
        raise InvalidInputError(msg) from None
    del data
    if "\0" in text:
        msg = f"{p}: cannot read as CSV (contains NUL bytes)"
        raise InvalidInputError(msg)
    rows = _csv_rows(p, text, _delimiter(text))
    del text
    counts: Counter[str] = Counter() if rejected is None else rejected
    header = _header(rows, required)
    if header is None:
        msg = f"{p}: empty file, expected a header with columns {','.join(required)}"
        raise InvalidInputError(msg)
    if rows and [c.strip() for c in rows[0]] != header:
        _log.info("%s: header %s read as %s", p, ",".join(c.strip() for c in rows[0]), ",".join(header))
    missing = [c for c in required if c not in header]
    if missing:
        msg = f"{p}: missing column(s) {','.join(missing)}; header is {','.join(header)}"
        raise InvalidInputError(msg)
    body = rows[1:]
    if skip_bad_rows and "t" in required and body:
        _times_are_numbers(p, header.index("t"), body)
    if not body:
        msg = f"{p}: no data rows"
        raise InvalidInputError(msg)
    columns: dict[str, list[float]] = {name: [] for name in header}
    skipped: set[str] = set()
    required_set = set(required)
    for line_no, row in enumerate(body, start=2):
        if len(row) != len(header):
            if skip_bad_rows:
                counts["malformed"] += 1
                continue
            msg = f"{p}: line {line_no} has {len(row)} values, the header has {len(header)}"
            raise InvalidInputError(msg)
        values: list[tuple[str, float]] = []
        bad = ""
        for name, cell in zip(header, row, strict=True):
            if name in skipped:
                continue
            try:
                value = float(cell)
            except ValueError:
                if name in required_set or not optional_numeric:
                    if skip_bad_rows:
                        bad = "malformed"
                        break
                    msg = f"{p}: line {line_no}, column {name}: {cell!r} is not a number"
                    raise InvalidInputError(msg) from None
                skipped.add(name)  # a text column: not returned
                continue
            if not math.isfinite(value) and name in required_set:
                if skip_bad_rows:
                    bad = "non_finite"
                    break
                msg = f"{p}: line {line_no}, column {name}: {cell!r} is not a finite number"
                raise InvalidInputError(msg)
            values.append((name, value))
        if bad:
            counts[bad] += 1
            continue
        for name, value in values:
            columns[name].append(value)
    out = {name: np.asarray(vals, dtype=float) for name, vals in columns.items() if name not in skipped}
    if not skip_bad_rows and "t" in out and np.any(np.diff(out["t"]) < 0):
        line = int(np.argmax(np.diff(out["t"]) < 0)) + 3
        msg = f"{p}: column t decreases at line {line}"
        raise InvalidInputError(msg)
    return out


#: Header names read as ``t`` when a file has no ``t`` column.
TIME_ALIASES = ("time", "t_s", "timestamp", "time_s", "seconds")


def _delimiter(text: str) -> str:
    """',' unless the header line (the first that is not a '#' comment; or the first) has none but ';' or a tab
    (user review: a semicolon- or tab-separated export, its header plainly naming the columns, read 'missing
    column(s) t,...')."""
    lines = [ln for ln in text.splitlines()[:50] if ln.strip()]
    first = next((ln for ln in lines if not ln.lstrip().startswith("#")), lines[0] if lines else "")
    if "," in first:
        return ","
    return ";" if ";" in first else "\t" if "\t" in first else ","


#: A number written with a decimal comma (0,01; -1,5e-3), as ';'- and tab-separated exports write them.
_DECIMAL_COMMA = re.compile(r"^\s*[+-]?\d*,\d+([eE][+-]?\d+)?\s*$")


def _csv_rows(p: Path, text: str, delimiter: str) -> list[list[str]]:
    """The non-empty rows; with ';' or a tab, a number's decimal comma is a point (those exports write 0,01; only
    cells that are such a number: text and '1.000,5' are left as they are)."""
    try:
        rows = [r for r in csv.reader(io.StringIO(text, newline=""), delimiter=delimiter)
                if r and any(c.strip() for c in r)]
    except csv.Error as exc:
        msg = f"{p}: cannot read as CSV ({exc})"
        raise InvalidInputError(msg) from None
    if delimiter != "," and len(rows) > 1:
        rows = [rows[0], *([c.replace(",", ".") if _DECIMAL_COMMA.match(c) else c for c in r] for r in rows[1:])]
    return rows


def _header(rows: list[list[str]], required: Sequence[str]) -> list[str] | None:
    """The header's names (``rows`` loses the lines above it): the first row as written when it names every
    required column (a header whose first name starts with '#' included: review); else after leading '#' comment
    lines (a logger's note above the header), and read loosely (:func:`_loose_header`) when that finds them; else
    the first row as written, for the caller's 'missing column(s)'. None for no rows."""
    if not rows:
        return None
    first = [c.strip() for c in rows[0]]
    if all(c in first for c in required):
        return first
    k = 0
    while k < len(rows) - 1 and rows[k][0].lstrip().startswith("#"):
        k += 1
    for cand in ([c.strip() for c in rows[k]], _loose_header(rows[k], required)):
        if cand is not None and all(c in cand for c in required):
            del rows[:k]
            return cand
    return first


def _loose_header(header: list[str], required: Sequence[str]) -> list[str] | None:
    """The header read loosely, or None when that finds the required columns no better: names lower-cased, a
    unit after them left out ('t [s]', 'gx (deg/s)': walkmon infers the units from the data), a time column
    under a usual other name taken as ``t``."""
    names = [re.sub(r"\s*[\[(][^\])]*[\])]\s*$", "", c.strip()).strip().lower() for c in header]
    if "t" not in names:
        alias = next((a for a in TIME_ALIASES if a in names), None)
        if alias is not None:
            names[names.index(alias)] = "t"
    return names if all(c in names for c in required) else None


def _times_are_numbers(p: Path, k: int, body: list[list[str]]) -> None:
    """One line for a time column that holds no numbers (ISO dates: user review, '0 plausible IMU rows ...
    (malformed 1115) ... a dead sensor reads all zeros' never said what was wrong)."""
    cells = [c for c in (r[k].strip() for r in body[:: max(1, len(body) // 200)] if len(r) > k) if c]
    numbers = 0
    for c in cells:
        try:
            float(c)
            numbers += 1
        except ValueError:
            pass
    if cells and numbers < 0.1 * len(cells):  # (empty cells are the rows' own fault: skipped and counted)
        example = cells[0]
        msg = (f"{p}: column t holds no numbers (e.g. {example[:40]!r}): times must be seconds, one number a row "
               f"(convert dates to seconds since the start)")
        raise InvalidInputError(msg)


def write_table(
    path: str | Path,
    columns: Mapping[str, ArrayLike | Sequence[str]],
    *,
    precision: Mapping[str, int] | None = None,
    default_precision: int = 6,
) -> None:
    """Write ``{column: values}`` as CSV; numbers get ``precision[column]`` decimals (default 6).

    Written safely (:func:`walkmon.safe_io.atomic_write`): a symlinked target is refused, the file is 0600.
    """
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
    from walkmon.safe_io import atomic_write  # noqa: PLC0415

    with atomic_write(path, "w", newline="", encoding="utf-8") as fh:  # temp file + rename, never via a link
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(names)
        writer.writerows(zip(*formatted, strict=True))


def read_text_column(path: str | Path, name: str) -> list[str] | None:
    """The text of column ``name`` of a CSV table, one entry per data row (None without that column), e.g.
    angles.csv's ``model``, which :func:`read_table` leaves out as non-numeric. Rows are counted as
    :func:`read_table` counts them (blank lines skipped)."""
    from walkmon.safe_io import MAX_TABLE_BYTES, read_bounded  # noqa: PLC0415

    try:
        text = read_bounded(Path(path), MAX_TABLE_BYTES, "CSV table").decode("utf-8-sig")
        rows = [r for r in csv.reader(io.StringIO(text, newline="")) if r and any(c.strip() for c in r)]
    except (UnicodeDecodeError, csv.Error):
        return None  # read_table has already said what is wrong with such a file
    header = [c.strip() for c in rows[0]] if rows else []
    if name not in header:
        return None
    k = header.index(name)
    return [r[k].strip() if k < len(r) else "" for r in rows[1:]]


def read_imu_csv(path: str | Path, *, units_out: list[str] | None = None) -> ImuRecording:
    """Read imu.csv (``t,gx,gy,gz,ax,ay,az``); malformed files raise InvalidInputError with one line.

    Rows that cannot be real (malformed, non-finite, beyond a MEMS sensor's range, no gravity, time going back)
    are skipped and counted by :func:`read_imu_file` (CSV lines carry no checksum); a
    file with fewer than 10 plausible rows is refused. A file in g or deg/s is converted (:mod:`walkmon.imu.units`;
    the lines saying so are appended to ``units_out``)."""
    from walkmon.imu.recordings import ImuRecording  # noqa: PLC0415  (the IMU package does no I/O)

    f = read_imu_file(path, min_rows=10)
    if units_out is not None:
        units_out.extend(f.units)
    return ImuRecording(f.t_s, f.gyroscope_rad_s, f.accelerometer_m_s2)


#: Columns of an accelerometer-only recording (a phone, a cheap accelerometer in a neck pouch).
ACC_COLUMNS = ("t", "ax", "ay", "az")
#: timeline.csv (the session analysis, every 1 s; see the README's file formats)
TIMELINE_COLUMNS = ("t", "activity", "label", "pitch", "roll", "ref_uncertainty_deg")


def imu_file_kind(path: str | Path) -> str:
    """'imu' for ``t,gx,gy,gz,ax,ay,az``; 'acc' for ``t,ax,ay,az`` without a gyroscope (issue 11). Bad rows are
    the reader's to skip and count: read strictly here, one NaN row refused the whole file before the reader
    that skips it was reached."""
    acc_rejected: Counter[str] = Counter()
    cols = read_table(path, ACC_COLUMNS, skip_bad_rows=True, rejected=acc_rejected)
    if all(c in cols for c in ("gx", "gy", "gz")):
        return "imu"
    # a gyroscope column with some empty cells (pandas writes NaN as nothing) was dropped as not numeric, and the
    # whole file read as an accelerometer's (user review: 3 such rows cost yaw and turns for all 1115): the file is
    # an IMU's when most of its rows have the gyroscope, the others the reader's to skip and count
    n_rows = len(cols["t"]) + sum(acc_rejected.values())
    if n_rows and _header_has(path, ("gx", "gy", "gz")):
        imu = read_table(path, IMU_COLUMNS, skip_bad_rows=True)
        if len(imu["t"]) >= 0.5 * n_rows:
            return "imu"
    # some gyroscope columns but not all (a typo in a header): not an accelerometer's file with the gyroscope
    # silently dropped (review: no 'gz' read as accelerometer-only, yaw and turns lost without a word)
    present = _header_names(path, ("gx", "gy", "gz"))
    if present and len(present) < 3:
        missing = ", ".join(c for c in ("gx", "gy", "gz") if c not in present)
        msg = (f"{path}: gyroscope columns {', '.join(present)} but no {missing}: an IMU file needs "
               "t,gx,gy,gz,ax,ay,az (an accelerometer alone: t,ax,ay,az)")
        raise InvalidInputError(msg)
    return "acc"


def _table_rows(path: str | Path) -> list[list[str]]:
    """The CSV file's rows as :func:`read_table` splits them (its delimiter, comment lines)."""
    from walkmon.safe_io import MAX_TABLE_BYTES, read_bounded  # noqa: PLC0415

    text = read_bounded(path, MAX_TABLE_BYTES, "CSV table").decode("utf-8-sig", "replace")
    return _csv_rows(Path(path), text, _delimiter(text))


def _header_names(path: str | Path, names: Sequence[str]) -> list[str]:
    """Which of ``names`` the CSV file's header has, each read as :func:`_header_has` reads it; the file read and
    parsed once (review: once per name cost 0.4 s a name on a 30-minute accelerometer file)."""
    rows = _table_rows(path)
    return [c for c in names if (h := _header(list(rows), (c,))) is not None and c in h]


def _header_has(path: str | Path, names: Sequence[str]) -> bool:
    """The CSV file's header, read as :func:`read_table` reads it (its delimiter, comment lines, loose names:
    review, the empty-gyroscope rule missed every export but a plain comma one), names all of ``names``."""
    header = _header(_table_rows(path), names)
    return header is not None and all(c in header for c in names)


def read_acc_csv(path: str | Path, *, units_out: list[str] | None = None) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(t (N,) s, acc (N,3) m/s²) of an accelerometer-only file, read as imu.csv is (:func:`read_imu_file`):
    malformed and non-finite rows and the rows the plausibility rules reject (out of range, no gravity, time
    going back) are skipped and counted; a clock that goes back for more than 1 % of the rows, or fewer than 10
    plausible rows, is an error (InvalidInputError); an accelerometer in g is converted
    (:mod:`walkmon.imu.units`; the line saying so is appended to ``units_out``)."""
    rejected: Counter[str] = Counter()
    cols = read_table(path, ACC_COLUMNS, skip_bad_rows=True, rejected=rejected)
    t = np.asarray(cols["t"], dtype=float)
    acc = np.column_stack([cols["ax"], cols["ay"], cols["az"]]).astype(float) if len(t) else np.zeros((0, 3))
    n_total = len(t) + sum(rejected.values())
    _, acc, units = _in_si_units(path, t, None, acc)
    if units_out is not None:
        units_out.extend(units)
    keep = _keep_plausible(path, t, None, acc, rejected, n_total, 10, "accelerometer", "t,ax,ay,az in s, m/s2")
    return t[keep], acc[keep]


def read_accelerometer_calibration(path: str | Path) -> AccelerometerCalibration:
    """A ``walkmon calibrate-imu`` JSON file; malformed files raise InvalidInputError with one line."""
    from walkmon.imu.calibration import AccelerometerCalibration  # noqa: PLC0415  (the IMU package does no I/O)
    from walkmon.safe_io import MAX_TEXT_INPUT_BYTES, read_bounded  # noqa: PLC0415

    try:
        data = json.loads(read_bounded(path, MAX_TEXT_INPUT_BYTES, "calibration file").decode("utf-8"))
    except RecursionError:
        msg = f"{path}: nested too deeply to be a calibration file"
        raise InvalidInputError(msg) from None
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
    """Write indicators.json (UTF-8, indented, keys in schema order, NaN as null); safely
    (:func:`walkmon.safe_io.write_text`: temp file + rename, a symlinked target refused, 0600)."""
    from walkmon.safe_io import write_text  # noqa: PLC0415

    write_text(path, json.dumps(indicators.to_dict(), indent=2, allow_nan=False) + "\n")


def read_indicators(path: str | Path) -> Indicators:
    """Read an indicators.json; a missing, unreadable, oversized (> 4 MiB) or malformed file raises
    InvalidInputError (one line)."""
    from walkmon.safe_io import MAX_TEXT_INPUT_BYTES, read_bounded  # noqa: PLC0415

    p = Path(path)
    try:
        doc = json.loads(read_bounded(p, MAX_TEXT_INPUT_BYTES, "indicators.json").decode("utf-8"))
    except UnicodeDecodeError as exc:
        msg = f"{p}: cannot read ({exc})"
        raise InvalidInputError(msg) from None
    except json.JSONDecodeError as exc:
        msg = f"{p}: not valid JSON ({exc.msg} at line {exc.lineno})"
        raise InvalidInputError(msg) from None
    except RecursionError:
        msg = f"{p}: nested too deeply to be an indicators.json"
        raise InvalidInputError(msg) from None
    from walkmon.gait.indicators import indicators_from_dict  # noqa: PLC0415  (gait does no I/O)

    return indicators_from_dict(doc, str(p))


# ------------------------------------------------------------------------------------------ imu.csv
@dataclass(frozen=True, slots=True)
class ImuFile:
    """The plausible rows of an imu.csv and the count of rows skipped per reason."""

    t_s: NDArray[np.float64]
    gyroscope_rad_s: NDArray[np.float64]
    accelerometer_m_s2: NDArray[np.float64]
    rejected: dict[str, int]
    #: the file's units where they were not the documented ones, one line each (:mod:`walkmon.imu.units`)
    units: tuple[str, ...] = ()

    @property
    def n_rejected(self) -> int:
        return sum(self.rejected.values())


def _in_si_units(path: str | Path, t: NDArray[np.float64], gyro: NDArray[np.float64] | None,
                 acc: NDArray[np.float64]) -> tuple[Any, NDArray[np.float64], tuple[str, ...]]:
    """The columns in rad/s and m/s² whatever the file used (g, deg/s: :mod:`walkmon.imu.units`, each conversion
    logged and returned); InvalidInputError for time stamps that cannot be seconds."""
    from walkmon.imu.units import infer_units  # noqa: PLC0415  (pure)

    if len(t) < 2:
        return gyro, acc, ()
    units = infer_units(t, gyro, acc, source=str(path))
    for note in units.notes:
        _log.warning("%s", note)
    return (None if gyro is None else gyro * units.gyro_scale), acc * units.acc_scale, units.notes


def read_imu_file(path: str | Path, *, min_rows: int = 1) -> ImuFile:
    """Read imu.csv keeping only plausible rows (see the module docstring); InvalidInputError (one line) for
    an unreadable file or one with fewer than ``min_rows`` plausible rows."""
    rejected: Counter[str] = Counter()
    cols = read_table_skipping(path, rejected)
    t = cols["t"]
    gyro = np.column_stack([cols["gx"], cols["gy"], cols["gz"]]) if len(t) else np.zeros((0, 3))
    accel = np.column_stack([cols["ax"], cols["ay"], cols["az"]]) if len(t) else np.zeros((0, 3))
    n_total = len(t) + sum(rejected.values())  # rows read + rows read_table skipped as malformed
    gyro, accel, units = _in_si_units(path, t, gyro, accel)
    keep = _keep_plausible(path, t, gyro, accel, rejected, n_total, min_rows, "IMU",
                           "t,gx,gy,gz,ax,ay,az in s, rad/s, m/s2")
    return ImuFile(t[keep], gyro[keep], accel[keep], dict(rejected), units)


def _keep_plausible(
    path: str | Path, t: NDArray[np.float64], gyro: NDArray[np.float64] | None, acc: NDArray[np.float64],
    rejected: Counter[str], n_total: int, min_rows: int, what: str, columns: str,
) -> NDArray[np.bool_]:
    """The rows :func:`walkmon.drivers.imu_checks.plausible_rows` keeps; the skipped ones counted into
    ``rejected`` (with any the reader skipped as malformed) and told in one warning line; fewer than ``min_rows``
    kept is InvalidInputError (one line)."""
    from walkmon.drivers.imu_checks import plausible_rows, time_jumps  # noqa: PLC0415  (pure: the rules)

    keep, why = plausible_rows(t, gyro, acc)
    # rows earlier than a row before them (repeated time stamps, a logger writing rows twice, are dropped as
    # time_back but are no clock reset: review found 1 % of them refusing a file)
    # ... among the rows plausible but for their time: a corrupt row's far-future time is no reset (review), nor
    # is one row's time far ahead of the rows about it (user review: every row after it read as going back)
    values_ok, _ = plausible_rows(np.arange(t.size, dtype=float), gyro, acc)
    tt = t[values_ok & np.isfinite(t)]
    tt = tt[~time_jumps(tt)]
    earlier = tt[1:] < np.maximum.accumulate(tt)[:-1] if tt.size > 1 else np.zeros(0, bool)
    steps_back = int(np.sum(np.diff(tt) < 0)) if tt.size > 1 else 0
    if int(earlier.sum()) > max(1, 0.01 * n_total) and steps_back > max(3, 0.001 * n_total):
        # rows in no order (a spreadsheet sorted by another column): not a reset to split at (user review)
        msg = (f"{path}: the rows are out of time order (the time goes back {steps_back} times): sort the file by "
               f"t")
        raise InvalidInputError(msg)
    if int(earlier.sum()) > max(1, 0.01 * n_total):
        # a clock reset (or files joined): the rows after it are not a few late samples to drop
        i = int(np.argmax(earlier))
        top = float(np.max(tt[: i + 1]))
        msg = (f"{path}: the time goes back by {top - tt[i + 1]:.6g} s after t={top:.6g} s ({int(earlier.sum())} of "
               f"{n_total} rows earlier than a row before them): a clock reset or joined files; split the file there")
        raise InvalidInputError(msg)
    rejected.update(why)
    counts = ", ".join(f"{k} {v}" for k, v in sorted(rejected.items()))
    if rejected:
        _log.warning("%s: %d of %d %s rows skipped as implausible (%s)", path, sum(rejected.values()), n_total, what,
                     counts)
    if int(keep.sum()) < min_rows:
        detail = f" ({counts})" if rejected else ""
        msg = (f"{path}: {int(keep.sum())} plausible {what} rows of {n_total}{detail}; need at least {min_rows} "
               f"(a dead sensor reads all zeros; columns are {columns})")
        raise InvalidInputError(msg)
    return keep


def read_table_skipping(path: str | Path, rejected: Counter[str]) -> dict[str, NDArray[np.float64]]:
    """The imu.csv columns with malformed rows skipped and counted in ``rejected``."""
    return read_table(path, IMU_COLUMNS, skip_bad_rows=True, rejected=rejected)
