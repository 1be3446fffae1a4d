"""Configuration of the vertical-line UKF localiser (Barra & Costa): one frozen dataclass.

Every number of the paper is a default here, with the section it comes from; the choices the
paper leaves open (its reference Barra & Costa 2005 for step 3 is not available) are marked
"ours" and documented where they are used.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from enum import Enum

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
class PhotometricConfig:
    """The photometric gate of sec. 3.2 and the PMC match of step 3.

    Attributes:
        max_diff_band: reject a pair when (max_diff_band - diff_band) < 0 (paper: 30).
        max_diff_mean: reject a pair when (max_diff_mean - diff_mean) < 0 (paper: 100).
        weight_band: weight of the band term of C'_ij (paper: 0.7; the mean term gets 1 - it).
        max_profile_diff: step 3 (ours): two projections of consecutive frames are the same
            line only if their PMCs differ by at most this mean absolute grey level.
    """

    max_diff_band: float = 30.0
    max_diff_mean: float = 100.0
    weight_band: float = 0.7
    max_profile_diff: float = 40.0


@dataclass(frozen=True, slots=True)
class AssociationConfig:
    """Steps 3-5 of sec. 3 (candidates, u_shift windows, F_shift / Sc_k, validation).

    Attributes:
        max_range_m: candidate landmarks lie within this distance of the pose (paper: 50 m).
        fov_widening: the image plane is widened to this multiple of its size (paper: 2).
        windows_px: maximum u_shift spread of the sliding windows (paper: 3, 6, 12, 24 px).
        shift_weight: the factor of F_shift in Sc_k = mean(C'_ij) + shift_weight * F_shift
            (paper: 100, "to be controlled by the quality of the MC values").
        variance_floor_px2: floor of F_shift's denominator (ours: a set of one pair has
            Var = d_max = 0, and F_shift would be infinite) [px^2].
        spread_divisor: the 7 of eq. 1, F_shift = sqrt(n) / (Var + |mean| d_max / 7).
        min_set_pairs: sets of fewer pairs compete only when no window yields this many (ours:
            with eq. 1 as printed a one-pair set, Var = d_max = 0, beats every larger set).
        wall_margin_m: a wall crossing closer than this to the landmark does not occlude it
            (door-frame lines lie on their wall) [m].
        track_tolerance_px: step 3 (ours): a projection may lie this far outside the interval
            of image positions that the previous projection can move to [px].
        min_depth_m, max_depth_m: step 3 (ours): depths spanned by that interval [m].
        use_ids: take the sightings' landmark ids as the association (steps 3-5 skipped).
            None (default): in a frame whose every sighting carries an id -- a dataset's own
            ids, as MR.CLAM's barcodes, which every other estimator takes too; a dataset hides
            them with its ``association=unknown`` option -- and steps 3-5 elsewhere (extracted
            image lines carry none). True: always (sightings without an id unused); False:
            never, steps 3-5 on every frame.
        validate: step 5, use a pair only when the previous frame associated the same landmark
            with the same physical line (paper: on).
        gate_probability: chi-square probability of the two gates step 4 gets from the UKF's
            predicted covariance (ours; None: the paper's step 4 alone): a pair enters step 4
            only if its bearing innovation passes the 1-dof gate (the pre-gate, before the
            photometric stage), and each window's set is cut to its largest subset whose
            innovation vector passes the n-dof joint gate (the pairs share one pose error).
        largest_set_first: compare the windows' sets by their number of pairs first and by Sc_k
            among sets of equal size (ours; False: by Sc_k alone, the paper's, with the
            ``min_set_pairs`` rule). Eq. 1's |mean(u_shift)| d_max / 7 term makes a large
            correct set with the common shift of a heading error lose to a two-pair set of
            small shift; with the joint gate a common shift that the covariance explains is
            no evidence against a set.
        unambiguous_single: a set of a single pair is used only when no other pair of its
            projection or of its landmark passed the gates (ours; False: the paper's, the
            nearest). One pair carries no evidence beyond its own gate: with one sighting
            among identical landmarks (MR.CLAM without ids) the nearest predicted bearing was
            the wrong landmark whenever the pose had drifted (median ATE 0.64-2.55 m over
            robots 1-5; with the rule 0.31-1.73 m; both at innovation_gate 0.999). It
            changes nothing on corridor21.
        nearest_line: a pair of the chosen set is kept only when its line is, of all the
            frame's extracted lines (whatever their colour), the one nearest to its landmark's
            bearing as the set's other pairs predict it (ours; with ``gate_probability``;
            False: the photometric stage may pick any line inside the gates). See
            ``association.PoseConsistency.nearest_lines`` and the module docstring.
    """

    max_range_m: float = 50.0
    fov_widening: float = 2.0
    windows_px: tuple[float, ...] = (3.0, 6.0, 12.0, 24.0)
    shift_weight: float = 100.0
    variance_floor_px2: float = 1.0
    spread_divisor: float = 7.0
    min_set_pairs: int = 2
    wall_margin_m: float = 0.05
    track_tolerance_px: float = 6.0
    min_depth_m: float = 0.3
    max_depth_m: float = 50.0
    use_ids: bool | None = None
    validate: bool = True
    gate_probability: float | None = 0.999
    largest_set_first: bool = True
    unambiguous_single: bool = True
    nearest_line: bool = True


@dataclass(frozen=True, slots=True)
class UKFConfig:
    """The vertical-line UKF localiser.

    Attributes:
        d_it_m: travel between processed frames (paper sec. 5: 0.375 m); between them the filter
            only predicts.
        d_it_sightings_m: travel between processed frames whose sightings come from a
            range-bearing sensor rather than images (ours; default 0, every such frame). The
            paper spaces *images* by d_it because steps 1-2 cost 88 ms per image on its robot
            (sec. 5); a sensor that gives its bearings costs nothing to process, and a
            frame of MR.CLAM holds one or two sightings, so the paper's d_it kept 124 of 1534
            of robot 1's sightings and left the pose to the commanded odometry between them
            (median ATE with ids 0.15-0.29 m over robots 1-5, every sighting 0.07-0.13 m;
            ``benchmarks/ukf_mrclam.py``, docs/results/ukf.md). ``d_it_m`` stays the paper's for
            images.
        d_it_tolerance: a frame is processed once the travel reaches (1 - tolerance) d_it (ours:
            images arrive at discrete places; without it an image spacing just under d_it
            would process every second image).
        motion_noise: alpha coefficients of the shared odometry model (core.motion), used when
            the odometry states no covariance. Ours: 4x core's defaults (``UKF_MOTION_NOISE``),
            because a localiser that trusts odometry more than it deserves gates out the
            correct lines after a stretch without landmarks. Real odometry drifts
            systematically (wheel scale, turn scale, curvature: the synthetic presets' 1-3 %
            per 10 m), which the zero-mean alpha model does not describe: with core's alphas
            the UKF's pose NEES on corridor21 (seed 0) was 5.9 at the preset's odometry and 2742
            at 4x its alpha noise, mean error 2.7 and 26.3 cm; with these 0.21 and 1.20
            (conservative), 1.1 and 2.0 cm (``benchmarks/ukf_corridor21.py --ablation``).
        initial_sigma_xy_m, initial_sigma_theta_rad: std of the start pose (the map's
            ``initial_pose_w``).
        sigma_bearing_rad: bearing std of every sighting, in place of the one the sightings
            state [rad]; None: theirs (``localiser.VerticalLineUKF._sightings``).
        pixels_per_rad: image scale of sightings without a camera (MR.CLAM) [px / rad]; the
            default is corridor21's focal length.
        fov_rad: full field of view of sightings without a camera (before widening) [rad].
        alpha, beta, kappa: the scaled sigma points (van der Merwe 2004; filterpy's
            MerweScaledSigmaPoints). alpha = 1, kappa = 0 (lambda = 0) keeps every weight
            non-negative (the centre point's Wc is 2): with alpha = 0.5 its Wc of -0.25 made
            the covariance indefinite on MR.CLAM robot 4 after a 2 m error.
        innovation_gate: chi-square probability above which a validated bearing is dropped
            before the update (ours; None: no gate). The default, 1 - 1e-12 (7.1 sigma), is a
            gate against gross errors only. Step 4's pre-gate (0.999, unscented) already holds
            the associated pairs to a tighter test at the same predicted pose, so without ids
            this (linearised) gate rarely drops a pair; with ``association.use_ids`` it is
            the outlier gate of the sightings' ids: on MR.CLAM robot 3 one sighting 3.0 rad
            from its landmark's predicted bearing (a misread barcode) threw the pose 5 m
            (median ATE 0.71 m; 0.07 m with the gate). It is loose because real odometry is
            worse than any zero-mean model of it after a long stretch without sightings
            (MR.CLAM robot 4: 78 s): at 0.999 the
            correct sightings that end such a stretch were gated out too (robots 1-5: 0.124 /
            0.094 / 0.069 / 0.225 / 0.127 m; at 1 - 1e-12 0.112 / 0.093 / 0.068 / 0.126 /
            0.098 m; ``benchmarks/ukf_mrclam.py``).
        photometric: whether step 4 uses the photometric gate and score C'_ij: auto (when
            the map and the sightings both carry colour), on or off (PhotometricMode).
        association, colour: see their classes.
    """

    d_it_m: float = 0.375
    d_it_sightings_m: float = 0.0
    d_it_tolerance: float = 0.1
    motion_noise: MotionNoise = field(default_factory=lambda: UKF_MOTION_NOISE)
    initial_sigma_xy_m: float = 0.02
    initial_sigma_theta_rad: float = 0.01
    sigma_bearing_rad: float | None = None
    pixels_per_rad: float = 400.0
    fov_rad: float = 2.0 * math.pi
    alpha: float = 1.0
    beta: float = 2.0
    kappa: float = 0.0
    innovation_gate: float | None = 1.0 - 1e-12
    photometric: PhotometricMode = PhotometricMode.AUTO
    association: AssociationConfig = field(default_factory=AssociationConfig)
    colour: PhotometricConfig = field(default_factory=PhotometricConfig)

    def __post_init__(self) -> None:
        if min(self.d_it_m, self.d_it_sightings_m) < 0 or not 0 <= self.d_it_tolerance < 1:
            raise ConfigError(
                "UKFConfig: d_it_m >= 0, d_it_sightings_m >= 0 and 0 <= d_it_tolerance < 1"
            )
        if min(self.initial_sigma_xy_m, self.initial_sigma_theta_rad) <= 0:
            raise ConfigError("UKFConfig: initial sigmas must be positive")
        if self.sigma_bearing_rad is not None and self.sigma_bearing_rad <= 0:
            raise ConfigError("UKFConfig: sigma_bearing_rad must be positive")
        if self.pixels_per_rad <= 0 or not 0 < self.fov_rad <= 2 * math.pi:
            raise ConfigError("UKFConfig: pixels_per_rad > 0 and 0 < fov_rad <= 2 pi")
        if self.innovation_gate is not None and not 0 < self.innovation_gate < 1:
            raise ConfigError("UKFConfig: innovation_gate is a probability in (0, 1)")
        a = self.association
        if not a.windows_px or min(a.windows_px) <= 0 or a.fov_widening < 1:
            raise ConfigError("UKFConfig: windows_px > 0 and fov_widening >= 1")
        if a.variance_floor_px2 <= 0 or a.max_range_m <= 0:
            raise ConfigError("UKFConfig: variance_floor_px2 > 0 and max_range_m > 0")
        if a.gate_probability is not None and not 0 < a.gate_probability < 1:
            raise ConfigError("UKFConfig: association.gate_probability is a probability in (0, 1)")

    def with_(self, **changes: object) -> UKFConfig:
        """A copy with fields replaced."""
        return replace(self, **changes)
