"""2-D point landmarks from range-bearing sightings (``Modality.RANGE_BEARING_2D``).

A sighting measures z = (range, bearing) in the robot frame with noise R = diag(sigma_r^2,
sigma_b^2) (the thesis's Q, eq. 4.23). A landmark a particle sees for the first time is
initialised from the inverse model, mean = h^-1(x, z) and Sigma = J_z R J_z^T (eqs. 4.26-4.27 in
2-D); later sightings update it by EKF (eqs. 4.33-4.37, ``core.kalman.ekf_update``), whose
innovation likelihood is FastSLAM 1.0's importance factor (eq. 4.47). The FastSLAM 2.0
proposal uses the same model.

The graph and EKF-SLAM gate a sighting of a known landmark on its innovation (``core.gating``);
FastSLAM can, per particle, with ``ExperimentalConfig.outlier_gate_probability`` < 1 (off by
default, see the option): an innovation with y^T S^-1 y above the chi-square gate (S = H Sigma
H^T + R for the landmark update, the proposal's H_x P H_x^T + Q for FastSLAM 2.0's refinement)
neither refines the proposal nor updates the landmark, and its weight factor is the Gaussian
likelihood truncated at the gate. A misread barcode that names a landmark metres away (MR.CLAM)
then costs every particle the same bounded factor instead of pulling the proposal onto it and
moving the landmark.
"""

from __future__ import annotations

import numpy as np

from omnislam.core.gating import chi_square_gate, gate_truncated_log_likelihood
from omnislam.core.gaussian import log_likelihood_from_mahalanobis
from omnislam.core.kalman import ekf_update, initialize_from_inverse
from omnislam.core.measurement import RangeBearing2D
from omnislam.core.modality import Modality
from omnislam.core.types import FrameInput
from omnislam.fastslam.landmark_store import ESTIMATED, LandmarkBlock
from omnislam.fastslam.sightings import Sightings


class RangeBearingMapper:
    """``LandmarkMapper`` of 2-D range-bearing sightings (MR.CLAM, Victoria Park, poles)."""

    modality = Modality.RANGE_BEARING_2D
    landmark_dim = 2
    ray_dim = 0
    #: every established landmark may refine the proposal
    proposal_converged_only = False
    #: nothing is triangulated
    triangulation_fallbacks = 0

    def __init__(self, kernels: object | None = None, gate_probability: float = 1.0) -> None:
        """Args: kernels: the compiled kernels (``kernels.compiled()``) for the EKF update, or
        None for ``core.kalman.ekf_update`` (the reference); gate_probability: the chi-square
        probability of the outlier gate (1.0: no gate)."""
        self._model = RangeBearing2D()
        self.proposal_model = self._model
        self._kernels = kernels
        #: validation gate of the 2-dof innovations (landmark update and proposal)
        self.proposal_gate = chi_square_gate(gate_probability, 2)
        #: (particle, sighting) landmark updates rejected by the gate so far
        self.sightings_gated = 0

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
        """Initialise new landmarks from the inverse model, EKF-update the others (outliers
        gated out: landmark unchanged, likelihood truncated at the gate)."""
        log_likelihood = np.zeros(len(block))
        z, R = sightings.z[obs], sightings.R[obs]
        est = block.status == ESTIMATED
        if est.all():  # the common case: no boolean-mask copies
            mean, cov, log_likelihood = self._gated_update(wTr, block.mean, block.cov, z, R)
            block.mean, block.cov = mean, cov
            return log_likelihood
        if est.any():
            mean, cov, log_likelihood[est] = self._gated_update(
                wTr[est], block.mean[est], block.cov[est], z[est], R[est]
            )
            block.mean[est] = mean
            block.cov[est] = cov
        new = ~est
        if new.any():
            mean, cov = initialize_from_inverse(wTr[new], z[new], R[new], self._model.inverse)
            block.mean[new] = mean
            block.cov[new] = cov
            block.status[new] = ESTIMATED
            block.existence[new] = 0
        return log_likelihood

    def _gated_update(
        self, wTr: np.ndarray, mean: np.ndarray, cov: np.ndarray, z: np.ndarray, R: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """EKF update (eqs. 4.33-4.37) of N landmarks with the gate: (means, covariances,
        log-likelihoods truncated at the gate); the compiled kernel updates ``mean`` / ``cov``
        in place."""
        gate = self.proposal_gate
        if self._kernels is not None:
            n = mean.shape[0]
            mahalanobis, det = np.empty(n), np.empty(n)
            self._kernels.ekf_range_bearing(
                np.ascontiguousarray(wTr), mean, cov, z, R, mean, cov, mahalanobis, det, gate
            )
            log_likelihood = log_likelihood_from_mahalanobis(mahalanobis, np.log(det), 2)
        else:
            update = ekf_update(wTr, mean, cov, z, R, self._model)
            mahalanobis, log_likelihood = update.mahalanobis, update.log_likelihood
            accepted = mahalanobis <= gate
            if accepted.all():
                mean, cov = update.mean, update.cov
            else:
                mean = np.where(accepted[:, None], update.mean, mean)
                cov = np.where(accepted[:, None, None], update.cov, cov)
        rejected = mahalanobis > gate
        if rejected.any():
            self.sightings_gated += int(np.count_nonzero(rejected))
            log_likelihood = gate_truncated_log_likelihood(log_likelihood, mahalanobis, gate)
        return mean, cov, log_likelihood
