"""Configuration of the FastSLAM estimator: one frozen dataclass, option enums, named presets.

Every default is documented next to the field. Presets reproduce the thesis's experiments
(Guizilini 2008, sec. 5.1.2: FastSLAM 1.0 with 50 particles, FastSLAM 2.0 with 10 particles on
route 1) and a fast setting for large range-bearing logs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from enum import Enum

from omnislam.core.motion import MotionNoise
from omnislam.core.types import OdometrySource
from omnislam.errors import ConfigError

#: FastSLAM's default odometry noise: twice the alpha coefficients of the thesis's simulator
#: (``MotionNoise()``, thesis eqs. 4.40-4.41). Those alphas describe white noise per step only;
#: real odometry also drifts systematically (wheel scale, turn scale, curvature: 1-3 % per 10 m
#: on the synthetic presets, ``benchmarks/odometry_drift.py``; MR.CLAM's commanded velocities
#: are off by far more, ``benchmarks/fastslam_mrclam.py``), and a particle filter whose motion
#: model leaves that out proposes poses around the biased odometry: its maps bend with the
#: drift. Doubled, on loop150 (5 seeds) fastslam2@10 / fastslam2@50 / fastslam1@50 went from
#: 1.07 / 0.54 / 0.90 m median ATE (worse than dead reckoning's 0.77 m) to 0.46 / 0.23 / 0.46 m,
#: and on MR.CLAM (robots 1-5, seeds 0-2) fastslam2 / fastslam1 from 0.343 / 0.494 m to
#: 0.290 / 0.414 m; tripled was worse on both (README, FastSLAM section).
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
        ICP, covariance from the point-to-line Hessian, calibrated against the corrected CARMEN
        poses to a median NEES of 1.9-2.3 for chi-square(3)'s 2.37) -- and from the alpha model
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
        per step at the end. On carmen-aces the laser odometry's transition is so narrow
        against the cloud's spread that the backward kernel keeps each particle's own parent
        (1.0-1.2 effective parents), so the read-out is close to the genealogy's: median ATE
        over seeds 0-9 / 0-29 fastslam1 1.93 / 2.00 -> 1.42 / 1.78 m, fastslam2 1.81 / 1.81
        -> 1.77 / 1.77 m; corridor21, demo, intel, MR.CLAM and loop150 unchanged within the
        seeds' spread, pose NEES worse (the smoothed weights sit on few particles). Not the
        default: it does not bring FastSLAM to 0.3x dead reckoning on aces
        (docs/results/fastslam.md, "What was tried and did not work").
    """

    WEIGHTED_MEAN = "weighted_mean"
    BEST_ANCESTRY = "best_ancestry"
    SMOOTHED = "smoothed"


class ResamplingScheme(Enum):
    """Resampling algorithm (``omnislam.fastslam.resampling``)."""

    SYSTEMATIC = "systematic"
    STRATIFIED = "stratified"
    MULTINOMIAL = "multinomial"


@dataclass(frozen=True, slots=True)
class ExistenceIndexConfig:
    """The existence index of thesis sec. 5.1.2 and the sensor field it needs.

    A landmark's index grows by one each time it is seen and drops by one each time it is
    predicted inside the sensor's field but not seen; a landmark whose index becomes negative
    is deleted from that particle's map.

    Attributes:
        max_range_m: the sensor's range (thesis simulation: 4 m laser) [m].
        min_range_m: landmarks closer than this are not expected to be seen [m].
        half_fov_rad: half the horizontal field of view (pi: omnidirectional) [rad].
        min_elevation_rad, max_elevation_rad: vertical field of the omni camera (3-D only) [rad].
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
class FastSLAMConfig:
    """The settings of a FastSLAM estimator.

    What it observes (``core.modality.Modality``, resolved once by the shared rule) and its
    motion model are given to ``FastSLAM`` at construction, not set here; the factories build
    the motion model from ``motion_noise``.

    Attributes:
        variant: FastSLAM 1.0 or 2.0; also the estimator's ``name``.
        n_particles: number of particles P.
        motion_noise: alpha coefficients of thesis eqs. 4.40-4.41, from which the factories
            (``make_fastslam``) build the ``OdometryMotionModel`` (default
            ``DEFAULT_MOTION_NOISE``: twice the simulator's, to cover systematic drift).
            ``motion_noise.reference_step_m=0.03`` (off by default) scales a step longer than
            3 cm (the simulator's step) so that its variance grows linearly with its length
            (``core.motion.MotionNoise``): on Victoria Park (0.62 m frames; the default alphas
            4.4x wider there than the odometry's measured error against GPS) fastslam2's median
            ATE over seeds 0-2 falls from 9.44 to 2.58 m, but on MR.CLAM 6 with ids (2 cm
            steps, longer ones across sighting gaps) from 0.203 to 0.233 m and fastslam1's r1
            from 0.30 to 0.52 m: worse beyond the seed spread, so it is not the default
            (docs/results/fastslam.md, "Victoria Park: drift between revisits").
        stated_odometry_noise: where a frame's odometry states its covariance
            (``Odometry.covariance``: the front end's laser odometry, MR.CLAM, CARMEN logs with
            ``odometry_noise``, gtsam's victoria_park.txt), whether poses are sampled from it
            (``core.motion.StatedOdometryMotion``: additive on the delta in the previous pose's
            frame, as the graph and EKF-SLAM use it) instead of from ``motion_noise``
            (``StatedOdometryNoise``). Default AUTO: yes for laser odometry (a covariance
            measured per step), no for wheel odometry. Measured on the CARMEN logs (laser
            odometry, seeds 0-2, ``benchmarks/ekfslam_accuracy.py --datasets carmen-intel
            carmen-aces``) fastslam1 / fastslam2 median ATE intel 0.90 / 0.64 m and aces 2.92 /
            1.84 m, against 7.10 / 7.31 m and 6.78 / 7.17 m from the alphas (``--set
            stated_odometry_noise=false``), which are far wider than the registration's error
            and leave the few, ambiguous laser landmarks to sort the particles. On MR.CLAM 6
            (wheel odometry with a stated frame-to-frame fit; robots 1-5, seeds 0-2,
            ``benchmarks/fastslam_mrclam.py --set stated_odometry_noise=true``) sampling the
            stated noise makes fastslam2's median ATE grow from 0.203 to 0.345 m with the
            loader's 2 s steps (0.271 -> 0.602 m with frames at sighting times only): that
            noise (1.3-7x the alphas) spreads the particles wider than the sightings can sort
            out, and the proposal follows the sightings' per-robot biases; AUTO leaves MR.CLAM
            on the alphas.
        compose_gaps: frames without sightings compose their odometry and its covariance into
            one Gaussian step (``gap.py``) instead of sampling each; the next frame with
            sightings samples the whole gap (FastSLAM 1.0) or refines it by its sightings (2.0),
            so a particle that drifted over a gap can be moved back by the whole gap's spread.
        likelihood_temper: FastSLAM 1.0 only: its importance factor is p(z | x)^t (thesis eq.
            4.47 raised to t; for the Mahalanobis term the same as weighing with R / t), the
            tempered likelihood of annealed importance sampling (Neal 2001). 1.0 (default):
            the thesis. Measured on loop150 (5 seeds, benchmarks/fastslam_loop150.py): t = 0.02
            ends FastSLAM 1.0's collapse onto one ancestor (longest single-ancestor run 1
            instead of 17 at 50 particles) but the median ATE grows from 0.46 to 1.40 m,
            beyond dead reckoning's 0.77 m: the diversity is bought by discarding the
            sightings' information, so it is not the default.
        resample_ess_fraction: resample when ESS (thesis eq. 4.51) < fraction * P; 1.0 resamples
            every step with observations, 0.0 never.
        islands: K: the particles form K islands of near-equal size, independent particle
            filters averaged with equal weights -- each island's weights are normalised to 1/K
            and each island is resampled from its own weights when its own ESS falls below
            ``resample_ess_fraction`` of its size (``resampling.island_resample``), so the
            weighted-mean read-out is the mean of the K filters' estimates. A variance
            reduction by independent replication: each collapsed filter keeps one draw of the
            sampled odometry noise, K filters average K draws; not the posterior's combination
            (which would weigh the islands by their evidence: measured to pick one island).
            Set ``n_particles`` to K times the particles of one filter. 1 (default): one filter.
            Measured with full-size islands (each the default filter; docs/results/fastslam.md,
            "CARMEN aces"): carmen-aces median ATE over seeds 0-9 fastslam1 1.93 -> 1.41 /
            1.12 m at K = 3 / 5, fastslam2 1.81 -> 1.31 / 1.19 m; intel and loop150 gain,
            MR.CLAM with ids within its seed spread, lab40's paths better and maps worse; K
            times the CPU, hence not the default.
        resampling: the resampling algorithm (low-variance systematic by default, Thrun et al.
            2005 Table 4.4).
        store: landmark storage (thesis tree by default).
        sensor_height_m: height of the omni camera's viewpoint above the ground plane (3-D) [m].
        bearing_update: update of established 3-D landmarks (thesis triangulation or direct).
        triangulation: first 3-D estimate from two rays.
        triangulated_ray_reuse: with ``BearingUpdate.TRIANGULATED``, the pseudo-measurement's
            noise Q (and the first estimate's, eq. 4.27) is multiplied by this: each ray enters
            two successive triangulations (new ray, then stored sighting), so without inflation
            its information is counted twice (``bearing_landmarks``). 1.0: the thesis as
            printed. Not applied with ``DIRECT`` updates, where every ray is used once.
        min_parallax_deg: two rays closer than this are not triangulated; the first sighting is
            kept until a ray with enough parallax arrives [deg] (as graphslam's option).
        new_landmark_log_likelihood: log p0, Montemerlo 2003 sec. 3.4.1 / Thrun et al. Table
            13.2: for sightings of unknown association, a particle creates a new landmark when no
            existing landmark explains the sighting with a log-likelihood above log p0, and its
            weight is then multiplied by p0. The default suits ~0.1 m / ~3 deg range-bearing
            noise: it is the log-likelihood of a residual ~4 sigma out.
        association_margin_m: unknown sightings are only compared with landmarks whose last
            known position lies within the largest sighting range plus this margin of the mean
            pose [m] (a coarse gate that keeps association O(nearby landmarks)).
        association_exclusive: unknown sightings of one frame are associated under mutual
            exclusion (``association._exclusive_choice``): per particle, no landmark takes two
            of them. Off by default: on Victoria Park (a particle gave one landmark two of a
            frame's sightings in 262 of 7230 frames) it takes fastslam2's median ATE over seeds
            0-2 from 9.44 to 4.93 m, but on MR.CLAM 6 without ids (seed 0) it is worse on four
            of five robots with more landmarks on all, and CARMEN was not measured
            (docs/results/fastslam.md, "Victoria Park: drift between revisits").
        resighting_spread: sightings of unknown association are compared with each landmark
            under an innovation covariance that also holds the odometry's pose covariance
            accumulated since that landmark was last seen, times this factor
            (``resighting.ResightingSpread``: the motion model's step covariance -- the stated
            one where it is sampled -- composed over the gap, Smith, Self & Cheeseman 1990),
            the "pose uncertainty since it last saw the landmark" of issue 16: a landmark seen
            again after a long gap stays inside the p0 gate although the particle set is far
            narrower than its error. It enters the association decision only (not the
            proposal, the landmark update or the weights). 0.0 (default): off. Measured
            (fastslam2, seeds 0-2, ``--set association=unknown``): at 3 MR.CLAM 6's median ATE
            on robots 1-5 falls from 1.126 / 1.070 / 2.521 / 0.940 / 0.489 m to 0.717 / 0.500
            / 2.056 / 0.465 / 0.487 m (41-106 landmarks for 15), but carmen-aces goes from
            1.63-1.82 m to 2.9-14.8 m, carmen-intel from 0.24-1.08 m to 5.7-11.1 m and Victoria
            Park from 8.9-10.7 m to 91-111 m (at 1: aces 3.3-9.2 m, intel 3.4-6.2 m): the
            composed spread makes neighbouring laser landmarks compatible, so it is not the
            default (docs/results/fastslam.md, "MR.CLAM without ids").
        association_pose_spread: sightings of unknown association are compared with each
            landmark under an innovation covariance that also holds this factor times the
            filter's pose covariance relative to its maps (``pose_spread.PoseSpread``: predicted
            by the odometry, shrunk by the information of every matched sighting, EKF
            localisation against the particles' maps, Thrun et al. 2005 Tables 7.1-7.2).
            Association only. 0.0 (default): off. Measured (fastslam2, seeds 0-2, ``--set
            association=unknown``): at 30 MR.CLAM 6's median ATE on robots 1-5 falls from
            1.126 / 1.070 / 2.521 / 0.940 / 0.489 m (50-113 landmarks for 15) to 0.497 / 0.464
            / 0.709 / 0.235 / 0.327 m (16-38 landmarks; robot 4 within 1.5x of its ATE with
            ids, 16 landmarks), but carmen-aces' median goes from 1.805 to 2.015 m,
            carmen-intel's from 0.627 to 1.021 m and Victoria Park (seed 0) from 8.85 to 26.8
            m, so it is not the default (docs/results/fastslam.md, "MR.CLAM without ids").
        association_gate_probability: 1.0 (default): a sighting of unknown association starts
            a new landmark when its likeliest landmark's log-likelihood is below
            ``new_landmark_log_likelihood`` (Montemerlo 2003 sec. 3.4.1). Below 1: when no
            landmark's squared Mahalanobis distance lies inside the chi-square quantile of this
            probability (2 dof), and it goes to the likeliest landmark inside it otherwise
            (``association.maximum_likelihood_association``); a new landmark still weighs p0.
            With the spread a wide S cannot start a new landmark by its determinant alone.
            Measured on MR.CLAM 6 without ids (fastslam2, seed 0): with ``resighting_spread=1``
            at 0.999 robots 1-5 0.775 / 0.942 / 2.930 / 1.727 / 0.378 m (55-141 landmarks);
            with ``resighting_spread=10`` at 0.9999 robots 1 / 3 0.558 / 0.619 m against
            1.246 / 0.883 m without the gate: no setting within the issue's goal.
        confirm_sightings: a landmark of unknown association (a sighting without id that a
            particle made a new landmark) is tentative until that particle has seen it this
            many times, the first sighting included (the provisional landmarks of Montemerlo
            2003 ch. 4; the thesis's existence index, sec. 5.1.2, counts the same sightings): a
            sighting paired with a tentative landmark updates it but neither refines the
            FastSLAM 2.0 proposal nor weighs with its innovation likelihood -- its weight
            factor is p0, a new landmark's -- so a landmark born of a spurious or wrongly
            chained sighting cannot select particles until it is confirmed. Landmarks with ids
            are never tentative. 1 (default): every landmark counts from its first
            re-sighting. Measured on carmen-aces (one front-end log, seeds 0-9, median ATE
            fastslam1 / fastslam2): 1.93 / 1.81 m at 1, 1.96 / 2.37 m at 2, fastslam2 1.86 m
            at 3 -- no gain, so it stays off (docs/results/fastslam.md, "CARMEN aces").
        bearing_gate_probability: 3-D only: a bearing innovation whose squared Mahalanobis
            distance exceeds the chi-square quantile of this probability (degrees of freedom = the
            measurement's dimension) is an outlier -- a feature track that jumped to another
            point. It neither refines the FastSLAM 2.0 proposal nor updates the landmark EKF, and
            its weight factor is the Gaussian likelihood truncated at the gate (a robust
            likelihood: one bad track cannot decide between particles). 1.0 disables the gate.
        outlier_gate_probability: 2-D range-bearing only: the chi-square probability of a
            per-particle outlier gate, the equivalent of graphslam's and ekfslam's option of
            the same name (``core.gating``): an innovation outside it neither refines the
            FastSLAM 2.0 proposal (gate on y^T L^-1 y, L the proposal's predictive covariance)
            nor updates the landmark EKF (gate on y^T S^-1 y), and its weight factor is the
            Gaussian truncated at the gate (``range_bearing_mapper``). Default 1.0 (no gate):
            at 0.999 (the graph's) MR.CLAM 6 fastslam2's median ATE grows from 0.203 to
            1.88 m (robots 1-5, seeds 0-2, ``benchmarks/fastslam_mrclam.py --set
            outlier_gate_probability=0.999``; r3 3.2 m): the particle set is far narrower
            than its error (pose NEES 1e7-1e32), so once the set has drifted the gate rejects
            the correct sightings too and nothing pulls it back. The graph's gate works on
            iSAM2's marginals, which are consistent.
        proposal_update: FastSLAM 2.0 only: sequential (Montemerlo 2003, the default) or joint
            refinement of the proposal by the matched observations (``ProposalUpdateMode``).
        proposal_max_landmark_std_m: 3-D only: a landmark refines the FastSLAM 2.0 proposal only
            when its position std sqrt(tr Sigma) is at most this (a converged triangulation;
            infinite: every established landmark) [m].
        proposal_max_sightings: 3-D only: at most this many sightings refine the proposal, the
            best-converged landmarks first (0: no cap). The landmark errors of one particle's
            map are correlated through its path, so ~200 omni bearings treated as independent
            make the proposal far narrower than the pose error; on lab40 a cap of 10-40 halves
            fastslam2's ATE (1.6-2.2 cm -> 0.8-1.3 cm, 3 seeds) and its run time.
        existence: the existence index of thesis 5.1.2, or None to keep every landmark forever.
        trajectory: which trajectory ``estimate()`` reports.
        initial_pose_sigma: std of the initial pose (x, y, theta) [m, m, rad]; zero: all
            particles start at the given pose (the map frame is anchored at the first pose).
        initial_landmark_capacity: landmark slots allocated up front (the stores grow).
        kernels: compiled kernels or the numpy reference for the landmark tree, the 2-D
            landmark EKF and FastSLAM 2.0's sequential 2-D proposal (``Kernels``; same numbers
            to rounding, ``kernels.py``).
    """

    variant: Variant = Variant.FASTSLAM1
    n_particles: int = 100
    motion_noise: MotionNoise = DEFAULT_MOTION_NOISE
    stated_odometry_noise: StatedOdometryNoise = StatedOdometryNoise.AUTO
    compose_gaps: bool = False
    resample_ess_fraction: float = 0.5
    islands: int = 1
    likelihood_temper: float = 1.0
    resampling: ResamplingScheme = ResamplingScheme.SYSTEMATIC
    store: StoreKind = StoreKind.TREE
    sensor_height_m: float = 0.0
    bearing_update: BearingUpdate = BearingUpdate.TRIANGULATED
    triangulation: TriangulationMethod = TriangulationMethod.MIDPOINT
    triangulated_ray_reuse: float = 2.0
    min_parallax_deg: float = 3.0
    new_landmark_log_likelihood: float = -6.0
    association_margin_m: float = 3.0
    association_exclusive: bool = False
    resighting_spread: float = 0.0
    association_pose_spread: float = 0.0
    association_gate_probability: float = 1.0
    confirm_sightings: int = 1
    bearing_gate_probability: float = 0.999
    outlier_gate_probability: float = 1.0
    proposal_update: ProposalUpdateMode = ProposalUpdateMode.SEQUENTIAL
    proposal_max_landmark_std_m: float = math.inf
    proposal_max_sightings: int = 40
    existence: ExistenceIndexConfig | None = None
    trajectory: TrajectoryMode = TrajectoryMode.WEIGHTED_MEAN
    initial_pose_sigma: tuple[float, float, float] = (0.0, 0.0, 0.0)
    initial_landmark_capacity: int = 64
    kernels: Kernels = Kernels.AUTO

    def __post_init__(self) -> None:
        if self.n_particles < 1:
            raise ConfigError("n_particles must be >= 1")
        if not 0.0 < self.likelihood_temper <= 1.0:
            raise ConfigError("likelihood_temper must be in (0, 1]")
        if not 0.0 <= self.resample_ess_fraction <= 1.0:
            raise ConfigError("resample_ess_fraction must be in [0, 1]")
        if not 1 <= self.islands <= self.n_particles:
            raise ConfigError("islands must be in [1, n_particles]")
        if self.min_parallax_deg < 0 or self.association_margin_m < 0:
            raise ConfigError("min_parallax_deg and association_margin_m must be non-negative")
        if not 0.0 <= self.resighting_spread < math.inf:
            raise ConfigError("resighting_spread must be finite and non-negative")
        if not 0.0 <= self.association_pose_spread < math.inf:
            raise ConfigError("association_pose_spread must be finite and non-negative")
        if not 0.0 < self.association_gate_probability <= 1.0:
            raise ConfigError("association_gate_probability must be in (0, 1]")
        if self.confirm_sightings < 1:
            raise ConfigError("confirm_sightings must be >= 1")
        if self.triangulated_ray_reuse < 1.0:
            raise ConfigError("triangulated_ray_reuse must be >= 1")
        if not 0.0 < self.bearing_gate_probability <= 1.0:
            raise ConfigError("bearing_gate_probability must be in (0, 1]")
        if not 0.0 < self.outlier_gate_probability <= 1.0:
            raise ConfigError("outlier_gate_probability must be in (0, 1]")
        if self.proposal_max_landmark_std_m <= 0 or self.proposal_max_sightings < 0:
            raise ConfigError(
                "proposal_max_landmark_std_m must be positive, proposal_max_sightings >= 0"
            )
        if min(self.initial_pose_sigma) < 0:
            raise ConfigError("initial_pose_sigma must be non-negative")
        if self.compose_gaps and self.trajectory is TrajectoryMode.SMOOTHED:
            raise ConfigError("trajectory=smoothed needs every step sampled: not compose_gaps")
        if self.initial_landmark_capacity < 1:
            raise ConfigError("initial_landmark_capacity must be >= 1")

    @property
    def name(self) -> str:
        """The estimator name: ``fastslam1`` or ``fastslam2``."""
        return self.variant.value

    def with_(self, **changes: object) -> FastSLAMConfig:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    # -- named presets -------------------------------------------------------------------------

    @classmethod
    def thesis_fastslam1(cls) -> FastSLAMConfig:
        """Thesis route 1 (Fig. 5.6): FastSLAM 1.0 with 50 particles, existence index on."""
        return cls(variant=Variant.FASTSLAM1, n_particles=50, existence=ExistenceIndexConfig())

    @classmethod
    def thesis_fastslam2(cls) -> FastSLAMConfig:
        """Thesis route 1 (Fig. 5.6): FastSLAM 2.0 with 10 particles, existence index on."""
        return cls(variant=Variant.FASTSLAM2, n_particles=10, existence=ExistenceIndexConfig())

    @classmethod
    def thesis_route2_fastslam2(cls) -> FastSLAMConfig:
        """Thesis route 2 (Fig. 5.8): the long route needs FastSLAM 2.0 with 50 particles."""
        return cls(variant=Variant.FASTSLAM2, n_particles=50, existence=ExistenceIndexConfig())

    @classmethod
    def omni(cls, sensor_height_m: float, variant: Variant = Variant.FASTSLAM2) -> FastSLAMConfig:
        """Omni camera bearings (3-D landmarks, ``Modality.BEARINGS_3D``) with the thesis's
        triangulated updates."""
        return cls(variant=variant, n_particles=50, sensor_height_m=sensor_height_m)


PRESETS: dict[str, FastSLAMConfig] = {
    "fastslam1": FastSLAMConfig(variant=Variant.FASTSLAM1, n_particles=100),
    "fastslam2": FastSLAMConfig(variant=Variant.FASTSLAM2, n_particles=20),
    "thesis-fastslam1": FastSLAMConfig.thesis_fastslam1(),
    "thesis-fastslam2": FastSLAMConfig.thesis_fastslam2(),
    "thesis-route2-fastslam2": FastSLAMConfig.thesis_route2_fastslam2(),
}
"""Named presets (``omnislam run ... --estimator fastslam2`` starts from ``PRESETS[name]``)."""
