"""FastSLAM 2.0's pose sampling: each particle's motion prediction refined by its sightings.

Thesis eqs. 4.45-4.46 / Montemerlo 2003 sec. 3.3: every particle refines the Gaussian motion
prediction N(mu0, P) of its pose by its sightings of established landmarks -- one after the other
(``ProposalUpdateMode.SEQUENTIAL``, ``proposal.refine_proposal``) or all in one update linearised
at the prediction (``JOINT``, ``proposal.joint_proposal``) -- and draws its new pose from the
result. The product of the sightings' predictive likelihoods is the particle's importance factor
(eq. 4.47 with the predictive covariance H_x P H_x^T + H_m Sigma H_m^T + R). A particle without
such sightings samples from the motion model itself, as in FastSLAM 1.0 (eqs. 4.42-4.44).

The mapper gives the model and the gate; where its landmarks are triangulated from bearings
(``LandmarkMapper.proposal_converged_only``) only the converged ones take part, capped
(``converged_pairs``, ``ProposalConfig``).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from omnislam.core.gaussian import log_likelihood_from_mahalanobis
from omnislam.core.measurement import BearingElevation3D, RangeBearing2D
from omnislam.core.motion import MotionModel, OdometryMotionModel
from omnislam.fastslam.config import ProposalConfig, ProposalUpdateMode
from omnislam.fastslam.landmark_store import ESTIMATED, LandmarkBlock, LandmarkStore
from omnislam.fastslam.mapper import LandmarkMapper
from omnislam.fastslam.proposal import _JITTER, joint_proposal, refine_proposal, sample_poses
from omnislam.fastslam.sightings import Pairs, Sightings, tentative_pairs


@dataclass(frozen=True, slots=True)
class ProposalDraw:
    """The poses drawn from the proposal and their importance factors.

    Attributes:
        poses: (P, 3) sampled poses.
        log_factors: (P,) log importance factors (0 for particles sampled from the motion
            model).
        gated: (particle, sighting) pairs the validation gate kept out of the proposal.
        block: the landmarks of all the pairs as gathered for the proposal (not modified), for
            the landmark update to reuse.
        tentative: (N,) the pairs kept out of the proposal because their landmark is
            tentative (``sightings.tentative_pairs``); their weight factor is the caller's.
    """

    poses: np.ndarray
    log_factors: np.ndarray
    gated: int
    block: LandmarkBlock
    tentative: np.ndarray


class ProposalSampler:
    """Draws FastSLAM 2.0's poses.

    Args:
        mapper: the modality's mapper (proposal model and gate).
        config: the proposal section (sequential or joint refinement, the converged landmarks
            of 3-D maps).
        motion: the motion model (particles without usable sightings sample from it).
        rng: the filter's random generator.
        kernels: the compiled kernels (``kernels.compiled()``), or None for the numpy path.
        confirm_sightings: landmarks of unknown association seen fewer times are tentative and
            do not refine the proposal (``ExperimentalConfig.confirm_sightings``).
    """

    def __init__(
        self,
        mapper: LandmarkMapper,
        config: ProposalConfig,
        motion: MotionModel,
        rng: np.random.Generator,
        kernels: object | None = None,
        confirm_sightings: int = 1,
    ) -> None:
        self._mapper = mapper
        self._config = config
        self._confirm = confirm_sightings
        mode = config.update
        self._mode = mode
        self._motion = motion
        self._rng = rng
        # the compiled sequential proposal covers 2-D range-bearing sightings
        compiled = (
            kernels is not None
            and mode is ProposalUpdateMode.SEQUENTIAL
            and isinstance(mapper.proposal_model, RangeBearing2D)
        )
        self._kernels = kernels if compiled else None
        # and the compiled sequential proposal over omni bearings
        bearings = (
            kernels is not None
            and mode is ProposalUpdateMode.SEQUENTIAL
            and isinstance(mapper.proposal_model, BearingElevation3D)
        )
        self._bearing_kernels = kernels if bearings else None
        self._draw_kernels = kernels
        self._odometry = motion if isinstance(motion, OdometryMotionModel) else None

    def predict(
        self, previous: np.ndarray, delta_r: np.ndarray, motion: MotionModel | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """The motion prediction N(mu0, P) from the exactly known previous poses (thesis 4.41,
        4.44; ``MotionModel.predict(previous, None, delta_r)``), compiled for the odometry
        model when the kernels are on. ``motion``: this step's model instead of the filter's
        (a stated odometry covariance, ``core.motion.StatedOdometryMotion``)."""
        if motion is not None:
            return motion.predict(previous, None, delta_r)
        if self._draw_kernels is None or self._odometry is None:
            return self._motion.predict(previous, None, delta_r)
        rot1, trans, rot2 = self._odometry.decompose(delta_r).tolist()
        variances = self._odometry.component_sigmas(np.array([rot1, trans, rot2])) ** 2
        p = previous.shape[0]
        mean, cov = np.empty((p, 3)), np.empty((p, 3, 3))
        self._draw_kernels.odometry_prediction(
            np.ascontiguousarray(previous, dtype=float), rot1, trans, rot2, variances, mean, cov
        )
        return mean, cov

    def sample(
        self,
        previous: np.ndarray,
        delta_r: np.ndarray,
        mean: np.ndarray,
        cov: np.ndarray,
        sightings: Sightings,
        pairs: Pairs,
        store: LandmarkStore,
        motion: MotionModel | None = None,
    ) -> ProposalDraw:
        """Refine each particle's prediction by its sightings and sample from the result.

        Args:
            previous: (P, 3) the particles' previous poses.
            delta_r: (3,) the odometry delta.
            mean: (P, 3) the motion prediction's mean from ``previous``.
            cov: (P, 3, 3) the motion prediction's covariance.
            sightings: the frame's sightings; pairs: what they address (``association``).
            store: the landmark store (the addressed landmarks before this frame's update).
            motion: this step's motion model for the particles without usable sightings
                (default: the filter's, as in ``predict``).
        """
        block = store.gather(pairs.particle, pairs.slot)
        tentative = tentative_pairs(pairs, sightings, block.existence, self._confirm)
        usable = (block.status == ESTIMATED) & ~pairs.new_unknown & ~tentative
        if self._mapper.proposal_converged_only:
            usable = converged_pairs(block, pairs, usable, self._config)
        mean, cov, log_factors, gated = self._refine(mean, cov, sightings, pairs, block, usable)
        refined = np.zeros(len(previous), dtype=bool)
        refined[pairs.particle[usable]] = True
        poses = self._draw(previous, delta_r, mean, cov, refined, motion)
        return ProposalDraw(poses, log_factors, gated, block, tentative)

    def _refine(
        self,
        mean: np.ndarray,
        cov: np.ndarray,
        sightings: Sightings,
        pairs: Pairs,
        block: LandmarkBlock,
        usable: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """Each particle's prediction refined by its ``usable`` pairs, jointly or sequentially
        (compiled where the kernels cover the model): (means, covariances, summed predictive
        log-likelihoods (P,), pairs the gate kept out)."""
        if self._mode is ProposalUpdateMode.JOINT:
            return self._refine_joint(mean, cov, sightings, pairs, block, usable)
        if self._kernels is not None:
            return self._refine_compiled(mean, cov, sightings, pairs, block, usable)
        if self._bearing_kernels is not None:
            return self._refine_bearings_compiled(mean, cov, sightings, pairs, block, usable)
        return self._refine_sequential(mean, cov, sightings, pairs, block, usable)

    def _draw(
        self,
        previous: np.ndarray,
        delta_r: np.ndarray,
        mean: np.ndarray,
        cov: np.ndarray,
        refined: np.ndarray,
        motion: MotionModel | None,
    ) -> np.ndarray:
        """(P, 3) poses: the ``refined`` particles drawn from their refined Gaussians, the others
        from the motion model (``motion``, or the filter's)."""
        poses = np.empty_like(previous)
        if self._draw_kernels is not None and mean.shape[-1] == 3:
            chosen = mean[refined]
            normals = self._rng.standard_normal(chosen.shape)  # as sample_poses draws them
            drawn = np.empty_like(chosen)
            self._draw_kernels.cholesky_draws(chosen, cov[refined], normals, _JITTER, drawn)
            poses[refined] = drawn
        else:
            poses[refined] = sample_poses(mean[refined], cov[refined], self._rng)
        plain = ~refined
        if plain.any():
            model = self._motion if motion is None else motion
            poses[plain] = model.sample(previous[plain], delta_r, self._rng)
        return poses

    def _refine_joint(
        self,
        mean: np.ndarray,
        cov: np.ndarray,
        sightings: Sightings,
        pairs: Pairs,
        block: LandmarkBlock,
        usable: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """All of a particle's usable sightings in one update at the prediction
        (``proposal.joint_proposal``)."""
        rows = np.flatnonzero(usable)
        obs = pairs.obs[rows]
        joint = joint_proposal(
            mean,
            cov,
            pairs.particle[rows],
            sightings.z[obs],
            sightings.R[obs],
            block.mean[rows],
            block.cov[rows],
            self._mapper.proposal_model,
            self._mapper.proposal_gate,
        )
        gated = int(joint.accepted.size - np.count_nonzero(joint.accepted))
        return joint.mean, joint.cov, joint.log_likelihood, gated

    def _refine_sequential(
        self,
        mean: np.ndarray,
        cov: np.ndarray,
        sightings: Sightings,
        pairs: Pairs,
        block: LandmarkBlock,
        usable: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """The usable sightings one after the other (``proposal.refine_proposal``, thesis eqs.
        4.45-4.46), each one's particles at once: the numpy reference."""
        model, gate = self._mapper.proposal_model, self._mapper.proposal_gate
        log_factors = np.zeros(len(mean))
        mean = mean.copy()
        cov = cov.copy()
        gated = 0
        for k in np.unique(pairs.obs[usable]):
            rows = np.flatnonzero(usable & (pairs.obs == k))
            who = pairs.particle[rows]  # one row per particle for a given sighting
            n = rows.size
            update = refine_proposal(
                mean[who],
                cov[who],
                np.broadcast_to(sightings.z[k], (n, sightings.z.shape[1])),
                np.broadcast_to(sightings.R[k], (n, *sightings.R.shape[1:])),
                block.mean[rows],
                block.cov[rows],
                model,
                gate,
            )
            mean[who] = update.mean
            cov[who] = update.cov
            log_factors[who] += update.log_likelihood
            gated += int(update.accepted.size - np.count_nonzero(update.accepted))
        return mean, cov, log_factors, gated

    def _refine_compiled(
        self,
        mean: np.ndarray,
        cov: np.ndarray,
        sightings: Sightings,
        pairs: Pairs,
        block: LandmarkBlock,
        usable: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """The sequential refinement by ``kernels.refine_range_bearing``: the usable pairs in
        ascending sighting order (the reference's loop order, per particle), the predictive
        log-likelihoods (truncated at the mapper's gate) summed per particle in that order,
        and the number of pairs the gate kept out."""
        gate = self._mapper.proposal_gate
        rows = np.flatnonzero(usable)
        rows = rows[np.argsort(pairs.obs[rows], kind="stable")]
        who, obs = pairs.particle[rows], pairs.obs[rows]
        mean = np.array(mean, dtype=float)  # contiguous copies, refined in place
        cov = np.array(cov, dtype=float)
        n = rows.size
        mahalanobis, det = np.empty(n), np.empty(n)
        self._kernels.refine_range_bearing(
            mean,
            cov,
            who,
            sightings.z[obs],
            sightings.R[obs],
            block.mean[rows],
            block.cov[rows],
            mahalanobis,
            det,
            gate,
        )
        gated = int(np.count_nonzero(mahalanobis > gate))
        return mean, cov, _summed_log_likelihoods(mahalanobis, det, who, gate, len(mean)), gated

    def _refine_bearings_compiled(
        self,
        mean: np.ndarray,
        cov: np.ndarray,
        sightings: Sightings,
        pairs: Pairs,
        block: LandmarkBlock,
        usable: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """The sequential refinement by omni bearings: the reference's loop over the sightings
        in ascending order, each one's particles refined by ``kernels.refine_bearing_elevation``
        after numpy's atan2 of the landmarks from the refined means; the predictive
        log-likelihoods (truncated at the gate) summed per particle in that order, and the
        number of pairs the gate kept out."""
        kernels = self._bearing_kernels
        model, gate = self._mapper.proposal_model, self._mapper.proposal_gate
        rows = np.flatnonzero(usable)
        rows = rows[np.argsort(pairs.obs[rows], kind="stable")]
        who, obs = pairs.particle[rows], pairs.obs[rows]
        landmark_mean, landmark_cov = block.mean[rows], block.cov[rows]
        mean = np.array(mean, dtype=float)  # contiguous copies, refined in place
        cov = np.array(cov, dtype=float)
        n = rows.size
        mahalanobis, det = np.empty(n), np.empty(n)
        arguments, angles = np.empty((4, n)), np.empty((2, n))
        # where the sighting changes: the start of each one's run and the end of the last
        bounds = np.flatnonzero(np.diff(obs, prepend=-1, append=-1)).tolist()
        for start, end in itertools.pairwise(bounds):
            span = slice(start, end)  # one sighting, each of its particles once
            kernels.azimuth_elevation_arguments(
                mean[who[span]], landmark_mean[span], model.sensor_height_m, arguments[:, span]
            )
            np.arctan2(arguments[0, span], arguments[1, span], out=angles[0, span])
            np.arctan2(arguments[2, span], arguments[3, span], out=angles[1, span])
            k = obs[start]
            kernels.refine_bearing_elevation(
                mean,
                cov,
                who[span],
                sightings.z[k],
                sightings.R[k],
                landmark_mean[span],
                landmark_cov[span],
                angles[:, span],
                model.sensor_height_m,
                gate,
                mahalanobis[span],
                det[span],
            )
        gated = int(np.count_nonzero(~(mahalanobis <= gate)))
        return mean, cov, _summed_log_likelihoods(mahalanobis, det, who, gate, len(mean)), gated


def _summed_log_likelihoods(
    mahalanobis: np.ndarray, det: np.ndarray, who: np.ndarray, gate: float, n: int
) -> np.ndarray:
    """(n,) each particle's sum of its pairs' predictive log-likelihoods (2-D innovations of
    squared Mahalanobis distance ``mahalanobis`` and covariance determinant ``det``), each
    distance truncated at ``gate`` as ``refine_proposal`` truncates it."""
    truncated = np.minimum(mahalanobis, gate)
    log_likelihood = log_likelihood_from_mahalanobis(truncated, np.log(det), 2)
    log_factors = np.bincount(who, weights=log_likelihood, minlength=n)
    return log_factors.astype(float, copy=False)  # int64 when there are no pairs


def converged_pairs(
    block: LandmarkBlock, pairs: Pairs, usable: np.ndarray, config: ProposalConfig
) -> np.ndarray:
    """Which usable pairs of a map of triangulated landmarks may refine the proposal.

    A landmark triangulated from two rays of little parallax is uncertain in depth and its
    error is correlated with the poses that triangulated it; the proposal (which treats the
    observations as independent given the map) then trusts it too much. Only landmarks whose
    position std sqrt(tr Sigma) is at most ``config.max_landmark_std_m`` are used, and of those
    at most ``config.max_sightings`` sightings, the best-converged (smallest mean tr Sigma over
    the particles) first.

    Args:
        block: the landmarks of the N pairs; pairs: the frame's pairs.
        usable: (N,) the pairs whose landmark is established (and not tentative).
        config: the proposal section.

    Returns:
        (N,) bool over the pairs: ``usable`` and selected.
    """
    trace = np.trace(block.cov, axis1=-2, axis2=-1)
    keep = trace <= config.max_landmark_std_m**2
    cap = config.max_sightings
    candidates = usable & keep
    if cap > 0:
        obs = pairs.obs[candidates]
        if np.unique(obs).size > cap:
            n_obs = int(pairs.obs.max()) + 1
            total = np.bincount(obs, weights=trace[candidates], minlength=n_obs)
            count = np.bincount(obs, minlength=n_obs)
            score = np.where(count > 0, total / np.maximum(count, 1), np.inf)
            best = np.argsort(score, kind="stable")[:cap]
            keep &= np.isin(pairs.obs, best)
    return usable & keep
