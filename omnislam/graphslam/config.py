"""Configuration of the GTSAM back end: robust kernels, factorisation, one frozen config record.

Every default is documented next to its field, with the reason it has that value. The measured
facts behind the iSAM2 and insertion defaults are in docs/design.md ("Facts measured when the
design was fixed"). Which observation stream the graph is built from is not configured here: it
is the ``core.modality.Modality`` the registry resolves once and hands to ``GraphSLAM`` (``--set
modality=NAME`` overrides the shared rule).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

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

    AUTO: by modality (``GraphSLAMConfig.landmark_kernel``) -- Huber at
    ``BEARING_HUBER_THRESHOLD`` on the omni front end's bearings, none on range-bearing
    sightings and vertical lines. The bearings' outlier gate is an angle of 20 deg
    (``bearings_3d.BEARING_GATE_RAD``, there to keep a Unit3 error away from 180 deg), ~100
    sigmas of a bearing: a mismatched track's bearing inside it, on a landmark whose depth few
    bearings hold, made iSAM2's Gauss-Newton steps diverge (campus1500 seed 2 at frame 10820: the
    landmark moved 10, 30, 120 m in three updates and dragged the window's poses metres off the
    floor; loop150 seed 2's landmark RMSE 377 m). Range-bearing sightings are gated by their
    chi-square innovation instead.
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
    QR: slower (about 3-5x per update here) and numerically robust.
    AUTO: Cholesky; when it reports an indeterminate system, every factor so far is re-added
        to a fresh QR-factorising iSAM2 (at the current linearisation point), which the rest of
        the run keeps using (``GraphSLAMInfo.factorization_fallbacks``). Cholesky alone was 8x
        faster than QR on the first 250 frames of lab40, and QR alone had not finished lab40
        after 20 min of CPU.
    """

    AUTO = "auto"
    CHOLESKY = "cholesky"
    QR = "qr"


class AssociationTest(enum.Enum):
    """How unlabelled sightings are associated (``association.py``).

    JOINT: joint compatibility (JCBB, ``core.compatibility``) over the frame's sightings with
        the covariance of the frame's pose guess and the candidate landmarks from iSAM2.
    NEAREST: each sighting's nearest landmark inside an individual gate, with a fixed
        landmark sigma (``association_landmark_sigma_m``), one landmark per sighting per frame.
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
#: keep a calibrated bearing (chi-square 2 dof: 98.9 % of them) fully weighted; 1.345 cost
#: lab40 accuracy (seed 0 ATE 0.24 -> 0.42 cm against 0.38 cm at 3; docs/results/graph.md)
BEARING_HUBER_THRESHOLD = 3.0


class PoseVariables(enum.Enum):
    """Which frames get a pose variable.

    SIGHTINGS: frame 0 and every frame whose observation stream is not empty; the odometry in
        between is composed into one between-factor (``poses.py``). On lab40 (2698 frames, 540
        images) it is 5x fewer poses and iSAM2 updates, with the same measurements.
    FRAMES: every frame (one between-factor per odometry step).
    """

    SIGHTINGS = "sightings"
    FRAMES = "frames"


@dataclass(frozen=True, slots=True)
class GraphSLAMConfig:
    """Settings of ``GraphSLAM`` / ``BatchGraphSLAM``.

    Attributes:
        motion_noise: alpha coefficients of the odometry model (thesis eq. 4.41); the 3x3
            covariance of each odometry delta is ``OdometryMotionModel.covariance``.
        odometry_sigmas: fixed (sx [m], sy [m], stheta [rad]) of every odometry factor instead
            of the motion model, for datasets that state their odometry noise (gtsam's
            victoria_park.txt: 0.01, 0.002, 0.002). None (default) uses ``motion_noise``.
        pose_variables: which frames get a pose variable (default SIGHTINGS: frame 0 and the
            frames with sightings of the graph's stream, the odometry in between composed; see
            ``PoseVariables``).
        keyframe_spacing_m: omni bearings: an image becomes a key frame (a pose variable with
            its bearings) only once the robot has moved this far since the newest key frame
            [m]; the bearings of the images in between are not used (counted), their poses are
            the key frame's composed with the odometry. 0 uses every image.
        landmarks_per_image: omni bearings: the per-image landmark budget. Bearings of tracks
            already admitted to the graph are always used; while an image has fewer than this,
            tracks seen in it are admitted, the most-sighted first, spread over azimuth
            (``bearings_3d.py``). 0: every track.
        budget_grace_images: omni bearings: an admitted track that has not entered the graph
            this many images after its admission (far, it does not triangulate) stops counting
            against ``landmarks_per_image`` (``core.track_budget``; default None: every
            admitted track counts). Measured at 10 (docs/results/graph.md, "The landmark budget
            outdoors"): campus1500 seed 0 ATE 39.3 -> 20.2 m (1278 -> 10 303 landmarks); lab40
            seeds 0-1 unchanged, seed 2 1.6 -> 2.8 mm; not the default.
        odometry_min_sigma_m: floor of the std of every odometry factor's translation given its
            rotation [m] (default 1 mm; see ``factors.condition_odometry_covariance``). GTSAM
            4.3's Cholesky rejects a clique whose equilibrated frontal block has a reciprocal
            condition number below sqrt(eps) ~ 1.5e-8 ("Indeterminate linear system"). Two
            consecutive poses in one clique whose relative position is known to ``s_rel`` and
            whose absolute position to ``s_abs`` reach that limit near ``s_abs / s_rel`` ~ 2000
            (the rcond falls as the ratio squared): the motion model's own floor (0.1 mm,
            lateral motion of a car creeping forward) hit it on Victoria Park at frame 2934,
            ``s_abs`` = 0.6 m, measured rcond 2.2e-9. 1 mm keeps the pair solvable while
            ``s_abs`` stays below ~2 m and is still far below the landmark noise of every
            dataset here. Covariances that already respect it (e.g. fixed ``odometry_sigmas``,
            gtsam's victoria_park.txt) are unchanged.
        prior_sigmas: (sx [m], sy [m], stheta [rad]) of the prior anchoring the first pose at
            ``initial_pose`` (default 1 mm / 1 mrad: the first pose defines the world frame).
        sensor_height_m: height of the omni camera's single viewpoint above the robot frame
            origin [m] (omni bearings). Bearings are measured from there.
        planar_sigma_m: std of z in the per-pose prior and of the vertical component of each
            odometry factor [m] (omni bearings; default 1 mm: the robot drives on a plane).
        planar_sigma_rad: std of roll and pitch in the same factors [rad] (default 1 mrad).
        relinearize_threshold: iSAM2 relinearisation threshold on the tangent-space delta
            (default 0.1; stable on all seeds, docs/design.md).
        relinearize_skip: iSAM2 checks for relinearisation every this many updates (default 1:
            the GTSAM default of 10 diverged on one of four seeds, docs/design.md).
        adaptive_reorder_threshold: when iSAM2's Bayes tree holds more than this many times
            the non-zeros a fresh batch ordering would give, GTSAM re-orders and re-eliminates
            the whole tree (``ISAM2Params.enableAdaptiveReorder``, GTSAM 4.3); None disables
            it. Incremental orderings fill in badly once bearing-only tracks close loops.
        min_sightings: sightings a bearing-only track needs before it is triangulated and
            inserted (default 3).
        min_parallax_deg: largest angle between a track's world rays needed before insertion
            [deg] (default 3: fewer made iSAM2 throw "Indeterminate linear system").
        landmark_prior_sigma_m: std of a weak prior that holds each bearing-only landmark near
            the point it was triangulated at when inserted [m] (default 10; None: no prior).
            Bearings leave a landmark's depth only weakly determined; the prior bounds the
            pivots iSAM2's Cholesky meets (a landmark's information is at least 1/sigma^2 per
            axis), so it never reports an indeterminate system, while biasing a landmark known
            to within 0.5 m by (0.5/10)^2 = 0.25% of its offset from the insertion point. On
            lab40 without it, Cholesky failed at frame ~1930 and the rebuild into QR then
            crawled. Range-bearing landmarks are fully observed and get none.
        floor_scale: omni bearings: multiply each odometry translation by the scale the floor
            points give (default True; ``floor_scale.py``): bearings alone leave the map at the
            odometry's scale, and floor points seen from the known camera height are metric.
            Needs a camera height (``sensor_height_m`` > 0); without floor points in the log
            the scale stays 1 and nothing changes.
        floor_scale_final: with ``floor_scale`` and the fixed-lag session: the final estimate
            (LM over the whole graph) takes every odometry translation at the run's final floor
            scale, not at the scale known when its factor was added (the first frames, before
            enough floor pairs, were added at 1; on lab40 the online estimate also sat on a
            wrong mode for a while). The online estimate keeps the scale of its time.
        floor_scale_refine: with ``floor_scale_final``: the final scale is re-estimated from
            the floor pairs over the graph's own trajectory instead of the raw odometry, and
            the final estimate re-solved at it until the correction is < 0.01 % (default True;
            ``FloorScale.refined``). The floor pairs span 5-15 cm, over which the wheel
            odometry's per-step noise spreads each pair's scale by ~16 % (lab40), so the raw
            pairs' estimate was 0.4-0.5 % off; the graph's trajectory, held by every landmark's
            bearings, is not (within 0.03 % on lab40). One or two more LM solves of the whole
            graph.
        floor_landmarks: with ``floor_scale_final``: the tracks of the floor's mode enter the
            final estimate as landmarks with a prior on their height (z = 0) (with
            ``floor_viewpoints`` also the images between key frames that see them, as
            viewpoints with their bearings), and the final
            scale is the one at which the solved trajectory agrees with the odometry
            (``floor_points.py``; default True). The pairs' refined scale
            (``floor_scale_refine``) takes the graph's short relative translations as the
            reference, most of them odometry between key frames: on lab40 seeds 0/1/2 it left
            the map 0.37/0.12/0.17 % small (landmark median 1.57/0.71/0.76 cm), the joint solve
            0.02/0.02/0.03 % (0.63/0.52/0.39 cm). With fewer than ``MIN_PAIRS`` floor tracks
            ``floor_scale_refine`` decides. Four LM solves of the whole graph (the last three
            warm-started, with the floor images' poses) instead of two.
        floor_viewpoints: with ``floor_landmarks``: an image between key frames that sees a
            floor track gets a viewpoint of its own in the joint solve; False (default): only
            the key frames' floor sightings enter it, and a floor track needs two of them.
            The viewpoints make the joint solve grow with the floor sightings: with the front
            end's floor tracks (``FrontendConfig.floor``, ~2600 on lab40, in every image) the
            lab40 replay took 13.6 / 11.1 / 21.8 s of CPU on seeds 0 / 1 / 2, with False 4.0 /
            4.2 / 4.7 s at the same accuracy (ATE 0.19 / 0.21 / 0.22 cm, landmark median 0.46 /
            0.52 / 0.39 cm). Without the front end's floor tracks (a log with ``floor.enabled``
            off: the landmark tracks' few hundred floor points) the viewpoints pay for
            themselves: False gave lab40 seeds 1 / 2 ATE 0.36 / 0.29 cm against 0.25 / 0.16 cm
            (docs/results/graph.md, "The joint floor solve's viewpoints").
        known_odometry_scale: the wheel odometry's translation scale when it is known (a
            calibrated wheel radius): each translation is multiplied by it from the first frame
            and the floor points are not used (None: ``floor_scale`` decides). With the truth's
            scale it tells how much of a graph's error is the floor scale's
            (``benchmarks/realtime_lab40.py --variants true-scale``).
        online_lag_key_frames: omni bearings: the online estimate is a fixed-lag smoother over
            the variables touched within this many key frames, and ``estimate()`` is LM over
            the whole graph (default 20; ``session.FixedLagSession``). None: iSAM2 over the
            whole graph at every key frame (its update grew 35x over lab40, the smoother's
            stays flat; benchmarks/realtime_lab40.py). The smoother's iSAM2 takes
            ``relinearize_threshold`` / ``relinearize_skip``; ``factorization`` and
            ``adaptive_reorder_threshold`` act on the whole-graph iSAM2 only.
        min_consistent_sightings: range-bearing landmarks with given ids enter the graph once
            this many of their sightings agree on the position (chi-square gate at
            ``association_gate_probability``; ``landmark_init.ConsistentInsertion``); the
            disagreeing held-back sightings are dropped with the outlier gate on. Default 2:
            a landmark started from a misread id would sit metres away and the outlier gate
            would then reject its correct sightings (on ``simulate_planar`` with 20 % wrong ids
            the ATE grows 2.7x with 1, 0.98x with 2; MR.CLAM: the README). 1 inserts on the
            first sighting.
        factorization: iSAM2's factorisation (default AUTO: Cholesky, rebuilt with QR if it
            reports an indeterminate system, as it did on a demo seed's front-end log).
        robust_kernel: M-estimator on landmark factors (default AUTO: Huber on the omni
            bearings, none on the other modalities; ``RobustKernel``).
        robust_threshold: kernel threshold on the whitened residual; None uses the kernel's
            default (``DEFAULT_ROBUST_THRESHOLD``: Huber 1.345, Cauchy 2.3849; AUTO's Huber on
            the omni bearings 3, ``BEARING_HUBER_THRESHOLD``).
        outlier_gate_probability: chi-square probability of the outlier gate on range-bearing
            sightings of mapped landmarks with given ids (default
            ``core.gating.OUTLIER_GATE_PROBABILITY``, 0.999): the innovation at the frame's
            guess, with the covariance of the guess and the landmark read from iSAM2
            (``joint_state.py``), beyond the chi-square quantile drops the sighting. 1.0
            disables it.
        outlier_gate_min_sightings: sightings of landmarks with fewer sightings in the graph
            are gated 10 times wider (``core.gating.YOUNG_GATE_FACTOR``; default 20): a
            wrong id among a landmark's first sightings is still hundreds of sigmas off (the
            20%-wrong-ids test of ``tests/graphslam/test_isam.py``). A young landmark's iSAM2
            marginal is linearised where its first sightings put it: with Victoria Park's
            0.2 rad bearing noise the gate then rejected its re-sightings (range innovations of
            3-4 m against a predicted 0.7 m std), each rejection leaving it worse placed, and
            the known-association run on ``victoria-park-gtsam`` ended 101 m from the LM
            optimum (2632 sightings gated; from 5 sightings on: 3.7 m, 1191; from 20: 0.16 m,
            37; gate off: 0.016 m). MR.CLAM's misread barcodes name landmarks seen hundreds of
            times: its ATE is the same from 5, 20 or 50 on (``omnislam run mrclam6-rK
            --estimator graphslam --set outlier_gate_min_sightings=N``).
        outlier_gate_votes: gated range-bearing sightings of one landmark within 10 frames
            that imply the same point, on no other landmark, overrule the gate and all enter
            the graph (``core.gating.GatedResightings``; default 3, 0: the gate has the last
            word). After a lap under biased odometry the pose is metres off and its marginal
            says decimetres: on ``loop150`` seeds 1 and 4 the gate rejected every re-sighting
            of the first poles, 0.866 / 0.854 m ATE with the end 3.3 m off; 0.029 / 0.058 m
            with the votes; ``victoria-park-gtsam`` with ids 0.162 -> 0.0165 m from the LM
            optimum (6 sightings readmitted). MR.CLAM's misread barcodes imply points on the
            landmark the robot really sees and stay rejected (robots 1-5 with ids unchanged).
            Sightings of young landmarks (``outlier_gate_min_sightings``) never vote.
        association_test: JOINT (default) or NEAREST (see ``AssociationTest``).
        association_gate_probability: chi-square probability of the gate inside which an
            unlabelled range-bearing sighting may take a landmark (individual compatibility;
            with JOINT also the joint gate of the frame's hypothesis, d = 2 per pairing;
            default 0.99).
        association_lag_frames: with JOINT, the frames with unlabelled sightings that must
            follow a frame before its unlabelled sightings are associated: JCBB runs over the
            waiting frames together and keeps the oldest frame's decisions
            (``window_association.py``); default 0: each frame on its own.
        association_ambiguity_margin: with JOINT, a pairing that the second-best hypothesis
            (as many pairings) makes differently is dropped as ambiguous unless that hypothesis'
            joint D2 exceeds the best's by this margin (default 2 ln 10 = 4.6: the best must be
            10 times likelier; ``core.compatibility.decide``). MR.CLAM's landmarks stand in
            groups 0.18 m apart: a lone sighting after a stretch of odometry fits several.
        new_landmark_probability: chi-square probability beyond which an unmatched sighting
            starts a new landmark (default 0.9999); sightings between the two gates are
            ambiguous and dropped.
        association_landmark_sigma_m: fixed std of every landmark position used in the
            association gate instead of landmark marginals [m] (default 0.3). See
            ``association.py`` for why and what it costs.
        association_pose_covariance: add the newest pose's iSAM2 marginal covariance to the
            sightings' covariance in the gate (default True; one marginal per frame with
            unlabelled sightings).
        association_landmark_marginals: use each nearby candidate landmark's iSAM2 marginal
            covariance in the gate instead of ``association_landmark_sigma_m`` (default False:
            one back-substitution per candidate and frame, see ``association.py``).
        association_min_sightings: sightings a landmark started by the association needs
            before it enters the graph (default 1: at once). 2 or more holds it as a tentative
            landmark (``tentative.py``) that is dropped, with its sightings, unless re-observed
            within ``association_window_frames`` frames: it removes clutter (spurious
            detections) from the map.
        association_window_frames: largest gap in frames between consecutive sightings of a
            tentative landmark (default 10).
        association_reorder_candidates: have the update after each association re-eliminate
            its candidate landmarks (``ISAM2UpdateParams.extraReelimKeys``; default True). The
            association's joint marginal (``joint_state``) costs what its deepest candidate costs:
            a landmark unseen for a while sits deep in the Bayes tree, and every update replaces
            the root, so its walk to the root is recomputed each frame it stays a candidate.
            Re-eliminated, it moves into the top of the tree, read there on the next frames.
            The same linear system in another order: on Victoria Park the same decisions and
            ATE, 14 % less CPU over the run, 2x over its first half (docs/results/association.md,
            "The cost of the association on Victoria Park").
        loop_closure: merge landmarks started by the association that duplicate older ones
            (``loop_closure.LandmarkMerger``: the local map of recently seen created landmarks
            matched against the older ones by joint compatibility of their iSAM2 estimates,
            then tied by a zero ``BetweenFactorPoint2``). Landmarks with given ids never take
            part. Default False: on MR.CLAM with the ids hidden 2 of the 4 merges it made were
            wrong by the hidden ids (3-sighting landmarks joined to a neighbour 0.18 m away),
            r1 went from 1.60 to 1.46 m and the others did not move, and on Victoria Park it
            cost 64 % more CPU for the same ATE (docs/results/association.md).
        loop_closure_every_frames: the local map is matched every this many frames with
            unlabelled sightings (default 10).
        loop_closure_window_frames: the local map holds the created landmarks seen within this
            many frames (default 50).
        loop_closure_min_landmarks: pairings a match needs before it is accepted (default 2:
            a single landmark near an old one is no evidence of a revisit, see the module).
        loop_closure_merge_sigma_m: std per axis of the merging factor [m] (default 1 mm, the
            odometry's floor: see ``odometry_min_sigma_m`` for the conditioning).
        batch_max_iterations: Levenberg-Marquardt iteration limit of batch mode (default 100).
        batch_relative_error_tol: relative decrease of the graph error below which the final
            Levenberg-Marquardt solve stops (the fixed-lag smoother's ``estimate()`` and batch
            mode; default 1e-6, Ceres's ``function_tolerance``). At 1e-10 the final solve on
            lab40 seeds 1 / 2 ran on for 7-9 s of CPU with the omni bearings' Huber kernel,
            changing the ATE and the landmark median by at most 0.01 mm; GTSAM's default
            1e-5 stopped loop150 seed 2 early (ATE 0.220 -> 0.232 m). The reference optimum
            of ``compare.reference`` keeps its own 1e-10.
        batch_reassociation_rounds: batch mode only: after the final LM, give the sightings the
            association decided to landmarks again, per frame by a minimum-cost assignment
            against the LM map inside the association gate, and solve again, for at most this
            many rounds (``reassociation.py``; default 0: off). Session 21, 3 rounds: MR.CLAM
            without ids robot 1 0.095 -> 0.084 m, the others within 1.1 mm; Victoria Park and
            victoria-park-gtsam without ids unchanged; CARMEN aces 0.800 -> 0.807 m. Not the
            default yet: the suite's rows on those datasets were not re-run with it.
        compute_covariances: ``estimate()`` returns marginal covariances of poses and landmarks
            (default False: marginals cost far more than the estimate).
    """

    motion_noise: MotionNoise = field(default_factory=MotionNoise)
    odometry_sigmas: tuple[float, float, float] | None = None
    pose_variables: PoseVariables = PoseVariables.SIGHTINGS
    keyframe_spacing_m: float = 0.2
    landmarks_per_image: int = 40
    budget_grace_images: int | None = None
    odometry_min_sigma_m: float = 1e-3
    prior_sigmas: tuple[float, float, float] = (1e-3, 1e-3, 1e-3)
    sensor_height_m: float = 0.0
    planar_sigma_m: float = 1e-3
    planar_sigma_rad: float = 1e-3
    relinearize_threshold: float = 0.1
    relinearize_skip: int = 1
    adaptive_reorder_threshold: float | None = None
    min_sightings: int = 3
    min_parallax_deg: float = 3.0
    landmark_prior_sigma_m: float | None = 10.0
    floor_scale: bool = True
    floor_scale_final: bool = True
    floor_scale_refine: bool = True
    floor_landmarks: bool = True
    floor_viewpoints: bool = False
    known_odometry_scale: float | None = None
    online_lag_key_frames: int | None = 20
    min_consistent_sightings: int = 2
    factorization: Factorization = Factorization.AUTO
    robust_kernel: RobustKernel = RobustKernel.AUTO
    robust_threshold: float | None = None
    outlier_gate_probability: float = OUTLIER_GATE_PROBABILITY
    outlier_gate_min_sightings: int = OUTLIER_GATE_MIN_SIGHTINGS
    outlier_gate_votes: int = RESIGHTING_VOTES
    association_test: AssociationTest = AssociationTest.JOINT
    association_gate_probability: float = 0.99
    association_lag_frames: int = 0
    association_ambiguity_margin: float = 4.6
    new_landmark_probability: float = 0.9999
    association_landmark_sigma_m: float = 0.3
    association_pose_covariance: bool = True
    association_landmark_marginals: bool = False
    association_min_sightings: int = 1
    association_window_frames: int = 10
    association_reorder_candidates: bool = True
    loop_closure: bool = False
    loop_closure_every_frames: int = 10
    loop_closure_window_frames: int = 50
    loop_closure_min_landmarks: int = 2
    loop_closure_merge_sigma_m: float = 1e-3
    batch_max_iterations: int = 100
    batch_relative_error_tol: float = 1e-6
    batch_reassociation_rounds: int = 0
    compute_covariances: bool = False

    def __post_init__(self) -> None:
        if self.known_odometry_scale is not None and not self.known_odometry_scale > 0:
            raise ConfigError(
                f"known_odometry_scale must be positive, got {self.known_odometry_scale}")
        if not isinstance(self.robust_kernel, RobustKernel):
            raise ConfigError(f"robust_kernel must be a RobustKernel, got {self.robust_kernel!r}")
        positive = {
            "planar_sigma_m": self.planar_sigma_m,
            "planar_sigma_rad": self.planar_sigma_rad,
            "relinearize_threshold": self.relinearize_threshold,
            "odometry_min_sigma_m": self.odometry_min_sigma_m,
            "association_landmark_sigma_m": self.association_landmark_sigma_m,
            "loop_closure_merge_sigma_m": self.loop_closure_merge_sigma_m,
        }
        for name, value in positive.items():
            if not value > 0:
                raise ConfigError(f"{name} must be positive, got {value}")
        for name in ("prior_sigmas", "odometry_sigmas"):
            sigmas = getattr(self, name)
            if sigmas is not None and (len(sigmas) != 3 or min(sigmas) <= 0):
                raise ConfigError(f"{name} must be three positive numbers, got {sigmas}")
        if self.keyframe_spacing_m < 0 or self.landmarks_per_image < 0:
            raise ConfigError("keyframe_spacing_m and landmarks_per_image must be >= 0")
        if self.budget_grace_images is not None and self.budget_grace_images < 1:
            raise ConfigError(
                f"budget_grace_images must be >= 1 or unset, got {self.budget_grace_images}"
            )
        if self.relinearize_skip < 1 or self.batch_max_iterations < 1:
            raise ConfigError("relinearize_skip and batch_max_iterations must be >= 1")
        if self.batch_reassociation_rounds < 0:
            raise ConfigError(
                f"batch_reassociation_rounds must be >= 0, got {self.batch_reassociation_rounds}"
            )
        if self.min_sightings < 2:
            raise ConfigError(f"min_sightings must be >= 2, got {self.min_sightings}")
        if self.min_consistent_sightings < 1:
            raise ConfigError(
                f"min_consistent_sightings must be >= 1, got {self.min_consistent_sightings}"
            )
        if self.association_min_sightings < 1 or self.association_window_frames < 1:
            raise ConfigError(
                "association_min_sightings and association_window_frames must be >= 1, got "
                f"{self.association_min_sightings} and {self.association_window_frames}"
            )
        if min(self.loop_closure_every_frames, self.loop_closure_window_frames) < 1:
            raise ConfigError(
                "loop_closure_every_frames and loop_closure_window_frames must be >= 1"
            )
        if self.loop_closure_min_landmarks < 1:
            raise ConfigError(
                f"loop_closure_min_landmarks must be >= 1, got {self.loop_closure_min_landmarks}"
            )
        if self.min_parallax_deg < 0:
            raise ConfigError(f"min_parallax_deg must be >= 0, got {self.min_parallax_deg}")
        if self.outlier_gate_votes < 0:
            raise ConfigError(f"outlier_gate_votes must be >= 0, got {self.outlier_gate_votes}")
        if not 0 < self.outlier_gate_probability <= 1:
            raise ConfigError(
                f"outlier_gate_probability must be in (0, 1], got {self.outlier_gate_probability}"
            )
        if not 0 < self.association_gate_probability <= self.new_landmark_probability < 1:
            raise ConfigError(
                "need 0 < association_gate_probability <= new_landmark_probability < 1"
            )
        if self.robust_threshold is not None and not self.robust_threshold > 0:
            raise ConfigError(f"robust_threshold must be positive, got {self.robust_threshold}")
        if self.landmark_prior_sigma_m is not None and not self.landmark_prior_sigma_m > 0:
            raise ConfigError(
                "landmark_prior_sigma_m must be positive or unset, "
                f"got {self.landmark_prior_sigma_m}"
            )
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


#: named presets (the CLI merges ``--set key=value`` overrides on top of one of these)
PRESETS: dict[str, GraphSLAMConfig] = {
    "default": GraphSLAMConfig(),
    "robust": GraphSLAMConfig(robust_kernel=RobustKernel.CAUCHY, min_consistent_sightings=2),
    "victoria-park-gtsam": GraphSLAMConfig(odometry_sigmas=(0.01, 0.002, 0.002)),
}
