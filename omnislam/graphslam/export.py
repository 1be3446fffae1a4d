"""Export the factor graph in g2o's text format.

The pose graph (Pose2 / Pose3 vertices and odometry ``BetweenFactor`` edges) is written by
``gtsam.writeG2o`` (``VERTEX_SE2`` / ``EDGE_SE2`` or ``VERTEX_SE3:QUAT`` / ``EDGE_SE3:QUAT``).
``gtsam.writeG2o`` skips landmarks and every other factor, and writes a ``Symbol`` key as its
bare index (so pose x5 and landmark l5 would collide); therefore vertices are renumbered first,
poses 0..N-1 in frame order, then landmarks N..N+M-1 in id order, and the landmark part is
appended here in g2o's own types:

* 2-D: ``VERTEX_XY id x y`` per landmark and ``EDGE_SE2_XY pose landmark dx dy I11 I12 I22``
  per ``BearingRangeFactor2D``: the sighting as a point in the pose frame,
  ``(r cos b, r sin b)``, with information ``(J R J^T)^-1`` (J the polar-to-Cartesian
  Jacobian at the measurement) -- the inverse of what gtsam's ``load2D`` does with LANDMARK
  records.
* 3-D: ``VERTEX_TRACKXYZ id x y z`` per landmark. ``BearingFactor3D`` and ``BearingFactor2D``
  have no g2o edge type (a bearing is not a point): they are **not written**, and neither are
  the priors (g2o fixes the gauge by holding a vertex fixed). ``G2oExport`` counts what was
  skipped so a caller can say so.

Robust kernels are not written (g2o sets them in the solver, not in the file). Precision:
``gtsam.writeG2o`` prints 6 significant digits; the appended landmark lines print 9.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from omnislam._optional import require

gtsam = require("gtsam")


@dataclass(frozen=True, slots=True)
class G2oExport:
    """What ``write_g2o`` wrote.

    Attributes:
        path: the file.
        poses: pose vertices written.
        landmarks: landmark vertices written.
        odometry_edges: pose-pose edges written.
        landmark_edges: pose-landmark edges written (2-D range-bearing only).
        factors_skipped: factors with no g2o type (priors, bearing-only factors).
        vertex_of_key: GTSAM key -> g2o vertex id.
    """

    path: Path
    poses: int
    landmarks: int
    odometry_edges: int
    landmark_edges: int
    factors_skipped: int
    vertex_of_key: dict[int, int]


def _is_pose_key(key: int) -> bool:
    return chr(gtsam.Symbol(key).chr()) == "x"


def write_g2o(graph: Any, values: Any, path: str | Path) -> G2oExport:
    """Write ``graph`` at ``values`` (as built by ``GraphSLAM``) to a g2o file.

    Args:
        graph: ``gtsam.NonlinearFactorGraph`` (e.g. ``GraphSLAM.factor_graph()``).
        values: ``gtsam.Values`` holding every variable (e.g. ``GraphSLAM.values()``).
        path: output file.

    Returns:
        The counts and the key -> vertex numbering (see ``G2oExport``).
    """
    path = Path(path)
    keys = sorted(int(k) for k in values.keys())
    pose_keys = [k for k in keys if _is_pose_key(k)]
    landmark_keys = [k for k in keys if not _is_pose_key(k)]
    vertex = {k: i for i, k in enumerate(pose_keys + landmark_keys)}

    pose_graph = gtsam.NonlinearFactorGraph()
    pose_values = gtsam.Values()
    for k in pose_keys:
        if values.exists(k) and _is_pose3(values, k):
            pose_values.insert(vertex[k], values.atPose3(k))
        else:
            pose_values.insert(vertex[k], values.atPose2(k))
    landmark_lines: list[str] = []
    skipped = 0
    for index in range(graph.size()):
        factor = graph.at(index)
        if factor is None:
            continue
        if isinstance(factor, gtsam.BetweenFactorPose2 | gtsam.BetweenFactorPose3):
            i, j = factor.keys()
            pose_graph.add(factor.rekey([vertex[i], vertex[j]]))
        elif isinstance(factor, gtsam.BearingRangeFactor2D):
            pose, landmark = factor.keys()
            landmark_lines.append(_edge_se2_xy(vertex[pose], vertex[landmark], factor))
        else:
            skipped += 1
    gtsam.writeG2o(pose_graph, pose_values, str(path))

    vertex_lines = []
    for k in landmark_keys:
        point = np.asarray(_point(values, k))
        tag = "VERTEX_XY" if point.shape[0] == 2 else "VERTEX_TRACKXYZ"
        vertex_lines.append(f"{tag} {vertex[k]} " + " ".join(f"{c:.9g}" for c in point))
    with open(path, "a", encoding="utf-8") as stream:
        for line in vertex_lines + landmark_lines:
            stream.write(line + "\n")
    return G2oExport(
        path=path,
        poses=len(pose_keys),
        landmarks=len(landmark_keys),
        odometry_edges=int(pose_graph.size()),
        landmark_edges=len(landmark_lines),
        factors_skipped=skipped,
        vertex_of_key=vertex,
    )


def _is_pose3(values: Any, key: int) -> bool:
    try:
        values.atPose3(key)
    except RuntimeError:
        return False
    return True


def _point(values: Any, key: int) -> Any:
    try:
        return values.atPoint2(key)
    except RuntimeError:
        return values.atPoint3(key)


def _edge_se2_xy(pose_vertex: int, landmark_vertex: int, factor: Any) -> str:
    """``EDGE_SE2_XY`` line of a bearing-range sighting (see the module docstring)."""
    measured = factor.measured()
    bearing, range_m = measured.bearing().theta(), measured.range()
    sigma_bearing, sigma_range = factor.noiseModel().sigmas()
    c, s = np.cos(bearing), np.sin(bearing)
    J = np.array([[c, -range_m * s], [s, range_m * c]])  # d(x, y) / d(range, bearing)
    info = np.linalg.inv(J @ np.diag([sigma_range**2, sigma_bearing**2]) @ J.T)
    numbers = [range_m * c, range_m * s, info[0, 0], info[0, 1], info[1, 1]]
    return f"EDGE_SE2_XY {pose_vertex} {landmark_vertex} " + " ".join(f"{v:.9g}" for v in numbers)
