"""Nearest-neighbour association of a frame's unlabelled range-bearing sightings against iSAM2.

``AssociationTest.NEAREST`` (``config.py``): each frame's unlabelled sightings are associated
when the frame arrives, one at a time, by ``association.associate`` (a Mahalanobis gate with a
fixed landmark sigma, one landmark per sighting per frame). This module gathers what that gate
is given from the back end:

* the sightings' world points from the frame's pose guess, their covariance including the
  newest estimated pose's iSAM2 marginal (the previous key frame's, in the root clique of the
  Bayes tree: a cheap marginal; without it the drift before a loop closure puts revisited
  landmarks outside the gate and duplicates them);
* the candidates: the mapped landmarks whose cached position lies within a conservative
  radius of the robot (their positions refreshed from iSAM2), and the tentative landmarks
  (``tentative.py``) with the fused covariance of their sightings;
* the candidates' covariances: ``sigma_l^2 I`` (``AssociationConfig.landmark_sigma_m``), or
  with ``ExperimentalConfig.association_landmark_marginals`` the iSAM2 marginal of each
  candidate close enough to matter.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from omnislam.core.types import RangeBearing
from omnislam.graphslam import factors as fx
from omnislam.graphslam.association import Gates, associate, mahalanobis2, sighting_points
from omnislam.graphslam.builder import LandmarkRegistry
from omnislam.graphslam.config import AssociationConfig
from omnislam.graphslam.poses import PlanarPoses
from omnislam.graphslam.session import ISAM2Session
from omnislam.graphslam.tentative import TentativeLandmarks


@dataclass(frozen=True, slots=True)
class NearestMatch:
    """The association of one frame's unlabelled sightings.

    Attributes:
        candidate_ids: (M,) the landmarks offered (mapped, then tentative).
        indices: (K,) per sighting an index into ``candidate_ids``, or
            ``association.NEW_LANDMARK`` / ``association.AMBIGUOUS``.
        points_w: (K, 2) the sightings' world points [m].
        covariances_w: (K, 2, 2) their covariances [m^2].
    """

    candidate_ids: np.ndarray
    indices: np.ndarray
    points_w: np.ndarray
    covariances_w: np.ndarray


class NearestAssociation:
    """Nearest-neighbour association against the landmarks near the robot (module docstring).

    Args:
        config: the association's section (fixed landmark sigma, gate probabilities).
        session: the iSAM2 session (marginals and landmark estimates).
        poses: the planar pose chain (the newest estimated pose).
        registry: the landmarks in the graph.
        tentative: the tentative landmarks (or None without a tentative stage).
        landmark_marginals: the candidates' iSAM2 marginals instead of the fixed sigma
            (``ExperimentalConfig.association_landmark_marginals``).
    """

    def __init__(
        self,
        config: AssociationConfig,
        session: ISAM2Session,
        poses: PlanarPoses,
        registry: LandmarkRegistry,
        tentative: TentativeLandmarks | None,
        landmark_marginals: bool = False,
    ) -> None:
        self._sigma_m = config.landmark_sigma_m
        self._gates = Gates.from_probabilities(
            config.gate_probability, config.new_landmark_probability
        )
        self._session = session
        self._poses = poses
        self._registry = registry
        self._tentative = tentative
        self._landmark_marginals = landmark_marginals

    def associate(self, k: int, sightings: RangeBearing, guess_w: np.ndarray) -> NearestMatch:
        """Associate frame k's unlabelled ``sightings`` seen from ``guess_w`` (3,)."""
        pose_cov = None
        if k > 0:
            # the newest estimated pose (the previous key frame) is in the root clique: a
            # cheap marginal
            previous = self._session.marginal_covariance(fx.pose_key(self._poses.newest_key))
            pose_cov = self._poses.world_covariance(previous, self._poses.newest_w[2])
        points, covs = sighting_points(
            guess_w,
            sightings.ranges_m,
            sightings.bearings_rad,
            sightings.sigma_range_m,
            sightings.sigma_bearing_rad,
            pose_cov,
        )
        near = self._mapped_near(guess_w, float(sightings.ranges_m.max()), covs)
        candidate_ids = [self._registry.id_at(row) for row in near.tolist()]
        candidates_xy = self._registry.xy[near]
        candidate_covs = self._landmark_covariances(near, points, covs)
        if self._tentative is not None:
            self._tentative.expire(k)
            if len(self._tentative):
                tentative_ids, tentative_xy, tentative_covs = self._tentative.candidates()
                candidate_ids += tentative_ids.tolist()
                candidates_xy = np.concatenate([candidates_xy, tentative_xy])
                candidate_covs = np.concatenate([candidate_covs, tentative_covs])
        indices, _ = associate(
            points, covs, candidates_xy, self._sigma_m, self._gates, candidate_covs
        )
        return NearestMatch(np.asarray(candidate_ids, dtype=np.int64), indices, points, covs)

    def _mapped_near(
        self, guess_w: np.ndarray, max_range_m: float, point_covariances: np.ndarray
    ) -> np.ndarray:
        """Registry rows of the active landmarks that could fall inside the outer gate
        (a conservative radius about the guess); their cached positions are refreshed from
        iSAM2."""
        cached = self._registry.xy
        spread = self._sigma_m + np.sqrt(np.linalg.eigvalsh(point_covariances)[:, -1].max())
        radius = max_range_m + 3.0 * np.sqrt(self._gates.new_landmark) * spread
        near = np.flatnonzero(np.hypot(*(cached - guess_w[:2]).T) <= radius)
        near = near[[self._registry.active(self._registry.id_at(r)) for r in near.tolist()]]
        for row in near.tolist():  # refresh only these positions from iSAM2
            key = fx.landmark_key(self._registry.id_at(row))
            if self._session.exists(key):
                cached[row] = self._session.point2(key)
        return near

    def _landmark_covariances(
        self, rows: np.ndarray, points_w: np.ndarray, point_covariances: np.ndarray
    ) -> np.ndarray:
        """Position covariances (M, 2, 2) of the mapped landmarks ``rows`` for the gate.

        ``sigma_l^2 I`` (``landmark_sigma_m``), or with ``landmark_marginals`` the iSAM2
        marginal of each landmark whose distance with ``sigma_l`` is within 4x the new-landmark
        gate of some sighting (a marginal costs a back-substitution; the far ones could not
        match anyway unless their marginal were huge).
        """
        covariances = np.tile(self._sigma_m**2 * np.eye(2), (len(rows), 1, 1))
        if not self._landmark_marginals or not len(rows):
            return covariances
        d2 = mahalanobis2(points_w, point_covariances, self._registry.xy[rows], covariances)
        for j in np.flatnonzero(d2.min(axis=0) <= 4.0 * self._gates.new_landmark).tolist():
            key = fx.landmark_key(self._registry.id_at(int(rows[j])))
            if self._session.exists(key):
                covariances[j] = self._session.marginal_covariance(key)
        return covariances
