"""FastSLAM 1.0 and 2.0 (Guizilini 2008 sec. 4.4; Montemerlo 2003), vectorised over particles.

One step (thesis Fig. 4.1, Fig. 4.11):

1. *Prediction.* FastSLAM 1.0 samples each particle's pose from the odometry motion model
   (thesis eqs. 4.38-4.44), or from the odometry's stated covariance where it samples that
   (``step_motion.py``). FastSLAM 2.0 refines the motion prediction of each particle by its
   matched observations of established landmarks and samples from that (eqs. 4.45-4.46,
   ``proposal_sampling.py``). A frame without observations only predicts (asynchronous front
   end, sec. 4.5), and the weights stay as they are.
2. *Association.* Known ids address their slots in every particle; sightings of unknown
   association are associated per particle by maximum likelihood (``association.py``).
3. *Mapping.* Per particle and sighting, the landmark EKF of the filter's modality (sec.
   4.4.1, ``landmark_update.py``): range-bearing landmarks are initialised from the sighting
   and EKF-updated (``range_bearing_mapper.py``); bearing landmarks store a ray (eq. 4.24), are
   triangulated at a later sighting (eqs. 4.21, 4.26-4.27) and EKF-updated afterwards (eqs.
   4.29-4.37), with a chi-square gate against jumped feature tracks (``bearing_mapper.py``).
   The existence index (sec. 5.1.2, ``existence.py``) optionally deletes landmarks that keep
   not being seen where they should be.
4. *Weights.* Log-likelihood of the innovations (1.0: eq. 4.47 with S from eq. 4.34; 2.0: the
   predictive likelihood that also includes the pose uncertainty), normalised (eq. 4.48).
5. *Resampling* with the low-variance sampler, only when ESS (eq. 4.51) drops below a fraction
   of P (sec. 4.4.2.3, ``resampler.py``); the landmark store copies maps by reference (tree) or
   by value (dense).

Landmarks are addressed by slots shared by all particles (``slot_registry.py``). Each
collaborator is built from its section of ``FastSLAMConfig``; ``FastSLAM.step`` calls them in
this order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from omnislam.core.gating import chi_square_gate
from omnislam.core.modality import Modality
from omnislam.core.motion import MotionModel
from omnislam.core.types import Estimate, FrameInput, OdometrySource, Trajectory
from omnislam.errors import ConfigError
from omnislam.fastslam.association import SightingAssociation
from omnislam.fastslam.config import (
    ExperimentalConfig,
    FastSLAMConfig,
    StoreKind,
    TrajectoryMode,
    Variant,
)
from omnislam.fastslam.dense_store import DenseLandmarkStore
from omnislam.fastslam.diversity import DiversityLog
from omnislam.fastslam.existence import ExistenceIndex
from omnislam.fastslam.gap import ComposedGap
from omnislam.fastslam.info import FastSLAMInfo
from omnislam.fastslam.kernels import resolve as resolve_kernels
from omnislam.fastslam.landmark_store import ESTIMATED, RAY, LandmarkBlock, LandmarkStore
from omnislam.fastslam.landmark_tree import LandmarkTree, TreeLayout
from omnislam.fastslam.landmark_update import LandmarkUpdate
from omnislam.fastslam.mapper import make_mapper
from omnislam.fastslam.particles import ParticleSet, PathHistory, initial_poses
from omnislam.fastslam.pose_spread import PoseSpread
from omnislam.fastslam.proposal_sampling import ProposalSampler
from omnislam.fastslam.resampler import Resampler
from omnislam.fastslam.resighting import ResightingSpread
from omnislam.fastslam.sightings import Pairs, Sightings
from omnislam.fastslam.slot_registry import SlotRegistry
from omnislam.fastslam.step_motion import OdometryNoise, StepMotion

__all__ = ["FastSLAM", "FastSLAMInfo", "make_store"]


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
class _Draw:
    """A frame's sampled poses, what its sightings address, and their weight factors so far.

    Attributes:
        poses: (P, 3) the sampled poses.
        pairs: the (particle, slot, sighting) pairs of the association.
        log_factors: (P,) log weight factors of the sampling (FastSLAM 2.0's proposal).
        block: the landmarks of all the pairs as gathered for the proposal, or None.
    """

    poses: np.ndarray
    pairs: Pairs
    log_factors: np.ndarray
    block: LandmarkBlock | None


def _spreads(
    experimental: ExperimentalConfig, modality: Modality
) -> tuple[ResightingSpread | None, PoseSpread | None]:
    """The association's widened pose terms, when on: the spread since each landmark was last
    seen, and the pose spread relative to the maps (range-bearing sightings only)."""
    spread = (
        ResightingSpread(experimental.resighting_spread)
        if experimental.resighting_spread > 0
        else None
    )
    pose_spread = (
        PoseSpread(experimental.association_pose_spread)
        if experimental.association_pose_spread > 0 and modality is Modality.RANGE_BEARING_2D
        else None
    )
    return spread, pose_spread


class FastSLAM:
    """FastSLAM 1.0 / 2.0 estimator (``omnislam.core.types.Estimator``, ``Introspectable``).

    Args:
        config: all settings; ``config.variant`` sets ``name`` ("fastslam1" / "fastslam2"),
            each collaborator gets its section.
        rng: the only source of randomness.
        modality: the one observation stream it reads (``Modality.RANGE_BEARING_2D`` or
            ``Modality.BEARINGS_3D``), resolved by the shared rule (``core.modality``).
        motion: the motion model (``OdometryMotionModel``, or any ``core.motion.MotionModel``:
            its ``covariance`` composes gaps, widens the association and smooths the path).
        initial_pose: (3,) [x, y, theta] of the first frame; the map is anchored there.
        odometry_source: where the frames' odometry comes from, WHEEL (the dataset's) or
            LASER (the front end's scan matching, ``ObservationLog.odometry_source``);
            with ``config.stated_odometry_noise`` AUTO it decides whether a stated odometry
            covariance is sampled (``StatedOdometryNoise.resolve``).

    Raises:
        ConfigError: a modality FastSLAM does not consume, a motion model without the
            ``MotionModel`` interface, or a bad initial pose.
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
        if not isinstance(motion, MotionModel):
            raise ConfigError(
                f"{type(motion).__name__} is not a motion model: FastSLAM needs sample, "
                "predict and covariance (core.motion.MotionModel)"
            )
        self.config = config
        self.name = config.name
        self._rng = rng
        self._motion = motion
        experimental = config.experimental
        kernels = resolve_kernels(config.kernels)
        sample_stated = config.stated_odometry_noise.resolve(odometry_source)
        self._odometry = OdometryNoise(motion, sample_stated)
        self._mapper = make_mapper(
            modality,
            config.bearings,
            config.sensor_height_m,
            experimental.outlier_gate_probability,
            kernels,
        )
        particles = config.particles
        p = particles.n_particles
        self._particles = ParticleSet(
            initial_poses(p, initial_pose, particles.initial_pose_sigma, rng)
        )
        self._history = PathHistory(
            keep_particles=experimental.trajectory is not TrajectoryMode.WEIGHTED_MEAN,
            kernels=kernels,
        )
        self._store = make_store(
            particles.store,
            p,
            self._mapper.landmark_dim,
            self._mapper.ray_dim,
            particles.initial_landmark_capacity,
            kernels,
        )
        self._slots = SlotRegistry(self._store)
        self._gap = ComposedGap() if experimental.compose_gaps else None
        self._spread, self._pose_spread = _spreads(experimental, modality)
        self._association = self._associate(config, kernels)
        self._proposal = ProposalSampler(
            self._mapper, config.proposal, motion, rng, kernels, experimental.confirm_sightings
        )
        self._log_p0 = config.association.new_landmark_log_likelihood
        self._landmarks = LandmarkUpdate(
            self._mapper,
            self._store,
            self._slots,
            self._log_p0,
            weigh=config.variant is Variant.FASTSLAM1,
            confirm_sightings=experimental.confirm_sightings,
            likelihood_temper=experimental.likelihood_temper,
            spread=self._spread,
        )
        self._existence = (
            None
            if config.existence is None
            else ExistenceIndex(
                config.existence, config.association.margin_m, config.sensor_height_m
            )
        )
        self._resampler = Resampler(config.resampling, p, experimental.islands, rng)
        self._diversity = DiversityLog(p)
        #: effective sample size after the last update
        self.last_ess = float(p)
        self._frames = 0
        self._frames_with_sightings = 0
        self._proposal_gated = 0

    def _associate(self, config: FastSLAMConfig, kernels: object | None) -> SightingAssociation:
        """The association of the filter's slots and store: its section, the experimental
        exclusion and gate, and the spreads."""
        experimental = config.experimental
        gate = experimental.association_gate_probability
        return SightingAssociation(
            self._slots,
            self._store,
            config.association,
            exclusive=experimental.association_exclusive,
            spread=self._spread,
            gate=None if gate >= 1.0 else chi_square_gate(gate, 2),
            pose_spread=self._pose_spread,
            kernels=kernels,
        )

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

    @property
    def resample_count(self) -> int:
        """Resamplings so far."""
        return self._resampler.count

    # -- the Estimator protocol -----------------------------------------------------------------

    def step(self, frame: FrameInput) -> None:
        """Predict with the frame's odometry; if it carries sightings of the modality, draw the
        poses (FastSLAM 2.0: refined by the sightings), map, weigh, and resample when the
        effective sample size is low."""
        self._frames += 1
        sightings = self._mapper.read(frame)
        move = self._odometry.step(frame.odometry)
        if self._pose_spread is not None:
            mean = self._particles.mean_pose()
            self._pose_spread.predict_step(mean, move.delta, move.covariance())
        if sightings is None:
            self._predict(frame.stamp_s, move)
            return
        self._frames_with_sightings += 1
        previous, sampled = self._whole_gap(move)
        draw = self._draw(previous, sampled, sightings)
        if self._spread is not None:  # after the association: the spread up to the last step
            self._spread.advance(move.delta, move.covariance())
        log_factors = self._map(draw, sightings)
        self._weigh_and_resample(frame.stamp_s, log_factors, sampled)

    def estimate(self) -> Estimate:
        """The trajectory chosen by ``config.experimental.trajectory`` and the best particle's
        map.

        2-D landmarks are reported with z = 0 and zero z-variance.
        """
        best = self._particles.best()
        trajectory, pose_covariances = self._trajectory(best)
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
        diversity = self._diversity.summary()
        return FastSLAMInfo(
            variant=self.config.variant,
            modality=self.modality,
            particles=len(self._particles),
            frames=self._frames,
            frames_with_sightings=self._frames_with_sightings,
            frames_stated_odometry=self._odometry.frames_stated,
            resample_count=self.resample_count,
            last_ess=self.last_ess,
            landmark_slots=self._slots.n_slots,
            landmarks=int(np.count_nonzero(status == ESTIMATED)),
            rays_pending=int(np.count_nonzero(status == RAY)),
            unknown_slots=self._slots.n_unknown,
            unknown_matched=self._association.matched,
            unknown_new=self._association.created,
            landmarks_pruned=0 if self._existence is None else self._existence.pruned,
            sightings_gated=self._mapper.sightings_gated,
            proposal_sightings_gated=self._proposal_gated,
            triangulation_fallbacks=self._mapper.triangulation_fallbacks,
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

    # -- the stages of a step -------------------------------------------------------------------

    def _predict(self, stamp_s: float, move: StepMotion) -> None:
        """A frame without sightings: the poses move by the step's motion model (or, composing
        gaps, to the composed mean, ``gap.py``); the weights stay as they are."""
        particles = self._particles
        if self._spread is not None:
            self._spread.advance(move.delta, move.covariance())
        if self._gap is not None:
            particles.poses = self._gap.extend(particles.poses, move.delta, move.covariance())
        else:
            particles.poses = move.model.sample(particles.poses, move.delta, self._rng)
        self._history.record(stamp_s, particles, self._transition(move))

    def _whole_gap(self, move: StepMotion) -> tuple[np.ndarray, StepMotion]:
        """The poses the step starts from and its motion: the previous frame's and ``move``,
        or, closing a composed gap, the gap's start and the whole gap with this step as one
        Gaussian motion (``gap.py``)."""
        if self._gap is None or not self._gap.open:
            return self._particles.poses, move
        start, delta, model = self._gap.close(move.delta, move.covariance())
        return start, StepMotion(delta, model, model)

    def _draw(self, previous: np.ndarray, sampled: StepMotion, sightings: Sightings) -> _Draw:
        """The frame's poses and what its sightings address: FastSLAM 1.0 samples from the
        motion model and associates with the samples (thesis eqs. 4.42-4.44); 2.0 associates
        with the motion prediction and samples from it refined by the sightings (eqs.
        4.45-4.46, ``proposal_sampling.py``), a tentative landmark's sighting weighing p0."""
        weights = self._particles.weights
        if self.config.variant is Variant.FASTSLAM1:
            poses = sampled.model.sample(previous, sampled.delta, self._rng)
            pairs = self._association.pairs(sightings, poses, None, weights)
            return _Draw(poses, pairs, np.zeros(len(poses)), None)
        mean, cov = self._proposal.predict(previous, sampled.delta, sampled.stated)
        pairs = self._association.pairs(sightings, mean, cov, weights)
        draw = self._proposal.sample(
            previous, sampled.delta, mean, cov, sightings, pairs, self._store, sampled.stated
        )
        self._proposal_gated += draw.gated
        log_factors = draw.log_factors
        if draw.tentative.any():
            log_factors = log_factors + self._log_p0 * np.bincount(
                pairs.particle[draw.tentative], minlength=len(previous)
            )
        return _Draw(draw.poses, pairs, log_factors, draw.block)

    def _map(self, draw: _Draw, sightings: Sightings) -> np.ndarray:
        """The particles take the drawn poses and update the landmarks their sightings address
        (``landmark_update.py``); the existence index (thesis 5.1.2) and the pose spread follow.
        Returns the (P,) log weight factors of the frame."""
        particles = self._particles
        particles.poses = draw.poses
        log_factors = draw.log_factors + self._landmarks(
            draw.poses, sightings, draw.pairs, draw.block
        )
        if self._pose_spread is not None:
            self._pose_spread.update_from_pairs(
                self._store, draw.poses, sightings, draw.pairs, particles.weights
            )
        if self._existence is not None:
            self._existence.apply(
                self._store, self._slots, draw.poses, particles.weights, draw.pairs
            )
        return log_factors

    def _weigh_and_resample(
        self, stamp_s: float, log_factors: np.ndarray, sampled: StepMotion
    ) -> None:
        """Reweigh (thesis eqs. 4.47-4.48), record the step, and resample when the effective
        sample size (eq. 4.51) is low (``resampler.py``)."""
        particles = self._particles
        particles.reweight(log_factors, self._resampler.islands)
        self._history.record(stamp_s, particles, self._transition(sampled))
        self.last_ess = particles.effective_sample_size()
        ancestors = self._resampler(particles, self._store, self._history, self.last_ess)
        self._diversity.record(self.last_ess, ancestors)

    def _transition(self, move: StepMotion) -> tuple[np.ndarray, np.ndarray] | None:
        """The step's (delta, covariance) for the smoothed read-out (None when not smoothing)."""
        if self.config.experimental.trajectory is not TrajectoryMode.SMOOTHED:
            return None
        return move.transition()

    def _trajectory(self, best: int) -> tuple[Trajectory, np.ndarray]:
        """The trajectory of the read-out mode and its (N, 3, 3) pose covariances: the
        per-step weighted means, the best particle's ancestry, or the smoothed means."""
        mode = self.config.experimental.trajectory
        if mode is TrajectoryMode.BEST_ANCESTRY:
            trajectory = self._history.ancestry_trajectory(best)
            return trajectory, self._history.covariances_about(trajectory.se2)
        if mode is TrajectoryMode.SMOOTHED:
            return self._history.smoothed_trajectory()
        return self._history.mean_trajectory()
