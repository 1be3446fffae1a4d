"""Export the factor graph in g2o's text format, so that ``gtsam.readG2o`` reads it back.

Written for GTSAM's own reader (``gtsam.readG2o``, ``gtsam/slam/dataset.cpp``), in g2o's record
types wherever one exists; every number at full precision (``repr``), so what the reader gets
back is the graph, not a rounding of it:

* vertices, renumbered so that every vertex has its own id (g2o needs unique ids; a ``Symbol``
  key's bare index would make pose x5 and landmark l5 collide): poses 0..N-1 in frame order,
  then landmarks N..N+M-1 in id order. ``VERTEX_SE2 i x y theta`` / ``VERTEX_SE3:QUAT i x y z
  qx qy qz qw`` (omni graphs: the Pose3 *sensor viewpoints*), ``VERTEX_XY j x y`` /
  ``VERTEX_TRACKXYZ j x y z``. ``gtsam.readG2o`` returns poses at key ``i``, landmarks at
  ``L(j)``.
* odometry: ``EDGE_SE2 i j dx dy dtheta`` + the upper triangle of the information
  (``BetweenFactorPose2``), ``EDGE_SE3:QUAT i j t q`` + the information in g2o's (t, R) block
  order (``BetweenFactorPose3``; gtsam's tangent order is (R, t) -- the reader swaps back).
* range-bearing sightings: ``BR i j bearing range sigma_bearing sigma_range``, gtsam's record
  of a ``BearingRangeFactor2D`` (the reader turns it into exactly that factor). g2o proper has no
  bearing-range edge (``EDGE_SE2_XY`` is a Cartesian point, a linearisation of it), so a g2o
  tool skips these lines.
* 2-D bearings (vertical lines): ``EDGE_BEARING_SE2_XY i j bearing information``, g2o's exact
  type of a ``BearingFactor2D``; ``gtsam.readG2o`` has no bearing-only record and skips it.

Not written, because neither reader has a record for them (``G2oExport`` counts them):

* priors -- the first pose's (the gauge), the omni planar priors (z, roll, pitch) and the weak
  landmark priors. g2o's tools fix the gauge by holding a vertex fixed; a gtsam user adds a
  prior on vertex 0 (as gtsam's ``Pose2SLAMExample_g2o`` does). g2o's ``FIX`` line is not
  written either: ``gtsam.readG2o``'s 2-D parser reads two integers after *any* tag it does not
  know (its bearing-range parser extracts the ids before checking the tag), so ``FIX 0`` -- or
  a ``#`` comment -- puts its stream into a failed state and every factor after it is lost;
* ``BearingFactor3D`` (omni bearings): a unit bearing has no g2o edge type. An omni graph's file
  is therefore its pose graph and its landmark positions, without the sightings that tie them.

Robust kernels are not written either (g2o sets them in the solver, not in the file; counted
in ``kernels_dropped``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from omnislam._optional import require

gtsam = require("gtsam")

#: the RUN_DIR file name of the export (``harness.layout.GRAPH_G2O``)
G2O_ATTACHMENT = "graph.g2o"

#: g2o's (tx, ty, tz, rx, ry, rz) in gtsam's Pose3 tangent order (rx, ry, rz, tx, ty, tz)
_G2O_FROM_GTSAM_POSE3 = np.array([3, 4, 5, 0, 1, 2])


@dataclass(frozen=True, slots=True)
class G2oExport:
    """A graph in g2o text and what went into it.

    Attributes:
        text: the file's content.
        poses: pose vertices written.
        landmarks: landmark vertices written.
        odometry_edges: ``EDGE_SE2`` / ``EDGE_SE3:QUAT`` lines (read by ``gtsam.readG2o``).
        range_bearing_edges: ``BR`` lines (read by ``gtsam.readG2o``).
        bearing_edges: ``EDGE_BEARING_SE2_XY`` lines (g2o's; skipped by ``gtsam.readG2o``).
        priors_skipped: prior factors not written (no record in either reader).
        bearings_3d_skipped: ``BearingFactor3D`` not written (no g2o edge type).
        others_skipped: any other factor not written (none in graphs ``GraphSLAM`` builds).
        kernels_dropped: written edges whose robust kernel the file cannot carry.
        vertex_of_key: GTSAM key -> g2o vertex id.
    """

    text: str = field(repr=False)
    poses: int
    landmarks: int
    odometry_edges: int = 0
    range_bearing_edges: int = 0
    bearing_edges: int = 0
    priors_skipped: int = 0
    bearings_3d_skipped: int = 0
    others_skipped: int = 0
    kernels_dropped: int = 0
    vertex_of_key: dict[int, int] = field(default_factory=dict, repr=False)

    @property
    def factors_read_by_gtsam(self) -> int:
        """The factors ``gtsam.readG2o`` builds from the file."""
        return self.odometry_edges + self.range_bearing_edges

    @property
    def factors_skipped(self) -> int:
        """The graph's factors that are not in the file."""
        return self.priors_skipped + self.bearings_3d_skipped + self.others_skipped


def _num(value: float) -> str:
    """Shortest text that reads back as the same double."""
    return repr(float(value))


def _line(tag: str, ids: tuple[int, ...], numbers: Any) -> str:
    return " ".join([tag, *map(str, ids), *map(_num, numbers)])


def _is_pose_key(key: int) -> bool:
    return chr(gtsam.Symbol(key).chr()) == "x"


def _is_pose3(values: Any, key: int) -> bool:
    try:
        values.atPose3(key)
    except RuntimeError:
        return False
    return True


def _upper_triangle(matrix: np.ndarray) -> np.ndarray:
    """Row-major upper triangle (with the diagonal) of a square matrix."""
    return matrix[np.triu_indices(len(matrix))]


_PRIORS = (
    gtsam.PriorFactorPose2,
    gtsam.PriorFactorPose3,
    gtsam.PriorFactorPoint2,
    gtsam.PriorFactorPoint3,
)


class _Writer:
    """Accumulates the lines and counts of one export."""

    def __init__(self, vertex: dict[int, int]) -> None:
        self.vertex = vertex
        self.lines: list[str] = []
        self.counts = dict.fromkeys(
            (
                "odometry_edges",
                "range_bearing_edges",
                "bearing_edges",
                "priors_skipped",
                "bearings_3d_skipped",
                "others_skipped",
                "kernels_dropped",
            ),
            0,
        )

    def _base_noise(self, factor: Any) -> Any:
        """The factor's Gaussian noise model (a robust kernel is dropped and counted)."""
        model = factor.noiseModel()
        if isinstance(model, gtsam.noiseModel.Robust):
            self.counts["kernels_dropped"] += 1
            return model.noise()
        return model

    def factor(self, factor: Any) -> None:
        """Write one factor (or count it as skipped)."""
        if isinstance(factor, gtsam.BetweenFactorPose2):
            self._between_pose2(factor)
        elif isinstance(factor, gtsam.BetweenFactorPose3):
            self._between_pose3(factor)
        elif isinstance(factor, gtsam.BearingRangeFactor2D) and self._diagonal(factor):
            self._bearing_range_2d(factor)
        elif isinstance(factor, gtsam.BearingFactor2D):
            self._bearing_2d(factor)
        elif isinstance(factor, _PRIORS):
            self.counts["priors_skipped"] += 1
        elif isinstance(factor, gtsam.BearingFactor3D):
            self.counts["bearings_3d_skipped"] += 1
        else:
            self.counts["others_skipped"] += 1

    def _ids(self, factor: Any) -> tuple[int, int]:
        first, second = factor.keys()
        return self.vertex[first], self.vertex[second]

    def _between_pose2(self, factor: Any) -> None:
        measured = factor.measured()
        information = self._base_noise(factor).information()
        self.lines.append(
            _line(
                "EDGE_SE2",
                self._ids(factor),
                [measured.x(), measured.y(), measured.theta(), *_upper_triangle(information)],
            )
        )
        self.counts["odometry_edges"] += 1

    def _between_pose3(self, factor: Any) -> None:
        measured = factor.measured()
        q = measured.rotation().toQuaternion()
        information = self._base_noise(factor).information()
        g2o_order = information[np.ix_(_G2O_FROM_GTSAM_POSE3, _G2O_FROM_GTSAM_POSE3)]
        self.lines.append(
            _line(
                "EDGE_SE3:QUAT",
                self._ids(factor),
                [
                    *np.asarray(measured.translation()),
                    q.x(),
                    q.y(),
                    q.z(),
                    q.w(),
                    *_upper_triangle(g2o_order),
                ],
            )
        )
        self.counts["odometry_edges"] += 1

    def _diagonal(self, factor: Any) -> bool:
        """True when a factor's (base) noise is diagonal, as the ``BR`` record's is."""
        model = factor.noiseModel()
        if isinstance(model, gtsam.noiseModel.Robust):
            model = model.noise()
        return isinstance(model, gtsam.noiseModel.Diagonal)

    def _bearing_range_2d(self, factor: Any) -> None:
        measured = factor.measured()
        sigma_bearing, sigma_range = self._base_noise(factor).sigmas()
        self.lines.append(
            _line(
                "BR",
                self._ids(factor),
                [measured.bearing().theta(), measured.range(), sigma_bearing, sigma_range],
            )
        )
        self.counts["range_bearing_edges"] += 1

    def _bearing_2d(self, factor: Any) -> None:
        (sigma,) = self._base_noise(factor).sigmas()
        self.lines.append(
            _line(
                "EDGE_BEARING_SE2_XY",
                self._ids(factor),
                [factor.measured().theta(), sigma**-2],
            )
        )
        self.counts["bearing_edges"] += 1


def format_g2o(graph: Any, values: Any) -> G2oExport:
    """The g2o text of ``graph`` at ``values`` (as built by ``GraphSLAM``).

    Args:
        graph: ``gtsam.NonlinearFactorGraph`` (e.g. ``GraphSLAM.factor_graph()``).
        values: ``gtsam.Values`` holding every variable of ``graph`` (e.g. ``GraphSLAM.values()``).

    Returns:
        The text, what it holds and the key -> vertex numbering (see ``G2oExport``).
    """
    keys = sorted(int(k) for k in values.keys())
    pose_keys = [k for k in keys if _is_pose_key(k)]
    landmark_keys = [k for k in keys if not _is_pose_key(k)]
    vertex = {k: i for i, k in enumerate(pose_keys + landmark_keys)}
    pose3 = bool(pose_keys) and _is_pose3(values, pose_keys[0])

    lines = []
    for k in pose_keys:
        if pose3:
            pose = values.atPose3(k)
            q = pose.rotation().toQuaternion()
            numbers = [*np.asarray(pose.translation()), q.x(), q.y(), q.z(), q.w()]
            lines.append(_line("VERTEX_SE3:QUAT", (vertex[k],), numbers))
        else:
            pose = values.atPose2(k)
            lines.append(_line("VERTEX_SE2", (vertex[k],), [pose.x(), pose.y(), pose.theta()]))
    for k in landmark_keys:
        # Point2 and Point3 are both stored as vectors (and gtsam.utilities.extractPoint2/3
        # count every vector value, leaving the other kind's rows uninitialised)
        point = np.asarray(values.atVector(k))
        tag = "VERTEX_XY" if len(point) == 2 else "VERTEX_TRACKXYZ"
        lines.append(_line(tag, (vertex[k],), point))

    writer = _Writer(vertex)
    for index in range(graph.size()):
        factor = graph.at(index)
        if factor is not None:
            writer.factor(factor)
    text = "\n".join(lines + writer.lines) + "\n" if lines or writer.lines else ""
    return G2oExport(
        text=text,
        poses=len(pose_keys),
        landmarks=len(landmark_keys),
        vertex_of_key=vertex,
        **writer.counts,
    )


def write_g2o(graph: Any, values: Any, path: str | Path) -> G2oExport:
    """Write ``format_g2o(graph, values)`` to ``path`` and return it."""
    export = format_g2o(graph, values)
    Path(path).write_text(export.text, encoding="utf-8")
    return export
