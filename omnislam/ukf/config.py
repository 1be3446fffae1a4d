"""Configuration of the vertical-line UKF localiser (Barra & Costa): a tree of frozen sections.

``UKFConfig`` holds one section per trade, and each collaborator receives its own: the pose
UKF its ``sigma_points``, step 3 (``tracking.track_lines``) ``tracking``, the photometric
stage ``photometric``, steps 4-5 ``association``; the localiser reads ``spacing``, ``filter``
and ``image``. Every number of the paper is a default here, with the section it comes from; the
choices the paper leaves open (its reference Barra & Costa 2005 for step 3 is not available) are
marked "ours" and documented where they are used.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from enum import Enum
from typing import ClassVar

from omnislam.core.motion import MotionNoise
from omnislam.errors import ConfigError

#: the UKF's odometry noise: 4x core's default alphas (see ``UKFConfig.motion_noise``)
UKF_MOTION_NOISE = MotionNoise(a_vv=0.2, a_vw=0.05, a_wv=0.05, a_ww=0.2)


class PhotometricMode(Enum):
    """Whether step 4 uses the photometric gate and score C'_ij (sec. 3.2).

    AUTO: when both the map (MC descriptors) and the sightings (PMC profiles) carry colour.
    ON: always; a map without descriptors or sightings without profiles is a ConfigError.
    OFF: geometric association only (u_shift windows, F_shift; C'_ij = 0).
    """

    AUTO = "auto"
    ON = "on"
    OFF = "off"


@dataclass(frozen=True, slots=True)
class SpacingConfig:
    """Which frames are processed: every d_it of travel (sec. 5); between them the filter only
    predicts.

    Attributes:
        d_it_m: travel between processed images [m]. Default 0.375, the paper's (sec. 5).
        d_it_sightings_m: travel between processed frames whose sightings come from a
            range-bearing sensor rather than images [m]. Default 0, every such frame (ours): a
            sensor that states its bearings costs nothing to process, where the paper spaces
            images because steps 1-2 cost 88 ms each (sec. 5).
        d_it_tolerance: a frame is processed once the travel reaches (1 - tolerance) d_it.
            Default 0.1 (ours): images arrive at discrete places, and without it an image
            spacing just under d_it would process every second image.
    """

    d_it_m: float = 0.375
    d_it_sightings_m: float = 0.0
    d_it_tolerance: float = 0.1

    def __post_init__(self) -> None:
        if min(self.d_it_m, self.d_it_sightings_m) < 0 or not 0 <= self.d_it_tolerance < 1:
            raise ConfigError(
                "ukf spacing: d_it_m >= 0, d_it_sightings_m >= 0 and 0 <= d_it_tolerance < 1"
            )


@dataclass(frozen=True, slots=True)
class FilterConfig:
    """The pose UKF's start, the sightings' noise and the outlier gate of its update.

    Attributes:
        initial_sigma_xy_m: std of the start pose's position (the map's ``initial_pose_w``)
            [m]. Default 0.02.
        initial_sigma_theta_rad: std of the start pose's heading [rad]. Default 0.01.
        sigma_bearing_rad: bearing std of every sighting, in place of the one the sightings
            state [rad]. Default none: theirs (``localiser.VerticalLineUKF._sightings``).
        innovation_gate: chi-square probability (1 dof) above which a validated bearing is
            dropped before the update (ours; none: no gate). Default 1 - 1e-12 (7.1 sigma), a
            gate against gross errors (a misread id) only: real odometry drifts beyond any
            zero-mean model of it over a long stretch without sightings.
    """

    initial_sigma_xy_m: float = 0.02
    initial_sigma_theta_rad: float = 0.01
    sigma_bearing_rad: float | None = None
    innovation_gate: float | None = 1.0 - 1e-12

    def __post_init__(self) -> None:
        if min(self.initial_sigma_xy_m, self.initial_sigma_theta_rad) <= 0:
            raise ConfigError("ukf filter: initial sigmas must be positive")
        if self.sigma_bearing_rad is not None and self.sigma_bearing_rad <= 0:
            raise ConfigError("ukf filter: sigma_bearing_rad must be positive")
        if self.innovation_gate is not None and not 0 < self.innovation_gate < 1:
            raise ConfigError("ukf filter: innovation_gate is a probability in (0, 1)")


@dataclass(frozen=True, slots=True)
class SigmaPointsConfig:
    """The scaled sigma points (van der Merwe 2004; filterpy's ``MerweScaledSigmaPoints``).

    Attributes:
        alpha: spread of the sigma points around the mean. Default 1: with kappa 0 (lambda = 0)
            every weight stays non-negative (the centre point's Wc is 2), and so the covariance
            positive definite.
        beta: prior knowledge of the distribution of the sigma points. Default 2, optimal for a
            Gaussian.
        kappa: secondary scaling of the sigma points. Default 0 (see alpha).
    """

    alpha: float = 1.0
    beta: float = 2.0
    kappa: float = 0.0


@dataclass(frozen=True, slots=True)
class ImageConfig:
    """The 1-D image the pixel thresholds are measured on (``image_line``).

    Attributes:
        pixels_per_rad: image scale of sightings without a camera (MR.CLAM) [px / rad].
            Default 400, corridor21's focal length.
        fov_rad: full field of view of sightings without a camera, before widening [rad].
            Default 2 pi.
        fov_widening: candidates are the landmarks whose ray meets the image plane widened to
            this multiple of its size. Default 2, the paper's (sec. 3.2).
    """

    pixels_per_rad: float = 400.0
    fov_rad: float = 2.0 * math.pi
    fov_widening: float = 2.0

    def __post_init__(self) -> None:
        if self.pixels_per_rad <= 0 or not 0 < self.fov_rad <= 2 * math.pi:
            raise ConfigError("ukf image: pixels_per_rad > 0 and 0 < fov_rad <= 2 pi")
        if self.fov_widening < 1:
            raise ConfigError("ukf image: fov_widening >= 1")


@dataclass(frozen=True, slots=True)
class TrackingConfig:
    """Step 3 of sec. 3.1 (ours: the paper defers it to Barra & Costa 2005): projections of
    this frame matched to the previous processed frame's (``tracking.track_lines``).

    Attributes:
        tolerance_px: a projection may lie this far outside the interval of image positions
            that the previous projection can move to [px]. Default 6.
        min_depth_m, max_depth_m: the depths that interval spans [m]. Defaults 0.3 and 50 (the
            candidates' range).
        max_profile_diff: two projections are the same line only if their PMCs differ by at
            most this mean absolute grey level. Default 40.
    """

    tolerance_px: float = 6.0
    min_depth_m: float = 0.3
    max_depth_m: float = 50.0
    max_profile_diff: float = 40.0

    def __post_init__(self) -> None:
        if not 0 < self.min_depth_m < self.max_depth_m or self.tolerance_px < 0:
            raise ConfigError("ukf tracking: 0 < min_depth_m < max_depth_m, tolerance_px >= 0")


@dataclass(frozen=True, slots=True)
class PhotometricConfig:
    """The photometric gate and score C'_ij of sec. 3.2 (step 4).

    Attributes:
        mode: whether step 4 uses the photometric gate and score: auto, on or off
            (``PhotometricMode``). Default auto: when the map and the sightings both carry
            colour.
        max_diff_band: a pair is rejected when (max_diff_band - diff_band) < 0 [grey levels].
            Default 30, the paper's.
        max_diff_mean: a pair is rejected when (max_diff_mean - diff_mean) < 0 [grey levels].
            Default 100, the paper's.
        weight_band: weight of the band term of C'_ij (the mean term gets 1 - it). Default 0.7,
            the paper's.
    """

    mode: PhotometricMode = PhotometricMode.AUTO
    max_diff_band: float = 30.0
    max_diff_mean: float = 100.0
    weight_band: float = 0.7


@dataclass(frozen=True, slots=True)
class AssociationConfig:
    """Steps 4-5 of sec. 3 (candidates, u_shift windows, F_shift / Sc_k, validation) and the
    gates we add on top of them (``association`` module docstring).

    Attributes:
        max_range_m: candidate landmarks lie within this distance of the pose [m]. Default 50,
            the paper's.
        wall_margin_m: a wall crossing closer than this to the landmark does not occlude it
            [m]. Default 0.05: door-frame lines lie on their wall.
        windows_px: maximum u_shift spreads of the sliding windows [px]. Default 3, 6, 12, 24,
            the paper's.
        shift_weight: the factor of F_shift in Sc_k = mean(C'_ij) + shift_weight * F_shift.
            Default 100, the paper's ("to be controlled by the quality of the MC values").
        variance_floor_px2: floor of F_shift's denominator [px^2]. Default 1 (ours): a set of
            one pair has Var = d_max = 0, and F_shift would be infinite.
        spread_divisor: the 7 of eq. 1, F_shift = sqrt(n) / (Var + |mean| d_max / 7). Default
            7, the paper's.
        min_set_pairs: with ``largest_set_first`` off, sets of fewer pairs compete only when no
            window yields this many. Default 2 (ours): with eq. 1 as printed a one-pair set,
            Var = d_max = 0, beats every larger set.
        use_ids: take the sightings' landmark ids as the association (steps 3-5 skipped): true
            always (sightings without an id unused), false never (steps 3-5 on every frame).
            Default none: in a frame whose every sighting carries an id (a dataset's own ids,
            as MR.CLAM's barcodes, which every other estimator takes too; a dataset hides them
            with its ``association=unknown`` option), steps 3-5 elsewhere.
        validate: step 5: a pair is used only when the previous frame associated the same
            landmark with the same physical line. Default on, the paper's.
        gate_probability: chi-square probability of the two gates step 4 gets from the UKF's
            predicted covariance (ours; none: the paper's step 4 alone). Default 0.999: a pair
            enters step 4 only if its bearing innovation passes the 1-dof pre-gate, and each
            window's set is cut to its largest subset whose innovation vector passes the n-dof
            joint gate, as the pairs share one pose error.
        largest_set_first: the windows' sets are compared by their number of pairs first and
            by Sc_k among sets of equal size (ours; off: by Sc_k alone, the paper's, with
            ``min_set_pairs``). Default on: with the joint gate a common shift that the
            covariance explains is no evidence against a set.
        unambiguous_single: a set of a single pair is used only when no other pair of its
            projection or of its landmark passed the gates (ours; off: the paper's, the
            nearest). Default on: one pair carries no evidence beyond its own gate.
        nearest_line: a pair of the chosen set is kept only when its line is, of all the
            frame's extracted lines (whatever their colour), the nearest to its landmark's
            bearing as the set's other pairs predict it (ours, with ``gate_probability``;
            ``association.PoseConsistency.nearest_lines``). Default on; off: the photometric
            stage may pick any line inside the gates.
    """

    max_range_m: float = 50.0
    wall_margin_m: float = 0.05
    windows_px: tuple[float, ...] = (3.0, 6.0, 12.0, 24.0)
    shift_weight: float = 100.0
    variance_floor_px2: float = 1.0
    spread_divisor: float = 7.0
    min_set_pairs: int = 2
    use_ids: bool | None = None
    validate: bool = True
    gate_probability: float | None = 0.999
    largest_set_first: bool = True
    unambiguous_single: bool = True
    nearest_line: bool = True

    def __post_init__(self) -> None:
        if not self.windows_px or min(self.windows_px) <= 0:
            raise ConfigError("ukf association: windows_px > 0")
        if self.variance_floor_px2 <= 0 or self.max_range_m <= 0:
            raise ConfigError("ukf association: variance_floor_px2 > 0 and max_range_m > 0")
        if self.gate_probability is not None and not 0 < self.gate_probability < 1:
            raise ConfigError("ukf association: gate_probability is a probability in (0, 1)")


@dataclass(frozen=True, slots=True)
class UKFConfig:
    """The vertical-line UKF localiser, section by section.

    Attributes:
        motion_noise: alpha coefficients of the shared odometry model (core.motion), used when
            the odometry states no covariance. Default 4x core's (``UKF_MOTION_NOISE``): a
            localiser that trusts odometry more than it deserves gates out the correct lines
            after a stretch without landmarks.
        spacing: which frames are processed (d_it).
        filter: the start pose's stds, the sightings' bearing std and the outlier gate.
        sigma_points: alpha, beta, kappa of the scaled sigma points.
        image: the 1-D image of sightings without a camera, and its widening for candidates.
        tracking: step 3, the lines of consecutive processed frames matched.
        photometric: the photometric gate and score of step 4.
        association: steps 4-5 and the gates we add.
    """

    MAIN_OPTIONS: ClassVar[tuple[str, ...]] = (
        "spacing.d_it_m",
        "spacing.d_it_sightings_m",
        "motion_noise.a_vv",
        "motion_noise.a_ww",
        "filter.sigma_bearing_rad",
        "filter.innovation_gate",
        "photometric.mode",
        "association.use_ids",
        "association.validate",
        "association.gate_probability",
        "association.nearest_line",
    )
    RENAMED_OPTIONS: ClassVar[dict[str, str]] = {
        "association.track_tolerance_px": "tracking.tolerance_px",
    }

    motion_noise: MotionNoise = field(default_factory=lambda: UKF_MOTION_NOISE)
    spacing: SpacingConfig = field(default_factory=SpacingConfig)
    filter: FilterConfig = field(default_factory=FilterConfig)
    sigma_points: SigmaPointsConfig = field(default_factory=SigmaPointsConfig)
    image: ImageConfig = field(default_factory=ImageConfig)
    tracking: TrackingConfig = field(default_factory=TrackingConfig)
    photometric: PhotometricConfig = field(default_factory=PhotometricConfig)
    association: AssociationConfig = field(default_factory=AssociationConfig)

    def with_(self, **changes: object) -> UKFConfig:
        """A copy with fields (whole sections) replaced."""
        return replace(self, **changes)
