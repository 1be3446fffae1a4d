"""The filter's pose uncertainty relative to its maps: odometry-predicted, shrunk by sightings.

An alternative to ``resighting.ResightingSpread`` for the association of unknown sightings
(``ExperimentalConfig.association_pose_spread``): one Gaussian pose covariance C (3x3, world frame
at the particles' weighted mean pose) that EKF localisation against the particles' own maps would
hold (Thrun et al. 2005 Table 7.2, the map taken as known): each step C <- J_x C J_x^T + Rot Q
Rot^T with the step's covariance Q (Table 7.1's prediction; J_x the lever-arm Jacobian of the
composition), and each frame's matched sightings add their information, C <- (C^-1 + sum H_x^T S^-1
H_x)^-1 with S = H_m Sigma H_m^T + R, averaged over the particles by their weights. Where sightings
arrive all the time C stays at the steady state they support; over a stretch without any it grows
with the odometry, as the particles' poses do not after resampling has narrowed them.
"""

from __future__ import annotations

import numpy as np

from omnislam.core.batch_linalg import inverse_and_logdet, transpose
from omnislam.core.measurement import MeasurementModel, RangeBearing2D
from omnislam.core.se import se2_compose
from omnislam.fastslam.landmark_store import ESTIMATED, LandmarkStore
from omnislam.fastslam.resighting import pose_rotation
from omnislam.fastslam.sightings import Pairs, Sightings

#: the covariance starts (and is floored) at this times the identity
_FLOOR = 1e-9


class PoseSpread:
    """The pose covariance C of the module docstring.

    Args:
        scale: the association adds ``scale * C`` to each particle's pose covariance.
    """

    def __init__(self, scale: float) -> None:
        self.scale = scale
        self.covariance = _FLOOR * np.eye(3)

    def predict(self, wTr_before: np.ndarray, wTr_after: np.ndarray, step_cov: np.ndarray) -> None:
        """One odometry step from the mean pose ``wTr_before`` (3,) to ``wTr_after`` (3,), with the
        step's covariance (3, 3) in the previous pose's frame."""
        J = np.eye(3)
        J[0, 2] = -(wTr_after[1] - wTr_before[1])
        J[1, 2] = wTr_after[0] - wTr_before[0]
        rotate = pose_rotation(float(wTr_before[2]))
        C = J @ self.covariance @ J.T + rotate @ step_cov @ rotate.T
        self.covariance = 0.5 * (C + C.T)

    def predict_step(
        self, wTr_mean: np.ndarray, delta_r: np.ndarray, step_cov: np.ndarray
    ) -> None:
        """``predict`` of the step ``delta_r`` (3,) with covariance ``step_cov`` (3, 3) from the
        particles' mean pose ``wTr_mean`` (3,)."""
        self.predict(wTr_mean, se2_compose(wTr_mean, delta_r), step_cov)

    def update_from_pairs(
        self,
        store: LandmarkStore,
        wTr: np.ndarray,
        sightings: Sightings,
        pairs: Pairs,
        weights: np.ndarray,
    ) -> None:
        """``update`` with a frame's range-bearing sightings of established landmarks (not the
        new ones), from the particles' poses ``wTr`` (P, 3) and weights (P,), the landmarks as
        ``store`` holds them after the frame's update."""
        rows = np.flatnonzero(~pairs.new_unknown)
        if rows.size == 0:
            return
        block = store.gather(pairs.particle[rows], pairs.slot[rows])
        ok = block.status == ESTIMATED
        rows = rows[ok]
        who = pairs.particle[rows]
        self.update(
            RangeBearing2D(),
            wTr[who],
            block.mean[ok],
            block.cov[ok],
            sightings.R[pairs.obs[rows]],
            who,
            weights,
        )

    def update(
        self,
        model: MeasurementModel,
        wTr: np.ndarray,
        landmark_mean: np.ndarray,
        landmark_cov: np.ndarray,
        R: np.ndarray,
        particle: np.ndarray,
        weights: np.ndarray,
    ) -> None:
        """Add the information of N matched sightings: poses (N, 3), landmarks (N, 2) with
        covariances (N, 2, 2), noise (N, 2, 2), the particle (N,) each belongs to, and the
        particle weights (P,) that average the particles' information."""
        if len(particle) == 0:
            return
        _, H_x, H_m = model.predict(wTr, landmark_mean)
        S = H_m @ landmark_cov @ transpose(H_m) + R
        S_inv, _ = inverse_and_logdet(S)
        info = transpose(H_x) @ S_inv @ H_x  # (N, 3, 3)
        total = np.einsum("n,nij->ij", weights[particle], info)
        C = np.linalg.inv(np.linalg.inv(self.covariance) + total)
        self.covariance = 0.5 * (C + C.T) + _FLOOR * np.eye(3)

    def world_frame(self, n_particles: int) -> np.ndarray:
        """(P, 3, 3) ``scale * C`` for every particle."""
        return np.broadcast_to(self.scale * self.covariance, (n_particles, 3, 3))
