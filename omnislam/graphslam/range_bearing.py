"""Graph builder of 2-D range-bearing sightings (``Modality.RANGE_BEARING_2D``).

Each sighting becomes a ``BearingRangeFactor2D(pose, point)`` on the ``Pose2`` chain
(MR.CLAM barcodes, Victoria Park trees, synthetic poles, laser landmarks). A range-bearing
sighting fixes a planar landmark on its own, so:

* **given ids**: a new landmark enters on its first sighting at ``inverse(guess, z)``
  (``RangeBearing2D.inverse``), or, with ``LandmarkConfig.min_consistent_sightings`` > 1, once
  that many of its sightings agree (``landmark_init.ConsistentInsertion``, against wrong ids);
  a sighting of a mapped landmark passes the outlier gate first (``outlier_gate.py``);
* **unknown ids** (``UNKNOWN_ID``): the sightings are associated first, by joint
  compatibility over a window of frames (``window_association.py``) or nearest neighbour
  (``nearest_association.py``; ``AssociationConfig.test``). A sighting that matches takes the
  landmark's id; one beyond the new-landmark gate starts a landmark with an id from
  ``CREATED_ID_BASE`` upwards (never colliding with given ids) -- at once, or as a tentative
  landmark until re-observed (``tentative.py``, ``AssociationConfig.tentative_min_sightings``
  > 1); one between the gates is dropped as ambiguous. Landmarks started so that duplicate
  older ones can be merged (``loop_closure.py``, experimental).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from omnislam._optional import require
from omnislam.core.compatibility import Decision
from omnislam.core.measurement import RangeBearing2D
from omnislam.core.modality import Modality
from omnislam.core.types import UNKNOWN_ID, RangeBearing
from omnislam.graphslam import factors as fx
from omnislam.graphslam.association import AMBIGUOUS, NEW_LANDMARK, Gates, sighting_points
from omnislam.graphslam.builder import LandmarkRegistry, SightingCounts
from omnislam.graphslam.config import (
    AssociationConfig,
    AssociationTest,
    LandmarkConfig,
    LoopClosureConfig,
)
from omnislam.graphslam.landmark_init import ConsistentInsertion
from omnislam.graphslam.loop_closure import LandmarkMerger
from omnislam.graphslam.nearest_association import NearestAssociation
from omnislam.graphslam.outlier_gate import OutlierGate
from omnislam.graphslam.poses import PlanarPoses
from omnislam.graphslam.session import ISAM2Session
from omnislam.graphslam.tentative import TentativeLandmarks, TentativeStats
from omnislam.graphslam.window_association import Decided, WindowAssociation

gtsam = require("gtsam")


#: first id given to a landmark created by the association of unlabelled sightings
CREATED_ID_BASE = 1_000_000_000

_RANGE_BEARING = RangeBearing2D()


class RangeBearingGraph:
    """Range-bearing sightings -> ``BearingRangeFactor2D`` and ``Point2`` landmarks.

    Args:
        landmarks: the landmarks' section (consistent insertion, outlier gate).
        association: the association's section (test, gates, tentative stage).
        noise: the landmark factors' noise models (with the solver's robust kernel).
        poses: the planar pose chain of the graph (the newest pose for the association).
        session: the iSAM2 session (marginals and landmark estimates for the association).
        loop_closure: the merging of duplicated created landmarks
            (``ExperimentalConfig.loop_closure``; off by default).
        landmark_marginals: the NEAREST test's candidates take their iSAM2 marginals
            (``ExperimentalConfig.association_landmark_marginals``).
    """

    modality = Modality.RANGE_BEARING_2D

    def __init__(
        self,
        landmarks: LandmarkConfig,
        association: AssociationConfig,
        noise: fx.NoiseModels,
        poses: PlanarPoses,
        session: ISAM2Session,
        loop_closure: LoopClosureConfig | None = None,
        landmark_marginals: bool = False,
    ) -> None:
        self._poses = poses
        self._session = session
        self._noise = noise
        self._delay = landmarks.min_consistent_sightings > 1
        self._registry = LandmarkRegistry()
        self._gate = OutlierGate(landmarks, session, poses, self._registry, noise)
        self._consistent = ConsistentInsertion(
            landmarks.min_consistent_sightings,
            Gates.from_probabilities(
                association.gate_probability, association.new_landmark_probability
            ).match,
            release_disagreeing=not np.isfinite(self._gate.gate),
        )
        self._tentative = (
            TentativeLandmarks(association.tentative_min_sightings,
                               association.tentative_window_frames)
            if association.tentative_min_sightings > 1
            else None
        )
        self._in_graph: dict[int, int] = {}  # landmark id -> its sightings in the graph
        joint = association.test is AssociationTest.JOINT
        self._window = (
            WindowAssociation(association, session, self._registry, self._tentative, self._pose_of)
            if joint
            else None
        )
        self._nearest = (
            None
            if joint
            else NearestAssociation(
                association, session, poses, self._registry, self._tentative, landmark_marginals
            )
        )
        self._next_created_id = CREATED_ID_BASE
        self._created = self._associated = self._ambiguous = self._jointly_rejected = 0
        self._merger = (
            LandmarkMerger(
                loop_closure,
                session,
                self._registry,
                lambda lid: lid >= CREATED_ID_BASE,
                gate_probability=association.gate_probability,
                new_landmark_probability=association.new_landmark_probability,
                ambiguity_margin=association.ambiguity_margin,
                landmark_sigma_m=association.landmark_sigma_m,
            )
            if loop_closure is not None and loop_closure.enabled
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
        mapped = np.array(
            [not u and lid in self._registry for u, lid in zip(unknown, ids.tolist(), strict=True)]
        )
        if mapped.any() and k > 0 and self._gate.enabled:
            rejected, readmitted = self._gate.apply(
                k, np.flatnonzero(mapped), sightings, guess_w, self._in_graph
            )
            for lid, held in readmitted:
                graph.add(held.payload)
                self._in_graph[lid] += 1
                if self._merger is not None:
                    self._merger.seen(lid, held.frame)
            ids[rejected] = UNKNOWN_ID
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
                self._gate.seen(lid, k)
                continue
            if lid in created and self._tentative is not None:  # unlabelled: wait for more
                row = unknown_row[i]
                commitment = self._tentative.add(lid, k, points_w[row], covariances_w[row], factor)
                if commitment is not None:
                    self._insert(lid, commitment.point_w, commitment.factors, graph, values)
                continue
            if not self._delay or lid in created:
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
        """Ids for the unlabelled sightings ``rows`` by the NEAREST test: matched, new or
        UNKNOWN_ID (ambiguous). A new id is registered in the graph by the caller (at once, or
        through the tentative stage).

        Returns:
            (ids (K,), the sightings' world points (K, 2) and covariances (K, 2, 2)).
        """
        assert self._nearest is not None
        match = self._nearest.associate(k, _subset(sightings, rows), guess_w)
        out = np.full(len(rows), UNKNOWN_ID, dtype=np.int64)
        for i, index in enumerate(match.indices.tolist()):
            if index >= 0:
                out[i] = match.candidate_ids[index]
                self._associated += 1
            elif index == NEW_LANDMARK:
                out[i] = self._next_created_id
                self._next_created_id += 1
                self._created += 1
            elif index == AMBIGUOUS:
                self._ambiguous += 1
        return out, match.points_w, match.covariances_w

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
            sightings_gated=self._gate.rejected
            - self._gate.readmitted
            + self._consistent.rejected
            + self._jointly_rejected,
            sightings_readmitted=self._gate.readmitted,
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
