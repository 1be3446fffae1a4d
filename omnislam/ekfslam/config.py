"""Configuration of the EKF-SLAM baseline: one frozen dataclass with documented defaults.

One set of defaults serves every dataset: the sighting noise comes from the data
(``RangeBearing.sigma_range_m`` / ``sigma_bearing_rad`` per sighting), the odometry noise from the
shared motion model (or from the log's own odometry covariance, when it states one).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from omnislam.core.gating import (
    OUTLIER_GATE_MIN_SIGHTINGS,
    OUTLIER_GATE_PROBABILITY,
    RESIGHTING_VOTES,
)
from omnislam.core.motion import MotionNoise
from omnislam.errors import ConfigError


@dataclass(frozen=True, slots=True)
class EKFSLAMConfig:
    """Everything the EKF-SLAM estimator needs.

    Attributes:
        motion_noise: alpha coefficients of the shared odometry model (thesis eqs. 4.40-4.41),
            the process noise Q of SLAM for Dummies' "Passo 1"; the same defaults as the other
            back ends. Unused for frames whose odometry carries its own covariance.
        initial_pose_sigma: std of the first pose (x, y, theta) [m, m, rad]. SLAM for Dummies
            ("A matriz de covariância") advises a small non-zero initial uncertainty; 1 mm /
            1 mrad, like graphslam's prior on the first pose, anchors the map frame there.
        gate_probability: the validation gate nu^T S^-1 nu <= lambda with lambda the chi-square
            quantile (2 dof) of this probability ("Associação de dados"); 0.99 -> lambda = 9.21.
            Sightings without ids only.
        new_landmark_gate_probability: a sighting of unknown id outside the validation gate of
            every landmark but inside this wider gate (chi-square quantile, 2 dof; 0.99999 ->
            23.0) of one of them is ambiguous: it is discarded instead of starting a new
            landmark. Without it, a landmark whose estimate has become overconfident (the EKF's
            linearisation at loop closure) is duplicated as soon as two sightings miss its gate.
            Must be >= ``gate_probability``.
        min_sightings: N of "Associação de dados": a sighting of unknown id is associated only
            with landmarks seen at least N times; a landmark seen fewer times is tentative (kept
            outside the filter state) and enters the state (augmentation, "Passo 3") at its N-th
            sighting. 1: every unmatched sighting becomes a landmark at once.
        tentative_window_m: a tentative landmark not re-observed while the robot travels this
            far [m] (odometry path length) is dropped (a spurious detection). A distance, not a
            count of frames, so that one default means the same on every dataset: the earlier
            window of 20 frames was 11-13 m on Victoria Park and carmen-intel (0.57 / 0.64 m per
            frame) but 0.4 m on MR.CLAM (0.02 m per frame), where it dropped the one far
            sighting of landmarks 16 and 17 that robot 1 has before it reaches them, 53 s
            later, with its pose 0.8 m / 25 deg uncertain: without them in the map, their
            sightings paired with landmarks 14 and 15, 2 m away (ATE 2.13 m; 0.18 m with ids).
            12 m: MR.CLAM robot 1 without ids 0.18 m, robot 5 0.11 -> 0.18 m; carmen-aces,
            carmen-intel and Victoria Park within noise (docs/results/ekfslam.md,
            "MR.CLAM without ids"); 2-5 m throws carmen-aces (0.98 m per frame) from 1.62 to
            3.9 m, no limit throws carmen-intel from 0.26 to 0.65 m.
        known_gate_probability: the outlier gate for sightings *with* ids: an update whose
            innovation lies outside the chi-square quantile of this probability (2 dof, under
            the filter's own S = H P H^T + R) is skipped. Default
            ``core.gating.OUTLIER_GATE_PROBABILITY`` (0.999, the same as every Gaussian back
            end); 1.0 trusts every id.
        known_gate_min_sightings: landmarks with fewer sightings in the state are gated
            ``core.gating.YOUNG_GATE_FACTOR`` (10) times wider (default 20, as graphslam): with
            the plain gate on ``victoria-park-gtsam`` 2650 of 3640 sightings were gated and the
            run ended 105 m off (6.6 m with no gate).
        known_gate_votes: gated sightings of one landmark within 10 frames that imply the same
            point, on no other landmark, overrule the gate, and the newest updates the state
            (``core.gating.GatedResightings``; default 3, 0: the gate has the last word): a
            loop closed under an overconfident pose is not a misread id (``loop150`` seeds 1
            and 4, wheel odometry and the poles' ids: end error 3.0 / 3.9 m with the gate
            alone, 0.10 / 0.54 m with the votes). Young landmarks never vote.
        association_test: "joint" (default): a frame's sightings of unknown id against the
            state landmarks by joint compatibility (JCBB, Neira & Tardos 2001) with the filter's
            P; "nearest": the tutorial's sequential nearest neighbour.
        ambiguity_margin: with "joint", a pairing that the second-best hypothesis (as many
            pairings) makes differently is dropped as ambiguous unless its joint D2 exceeds
            the best's by this margin (default 2 ln 10 = 4.6; ``core.compatibility.decide``).
        support_sigma_ratio: with "joint", a pairing of unknown id whose innovation is wider than
            the sighting's noise by more than this factor
            (``core.compatibility.innovation_widening``) must keep its landmark when JCBB and the
            ambiguity test run again on the frame's kept pairings alone
            (``decide_on_kept_support``): when ``ambiguity_margin`` drops a sighting, the ones it
            keeps lose its joint support. Default 20. On carmen-aces (the default front-end log) a
            frame-221 sighting kept that way paired with a landmark 200 scans old (range innovation
            11 m) and threw the pose 12 m: ATE 4.19 m, 1.62 m with the rule (1.61-1.62 m at 5-40,
            3.06 m at 50; on three ICP realisations of the earlier multi-threaded front end 4.19 ->
            1.62, 4.31 -> 1.61, 4.30 -> 3.50 m). At 20 MR.CLAM 6 without ids (robots 1-5; also at
            40), carmen-intel (also at 5-50), Victoria Park and corridor21 stay within 3 mm; at 10
            MR.CLAM robot 5 goes from 0.11 to 0.18 m, and with every pairing held to it (1) robot 2
            from 0.49 to 0.75 m (docs/results/ekfslam.md, "CARMEN aces"). inf: off.
        loop_sigma_ratio: with "joint", a pairing of unknown id whose innovation covariance
            S is wider than the sighting's noise R by more than this factor (largest std of
            R^-1/2 S R^-1/2) is a loop closure: a landmark the robot is no longer tied to.
        loop_min_pairings: such a pairing is kept only when the frame's joint hypothesis has at
            least this many pairings; otherwise it is ambiguous and dropped. 1 (the default):
            always kept. On carmen-aces (0.7 persistent laser sightings per scan) one sighting
            paired with a landmark seen 200 scans before, 11 m of range innovation inside the
            gate of a pose 3 m uncertain, threw the pose 12 m; with 2, two sightings of one
            object paired with two old landmarks threw it 4 m. 3 with a ratio of 50 takes aces
            from 4.20 to 1.40 m on one front-end log (4.19 -> 4.27 m on another: the ICP's
            realisation decides) but MR.CLAM robot 1 without ids from 2.13 to 2.89 m (robots 2,
            3, 5 unchanged, robot 4 0.29 -> 0.26 m; Victoria Park unchanged at a ratio of 10;
            docs/results/ekfslam.md): off by default.
        displaced_sigma_ratio: with "joint", a pairing of unknown id whose innovation is wider
            than the sighting's noise by more than this factor (``innovation_widening``) is
            dropped as ambiguous when its sighting is individually nearer (smaller D2) to a
            candidate landmark that no pairing of the frame takes (``EKFSLAM._displaced_wide``):
            JCBB's most-pairings hypothesis moved it there. On MR.CLAM robot 2 without ids
            (frame 194, after 45 s without sightings, the heading 17 deg uncertain) landmarks 19
            and 20, mapped as one, paired with 17 and 16 1.7 m away: ATE 0.48 -> 0.36 m (0.28 m
            with ids); robots 3-5 unchanged (within 1 mm), robot 1 2.14 -> 2.09 m; carmen-aces,
            carmen-intel and Victoria Park unchanged: the rule never fires there. inf: off.
        contested_sigma_ratio: with "joint", the same from the landmark's side: a pairing wider
            than its noise by more than this factor is dropped as ambiguous when another sighting
            of the frame, left unpaired, is within ``ambiguity_margin`` of its D2 to that
            landmark: the frame does not tell which of the two the landmark is (MR.CLAM robot 1,
            frame 190: sightings of 17 and 18, 0.17 m apart, D2 8.9 and 12.1 to landmark 14, 2 m
            away). Default 20: carmen-aces 1.62 -> 1.37 m, MR.CLAM without ids robot 2 0.356 ->
            0.352 m and robot 4 0.287 -> 0.277 m (16 landmarks for 15), robots 1, 3, 5,
            carmen-intel and Victoria Park unchanged (it never fires on the last two). inf: off.
        ignore_ids: treat every sighting as of unknown id (nearest-neighbour association even
            when the data carry ids).
        initial_landmark_capacity: landmark slots preallocated in the state; the arrays double
            when full.
        sensor_height_m: omni bearings: height of the camera's single viewpoint above the
            ground plane [m] (set from the calibration rig by the factory).
        bearing_min_sightings: omni bearings: sightings a track needs before it is
            triangulated and enters the state (delayed initialisation, ``bearings``); >= 2.
        bearing_min_parallax_deg: omni bearings: the angle the track's viewpoints subtend at
            the triangulated point needed before it enters the state [deg] (graphslam's and
            FastSLAM's 3 deg).
        bearing_gate_probability: omni bearings: an (azimuth, elevation) innovation of a mapped
            track outside this chi-square quantile (2 dof) is an outlier (a feature track that
            jumped to another point) and is skipped.
        landmarks_per_image: omni bearings: the per-image landmark budget of
            ``core.track_budget`` (graphslam's is 40); 0: every track. Each landmark adds three
            rows and columns to P and each sighting an O(n^2) update. 30 since the front end's
            keypoint budget (~115 bearings per lab40 image instead of ~226, shorter tracks, so
            more admissions): with 40 lab40's state grew from 619 to 1197 landmarks and the
            replay to 16.5 s (< 20x real time); 30 gives 8.2 s and ATE / landmark RMSE 3.08 /
            17.7 cm against 3.26 / 18.8 (demo 2.96 / 6.4 against 2.71 / 9.1 cm, loop150 21.6 /
            41.1 against 23.5 / 42.8 cm; docs/results/ekfslam.md, "Omni bearings").
    """

    motion_noise: MotionNoise = field(default_factory=MotionNoise)
    initial_pose_sigma: tuple[float, float, float] = (1e-3, 1e-3, 1e-3)
    gate_probability: float = 0.99
    new_landmark_gate_probability: float = 0.99999
    min_sightings: int = 2
    tentative_window_m: float = 12.0
    known_gate_probability: float = OUTLIER_GATE_PROBABILITY
    known_gate_min_sightings: int = OUTLIER_GATE_MIN_SIGHTINGS
    known_gate_votes: int = RESIGHTING_VOTES
    association_test: str = "joint"
    ambiguity_margin: float = 4.6
    support_sigma_ratio: float = 20.0
    loop_sigma_ratio: float = 50.0
    loop_min_pairings: int = 1
    displaced_sigma_ratio: float = 20.0
    contested_sigma_ratio: float = 20.0
    ignore_ids: bool = False
    initial_landmark_capacity: int = 64
    sensor_height_m: float = 0.0
    bearing_min_sightings: int = 3
    bearing_min_parallax_deg: float = 3.0
    bearing_gate_probability: float = 0.999
    landmarks_per_image: int = 30

    def __post_init__(self) -> None:
        if not 0.0 < self.gate_probability < 1.0:
            raise ConfigError(f"gate_probability must be in (0, 1), got {self.gate_probability}")
        if not self.gate_probability <= self.new_landmark_gate_probability < 1.0:
            raise ConfigError(
                "new_landmark_gate_probability must be in [gate_probability, 1), "
                f"got {self.new_landmark_gate_probability}"
            )
        if self.known_gate_votes < 0:
            raise ConfigError(f"known_gate_votes must be >= 0, got {self.known_gate_votes}")
        if not 0.0 < self.known_gate_probability <= 1.0:
            raise ConfigError(
                f"known_gate_probability must be in (0, 1], got {self.known_gate_probability}"
            )
        if self.association_test not in ("joint", "nearest"):
            raise ConfigError(
                f"association_test must be 'joint' or 'nearest', got {self.association_test!r}"
            )
        if self.ambiguity_margin < 0:
            raise ConfigError(f"ambiguity_margin must be >= 0, got {self.ambiguity_margin}")
        if self.min_sightings < 1:
            raise ConfigError(f"min_sightings must be >= 1, got {self.min_sightings}")
        if not self.support_sigma_ratio >= 1:
            raise ConfigError(
                f"support_sigma_ratio must be >= 1 (inf: off), got {self.support_sigma_ratio}"
            )
        if self.displaced_sigma_ratio < 1 or self.contested_sigma_ratio < 1:
            raise ConfigError(
                "displaced_sigma_ratio and contested_sigma_ratio must be >= 1 (inf: off), got "
                f"{self.displaced_sigma_ratio}, {self.contested_sigma_ratio}"
            )
        if self.loop_min_pairings < 1 or self.loop_sigma_ratio < 1:
            raise ConfigError(
                "loop_min_pairings must be >= 1 and loop_sigma_ratio >= 1, got "
                f"{self.loop_min_pairings}, {self.loop_sigma_ratio}"
            )
        if not self.tentative_window_m > 0:
            raise ConfigError(f"tentative_window_m must be > 0, got {self.tentative_window_m}")
        if len(self.initial_pose_sigma) != 3 or min(self.initial_pose_sigma) < 0:
            raise ConfigError("initial_pose_sigma must be three non-negative stds")
        if self.initial_landmark_capacity < 1:
            raise ConfigError("initial_landmark_capacity must be >= 1")
        if self.bearing_min_sightings < 2:
            raise ConfigError(
                f"bearing_min_sightings must be >= 2, got {self.bearing_min_sightings}"
            )
        if self.bearing_min_parallax_deg < 0 or self.landmarks_per_image < 0:
            raise ConfigError("bearing_min_parallax_deg and landmarks_per_image must be >= 0")
        if not 0.0 < self.bearing_gate_probability <= 1.0:
            raise ConfigError(
                f"bearing_gate_probability must be in (0, 1], got {self.bearing_gate_probability}"
            )

    def with_(self, **changes: object) -> EKFSLAMConfig:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)
