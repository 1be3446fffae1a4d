"""FastSLAM 1.0 and 2.0 (Guizilini 2008 sec. 4.4; Montemerlo 2003), vectorised over particles.

One step (thesis Fig. 4.1, Fig. 4.11):

1. *Prediction.* FastSLAM 1.0 samples each particle's pose from the odometry motion model
   (thesis eqs. 4.38-4.44). FastSLAM 2.0 refines the motion prediction of each particle by its
   matched observations of established landmarks and samples from that (eqs. 4.45-4.46,
   ``proposal.py``). A frame without observations only predicts (asynchronous front end,
   sec. 4.5), and the weights stay as they are.
2. *Mapping.* Per particle and sighting, the landmark EKF (sec. 4.4.1): a new landmark is
   initialised from the sighting (range-bearing) or stores its ray (bearing, eq. 4.24), is
   triangulated at the next sighting (eqs. 4.21, 4.26-4.27) and EKF-updated afterwards
   (eqs. 4.29-4.37). The existence index (sec. 5.1.2) optionally deletes landmarks that keep
   not being seen where they should be. In 3-D a chi-square validation gate keeps bearings of
   feature tracks that jumped to another point out of the proposal and the landmark EKFs.
3. *Weights.* Log-likelihood of the innovations (1.0: eq. 4.47 with S from eq. 4.34; 2.0: the
   predictive likelihood that also includes the pose uncertainty), normalised (eq. 4.48).
4. *Resampling* with the low-variance sampler, only when ESS (eq. 4.51) drops below a fraction
   of P (sec. 4.4.2.3); the landmark store copies maps by reference (tree) or by value (dense).

Landmarks are addressed by slots shared by all particles: a known landmark id always maps to
the same slot; for sightings of unknown association (id -1, 2-D only) every particle picks its
maximum-likelihood landmark or creates a new one (``association.py``); a new landmark gets one
slot per sighting, used by the particles that created it and absent in the others.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from omnislam.core.gating import chi_square_gate, gate_truncated_log_likelihood
from omnislam.core.kalman import ekf_update, initialize_from_inverse
from omnislam.core.measurement import (
    BearingElevation3D,
    RangeAzimuthElevation3D,
    RangeBearing2D,
    azimuth_elevation_from_unit_vectors,
)
from omnislam.core.motion import OdometryMotionModel
from omnislam.core.types import Estimate, FrameInput
from omnislam.errors import ConfigError, DataError
from omnislam.fastslam.association import NEW_LANDMARK, maximum_likelihood_association
from omnislam.fastslam.bearing_landmarks import (
    RAY_DIM,
    first_estimate,
    triangulate,
    triangulated_measurement,
    world_rays,
)
from omnislam.fastslam.config import (
    BearingUpdate,
    FastSLAMConfig,
    ProposalUpdateMode,
    ResamplingScheme,
    SensorMode,
    StoreKind,
    TrajectoryMode,
    Variant,
)
from omnislam.fastslam.dense_store import DenseLandmarkStore
from omnislam.fastslam.existence import predicted_visible
from omnislam.fastslam.landmark_store import LandmarkBlock, LandmarkStatus, LandmarkStore
from omnislam.fastslam.landmark_tree import LandmarkTree, TreeLayout
from omnislam.fastslam.particles import ParticleSet, PathHistory
from omnislam.fastslam.proposal import joint_proposal, refine_proposal, sample_poses
from omnislam.fastslam.resampling import (
    multinomial_resample,
    stratified_resample,
    systematic_resample,
)

#: ids reported for landmarks created from sightings of unknown association: base + slot
UNKNOWN_SLOT_ID_BASE = 1 << 32

_RESAMPLERS = {
    ResamplingScheme.SYSTEMATIC: systematic_resample,
    ResamplingScheme.STRATIFIED: stratified_resample,
    ResamplingScheme.MULTINOMIAL: multinomial_resample,
}
_ESTIMATED = np.int8(LandmarkStatus.ESTIMATED)
_RAY = np.int8(LandmarkStatus.RAY)
_ABSENT = np.int8(LandmarkStatus.ABSENT)


def make_store(
    kind: StoreKind, n_particles: int, dim: int, ray_dim: int, capacity: int
) -> LandmarkStore:
    """The landmark store of the given kind (tree, leaf-only tree or dense arrays)."""
    if kind is StoreKind.DENSE:
        return DenseLandmarkStore(n_particles, dim, ray_dim, capacity)
    layout = TreeLayout.ALL_NODES if kind is StoreKind.TREE else TreeLayout.LEAF_ONLY
    return LandmarkTree(n_particles, dim, ray_dim, 4 * capacity, layout)


@dataclass(frozen=True, slots=True)
class _Sightings:
    """One frame's observations in filter form.

    z is (range, bearing) in 2-D and (azimuth, elevation) in 3-D; R its noise covariance.
    """

    ids: np.ndarray  # (K,)
    z: np.ndarray  # (K, k)
    R: np.ndarray  # (K, k, k)
    unit_vectors_r: np.ndarray | None = None  # (K, 3), 3-D only
    sigmas_rad: np.ndarray | None = None  # (K,), 3-D only


@dataclass(frozen=True, slots=True)
class _Pairs:
    """(particle, slot, sighting) triples to process, N of them."""

    particle: np.ndarray
    slot: np.ndarray
    obs: np.ndarray
    new_unknown: np.ndarray  # bool: an unknown sighting this particle made a new landmark


class FastSLAM:
    """FastSLAM 1.0 / 2.0 estimator (``omnislam.core.types.Estimator``).

    Args:
        config: all settings; ``config.variant`` sets ``name`` ("fastslam1" / "fastslam2").
        rng: the only source of randomness.
        initial_pose: (3,) [x, y, theta] of the first frame; the map is anchored there.
    """

    def __init__(
        self,
        config: FastSLAMConfig,
        rng: np.random.Generator,
        initial_pose: np.ndarray | None = None,
    ) -> None:
        self.config = config
        self.name = config.name
        self._rng = rng
        self._motion = OdometryMotionModel(config.motion_noise)
        pose = np.zeros(3) if initial_pose is None else np.asarray(initial_pose, dtype=float)
        if pose.shape != (3,) or not np.all(np.isfinite(pose)):
            raise ConfigError(f"initial_pose must be a finite (3,) array, got {pose!r}")
        p = config.n_particles
        poses = np.tile(pose, (p, 1))
        sigma = np.asarray(config.initial_pose_sigma, dtype=float)
        if np.any(sigma > 0):
            poses = poses + sigma * rng.standard_normal((p, 3))
        self._particles = ParticleSet(poses)
        self._history = PathHistory(
            keep_particles=config.trajectory is TrajectoryMode.BEST_ANCESTRY
        )
        self._range_bearing = RangeBearing2D()
        self._bearing = BearingElevation3D(config.sensor_height_m)
        self._range_az_el = RangeAzimuthElevation3D(config.sensor_height_m)
        #: 3-D validation gates of (azimuth, elevation) and (d, theta, phi) innovations
        self._bearing_gate = chi_square_gate(config.bearing_gate_probability, 2)
        self._triangulated_gate = chi_square_gate(config.bearing_gate_probability, 3)
        self._mode: SensorMode | None = None
        self._store: LandmarkStore | None = None
        self._slot_of_id: dict[int, int] = {}
        self._slot_ids = np.zeros(0, dtype=np.int64)
        self._reference_xy = np.zeros((0, 2))  # last written position of each slot (gating)
        self._reference_valid = np.zeros(0, dtype=bool)
        self._n_slots = 0
        #: number of resamplings so far
        self.resample_count = 0
        #: effective sample size after the last update
        self.last_ess = float(p)
        if config.sensor_mode is not SensorMode.AUTO:
            self._set_mode(config.sensor_mode)

    # -- read-only views ----------------------------------------------------------------------

    @property
    def particles(self) -> ParticleSet:
        """The particle set (poses and log weights)."""
        return self._particles

    @property
    def store(self) -> LandmarkStore | None:
        """The landmark store (None until the first observation fixes the sensor mode)."""
        return self._store

    @property
    def mode(self) -> SensorMode | None:
        """2-D or 3-D once fixed."""
        return self._mode

    # -- the Estimator protocol -----------------------------------------------------------------

    def step(self, frame: FrameInput) -> None:
        """Predict with the frame's odometry; if it carries observations, map, weigh and
        resample when the effective sample size is low."""
        delta = frame.odometry.delta
        sightings = self._read_sightings(frame)
        particles = self._particles
        if sightings is None:
            particles.poses = self._motion.sample(particles.poses, delta, self._rng)
            self._history.record(frame.stamp_s, particles)
            return
        previous = particles.poses
        if self.config.variant is Variant.FASTSLAM1:
            poses = self._motion.sample(previous, delta, self._rng)
            pairs = self._associate(sightings, poses, None)
            log_factors = np.zeros(len(particles))
        else:
            mean, cov = self._motion.predict(previous, None, delta)
            pairs = self._associate(sightings, mean, cov)
            poses, log_factors = self._sample_proposal(previous, delta, mean, cov, sightings, pairs)
        particles.poses = poses
        log_factors += self._update_landmarks(poses, sightings, pairs)
        if self.config.existence is not None:
            self._apply_existence_index(poses, pairs)
        particles.reweight(log_factors)
        self._history.record(frame.stamp_s, particles)
        self.last_ess = particles.effective_sample_size()
        fraction = self.config.resample_ess_fraction
        # fraction 1 means "every step": ESS of equal weights is P only up to rounding
        if fraction >= 1.0 or self.last_ess < fraction * len(particles):
            self._resample()

    def estimate(self) -> Estimate:
        """The trajectory chosen by ``config.trajectory`` and the best particle's map.

        2-D landmarks are reported with z = 0 and zero z-variance.
        """
        best = self._particles.best()
        if self.config.trajectory is TrajectoryMode.BEST_ANCESTRY:
            trajectory, pose_covariances = self._history.ancestry_trajectory(best), None
        else:
            trajectory, pose_covariances = self._history.mean_trajectory()
        if self._store is None or self._store.n_landmarks == 0:
            return Estimate(trajectory, pose_covariances=pose_covariances)
        block = self._store.particle_map(best)
        mapped = np.flatnonzero(block.status == _ESTIMATED)
        d = block.mean.shape[1]
        means = np.zeros((mapped.size, 3))
        means[:, :d] = block.mean[mapped]
        covs = np.zeros((mapped.size, 3, 3))
        covs[:, :d, :d] = block.cov[mapped]
        return Estimate(
            trajectory,
            landmark_ids=self._slot_ids[mapped],
            landmarks_w=means,
            landmark_covariances=covs,
            pose_covariances=pose_covariances,
        )

    # -- observations -------------------------------------------------------------------------

    def _set_mode(self, mode: SensorMode) -> None:
        self._mode = mode
        three_d = mode is SensorMode.BEARINGS_3D
        self._store = make_store(
            self.config.store,
            self.config.n_particles,
            3 if three_d else 2,
            RAY_DIM if three_d else 0,
            self.config.initial_landmark_capacity,
        )

    def _read_sightings(self, frame: FrameInput) -> _Sightings | None:
        """The frame's observations of the filter's kind, or None (prediction only).

        With ``SensorMode.AUTO`` the first frame with observations fixes the mode; afterwards
        only observations of that kind are read.
        """
        has_rb = frame.range_bearing is not None and len(frame.range_bearing) > 0
        has_b = frame.bearings is not None and len(frame.bearings) > 0
        if self._mode is None:
            if has_rb and has_b:
                raise DataError(
                    f"frame {frame.index} carries both range-bearing and bearing sightings; "
                    "set FastSLAMConfig.sensor_mode to choose one"
                )
            if not (has_rb or has_b):
                return None
            self._set_mode(SensorMode.RANGE_BEARING_2D if has_rb else SensorMode.BEARINGS_3D)
        if self._mode is SensorMode.RANGE_BEARING_2D:
            if not has_rb:
                return None
            rb = frame.range_bearing
            assert rb is not None
            k = len(rb)
            R = np.zeros((k, 2, 2))
            R[:, 0, 0] = rb.sigma_range_m**2
            R[:, 1, 1] = rb.sigma_bearing_rad**2
            z = np.stack([rb.ranges_m, rb.bearings_rad], axis=-1)
            return _Sightings(np.asarray(rb.landmark_ids), z, R)
        if not has_b:
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
        return _Sightings(
            np.asarray(bearings.landmark_ids),
            z,
            R,
            np.asarray(bearings.unit_vectors_r),
            np.asarray(bearings.sigmas_rad),
        )

    # -- slots ----------------------------------------------------------------------------------

    def _add_slots(self, external_ids: np.ndarray | None, count: int) -> np.ndarray:
        """Allocate ``count`` slots in the store; ids default to UNKNOWN_SLOT_ID_BASE + slot."""
        assert self._store is not None
        slots = self._store.add_landmarks(count)
        end = self._n_slots + count
        if end > self._slot_ids.size:
            capacity = max(end, 2 * self._slot_ids.size, 16)
            self._slot_ids = np.resize(self._slot_ids, capacity)
            self._reference_xy = np.concatenate(
                [self._reference_xy, np.zeros((capacity - self._reference_xy.shape[0], 2))]
            )
            valid = np.zeros(capacity, dtype=bool)
            valid[: self._n_slots] = self._reference_valid[: self._n_slots]
            self._reference_valid = valid
        ids = UNKNOWN_SLOT_ID_BASE + slots if external_ids is None else external_ids
        self._slot_ids[self._n_slots : end] = ids
        self._reference_valid[self._n_slots : end] = False
        self._n_slots = end
        return slots

    def _slots_for_ids(self, ids: np.ndarray) -> np.ndarray:
        """Slots of known landmark ids, allocating slots for ids seen for the first time."""
        slots = np.empty(ids.size, dtype=np.int64)
        fresh: list[int] = []
        for i, landmark_id in enumerate(ids.tolist()):
            slot = self._slot_of_id.get(landmark_id)
            if slot is None:
                slot = self._n_slots + len(fresh)
                self._slot_of_id[landmark_id] = slot
                fresh.append(landmark_id)
            slots[i] = slot
        if fresh:
            self._add_slots(np.array(fresh, dtype=np.int64), len(fresh))
        return slots

    def add_known_landmarks(self, ids: np.ndarray) -> np.ndarray:
        """Reserve slots for known landmark ids up front (absent in every particle).

        Optional: ids are otherwise given slots when first seen. Returns their slots.
        """
        if self._store is None:
            raise ConfigError("set FastSLAMConfig.sensor_mode to reserve landmarks up front")
        return self._slots_for_ids(np.asarray(ids, dtype=np.int64))

    def _candidates(self, center_xy: np.ndarray, radius_m: float) -> np.ndarray:
        """Slots whose last written position lies within ``radius_m`` of ``center_xy``."""
        n = self._n_slots
        offsets = self._reference_xy[:n] - center_xy
        near = np.einsum("ij,ij->i", offsets, offsets) <= radius_m * radius_m
        return np.flatnonzero(near & self._reference_valid[:n])

    # -- association ----------------------------------------------------------------------------

    def _associate(
        self, sightings: _Sightings, poses: np.ndarray, pose_cov: np.ndarray | None
    ) -> _Pairs:
        """(particle, slot, sighting) triples: known ids map to their slots in every particle;
        unknown sightings are associated per particle by maximum likelihood."""
        p = len(poses)
        known = np.flatnonzero(sightings.ids >= 0)
        unknown = np.flatnonzero(sightings.ids < 0)
        parts: list[_Pairs] = []
        if known.size:
            slots = self._slots_for_ids(sightings.ids[known])
            parts.append(
                _Pairs(
                    np.repeat(np.arange(p), known.size),
                    np.tile(slots, p),
                    np.tile(known, p),
                    np.zeros(p * known.size, dtype=bool),
                )
            )
        if unknown.size:
            parts.append(self._associate_unknown(sightings, unknown, poses, pose_cov))
        if len(parts) == 1:
            return parts[0]
        names = [f.name for f in fields(_Pairs)]
        return _Pairs(*(np.concatenate([getattr(part, name) for part in parts]) for name in names))

    def _associate_unknown(
        self,
        sightings: _Sightings,
        unknown: np.ndarray,
        poses: np.ndarray,
        pose_cov: np.ndarray | None,
    ) -> _Pairs:
        assert self._store is not None
        p = len(poses)
        center = np.average(poses[:, :2], axis=0, weights=self._particles.weights)
        radius = float(sightings.z[unknown, 0].max()) + self.config.association_margin_m
        candidates = self._candidates(center, radius)
        c = candidates.size
        block = self._store.gather(np.repeat(np.arange(p), c), np.tile(candidates, p))
        choice, _ = maximum_likelihood_association(
            poses,
            pose_cov,
            block.mean.reshape(p, c, 2),
            block.cov.reshape(p, c, 2, 2),
            (block.status == _ESTIMATED).reshape(p, c),
            sightings.z[unknown],
            sightings.R[unknown],
            self._range_bearing,
            self.config.new_landmark_log_likelihood,
        )
        new = choice == NEW_LANDMARK  # (P, K_u)
        wanted = np.flatnonzero(new.any(axis=0))
        new_slots = np.full(unknown.size, -1, dtype=np.int64)
        if wanted.size:
            new_slots[wanted] = self._add_slots(None, wanted.size)
        existing = candidates[np.maximum(choice, 0)] if c else np.zeros_like(choice)
        slots = np.where(new, new_slots[None, :], existing)
        return _Pairs(
            np.repeat(np.arange(p), unknown.size),
            slots.ravel(),
            np.tile(unknown, p),
            new.ravel(),
        )

    # -- FastSLAM 2.0 proposal ----------------------------------------------------------------

    def _sample_proposal(
        self,
        previous: np.ndarray,
        delta: np.ndarray,
        mean: np.ndarray,
        cov: np.ndarray,
        sightings: _Sightings,
        pairs: _Pairs,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Thesis 4.45-4.46 / Montemerlo 2003: refine each particle's motion prediction by its
        sightings of established landmarks, one after the other, and sample from the result
        (``ProposalUpdateMode.SEQUENTIAL``); or all of them in one update linearised at the
        prediction (``JOINT``, ``proposal.joint_proposal``).

        Particles without such sightings sample from the motion model itself (as FastSLAM 1.0).
        In 3-D the proposal uses the direct (azimuth, elevation) model: the thesis's
        triangulated pseudo-measurement depends on the very pose being sampled.

        Returns:
            poses (P, 3) and the log importance factors (P,) of eq. 4.47 with the predictive
            covariance H_x P H_x^T + H_m Sigma H_m^T + R.
        """
        assert self._store is not None
        p = len(previous)
        if self._mode is SensorMode.RANGE_BEARING_2D:
            model, gate = self._range_bearing, np.inf
        else:
            model, gate = self._bearing, self._bearing_gate
        block = self._store.gather(pairs.particle, pairs.slot)
        usable = (block.status == _ESTIMATED) & ~pairs.new_unknown
        if self._mode is SensorMode.BEARINGS_3D:
            usable &= self._proposal_landmarks(block, pairs, usable)
        refined = np.zeros(p, dtype=bool)
        if self.config.proposal_update is ProposalUpdateMode.JOINT:
            # all of a particle's sightings in one update at the prediction (joint_proposal)
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
                model,
                gate,
            )
            mean, cov, log_factors = joint.mean, joint.cov, joint.log_likelihood
            refined[pairs.particle[rows]] = True
        else:
            log_factors = np.zeros(p)
            mean = mean.copy()
            cov = cov.copy()
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
                refined[who] = True
        poses = np.empty_like(previous)
        poses[refined] = sample_poses(mean[refined], cov[refined], self._rng)
        plain = ~refined
        if plain.any():
            poses[plain] = self._motion.sample(previous[plain], delta, self._rng)
        return poses, log_factors

    def _proposal_landmarks(
        self, block: LandmarkBlock, pairs: _Pairs, usable: np.ndarray
    ) -> np.ndarray:
        """3-D: which established landmarks may refine the FastSLAM 2.0 proposal.

        A landmark triangulated from two rays of little parallax is uncertain in depth and its
        error is correlated with the poses that triangulated it; the proposal (which treats the
        observations as independent given the map) then trusts it too much. Only landmarks
        whose position std sqrt(tr Sigma) is at most ``proposal_max_landmark_std_m`` are used,
        and of those at most ``proposal_max_sightings`` sightings, the best-converged (smallest
        mean tr Sigma over the particles) first.

        Returns:
            (N,) bool over the pairs.
        """
        config = self.config
        trace = np.trace(block.cov, axis1=-2, axis2=-1)
        keep = trace <= config.proposal_max_landmark_std_m**2
        cap = config.proposal_max_sightings
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
        return keep

    # -- mapping -------------------------------------------------------------------------------

    @staticmethod
    def _rounds(pairs: _Pairs, n_slots: int) -> np.ndarray:
        """Rank of each pair among the pairs with the same (particle, slot): a landmark seen
        twice in one frame is updated twice, in successive rounds."""
        key = pairs.particle * max(n_slots, 1) + pairs.slot
        order = np.argsort(key, kind="stable")
        sorted_key = key[order]
        n = key.size
        starts = np.r_[True, sorted_key[1:] != sorted_key[:-1]]
        group_start = np.maximum.accumulate(np.where(starts, np.arange(n), 0))
        rank = np.empty(n, dtype=np.int64)
        rank[order] = np.arange(n) - group_start
        return rank

    def _update_landmarks(
        self, poses: np.ndarray, sightings: _Sightings, pairs: _Pairs
    ) -> np.ndarray:
        """Update every addressed landmark EKF with the sampled poses.

        Returns:
            (P,) log weight factors: the EKF innovation likelihoods for FastSLAM 1.0 (thesis
            eq. 4.47), plus log p0 for each unknown sighting a particle made a new landmark.
        """
        assert self._store is not None
        p = len(poses)
        log_factors = np.zeros(p)
        if pairs.new_unknown.any():
            np.add.at(
                log_factors,
                pairs.particle[pairs.new_unknown],
                self.config.new_landmark_log_likelihood,
            )
        known = sightings.ids[sightings.ids >= 0]
        if known.size == sightings.ids.size and np.unique(known).size == known.size:
            rank = np.zeros(pairs.particle.size, dtype=np.int64)  # one round: all distinct
        else:
            rank = self._rounds(pairs, self._n_slots)
        weigh = self.config.variant is Variant.FASTSLAM1
        for r in range(int(rank.max(initial=0)) + 1):
            rows = np.flatnonzero(rank == r)
            who, slots, obs = pairs.particle[rows], pairs.slot[rows], pairs.obs[rows]
            block = self._store.gather(who, slots)
            if self._mode is SensorMode.RANGE_BEARING_2D:
                log_likelihood = self._update_2d(block, poses[who], sightings, obs)
            else:
                log_likelihood = self._update_3d(block, poses[who], sightings, obs)
            if weigh:
                np.add.at(log_factors, who, log_likelihood)
            block.existence += 1  # thesis 5.1.2: +1 when seen
            self._store.scatter(who, slots, block)
            estimated = block.status == _ESTIMATED
            self._reference_xy[slots[estimated]] = block.mean[estimated, :2]
            self._reference_valid[slots[estimated]] = True
        return log_factors

    def _update_2d(
        self, block: LandmarkBlock, wTr: np.ndarray, sightings: _Sightings, obs: np.ndarray
    ) -> np.ndarray:
        """Range-bearing landmarks: initialise from the inverse model or EKF-update."""
        log_likelihood = np.zeros(len(block))
        z, R = sightings.z[obs], sightings.R[obs]
        est = block.status == _ESTIMATED
        if est.all():  # the common case: no boolean-mask copies
            update = ekf_update(wTr, block.mean, block.cov, z, R, self._range_bearing)
            block.mean, block.cov = update.mean, update.cov
            return update.log_likelihood
        if est.any():
            update = ekf_update(
                wTr[est], block.mean[est], block.cov[est], z[est], R[est], self._range_bearing
            )
            block.mean[est] = update.mean
            block.cov[est] = update.cov
            log_likelihood[est] = update.log_likelihood
        new = ~est
        if new.any():
            mean, cov = initialize_from_inverse(
                wTr[new], z[new], R[new], self._range_bearing.inverse
            )
            block.mean[new] = mean
            block.cov[new] = cov
            block.status[new] = _ESTIMATED
            block.existence[new] = 0
        return log_likelihood

    def _update_3d(
        self, block: LandmarkBlock, wTr: np.ndarray, sightings: _Sightings, obs: np.ndarray
    ) -> np.ndarray:
        """Bearing landmarks, thesis sec. 4.4.1: store the ray, triangulate, then EKF-update
        (triangulated pseudo-measurement or direct azimuth/elevation, ``BearingUpdate``)."""
        assert sightings.unit_vectors_r is not None and sightings.sigmas_rad is not None
        config = self.config
        # each ray enters two triangulations only when later sightings are triangulated too
        triangulated = config.bearing_update is BearingUpdate.TRIANGULATED
        ray_reuse = config.triangulated_ray_reuse if triangulated else 1.0
        log_likelihood = np.zeros(len(block))
        rays = world_rays(wTr, sightings.unit_vectors_r[obs], config.sensor_height_m)
        sigma = sightings.sigmas_rad[obs]
        absent = np.flatnonzero(block.status == _ABSENT)
        ray_only = np.flatnonzero(block.status == _RAY)
        est = np.flatnonzero(block.status == _ESTIMATED)

        # first sighting: store the ray (eq. 4.24)
        block.ray[absent] = rays[absent]
        block.status[absent] = _RAY
        block.existence[absent] = 0

        # first match: triangulate (eq. 4.21) and Sigma = R Q R^T (eqs. 4.26-4.27)
        if ray_only.size:
            ok, z3, Q = self._triangulated(block, ray_only, rays, wTr, sigma, ray_reuse)
            rows = ray_only[ok]
            if rows.size:
                block.mean[rows], block.cov[rows] = first_estimate(
                    self._range_az_el, wTr[rows], z3, Q
                )
                block.status[rows] = _ESTIMATED
                block.ray[rows] = rays[rows]  # eq. 4.28: keep the latest sighting

        # later matches: EKF update (eqs. 4.29-4.37), outliers gated out
        if est.size:
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
        config = self.config
        points, valid, parallax = triangulate(config.triangulation, block.ray[rows], rays[rows])
        ok = valid & (parallax >= config.min_parallax_rad)
        kept = rows[ok]
        if not kept.size:
            return ok, np.zeros((0, 3)), np.zeros((0, 3, 3))
        z3, Q = triangulated_measurement(
            self._range_az_el, wTr[kept], points[ok], sigma[kept], parallax[ok], ray_reuse
        )
        return ok, z3, Q

    @staticmethod
    def _gated_update(
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
        return accepted

    def _apply_existence_index(self, poses: np.ndarray, pairs: _Pairs) -> None:
        """Thesis 5.1.2: -1 for every established landmark predicted inside the sensor's field
        but not seen; negative -> deleted from that particle's map."""
        config = self.config.existence
        assert config is not None and self._store is not None
        center = np.average(poses[:, :2], axis=0, weights=self._particles.weights)
        candidates = self._candidates(center, config.max_range_m + self.config.association_margin_m)
        if candidates.size == 0:
            return
        p = len(poses)
        who = np.repeat(np.arange(p), candidates.size)
        slots = np.tile(candidates, p)
        m = max(self._n_slots, 1)
        unseen = ~np.isin(who * m + slots, pairs.particle * m + pairs.slot)
        who, slots = who[unseen], slots[unseen]
        block = self._store.gather(who, slots)
        missed = (block.status == _ESTIMATED) & predicted_visible(
            config, poses[who], block.mean, self.config.sensor_height_m
        )
        rows = np.flatnonzero(missed)
        if rows.size == 0:
            return
        changed = block.take(rows)
        changed.existence -= 1
        gone = changed.existence < 0
        changed.status[gone] = _ABSENT
        changed.existence[gone] = 0
        changed.mean[gone] = 0.0
        changed.cov[gone] = 0.0
        changed.ray[gone] = 0.0
        self._store.scatter(who[rows], slots[rows], changed)

    # -- resampling ---------------------------------------------------------------------------

    def _resample(self) -> None:
        """Low-variance resampling (thesis 4.49, Thrun et al. Table 4.4) of poses and maps."""
        assert self._store is not None
        ancestors = _RESAMPLERS[self.config.resampling](self._particles.weights, self._rng)
        self._history.record_resampling(ancestors)
        self._particles.resample(ancestors)
        self._store.resample(ancestors)
        self.resample_count += 1
