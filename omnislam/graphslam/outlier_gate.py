"""The outlier gate on range-bearing sightings of mapped landmarks with given ids.

A sighting of a landmark already in the graph is tested before its factor is added: its
innovation at the frame's pose guess against the landmark's current estimate, with the
covariance of both read from iSAM2 (``joint_state``), ``S = H P H^T + R`` with H the Jacobian
with respect to (pose k, landmark) (``core.compatibility.Pairings.individual``), beyond the
chi-square quantile of ``LandmarkConfig.outlier_gate_probability`` drops it (counted). A
landmark with fewer than ``outlier_gate_min_sightings`` sightings in the graph is gated
``core.gating.YOUNG_GATE_FACTOR`` times wider: its linearised estimate is not trusted near the
gate.

A sighting of a landmark past the young stage that the gate rejects is held
(``core.gating.GatedResightings``): once ``outlier_gate_votes`` held sightings of the landmark
agree on one point, they all enter the graph (readmitted) -- the pose was wrong, not the
sightings. One whose point lies on another landmark is a misread id and is dropped for good.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from omnislam.core.compatibility import Pairings
from omnislam.core.gating import (
    YOUNG_GATE_FACTOR,
    GatedResightings,
    Resighting,
    chi_square_gate,
    lies_on_a_landmark,
)
from omnislam.core.measurement import RangeBearing2D
from omnislam.core.types import RangeBearing
from omnislam.graphslam import factors as fx
from omnislam.graphslam.association import sighting_points
from omnislam.graphslam.builder import LandmarkRegistry
from omnislam.graphslam.config import LandmarkConfig
from omnislam.graphslam.joint_state import joint_state
from omnislam.graphslam.poses import PlanarPoses
from omnislam.graphslam.session import ISAM2Session

_RANGE_BEARING = RangeBearing2D()

#: a gated sighting is a misread id when the point it implies lies on another landmark; the
#: landmarks searched are those whose cached position (the insertion point, refreshed where
#: the association reads them) lies within this distance of that point [m]
MISREAD_RADIUS_M = 10.0


class OutlierGate:
    """Gates the sightings of mapped landmarks and holds the rejected ones (module docstring).

    Args:
        config: the landmarks' section (``outlier_gate_probability``,
            ``outlier_gate_min_sightings``, ``outlier_gate_votes``).
        session: the iSAM2 session (the joint marginal of the pose and the landmarks).
        poses: the planar pose chain (the odometry since the newest key frame).
        registry: the landmarks in the graph.
        noise: the landmark factors' noise models (for the factors of held sightings).
    """

    def __init__(
        self,
        config: LandmarkConfig,
        session: ISAM2Session,
        poses: PlanarPoses,
        registry: LandmarkRegistry,
        noise: fx.NoiseModels,
    ) -> None:
        self._session = session
        self._poses = poses
        self._registry = registry
        self._noise = noise
        self._min_sightings = config.outlier_gate_min_sightings
        self.gate = chi_square_gate(config.outlier_gate_probability, 2)
        self._resightings = GatedResightings(self.gate, config.outlier_gate_votes)
        self._rejected = 0

    @property
    def enabled(self) -> bool:
        """False when the gate is infinite (``outlier_gate_probability`` = 1)."""
        return bool(self.gate < np.inf)

    @property
    def rejected(self) -> int:
        """Sightings the gate rejected (readmitted ones included)."""
        return self._rejected

    @property
    def readmitted(self) -> int:
        """Rejected sightings that entered the graph with agreeing re-sightings."""
        return self._resightings.readmitted

    def seen(self, landmark_id: int, k: int) -> None:
        """A sighting of ``landmark_id`` in frame k entered the graph."""
        self._resightings.seen(landmark_id, k)

    def apply(
        self,
        k: int,
        rows: np.ndarray,
        sightings: RangeBearing,
        guess_w: np.ndarray,
        in_graph: Mapping[int, int],
    ) -> tuple[np.ndarray, list[tuple[int, Resighting]]]:
        """Gate frame k's sightings ``rows`` of mapped landmarks.

        Args:
            k: the frame being added (its pose is not in iSAM2 yet).
            rows: the rows of ``sightings`` whose landmark is in the graph.
            sightings: the frame's sightings.
            guess_w: (3,) the frame's pose guess.
            in_graph: landmark id -> its sightings in the graph.

        Returns:
            (the rows rejected, the held sightings readmitted now with their landmark ids, in
            the order their factors are to be added).
        """
        young = np.array(
            [
                in_graph.get(lid, 0) < self._min_sightings
                for lid in sightings.landmark_ids[rows].tolist()
            ]
        )
        gates = np.where(young, YOUNG_GATE_FACTOR * self.gate, self.gate)
        inside = self._inside(k, rows, sightings, gates)
        readmitted: list[tuple[int, Resighting]] = []
        # a young landmark's gate is 10x wider already: its gated sightings never vote
        for row in rows[~inside & ~young].tolist():
            readmitted += self._hold(k, row, sightings, guess_w)
        return rows[~inside], readmitted

    def _inside(
        self, k: int, rows: np.ndarray, sightings: RangeBearing, gates: np.ndarray
    ) -> np.ndarray:
        """(len(rows),) True for the sightings ``rows`` inside their gate (module docstring)."""
        lids = sightings.landmark_ids[rows].tolist()
        state = joint_state(self._session, [], lids, (k, *self._poses.odometry_step()))
        pose_col = state.pose_column[k]
        K = len(rows)
        nu = np.zeros((K, 1, 2))
        H = np.zeros((K, 1, 2, state.dim))
        R = np.zeros((K, 2, 2))
        for i, (row, lid) in enumerate(zip(rows.tolist(), lids, strict=True)):
            z_hat, H_r, H_l = _RANGE_BEARING.predict(state.pose(k), state.landmark(lid))
            z = np.array([sightings.ranges_m[row], sightings.bearings_rad[row]])
            nu[i, 0] = _RANGE_BEARING.residual(z, z_hat)
            H[i, 0, :, pose_col : pose_col + 3] = H_r
            col = state.landmark_column[lid]
            H[i, 0, :, col : col + 2] = H_l
            R[i] = np.diag(
                [sightings.sigma_range_m[row] ** 2, sightings.sigma_bearing_rad[row] ** 2]
            )
        d2 = Pairings(nu, H, state.covariance, R).individual()[:, 0]
        inside = d2 <= gates
        self._rejected += int(np.sum(~inside))
        return inside

    def _hold(
        self, k: int, row: int, sightings: RangeBearing, guess_w: np.ndarray
    ) -> list[tuple[int, Resighting]]:
        """Hold a rejected sighting of a landmark past the young stage; the held sightings of
        its landmark that now enter the graph with it (none while too few agree, or when the
        point it implies lies on another landmark: a misread id, dropped)."""
        lid = int(sightings.landmark_ids[row])
        r, b = float(sightings.ranges_m[row]), float(sightings.bearings_rad[row])
        s_r, s_b = float(sightings.sigma_range_m[row]), float(sightings.sigma_bearing_rad[row])
        points, covs = sighting_points(guess_w, *map(np.atleast_1d, (r, b, s_r, s_b)))
        if lies_on_a_landmark(points[0], covs[0], self._landmarks_near(points[0], lid), self.gate):
            return []
        factor: Any = fx.bearing_range_2d(k, lid, b, r, self._noise.diagonal(s_b, s_r))
        held = self._resightings.offer(lid, Resighting(k, points[0], covs[0], factor))
        return [(lid, resighting) for resighting in held]

    def _landmarks_near(self, point_w: np.ndarray, other_than: int) -> np.ndarray:
        """(M, 2) the current estimates of the active landmarks within ``MISREAD_RADIUS_M`` of
        ``point_w`` (by their cached positions), ``other_than`` excluded."""
        cached = self._registry.xy
        rows = np.flatnonzero(np.hypot(*(cached - point_w).T) <= MISREAD_RADIUS_M)
        points = []
        for row in rows.tolist():
            lid = self._registry.id_at(row)
            if lid == other_than or not self._registry.active(lid):
                continue
            key = fx.landmark_key(lid)
            points.append(self._session.point2(key) if self._session.exists(key) else cached[row])
        return np.asarray(points, dtype=float).reshape(-1, 2)
