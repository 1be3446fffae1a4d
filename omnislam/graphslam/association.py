"""Nearest-neighbour data association of unlabelled 2-D range-bearing sightings.

For each sighting z = (range, bearing) seen from the current pose estimate ``wTr`` the landmark
position it implies is ``p = inverse(wTr, z)`` (``RangeBearing2D.inverse``) with covariance
``J_z R J_z^T``. Against every mapped landmark ``l`` with the *fixed* position covariance
``sigma_l^2 I`` the squared Mahalanobis distance is

    d^2 = (p - l)^T (J_z R J_z^T + sigma_l^2 I)^-1 (p - l)

(Thrun, Burgard & Fox 2005, sec. 10.3, with the innovation covariance moved into the landmark
frame). A sighting takes its nearest landmark when d^2 is inside the ``gate`` (chi-square, 2
degrees of freedom), starts a new landmark when every d^2 is beyond ``new_landmark`` and is
dropped as ambiguous in between. Within one frame a landmark is given to at most one sighting
(greedy, closest pair first).

Covariances, and what they cost: the sighting's covariance includes the *newest pose's* iSAM2
marginal, ``J_p P J_p^T`` -- one ``ISAM2.marginalCovariance`` call per frame with unlabelled
sightings, cheap because the newest pose sits in the root clique of the Bayes tree; without it
the drift accumulated before a loop closure puts revisited landmarks outside the gate and
duplicates them. Landmark marginals cost a back-substitution each, per nearby landmark and
frame, so by default every landmark gets the *fixed* covariance ``sigma_l^2 I``;
``ExperimentalConfig.association_landmark_marginals`` uses the iSAM2 marginal ``L`` of each
candidate close enough to matter instead (``d^2`` with ``S = C_p + L``, the pose-landmark
cross-covariance neglected). The position estimates are refreshed from iSAM2 only for the
landmarks near the robot (``nearest_association.py``).

A landmark started here can wait as a *tentative* landmark until re-observed
(``tentative.py``, ``AssociationConfig.tentative_min_sightings``): tentative landmarks are
candidates like mapped ones, with the fused covariance of their sightings.

What it cannot do (measured on gtsam's victoria_park.txt with the ids hidden;
docs/results/association.md):
close loops after long stretches of odometry. There the online pose is metres off while its
iSAM2 covariance is overconfident (pose NEES 10-90 against the final solution, for 2 degrees of
freedom, even with the true association), trees are a median 6.7 m apart and a frame holds ~1
sighting, so single-sighting gating matches revisited trees to wrong neighbours.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from omnislam.core.measurement import RangeBearing2D

#: index returned for a sighting that should start a new landmark
NEW_LANDMARK = -1
#: index returned for a sighting that is neither matched nor new (dropped)
AMBIGUOUS = -2

_MODEL = RangeBearing2D()


@dataclass(frozen=True, slots=True)
class Gates:
    """Chi-square thresholds on d^2 (2 degrees of freedom).

    Attributes:
        match: d^2 below which the nearest landmark is taken.
        new_landmark: d^2 above which (for every landmark) a new landmark starts.
    """

    match: float
    new_landmark: float

    @classmethod
    def from_probabilities(cls, match_probability: float, new_probability: float) -> Gates:
        """Gates from chi-square probabilities (e.g. 0.99 -> 9.21, 0.9999 -> 18.4)."""
        return cls(float(chi2.ppf(match_probability, 2)), float(chi2.ppf(new_probability, 2)))


def sighting_points(
    wTr: np.ndarray,
    ranges_m: np.ndarray,
    bearings_rad: np.ndarray,
    sigma_range_m: np.ndarray,
    sigma_bearing_rad: np.ndarray,
    pose_covariance: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """World points (K, 2) implied by K sightings from pose ``wTr`` and their covariances (K, 2, 2).

    Args:
        wTr: (3,) robot pose [x, y, theta] in the world.
        ranges_m: (K,) ranges [m].
        bearings_rad: (K,) bearings [rad].
        sigma_range_m: (K,) range stds [m].
        sigma_bearing_rad: (K,) bearing stds [rad].
        pose_covariance: (3, 3) covariance of ``wTr`` in world [x, y, theta], or None.

    Returns:
        points (K, 2) and covariances ``J_z R J_z^T (+ J_p P J_p^T)`` (K, 2, 2) [m^2].
    """
    z = np.stack([ranges_m, bearings_rad], axis=-1)
    points_w, J_p, J_z = _MODEL.inverse(np.broadcast_to(wTr, (len(ranges_m), 3)), z)
    R = np.zeros((len(ranges_m), 2, 2))
    R[:, 0, 0] = sigma_range_m**2
    R[:, 1, 1] = sigma_bearing_rad**2
    covariances = J_z @ R @ np.swapaxes(J_z, 1, 2)
    if pose_covariance is not None:
        covariances += J_p @ pose_covariance @ np.swapaxes(J_p, 1, 2)
    return points_w, covariances


def mahalanobis2(
    points_w: np.ndarray,
    point_covariances: np.ndarray,
    landmarks_w: np.ndarray,
    landmark_covariances: np.ndarray,
) -> np.ndarray:
    """Squared Mahalanobis distances (K, M) of K sighting points to M landmarks.

    ``d2[k, m] = (p_k - l_m)^T (C_k + L_m)^-1 (p_k - l_m)`` with the sightings' covariances
    ``C`` (K, 2, 2) and the landmarks' ``L`` (M, 2, 2) [m^2].
    """
    diff = points_w[:, None, :] - landmarks_w[None, :, :]  # (K, M, 2)
    S = point_covariances[:, None] + np.asarray(landmark_covariances)[None]  # (K, M, 2, 2)
    return np.einsum("kmi,kmij,kmj->km", diff, np.linalg.inv(S), diff)


def associate(
    points_w: np.ndarray,
    point_covariances: np.ndarray,
    landmarks_w: np.ndarray,
    landmark_sigma_m: float,
    gates: Gates,
    landmark_covariances: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Nearest neighbour with a Mahalanobis gate, one landmark per sighting per frame.

    Args:
        points_w: (K, 2) world points of the sightings [m].
        point_covariances: (K, 2, 2) their covariances [m^2].
        landmarks_w: (M, 2) candidate landmark positions [m].
        landmark_sigma_m: fixed std of every landmark position [m], used when
            ``landmark_covariances`` is None.
        gates: chi-square thresholds.
        landmark_covariances: (M, 2, 2) covariance of each candidate's position [m^2] (iSAM2
            marginals, fused tentative points), or None.

    Returns:
        (indices (K,) into ``landmarks_w``, or NEW_LANDMARK / AMBIGUOUS; d2 (K,) the squared
        Mahalanobis distance to the chosen or nearest landmark, inf when M = 0).
    """
    k, m = len(points_w), len(landmarks_w)
    indices = np.full(k, NEW_LANDMARK, dtype=np.int64)
    best = np.full(k, np.inf)
    if k == 0 or m == 0:
        return indices, best
    if landmark_covariances is None:
        landmark_covariances = np.broadcast_to(landmark_sigma_m**2 * np.eye(2), (m, 2, 2))
    d2 = mahalanobis2(points_w, point_covariances, landmarks_w, landmark_covariances)
    best = d2.min(axis=1)
    indices[best > gates.new_landmark] = NEW_LANDMARK
    ambiguous = (best > gates.match) & (best <= gates.new_landmark)
    indices[ambiguous] = AMBIGUOUS
    # greedy unique assignment of the gated pairs, closest first
    rows, cols = np.nonzero(d2 <= gates.match)
    order = np.argsort(d2[rows, cols], kind="stable")
    taken_rows: set[int] = set()
    taken_cols: set[int] = set()
    for r, c in zip(rows[order], cols[order], strict=True):
        if r in taken_rows or c in taken_cols:
            continue
        taken_rows.add(int(r))
        taken_cols.add(int(c))
        indices[r] = c
        best[r] = d2[r, c]
    # a gated sighting that lost its landmarks to closer sightings is ambiguous, not new
    lost = (best <= gates.match) & ~np.isin(np.arange(k), list(taken_rows))
    indices[lost] = AMBIGUOUS
    return indices, best
