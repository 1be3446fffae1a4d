"""Configuration of the GTSAM back end: a tree of frozen sections, one per trade, and presets.

``GraphSLAMConfig`` holds the odometry's motion noise, the covariance switch and one section per
trade, each handed only to the collaborators of that trade:

* ``poses`` (``PoseConfig``): which frames get a pose variable, the noise of the odometry
  factors and priors, the omni viewpoint (``poses.py``);
* ``solver`` (``SolverConfig``): iSAM2's relinearisation and factorisation, the omni fixed-lag
  smoother, the robust kernel on landmark factors (``session.py``, ``factors.py``);
* ``landmarks`` (``LandmarkConfig``): insertion, weak prior, per-image budget and outlier gate
  (``builder.py``, ``bearings_3d.py``, ``range_bearing.py``, ``outlier_gate.py``);
* ``association`` (``AssociationConfig``): unlabelled range-bearing sightings
  (``window_association.py``, ``nearest_association.py``, ``tentative.py``);
* ``floor`` (``FloorConfig``): the odometry's scale from floor points (``odometry_scale.py``);
* ``batch`` (``BatchConfig``): the final Levenberg-Marquardt solve (``levenberg_marquardt.py``);
* ``experimental`` (``ExperimentalConfig``): switches that were measured and left off.

The measured facts behind the iSAM2 and insertion defaults are in docs/design.md and
docs/results/graph.md. Which observation stream the graph is built
from is not configured here: it is the ``core.modality.Modality`` the registry resolves once
and hands to ``GraphSLAM`` (``--set modality=NAME`` overrides the shared rule).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import ClassVar

from omnislam.core.gating import (
    OUTLIER_GATE_MIN_SIGHTINGS,
    OUTLIER_GATE_PROBABILITY,
    RESIGHTING_VOTES,
)
from omnislam.core.modality import Modality
from omnislam.core.motion import MotionNoise
from omnislam.errors import ConfigError


class RobustKernel(enum.Enum):
    """M-estimator wrapped around every landmark factor's noise model (odometry stays Gaussian).

    AUTO: by modality (``SolverConfig.landmark_kernel``) -- Huber at
    ``BEARING_HUBER_THRESHOLD`` on the omni front end's bearings, none on range-bearing
    sightings and vertical lines. The bearings' outlier gate is an angle of 20 deg
    (``bearings_3d.BEARING_GATE_RAD``, there to keep a Unit3 error away from 180 deg), ~100
    sigmas of a bearing: a mismatched track's bearing inside it, on a landmark whose depth few
    bearings hold, can make iSAM2's Gauss-Newton steps diverge without the kernel.
    Range-bearing sightings are gated by their chi-square innovation instead.
    """

    AUTO = "auto"
    NONE = "none"
    HUBER = "huber"
    CAUCHY = "cauchy"


class Factorization(enum.Enum):
    """How iSAM2 factorises the linearised system.

    CHOLESKY: fastest; GTSAM 4.3 throws "Indeterminate linear system" when a clique's
        reciprocal condition number falls below sqrt(eps), which front-end bearings to distant,
        barely triangulated landmarks next to millimetre pose priors can reach.
    QR: slower and numerically robust.
    AUTO: Cholesky; when it reports an indeterminate system, every factor so far is re-added
        to a fresh QR-factorising iSAM2 (at the current linearisation point), which the rest of
        the run keeps using (``GraphSLAMInfo.factorization_fallbacks``): Cholesky's speed
        until it fails, QR's robustness after.
    """

    AUTO = "auto"
    CHOLESKY = "cholesky"
    QR = "qr"


class AssociationTest(enum.Enum):
    """How unlabelled sightings are associated.

    JOINT: joint compatibility (JCBB, ``core.compatibility``) over the frame's sightings with
        the covariance of the frame's pose guess and the candidate landmarks from iSAM2
        (``window_association.py``).
    NEAREST: each sighting's nearest landmark inside an individual gate, with a fixed
        landmark sigma (``AssociationConfig.landmark_sigma_m``), one landmark per sighting per
        frame (``nearest_association.py``).
    """

    JOINT = "joint"
    NEAREST = "nearest"


#: default thresholds on the whitened residual: 95% asymptotic efficiency on Gaussian noise
#: (Huber 1.345, Cauchy 2.3849; Zhang, "Parameter estimation techniques", 1997)
DEFAULT_ROBUST_THRESHOLD: dict[RobustKernel, float] = {
    RobustKernel.NONE: 0.0,
    RobustKernel.HUBER: 1.345,
    RobustKernel.CAUCHY: 2.3849,
}
#: Huber threshold of ``RobustKernel.AUTO`` on the omni bearings [whitened residual]: 3 sigmas
#: keep a calibrated bearing (chi-square 2 dof: 98.9 % of them) fully weighted
BEARING_HUBER_THRESHOLD = 3.0


class PoseVariables(enum.Enum):
    """Which frames get a pose variable.

    SIGHTINGS: frame 0 and every frame whose observation stream is not empty; the odometry in
        between is composed into one between-factor (``poses.py``): fewer poses and iSAM2
        updates, with the same measurements.
    FRAMES: every frame (one between-factor per odometry step).
    """

    SIGHTINGS = "sightings"
    FRAMES = "frames"


def _check_positive(values: dict[str, float | None]) -> None:
    """ConfigError unless every value that is not None is > 0."""
    for name, value in values.items():
        if value is not None and not value > 0:
            raise ConfigError(f"{name} must be positive, got {value}")


@dataclass(frozen=True, slots=True)
class PoseConfig:
    """The pose chain: which frames get a pose variable, the odometry factors' and the priors'
    noise, the omni viewpoint (``poses.py``).

    Attributes:
        pose_variables: which frames get a pose variable (default SIGHTINGS: frame 0 and the
            frames with sightings of the graph's stream, the odometry in between composed; see
            ``PoseVariables``).
        keyframe_spacing_m: omni bearings: how far the robot moves before an image becomes a
            key frame [m] (default 0.2). A key frame is a pose variable with its bearings; the
            bearings of the images in between are not used (counted), their poses are the key
            frame's composed with the odometry. 0 uses every image.
        odometry_sigmas: fixed (sx [m], sy [m], stheta [rad]) of every odometry factor instead
            of the motion model. For datasets that state their odometry noise (gtsam's
            victoria_park.txt: 0.01, 0.002, 0.002); None (default) uses ``motion_noise``.
        odometry_min_sigma_m: floor of the std of every odometry factor's translation given its
            rotation [m] (default 1 mm; see ``factors.condition_odometry_covariance``): GTSAM
            4.3's Cholesky rejects a clique of two poses whose absolute position is known
            ~2000 times worse than their relative one ("Indeterminate linear system"), and 1 mm
            keeps such a pair solvable while staying far below every dataset's landmark noise.
            Covariances that already respect it (e.g. fixed ``odometry_sigmas``) are unchanged.
        prior_sigmas: (sx [m], sy [m], stheta [rad]) of the prior anchoring the first pose at
            ``initial_pose`` (default 1 mm / 1 mrad: the first pose defines the world frame).
        sensor_height_m: height of the omni camera's single viewpoint above the robot frame
            origin [m] (omni bearings; default 0). Bearings are measured from there.
        planar_sigma_m: std of z in the per-pose prior and of the vertical component of each
            odometry factor [m] (omni bearings; default 1 mm: the robot drives on a plane).
        planar_sigma_rad: std of roll and pitch in the same factors [rad] (default 1 mrad).
    """

    pose_variables: PoseVariables = PoseVariables.SIGHTINGS
    keyframe_spacing_m: float = 0.2
    odometry_sigmas: tuple[float, float, float] | None = None
    odometry_min_sigma_m: float = 1e-3
    prior_sigmas: tuple[float, float, float] = (1e-3, 1e-3, 1e-3)
    sensor_height_m: float = 0.0
    planar_sigma_m: float = 1e-3
    planar_sigma_rad: float = 1e-3

    def __post_init__(self) -> None:
        _check_positive(
            {
                "planar_sigma_m": self.planar_sigma_m,
                "planar_sigma_rad": self.planar_sigma_rad,
                "odometry_min_sigma_m": self.odometry_min_sigma_m,
            }
        )
        for name in ("prior_sigmas", "odometry_sigmas"):
            sigmas = getattr(self, name)
            if sigmas is not None and (len(sigmas) != 3 or min(sigmas) <= 0):
                raise ConfigError(f"{name} must be three positive numbers, got {sigmas}")
        if self.keyframe_spacing_m < 0:
            raise ConfigError(f"keyframe_spacing_m must be >= 0, got {self.keyframe_spacing_m}")


@dataclass(frozen=True, slots=True)
class SolverConfig:
    """How the graph is solved online: iSAM2's relinearisation and factorisation, the omni
    fixed-lag smoother, the robust kernel on landmark factors (``session.py``, ``factors.py``).

    Attributes:
        relinearize_threshold: iSAM2 relinearisation threshold on the tangent-space delta
            (default 0.1; stable on all seeds, docs/design.md).
        relinearize_skip: iSAM2 checks for relinearisation every this many updates (default 1:
            the GTSAM default of 10 diverged on one of four seeds, docs/design.md).
        factorization: iSAM2's factorisation (default AUTO: Cholesky, rebuilt with QR if it
            reports an indeterminate system, as it did on a demo seed's front-end log).
        adaptive_reorder_threshold: iSAM2 re-orders the whole Bayes tree past this ratio of its
            non-zeros to a fresh ordering's (default None: never). GTSAM 4.3's
            ``ISAM2Params.enableAdaptiveReorder``: incremental orderings fill in badly once
            bearing-only tracks close loops.
        online_lag_key_frames: omni bearings: the online estimate's fixed-lag window [key
            frames] (default 20). None: iSAM2 over the whole graph at every key frame. The
            online estimate is a fixed-lag smoother over the variables touched within this many key
            frames, and ``estimate()`` is LM over the whole graph (``session.FixedLagSession``):
            the smoother's update stays flat where iSAM2's over the whole graph grows with the
            run. The smoother's iSAM2 takes ``relinearize_threshold`` / ``relinearize_skip``;
            ``factorization`` and ``adaptive_reorder_threshold`` act on the whole-graph iSAM2
            only.
        robust_kernel: M-estimator on landmark factors (default AUTO: Huber on the omni
            bearings, none elsewhere). See ``RobustKernel``.
        robust_threshold: kernel threshold on the whitened residual; None (default) uses the
            kernel's own (``DEFAULT_ROBUST_THRESHOLD``: Huber 1.345, Cauchy 2.3849; AUTO's
            Huber on the omni bearings 3, ``BEARING_HUBER_THRESHOLD``).
    """

    relinearize_threshold: float = 0.1
    relinearize_skip: int = 1
    factorization: Factorization = Factorization.AUTO
    adaptive_reorder_threshold: float | None = None
    online_lag_key_frames: int | None = 20
    robust_kernel: RobustKernel = RobustKernel.AUTO
    robust_threshold: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.robust_kernel, RobustKernel):
            raise ConfigError(f"robust_kernel must be a RobustKernel, got {self.robust_kernel!r}")
        _check_positive(
            {
                "relinearize_threshold": self.relinearize_threshold,
                "robust_threshold": self.robust_threshold,
            }
        )
        if self.relinearize_skip < 1:
            raise ConfigError(f"relinearize_skip must be >= 1, got {self.relinearize_skip}")
        if self.online_lag_key_frames is not None and self.online_lag_key_frames < 1:
            raise ConfigError(
                f"online_lag_key_frames must be >= 1 or unset, got {self.online_lag_key_frames}"
            )
        if self.adaptive_reorder_threshold is not None and not self.adaptive_reorder_threshold > 1:
            raise ConfigError(
                "adaptive_reorder_threshold must be > 1 (a ratio of non-zeros) or unset, "
                f"got {self.adaptive_reorder_threshold}"
            )

    def landmark_kernel(self, modality: Modality) -> tuple[RobustKernel, float]:
        """The robust kernel on ``modality``'s landmark factors and its threshold on the
        whitened residual (0 without a kernel): ``robust_kernel`` with AUTO resolved
        (``RobustKernel``)."""
        kernel = self.robust_kernel
        if kernel is RobustKernel.AUTO:
            if modality is not Modality.BEARINGS_3D:
                return RobustKernel.NONE, 0.0
            kernel, default = RobustKernel.HUBER, BEARING_HUBER_THRESHOLD
        else:
            default = DEFAULT_ROBUST_THRESHOLD[kernel]
        if kernel is RobustKernel.NONE:
            return kernel, 0.0
        return kernel, default if self.robust_threshold is None else self.robust_threshold


@dataclass(frozen=True, slots=True)
class LandmarkConfig:
    """Which landmarks enter the graph, and which sightings of mapped ones: the delayed
    insertion of bearing-only tracks and its weak prior, the omni per-image budget, the
    consistent insertion and the outlier gate of range-bearing landmarks (``builder.py``,
    ``bearings_3d.py``, ``range_bearing.py``, ``outlier_gate.py``).

    Attributes:
        min_sightings: sightings a bearing-only track needs before it is triangulated and
            inserted (default 3).
        min_parallax_deg: largest angle between a track's world rays needed before insertion
            [deg] (default 3). Fewer made iSAM2 throw "Indeterminate linear system".
        prior_sigma_m: std of a weak prior that holds each bearing-only landmark near the point
            it was triangulated at when inserted [m] (default 10; None: no prior): bearings
            leave a landmark's depth only weakly determined, and the prior bounds the pivots
            iSAM2's Cholesky meets (a landmark's information is at least 1/sigma^2 per axis),
            so it never reports an indeterminate system, while biasing a landmark known to
            within 0.5 m by (0.5/10)^2 = 0.25% of its offset from the insertion point.
            Range-bearing landmarks are fully observed and get none.
        per_image: omni bearings: the per-image landmark budget (default 40). Bearings of
            tracks already admitted to the graph are always used; while an image has fewer
            than this, tracks seen in it are admitted, the most-sighted first, spread over
            azimuth (``bearings_3d.py``). 0: every track.
        min_consistent_sightings: range-bearing landmarks with given ids enter the graph once
            this many of their sightings agree on the position (chi-square gate at
            ``association.gate_probability``; ``landmark_init.ConsistentInsertion``); the
            disagreeing held-back sightings are dropped with the outlier gate on. Default 2:
            a landmark started from a misread id would sit metres away and the outlier gate
            would then reject its correct sightings. 1 inserts on the first sighting.
        outlier_gate_probability: chi-square probability of the outlier gate on range-bearing
            sightings of mapped landmarks with ids (default 0.999). 1.0 disables it. The
            innovation at the frame's guess, with the covariance of the guess and the landmark
            read from iSAM2 (``joint_state.py``), beyond the chi-square quantile drops the
            sighting (``core.gating.OUTLIER_GATE_PROBABILITY``).
        outlier_gate_min_sightings: sightings of landmarks with fewer sightings in the graph
            are gated 10 times wider (``core.gating.YOUNG_GATE_FACTOR``; default 20): a young
            landmark's iSAM2 marginal is linearised where its first sightings put it, and a
            tight gate rejected its re-sightings, each rejection leaving it worse placed; a
            wrong id among its first sightings is still hundreds of sigmas off the wider gate.
        outlier_gate_votes: gated range-bearing sightings of one landmark within 10 frames
            that imply the same point, on no other landmark, overrule the gate and all enter
            the graph (``core.gating.GatedResightings``; default 3, 0: the gate has the last
            word): after a lap under biased odometry the pose is metres off while its marginal
            says decimetres, and the gate alone rejects every re-sighting of the first
            landmarks. Sightings of young landmarks (``outlier_gate_min_sightings``) never vote.
    """

    min_sightings: int = 3
    min_parallax_deg: float = 3.0
    prior_sigma_m: float | None = 10.0
    per_image: int = 40
    min_consistent_sightings: int = 2
    outlier_gate_probability: float = OUTLIER_GATE_PROBABILITY
    outlier_gate_min_sightings: int = OUTLIER_GATE_MIN_SIGHTINGS
    outlier_gate_votes: int = RESIGHTING_VOTES

    def __post_init__(self) -> None:
        _check_positive({"prior_sigma_m": self.prior_sigma_m})
        if self.min_sightings < 2:
            raise ConfigError(f"min_sightings must be >= 2, got {self.min_sightings}")
        if self.min_parallax_deg < 0:
            raise ConfigError(f"min_parallax_deg must be >= 0, got {self.min_parallax_deg}")
        if self.per_image < 0:
            raise ConfigError(f"per_image must be >= 0, got {self.per_image}")
        if self.min_consistent_sightings < 1:
            raise ConfigError(
                f"min_consistent_sightings must be >= 1, got {self.min_consistent_sightings}"
            )
        if self.outlier_gate_votes < 0:
            raise ConfigError(f"outlier_gate_votes must be >= 0, got {self.outlier_gate_votes}")
        if not 0 < self.outlier_gate_probability <= 1:
            raise ConfigError(
                f"outlier_gate_probability must be in (0, 1], got {self.outlier_gate_probability}"
            )


@dataclass(frozen=True, slots=True)
class AssociationConfig:
    """How unlabelled range-bearing sightings are given to landmarks (``window_association.py``,
    ``nearest_association.py``, ``tentative.py``).

    Attributes:
        test: JOINT (default) or NEAREST (see ``AssociationTest``).
        gate_probability: chi-square probability of the gate inside which an unlabelled
            sighting may take a landmark (default 0.99). Individual compatibility;
            with JOINT also the joint gate of the frame's hypothesis, d = 2 per pairing.
        new_landmark_probability: chi-square probability beyond which an unmatched sighting
            starts a new landmark (default 0.9999); sightings between the two gates are
            ambiguous and dropped.
        lag_frames: with JOINT, later frames with unlabelled sightings a frame waits for before
            its own are associated (default 0). JCBB runs over
            the waiting frames together and keeps the oldest frame's decisions
            (``window_association.py``); 0: each frame on its own.
        ambiguity_margin: with JOINT, a pairing that the second-best hypothesis (as many
            pairings) makes differently is dropped as ambiguous unless that hypothesis' joint
            D2 exceeds the best's by this margin (default 2 ln 10 = 4.6: the best must be 10
            times likelier; ``core.compatibility.decide``): landmarks standing in groups (as
            MR.CLAM's, 0.18 m apart) let a lone sighting after a stretch of odometry fit several.
        landmark_sigma_m: fixed std of every landmark position [m] in the NEAREST gate, and in
            the loose test that picks JOINT's candidates (default 0.3).
        tentative_min_sightings: sightings a landmark started by the association needs before
            it enters the graph (default 1: at once). Two or more hold it as a tentative landmark
            (``tentative.py``) that is dropped, with its sightings, unless re-observed within
            ``tentative_window_frames`` frames: it removes clutter (spurious detections) from
            the map.
        tentative_window_frames: largest gap in frames between consecutive sightings of a
            tentative landmark (default 10).
        reorder_candidates: have the update after each association re-eliminate its candidate
            landmarks (``ISAM2UpdateParams.extraReelimKeys``; default True): the association's
            joint marginal (``joint_state``) costs what its deepest candidate costs, and a
            re-eliminated candidate moves into the top of the Bayes tree, where the next
            frames read it cheaply. The same linear system in another order.
    """

    test: AssociationTest = AssociationTest.JOINT
    gate_probability: float = 0.99
    new_landmark_probability: float = 0.9999
    lag_frames: int = 0
    ambiguity_margin: float = 4.6
    landmark_sigma_m: float = 0.3
    tentative_min_sightings: int = 1
    tentative_window_frames: int = 10
    reorder_candidates: bool = True

    def __post_init__(self) -> None:
        _check_positive({"landmark_sigma_m": self.landmark_sigma_m})
        if not 0 < self.gate_probability <= self.new_landmark_probability < 1:
            raise ConfigError("need 0 < gate_probability <= new_landmark_probability < 1")
        if self.lag_frames < 0:
            raise ConfigError(f"lag_frames must be >= 0, got {self.lag_frames}")
        if self.tentative_min_sightings < 1 or self.tentative_window_frames < 1:
            raise ConfigError(
                "tentative_min_sightings and tentative_window_frames must be >= 1, got "
                f"{self.tentative_min_sightings} and {self.tentative_window_frames}"
            )


@dataclass(frozen=True, slots=True)
class FloorConfig:
    """The odometry's scale from the floor points seen from the camera height (omni bearings;
    ``odometry_scale.py``, ``floor_scale.py``, ``floor_points.py``).

    Attributes:
        scale: omni bearings: multiply each odometry translation by the scale the floor points
            give (default True). Bearings alone leave the map at the odometry's scale, and floor
            points seen from the known camera height are metric (``floor_scale.py``). Needs a
            camera height (``poses.sensor_height_m`` > 0); without floor points in the log the
            scale stays 1 and nothing changes.
        scale_final: with ``scale`` and the fixed-lag session: the final estimate (LM over the
            whole graph) takes every odometry translation at the run's final floor scale, not
            at the scale known when its factor was added (default True: the first frames,
            before enough floor pairs, were added at 1). The online estimate keeps the scale of
            its time.
        scale_refine: with ``scale_final``: the final scale is re-estimated from the floor pairs
            over the graph's own trajectory instead of the raw odometry, and the final estimate
            re-solved at it until the correction is < 0.01 % (default True;
            ``FloorScale.refined``): the wheel odometry's per-step noise spreads each 5-15 cm
            pair's scale, the graph's trajectory, held by every landmark's bearings, far less.
            One or two more LM solves of the whole graph.
        landmarks: with ``scale_final``: the tracks of the floor's mode enter the final estimate
            as landmarks with a prior on their height (z = 0) (with ``viewpoints`` also the
            images between key frames that see them, as viewpoints with their bearings), and
            the final scale is the one at which the solved trajectory agrees with the odometry
            (``floor_points.py``; default True): the pairs' refined scale (``scale_refine``)
            takes the graph's short relative translations, most of them odometry between key
            frames, as the reference. With fewer than ``MIN_PAIRS`` floor tracks
            ``scale_refine`` decides. Four LM solves of the whole graph (the last three
            warm-started, with the floor images' poses) instead of two.
        viewpoints: with ``landmarks``: an image between key frames that sees a floor track
            gets a viewpoint of its own in the joint solve; False (default): only the key
            frames' floor sightings enter it, and a floor track needs two of them: with the
            front end's floor tracks (in every image) the viewpoints make the joint solve grow
            with the floor sightings for the same accuracy. Without the front end's floor
            tracks (a log with ``floor.enabled`` off) they pay for themselves.
        known_odometry_scale: the wheel odometry's translation scale when it is known (a
            calibrated wheel radius): each translation is multiplied by it from the first frame
            and the floor points are not used (default None: ``scale`` decides). With the
            truth's scale it tells how much of a graph's error is the floor scale's
            (``benchmarks/realtime_lab40.py --variants true-scale``).
    """

    scale: bool = True
    scale_final: bool = True
    scale_refine: bool = True
    landmarks: bool = True
    viewpoints: bool = False
    known_odometry_scale: float | None = None

    def __post_init__(self) -> None:
        _check_positive({"known_odometry_scale": self.known_odometry_scale})


@dataclass(frozen=True, slots=True)
class BatchConfig:
    """The final Levenberg-Marquardt solve over the whole graph: ``graphslam-batch``'s
    ``estimate()``, and the fixed-lag session's (``levenberg_marquardt.py``).

    Attributes:
        max_iterations: Levenberg-Marquardt iteration limit of the final solve (default 100).
        relative_error_tol: relative decrease of the graph error below which the final solve
            stops (default 1e-6, Ceres's ``function_tolerance``): tighter ran on for seconds
            of CPU changing the estimate by hundredths of a millimetre, GTSAM's 1e-5 stopped
            early. The reference optimum of ``harness.reference`` keeps its own 1e-10.
    """

    max_iterations: int = 100
    relative_error_tol: float = 1e-6

    def __post_init__(self) -> None:
        if self.max_iterations < 1:
            raise ConfigError(f"max_iterations must be >= 1, got {self.max_iterations}")


@dataclass(frozen=True, slots=True)
class LoopClosureConfig:
    """Merging landmarks the association started that duplicate older ones (``loop_closure.py``).

    Attributes:
        enabled: merge landmarks the association started that duplicate older ones (default
            False). ``loop_closure.LandmarkMerger``: the local map of recently seen created
            landmarks matched against the older ones by joint compatibility of their iSAM2
            estimates, then tied by a zero ``BetweenFactorPoint2``; landmarks with given ids
            never take part. Left off: on MR.CLAM without ids half of its merges joined
            neighbours 0.18 m apart, and on Victoria Park it cost CPU for the same ATE.
        every_frames: the local map is matched every this many frames with unlabelled sightings
            (default 10).
        window_frames: the local map holds the created landmarks seen within this many frames
            (default 50).
        min_landmarks: pairings a match needs before it is accepted (default 2: a single
            landmark near an old one is no evidence of a revisit, see the module).
        merge_sigma_m: std per axis of the merging factor [m] (default 1 mm, the odometry's
            floor: see ``poses.odometry_min_sigma_m`` for the conditioning).
    """

    enabled: bool = False
    every_frames: int = 10
    window_frames: int = 50
    min_landmarks: int = 2
    merge_sigma_m: float = 1e-3

    def __post_init__(self) -> None:
        _check_positive({"merge_sigma_m": self.merge_sigma_m})
        if min(self.every_frames, self.window_frames, self.min_landmarks) < 1:
            raise ConfigError("every_frames, window_frames and min_landmarks must be >= 1")


@dataclass(frozen=True, slots=True)
class ExperimentalConfig:
    """Switches that were measured and left off, each with the reason (docs/results/graph.md holds
    the measurements).

    Attributes:
        budget_grace_images: omni bearings: an admitted track that has not entered the graph
            this many images after its admission (far, it does not triangulate) stops counting
            against ``landmarks.per_image`` (``core.track_budget``; default None: every
            admitted track counts). Left off: it halved campus1500's ATE but cost lab40
            accuracy.
        association_landmark_marginals: with ``association.test`` NEAREST, use each nearby
            candidate landmark's iSAM2 marginal covariance in the gate instead of
            ``association.landmark_sigma_m`` (default False). Left off: on victoria-park-gtsam
            without ids no better, at many times the CPU (a back-substitution per candidate and
            frame).
        batch_reassociation_rounds: ``graphslam-batch`` only: after the final LM, give the
            sightings the association decided to landmarks again, per frame by a minimum-cost
            assignment against the LM map inside the association gate, and solve again, for at
            most this many rounds (``reassociation.py``; default 0: off). Left off until the
            suite's rows without ids are re-run with it.
        loop_closure: merging duplicated created landmarks (``LoopClosureConfig``; off).
    """

    budget_grace_images: int | None = None
    association_landmark_marginals: bool = False
    batch_reassociation_rounds: int = 0
    loop_closure: LoopClosureConfig = field(default_factory=LoopClosureConfig)

    def __post_init__(self) -> None:
        if self.budget_grace_images is not None and self.budget_grace_images < 1:
            raise ConfigError(
                f"budget_grace_images must be >= 1 or unset, got {self.budget_grace_images}"
            )
        if self.batch_reassociation_rounds < 0:
            raise ConfigError(
                f"batch_reassociation_rounds must be >= 0, got {self.batch_reassociation_rounds}"
            )


@dataclass(frozen=True, slots=True)
class GraphSLAMConfig:
    """Settings of ``GraphSLAM`` / ``BatchGraphSLAM``: the motion noise and one section per trade.

    Attributes:
        compute_covariances: ``estimate()`` returns marginal covariances of poses and landmarks
            (default False). Marginals cost far more than the estimate.
        motion_noise: alpha coefficients of the odometry model (thesis eq. 4.41); the 3x3
            covariance of each odometry delta is ``OdometryMotionModel.covariance``.
        poses: the pose chain (``PoseConfig``).
        solver: iSAM2, the fixed-lag smoother and the robust kernel (``SolverConfig``).
        landmarks: insertion, budget and outlier gate (``LandmarkConfig``).
        association: unlabelled range-bearing sightings (``AssociationConfig``).
        floor: the odometry's scale from floor points (``FloorConfig``).
        batch: the final Levenberg-Marquardt solve (``BatchConfig``).
        experimental: switches measured and left off (``ExperimentalConfig``).
    """

    #: the options most users set (``omnislam estimators graphslam``; ``--all`` lists the rest)
    MAIN_OPTIONS = (
        "motion_noise.a_vv",
        "motion_noise.a_ww",
        "poses.odometry_sigmas",
        "poses.keyframe_spacing_m",
        "solver.robust_kernel",
        "solver.online_lag_key_frames",
        "solver.adaptive_reorder_threshold",
        "landmarks.min_parallax_deg",
        "landmarks.per_image",
        "landmarks.outlier_gate_probability",
        "association.gate_probability",
        "association.lag_frames",
        "association.tentative_min_sightings",
        "floor.scale",
        "compute_covariances",
    )
    #: earlier flat keys renamed on the way into a section (named by the unknown-key message)
    RENAMED_OPTIONS: ClassVar[dict[str, str]] = {
        "landmarks_per_image": "landmarks.per_image",
        "landmark_prior_sigma_m": "landmarks.prior_sigma_m",
        "floor_scale": "floor.scale",
        "floor_scale_final": "floor.scale_final",
        "floor_scale_refine": "floor.scale_refine",
        "floor_landmarks": "floor.landmarks",
        "floor_viewpoints": "floor.viewpoints",
        "association_test": "association.test",
        "association_gate_probability": "association.gate_probability",
        "association_lag_frames": "association.lag_frames",
        "association_ambiguity_margin": "association.ambiguity_margin",
        "association_landmark_sigma_m": "association.landmark_sigma_m",
        "association_min_sightings": "association.tentative_min_sightings",
        "association_window_frames": "association.tentative_window_frames",
        "association_reorder_candidates": "association.reorder_candidates",
        "loop_closure": "experimental.loop_closure.enabled",
        "loop_closure_every_frames": "experimental.loop_closure.every_frames",
        "loop_closure_window_frames": "experimental.loop_closure.window_frames",
        "loop_closure_min_landmarks": "experimental.loop_closure.min_landmarks",
        "loop_closure_merge_sigma_m": "experimental.loop_closure.merge_sigma_m",
        "batch_max_iterations": "batch.max_iterations",
        "batch_relative_error_tol": "batch.relative_error_tol",
    }

    compute_covariances: bool = False
    motion_noise: MotionNoise = field(default_factory=MotionNoise)
    poses: PoseConfig = field(default_factory=PoseConfig)
    solver: SolverConfig = field(default_factory=SolverConfig)
    landmarks: LandmarkConfig = field(default_factory=LandmarkConfig)
    association: AssociationConfig = field(default_factory=AssociationConfig)
    floor: FloorConfig = field(default_factory=FloorConfig)
    batch: BatchConfig = field(default_factory=BatchConfig)
    experimental: ExperimentalConfig = field(default_factory=ExperimentalConfig)


#: named presets (the CLI merges ``--set key=value`` overrides on top of one of these)
PRESETS: dict[str, GraphSLAMConfig] = {
    "default": GraphSLAMConfig(),
    "robust": GraphSLAMConfig(
        solver=SolverConfig(robust_kernel=RobustKernel.CAUCHY),
        landmarks=LandmarkConfig(min_consistent_sightings=2),
    ),
    "victoria-park-gtsam": GraphSLAMConfig(
        poses=PoseConfig(odometry_sigmas=(0.01, 0.002, 0.002))
    ),
}
