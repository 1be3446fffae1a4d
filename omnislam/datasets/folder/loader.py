"""``load_folder`` (a Sequence) and ``check_folder`` (every problem) of an omnislam folder."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from omnislam.datasets._common import Association
from omnislam.datasets.folder import layout
from omnislam.datasets.folder.reader import (
    FolderImages,
    FolderOdometry,
    FolderSightings,
    attempt,
    check_image_sizes,
    metadata_problems,
    read_calibration,
    read_ground_truth,
    read_images,
    read_laser,
    read_metadata,
    read_odometry,
    read_prior_map,
    read_sightings,
)
from omnislam.datasets.sequence import Sequence
from omnislam.errors import DataError


def load_folder(
    path: str | Path, *, name: str | None = None, association: Association = Association.KNOWN
) -> Sequence:
    """Read an omnislam folder as a Sequence (images on demand).

    Args:
        path: the folder.
        name: the sequence's name (default: the folder's).
        association: KNOWN hands the sightings' ids to the estimators; UNKNOWN hides them.

    Raises:
        DataError: naming the file and the line of the first problem (``check_folder`` lists
            them all).
    """
    root = Path(path)
    meta = read_metadata(root)
    odometry = read_odometry(root, meta)
    stamps = odometry.stamps_s
    images = read_images(root, stamps)
    sightings = read_sightings(root, meta, stamps, association)
    if sightings.bearings is not None and images is not None:
        raise DataError(
            f"bearing-only sightings and {layout.IMAGES}: the front end's bearings of the images "
            "and the file's would be one stream; keep one of them", root / layout.SIGHTINGS)
    rig = None
    if images is not None:
        rig = read_calibration(root)
        check_image_sizes(images, rig)
    return _sequence(
        root,
        meta,
        odometry,
        sightings,
        name=name,
        images=images,
        rig=rig,
    )


def _sequence(
    root: Path,
    meta: dict[str, Any],
    odometry: FolderOdometry,
    sightings: FolderSightings,
    *,
    name: str | None,
    images: FolderImages | None,
    rig: Any,
) -> Sequence:
    """The Sequence of a folder whose metadata, odometry, sightings and images are read."""
    stamps = odometry.stamps_s
    laser = read_laser(root, meta, stamps)
    initial = meta.get("initial_pose_w")
    facts = {
        **meta.get("facts", {}),
        "format": f"{layout.FORMAT_NAME} {layout.FORMAT_VERSION}",
        "frames": str(len(stamps)),
        "images": str(0 if images is None else len(images.frames)),
        "licence": meta["licence"],
    }
    return Sequence(
        name=name or root.name,
        source=meta["source"],
        stamps_s=stamps,
        odometry_r=odometry.odometry_r,
        odometry_true_r=odometry.true_r,
        odometry_covariance_r=odometry.covariance_r,
        initial_pose_w=None if initial is None else np.asarray(initial, dtype=float),
        ground_truth=read_ground_truth(root, meta),
        range_bearing=sightings.range_bearing,
        bearing_sightings=sightings.bearings,
        laser=laser,
        image_loader=None if images is None else images.load,
        image_frames=np.zeros(0, np.int64) if images is None else images.frames,
        calibration=rig,
        prior_map=read_prior_map(root, meta),
        info=facts,
    )


def check_folder(path: str | Path) -> list[str]:
    """Every problem of an omnislam folder, one line each: the file, the line, what.

    Each file is read as ``load_folder`` reads it; a file's first problem is reported and the
    other files are still read (those that need the frames only when ``odometry.csv`` reads).

    Returns:
        The problems (empty: the folder loads).
    """
    root = Path(path)
    meta_path = root / layout.METADATA
    try:
        meta = read_metadata(root)
    except DataError as exc:
        if exc.path is None or not meta_path.is_file():
            return [str(exc)]
        try:
            import json

            raw = json.loads(meta_path.read_text())
        except (OSError, ValueError):
            return [str(exc)]
        return [f"{meta_path}: {problem}" for problem in metadata_problems(raw)]
    problems: list[str] = []
    attempt(lambda: read_ground_truth(root, meta), problems)
    attempt(lambda: read_prior_map(root, meta), problems)
    odometry = attempt(lambda: read_odometry(root, meta), problems)
    if odometry is None:
        return problems
    stamps = odometry.stamps_s
    attempt(lambda: read_sightings(root, meta, stamps, Association.KNOWN), problems)
    attempt(lambda: read_laser(root, meta, stamps), problems)
    images = attempt(lambda: read_images(root, stamps), problems)
    if images is not None:
        rig = attempt(lambda: read_calibration(root), problems)
        if rig is not None:
            attempt(lambda: check_image_sizes(images, rig), problems)
    if not problems:
        attempt(lambda: load_folder(root), problems)  # what only the Sequence checks
    return problems
