"""Read an omnislam folder (``layout``; specification: docs/datasets/folder-format.md).

``load_folder`` returns the Sequence (``omnislam run DIR`` detects the folder by its
``dataset.json``); ``check_folder`` lists every problem, one line each (file, line, what),
for ``omnislam dataset check``. Both read each file through the same functions, so what the
check accepts the loader loads.

Every sensor's stamps are frame stamps: the frames are the rows of ``odometry.csv``, and a
sighting, a scan, an image must carry the stamp of one of them (to the bit: the files print 17
digits). Values are used as written (no re-wrapping of angles), so a folder exported from
another dataset gives the estimators the same numbers bit for bit.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from omnislam.core.ackermann import integrate_unicycle
from omnislam.core.motion import MotionNoise, OdometryMotionModel
from omnislam.core.sensor_mount import range_bearing_in_robot_frame
from omnislam.core.types import UNKNOWN_ID, Bearings, PriorMap, RangeBearing
from omnislam.datasets._common import Association, odometry_from_poses
from omnislam.datasets._text import (
    StampOrder,
    Table,
    check_integers,
    check_range,
    check_stamps,
    check_unique,
)
from omnislam.datasets.folder import layout
from omnislam.datasets.folder.csv_table import NamedTable, read_csv
from omnislam.datasets.sequence import (
    BearingSightings,
    GroundTruth,
    GroundTruthKind,
    LaserRole,
    LaserScans,
)
from omnislam.errors import DataError

_T = TypeVar("_T")

#: the largest plausible coordinate of a pose or landmark [m] (a corrupt 1e308 is not one)
MAX_COORDINATE_M = 1e6
#: the largest plausible odometry step between two frames [m] and [rad]
MAX_STEP_M = 100.0
MAX_STEP_RAD = 2 * math.pi


def is_folder(path: str | Path) -> bool:
    """True when ``path`` is a folder whose ``dataset.json`` names the omnislam folder format."""
    try:
        meta = json.loads((Path(path) / layout.METADATA).read_text())
    except (OSError, ValueError):
        return False
    return isinstance(meta, dict) and meta.get("format") == layout.FORMAT_NAME


def metadata_problems(meta: object) -> list[str]:
    """Every way ``meta`` breaks the schema of ``dataset.json``, one line each (JSON path and
    what), in the document's order."""
    import jsonschema

    validator = jsonschema.Draft202012Validator(layout.schema())
    errors = sorted(validator.iter_errors(meta), key=lambda e: list(map(str, e.absolute_path)))
    return [f"{e.json_path}: {e.message}" for e in errors]


def read_metadata(root: Path) -> dict[str, Any]:
    """``dataset.json``, checked against the schema.

    Raises:
        DataError: naming ``dataset.json``: unreadable, not JSON, or its first schema problem.
    """
    path = root / layout.METADATA
    try:
        meta = json.loads(path.read_text())
    except FileNotFoundError:
        raise DataError("file missing (every omnislam folder has one)", path) from None
    except (OSError, ValueError) as exc:
        raise DataError(f"cannot read the metadata ({exc})", path) from None
    problems = metadata_problems(meta)
    if problems:
        raise DataError(problems[0], path)
    return meta


@dataclass(frozen=True, slots=True)
class FolderOdometry:
    """The frames of a folder: ``odometry.csv`` as the Sequence holds it.

    Attributes:
        stamps_s: (N,) frame stamps [s].
        odometry_r: (N, 3) increments from the previous frame (row 0: zero).
        covariance_r: (N, 3, 3) stated covariances, or None.
        true_r: (N, 3) noiseless increments, or None.
    """

    stamps_s: np.ndarray
    odometry_r: np.ndarray
    covariance_r: np.ndarray | None
    true_r: np.ndarray | None


def read_odometry(root: Path, meta: dict[str, Any]) -> FolderOdometry:
    """``odometry.csv`` in increments or velocities, with its covariance (columns, or the noise
    statement of ``dataset.json``).

    Raises:
        DataError: naming the file and the line.
    """
    path = root / layout.ODOMETRY
    optional = (*layout.INCREMENTS, *layout.VELOCITIES, *layout.COVARIANCE,
                *layout.COVARIANCE_LOWER, *layout.TRUE_INCREMENTS)
    odometry = read_csv(path, (layout.STAMP,), optional)
    table = odometry.table
    if len(odometry) == 0:
        raise DataError("no frames (one row per frame is needed)", path)
    odometry.require_values([layout.STAMP])
    stamps = odometry.column(layout.STAMP)
    check_stamps(stamps, table.line_numbers, path, StampOrder.INCREASING)
    form = _odometry_form(odometry, path)
    names = layout.INCREMENTS if form is layout.OdometryForm.INCREMENTS else layout.VELOCITIES
    odometry.require_values(names)
    if form is layout.OdometryForm.INCREMENTS:
        increments = odometry.block(layout.INCREMENTS)
        _check_steps(odometry, layout.INCREMENTS)
    else:
        v, w = odometry.column("v_mps"), odometry.column("omega_radps")
        increments = odometry_from_poses(integrate_unicycle(stamps, v, w, stamps))
    true_r = None
    if any(odometry.has(n) for n in layout.TRUE_INCREMENTS):
        odometry.require_values(layout.TRUE_INCREMENTS)
        _check_steps(odometry, layout.TRUE_INCREMENTS)
        true_r = odometry.block(layout.TRUE_INCREMENTS)
    covariance = _covariance(odometry, increments, meta.get("odometry", {}).get("noise"))
    return FolderOdometry(stamps, increments, covariance, true_r)


def _odometry_form(odometry: NamedTable, path: Path) -> layout.OdometryForm:
    """Increments or velocities, from the columns present (exactly one set of them)."""
    increments = [n for n in layout.INCREMENTS if odometry.has(n)]
    velocities = [n for n in layout.VELOCITIES if odometry.has(n)]
    if increments and velocities:
        raise DataError("line 1: give increments (dx_m ...) or velocities (v_mps ...), not both",
                        path)
    if velocities:
        missing = [n for n in layout.VELOCITIES if n not in velocities]
        if missing:
            raise DataError(f"line 1: column {missing[0]!r} missing", path)
        return layout.OdometryForm.VELOCITIES
    missing = [n for n in layout.INCREMENTS if n not in increments]
    if missing:
        raise DataError(
            f"line 1: column {missing[0]!r} missing (odometry is dx_m,dy_m,dtheta_rad or "
            "v_mps,omega_radps)", path)
    return layout.OdometryForm.INCREMENTS


def _check_steps(odometry: NamedTable, names: tuple[str, ...]) -> None:
    """Plausible steps: within ``MAX_STEP_M`` and ``MAX_STEP_RAD``."""
    for name in names:
        limit = MAX_STEP_RAD if name.endswith("_rad") else MAX_STEP_M
        check_range(odometry.table, odometry.columns[name], name, -limit, limit)


def _covariance(
    odometry: NamedTable, increments: np.ndarray, noise: dict[str, Any] | None
) -> np.ndarray | None:
    """(N, 3, 3) covariance of every increment: the columns (the upper triangle, and the lower
    one when given; row 0 may be empty), the noise statement (rot1-trans-rot2 model, thesis eq.
    4.41), or None when neither is given."""
    present = [n for n in layout.COVARIANCE if odometry.has(n)]
    if not present:
        if noise is None:
            return None
        model = OdometryMotionModel(MotionNoise(
            a_vv=noise["a_vv"], a_vw=noise["a_vw"], a_wv=noise["a_wv"], a_ww=noise["a_ww"],
            min_sigma=tuple(noise.get("min_sigma", MotionNoise().min_sigma)),
            reference_step_m=noise.get("reference_step_m"),
        ))
        return np.array([model.covariance(delta) for delta in increments])
    path = odometry.table.path
    if len(present) != len(layout.COVARIANCE):
        missing = next(n for n in layout.COVARIANCE if n not in present)
        raise DataError(f"line 1: column {missing!r} missing (all six or none)", path)
    lower = [n for n in layout.COVARIANCE_LOWER if odometry.has(n)]
    if lower and len(lower) != len(layout.COVARIANCE_LOWER):
        missing = next(n for n in layout.COVARIANCE_LOWER if n not in lower)
        raise DataError(f"line 1: column {missing!r} missing (all three or none)", path)
    values = odometry.block(layout.COVARIANCE + (layout.COVARIANCE_LOWER if lower else ()))
    values = values.copy()
    if len(values) and np.isnan(values[0]).all():
        values[0] = 0.0  # the first frame has no motion to state a noise for
    rows, cols = np.triu_indices(3)
    covariance = np.zeros((len(values), 3, 3))
    covariance[:, rows, cols] = values[:, :6]
    covariance[:, cols, rows] = values[:, :6]
    if lower:  # (y, x), (theta, x), (theta, y) as given
        covariance[:, [1, 2, 2], [0, 0, 1]] = values[:, 6:]
    finite = np.isfinite(values).all(axis=1)
    definite = np.ones(len(values), dtype=bool)
    definite[1:] = np.linalg.eigvalsh(np.where(finite[1:, None, None], covariance[1:],
                                               np.eye(3)))[:, 0] > 0
    bad = ~finite | ~definite
    if bad.any():
        row = int(np.argmax(bad))
        what = "has an empty cell" if not finite[row] else "is not positive definite"
        raise DataError(f"{odometry.table.where(row)}: covariance {what}", path)
    return covariance


def frame_rows(stamps_s: np.ndarray, frame_stamps_s: np.ndarray, table: NamedTable) -> np.ndarray:
    """(K,) frame index of each row's stamp.

    Raises:
        DataError: naming the line of the first stamp that is no frame's (with the nearest one).
    """
    index = np.clip(np.searchsorted(frame_stamps_s, stamps_s), 0, len(frame_stamps_s) - 1)
    missed = frame_stamps_s[index] != stamps_s
    if missed.any():
        row = int(np.argmax(missed))
        nearest = frame_stamps_s[np.argmin(np.abs(frame_stamps_s - stamps_s[row]))]
        raise DataError(
            f"{table.table.where(row)}: stamp {float(stamps_s[row])!r} is not the stamp of a "
            f"frame of {layout.ODOMETRY} (nearest {float(nearest)!r})",
            table.table.path,
        )
    return index


@dataclass(frozen=True, slots=True)
class FolderSightings:
    """``sightings.csv`` as the Sequence holds it: range-bearing or bearing-only (one of them).

    Attributes:
        range_bearing: one RangeBearing per frame (None where none), or None.
        bearings: the bearing-only sightings, or None.
    """

    range_bearing: tuple[RangeBearing | None, ...] | None = None
    bearings: BearingSightings | None = None


def read_sightings(
    root: Path, meta: dict[str, Any], frame_stamps_s: np.ndarray, association: Association
) -> FolderSightings:
    """``sightings.csv``: range-bearing sightings (every row has a range) or bearing-only ones
    (no row has one), in the robot frame; nothing without the file.

    Raises:
        DataError: naming the file and the line (a file mixing rows with and without a range
            names the first row unlike the first).
    """
    path = root / layout.SIGHTINGS
    if not path.exists():
        return FolderSightings()
    settings = meta.get("sightings", {})
    optional = ("range_m", layout.ELEVATION, *layout.SIGHTING_SIGMAS, layout.SIGMA_ELEVATION)
    sightings = read_csv(path, (layout.STAMP, "landmark_id", "bearing_rad"), optional)
    sightings.require_values((layout.STAMP, "bearing_rad"))
    frames = frame_rows(sightings.column(layout.STAMP), frame_stamps_s, sightings)
    check_stamps(sightings.column(layout.STAMP), sightings.table.line_numbers, path,
                 StampOrder.NON_DECREASING)
    landmark_ids = _landmark_ids(sightings, association)
    check_range(sightings.table, sightings.columns["bearing_rad"], "bearing_rad", -math.pi,
                math.pi)
    per_frame = _per_frame(frames, len(frame_stamps_s), settings.get("every_frame", False))
    if _sighting_kind(sightings) is layout.SightingKind.RANGE_BEARING:
        return FolderSightings(range_bearing=_range_bearing(
            sightings, settings, landmark_ids, per_frame))
    return FolderSightings(bearings=_bearing_only(
        sightings, settings, landmark_ids, per_frame, root / layout.METADATA))


def _landmark_ids(sightings: NamedTable, association: Association) -> np.ndarray:
    """(K,) whole landmark ids >= 0, ``UNKNOWN_ID`` where empty (everywhere when
    ``association`` is UNKNOWN)."""
    ids = sightings.column("landmark_id")
    known = np.isfinite(ids)
    if known.any():
        check_integers(_rows(sightings, known), sightings.columns["landmark_id"], "landmark_id")
        check_range(_rows(sightings, known), sightings.columns["landmark_id"], "landmark_id",
                    0, math.inf)
    landmark_ids = np.where(known, np.nan_to_num(ids), UNKNOWN_ID).astype(np.int64)
    if association is Association.UNKNOWN:
        landmark_ids[:] = UNKNOWN_ID
    return landmark_ids


def _sighting_kind(sightings: NamedTable) -> layout.SightingKind:
    """Range-bearing (every row has a range) or bearing-only (no row has one, or no column).

    Raises:
        DataError: naming the first row whose range is given when the first row's is not, or
            the reverse.
    """
    if not sightings.has("range_m") or not len(sightings):
        return layout.SightingKind.BEARING_ONLY
    ranged = np.isfinite(sightings.column("range_m"))
    if ranged.all() or not ranged.any():
        return (layout.SightingKind.RANGE_BEARING if ranged[0]
                else layout.SightingKind.BEARING_ONLY)
    row = int(np.argmax(ranged != ranged[0]))
    first = int(sightings.table.line_numbers[0])
    what = "has a range_m" if ranged[row] else "has no range_m"
    raise DataError(
        f"{sightings.table.where(row)}: {what}, line {first} "
        f"{'does not' if ranged[row] else 'does'} (a file holds range-bearing or bearing-only "
        "sightings, not both)", sightings.table.path)


def _per_frame(frames: np.ndarray, n_frames: int, every_frame: bool
               ) -> tuple[list[np.ndarray | None], bool]:
    """(per frame, the rows of its sightings or None, whether a frame without rows saw
    nothing): the rows grouped by frame, in the file's order within a frame."""
    out: list[np.ndarray | None] = [None] * n_frames
    order = np.argsort(frames, kind="stable")
    starts = np.flatnonzero(np.r_[True, np.diff(frames[order]) != 0])
    for rows in np.split(order, starts[1:]) if len(order) else []:
        out[int(frames[rows[0]])] = rows
    return out, every_frame


def _range_bearing(
    sightings: NamedTable, settings: dict[str, Any], landmark_ids: np.ndarray,
    per_frame: tuple[list[np.ndarray | None], bool],
) -> tuple[RangeBearing | None, ...]:
    """The range-bearing sightings of every frame, moved into the robot frame
    (``sightings.offset_r``).

    Raises:
        DataError: naming the line: a range out of bounds, a sigma missing or not positive, an
            elevation (range-bearing sightings are planar).
    """
    _require_empty(sightings, (layout.ELEVATION, layout.SIGMA_ELEVATION),
                   "range-bearing sightings are planar; elevations are for bearing-only rows")
    check_range(sightings.table, sightings.columns["range_m"], "range_m", 0.0, MAX_COORDINATE_M)
    sigmas = [_sigma_column(sightings, name, settings) for name in layout.SIGHTING_SIGMAS]
    ranges, bearings = range_bearing_in_robot_frame(  # from the robot's origin
        sightings.column("range_m"), sightings.column("bearing_rad"), settings.get("offset_r"))
    rows_of, every_frame = per_frame
    empty = RangeBearing(np.zeros(0, np.int64), [], [], [], [])
    return tuple(
        (empty if every_frame else None) if rows is None else RangeBearing(
            landmark_ids[rows], ranges[rows], bearings[rows], sigmas[0][rows], sigmas[1][rows])
        for rows in rows_of
    )


def _bearing_only(
    sightings: NamedTable, settings: dict[str, Any], landmark_ids: np.ndarray,
    per_frame: tuple[list[np.ndarray | None], bool], metadata_path: Path,
) -> BearingSightings:
    """The bearing-only sightings of every frame as unit vectors in the robot frame: azimuth
    ``bearing_rad`` turned by the offset's yaw, ``elevation_rad`` (empty: 0, the landmark at
    the sensor's height), u = (cos e cos a, cos e sin a, sin e).

    Raises:
        DataError: naming the line (an elevation beyond +-pi/2, a sigma missing, not positive
            or unlike the bearing's, a range sigma) or ``dataset.json`` (an offset off the
            robot's vertical axis).
    """
    _require_empty(sightings, ("sigma_range_m",), "the row has no range")
    sigma = _sigma_column(sightings, "sigma_bearing_rad", settings)
    elevations = np.zeros(len(sightings))
    if sightings.has(layout.ELEVATION):
        check_range(sightings.table, sightings.columns[layout.ELEVATION], layout.ELEVATION,
                    -math.pi / 2, math.pi / 2)
        elevations = np.nan_to_num(sightings.column(layout.ELEVATION), nan=0.0)
    if sightings.has(layout.SIGMA_ELEVATION):
        given = sightings.column(layout.SIGMA_ELEVATION)
        unlike = np.isfinite(given) & (given != sigma)
        if unlike.any():
            row = int(np.argmax(unlike))
            raise DataError(
                f"{sightings.table.where(row)}: sigma_elevation_rad differs from "
                "sigma_bearing_rad (the bearing estimators take one angular sigma per "
                "bearing, the same in azimuth and elevation)", sightings.table.path)
    azimuths = sightings.column("bearing_rad")
    yaw = _bearing_sensor_yaw(settings.get("offset_r"), metadata_path)
    if yaw:
        azimuths = azimuths + yaw
    vectors = np.column_stack([np.cos(elevations) * np.cos(azimuths),
                               np.cos(elevations) * np.sin(azimuths), np.sin(elevations)])
    rows_of, every_frame = per_frame
    empty = Bearings(np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros(0))
    frames = tuple(
        (empty if every_frame else None) if rows is None
        else Bearings(landmark_ids[rows], vectors[rows], sigma[rows])
        for rows in rows_of
    )
    return BearingSightings(frames, settings.get("height_m", 0.0))


def _bearing_sensor_yaw(offset_r: list[float] | None, metadata_path: Path) -> float:
    """The yaw of a bearing-only sensor's offset (0 without one).

    Raises:
        DataError: an offset with x or y: a bearing without range cannot be moved to the
            robot's origin, and the bearing estimators place the viewpoint on its vertical axis.
    """
    if offset_r is None:
        return 0.0
    x, y, yaw = offset_r
    if x or y:
        raise DataError(
            "sightings.offset_r: bearing-only sightings need the sensor on the robot's vertical "
            "axis (x = y = 0; its height is sightings.height_m)", metadata_path)
    return float(yaw)


def _require_empty(sightings: NamedTable, names: tuple[str, ...], why: str) -> None:
    """Raise DataError at the first non-empty cell of the columns ``names`` (``why``: the
    reason they must be empty)."""
    for name in names:
        if not sightings.has(name):
            continue
        given = np.isfinite(sightings.column(name))
        if given.any():
            row = int(np.argmax(given))
            raise DataError(f"{sightings.table.where(row)}: {name} is given, but {why}",
                            sightings.table.path)


def _rows(table: NamedTable, mask: np.ndarray) -> Table:
    """The Table of ``table``'s rows where ``mask`` (for the shared checks)."""
    return Table(table.table.path, table.table.values[mask], table.table.line_numbers[mask])


def _sigma_column(sightings: NamedTable, name: str, settings: dict[str, Any]) -> np.ndarray:
    """(K,) standard deviations: the column, its empty cells filled with (or, without it) the
    ``dataset.json`` ``sightings`` value.

    Raises:
        DataError: a row with neither; a sigma that is not positive.
    """
    path = sightings.table.path
    stated = settings.get(name)
    values = (sightings.column(name).copy() if sightings.has(name)
              else np.full(len(sightings), np.nan))
    if stated is not None:
        values[np.isnan(values)] = stated
    if np.isnan(values).any():
        row = int(np.argmax(np.isnan(values)))
        raise DataError(
            f"{sightings.table.where(row)}: no {name} (give the column, or "
            f"sightings.{name} in {layout.METADATA})", path)
    bad = values <= 0
    if bad.any():
        row = int(np.argmax(bad))
        raise DataError(f"{sightings.table.where(row)}: {name} must be positive", path)
    return values


def read_laser(root: Path, meta: dict[str, Any], frame_stamps_s: np.ndarray
               ) -> LaserScans | None:
    """``laser.csv`` (one row per scanned frame) as one row of ranges per frame (NaN where a
    frame has no scan), or None without the file; the beam angles in the scanner frame as
    written, the scanner's pose ``laser.offset_r`` (default zero) kept with them.

    Raises:
        DataError: naming the file and the line (or ``dataset.json`` without ``laser``).
    """
    path = root / layout.LASER
    if not path.exists():
        return None
    settings = meta.get("laser")
    if settings is None:
        raise DataError(f"{layout.LASER} needs 'laser' (angles_rad, max_range_m)",
                        root / layout.METADATA)
    angles = np.asarray(settings["angles_rad"], dtype=float)
    if np.any(np.diff(angles) <= 0):
        raise DataError("laser.angles_rad must be increasing", root / layout.METADATA)
    names = layout.laser_columns(len(angles))
    scans = read_csv(path, (layout.STAMP, *names))
    scans.require_values([layout.STAMP])
    stamps = scans.column(layout.STAMP)
    check_stamps(stamps, scans.table.line_numbers, path, StampOrder.INCREASING)
    frames = frame_rows(stamps, frame_stamps_s, scans)
    values = scans.block(names)
    negative = values < 0
    if negative.any():
        row, beam = (int(v) for v in np.argwhere(negative)[0])
        raise DataError(f"{scans.table.where(row)}: range_{beam}_m is negative", path)
    ranges = np.full((len(frame_stamps_s), len(angles)), np.nan)
    ranges[frames] = values
    role = LaserRole(settings.get("role", LaserRole.SENSOR.value))
    return LaserScans(angles, ranges, float(settings["max_range_m"]), role,
                      settings.get("offset_r", np.zeros(3)))


@dataclass(frozen=True, slots=True)
class FolderImages:
    """The images of a folder: the frames that have one and their files."""

    frames: np.ndarray
    paths: tuple[Path, ...]

    def load(self, index: int) -> np.ndarray:
        """(H, W, 3) uint8 RGB image of frame ``index``."""
        from omnislam._optional import require
        from omnislam.camera.image_file import read_image

        position = int(np.searchsorted(self.frames, index))
        if position >= len(self.frames) or self.frames[position] != index:
            raise DataError(f"frame {index} has no image")
        cv2 = require("cv2")
        return cv2.cvtColor(read_image(self.paths[position]), cv2.COLOR_BGR2RGB)


def read_images(root: Path, frame_stamps_s: np.ndarray) -> FolderImages | None:
    """``images.csv``: the frames with an image and its file, or None without the file.

    Raises:
        DataError: naming the file and the line: a stamp that is no frame's or appears twice,
            a file that does not exist.
    """
    path = root / layout.IMAGES
    if not path.exists():
        return None
    images = read_csv(path, layout.IMAGE_COLUMNS, text=("file",))
    images.require_values([layout.STAMP])
    stamps = images.column(layout.STAMP)
    check_stamps(stamps, images.table.line_numbers, path, StampOrder.INCREASING)
    frames = frame_rows(stamps, frame_stamps_s, images)
    files = []
    for row, name in enumerate(images.texts["file"]):
        file = root / name
        if not name or not file.is_file():
            raise DataError(f"{images.table.where(row)}: image {name!r} not found", path)
        files.append(file)
    return FolderImages(frames.astype(np.int64), tuple(files))


def read_calibration(root: Path) -> Any:
    """``calibration.yaml`` as a camera rig (``omnislam.camera.io``)."""
    from omnislam.camera.io import load_rig

    path = root / layout.CALIBRATION
    if not path.exists():
        raise DataError(f"file missing: the folder has images ({layout.IMAGES})", path)
    return load_rig(path)


def check_image_sizes(images: FolderImages, rig: Any) -> None:
    """The first and last images decode and have the calibration's size.

    Raises:
        DataError: naming the image.
    """
    camera = rig.camera
    for position in sorted({0, len(images.frames) - 1}):
        image = images.load(int(images.frames[position]))
        if image.shape[:2] != (camera.height, camera.width):
            raise DataError(
                f"image is {image.shape[1]}x{image.shape[0]} px, {layout.CALIBRATION} is for "
                f"{camera.width}x{camera.height}", images.paths[position])


def read_points(path: Path, optional: tuple[str, ...] = ()) -> NamedTable:
    """``landmarks.csv`` or ``prior_map.csv``: whole unique non-negative ids, plausible
    coordinates.

    Raises:
        DataError: naming the file and the line.
    """
    points = read_csv(path, layout.POINT_COLUMNS, optional)
    points.require_values(layout.POINT_COLUMNS)
    check_integers(points.table, points.columns["id"], "id")
    check_range(points.table, points.columns["id"], "id", 0, math.inf)
    check_unique(points.table, points.columns["id"], "id")
    for name in layout.POINT_COLUMNS[1:]:
        check_range(points.table, points.columns[name], name, -MAX_COORDINATE_M,
                    MAX_COORDINATE_M)
    return points


def read_ground_truth(root: Path, meta: dict[str, Any]) -> GroundTruth:
    """``groundtruth.tum`` and ``landmarks.csv`` with the kind and note of ``dataset.json``.

    Raises:
        DataError: naming the file and the line; ground truth without its kind.
    """
    from omnislam.datasets.trajectory_io import read_tum

    trajectory_path, landmarks_path = root / layout.GROUND_TRUTH, root / layout.LANDMARKS
    settings = meta.get("ground_truth", {})
    if not trajectory_path.exists() and not landmarks_path.exists():
        return GroundTruth(kind=GroundTruthKind.NONE, note=settings.get("note", ""))
    if "kind" not in settings:
        raise DataError("ground_truth.kind is needed with groundtruth.tum or landmarks.csv "
                        "(exact, motion-capture, gps-partial, pseudo, reference)",
                        root / layout.METADATA)
    trajectory = read_tum(trajectory_path) if trajectory_path.exists() else None
    ids, points = np.zeros(0, dtype=np.int64), np.zeros((0, 3))
    if landmarks_path.exists():
        landmarks = read_points(landmarks_path)
        ids = landmarks.column("id").astype(np.int64)
        points = landmarks.block(layout.POINT_COLUMNS[1:])
    return GroundTruth(GroundTruthKind(settings["kind"]), trajectory, ids, points,
                       settings.get("note", ""))


def read_prior_map(root: Path, meta: dict[str, Any]) -> PriorMap | None:
    """``prior_map.csv`` and ``walls.csv`` as a PriorMap, or None without either.

    Raises:
        DataError: naming the file and the line.
    """
    points_path, walls_path = root / layout.PRIOR_MAP, root / layout.WALLS
    if not points_path.exists() and not walls_path.exists():
        return None
    ids, points = np.zeros(0, dtype=np.int64), np.zeros((0, 3))
    lines, left, right = None, None, None
    if points_path.exists():
        table = read_points(points_path, layout.PRIOR_MAP_EXTRAS)
        ids = table.column("id").astype(np.int64)
        points = table.block(layout.POINT_COLUMNS[1:])
        if table.has("vertical_line"):
            table.require_values(["vertical_line"])
            check_range(table.table, table.columns["vertical_line"], "vertical_line", 0, 1)
            lines = table.column("vertical_line") != 0
        colours = [n for n in layout.PRIOR_MAP_EXTRAS[1:] if table.has(n)]
        if colours:
            if len(colours) != 6:
                raise DataError("line 1: give all six colour columns or none", points_path)
            left, right = table.block(colours[:3]), table.block(colours[3:])
    walls = np.zeros((0, 2, 2))
    if walls_path.exists():
        table = read_csv(walls_path, layout.WALL_COLUMNS)
        table.require_values(layout.WALL_COLUMNS)
        walls = table.block(layout.WALL_COLUMNS).reshape(-1, 2, 2)
    initial = meta.get("initial_pose_w")
    return PriorMap(
        source=meta.get("prior_map", {}).get("source", "prior map of the folder"),
        landmark_ids=ids, points_w=points, vertical_line=lines, means_left=left,
        means_right=right, walls_w=walls,
        initial_pose_w=None if initial is None else np.asarray(initial, dtype=float),
    )


def attempt(read: Callable[[], _T], problems: list[str]) -> _T | None:
    """``read()``, or None with its DataError's message appended to ``problems``."""
    try:
        return read()
    except DataError as exc:
        problems.append(str(exc))
        return None
