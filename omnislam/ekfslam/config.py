"""Configuration of the EKF-SLAM baseline: a tree of frozen sections with documented defaults.

``EKFSLAMConfig`` holds one section per trade: the joint Gaussian's start (``state``), the
association of sightings without ids (``association``), the tentative landmarks
(``landmarks``), the outlier gate of sightings with ids (``outlier_gate``), the omni bearings'
delayed triangulation (``bearings``) and the switches measured and left off (``experimental``).
The 2-D filter (``filter.EKFSLAM``) reads all but ``bearings``; the omni filter
(``bearings.BearingEKFSLAM``) ``state`` and ``bearings`` only.

One set of defaults serves every dataset: the sighting noise comes from the data
(``RangeBearing.sigma_range_m`` / ``sigma_bearing_rad`` per sighting), the odometry noise from the
shared motion model (or from the log's own odometry covariance, when it states one).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from enum import Enum
from typing import ClassVar

from omnislam.core.gating import (
    OUTLIER_GATE_MIN_SIGHTINGS,
    OUTLIER_GATE_PROBABILITY,
    RESIGHTING_VOTES,
)
from omnislam.core.motion import MotionNoise
from omnislam.errors import ConfigError


class AssociationTest(Enum):
    """How a frame's sightings of unknown id are paired with the state's landmarks.

    JOINT: together, by joint compatibility (JCBB, Neira & Tardos 2001) with the filter's P.
    NEAREST: one after another, each with its nearest gated landmark (SLAM for Dummies).
    """

    JOINT = "joint"
    NEAREST = "nearest"


@dataclass(frozen=True, slots=True)
class StateConfig:
    """The joint Gaussian at the start (``state.SlamGaussian``).

    Attributes:
        initial_pose_sigma: std of the first pose (x, y, theta) [m, m, rad]. Default 1 mm /
            1 mrad, like graphslam's prior on the first pose: SLAM for Dummies ("A matriz de
            covariância") advises a small non-zero initial uncertainty, which anchors the map
            frame there.
        initial_landmark_capacity: landmark slots preallocated in the state (the arrays double
            when full). Default 64.
    """

    initial_pose_sigma: tuple[float, float, float] = (1e-3, 1e-3, 1e-3)
    initial_landmark_capacity: int = 64

    def __post_init__(self) -> None:
        if len(self.initial_pose_sigma) != 3 or min(self.initial_pose_sigma) < 0:
            raise ConfigError("initial_pose_sigma must be three non-negative stds")
        if self.initial_landmark_capacity < 1:
            raise ConfigError("initial_landmark_capacity must be >= 1")


@dataclass(frozen=True, slots=True)
class AssociationConfig:
    """The association of range-bearing sightings without ids ("Associação de dados").

    Attributes:
        test: how a frame's sightings of unknown id are paired with the state's landmarks
            (``AssociationTest``). Joint, the default: together, by joint compatibility (JCBB,
            Neira & Tardos 2001) with the filter's P; nearest: the tutorial's sequential
            nearest neighbour.
        gate_probability: the validation gate nu^T S^-1 nu <= lambda of sightings without ids
            (and of their match to tentative landmarks), lambda the chi-square quantile (2 dof)
            of this probability. Default 0.99 (lambda = 9.21).
        new_landmark_gate_probability: a sighting outside the validation gate of every
            landmark but inside this wider gate (chi-square, 2 dof) of one of them is ambiguous
            and discarded instead of starting a new landmark; at least ``gate_probability``.
            Default 0.99999 (23.0): otherwise a landmark whose estimate has become
            overconfident (the EKF's linearisation at loop closure) is duplicated as soon as
            two sightings miss its gate.
        ambiguity_margin: with the joint test, a pairing that the second-best hypothesis (as
            many pairings) makes differently is dropped as ambiguous unless its joint D2
            exceeds the best's by this margin (``core.compatibility.decide``). Default 2 ln 10
            = 4.6: the best ten times likelier.
        support_sigma_ratio: with the joint test, a pairing whose innovation is wider than the
            sighting's noise by more than this factor (``core.compatibility``'s
            ``innovation_widening``) must keep its landmark when JCBB and the ambiguity test run
            again on the frame's kept pairings alone (``decide_on_kept_support``); inf: off.
            Default 20: when ``ambiguity_margin`` drops a sighting, the ones it keeps lose its
            joint support.
        displaced_sigma_ratio: with the joint test, a pairing wider than its noise by more than
            this factor is dropped as ambiguous when its sighting is individually nearer
            (smaller D2) to a candidate landmark that no pairing of the frame takes
            (``EKFSLAM._displaced_wide``); inf: off. Default 20: JCBB's most-pairings
            hypothesis moved it there.
        contested_sigma_ratio: with the joint test, a pairing wider than its noise by more than
            this factor is dropped as ambiguous when another sighting of the frame, left
            unpaired, is within ``ambiguity_margin`` of its D2 to that landmark; inf: off.
            Default 20: the frame does not tell which of the two the landmark is.
        ignore_ids: treat every sighting as of unknown id (associated even when the data carry
            ids). Default off.
    """

    test: AssociationTest = AssociationTest.JOINT
    gate_probability: float = 0.99
    new_landmark_gate_probability: float = 0.99999
    ambiguity_margin: float = 4.6
    support_sigma_ratio: float = 20.0
    displaced_sigma_ratio: float = 20.0
    contested_sigma_ratio: float = 20.0
    ignore_ids: bool = False

    def __post_init__(self) -> None:
        if not 0.0 < self.gate_probability < 1.0:
            raise ConfigError(f"gate_probability must be in (0, 1), got {self.gate_probability}")
        if not self.gate_probability <= self.new_landmark_gate_probability < 1.0:
            raise ConfigError(
                "new_landmark_gate_probability must be in [gate_probability, 1), "
                f"got {self.new_landmark_gate_probability}"
            )
        if self.ambiguity_margin < 0:
            raise ConfigError(f"ambiguity_margin must be >= 0, got {self.ambiguity_margin}")
        if not self.support_sigma_ratio >= 1:
            raise ConfigError(
                f"support_sigma_ratio must be >= 1 (inf: off), got {self.support_sigma_ratio}"
            )
        if self.displaced_sigma_ratio < 1 or self.contested_sigma_ratio < 1:
            raise ConfigError(
                "displaced_sigma_ratio and contested_sigma_ratio must be >= 1 (inf: off), got "
                f"{self.displaced_sigma_ratio}, {self.contested_sigma_ratio}"
            )


@dataclass(frozen=True, slots=True)
class LandmarksConfig:
    """Landmarks of unknown id before they enter the state (the tutorial's counter;
    ``association.TentativeLandmarks``).

    Attributes:
        min_sightings: sightings a landmark of unknown id needs before it enters the state
            (augmentation, "Passo 3"; the N of "Associação de dados"). Before, it is tentative,
            kept outside the filter state; 1: every unmatched sighting becomes a landmark at
            once. Default 2.
        tentative_window_m: a tentative landmark not re-observed while the robot travels this
            far (odometry path length) is dropped as a spurious detection [m]. Default 12: a
            distance rather than a count of frames means the same on every dataset.
    """

    min_sightings: int = 2
    tentative_window_m: float = 12.0

    def __post_init__(self) -> None:
        if self.min_sightings < 1:
            raise ConfigError(f"min_sightings must be >= 1, got {self.min_sightings}")
        if not self.tentative_window_m > 0:
            raise ConfigError(f"tentative_window_m must be > 0, got {self.tentative_window_m}")


@dataclass(frozen=True, slots=True)
class OutlierGateConfig:
    """The outlier gate of range-bearing sightings *with* ids (``core.gating``).

    Attributes:
        probability: chi-square probability (2 dof) of the gate: an update whose innovation
            lies outside its quantile, under the filter's own S = H P H^T + R, is skipped; 1.0
            trusts every id. Default ``core.gating.OUTLIER_GATE_PROBABILITY``, 0.999 as every
            Gaussian back end.
        mature_sightings: sightings a landmark needs in the state before the plain gate
            applies: younger ones are gated ``core.gating.YOUNG_GATE_FACTOR`` (10) times wider
            and never vote. Default 20, as graphslam: a young landmark's linearised estimate is
            not trusted near the gate.
        votes: gated sightings of one landmark within 10 frames that imply the same point, on
            no other landmark, overrule the gate, and the newest updates the state
            (``core.gating.GatedResightings``); 0: the gate has the last word. Default 3: a
            loop closed under an overconfident pose is not a misread id.
    """

    probability: float = OUTLIER_GATE_PROBABILITY
    mature_sightings: int = OUTLIER_GATE_MIN_SIGHTINGS
    votes: int = RESIGHTING_VOTES

    def __post_init__(self) -> None:
        if self.votes < 0:
            raise ConfigError(f"outlier_gate.votes must be >= 0, got {self.votes}")
        if not 0.0 < self.probability <= 1.0:
            raise ConfigError(
                f"outlier_gate.probability must be in (0, 1], got {self.probability}"
            )


@dataclass(frozen=True, slots=True)
class BearingsConfig:
    """The omni camera's bearings: 3-D landmarks by delayed triangulation (``bearings``).

    Attributes:
        sensor_height_m: height of the camera's single viewpoint above the ground plane [m].
            Default 0; the factory sets it from the calibration rig.
        min_track_sightings: sightings a track needs before it is triangulated and enters the
            state (delayed initialisation), at least 2. Default 3.
        min_parallax_deg: the angle the track's viewpoints must subtend at the triangulated
            point before it enters the state [deg]. Default 3, graphslam's and FastSLAM's.
        track_gate_probability: chi-square probability (2 dof) of the gate on the (azimuth,
            elevation) innovation of a mapped track: outside it the sighting is an outlier (a
            feature track that jumped to another point) and is skipped. Default 0.999.
        landmarks_per_image: the per-image landmark budget of ``core.track_budget``; 0: every
            track. Default 30 (graphslam's is 40): each landmark adds three rows and columns to
            P and each sighting an O(n^2) update.
    """

    sensor_height_m: float = 0.0
    min_track_sightings: int = 3
    min_parallax_deg: float = 3.0
    track_gate_probability: float = 0.999
    landmarks_per_image: int = 30

    def __post_init__(self) -> None:
        if self.min_track_sightings < 2:
            raise ConfigError(
                f"min_track_sightings must be >= 2, got {self.min_track_sightings}"
            )
        if self.min_parallax_deg < 0 or self.landmarks_per_image < 0:
            raise ConfigError("min_parallax_deg and landmarks_per_image must be >= 0")
        if not 0.0 < self.track_gate_probability <= 1.0:
            raise ConfigError(
                f"track_gate_probability must be in (0, 1], got {self.track_gate_probability}"
            )


@dataclass(frozen=True, slots=True)
class ExperimentalConfig:
    """Switches measured and left off.

    Attributes:
        loop_min_pairings: with the joint test, a loop-closure pairing (wider than
            ``loop_sigma_ratio``) is kept only when the frame's joint hypothesis has at least
            this many pairings, else dropped as ambiguous. Default 1, off: it helped on one
            carmen-aces front-end log and hurt MR.CLAM robot 1 without ids.
        loop_sigma_ratio: a pairing whose innovation covariance S is wider than the sighting's
            noise R by more than this factor (largest std of R^-1/2 S R^-1/2) is a loop
            closure, a landmark the robot is no longer tied to; read by ``loop_min_pairings``
            only. Default 50.
    """

    loop_min_pairings: int = 1
    loop_sigma_ratio: float = 50.0

    def __post_init__(self) -> None:
        if self.loop_min_pairings < 1 or self.loop_sigma_ratio < 1:
            raise ConfigError(
                "loop_min_pairings must be >= 1 and loop_sigma_ratio >= 1, got "
                f"{self.loop_min_pairings}, {self.loop_sigma_ratio}"
            )


@dataclass(frozen=True, slots=True)
class EKFSLAMConfig:
    """Everything the EKF-SLAM estimator needs, section by section.

    Attributes:
        motion_noise: alpha coefficients of the shared odometry model (thesis eqs. 4.40-4.41),
            the process noise Q of SLAM for Dummies' "Passo 1", unused for frames whose
            odometry carries its own covariance. Default: core's, the same as the other back
            ends.
        state: the first pose's std and the preallocated landmark slots.
        association: sightings without ids: the test, its gates and its ambiguity rules.
        landmarks: tentative landmarks, before they enter the state.
        outlier_gate: sightings with ids: the gate, young landmarks and agreeing re-sightings.
        bearings: the omni bearings' delayed triangulation and landmark budget.
        experimental: switches measured and left off.
    """

    MAIN_OPTIONS: ClassVar[tuple[str, ...]] = (
        "motion_noise.a_vv",
        "motion_noise.a_ww",
        "association.test",
        "association.gate_probability",
        "association.new_landmark_gate_probability",
        "association.ignore_ids",
        "landmarks.min_sightings",
        "landmarks.tentative_window_m",
        "outlier_gate.probability",
        "outlier_gate.votes",
        "bearings.sensor_height_m",
        "bearings.min_parallax_deg",
        "bearings.landmarks_per_image",
    )
    RENAMED_OPTIONS: ClassVar[dict[str, str]] = {
        "association_test": "association.test",
        "known_gate_probability": "outlier_gate.probability",
        "known_gate_min_sightings": "outlier_gate.mature_sightings",
        "known_gate_votes": "outlier_gate.votes",
        "bearing_min_sightings": "bearings.min_track_sightings",
        "bearing_min_parallax_deg": "bearings.min_parallax_deg",
        "bearing_gate_probability": "bearings.track_gate_probability",
    }

    motion_noise: MotionNoise = field(default_factory=MotionNoise)
    state: StateConfig = field(default_factory=StateConfig)
    association: AssociationConfig = field(default_factory=AssociationConfig)
    landmarks: LandmarksConfig = field(default_factory=LandmarksConfig)
    outlier_gate: OutlierGateConfig = field(default_factory=OutlierGateConfig)
    bearings: BearingsConfig = field(default_factory=BearingsConfig)
    experimental: ExperimentalConfig = field(default_factory=ExperimentalConfig)

    def with_(self, **changes: object) -> EKFSLAMConfig:
        """A copy with some fields (whole sections) changed (validated again)."""
        return replace(self, **changes)
