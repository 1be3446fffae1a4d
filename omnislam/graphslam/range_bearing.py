"""Graph builder of 2-D range-bearing sightings (``Modality.RANGE_BEARING_2D``).

Each sighting becomes a ``BearingRangeFactor2D(pose, point)`` on the ``Pose2`` chain
(MR.CLAM barcodes, Victoria Park trees, synthetic poles, laser landmarks). A range-bearing
sighting fixes a planar landmark on its own, so:

* **given ids**: a new landmark enters on its first sighting at ``inverse(guess, z)``
  (``RangeBearing2D.inverse``), or, with ``min_consistent_sightings`` > 1, once that many of
  its sightings agree (``landmark_init.ConsistentInsertion``, against wrong ids);
* **unknown ids** (``UNKNOWN_ID``): the sightings are associated first (``association.py``:
  nearest neighbour in a Mahalanobis gate including the newest pose's marginal). A sighting
  that matches takes the landmark's id; one beyond the new-landmark gate starts a landmark with
  an id from ``CREATED_ID_BASE`` upwards (never colliding with given ids) -- at once, or as a
  tentative landmark until re-observed (``tentative.py``, ``association_min_sightings`` > 1);
  one between the gates is dropped as ambiguous.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from omnislam._optional import require
from omnislam.core.compatibility import Decision, Pairings
from omnislam.core.gating import (
    YOUNG_GATE_FACTOR,
    GatedResightings,
    Resighting,
    chi_square_gate,
    lies_on_a_landmark,
)
from omnislam.core.measurement import RangeBearing2D
from omnislam.core.modality import Modality
from omnislam.core.types import UNKNOWN_ID, RangeBearing
from omnislam.graphslam import factors as fx
from omnislam.graphslam.association import (
    AMBIGUOUS,
    NEW_LANDMARK,
    Gates,
    associate,
    mahalanobis2,
    sighting_points,
)
from omnislam.graphslam.builder import LandmarkRegistry, SightingCounts
from omnislam.graphslam.config import AssociationTest, GraphSLAMConfig
from omnislam.graphslam.joint_state import joint_state
from omnislam.graphslam.landmark_init import ConsistentInsertion
from omnislam.graphslam.loop_closure import LandmarkMerger
from omnislam.graphslam.poses import PlanarPoses
from omnislam.graphslam.session import ISAM2Session
from omnislam.graphslam.tentative import TentativeLandmarks, TentativeStats
from omnislam.graphslam.window_association import Decided, WindowAssociation

gtsam = require("gtsam")


#: first id given to a landmark created by the association of unlabelled sightings
CREATED_ID_BASE = 1_000_000_000

_RANGE_BEARING = RangeBearing2D()

#: a gated sighting is a misread id when the point it implies lies on another landmark; the
#: landmarks searched are those whose cached position (the insertion point, refreshed where
#: the association reads them) lies within this distance of that point [m]
MISREAD_RADIUS_M = 10.0


class RangeBearingGraph:
    """Range-bearing sightings -> ``BearingRangeFactor2D`` and ``Point2`` landmarks.

    Args:
        config: settings (consistent insertion, association gates and covariances, tentative
            stage, robust kernel).
        poses: the planar pose chain of the graph (the newest pose for the association).
        session: the iSAM2 session (marginals and landmark estimates for the association).
    """

    modality = Modality.RANGE_BEARING_2D

    def __init__(self, config: GraphSLAMConfig, poses: PlanarPoses, session: ISAM2Session) -> None:
        self._config = config
        self._poses = poses
        self._session = session
        self._noise = fx.NoiseModels(*config.landmark_kernel(self.modality))
        self._gates = Gates.from_probabilities(
            config.association_gate_probability, config.new_landmark_probability
        )
        self._outlier_gate = chi_square_gate(config.outlier_gate_probability, 2)
        self._consistent = ConsistentInsertion(
            config.min_consistent_sightings,
            self._gates.match,
            release_disagreeing=not np.isfinite(self._outlier_gate),
        )
        self._tentative = (
            TentativeLandmarks(config.association_min_sightings, config.association_window_frames)
            if config.association_min_sightings > 1
            else None
        )
        self._rejected = 0
        self._resightings = GatedResightings(self._outlier_gate, config.outlier_gate_votes)
        self._in_graph: dict[int, int] = {}  # landmark id -> its sightings in the graph
        self._registry = LandmarkRegistry()
        self._window = (
            WindowAssociation(config, session, self._registry, self._tentative, self._pose_of)
            if config.association_test is AssociationTest.JOINT
            else None
        )
        self._next_created_id = CREATED_ID_BASE
        self._created = self._associated = self._ambiguous = self._jointly_rejected = 0
        self._merger = (
            LandmarkMerger(config, session, self._registry, lambda lid: lid >= CREATED_ID_BASE)
            if config.loop_closure
            else None
        )

    def add(
        self, k: int, sightings: RangeBearing, guess_w: np.ndarray, graph: Any, values: Any
    ) -> None:
        """Add frame k's sightings (see the module docstring)."""
        ids = sightings.landmark_ids.copy()
        unknown = ids == UNKNOWN_ID
        created: set[int] = set()
        points_w = covariances_w = np.zeros((0, 2))
        if unknown.any() and self._merger is not None and k > 0:
            self._merger.check(k, graph)
        if unknown.any() and self._window is not None:
            rows = np.flatnonzero(unknown)
            waiting = _subset(sightings, rows)
            step = self._poses.odometry_step() if k > 0 else (0, np.zeros(3), np.eye(3))
            for decided in self._window.push(k, waiting, guess_w, step):
                self._add_decided(decided, k, guess_w, graph, values)
        elif unknown.any():
            ids[unknown], points_w, covariances_w = self._associate(
                k, np.flatnonzero(unknown), sightings, guess_w
            )
            created = set(ids[unknown].tolist())
        unknown_row = np.cumsum(unknown) - 1  # row of each unlabelled sighting in points_w
        delay = self._config.min_consistent_sightings > 1
        mapped = np.array(
            [not u and lid in self._registry for u, lid in zip(unknown, ids.tolist(), strict=True)]
        )
        if mapped.any() and k > 0 and self._outlier_gate < np.inf:
            rows = np.flatnonzero(mapped)
            young = np.array(
                [
                    self._in_graph.get(lid, 0) < self._config.outlier_gate_min_sightings
                    for lid in ids[rows].tolist()
                ]
            )
            gates = np.where(young, YOUNG_GATE_FACTOR * self._outlier_gate, self._outlier_gate)
            inside = self._gate_mapped(k, rows, sightings, guess_w, gates)
            # a young landmark's gate is 10x wider already: its gated sightings never vote
            for row in rows[~inside & ~young].tolist():
                self._hold_gated(k, row, sightings, guess_w, graph)
            ids[rows[~inside]] = UNKNOWN_ID
        for i, (lid, r, b, s_r, s_b) in enumerate(
            zip(
                ids.tolist(),
                sightings.ranges_m.tolist(),
                sightings.bearings_rad.tolist(),
                sightings.sigma_range_m.tolist(),
                sightings.sigma_bearing_rad.tolist(),
                strict=True,
            )
        ):
            if lid == UNKNOWN_ID:  # rejected, ambiguous, or waiting in the association window
                continue
            factor = fx.bearing_range_2d(k, lid, b, r, self._noise.diagonal(s_b, s_r))
            if self._merger is not None:
                self._merger.seen(lid, k)
            if lid in self._registry:
                graph.add(factor)
                self._in_graph[lid] += 1
                self._resightings.seen(lid, k)
                continue
            if lid in created and self._tentative is not None:  # unlabelled: wait for more
                row = unknown_row[i]
                commitment = self._tentative.add(lid, k, points_w[row], covariances_w[row], factor)
                if commitment is not None:
                    self._insert(lid, commitment.point_w, commitment.factors, graph, values)
                continue
            if not delay or lid in created:
                xy = _RANGE_BEARING.inverse(guess_w, np.array([r, b]))[0]
                self._insert(lid, xy, (factor,), graph, values)
                continue
            points, covs = sighting_points(guess_w, *map(np.atleast_1d, (r, b, s_r, s_b)))
            self._consistent.hold(lid, points[0], covs[0], factor)
            insertion = self._consistent.try_insert(lid)
            if insertion is not None:
                self._insert(lid, insertion.point_w, insertion.factors, graph, values)

    def finish(self, graph: Any, values: Any) -> bool:
        """Decide every sighting waiting in the association window (all poses in iSAM2).

        Returns:
            True when factors or variables were added to ``graph`` / ``values``.
        """
        if self._window is None or not len(self._window):
            return False
        for decided in self._window.flush():
            self._add_decided(decided, None, None, graph, values)
        return True

    def _pose_of(self, k: int) -> np.ndarray:
        """(3,) iSAM2's current estimate of frame k's pose."""
        return fx.planar_from_pose2(self._session.pose2(fx.pose_key(k)))

    def _add_decided(
        self,
        decided: Decided,
        k_now: int | None,
        guess_w: np.ndarray | None,
        graph: Any,
        values: Any,
    ) -> None:
        """Factors and landmarks of one frame's decided unlabelled sightings.

        Args:
            decided: the frame's decisions (``WindowAssociation``).
            k_now, guess_w: the frame being added and its guess (its pose is not in iSAM2
                yet), or None when every pose is.
        """
        k = decided.k
        rb = decided.sightings
        pose = guess_w if k == k_now else self._pose_of(k)
        pose_cov = None
        new_rows = np.flatnonzero(decided.decisions == Decision.NEW)
        if self._tentative is not None and (len(new_rows) or np.any(decided.candidate_ids >= 0)):
            self._tentative.expire(k)
            if k != k_now:
                pose_cov = self._poses.world_covariance(
                    self._session.marginal_covariance(fx.pose_key(k)), pose[2]
                )
        points, covs = sighting_points(
            pose, rb.ranges_m, rb.bearings_rad, rb.sigma_range_m, rb.sigma_bearing_rad, pose_cov
        )
        for i, decision in enumerate(decided.decisions.tolist()):
            if decision == Decision.AMBIGUOUS:
                self._ambiguous += 1
                continue
            if decision == Decision.REJECTED:
                self._jointly_rejected += 1
                continue
            if decision == Decision.NEW:
                lid = self._next_created_id
                self._next_created_id += 1
                self._created += 1
            else:
                lid = int(decided.candidate_ids[i])
                self._associated += 1
            noise = self._noise.diagonal(rb.sigma_bearing_rad[i], rb.sigma_range_m[i])
            factor = fx.bearing_range_2d(k, lid, rb.bearings_rad[i], rb.ranges_m[i], noise)
            if self._merger is not None:
                self._merger.seen(lid, k)
            if lid in self._registry:
                graph.add(factor)
                self._in_graph[lid] += 1
            elif self._tentative is not None:
                commitment = self._tentative.add(lid, k, points[i], covs[i], factor)
                if commitment is not None:
                    self._insert(lid, commitment.point_w, commitment.factors, graph, values)
            else:
                self._insert(lid, points[i], (factor,), graph, values)

    def _gate_mapped(
        self,
        k: int,
        rows: np.ndarray,
        sightings: RangeBearing,
        guess_w: np.ndarray,
        gates: np.ndarray,
    ) -> np.ndarray:
        """(len(rows),) True for the sightings ``rows`` of mapped landmarks inside the outlier gate.

        The innovation of each sighting at frame k's guess and the landmark's current estimate,
        with the covariance of both read from iSAM2 (``joint_state``):
        ``S = H P H^T + R`` with H the Jacobian with respect to (pose k, landmark)
        (``core.compatibility.Pairings.individual``). Sightings outside are counted as rejected.
        """
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

    def _hold_gated(
        self, k: int, row: int, sightings: RangeBearing, guess_w: np.ndarray, graph: Any
    ) -> None:
        """A sighting of a landmark past the young stage that the outlier gate rejected: held,
        and added with the held sightings of its landmark that agree with it once there are
        enough (``core.gating.GatedResightings``); dropped for good when the point it implies
        lies on another landmark (a misread id)."""
        lid = int(sightings.landmark_ids[row])
        r, b = float(sightings.ranges_m[row]), float(sightings.bearings_rad[row])
        s_r, s_b = float(sightings.sigma_range_m[row]), float(sightings.sigma_bearing_rad[row])
        points, covs = sighting_points(guess_w, *map(np.atleast_1d, (r, b, s_r, s_b)))
        if lies_on_a_landmark(
            points[0], covs[0], self._landmarks_near(points[0], lid), self._outlier_gate
        ):
            return
        factor = fx.bearing_range_2d(k, lid, b, r, self._noise.diagonal(s_b, s_r))
        for held in self._resightings.offer(lid, Resighting(k, points[0], covs[0], factor)):
            graph.add(held.payload)
            self._in_graph[lid] += 1
            if self._merger is not None:
                self._merger.seen(lid, held.frame)

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

    def _insert(self, lid: int, point_w: np.ndarray, factors: Any, graph: Any, values: Any) -> None:
        """A landmark enters the graph at ``point_w`` (2,) with its factors."""
        values.insert(fx.landmark_key(lid), gtsam.Point2(point_w))
        self._registry.add(lid, point_w)
        self._in_graph[lid] = len(factors)
        for factor in factors:
            graph.add(factor)

    def _associate(
        self, k: int, rows: np.ndarray, sightings: RangeBearing, guess_w: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Ids for the unlabelled sightings ``rows``: matched, new or UNKNOWN_ID (ambiguous).

        Candidates are the mapped landmarks near the robot and, with the tentative stage, the
        tentative landmarks. A new id is registered in the graph by the caller (at once, or
        through the tentative stage).

        Returns:
            (ids (K,), the sightings' world points (K, 2) and covariances (K, 2, 2)).
        """
        config = self._config
        pose_cov = None
        if config.association_pose_covariance and k > 0:
            # the newest estimated pose (the previous key frame) is in the root clique: a
            # cheap marginal
            previous = self._session.marginal_covariance(fx.pose_key(self._poses.newest_key))
            pose_cov = self._poses.world_covariance(previous, self._poses.newest_w[2])
        points, covs = sighting_points(
            guess_w,
            sightings.ranges_m[rows],
            sightings.bearings_rad[rows],
            sightings.sigma_range_m[rows],
            sightings.sigma_bearing_rad[rows],
            pose_cov,
        )
        cached = self._registry.xy
        # candidates: landmarks that could fall inside the outer gate (conservative radius)
        spread = config.association_landmark_sigma_m + np.sqrt(
            np.linalg.eigvalsh(covs)[:, -1].max()
        )
        radius = sightings.ranges_m[rows].max() + 3.0 * np.sqrt(self._gates.new_landmark) * spread
        near = np.flatnonzero(np.hypot(*(cached - guess_w[:2]).T) <= radius)
        near = near[[self._registry.active(self._registry.id_at(r)) for r in near.tolist()]]
        for row in near.tolist():  # refresh only these positions from iSAM2
            key = fx.landmark_key(self._registry.id_at(row))
            if self._session.exists(key):
                cached[row] = self._session.point2(key)
        candidate_ids = [self._registry.id_at(row) for row in near.tolist()]
        candidates_xy = cached[near]
        candidate_covs = self._landmark_covariances(near, points, covs)
        if self._tentative is not None:
            self._tentative.expire(k)
            if len(self._tentative):
                tentative_ids, tentative_xy, tentative_covs = self._tentative.candidates()
                candidate_ids += tentative_ids.tolist()
                candidates_xy = np.concatenate([candidates_xy, tentative_xy])
                candidate_covs = np.concatenate([candidate_covs, tentative_covs])
        indices, _ = associate(
            points,
            covs,
            candidates_xy,
            config.association_landmark_sigma_m,
            self._gates,
            candidate_covs,
        )
        out = np.full(len(rows), UNKNOWN_ID, dtype=np.int64)
        for i, index in enumerate(indices.tolist()):
            if index >= 0:
                out[i] = candidate_ids[index]
                self._associated += 1
            elif index == NEW_LANDMARK:
                out[i] = self._next_created_id
                self._next_created_id += 1
                self._created += 1
            elif index == AMBIGUOUS:
                self._ambiguous += 1
        return out, points, covs

    def _landmark_covariances(
        self, rows: np.ndarray, points_w: np.ndarray, point_covariances: np.ndarray
    ) -> np.ndarray:
        """Position covariances (M, 2, 2) of the mapped landmarks ``rows`` for the gate.

        ``sigma_l^2 I`` (``association_landmark_sigma_m``), or with
        ``association_landmark_marginals`` the iSAM2 marginal of each landmark whose distance
        with ``sigma_l`` is within 4x the new-landmark gate of some sighting (a marginal costs a
        back-substitution; the far ones could not match anyway unless their marginal were huge).
        """
        sigma2 = self._config.association_landmark_sigma_m**2
        covariances = np.tile(sigma2 * np.eye(2), (len(rows), 1, 1))
        if not self._config.association_landmark_marginals or not len(rows):
            return covariances
        d2 = mahalanobis2(points_w, point_covariances, self._registry.xy[rows], covariances)
        for j in np.flatnonzero(d2.min(axis=0) <= 4.0 * self._gates.new_landmark).tolist():
            key = fx.landmark_key(self._registry.id_at(int(rows[j])))
            if self._session.exists(key):
                covariances[j] = self._session.marginal_covariance(key)
        return covariances

    def reassociable(self, key: int) -> bool:
        """Whether a landmark key's sightings were decided by the association and may be
        given to another such landmark (``reassociation.py``): a landmark the association
        created, not merged into another."""
        symbol = gtsam.Symbol(key)
        lid = symbol.index()
        return symbol.chr() == ord("l") and lid >= CREATED_ID_BASE and self._registry.active(lid)

    def landmark_ids(self) -> np.ndarray:
        """(M,) ids of the landmarks in the graph, ascending (not those merged into another)."""
        ids = self._registry.sorted_ids()
        return ids[[self._registry.active(i) for i in ids.tolist()]]

    def landmarks(self, values: Any) -> np.ndarray:
        """(M, 3) the ``Point2`` landmarks of ``values`` with z = 0 [m], ``landmark_ids`` order.

        A landmark merged into another (``loop_closure.py``) keeps its variable, tied to the
        other by a merging factor; it is left out.
        """
        points = gtsam.utilities.extractPoint2(values).reshape(-1, 2)
        ids = self._registry.sorted_ids()
        if len(ids) == len(points):
            points = points[[self._registry.active(i) for i in ids.tolist()]]
        return np.column_stack([points, np.zeros(len(points))])

    def counts(self) -> SightingCounts:
        """Counts so far."""
        return SightingCounts(
            landmarks=len(self._registry) - self._registry.retired,
            insertion=self._consistent.stats(),
            landmarks_created=self._created,
            sightings_associated=self._associated,
            sightings_ambiguous=self._ambiguous,
            sightings_gated=self._rejected
            - self._resightings.readmitted
            + self._consistent.rejected
            + self._jointly_rejected,
            sightings_readmitted=self._resightings.readmitted,
            tentative=self._tentative.stats() if self._tentative is not None else TentativeStats(),
            landmarks_merged=0 if self._merger is None else self._merger.merged,
            loop_closures=0 if self._merger is None else self._merger.loop_closures,
        )


def _subset(sightings: RangeBearing, rows: np.ndarray) -> RangeBearing:
    """The sightings ``rows`` of a frame."""
    return RangeBearing(
        sightings.landmark_ids[rows],
        sightings.ranges_m[rows],
        sightings.bearings_rad[rows],
        sightings.sigma_range_m[rows],
        sightings.sigma_bearing_rad[rows],
    )
