"""Configuration of the FastSLAM estimator: a tree of frozen sections, option enums, presets.

``FastSLAMConfig`` holds the variant, the odometry noise, the rig's height and the kernels at
the top and one section per collaborator (``particles``, ``resampling``, ``association``,
``proposal``, ``bearings``, ``existence``), each handed only its own section; the research
switches that were measured and left off live in ``experimental``. Presets reproduce the
thesis's experiments (Guizilini 2008, sec. 5.1.2: FastSLAM 1.0 with 50 particles, FastSLAM 2.0
with 10 particles on route 1) and the defaults of ``fastslam1`` / ``fastslam2``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from enum import Enum
from typing import ClassVar

from omnislam.core.motion import MotionNoise
from omnislam.core.types import OdometrySource
from omnislam.errors import ConfigError

#: FastSLAM's default odometry noise: twice the alpha coefficients of the thesis's simulator
#: (``MotionNoise()``, thesis eqs. 4.40-4.41). Those alphas describe white noise per step only;
#: doubled, they also cover the systematic drift of real odometry (wheel scale, turn scale,
#: curvature), around which a particle filter would otherwise propose its poses.
DEFAULT_MOTION_NOISE = MotionNoise(a_vv=0.1, a_vw=0.02, a_wv=0.02, a_ww=0.1)


class Variant(Enum):
    """Which FastSLAM: 1.0 samples poses from the motion model (thesis eqs. 4.42-4.44); 2.0
    samples from the motion model refined by the matched observations (thesis 4.45-4.46,
    Montemerlo 2003 sec. 3.3)."""

    FASTSLAM1 = "fastslam1"
    FASTSLAM2 = "fastslam2"


class StatedOdometryNoise(Enum):
    """Where FastSLAM draws a step's pose noise from when the frame's odometry states its own
    covariance (``Odometry.covariance``); frames without one always use the alpha model.

    AUTO: from the stated covariance when the odometry is *measured* per step -- the front
        end's laser odometry (``SequenceInfo.odometry_source`` LASER: scans registered by
        ICP, covariance from the point-to-line Hessian) -- and from the alpha model
        (``motion_noise``) when it is wheel odometry, whose stated covariance, where a loader
        gives one, is a nominal formula of the step (MR.CLAM's frame-to-frame fit, CARMEN's
        ``odometry_noise``) and carries nothing the alphas do not. The default.
    ON: from the stated covariance whatever the odometry's source (``--set
        stated_odometry_noise=true``).
    OFF: always from the alpha model (``--set stated_odometry_noise=false``).
    """

    AUTO = "auto"
    ON = "true"
    OFF = "false"

    def resolve(self, odometry_source: OdometrySource) -> bool:
        """Whether a filter whose frames carry odometry from ``odometry_source``
        (``ObservationLog.odometry_source``) samples from a stated covariance."""
        if self is StatedOdometryNoise.AUTO:
            return odometry_source is OdometrySource.LASER
        return self is StatedOdometryNoise.ON


class StoreKind(Enum):
    """How each particle's landmark EKFs are stored.

    TREE: the thesis's persistent balanced tree with estimates in every node (sec. 4.4.1.3),
        shared between particles, path copying on update: O(P log M) per step.
    LEAF_TREE: Montemerlo's tree with estimates in the leaves only (for comparison).
    DENSE: plain (P, M, ...) arrays copied on resampling: O(P M) per resampling; the oracle.
    """

    TREE = "tree"
    LEAF_TREE = "leaf_tree"
    DENSE = "dense"


class BearingUpdate(Enum):
    """How a 3-D landmark that already has an estimate is updated by a new bearing.

    TRIANGULATED: the thesis (sec. 4.4.1.2): triangulate the new ray with the stored previous
        sighting, turn the point into a "measured" z = (d, theta, phi) (eq. 4.25) and update with
        the range-azimuth-elevation model (eqs. 4.29-4.37). The pseudo-measurement shares a ray
        with the previous one, so successive updates are correlated (the thesis ignores this);
        when the two rays have too little parallax the direct update is used instead.
    DIRECT: a bearing-only EKF update with z = (azimuth, elevation), 2 DOF
        (``BearingElevation3D``), which uses each ray exactly once.
    """

    TRIANGULATED = "triangulated"
    DIRECT = "direct"


class ProposalUpdateMode(Enum):
    """How FastSLAM 2.0 refines a particle's pose proposal by its matched observations.

    SEQUENTIAL: Montemerlo 2003 / thesis eqs. 4.45-4.46, one observation after the other,
        relinearised at the refined mean after each (the default; every published number).
    JOINT: all matched observations of a particle in one Gaussian update linearised at the
        motion-prediction mean (``proposal.joint_proposal``): the same result for a linear
        model, one vectorised pass over all (particle, observation) pairs instead of a loop over
        the observations.
    """

    SEQUENTIAL = "sequential"
    JOINT = "joint"


class TriangulationMethod(Enum):
    """How two rays give a first landmark position (thesis sec. 4.3).

    GROUND_PLANE: thesis eq. 4.21 (intersect the ground projections, z = mean height).
    MIDPOINT: the least-squares point of the two rays (midpoint of their common perpendicular).
    """

    GROUND_PLANE = "ground_plane"
    MIDPOINT = "midpoint"


class Kernels(Enum):
    """Which implementation runs the per-pair loops (``omnislam.fastslam.kernels``).

    AUTO: the compiled kernels when numba is installed (the extra ``fast``), else numpy.
    NUMPY: the vectorised numpy path, the reference and test oracle.
    NUMBA: the compiled kernels; an error naming the extra when numba is missing.
    """

    AUTO = "auto"
    NUMPY = "numpy"
    NUMBA = "numba"


class TrajectoryMode(Enum):
    """Which trajectory ``estimate()`` reports.

    WEIGHTED_MEAN: per step, the weighted mean of the particles (circular mean of the heading)
        with their weighted covariance. O(1) memory per step.
    BEST_ANCESTRY: the path of the current best particle, traced back through the resampling
        ancestry (the FastSLAM path posterior sample), with each step's weighted second moment
        of the particle set about that path's pose as its covariance (the mean read-out's
        covariance plus the offset's outer product, ``PathHistory.covariances_about``). Stores
        every particle's pose at every step: O(P) memory per step.
    SMOOTHED: per step, the weighted mean of the particle cloud recorded at that step under
        the forward-filtering backward-smoothing marginal weights (Doucet, Godsill & Andrieu
        2000 eq. 43, ``smoother.py``) with the odometry Gaussian the filter sampled from as the
        transition density, and the weighted covariance about it. Pose-only backward kernel:
        the particles' maps are not re-conditioned (an approximation, ``smoother.py``). Stores
        every particle's pose and weight at every step: O(P) memory per step, O(P^2) time
        per step at the end.
    """

    WEIGHTED_MEAN = "weighted_mean"
    BEST_ANCESTRY = "best_ancestry"
    SMOOTHED = "smoothed"


class ResamplingScheme(Enum):
    """Resampling algorithm (``omnislam.fastslam.resampling``)."""

    SYSTEMATIC = "systematic"
    STRATIFIED = "stratified"
    MULTINOMIAL = "multinomial"


def _probability(name: str, value: float) -> None:
    """Raise ConfigError unless ``value`` lies in (0, 1]."""
    if not 0.0 < value <= 1.0:
        raise ConfigError(f"{name} must be in (0, 1]")


@dataclass(frozen=True, slots=True)
class ParticlesConfig:
    """The particle set: how many, where they start, how their landmark maps are stored.

    Attributes:
        n_particles: number of particles P. Default 100 (the ``fastslam1`` preset; ``fastslam2``
            uses 20): more particles sample the path posterior better at linear cost.
        initial_pose_sigma: std of the initial pose (x, y, theta) [m, m, rad]. Default zero:
            all particles start at the given pose, which anchors the map frame.
        store: how each particle's landmark EKFs are stored (``StoreKind``). Default the
            thesis's shared tree: O(P log M) per step, maps shared between particles.
        initial_landmark_capacity: landmark slots allocated up front. Default 64: the stores
            grow, this only saves the first reallocations.
    """

    n_particles: int = 100
    initial_pose_sigma: tuple[float, float, float] = (0.0, 0.0, 0.0)
    store: StoreKind = StoreKind.TREE
    initial_landmark_capacity: int = 64

    def __post_init__(self) -> None:
        if self.n_particles < 1:
            raise ConfigError("particles.n_particles must be >= 1")
        if min(self.initial_pose_sigma) < 0:
            raise ConfigError("particles.initial_pose_sigma must be non-negative")
        if self.initial_landmark_capacity < 1:
            raise ConfigError("particles.initial_landmark_capacity must be >= 1")


@dataclass(frozen=True, slots=True)
class ResamplingConfig:
    """When and how the particles are resampled (thesis sec. 4.4.2.3).

    Attributes:
        scheme: the resampling algorithm (``ResamplingScheme``). Default systematic: the
            low-variance sampler of Thrun et al. 2005 Table 4.4, one uniform draw per step.
        ess_fraction: resample when the effective sample size (thesis eq. 4.51) falls below
            this fraction of P; 1.0 resamples every step with sightings, 0.0 never. Default 0.5:
            resampling only when the weights have degenerated keeps the particles' diversity.
    """

    scheme: ResamplingScheme = ResamplingScheme.SYSTEMATIC
    ess_fraction: float = 0.5

    def __post_init__(self) -> None:
        if not 0.0 <= self.ess_fraction <= 1.0:
            raise ConfigError("resampling.ess_fraction must be in [0, 1]")


@dataclass(frozen=True, slots=True)
class AssociationConfig:
    """The per-particle maximum-likelihood association of sightings without id (Montemerlo
    2003 sec. 3.4.1; Thrun et al. 2005 sec. 13.6).

    Attributes:
        new_landmark_log_likelihood: log p0: a particle makes a sighting of unknown
            association a new landmark when none of its landmarks explains it with a
            log-likelihood above log p0. Its weight is then multiplied by p0 (Thrun et al. 2005
            Table 13.2). Default -6.0: the log-likelihood of a residual ~4 sigma out for ~0.1 m /
            ~3 deg range-bearing noise.
        margin_m: the coarse gate of the association: a sighting of unknown association is
            compared only with the landmarks within the largest sighting range plus this margin
            of the mean pose (by their last known position) [m]. The existence index takes the
            same margin around its sensor range. Default 3.0: it keeps the association
            O(nearby landmarks).
    """

    new_landmark_log_likelihood: float = -6.0
    margin_m: float = 3.0

    def __post_init__(self) -> None:
        if self.margin_m < 0:
            raise ConfigError("association.margin_m must be non-negative")


@dataclass(frozen=True, slots=True)
class ProposalConfig:
    """FastSLAM 2.0's proposal: the motion prediction refined by the matched sightings (thesis
    eqs. 4.45-4.46, Montemerlo 2003 sec. 3.3).

    Attributes:
        update: sequential or joint refinement by the matched sightings
            (``ProposalUpdateMode``). Default sequential: Montemerlo's relinearised form, that of
            every published number.
        max_landmark_std_m: 3-D only: a landmark refines the proposal only when its position
            std sqrt(tr Sigma) is at most this [m]. Default infinite: every triangulated
            landmark takes part.
        max_sightings: 3-D only: at most this many sightings refine the proposal, the
            best-converged landmarks first; 0: no cap. Default 40: the errors of one particle's
            map are correlated through its path, so ~200 omni bearings taken as independent
            would make the proposal far narrower than the pose error.
    """

    update: ProposalUpdateMode = ProposalUpdateMode.SEQUENTIAL
    max_landmark_std_m: float = math.inf
    max_sightings: int = 40

    def __post_init__(self) -> None:
        if self.max_landmark_std_m <= 0 or self.max_sightings < 0:
            raise ConfigError(
                "proposal.max_landmark_std_m must be positive, proposal.max_sightings >= 0"
            )


@dataclass(frozen=True, slots=True)
class BearingsConfig:
    """3-D landmarks from omni bearings (``Modality.BEARINGS_3D``, thesis sec. 4.4.1.2).

    Attributes:
        update: how an established landmark is updated by a new bearing (``BearingUpdate``).
            Default triangulated: the thesis's pseudo-measurement (eq. 4.25), with the direct
            update where the parallax is too small.
        triangulation: how two rays give a first landmark position (``TriangulationMethod``).
            Default midpoint: the least-squares point of the two rays, which needs no
            assumption on the landmark's height.
        triangulated_ray_reuse: with triangulated updates, the pseudo-measurement's noise Q
            (and the first estimate's, eq. 4.27) is multiplied by this; 1.0: the thesis as
            printed. Default 2.0: each ray enters two successive triangulations, so without it
            its information would be counted twice (``bearing_landmarks``).
        min_parallax_deg: two rays closer than this are not triangulated; the first sighting
            is kept until a ray with enough parallax arrives [deg]. Default 3.0 (as graphslam's
            option of the same name): below it the depth is too uncertain to linearise.
        gate_probability: the chi-square probability of the validation gate on bearing
            innovations; 1.0: no gate. An innovation outside it (degrees of freedom: the
            measurement's dimension) neither refines the proposal nor updates the landmark, and
            weighs with the Gaussian truncated at the gate. Default 0.999: a feature track that
            jumped to another point cannot move a landmark or decide between particles.
    """

    update: BearingUpdate = BearingUpdate.TRIANGULATED
    triangulation: TriangulationMethod = TriangulationMethod.MIDPOINT
    triangulated_ray_reuse: float = 2.0
    min_parallax_deg: float = 3.0
    gate_probability: float = 0.999

    def __post_init__(self) -> None:
        if self.min_parallax_deg < 0:
            raise ConfigError("bearings.min_parallax_deg must be non-negative")
        if self.triangulated_ray_reuse < 1.0:
            raise ConfigError("bearings.triangulated_ray_reuse must be >= 1")
        _probability("bearings.gate_probability", self.gate_probability)


@dataclass(frozen=True, slots=True)
class ExistenceIndexConfig:
    """The existence index of thesis sec. 5.1.2 and the sensor field it needs.

    A landmark's index grows by one each time it is seen and drops by one each time it is
    predicted inside the sensor's field but not seen; a landmark whose index becomes negative
    is deleted from that particle's map.

    Attributes:
        max_range_m: the sensor's range [m]; setting any field of the section turns the index
            on. Default 4.0: the thesis simulation's laser.
        min_range_m: landmarks closer than this are not expected to be seen [m]. Default 0.0.
        half_fov_rad: half the horizontal field of view [rad]. Default pi: omnidirectional.
        min_elevation_rad, max_elevation_rad: the vertical field of the omni camera (3-D
            landmarks only) [rad]. Default -pi/2 and pi/2: the whole sphere.
    """

    max_range_m: float = 4.0
    min_range_m: float = 0.0
    half_fov_rad: float = math.pi
    min_elevation_rad: float = -math.pi / 2
    max_elevation_rad: float = math.pi / 2

    def __post_init__(self) -> None:
        if not 0 <= self.min_range_m < self.max_range_m:
            raise ConfigError("existence index: need 0 <= min_range_m < max_range_m")
        if not 0 < self.half_fov_rad <= math.pi:
            raise ConfigError("existence index: half_fov_rad must be in (0, pi]")


@dataclass(frozen=True, slots=True)
class ExperimentalConfig:
    """Research switches that were measured and left off (docs/results/fastslam.md has the numbers).

    Attributes:
        trajectory: which trajectory ``estimate()`` reports (``TrajectoryMode``). Default
            weighted_mean; best_ancestry and smoothed gained on one variant or one log only.
        compose_gaps: frames without sightings compose their odometry and its covariance into
            one Gaussian step (``gap.py``) that the next frame with sightings samples (1.0) or
            refines by its sightings (2.0). Default off: better on one CARMEN aces log, worse
            on another.
        likelihood_temper: FastSLAM 1.0 only: its importance factor is p(z | x)^t (thesis eq.
            4.47 raised to t; annealed importance sampling, Neal 2001); 1.0: the thesis.
            Default 1.0: smaller values keep the particles diverse by discarding the sightings'
            information, and the error grows.
        islands: K: the particles form K islands of near-equal size, independent particle
            filters averaged with equal weights, each normalised to 1/K and resampled from its
            own weights (``resampling.island_resample``); set ``particles.n_particles`` to K
            times one filter's. Default 1 (one filter): K filters cost K times the CPU.
        association_exclusive: a frame's sightings of unknown association are associated under
            mutual exclusion: per particle, no landmark takes two of them
            (``association._exclusive_choice``). Default off: it helped on Victoria Park and
            hurt on MR.CLAM without ids.
        association_gate_probability: below 1, a sighting of unknown association starts a new
            landmark when no landmark's squared Mahalanobis distance lies inside the chi-square
            quantile of this probability (2 dof), and goes to the likeliest landmark inside it
            otherwise; a new landmark still weighs p0. Default 1.0: the log p0 test alone
            (``association.new_landmark_log_likelihood``); no gate measured came closer to the
            association with ids.
        resighting_spread: the innovation covariance of the association of unknown sightings
            also holds the odometry's pose covariance accumulated since each landmark was last
            seen, times this factor (``resighting.ResightingSpread``; the association decision
            only). Default 0.0 (off): the composed spread makes neighbouring laser landmarks
            compatible.
        association_pose_spread: the innovation covariance of the association of unknown
            sightings also holds this factor times the filter's pose covariance relative to its
            maps (``pose_spread.PoseSpread``; 2-D, the association decision only). Default 0.0
            (off): it helped MR.CLAM without ids and hurt CARMEN and Victoria Park.
        confirm_sightings: a landmark a particle made of a sighting of unknown association is
            tentative until that particle has seen it this many times, the first included
            (Montemerlo 2003 ch. 4's provisional landmarks): its sightings update it but neither
            refine the proposal nor weigh with their innovation likelihood (they weigh p0).
            Default 1 (none tentative): 2 and 3 gave no gain on CARMEN aces.
        outlier_gate_probability: 2-D range-bearing only: the chi-square probability of a
            per-particle outlier gate (as graphslam's and ekfslam's option of the same name):
            an innovation outside it neither refines the proposal nor updates the landmark, and
            weighs with the Gaussian truncated at the gate (``range_bearing_mapper``). Default
            1.0 (no gate): the particle set is far narrower than its error, so once it has
            drifted the gate rejects the correct sightings too.
    """

    trajectory: TrajectoryMode = TrajectoryMode.WEIGHTED_MEAN
    compose_gaps: bool = False
    likelihood_temper: float = 1.0
    islands: int = 1
    association_exclusive: bool = False
    association_gate_probability: float = 1.0
    resighting_spread: float = 0.0
    association_pose_spread: float = 0.0
    confirm_sightings: int = 1
    outlier_gate_probability: float = 1.0

    def __post_init__(self) -> None:
        if not 0.0 < self.likelihood_temper <= 1.0:
            raise ConfigError("experimental.likelihood_temper must be in (0, 1]")
        if self.islands < 1:
            raise ConfigError("experimental.islands must be >= 1")
        if not 0.0 <= self.resighting_spread < math.inf:
            raise ConfigError("experimental.resighting_spread must be finite and non-negative")
        if not 0.0 <= self.association_pose_spread < math.inf:
            raise ConfigError(
                "experimental.association_pose_spread must be finite and non-negative"
            )
        _probability(
            "experimental.association_gate_probability", self.association_gate_probability
        )
        if self.confirm_sightings < 1:
            raise ConfigError("experimental.confirm_sightings must be >= 1")
        _probability("experimental.outlier_gate_probability", self.outlier_gate_probability)
        if self.compose_gaps and self.trajectory is TrajectoryMode.SMOOTHED:
            raise ConfigError(
                "experimental.trajectory=smoothed needs every step sampled: "
                "not experimental.compose_gaps"
            )


@dataclass(frozen=True, slots=True)
class FastSLAMConfig:
    """The settings of a FastSLAM estimator: a few values every part needs, then one section per
    collaborator.

    What it observes (``core.modality.Modality``, resolved once by the shared rule) and its
    motion model are given to ``FastSLAM`` at construction, not set here; the factories build
    the motion model from ``motion_noise``.

    Attributes:
        variant: FastSLAM 1.0 or 2.0; also the estimator's ``name``. Default 1.0; the
            ``fastslam2`` preset sets 2.0.
        motion_noise: the alpha coefficients of thesis eqs. 4.40-4.41 from which the factories
            build the ``OdometryMotionModel``. Default ``DEFAULT_MOTION_NOISE``: twice the
            simulator's, to cover systematic drift.
        stated_odometry_noise: whether a step's poses are sampled from its odometry's stated
            covariance (``Odometry.covariance``) instead of from ``motion_noise``
            (``StatedOdometryNoise``). The sample is additive on the delta in the previous
            pose's frame (``core.motion.StatedOdometryMotion``), as the graph and EKF-SLAM use a
            stated covariance. Default auto: yes for laser odometry, a covariance measured per
            step, no for wheel odometry, whose stated noise is a nominal formula.
        sensor_height_m: height of the omni camera's viewpoint above the ground plane (3-D
            landmarks and the existence index's elevation band) [m]. Default 0.0; the factories
            take the dataset's rig height when it states one.
        kernels: compiled kernels or the numpy reference for the per-pair loops of every part
            (``Kernels``; the same numbers to rounding, ``kernels.py``). Default auto: compiled
            when numba is installed.
        particles: the particle set and its maps (``ParticlesConfig``).
        resampling: when and how to resample (``ResamplingConfig``).
        association: sightings without id (``AssociationConfig``).
        proposal: FastSLAM 2.0's proposal (``ProposalConfig``).
        bearings: 3-D landmarks from omni bearings (``BearingsConfig``).
        existence: the existence index of thesis 5.1.2 (``ExistenceIndexConfig``). Default
            none: every landmark is kept; the thesis presets turn it on.
        experimental: switches measured and left off (``ExperimentalConfig``).
    """

    #: the options most users set (``omnislam estimators fastslam1``; ``--all`` lists the rest)
    MAIN_OPTIONS = (
        "particles.n_particles",
        "motion_noise.a_vv",
        "motion_noise.a_vw",
        "motion_noise.a_wv",
        "motion_noise.a_ww",
        "stated_odometry_noise",
        "resampling.ess_fraction",
        "association.new_landmark_log_likelihood",
        "association.margin_m",
        "proposal.max_sightings",
        "bearings.min_parallax_deg",
        "bearings.gate_probability",
        "existence.max_range_m",
    )
    RENAMED_OPTIONS: ClassVar[dict[str, str]] = {
        "resample_ess_fraction": "resampling.ess_fraction",
        "association_margin_m": "association.margin_m",
        "proposal_update": "proposal.update",
        "proposal_max_landmark_std_m": "proposal.max_landmark_std_m",
        "proposal_max_sightings": "proposal.max_sightings",
        "bearing_update": "bearings.update",
        "bearing_gate_probability": "bearings.gate_probability",
    }

    variant: Variant = Variant.FASTSLAM1
    motion_noise: MotionNoise = DEFAULT_MOTION_NOISE
    stated_odometry_noise: StatedOdometryNoise = StatedOdometryNoise.AUTO
    sensor_height_m: float = 0.0
    kernels: Kernels = Kernels.AUTO
    particles: ParticlesConfig = ParticlesConfig()
    resampling: ResamplingConfig = ResamplingConfig()
    association: AssociationConfig = AssociationConfig()
    proposal: ProposalConfig = ProposalConfig()
    bearings: BearingsConfig = BearingsConfig()
    existence: ExistenceIndexConfig | None = None
    experimental: ExperimentalConfig = ExperimentalConfig()

    def __post_init__(self) -> None:
        if self.experimental.islands > self.particles.n_particles:
            raise ConfigError("experimental.islands must be at most particles.n_particles")

    @property
    def name(self) -> str:
        """The estimator name: ``fastslam1`` or ``fastslam2``."""
        return self.variant.value

    def with_(self, **changes: object) -> FastSLAMConfig:
        """A copy with some top-level fields or whole sections changed (validated again)."""
        return replace(self, **changes)


def _preset(variant: Variant, n_particles: int, existence: bool = False) -> FastSLAMConfig:
    """The defaults with ``variant``, ``n_particles`` and, for the thesis's experiments, the
    existence index on (thesis sec. 5.1.2)."""
    return FastSLAMConfig(
        variant=variant,
        particles=ParticlesConfig(n_particles=n_particles),
        existence=ExistenceIndexConfig() if existence else None,
    )


PRESETS: dict[str, FastSLAMConfig] = {
    "fastslam1": _preset(Variant.FASTSLAM1, 100),
    "fastslam2": _preset(Variant.FASTSLAM2, 20),
    # thesis route 1 (Fig. 5.6): FastSLAM 1.0 with 50 particles, 2.0 with 10
    "thesis-fastslam1": _preset(Variant.FASTSLAM1, 50, existence=True),
    "thesis-fastslam2": _preset(Variant.FASTSLAM2, 10, existence=True),
    # thesis route 2 (Fig. 5.8): the long route needs FastSLAM 2.0 with 50 particles
    "thesis-route2-fastslam2": _preset(Variant.FASTSLAM2, 50, existence=True),
}
"""Named presets (``omnislam run ... --estimator fastslam2`` starts from ``PRESETS[name]``)."""
