"""CSV files of the omnislam folder format: a header naming the columns, numbers below it.

``read_csv`` reads a file into a ``Table`` (``datasets._text``: values and the line of every
row, so that the shared checks name the line) plus the index of each named column. An empty
cell is NaN (a landmark id that is not known, a laser beam without a return); the caller says
which columns must not have one.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Collection
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from omnislam.datasets._text import Table
from omnislam.errors import DataError


@dataclass(frozen=True, slots=True)
class NamedTable:
    """A CSV file's numeric columns by name.

    Attributes:
        table: the values (rows, columns in the file's order) and their line numbers.
        columns: column name -> index in ``table.values``.
        texts: the text columns asked for (``read_csv``'s ``text``), one string per row.
    """

    table: Table
    columns: dict[str, int]
    texts: dict[str, list[str]]

    def __len__(self) -> int:
        return len(self.table)

    def has(self, name: str) -> bool:
        """Whether the file has the column ``name``."""
        return name in self.columns or name in self.texts

    def column(self, name: str) -> np.ndarray:
        """(N,) values of the column ``name``."""
        return self.table.values[:, self.columns[name]]

    def block(self, names: Collection[str]) -> np.ndarray:
        """(N, len(names)) values of the columns ``names``, in that order."""
        return self.table.values[:, [self.columns[n] for n in names]]

    def require_values(self, names: Collection[str]) -> None:
        """Raise DataError at the first empty (or NaN) cell of the columns ``names``."""
        for name in names:
            empty = ~np.isfinite(self.column(name))
            if empty.any():
                row = int(np.argmax(empty))
                raise DataError(
                    f"{self.table.where(row)}: {name} is empty or not finite", self.table.path
                )


def read_csv(
    path: Path,
    required: Collection[str],
    optional: Collection[str] = (),
    *,
    text: Collection[str] = (),
) -> NamedTable:
    """Read a CSV file of the folder format.

    Args:
        path: the file.
        required: the numeric columns it must have.
        optional: the numeric columns it may have.
        text: the columns (among ``required``) read as text (a file name).

    Returns:
        The table; empty cells are NaN.

    Raises:
        DataError: naming the file and the line: unreadable, no header, a missing or unknown
            column, a row with another number of cells, a cell that is not a number.
    """
    try:
        with path.open(newline="") as handle:
            rows = list(csv.reader(handle))
    except FileNotFoundError:
        raise DataError("file missing", path) from None
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise DataError(f"cannot read the file ({exc})", path) from None
    if not rows or not any(cell.strip() for cell in rows[0]):
        raise DataError("line 1: missing header line (the column names)", path)
    header = [cell.strip() for cell in rows[0]]
    _check_header(header, required, optional, path)
    numeric = [k for k, name in enumerate(header) if name not in text]
    numbers: list[int] = []
    values: list[list[float]] = []
    texts: dict[str, list[str]] = {name: [] for name in text}
    for number, row in enumerate(rows[1:], start=2):
        if not any(cell.strip() for cell in row):
            continue
        if len(row) != len(header):
            raise DataError(
                f"line {number}: {len(row)} cells, the header names {len(header)}"
                + (" (file truncated?)" if len(row) < len(header) else ""),
                path,
            )
        values.append([_number(row[k], header[k], number, path) for k in numeric])
        for name in text:
            texts[name].append(row[header.index(name)].strip())
        numbers.append(number)
    array = np.array(values, dtype=float).reshape(len(values), len(numeric))
    array.setflags(write=False)
    table = Table(path, array, np.asarray(numbers, dtype=np.int64))
    columns = {header[k]: i for i, k in enumerate(numeric)}
    return NamedTable(table, columns, texts)


def _check_header(
    header: list[str], required: Collection[str], optional: Collection[str], path: Path
) -> None:
    """Raise DataError for a duplicate, missing or unknown column name."""
    known = set(required) | set(optional)
    for name in header:
        if header.count(name) > 1:
            raise DataError(f"line 1: column {name!r} appears twice", path)
        if name not in known:
            raise DataError(
                f"line 1: unknown column {name!r} (known: {', '.join(sorted(known))})", path
            )
    missing = [name for name in required if name not in header]
    if missing:
        raise DataError(f"line 1: column {missing[0]!r} missing", path)


def _number(cell: str, column: str, line: int, path: Path) -> float:
    """A cell as a float (empty: NaN); infinities are refused."""
    cell = cell.strip()
    if not cell:
        return math.nan
    try:
        value = float(cell)
    except ValueError:
        raise DataError(f"line {line}: {column} {cell!r} is not a number", path) from None
    if math.isinf(value):
        raise DataError(f"line {line}: {column} {cell!r} is infinite", path)
    return value


def write_csv(
    path: Path,
    header: Collection[str],
    rows: np.ndarray | list[list[str]],
    integers: Collection[str] = (),
) -> None:
    """Write a CSV file of the folder format (numbers as ``repr``: they read back exactly).

    Args:
        path: the file.
        header: the column names.
        rows: (N, C) numbers (NaN written as an empty cell), or rows of ready-made strings.
        integers: the columns written as whole numbers (ids, flags).
    """
    lines = [",".join(header)]
    if isinstance(rows, np.ndarray):
        whole = [name in integers for name in header]
        lines += [
            ",".join(_cell(v, w) for v, w in zip(row, whole, strict=True))
            for row in rows.tolist()
        ]
    else:
        lines += [",".join(row) for row in rows]
    path.write_text("\n".join(lines) + "\n")


def _cell(value: float, whole: bool) -> str:
    """A number's CSV cell: empty for NaN, an integer's digits, else ``repr``."""
    if math.isnan(value):
        return ""
    return str(int(value)) if whole else repr(value)
