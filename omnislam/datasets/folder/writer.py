"""Write any Sequence as an omnislam folder (``omnislam dataset export NAME --out DIR``).

Numbers are written with ``repr`` (17 significant digits at most, the shortest text that
reads back to the same double), so that ``load_folder`` gives back the odometry, range-bearing
sightings, scans and stamps bit for bit and an estimator run on the folder gives the run on the
original bit for bit (bearing-only sightings, held as unit vectors and written as azimuth and
elevation, come back to an ulp). Images are written as PNG (lossless). The folder is written
beside ``out`` and renamed into place when complete.
"""

from __future__ import annotations

import json
import os
import re
import shutil
from pathlib import Path
from typing import Any

import numpy as np

from omnislam._files import output_error
from omnislam.core.types import UNKNOWN_ID, PriorMap
from omnislam.datasets.folder import layout
from omnislam.datasets.folder.csv_table import write_csv
from omnislam.datasets.sequence import BearingSightings, GroundTruthKind, LaserRole, Sequence
from omnislam.errors import DataError

#: the licence written for datasets omnislam reads from elsewhere
SOURCE_LICENCE = "the terms of the original dataset (see source)"


def export_folder(sequence: Sequence, out: str | Path, *, licence: str = SOURCE_LICENCE
                  ) -> Path:
    """Write ``sequence`` to the folder ``out`` (replacing it), atomically.

    Args:
        sequence: any loaded Sequence.
        out: the folder to write.
        licence: the data's licence, for ``dataset.json``.

    Returns:
        ``out``.

    Raises:
        DataError: sightings the format cannot hold (frames with no sightings mixed with
            frames with an empty list; range-bearing and bearing-only sightings together).
        ConfigError: the folder cannot be written.
    """
    out = Path(out)
    tmp = out.parent / f".{out.name}.partial-{os.getpid()}"
    try:
        if tmp.exists():
            shutil.rmtree(tmp)
        tmp.mkdir(parents=True)
    except OSError as exc:
        raise output_error(exc, out, "dataset folder") from None
    try:
        meta = _metadata(sequence, licence)
        _write_odometry(tmp, sequence)
        meta |= _write_sightings(tmp, sequence)
        meta |= _write_laser(tmp, sequence)
        _write_images(tmp, sequence)
        meta |= _write_ground_truth(tmp, sequence)
        meta |= _write_prior_map(tmp, sequence.prior_map)
        (tmp / layout.METADATA).write_text(metadata_text(meta))
        _move_into_place(tmp, out)
    except OSError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        raise output_error(exc, out, "dataset folder") from None
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out


def metadata_text(meta: dict[str, Any]) -> str:
    """``dataset.json``'s text: indented, each list of numbers on one line (a laser's beam
    angles are one line, not hundreds)."""
    text = json.dumps(meta, indent=1)
    numbers = re.compile(r"\[\s*(-?[0-9][-0-9.eE+]*(?:,\s*-?[0-9][-0-9.eE+]*)*)\s*\]")

    def one_line(match: re.Match[str]) -> str:
        return "[" + ", ".join(v.strip() for v in match.group(1).split(",")) + "]"

    return numbers.sub(one_line, text) + "\n"


def _move_into_place(tmp: Path, out: Path) -> None:
    """Rename the written ``tmp`` folder to ``out``, removing the folder it replaces."""
    if out.exists():
        trash = out.parent / f".{out.name}.old-{os.getpid()}"
        out.rename(trash)
        shutil.rmtree(trash)
    tmp.rename(out)


def _metadata(sequence: Sequence, licence: str) -> dict[str, Any]:
    """The fields of ``dataset.json`` every folder has."""
    meta: dict[str, Any] = {
        "format": layout.FORMAT_NAME,
        "version": layout.FORMAT_VERSION,
        "source": sequence.source,
        "licence": licence,
        "units": {"length": "m", "angle": "rad", "time": "s"},
        "frames": {
            "robot": "x forward, y left, z up; angles counter-clockwise",
            "world": "the ground truth's frame",
        },
        "facts": {str(k): str(v) for k, v in sequence.info.items()},
    }
    if sequence.initial_pose_w is not None:
        meta["initial_pose_w"] = sequence.initial_pose_w.tolist()
    return meta


def _write_odometry(folder: Path, sequence: Sequence) -> None:
    """``odometry.csv``: stamps, increments, the stated covariance and the true increments."""
    header = [layout.STAMP, *layout.INCREMENTS]
    blocks = [sequence.stamps_s[:, None], sequence.odometry_r]
    covariance = sequence.odometry_covariance_r
    if covariance is not None:
        rows, cols = np.triu_indices(3)
        header += layout.COVARIANCE
        blocks.append(covariance[:, rows, cols])
        if not np.array_equal(covariance, np.swapaxes(covariance, 1, 2)):
            header += layout.COVARIANCE_LOWER
            blocks.append(covariance[:, [1, 2, 2], [0, 0, 1]])
    if sequence.odometry_true_r is not None:
        header += layout.TRUE_INCREMENTS
        blocks.append(sequence.odometry_true_r)
    write_csv(folder / layout.ODOMETRY, header, np.hstack(blocks))


def _write_sightings(folder: Path, sequence: Sequence) -> dict[str, Any]:
    """``sightings.csv`` (ids empty where unknown): the range-bearing sightings, or the
    bearing-only ones (``_bearing_rows``), and its ``dataset.json`` section."""
    own = sequence.bearing_sightings
    if sequence.range_bearing is not None and own is not None:
        raise DataError(f"{sequence.name}: range-bearing and bearing-only sightings; the folder "
                        "format holds one kind of sightings")
    records = sequence.range_bearing if own is None else own.frames
    if records is None:
        return {}
    listed = [record for record in records if record is not None]
    every_frame = len(listed) == len(sequence)
    if not every_frame and any(len(record) == 0 for record in listed):
        raise DataError(
            f"{sequence.name}: some frames have no sightings and others an empty list; the "
            "folder format tells them apart only for every frame (sightings.every_frame)"
        )
    if own is not None:
        header = [layout.STAMP, *layout.BEARING_SIGHTING_COLUMNS]
        write_csv(folder / layout.SIGHTINGS, header, _bearing_rows(sequence.stamps_s, own))
        return {"sightings": {"every_frame": every_frame, "height_m": own.sensor_height_m}}
    rows = []
    for stamp, rb in zip(sequence.stamps_s.tolist(), sequence.range_bearing, strict=True):
        if rb is None:
            continue
        for k in range(len(rb)):
            landmark = int(rb.landmark_ids[k])
            rows.append([
                repr(stamp),
                "" if landmark == UNKNOWN_ID else str(landmark),
                repr(float(rb.ranges_m[k])),
                repr(float(rb.bearings_rad[k])),
                repr(float(rb.sigma_range_m[k])),
                repr(float(rb.sigma_bearing_rad[k])),
            ])
    header = [layout.STAMP, *layout.SIGHTING_COLUMNS, *layout.SIGHTING_SIGMAS]
    write_csv(folder / layout.SIGHTINGS, header, rows)
    return {"sightings": {"every_frame": every_frame}}


def _bearing_rows(stamps_s: np.ndarray, sightings: BearingSightings) -> list[list[str]]:
    """The rows of bearing-only sightings: each unit vector u as its azimuth atan2(u_y, u_x)
    and elevation atan2(u_z, hypot(u_x, u_y)) (they give u back to a few ulps, not bit for
    bit)."""
    rows = []
    for stamp, seen in zip(stamps_s.tolist(), sightings.frames, strict=True):
        if seen is None:
            continue
        x, y, z = seen.unit_vectors_r.T
        azimuths, elevations = np.arctan2(y, x), np.arctan2(z, np.hypot(x, y))
        for k in range(len(seen)):
            landmark = int(seen.landmark_ids[k])
            rows.append([
                repr(stamp),
                "" if landmark == UNKNOWN_ID else str(landmark),
                repr(float(azimuths[k])),
                repr(float(elevations[k])),
                repr(float(seen.sigmas_rad[k])),
            ])
    return rows


def _write_laser(folder: Path, sequence: Sequence) -> dict[str, Any]:
    """``laser.csv`` (the frames with a scan) and its ``dataset.json`` section (the beam
    angles in the scanner frame, its ``offset_r`` when not zero)."""
    laser = sequence.laser
    if laser is None:
        return {}
    scanned = ~np.all(np.isnan(laser.ranges_m), axis=1)
    header = [layout.STAMP, *layout.laser_columns(len(laser.angles_rad))]
    write_csv(folder / layout.LASER, header,
              np.hstack([sequence.stamps_s[scanned, None], laser.ranges_m[scanned]]))
    section: dict[str, Any] = {
        "angles_rad": laser.angles_rad.tolist(),
        "max_range_m": laser.max_range_m,
    }
    if laser.role is not LaserRole.SENSOR:
        section["role"] = laser.role.value
    if np.any(laser.offset_r):
        section["offset_r"] = laser.offset_r.tolist()
    return {"laser": section}


def _write_images(folder: Path, sequence: Sequence) -> None:
    """``images/NNNNNN.png`` (lossless), ``images.csv`` and ``calibration.yaml``."""
    if sequence.image_loader is None or len(sequence.image_frames) == 0:
        return
    from omnislam._optional import require
    from omnislam._progress import Progress
    from omnislam.camera.io import save_rig

    cv2 = require("cv2")
    (folder / layout.IMAGE_FOLDER).mkdir()
    rows = []
    with Progress("export images", len(sequence.image_frames), "image") as progress:
        for index in sequence.image_frames.tolist():
            name = f"{layout.IMAGE_FOLDER}/{index:06d}.png"
            bgr = cv2.cvtColor(sequence.image(index), cv2.COLOR_RGB2BGR)
            if not cv2.imwrite(str(folder / name), bgr):
                raise OSError(f"cannot write {name}")
            rows.append([repr(float(sequence.stamps_s[index])), name])
            progress.advance()
    write_csv(folder / layout.IMAGES, layout.IMAGE_COLUMNS, rows)
    if sequence.calibration is None:
        raise DataError(f"{sequence.name}: images without a camera calibration")
    save_rig(sequence.calibration, folder / layout.CALIBRATION)


def _write_ground_truth(folder: Path, sequence: Sequence) -> dict[str, Any]:
    """``groundtruth.tum`` and ``landmarks.csv`` and their ``dataset.json`` section."""
    from omnislam.datasets.trajectory_io import write_tum

    truth = sequence.ground_truth
    if truth.kind is GroundTruthKind.NONE and truth.trajectory is None and not len(
            truth.landmark_ids):
        return {"ground_truth": {"kind": truth.kind.value, "note": truth.note}}
    if truth.trajectory is not None:
        write_tum(folder / layout.GROUND_TRUTH, truth.trajectory)
    if len(truth.landmark_ids):
        write_csv(folder / layout.LANDMARKS, layout.POINT_COLUMNS,
                  np.column_stack([truth.landmark_ids, truth.landmarks_w]), integers=("id",))
    return {"ground_truth": {"kind": truth.kind.value, "note": truth.note}}


def _write_prior_map(folder: Path, prior: PriorMap | None) -> dict[str, Any]:
    """``prior_map.csv`` and ``walls.csv`` and their ``dataset.json`` section."""
    if prior is None:
        return {}
    header = list(layout.POINT_COLUMNS)
    blocks = [prior.landmark_ids[:, None], prior.points_w]
    if prior.vertical_line is not None and prior.vertical_line.any():
        header.append("vertical_line")
        blocks.append(prior.vertical_line[:, None].astype(float))
    if prior.means_left is not None and prior.means_right is not None:
        header += layout.PRIOR_MAP_EXTRAS[1:]
        blocks += [prior.means_left, prior.means_right]
    write_csv(folder / layout.PRIOR_MAP, header, np.hstack(blocks).astype(float),
              integers=("id", "vertical_line"))
    if len(prior.walls_w):
        write_csv(folder / layout.WALLS, layout.WALL_COLUMNS, prior.walls_w.reshape(-1, 4))
    return {"prior_map": {"source": prior.source}}
