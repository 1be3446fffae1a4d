"""One reader for the whitespace-separated text formats of the real datasets.

MR.CLAM ``.dat`` files, Victoria Park's ``inputs.dat``/``measurements.dat``/``gps.dat``, gtsam's
``victoria_park.txt`` and CARMEN logs are all "one record per line, fields separated by white
space". Every loader reads them through this module, so that a truncated file, a wrong column
count, a non-numeric field or time going backwards is reported the same way everywhere: as a
``DataError`` naming the file and the 1-based line number.
"""

from __future__ import annotations

import enum
import gzip
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from omnislam.errors import DataError


class StampOrder(enum.Enum):
    """What a table's time column must satisfy."""

    ANY = "any"  # not a time column / not checked
    NON_DECREASING = "non-decreasing"  # equal stamps allowed (simultaneous sightings)
    INCREASING = "increasing"  # strictly increasing


@dataclass(frozen=True, slots=True)
class Table:
    """The numeric rows of a text file with the line each row came from.

    Attributes:
        path: the file read.
        values: (N, C) float rows.
        line_numbers: (N,) 1-based line number of each row in the file (for error messages).
    """

    path: Path
    values: np.ndarray
    line_numbers: np.ndarray

    def __len__(self) -> int:
        return int(self.values.shape[0])

    def where(self, row: int) -> str:
        """``"line N"`` of a row, for messages raised after reading."""
        return f"line {int(self.line_numbers[row])}"


def open_text(path: Path) -> Iterator[str]:
    """Yield the lines of a plain or gzip-compressed text file (gzip detected by magic bytes)."""
    path = Path(path)
    try:
        with open(path, "rb") as probe:
            gzipped = probe.read(2) == b"\x1f\x8b"
        opener = gzip.open if gzipped else open
        with opener(path, "rt", encoding="utf-8", errors="replace") as stream:
            yield from stream
    except FileNotFoundError as exc:
        raise DataError("file not found", path) from exc
    except (OSError, EOFError) as exc:  # unreadable, or a gzip stream cut short
        raise DataError(f"cannot read the file ({exc})", path) from exc


def iter_records(path: Path, comment: str = "#") -> Iterator[tuple[int, list[str]]]:
    """Yield ``(line_number, fields)`` for every non-blank, non-comment line (1-based numbers)."""
    for number, line in enumerate(open_text(path), start=1):
        stripped = line.strip()
        if not stripped or stripped.startswith(comment):
            continue
        yield number, stripped.split()


def parse_float(token: str, path: Path, line: int, what: str = "field") -> float:
    """``float(token)`` or a DataError naming the file, the line and the field."""
    try:
        value = float(token)
    except ValueError:
        raise DataError(f"line {line}: {what} {token!r} is not a number", path) from None
    if not np.isfinite(value):
        raise DataError(f"line {line}: {what} {token!r} is not finite", path)
    return value


def parse_int(token: str, path: Path, line: int, what: str = "field") -> int:
    """``int(token)`` or a DataError naming the file, the line and the field."""
    try:
        return int(token)
    except ValueError:
        raise DataError(f"line {line}: {what} {token!r} is not an integer", path) from None


def read_table(
    path: Path,
    columns: tuple[str, ...],
    *,
    stamp_order: StampOrder = StampOrder.NON_DECREASING,
    stamp_column: int = 0,
    min_rows: int = 1,
) -> Table:
    """Read a whitespace-separated numeric table with ``#`` comments.

    Args:
        path: the file (plain or gzip).
        columns: one name (with unit) per expected column; used in messages.
        stamp_order: what ``values[:, stamp_column]`` must satisfy.
        stamp_column: index of the time column.
        min_rows: fewer data rows than this is an error (an empty or truncated file).

    Returns:
        The rows and their line numbers.

    Raises:
        DataError: "path: line N: ..." for a wrong column count (the last line of a truncated
            file), a non-numeric or non-finite field, or time going backwards.
    """
    path = Path(path)
    width = len(columns)
    numbers: list[int] = []
    rows: list[list[str]] = []
    for number, fields in iter_records(path):
        if len(fields) != width:
            hint = " (file truncated?)" if len(fields) < width else ""
            raise DataError(
                f"line {number}: expected {width} columns ({' '.join(columns)}), "
                f"got {len(fields)}{hint}",
                path,
            )
        numbers.append(number)
        rows.append(fields)
    if len(rows) < min_rows:
        if not rows:
            raise DataError("no data rows (the file is empty or holds only comments)", path)
        raise DataError(f"expected at least {min_rows} data rows, found {len(rows)}", path)
    try:
        values = np.array(rows, dtype=float).reshape(len(rows), width)
    except ValueError:
        values = None
    if values is None or not np.all(np.isfinite(values)):
        # slow path only to name the culprit
        for number, fields in zip(numbers, rows, strict=True):
            for name, token in zip(columns, fields, strict=True):
                parse_float(token, path, number, name)
        raise DataError("unparseable numbers", path)  # pragma: no cover - defensive
    line_numbers = np.asarray(numbers, dtype=np.int64)
    if stamp_order is not StampOrder.ANY and len(values) > 1:
        check_stamps(values[:, stamp_column], line_numbers, path, stamp_order)
    values.setflags(write=False)
    line_numbers.setflags(write=False)
    return Table(path, values, line_numbers)


def check_stamps(
    stamps_s: np.ndarray, line_numbers: np.ndarray, path: Path, order: StampOrder
) -> None:
    """Raise DataError at the first stamp that breaks ``order`` (naming both lines)."""
    if order is StampOrder.ANY or len(stamps_s) < 2:
        return
    step = np.diff(stamps_s)
    bad = step < 0 if order is StampOrder.NON_DECREASING else step <= 0
    if np.any(bad):
        k = int(np.argmax(bad)) + 1
        relation = "earlier than" if step[k - 1] < 0 else "equal to"
        raise DataError(
            f"line {int(line_numbers[k])}: time {float(stamps_s[k])!r} is {relation} "
            f"{float(stamps_s[k - 1])!r} on line {int(line_numbers[k - 1])} "
            f"(times must be {order.value})",
            path,
        )


def check_range(
    table: Table, column: int, name: str, low: float, high: float, *, inclusive: bool = True
) -> None:
    """Raise DataError at the first row whose ``column`` is outside ``[low, high]``.

    A physical-range check at the loader (speeds, angles, ranges): a finite but absurd value
    (odometry at 1e308 m/s) is reported with its file and line instead of overflowing later.

    Args:
        table: the rows read by ``read_table``.
        column: column index.
        name: the column's name with unit (for the message).
        low, high: the plausible range.
        inclusive: False makes the bounds themselves implausible (a steering angle of pi/2).
    """
    values = table.values[:, column]
    bad = (values < low) | (values > high) if inclusive else (values <= low) | (values >= high)
    if np.any(bad):
        row = int(np.argmax(bad))
        brackets = "[]" if inclusive else "()"
        raise DataError(
            f"{table.where(row)}: {name} {float(values[row])!r} is outside the plausible range "
            f"{brackets[0]}{low:g}, {high:g}{brackets[1]}",
            table.path,
        )


#: largest id a text column may hold: every integer up to it is exact in a float and in int64
MAX_INTEGER = 2.0**53


def check_integers(table: Table, column: int, name: str) -> None:
    """Raise DataError at the first row whose ``column`` is not a whole number (an id column).

    Args:
        table: the rows read by ``read_table``.
        column: column index.
        name: the column's name (for the message).
    """
    values = table.values[:, column]
    bad = (values != np.round(values)) | ~(np.abs(values) <= MAX_INTEGER)
    if np.any(bad):
        row = int(np.argmax(bad))
        raise DataError(
            f"{table.where(row)}: {name} {float(values[row])!r} is not an integer "
            f"(of at most {MAX_INTEGER:.0f} in magnitude)",
            table.path,
        )


def check_unique(table: Table, column: int, name: str) -> None:
    """Raise DataError at the first row whose ``column`` repeats an earlier row's (naming both).

    Args:
        table: the rows read by ``read_table``.
        column: column index.
        name: the column's name (for the message).
    """
    first: dict[float, int] = {}
    for row, value in enumerate(table.values[:, column].tolist()):
        if value in first:
            raise DataError(
                f"{table.where(row)}: {name} {value:g} listed twice (first on "
                f"{table.where(first[value])})",
                table.path,
            )
        first[value] = row


def check_stream_start(
    stream: Table, first_needed_s: float, needed_by: Path, tolerance_s: float
) -> None:
    """Raise DataError when a stream (odometry, GPS) starts after the data that needs it.

    A file that lost its first lines would otherwise leave the robot standing still until its
    first sample while the sightings already see it move (or leave the start without truth).

    Args:
        stream: the stream's table, time in column 0.
        first_needed_s: the first time another stream (sightings) needs it at [s].
        needed_by: that stream's file (named in the message).
        tolerance_s: how much later the stream may start [s].
    """
    start_s = float(stream.values[0, 0])
    if start_s > first_needed_s + tolerance_s:
        raise DataError(
            f"starts at time {start_s!r} ({stream.where(0)}), "
            f"{start_s - first_needed_s:.3f} s after the first record of {Path(needed_by).name} "
            f"({first_needed_s!r}): the file is truncated",
            stream.path,
        )


def check_stream_end(
    odometry: Table, last_needed_s: float, needed_by: Path, tolerance_s: float
) -> None:
    """Raise DataError when the odometry stream stops before the data that needs it.

    A file cut short (at a line break, so every remaining line parses) would otherwise be
    extrapolated in a straight line to the end of the run.

    Args:
        odometry: the odometry table, time in column 0.
        last_needed_s: the last time another stream (sightings) needs a pose at [s].
        needed_by: that stream's file (named in the message).
        tolerance_s: how much earlier the odometry may end [s].
    """
    end_s = float(odometry.values[-1, 0])
    if last_needed_s > end_s + tolerance_s:
        raise DataError(
            f"stops at time {end_s!r} ({odometry.where(len(odometry) - 1)}), "
            f"{last_needed_s - end_s:.3f} s before the last record of {Path(needed_by).name} "
            f"({last_needed_s!r}): the file is truncated",
            odometry.path,
        )
