"""3-D point landmarks from omni bearings (``Modality.BEARINGS_3D``), thesis sec. 4.4.1.

The thesis's life cycle of a bearing-only landmark in one particle: the first sighting stores
the ray (eq. 4.24); the first later sighting with enough parallax triangulates it (eq. 4.21 or
least squares) with Sigma = R Q R^T (eqs. 4.26-4.27); later sightings update it by EKF
(eqs. 4.29-4.37), either with the triangulated pseudo-measurement z = (d, theta, phi) (eq. 4.25,
``BearingUpdate.TRIANGULATED``, falling back to the direct update where the parallax is too
small) or directly with z = (azimuth, elevation) (``BearingUpdate.DIRECT``). The ray geometry is
in ``bearing_landmarks``.

A chi-square validation gate (``core.gating``) keeps bearings of feature tracks that jumped to
another point out of the landmark EKFs and the FastSLAM 2.0 proposal; their weight factor is the
Gaussian likelihood truncated at the gate.

With the compiled kernels (``kernels``) the midpoint triangulations and the updates of
established landmarks run as loops over the (particle, sighting) pairs, with the same numbers
as the numpy path written out here (the reference, and the test oracle of the kernels).
"""

from __future__ import annotations

import math

import numpy as np

from omnislam.core.gating import chi_square_gate, gate_truncated_log_likelihood
from omnislam.core.gaussian import LOG_2PI
from omnislam.core.kalman import ekf_update
from omnislam.core.measurement import (
    BearingElevation3D,
    RangeAzimuthElevation3D,
    azimuth_elevation_from_unit_vectors,
)
from omnislam.core.modality import Modality
from omnislam.core.types import FrameInput
from omnislam.errors import DataError
from omnislam.fastslam.bearing_landmarks import (
    RAY_DIM,
    first_estimate,
    triangulate,
    triangulated_measurement,
    world_rays,
)
from omnislam.fastslam.config import BearingsConfig, BearingUpdate, TriangulationMethod
from omnislam.fastslam.landmark_store import ABSENT, ESTIMATED, RAY, LandmarkBlock
from omnislam.fastslam.sightings import Sightings


class BearingMapper:
    """``LandmarkMapper`` of the omni camera's unit bearings with track ids.

    Args:
        config: the bearings section (bearing update, triangulation, parallax, gate).
        sensor_height_m: height of the camera's viewpoint above the ground plane [m].
        kernels: the compiled kernels (``kernels.compiled()``) for the triangulations and the
            updates of established landmarks, or None for the numpy path (the reference).

    Attributes:
        sightings_gated: (particle, sighting) landmark updates rejected by the gate so far.
        triangulation_fallbacks: triangulated updates replaced by the direct one (too little
            parallax with the stored ray, or no valid intersection) so far.
    """

    modality = Modality.BEARINGS_3D
    landmark_dim = 3
    ray_dim = RAY_DIM
    #: triangulated landmarks: only converged ones refine the proposal
    proposal_converged_only = True

    def __init__(
        self, config: BearingsConfig, sensor_height_m: float, kernels: object | None = None
    ) -> None:
        self._config = config
        self._kernels = kernels
        self._sensor_height_m = sensor_height_m
        self._min_parallax_rad = math.radians(config.min_parallax_deg)
        self._range_az_el = RangeAzimuthElevation3D(sensor_height_m)
        self._bearing = BearingElevation3D(sensor_height_m)
        # validation gates of (azimuth, elevation) and (d, theta, phi) innovations
        self._bearing_gate = chi_square_gate(config.gate_probability, 2)
        self._triangulated_gate = chi_square_gate(config.gate_probability, 3)
        # the proposal uses the direct model: the triangulated pseudo-measurement depends on
        # the very pose being sampled
        self.proposal_model = self._bearing
        self.proposal_gate = self._bearing_gate
        self.sightings_gated = 0
        self.triangulation_fallbacks = 0

    def read(self, frame: FrameInput) -> Sightings | None:
        """``frame.bearings`` as z = (azimuth, elevation) with R = sigma^2 I.

        Raises:
            DataError: a bearing without track id (unknown association is supported for
                range-bearing sightings only).
        """
        if not self.modality.count(frame):
            return None
        bearings = frame.bearings
        assert bearings is not None
        if np.any(bearings.landmark_ids < 0):
            raise DataError(
                f"frame {frame.index}: bearing sightings need track ids (unknown association "
                "is supported for range-bearing sightings only)"
            )
        k = len(bearings)
        R = np.zeros((k, 2, 2))
        R[:, 0, 0] = R[:, 1, 1] = bearings.sigmas_rad**2
        z = azimuth_elevation_from_unit_vectors(bearings.unit_vectors_r)
        return Sightings(
            np.asarray(bearings.landmark_ids),
            z,
            R,
            np.asarray(bearings.unit_vectors_r),
            np.asarray(bearings.sigmas_rad),
        )

    def update(
        self, block: LandmarkBlock, wTr: np.ndarray, sightings: Sightings, obs: np.ndarray
    ) -> np.ndarray:
        """Store the ray, triangulate, then EKF-update (triangulated pseudo-measurement or
        direct azimuth/elevation, ``BearingUpdate``), outliers gated out."""
        assert sightings.unit_vectors_r is not None and sightings.sigmas_rad is not None
        config = self._config
        # each ray enters two triangulations only when later sightings are triangulated too
        triangulated = config.update is BearingUpdate.TRIANGULATED
        ray_reuse = config.triangulated_ray_reuse if triangulated else 1.0
        log_likelihood = np.zeros(len(block))
        rays = self._world_rays(wTr, sightings.unit_vectors_r, obs)
        sigma = sightings.sigmas_rad[obs]
        absent = np.flatnonzero(block.status == ABSENT)
        ray_only = np.flatnonzero(block.status == RAY)
        est = np.flatnonzero(block.status == ESTIMATED)

        # first sighting: store the ray (eq. 4.24)
        block.ray[absent] = rays[absent]
        block.status[absent] = RAY
        block.existence[absent] = 0

        # first match: triangulate (eq. 4.21) and Sigma = R Q R^T (eqs. 4.26-4.27)
        if ray_only.size:
            ok, z3, Q = self._triangulated(block, ray_only, rays, wTr, sigma, ray_reuse)
            rows = ray_only[ok]
            if rows.size:
                block.mean[rows], block.cov[rows] = first_estimate(
                    self._range_az_el, wTr[rows], z3, Q
                )
                block.status[rows] = ESTIMATED
                block.ray[rows] = rays[rows]  # eq. 4.28: keep the latest sighting

        # later matches: EKF update (eqs. 4.29-4.37), outliers gated out
        if est.size and self._kernels is not None:
            self._update_compiled(
                block, est, rays, wTr, sigma, sightings, obs, ray_reuse, log_likelihood
            )
        elif est.size:
            direct = np.ones(est.size, dtype=bool)
            if triangulated:
                ok, z3, Q = self._triangulated(block, est, rays, wTr, sigma, ray_reuse)
                rows = est[ok]
                if rows.size:
                    accepted = self._gated_update(
                        block,
                        rows,
                        wTr[rows],
                        z3,
                        Q,
                        self._range_az_el,
                        self._triangulated_gate,
                        log_likelihood,
                    )
                    block.ray[rows[accepted]] = rays[rows[accepted]]
                direct = ~ok
                self.triangulation_fallbacks += int(np.count_nonzero(direct))
            rows = est[direct]
            if rows.size:
                self._gated_update(
                    block,
                    rows,
                    wTr[rows],
                    sightings.z[obs[rows]],
                    sightings.R[obs[rows]],
                    self._bearing,
                    self._bearing_gate,
                    log_likelihood,
                )
        return log_likelihood

    def _triangulated(
        self,
        block: LandmarkBlock,
        rows: np.ndarray,
        rays: np.ndarray,
        wTr: np.ndarray,
        sigma: np.ndarray,
        ray_reuse: float,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Triangulate the stored ray of ``block[rows]`` with the new one (eq. 4.21) where the
        parallax allows, as a (d, theta, phi) pseudo-measurement with noise Q (eqs. 4.25-4.27).

        Returns:
            ((len(rows),) True where it triangulated, z3 (K, 3), Q (K, 3, 3) of those K rows).
        """
        points, valid, parallax = self._triangulate(block.ray, rays, rows)
        ok = valid & (parallax >= self._min_parallax_rad)
        kept = rows[ok]
        if not kept.size:
            return ok, np.zeros((0, 3)), np.zeros((0, 3, 3))
        z3, Q = triangulated_measurement(
            self._range_az_el, wTr[kept], points[ok], sigma[kept], parallax[ok], ray_reuse
        )
        return ok, z3, Q

    def _world_rays(
        self, wTr: np.ndarray, unit_vectors_r: np.ndarray, obs: np.ndarray
    ) -> np.ndarray:
        """``bearing_landmarks.world_rays`` of the bearings ``obs`` seen from ``wTr``; by the
        compiled kernel when there is one (the headings' cos and sin stay numpy's)."""
        if self._kernels is None:
            return world_rays(wTr, unit_vectors_r[obs], self._sensor_height_m)
        rays = np.empty((len(wTr), RAY_DIM))
        cos_theta, sin_theta = np.cos(wTr[..., 2]), np.sin(wTr[..., 2])
        self._kernels.world_rays(
            wTr, cos_theta, sin_theta, unit_vectors_r, obs, self._sensor_height_m, rays
        )
        return rays

    def _triangulate(
        self, rays_a: np.ndarray, rays_b: np.ndarray, rows: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``bearing_landmarks.triangulate`` of the rows ``rows`` of two ray tables with the
        configured method; the midpoint by the compiled kernel when there is one (the
        parallax's arccos stays numpy's)."""
        method = self._config.triangulation
        if self._kernels is None or method is not TriangulationMethod.MIDPOINT:
            return triangulate(method, rays_a[rows], rays_b[rows])
        n = rows.size
        points, cosine = np.empty((n, 3)), np.empty(n)
        valid = np.empty(n, dtype=bool)
        self._kernels.midpoint_triangulation(rays_a, rays_b, rows, points, cosine, valid)
        return points, valid, np.arccos(cosine)

    def _azimuth_elevation(self, wTr: np.ndarray, points_w: np.ndarray) -> np.ndarray:
        """(2, N) atan2(dy, dx) and atan2(dz, rho) of N points seen from N poses, the angles of
        the bearing models' ``predict`` before the heading is subtracted and wrapped (numpy's
        atan2 on the arguments of ``kernels.azimuth_elevation_arguments``)."""
        arguments = np.empty((4, len(wTr)))
        self._kernels.azimuth_elevation_arguments(wTr, points_w, self._sensor_height_m, arguments)
        angles = np.empty((2, len(wTr)))
        np.arctan2(arguments[0], arguments[1], out=angles[0])
        np.arctan2(arguments[2], arguments[3], out=angles[1])
        return angles

    def _update_compiled(
        self,
        block: LandmarkBlock,
        est: np.ndarray,
        rays: np.ndarray,
        wTr: np.ndarray,
        sigma: np.ndarray,
        sightings: Sightings,
        obs: np.ndarray,
        ray_reuse: float,
        log_likelihood: np.ndarray,
    ) -> None:
        """``update``'s later matches of ``block[est]`` by the compiled kernels: the same
        triangulations, pseudo-measurements, gated EKF updates and truncated likelihoods as
        ``_triangulated`` and ``_gated_update`` on the numpy path, in one loop over the pairs
        (``kernels.bearing_landmark_updates``); the transcendental functions are numpy's."""
        n = est.size
        wTr_est = wTr[est]
        if self._config.update is BearingUpdate.TRIANGULATED:
            points, valid, parallax = self._triangulate(block.ray, rays, est)
            triangulated = valid & (parallax >= self._min_parallax_rad)
            point_angles = self._azimuth_elevation(wTr_est, points)
            sin_parallax = np.sin(parallax)
            self.triangulation_fallbacks += int(n - np.count_nonzero(triangulated))
        else:
            triangulated = np.zeros(n, dtype=bool)
            points, point_angles, sin_parallax = np.zeros((n, 3)), np.zeros((2, n)), np.zeros(n)
        mean_angles = self._azimuth_elevation(wTr_est, block.mean[est])
        mahalanobis, det = np.empty(n), np.empty(n)
        accepted = np.empty(n, dtype=bool)
        self._kernels.bearing_landmark_updates(
            wTr,
            block.mean,
            block.cov,
            est,
            triangulated,
            points,
            point_angles,
            sin_parallax,
            sigma,
            ray_reuse,
            obs,
            sightings.z,
            sightings.R,
            mean_angles,
            self._sensor_height_m,
            self._triangulated_gate,
            self._bearing_gate,
            rays,
            block.ray,
            mahalanobis,
            det,
            accepted,
        )
        # log N(y; 0, S) (core.gaussian) truncated at the gate, as ekf_update and
        # gate_truncated_log_likelihood compute it for each model
        self._kernels.gated_log_likelihoods(
            mahalanobis,
            np.log(det),
            triangulated,
            3 * LOG_2PI,
            2 * LOG_2PI,
            self._triangulated_gate,
            self._bearing_gate,
            est,
            log_likelihood,
        )
        self.sightings_gated += int(n - np.count_nonzero(accepted))

    def _gated_update(
        self,
        block: LandmarkBlock,
        rows: np.ndarray,
        wTr: np.ndarray,
        z: np.ndarray,
        R: np.ndarray,
        model: RangeAzimuthElevation3D | BearingElevation3D,
        gate: float,
        log_likelihood: np.ndarray,
    ) -> np.ndarray:
        """EKF update (thesis eqs. 4.33-4.37) of ``block[rows]`` in place, skipping outliers.

        An innovation outside the validation gate (y^T S^-1 y > gate) leaves the landmark as it
        was; its likelihood, written to ``log_likelihood[rows]``, is truncated at the gate.

        Returns:
            (len(rows),) True where the update was applied.
        """
        update = ekf_update(wTr, block.mean[rows], block.cov[rows], z, R, model)
        accepted = update.mahalanobis <= gate
        kept = rows[accepted]
        block.mean[kept] = update.mean[accepted]
        block.cov[kept] = update.cov[accepted]
        log_likelihood[rows] = gate_truncated_log_likelihood(
            update.log_likelihood, update.mahalanobis, gate
        )
        self.sightings_gated += int(accepted.size - np.count_nonzero(accepted))
        return accepted
