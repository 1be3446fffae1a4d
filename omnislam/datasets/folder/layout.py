"""The omnislam folder format: its files, their columns, and the schema of ``dataset.json``.

The specification is ``docs/datasets/folder-format.md``; the JSON schema of the metadata is
``dataset.schema.json`` next to this module. Every file but ``dataset.json`` and
``odometry.csv`` is optional. CSV files have one header line naming their columns (in any
order); numbers are written with 17 significant digits so that they read back bit for bit.
"""

from __future__ import annotations

import enum
import json
from functools import cache
from pathlib import Path
from typing import Any

FORMAT_NAME = "omnislam-folder"
FORMAT_VERSION = 1

METADATA = "dataset.json"
ODOMETRY = "odometry.csv"
SIGHTINGS = "sightings.csv"
LASER = "laser.csv"
IMAGES = "images.csv"
IMAGE_FOLDER = "images"
CALIBRATION = "calibration.yaml"
GROUND_TRUTH = "groundtruth.tum"
LANDMARKS = "landmarks.csv"
PRIOR_MAP = "prior_map.csv"
WALLS = "walls.csv"

#: the stamp column every time-indexed file starts with [s]
STAMP = "stamp_s"
#: odometry as increments: the motion from the previous frame, in its frame [m, m, rad]
INCREMENTS = ("dx_m", "dy_m", "dtheta_rad")
#: odometry as velocities held from this row's stamp to the next (zero-order hold) [m/s, rad/s]
VELOCITIES = ("v_mps", "omega_radps")
#: upper triangle of the increment's covariance, row-major (x, y, theta) [m^2, m rad, rad^2]
COVARIANCE = ("cov_xx", "cov_xy", "cov_xtheta", "cov_yy", "cov_ytheta", "cov_thetatheta")
#: the lower triangle's own values, for a covariance computed without exact symmetry (the
#: full matrix round trips bit for bit; the loader uses it as given)
COVARIANCE_LOWER = ("cov_yx", "cov_thetax", "cov_thetay")
#: the noiseless increments, when known (simulations)
TRUE_INCREMENTS = ("true_dx_m", "true_dy_m", "true_dtheta_rad")
#: sightings: the landmark id (empty: unknown) and the range and bearing in the sensor frame
SIGHTING_COLUMNS = ("landmark_id", "range_m", "bearing_rad")
SIGHTING_SIGMAS = ("sigma_range_m", "sigma_bearing_rad")
#: bearing-only sightings (no ``range_m``): the elevation above the sensor's horizontal plane
#: and its sigma (the estimators take one angular sigma per bearing: it must equal the bearing's)
ELEVATION = "elevation_rad"
SIGMA_ELEVATION = "sigma_elevation_rad"
#: the columns a file of bearing-only sightings writes
BEARING_SIGHTING_COLUMNS = ("landmark_id", "bearing_rad", ELEVATION, "sigma_bearing_rad")
#: images: the stamp and the file, relative to the folder
IMAGE_COLUMNS = (STAMP, "file")
#: one landmark per row: ground truth (landmarks.csv) and prior map (prior_map.csv)
POINT_COLUMNS = ("id", "x_m", "y_m", "z_m")
#: optional columns of prior_map.csv: vertical line (0 or 1) and its mean colours (0-255)
PRIOR_MAP_EXTRAS = (
    "vertical_line",
    "left_r", "left_g", "left_b",
    "right_r", "right_g", "right_b",
)
WALL_COLUMNS = ("x0_m", "y0_m", "x1_m", "y1_m")


def laser_columns(beams: int) -> tuple[str, ...]:
    """The range columns of ``laser.csv`` for ``beams`` beams: ``range_0_m ...``."""
    return tuple(f"range_{k}_m" for k in range(beams))


class SightingKind(enum.Enum):
    """What the rows of ``sightings.csv`` give: all a range (and a bearing), or none."""

    RANGE_BEARING = "range-bearing"
    BEARING_ONLY = "bearing-only"


class OdometryForm(enum.Enum):
    """How ``odometry.csv`` gives the motion between frames."""

    INCREMENTS = "increments"
    VELOCITIES = "velocities"


@cache
def schema() -> dict[str, Any]:
    """The JSON schema of ``dataset.json`` (draft 2020-12)."""
    return json.loads((Path(__file__).with_name("dataset.schema.json")).read_text())


def float_text(value: float) -> str:
    """A float as the shortest text that reads back to the same double (``repr``); NaN as
    ``nan``."""
    return repr(float(value))
