"""The front end's ObservationLog as CSV files any back end can read (``omnislam frontend
DATASET --out LOG --export DIR``).

The folder holds ``log.json`` (what the log was built from, the tables and their columns) and
one CSV file per record type; ``observation_log.schema.json`` next to this module is the JSON
schema of ``log.json`` and docs/tutorials/observation-log.md describes every column. Numbers
are written with ``repr`` (they read back bit for bit), so a back end reading the CSV files
consumes exactly what the built-in estimators replay from the log.

Tables (one row per record; ``frame`` is the index of the frame in ``frames.csv``):

* ``frames.csv``: stamp, odometry increment and its covariance (empty: none stated), and
  whether the frame has each record type (a frame with no record is not one with an empty
  record: an image processed with nothing seen);
* ``bearings.csv``: the omni bearings: track id, unit vector in the robot frame, sigma, pixel;
* ``range_bearing.csv``: range-bearing sightings (laser landmarks, the data's own);
* ``vertical_lines.csv``: vertical lines: bearing, sigma, mean colours either side, id;
* ``vertical_line_profiles.csv``: each line's colour profile, one row per line and band.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Iterator
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

from omnislam._files import output_error
from omnislam.frontend.observation_log import ObservationLog

FORMAT_NAME = "omnislam-observation-log-csv"
FORMAT_VERSION = 1


@dataclass(frozen=True, slots=True)
class Column:
    """One column of an exported table: its name, unit and meaning (for ``log.json``)."""

    name: str
    unit: str
    meaning: str


def _columns(*specs: tuple[str, str, str]) -> tuple[Column, ...]:
    return tuple(Column(*spec) for spec in specs)


_COVARIANCE = tuple(
    (f"cov_{a}{b}", unit, f"covariance of the increment, row {a}, column {b}")
    for a, b, unit in (("x", "x", "m^2"), ("x", "y", "m^2"), ("x", "theta", "m rad"),
                       ("y", "x", "m^2"), ("y", "y", "m^2"), ("y", "theta", "m rad"),
                       ("theta", "x", "m rad"), ("theta", "y", "m rad"),
                       ("theta", "theta", "rad^2"))
)
#: table file -> its columns
TABLES: dict[str, tuple[Column, ...]] = {
    "frames.csv": _columns(
        ("frame", "", "frame index, 0 to N-1"),
        ("stamp_s", "s", "time of the frame"),
        ("dx_m", "m", "odometry increment from the previous frame, in its frame: x"),
        ("dy_m", "m", "odometry increment: y"),
        ("dtheta_rad", "rad", "odometry increment: heading"),
        *_COVARIANCE,
        ("has_bearings", "", "1: the frame has a bearings record (possibly empty)"),
        ("has_range_bearing", "", "1: the frame has a range-bearing record"),
        ("has_vertical_lines", "", "1: the frame has a vertical-lines record"),
    ),
    "bearings.csv": _columns(
        ("frame", "", "frame index"),
        ("track_id", "", "the track's id, stable across frames (>= floor_ids_from: floor)"),
        ("x", "", "unit bearing vector in the robot frame (x forward, z up): x"),
        ("y", "", "unit bearing vector: y"),
        ("z", "", "unit bearing vector: z"),
        ("sigma_rad", "rad", "angular standard deviation of the bearing"),
        ("u_px", "px", "the keypoint's column in the image"),
        ("v_px", "px", "the keypoint's row in the image"),
    ),
    "range_bearing.csv": _columns(
        ("frame", "", "frame index"),
        ("landmark_id", "", "landmark id, -1 where unknown"),
        ("range_m", "m", "range from the robot"),
        ("bearing_rad", "rad", "bearing in the robot frame, counter-clockwise from x"),
        ("sigma_range_m", "m", "range standard deviation"),
        ("sigma_bearing_rad", "rad", "bearing standard deviation"),
    ),
    "vertical_lines.csv": _columns(
        ("frame", "", "frame index"),
        ("line", "", "the line's position in its frame's record, 0 to K-1"),
        ("landmark_id", "", "landmark id, -1 where unknown"),
        ("bearing_rad", "rad", "azimuth of the line in the robot frame"),
        ("sigma_bearing_rad", "rad", "bearing standard deviation"),
        ("left_r", "", "mean colour left of the line, band r (0-255)"),
        ("left_g", "", "band g"),
        ("left_b", "", "band b"),
        ("right_r", "", "mean colour right of the line, band r (0-255)"),
        ("right_g", "", "band g"),
        ("right_b", "", "band b"),
    ),
    "vertical_line_profiles.csv": _columns(
        ("frame", "", "frame index"),
        ("line", "", "the line's position in its frame's record"),
        ("band", "", "colour band, 0 (r) to 2 (b)"),
        ("values", "", "the mean colour profile across the line, W values separated by ';'"),
    ),
}


@cache
def schema() -> dict[str, Any]:
    """The JSON schema of ``log.json`` (draft 2020-12)."""
    return json.loads(Path(__file__).with_name("observation_log.schema.json").read_text())


def export_observation_log(log: ObservationLog, out: str | Path) -> Path:
    """Write ``log`` as CSV files and ``log.json`` into the folder ``out`` (replaced
    atomically).

    Returns:
        ``out``.

    Raises:
        ConfigError: the folder cannot be written.
    """
    out = Path(out)
    tmp = out.parent / f".{out.name}.partial"
    try:
        shutil.rmtree(tmp, ignore_errors=True)
        tmp.mkdir(parents=True)
        for name, rows in _tables(log):
            header = ",".join(c.name for c in TABLES[name])
            (tmp / name).write_text("\n".join([header, *rows]) + "\n")
        (tmp / "log.json").write_text(json.dumps(_metadata(log), indent=1) + "\n")
        if out.exists():
            shutil.rmtree(out)
        tmp.rename(out)
    except OSError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        raise output_error(exc, out, "observation log export") from None
    return out


def _metadata(log: ObservationLog) -> dict[str, Any]:
    """``log.json``: format, the log's key, odometry source, floor ids, the tables."""
    return {
        "format": FORMAT_NAME,
        "version": FORMAT_VERSION,
        "dataset_id": log.dataset_id,
        "config_hash": log.config_hash,
        "odometry_source": log.odometry_source.value,
        "floor_ids_from": log.floor_ids_from,
        "frames": len(log),
        "config": dict(log.config),
        "tables": {
            name: [{"name": c.name, "unit": c.unit, "meaning": c.meaning} for c in columns]
            for name, columns in TABLES.items()
        },
    }


def _text(value: float) -> str:
    return repr(float(value))


def _tables(log: ObservationLog) -> Iterator[tuple[str, list[str]]]:
    """(file, rows) of every table."""
    frames, bearings, sightings, lines, profiles = [], [], [], [], []
    for frame, pixels in zip(log.frames, log.pixels, strict=True):
        frames.append(_frame_row(frame))
        i = str(frame.index)
        if frame.bearings is not None:
            b = frame.bearings
            for k in range(len(b)):
                bearings.append(",".join([i, str(int(b.landmark_ids[k])),
                                          *map(_text, b.unit_vectors_r[k]),
                                          _text(b.sigmas_rad[k]), *map(_text, pixels[k])]))
        if frame.range_bearing is not None:
            rb = frame.range_bearing
            for k in range(len(rb)):
                sightings.append(",".join([
                    i, str(int(rb.landmark_ids[k])), _text(rb.ranges_m[k]),
                    _text(rb.bearings_rad[k]), _text(rb.sigma_range_m[k]),
                    _text(rb.sigma_bearing_rad[k])]))
        if frame.vertical_lines is not None:
            v = frame.vertical_lines
            for k in range(len(v)):
                lines.append(",".join([
                    i, str(k), str(int(v.landmark_ids[k])), _text(v.bearings_rad[k]),
                    _text(v.sigma_bearing_rad[k]), *map(_text, v.means_left[k]),
                    *map(_text, v.means_right[k])]))
                profiles += [f"{i},{k},{band},{';'.join(map(_text, v.profiles[k, band]))}"
                             for band in range(3)]
    yield "frames.csv", frames
    yield "bearings.csv", bearings
    yield "range_bearing.csv", sightings
    yield "vertical_lines.csv", lines
    yield "vertical_line_profiles.csv", profiles


def _frame_row(frame: Any) -> str:
    """One row of ``frames.csv``."""
    odometry = frame.odometry
    covariance = ([""] * 9 if odometry.covariance is None
                  else [_text(v) for v in np.asarray(odometry.covariance).reshape(9)])
    flags = [str(int(record is not None))
             for record in (frame.bearings, frame.range_bearing, frame.vertical_lines)]
    return ",".join([str(frame.index), _text(odometry.stamp_s), *map(_text, odometry.delta),
                     *covariance, *flags])
