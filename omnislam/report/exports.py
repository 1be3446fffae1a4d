"""Each run of a report exported for other tools: trajectories (TUM, KITTI), maps (PLY), graphs.

``write_exports`` writes ``exports/CELL/`` next to the report; the landmark map is a PLY point
cloud written by open3d (the ``render`` extra), the factor graph the g2o file the estimator
attached to its RUN_DIR (graphslam).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from omnislam.errors import DataError, MissingExtraError
from omnislam.harness.layout import GRAPH_G2O
from omnislam.harness.rundir import read_run_dir
from omnislam.report.results import ReportCell


def write_landmarks_ply(path: Path, points_w: np.ndarray) -> None:
    """Write a landmark map as a PLY point cloud (open3d; the ``render`` extra).

    Raises:
        MissingExtraError: open3d is not installed (naming the extra).
        DataError: open3d could not write the file.
    """
    from omnislam._optional import require

    o3d = require("open3d")
    cloud = o3d.geometry.PointCloud()
    cloud.points = o3d.utility.Vector3dVector(np.array(points_w, dtype=float).reshape(-1, 3))
    if not o3d.io.write_point_cloud(str(path), cloud, write_ascii=True):
        raise DataError("open3d could not write the point cloud", path)


def write_exports(out: Path, cells: Sequence[ReportCell], notes: list[str]) -> None:
    """``out/exports/CELL/`` for every successful run: trajectory.tum and trajectory.kitti,
    landmarks.ply where it has landmarks (a note when open3d is missing), graph.g2o where the
    estimator exported its factor graph."""
    from omnislam.datasets.trajectory_io import write_kitti, write_tum

    for cell in cells:
        if not cell.ok:
            continue
        record = read_run_dir(cell.run_dir)  # type: ignore[arg-type]
        folder = out / "exports" / cell.cell_id
        folder.mkdir(parents=True, exist_ok=True)
        write_tum(folder / "trajectory.tum", record.estimate.trajectory)
        write_kitti(folder / "trajectory.kitti", record.estimate.trajectory)
        if len(record.estimate.landmark_ids):
            try:
                write_landmarks_ply(folder / "landmarks.ply", record.estimate.landmarks_w)
            except MissingExtraError as exc:
                notes.append(f"{cell.cell_id}: landmarks.ply not written: {exc}")
        if GRAPH_G2O in record.attachments:
            (folder / GRAPH_G2O).write_bytes(record.attachments[GRAPH_G2O])
