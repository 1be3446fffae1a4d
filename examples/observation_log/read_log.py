"""Read an observation log exported by ``omnislam frontend DATASET --out LOG --export DIR``.

Uses only the standard library and numpy, and only what ``DIR/log.json`` says (its format
and the columns of each table), as a back end written outside omnislam would:

    python read_log.py DIR

prints the number of frames and of each record type. ``read_log(DIR)`` returns the metadata
and, per table, a mapping column name -> numpy array (the profiles' ``values`` column as
a list of float arrays).
"""

from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

import numpy as np

FORMAT = "omnislam-observation-log-csv"
VERSION = 1
#: columns that hold whole numbers
INTEGER_COLUMNS = {"frame", "track_id", "landmark_id", "line", "band",
                   "has_bearings", "has_range_bearing", "has_vertical_lines"}


def read_table(path: Path, columns: list[str]) -> dict[str, object]:
    """One CSV table: column name -> (N,) array (empty cells: NaN), in ``columns``' order."""
    with path.open(newline="") as handle:
        rows = list(csv.reader(handle))
    if rows[0] != columns:
        raise ValueError(f"{path}: header {rows[0]} is not {columns} (from log.json)")
    body = rows[1:]
    out: dict[str, object] = {}
    for k, name in enumerate(columns):
        cells = [row[k] for row in body]
        if name == "values":
            out[name] = [np.array([float(v) for v in cell.split(";")]) for cell in cells]
        elif name in INTEGER_COLUMNS:
            out[name] = np.array([int(cell) for cell in cells], dtype=np.int64)
        else:
            out[name] = np.array([float(cell) if cell else np.nan for cell in cells])
    return out


def read_log(folder: str | Path) -> tuple[dict, dict[str, dict[str, object]]]:
    """``(metadata, tables)`` of an exported log folder."""
    folder = Path(folder)
    meta = json.loads((folder / "log.json").read_text())
    if meta.get("format") != FORMAT or meta.get("version") != VERSION:
        raise ValueError(f"{folder}: not an {FORMAT} version {VERSION} folder")
    tables = {
        name: read_table(folder / name, [column["name"] for column in columns])
        for name, columns in meta["tables"].items()
    }
    return meta, tables


if __name__ == "__main__":
    metadata, data = read_log(sys.argv[1])
    print(f"{metadata['frames']} frames from {metadata['dataset_id']}")
    for table, values in data.items():
        first = next(iter(values.values()))
        print(f"{table}: {len(first)} rows")
