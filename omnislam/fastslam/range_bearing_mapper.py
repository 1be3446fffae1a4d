"""2-D point landmarks from range-bearing sightings (``Modality.RANGE_BEARING_2D``).

A sighting measures z = (range, bearing) in the robot frame with noise R = diag(sigma_r^2,
sigma_b^2) (the thesis's Q, eq. 4.23). A landmark a particle sees for the first time is
initialised from the inverse model, mean = h^-1(x, z) and Sigma = J_z R J_z^T (eqs. 4.26-4.27 in
2-D); later sightings update it by EKF (eqs. 4.33-4.37, ``core.kalman.ekf_update``), whose
innovation likelihood is FastSLAM 1.0's importance factor (eq. 4.47). The FastSLAM 2.0
proposal uses the same model, ungated.
"""

from __future__ import annotations

import math

import numpy as np

from omnislam.core.gaussian import log_likelihood_from_mahalanobis
from omnislam.core.kalman import ekf_update, initialize_from_inverse
from omnislam.core.measurement import RangeBearing2D
from omnislam.core.modality import Modality
from omnislam.core.types import FrameInput
from omnislam.fastslam.landmark_store import ESTIMATED, LandmarkBlock
from omnislam.fastslam.sightings import Pairs, Sightings


class RangeBearingMapper:
    """``LandmarkMapper`` of 2-D range-bearing sightings (MR.CLAM, Victoria Park, poles)."""

    modality = Modality.RANGE_BEARING_2D
    landmark_dim = 2
    ray_dim = 0
    proposal_gate = math.inf

    def __init__(self, kernels: object | None = None) -> None:
        """Args: kernels: the compiled kernels (``kernels.compiled()``) for the EKF update, or
        None for ``core.kalman.ekf_update`` (the reference)."""
        self._model = RangeBearing2D()
        self.proposal_model = self._model
        self._kernels = kernels

    def read(self, frame: FrameInput) -> Sightings | None:
        """``frame.range_bearing`` as z = (range, bearing) with R = diag(sigma_r^2, sigma_b^2)."""
        if not self.modality.count(frame):
            return None
        rb = frame.range_bearing
        assert rb is not None
        k = len(rb)
        R = np.zeros((k, 2, 2))
        R[:, 0, 0] = rb.sigma_range_m**2
        R[:, 1, 1] = rb.sigma_bearing_rad**2
        z = np.stack([rb.ranges_m, rb.bearings_rad], axis=-1)
        return Sightings(np.asarray(rb.landmark_ids), z, R)

    def update(
        self, block: LandmarkBlock, wTr: np.ndarray, sightings: Sightings, obs: np.ndarray
    ) -> np.ndarray:
        """Initialise new landmarks from the inverse model, EKF-update the others."""
        model = self._model
        log_likelihood = np.zeros(len(block))
        z, R = sightings.z[obs], sightings.R[obs]
        est = block.status == ESTIMATED
        if est.all():  # the common case: no boolean-mask copies
            if self._kernels is not None:
                return self._compiled_update(wTr, block.mean, block.cov, z, R)
            update = ekf_update(wTr, block.mean, block.cov, z, R, model)
            block.mean, block.cov = update.mean, update.cov
            return update.log_likelihood
        if est.any():
            if self._kernels is not None:
                mean, cov = block.mean[est], block.cov[est]
                log_likelihood[est] = self._compiled_update(wTr[est], mean, cov, z[est], R[est])
            else:
                update = ekf_update(
                    wTr[est], block.mean[est], block.cov[est], z[est], R[est], model
                )
                mean, cov = update.mean, update.cov
                log_likelihood[est] = update.log_likelihood
            block.mean[est] = mean
            block.cov[est] = cov
        new = ~est
        if new.any():
            mean, cov = initialize_from_inverse(wTr[new], z[new], R[new], model.inverse)
            block.mean[new] = mean
            block.cov[new] = cov
            block.status[new] = ESTIMATED
            block.existence[new] = 0
        return log_likelihood

    def _compiled_update(
        self, wTr: np.ndarray, mean: np.ndarray, cov: np.ndarray, z: np.ndarray, R: np.ndarray
    ) -> np.ndarray:
        """``kernels.ekf_range_bearing`` in place on ``mean`` / ``cov``; returns the innovation
        log-likelihoods (the log of det S taken by numpy, as ``ekf_update`` does)."""
        n = mean.shape[0]
        mahalanobis, det = np.empty(n), np.empty(n)
        self._kernels.ekf_range_bearing(
            np.ascontiguousarray(wTr), mean, cov, z, R, mean, cov, mahalanobis, det
        )
        return log_likelihood_from_mahalanobis(mahalanobis, np.log(det), 2)

    def proposal_landmarks(
        self, block: LandmarkBlock, pairs: Pairs, usable: np.ndarray
    ) -> np.ndarray:
        """Every usable pair refines the proposal."""
        return usable
