"""FastSLAM 1.0 and 2.0 (Guizilini 2008 sec. 4.4; Montemerlo 2003), vectorised over particles.

One step (thesis Fig. 4.1, Fig. 4.11):

1. *Prediction.* FastSLAM 1.0 samples each particle's pose from the odometry motion model
   (thesis eqs. 4.38-4.44). FastSLAM 2.0 refines the motion prediction of each particle by its
   matched observations of established landmarks and samples from that (eqs. 4.45-4.46,
   ``proposal_sampling.py``). A frame without observations only predicts (asynchronous front
   end, sec. 4.5), and the weights stay as they are.
2. *Association.* Known ids address their slots in every particle; sightings of unknown
   association are associated per particle by maximum likelihood (``association.py``).
3. *Mapping.* Per particle and sighting, the landmark EKF of the filter's modality (sec.
   4.4.1): range-bearing landmarks are initialised from the sighting and EKF-updated
   (``range_bearing_mapper.py``); bearing landmarks store a ray (eq. 4.24), are triangulated at
   a later sighting (eqs. 4.21, 4.26-4.27) and EKF-updated afterwards (eqs. 4.29-4.37), with a
   chi-square gate against jumped feature tracks (``bearing_mapper.py``). The existence index
   (sec. 5.1.2, ``existence.py``) optionally deletes landmarks that keep not being seen where
   they should be.
4. *Weights.* Log-likelihood of the innovations (1.0: eq. 4.47 with S from eq. 4.34; 2.0: the
   predictive likelihood that also includes the pose uncertainty), normalised (eq. 4.48).
5. *Resampling* with the low-variance sampler, only when ESS (eq. 4.51) drops below a fraction
   of P (sec. 4.4.2.3); the landmark store copies maps by reference (tree) or by value (dense).

Landmarks are addressed by slots shared by all particles (``slot_registry.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from omnislam.core.gating import chi_square_gate
from omnislam.core.measurement import RangeBearing2D
from omnislam.core.modality import Modality
from omnislam.core.motion import MotionModel, StatedOdometryMotion
from omnislam.core.se import se2_compose
from omnislam.core.types import Estimate, FrameInput, OdometrySource
from omnislam.errors import ConfigError
from omnislam.fastslam.association import SightingAssociation
from omnislam.fastslam.bearing_mapper import BearingMapper
from omnislam.fastslam.config import (
    FastSLAMConfig,
    ResamplingScheme,
    StoreKind,
    TrajectoryMode,
    Variant,
)
from omnislam.fastslam.dense_store import DenseLandmarkStore
from omnislam.fastslam.diversity import DiversityLog
from omnislam.fastslam.existence import ExistenceIndex
from omnislam.fastslam.gap import ComposedGap
from omnislam.fastslam.kernels import resolve as resolve_kernels
from omnislam.fastslam.landmark_store import ESTIMATED, RAY, LandmarkBlock, LandmarkStore
from omnislam.fastslam.landmark_tree import LandmarkTree, TreeLayout
from omnislam.fastslam.mapper import make_mapper
from omnislam.fastslam.particles import ParticleSet, PathHistory
from omnislam.fastslam.pose_spread import PoseSpread
from omnislam.fastslam.proposal_sampling import ProposalSampler
from omnislam.fastslam.resampling import (
    island_bounds,
    island_resample,
    multinomial_resample,
    normalize_per_island,
    stratified_resample,
    systematic_resample,
)
from omnislam.fastslam.resighting import ResightingSpread
from omnislam.fastslam.sightings import Pairs, Sightings, tentative_pairs
from omnislam.fastslam.slot_registry import SlotRegistry

_RESAMPLERS = {
    ResamplingScheme.SYSTEMATIC: systematic_resample,
    ResamplingScheme.STRATIFIED: stratified_resample,
    ResamplingScheme.MULTINOMIAL: multinomial_resample,
}


def make_store(
    kind: StoreKind,
    n_particles: int,
    dim: int,
    ray_dim: int,
    capacity: int,
    kernels: object | None = None,
) -> LandmarkStore:
    """The landmark store of the given kind (tree, leaf-only tree or dense arrays); the trees
    walk with the compiled ``kernels`` when given."""
    if kind is StoreKind.DENSE:
        return DenseLandmarkStore(n_particles, dim, ray_dim, capacity)
    layout = TreeLayout.ALL_NODES if kind is StoreKind.TREE else TreeLayout.LEAF_ONLY
    return LandmarkTree(n_particles, dim, ray_dim, 4 * capacity, layout, kernels)


@dataclass(frozen=True, slots=True)
class FastSLAMInfo:
    """What a FastSLAM estimator has done so far (``FastSLAM.info``; ``estimator_info.json``).

    Attributes:
        variant: FastSLAM 1.0 or 2.0.
        modality: the observation stream it reads.
        particles: number of particles P.
        frames: frames consumed.
        frames_with_sightings: frames that carried sightings of the modality (mapped and
            weighed; the others only predicted).
        frames_stated_odometry: frames whose pose noise was drawn from the odometry's stated
            covariance (``config.stated_odometry_noise``), not from the alpha model.
        resample_count: resamplings so far.
        last_ess: effective sample size after the last update (thesis eq. 4.51).
        landmark_slots: landmarks known to any particle (slots).
        landmarks: landmarks estimated in the best particle's map (those ``estimate()``
            reports).
        rays_pending: landmarks of the best particle with a stored ray only, waiting for a ray
            with enough parallax (3-D).
        unknown_slots: slots created for sightings of unknown association.
        unknown_matched: (particle, sighting) decisions that gave a sighting of unknown
            association to a landmark of the particle's map.
        unknown_new: (particle, sighting) decisions that made such a sighting a new landmark.
        landmarks_pruned: (particle, landmark) deletions by the existence index (thesis
            5.1.2).
        sightings_gated: (particle, sighting) landmark updates rejected by the outlier gate
            (3-D: the bearing gate; 2-D: ``outlier_gate_probability``).
        proposal_sightings_gated: (particle, sighting) pairs the gate kept out of the
            FastSLAM 2.0 proposal.
        triangulation_fallbacks: triangulated updates of established landmarks replaced by
            the direct bearing update for lack of parallax (3-D, ``BearingUpdate.TRIANGULATED``).
        distinct_ancestors_min: fewest distinct particles of the previous step any step's set
            descended from (``diversity.py``; 1: the set collapsed onto one particle).
        distinct_ancestors_median: median distinct ancestors over the resampling steps.
        single_ancestor_steps: steps with sightings whose set descended from one particle.
        single_ancestor_longest_run: longest run of consecutive such steps.
        ess_min: smallest effective sample size before resampling.
        log_evidence: the particle filter's estimate of log p(z_1:t)
            (``ParticleSet.log_evidence``).
    """

    variant: Variant
    modality: Modality
    particles: int
    frames: int
    frames_with_sightings: int
    frames_stated_odometry: int
    resample_count: int
    last_ess: float
    landmark_slots: int
    landmarks: int
    rays_pending: int
    unknown_slots: int
    unknown_matched: int
    unknown_new: int
    landmarks_pruned: int
    sightings_gated: int
    proposal_sightings_gated: int
    triangulation_fallbacks: int
    distinct_ancestors_min: int
    distinct_ancestors_median: float
    single_ancestor_steps: int
    single_ancestor_longest_run: int
    ess_min: float
    log_evidence: float


class FastSLAM:
    """FastSLAM 1.0 / 2.0 estimator (``omnislam.core.types.Estimator``, ``Introspectable``).

    Args:
        config: all settings; ``config.variant`` sets ``name`` ("fastslam1" / "fastslam2").
        rng: the only source of randomness.
        modality: the one observation stream it reads (``Modality.RANGE_BEARING_2D`` or
            ``Modality.BEARINGS_3D``), resolved by the shared rule (``core.modality``).
        motion: the motion model (``OdometryMotionModel``, or any ``MotionModel``).
        initial_pose: (3,) [x, y, theta] of the first frame; the map is anchored there.
        odometry_source: where the frames' odometry comes from, WHEEL (the dataset's) or
            LASER (the front end's scan matching, ``ObservationLog.odometry_source``);
            with ``config.stated_odometry_noise`` AUTO it decides whether a stated odometry
            covariance is sampled (``StatedOdometryNoise.resolve``).

    Raises:
        ConfigError: a modality FastSLAM does not consume, or a bad initial pose.
    """

    def __init__(
        self,
        config: FastSLAMConfig,
        rng: np.random.Generator,
        *,
        modality: Modality,
        motion: MotionModel,
        initial_pose: np.ndarray | None = None,
        odometry_source: OdometrySource = OdometrySource.WHEEL,
    ) -> None:
        if not isinstance(odometry_source, OdometrySource):
            raise ConfigError(f"unknown odometry source {odometry_source!r}: wheel or laser")
        self.config = config
        self.name = config.name
        self._rng = rng
        self._motion = motion
        self._sample_stated = config.stated_odometry_noise.resolve(odometry_source)
        # a gap is composed only with a motion model that states a step's covariance
        self._gap = ComposedGap() if config.compose_gaps and hasattr(motion, "covariance") else None
        kernels = resolve_kernels(config.kernels)
        self._mapper = make_mapper(modality, config, kernels)
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
            keep_particles=config.trajectory is not TrajectoryMode.WEIGHTED_MEAN, kernels=kernels
        )
        self._smoothing = config.trajectory is TrajectoryMode.SMOOTHED
        if self._smoothing and not hasattr(motion, "covariance"):
            raise ConfigError("trajectory=smoothed needs a motion model with a covariance")
        self._store = make_store(
            config.store,
            p,
            self._mapper.landmark_dim,
            self._mapper.ray_dim,
            config.initial_landmark_capacity,
            kernels,
        )
        self._slots = SlotRegistry(self._store)
        # the spread since a landmark's last sighting needs a motion model that states a step's
        # covariance (``OdometryMotionModel.covariance``)
        self._spread = (
            ResightingSpread(config.resighting_spread)
            if config.resighting_spread > 0 and hasattr(motion, "covariance")
            else None
        )
        self._pose_spread = (
            PoseSpread(config.association_pose_spread)
            if config.association_pose_spread > 0
            and hasattr(motion, "covariance")
            and modality is Modality.RANGE_BEARING_2D
            else None
        )
        self._association = SightingAssociation(
            self._slots,
            self._store,
            config.association_margin_m,
            config.new_landmark_log_likelihood,
            config.association_exclusive,
            self._spread,
            None
            if config.association_gate_probability >= 1.0
            else chi_square_gate(config.association_gate_probability, 2),
            self._pose_spread,
            kernels,
        )
        self._proposal = ProposalSampler(
            self._mapper, config.proposal_update, motion, rng, kernels, config.confirm_sightings
        )
        self._existence = (
            None
            if config.existence is None
            else ExistenceIndex(
                config.existence, config.association_margin_m, config.sensor_height_m
            )
        )
        self._islands = None if config.islands == 1 else island_bounds(p, config.islands)
        self._diversity = DiversityLog(p)
        #: number of resamplings so far
        self.resample_count = 0
        #: effective sample size after the last update
        self.last_ess = float(p)
        self._frames = 0
        self._frames_with_sightings = 0
        self._proposal_gated = 0
        self._frames_stated = 0

    # -- read-only views ----------------------------------------------------------------------

    @property
    def particles(self) -> ParticleSet:
        """The particle set (poses and log weights)."""
        return self._particles

    @property
    def store(self) -> LandmarkStore:
        """The landmark store."""
        return self._store

    @property
    def modality(self) -> Modality:
        """The observation stream the filter reads."""
        return self._mapper.modality

    @property
    def history(self) -> PathHistory:
        """The per-step record of the particle set (``particles.PathHistory``)."""
        return self._history

    @property
    def diversity(self) -> DiversityLog:
        """Distinct ancestors and ESS of every step with sightings (``diversity.py``)."""
        return self._diversity

    # -- the Estimator protocol -----------------------------------------------------------------

    def step(self, frame: FrameInput) -> None:
        """Predict with the frame's odometry; if it carries sightings of the modality, map,
        weigh and resample when the effective sample size is low."""
        self._frames += 1
        delta = frame.odometry.delta
        sightings = self._mapper.read(frame)
        particles = self._particles
        stated = None
        if frame.odometry.covariance is not None and self._sample_stated:
            stated = StatedOdometryMotion(delta, frame.odometry.covariance)
            self._frames_stated += 1
        motion = self._motion if stated is None else stated
        gap = self._gap
        if self._pose_spread is not None:
            mean = particles.mean_pose()
            self._pose_spread.predict(mean, se2_compose(mean, delta), self._step_cov(delta, stated))
        if sightings is None:
            if self._spread is not None:
                self._spread.advance(delta, self._step_cov(delta, stated))
            if gap is not None:
                particles.poses = gap.extend(particles.poses, delta, self._step_cov(delta, stated))
            else:
                particles.poses = motion.sample(particles.poses, delta, self._rng)
            self._history.record(frame.stamp_s, particles, self._transition(delta, stated))
            return
        self._frames_with_sightings += 1
        step_delta, step_stated = delta, stated
        previous = particles.poses
        if gap is not None and gap.open:
            # the whole gap and this step as one Gaussian motion (``gap.py``)
            previous, delta, stated = gap.close(delta, self._step_cov(delta, stated))
            motion = stated
        if self.config.variant is Variant.FASTSLAM1:
            poses = motion.sample(previous, delta, self._rng)
            pairs = self._association.pairs(sightings, poses, None, particles.weights)
            log_factors = np.zeros(len(particles))
            gathered = None
        else:
            mean, cov = self._proposal.predict(previous, delta, stated)
            pairs = self._association.pairs(sightings, mean, cov, particles.weights)
            draw = self._proposal.sample(
                previous, delta, mean, cov, sightings, pairs, self._store, stated
            )
            poses, log_factors, gathered = draw.poses, draw.log_factors, draw.block
            self._proposal_gated += draw.gated
            if draw.tentative.any():  # a tentative landmark's sighting weighs as a new one
                log_factors = log_factors + self.config.new_landmark_log_likelihood * np.bincount(
                    pairs.particle[draw.tentative], minlength=len(particles)
                )
        if self._spread is not None:  # after the association: the spread up to the last step
            self._spread.advance(step_delta, self._step_cov(step_delta, step_stated))
        particles.poses = poses
        log_factors += self._update_landmarks(poses, sightings, pairs, gathered)
        if self._pose_spread is not None:
            self._shrink_pose_spread(poses, sightings, pairs, particles.weights)
        if self._existence is not None:
            self._existence.apply(self._store, self._slots, poses, particles.weights, pairs)
        particles.reweight(log_factors, self._islands)
        self._history.record(frame.stamp_s, particles, self._transition(delta, stated))
        self.last_ess = particles.effective_sample_size()
        fraction = self.config.resample_ess_fraction
        # fraction 1 means "every step": ESS of equal weights is P only up to rounding
        ancestors = None
        if self._islands is not None:
            ancestors = self._resample_islands()
        elif fraction >= 1.0 or self.last_ess < fraction * len(particles):
            ancestors = self._resample()
        self._diversity.record(self.last_ess, ancestors)

    def estimate(self) -> Estimate:
        """The trajectory chosen by ``config.trajectory`` and the best particle's map.

        2-D landmarks are reported with z = 0 and zero z-variance.
        """
        best = self._particles.best()
        if self.config.trajectory is TrajectoryMode.BEST_ANCESTRY:
            trajectory = self._history.ancestry_trajectory(best)
            pose_covariances = self._history.covariances_about(trajectory.se2)
        elif self.config.trajectory is TrajectoryMode.SMOOTHED:
            trajectory, pose_covariances = self._history.smoothed_trajectory()
        else:
            trajectory, pose_covariances = self._history.mean_trajectory()
        if self._store.n_landmarks == 0:
            return Estimate(trajectory, pose_covariances=pose_covariances)
        block = self._store.particle_map(best)
        mapped = np.flatnonzero(block.status == ESTIMATED)
        d = block.mean.shape[1]
        means = np.zeros((mapped.size, 3))
        means[:, :d] = block.mean[mapped]
        covs = np.zeros((mapped.size, 3, 3))
        covs[:, :d, :d] = block.cov[mapped]
        return Estimate(
            trajectory,
            landmark_ids=self._slots.ids(mapped),
            landmarks_w=means,
            landmark_covariances=covs,
            pose_covariances=pose_covariances,
        )

    def info(self) -> FastSLAMInfo:
        """Counts of what the filter did (``core.types.Introspectable``)."""
        status = self._store.particle_map(self._particles.best()).status
        mapper = self._mapper
        bearing = mapper if isinstance(mapper, BearingMapper) else None
        gated = getattr(mapper, "sightings_gated", 0)
        diversity = self._diversity.summary()
        return FastSLAMInfo(
            variant=self.config.variant,
            modality=self.modality,
            particles=len(self._particles),
            frames=self._frames,
            frames_with_sightings=self._frames_with_sightings,
            frames_stated_odometry=self._frames_stated,
            resample_count=self.resample_count,
            last_ess=self.last_ess,
            landmark_slots=self._slots.n_slots,
            landmarks=int(np.count_nonzero(status == ESTIMATED)),
            rays_pending=int(np.count_nonzero(status == RAY)),
            unknown_slots=self._slots.n_unknown,
            unknown_matched=self._association.matched,
            unknown_new=self._association.created,
            landmarks_pruned=0 if self._existence is None else self._existence.pruned,
            sightings_gated=gated,
            proposal_sightings_gated=self._proposal_gated,
            triangulation_fallbacks=0 if bearing is None else bearing.triangulation_fallbacks,
            distinct_ancestors_min=diversity.distinct_min,
            distinct_ancestors_median=diversity.distinct_median_at_resampling,
            single_ancestor_steps=diversity.single_ancestor_steps,
            single_ancestor_longest_run=diversity.single_ancestor_longest_run,
            ess_min=diversity.ess_min,
            log_evidence=self._particles.log_evidence,
        )

    def add_known_landmarks(self, ids: np.ndarray) -> np.ndarray:
        """Reserve slots for known landmark ids up front (absent in every particle).

        Optional: ids are otherwise given slots when first seen. Returns their slots.
        """
        return self._slots.slots_for_ids(np.asarray(ids, dtype=np.int64))

    def _shrink_pose_spread(
        self, poses: np.ndarray, sightings: Sightings, pairs: Pairs, weights: np.ndarray
    ) -> None:
        """The information of the frame's matched sightings (not the new landmarks) into the
        pose spread (``pose_spread.PoseSpread.update``)."""
        rows = np.flatnonzero(~pairs.new_unknown)
        if rows.size == 0:
            return
        block = self._store.gather(pairs.particle[rows], pairs.slot[rows])
        ok = block.status == ESTIMATED
        rows = rows[ok]
        who = pairs.particle[rows]
        self._pose_spread.update(
            RangeBearing2D(),
            poses[who],
            block.mean[ok],
            block.cov[ok],
            sightings.R[pairs.obs[rows]],
            who,
            weights,
        )

    def _step_cov(self, delta: np.ndarray, stated: StatedOdometryMotion | None) -> np.ndarray:
        """(3, 3) covariance of one odometry delta: the stated one being sampled, else the
        motion model's (``OdometryMotionModel.covariance``)."""
        if stated is not None:
            return stated.covariance
        return self._motion.covariance(delta)  # type: ignore[attr-defined]

    def _transition(
        self, delta: np.ndarray, stated: StatedOdometryMotion | None
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """The step's (delta, covariance) for the smoothed read-out (None when not smoothing)."""
        if not self._smoothing:
            return None
        return np.array(delta, dtype=float), self._step_cov(delta, stated)

    # -- mapping -------------------------------------------------------------------------------

    def _update_landmarks(
        self,
        poses: np.ndarray,
        sightings: Sightings,
        pairs: Pairs,
        gathered: LandmarkBlock | None = None,
    ) -> np.ndarray:
        """Update every addressed landmark EKF with the sampled poses, in rounds (a landmark
        seen twice in a frame is updated twice, ``Pairs.rounds``).

        ``gathered``: the landmarks of all ``pairs`` as gathered for the FastSLAM 2.0 proposal
        (unchanged since), reused when one round updates them all.

        Returns:
            (P,) log weight factors: the EKF innovation likelihoods for FastSLAM 1.0 (thesis
            eq. 4.47), plus log p0 for each unknown sighting a particle made a new landmark.
        """
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
            rank = None  # one round: all (particle, slot) pairs distinct
            rounds = 1
        else:
            rank = pairs.rounds(self._slots.n_slots)
            rounds = int(rank.max(initial=0)) + 1
        weigh = self.config.variant is Variant.FASTSLAM1
        for r in range(rounds):
            if rounds == 1:
                these = pairs
            else:
                rows = np.flatnonzero(rank == r)
                these = Pairs(
                    pairs.particle[rows], pairs.slot[rows], pairs.obs[rows], pairs.new_unknown[rows]
                )
            who, slots, obs = these.particle, these.slot, these.obs
            if rounds == 1 and gathered is not None:
                block = gathered
            else:
                block = self._store.gather(who, slots)
            tentative = None
            if weigh and self.config.confirm_sightings > 1:
                tentative = tentative_pairs(
                    these, sightings, block.existence, self.config.confirm_sightings
                )
            log_likelihood = self._mapper.update(block, poses[who], sightings, obs)
            if tentative is not None and tentative.any():
                # a tentative landmark's sighting weighs as a new landmark's (p0)
                log_likelihood = np.where(
                    tentative, self.config.new_landmark_log_likelihood, log_likelihood
                )
            if weigh:
                temper = self.config.likelihood_temper
                if temper != 1.0:
                    log_likelihood = temper * log_likelihood
                np.add.at(log_factors, who, log_likelihood)
            block.existence += 1  # thesis 5.1.2: +1 when seen
            self._store.scatter(who, slots, block)
            estimated = block.status == ESTIMATED
            self._slots.record_positions(slots[estimated], block.mean[estimated, :2])
            if self._spread is not None:
                self._spread.seen(np.unique(slots))
        return log_factors

    # -- resampling ---------------------------------------------------------------------------

    def _resample(self) -> np.ndarray:
        """Low-variance resampling (thesis 4.49, Thrun et al. Table 4.4) of poses and maps;
        returns the ancestors."""
        ancestors = _RESAMPLERS[self.config.resampling](self._particles.weights, self._rng)
        self._history.record_resampling(ancestors)
        self._particles.resample(ancestors)
        self._store.resample(ancestors)
        self.resample_count += 1
        return ancestors

    def _resample_islands(self) -> np.ndarray | None:
        """Each island resampled apart (``resampling.island_resample``); its weights become
        uniform at 1/K of the total. Returns the ancestors, or None when no island was."""
        ancestors = island_resample(
            self._particles.log_weights,
            self._islands,
            self.config.resample_ess_fraction,
            _RESAMPLERS[self.config.resampling],
            self._rng,
        )
        if ancestors is None:
            return None
        self._history.record_resampling(ancestors)
        self._particles.resample(ancestors)
        self._particles.log_weights = normalize_per_island(
            self._particles.log_weights, self._islands
        )
        self._store.resample(ancestors)
        self.resample_count += 1
        return ancestors
