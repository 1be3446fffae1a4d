"""Configuration of the shared front end: one frozen dataclass per component, named presets.

Every component of :mod:`omnislam.frontend` takes its own config record; ``FrontendConfig``
bundles them. YAML overrides are merged at the edge (``frontend_config_from_dict``) and the
whole configuration is hashed (``config_hash``) so that a cached ObservationLog built with
another configuration is never reused.
"""

from __future__ import annotations

import dataclasses
import enum
import hashlib
import json
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from omnislam.errors import ConfigError


class SiftBackend(enum.Enum):
    """Which SIFT implementation extracts the features."""

    OPENCV = "opencv"  # cv2.SIFT (fast; the default)
    PYCOLMAP = "pycolmap"  # COLMAP's SIFT through pycolmap.FeatureExtractor (~5x slower)


class FirstOctave(enum.Enum):
    """How SIFT samples its finest scales, sigma / 2 .. sigma (thesis 4.1.1; Lowe 2004 sec. 3.3).

    Lowe doubles the image so that the first octave (-1) samples them at half pixels; the
    thesis keeps the doubling optional. ``NATIVE`` samples them at the image's own pixels, at
    a third of the cost (``omnislam.frontend.scale_space``); ``NONE`` leaves them out (VLFeat's
    and COLMAP's ``first_octave = 0``). ``HALVED`` samples octave -1 as ``NATIVE`` does and
    every next octave at half the previous one's pixels (octave 0 at every second pixel: the
    pyramid of a SIFT of sigma / 2, which OpenCV's descriptor already uses for ``NATIVE``):
    cheaper, but not the default because it loses verified sightings and the graph's accuracy
    (docs/results/frontend.md, "What was tried and did not work").
    """

    DOUBLED = "doubled"  # Lowe 2004, OpenCV's detector
    NATIVE = "native"  # octave -1 at the image's resolution, octave 0 too
    HALVED = "halved"  # octave -1 at the image's resolution, each next one at half the pixels
    NONE = "none"  # no octave -1


class ScheduleMode(enum.Enum):
    """Which images the asynchronous front end processes (thesis 4.5; Barra & Costa 3)."""

    EVERY_K = "every-k"  # every k-th image
    EVERY_D = "every-d"  # the first image after the odometry has travelled d metres


@dataclass(frozen=True, slots=True)
class SiftConfig:
    """SIFT detector/descriptor settings (Lowe 2004; thesis 4.1).

    Attributes:
        contrast_threshold: Lowe's contrast threshold C on |D(x)| (thesis eq. 4.9) for images
            scaled to [0, 1], *per scale level*: Lowe's 0.03. (OpenCV expects it multiplied
            by the number of layers; the backend converts.)
        edge_threshold: maximum ratio R of principal curvatures (thesis eq. 4.15). Lowe: 10;
            the thesis keeps the same rejection rate on omni images with R ~ 2.
        n_octave_layers: scales per octave N (k = 2^(1/N), thesis 4.1.1).
        sigma: Lowe's sigma: blur of octave 0's base image [px] (octave -1 starts at half).
        max_features: keep at most this many strongest features, strongest first (0 = all).
        features_per_kpx: keep at most this many strongest features per 1000 pixels of the
            detection region (the mask's, else the whole image's; 0 = no such budget), so that
            one budget suits images of any size.
        budget_bands, budget_sectors: the budget is shared out over this many rings (equal
            areas, about the region's centroid: bands of elevation on an omni image) times
            angular sectors (azimuth), each keeping its share of the strongest, the share the
            sparse ones leave going to the strongest of the rest (``scale_space.budget_buckets``);
            1 x 1 = the strongest of the whole region.
        first_octave: how octave -1 (the scales sigma / 2 .. sigma) is sampled (and, with
            ``HALVED``, octave 0 at every second pixel).
        precise_upscale: with ``first_octave`` DOUBLED, OpenCV doubles the image by mapping
            pixel x to 2x exactly (``enable_precise_upscale``) instead of its default resize,
            which shifts keypoints (docs/results/frontend.md, what was tried).
        backend: OpenCV or pycolmap (pycolmap: DOUBLED or NONE only).
    """

    contrast_threshold: float = 0.03
    edge_threshold: float = 10.0
    n_octave_layers: int = 3
    sigma: float = 1.6
    max_features: int = 0
    features_per_kpx: float = 0.0
    budget_bands: int = 4
    budget_sectors: int = 8
    first_octave: FirstOctave = FirstOctave.DOUBLED
    precise_upscale: bool = True
    backend: SiftBackend = SiftBackend.OPENCV

    def __post_init__(self) -> None:
        if self.contrast_threshold < 0 or self.edge_threshold <= 1.0:
            raise ConfigError("SiftConfig: contrast_threshold >= 0 and edge_threshold > 1")
        if (self.n_octave_layers < 1 or self.sigma <= 0 or self.max_features < 0
                or not self.features_per_kpx >= 0 or self.budget_bands < 1
                or self.budget_sectors < 1):
            raise ConfigError("SiftConfig: n_octave_layers >= 1, sigma > 0, max_features >= 0, "
                              "features_per_kpx >= 0, budget_bands and budget_sectors >= 1")
        if self.backend is SiftBackend.PYCOLMAP and self.first_octave in (FirstOctave.NATIVE,
                                                                  FirstOctave.HALVED):
            raise ConfigError("SiftConfig: the pycolmap backend has no native first octave "
                              "(first_octave: doubled or none)")


#: Lowe (2004): C = 0.03, R = 10.
LOWE = SiftConfig()
#: Thesis 4.1.2: on omnidirectional images keep Lowe's rejection rate with R ~ 2. The contrast
#: threshold is lowered to 0.02 so that the ring (a third of the pixels of a perspective image
#: of the same size, blurred by the mirror) still yields several hundred features. The finest
#: octave is sampled at the image's pixels (the thesis leaves doubling optional, 4.1.1). A
#: keypoint budget of 1.2 per 1000 px of the ring (chosen before their orientations and
#: descriptors are computed) drops the weakest keypoints, which make the wrong tracks; it is
#: shared out over 4 rings x 8 sectors, not the strongest of the whole ring, because the graph
#: takes the odometry's scale from floor points, which are low-contrast (docs/results/frontend.md,
#: "The keypoint budget").
OMNI_THESIS = SiftConfig(contrast_threshold=0.02, edge_threshold=2.0,
                         first_octave=FirstOctave.NATIVE, features_per_kpx=1.2)
SIFT_PRESETS: dict[str, SiftConfig] = {"lowe": LOWE, "omni-thesis": OMNI_THESIS}


@dataclass(frozen=True, slots=True)
class GroupConfig:
    """Feature groups, the thesis's "objects" (4.1.3, after Jung 2004).

    Two keypoints are linked when they are close in the image **and** of similar contrast;
    a group is a connected component of links.

    Attributes:
        distance_px: link keypoints closer than ``max(distance_px, scale_factor * size)`` [px]
            (thesis Fig. 4.5 uses 3 px on a 2-megapixel image).
        scale_factor: multiple of the larger keypoint diameter that also links keypoints.
        contrast_ratio: link only if max(c_i, c_j) / min(c_i, c_j) <= this (c = |D(x)|).
        min_size: groups with fewer members are discarded (their features are not used).
    """

    distance_px: float = 12.0
    scale_factor: float = 1.5
    contrast_ratio: float = 3.0
    min_size: int = 3

    def __post_init__(self) -> None:
        if self.distance_px < 0 or self.scale_factor < 0 or self.contrast_ratio < 1:
            raise ConfigError("GroupConfig: distances >= 0 and contrast_ratio >= 1")
        if self.min_size < 1:
            raise ConfigError("GroupConfig.min_size must be >= 1")


@dataclass(frozen=True, slots=True)
class MatchConfig:
    """Descriptor matching (thesis 4.2).

    Attributes:
        ratio: Lowe's ratio test: accept when d1 < ratio * d2.
        flann_trees: randomised kd-trees of the FLANN index over the map (the BBF search).
        flann_checks: leaves visited per query (more = closer to exact).
        min_object_matches: object-level validation: a group's matches are accepted only if
            at least this many of its features match (Lowe: 3 features recognise an object).
        min_object_fraction: ... and at least this fraction of the object's live features
            (thesis 4.2). 0 by default: objects grow by absorbing features over time and a
            viewpoint sees only part of one, so the count alone (Lowe's rule) is used.
    """

    ratio: float = 0.8
    flann_trees: int = 4
    flann_checks: int = 64
    min_object_matches: int = 3
    min_object_fraction: float = 0.0

    def __post_init__(self) -> None:
        if not 0 < self.ratio <= 1:
            raise ConfigError("MatchConfig.ratio must be in (0, 1]")
        if self.flann_trees < 1 or self.flann_checks < 1 or self.min_object_matches < 1:
            raise ConfigError("MatchConfig: flann_trees, flann_checks, min_object_matches >= 1")
        if not 0 <= self.min_object_fraction <= 1:
            raise ConfigError("MatchConfig.min_object_fraction must be in [0, 1]")


@dataclass(frozen=True, slots=True)
class VerificationConfig:
    """RANSAC on bearing vectors (essential matrix of a central camera).

    Attributes:
        threshold_rad: inlier threshold on the angular epipolar error [rad].
        confidence: stop when the probability of having drawn an all-inlier sample reaches it.
        max_iterations: RANSAC iteration cap.
        min_inliers: fewer verified inliers than this reject the whole frame pair.
        min_baseline_m: below this odometry baseline the epipolar geometry is degenerate and
            the pure-rotation model ``f1 = R f2`` is verified instead.
        prior_rotation_tol_rad: a model whose rotation differs from the odometry prior's by
            more than this is rejected (the prior seeds and guards the search).
        planar_motion: the viewpoints move on a horizontal plane and turn about the vertical
            (a camera on a wheeled robot), so hypotheses come from 3 matches instead of 8
            (``verification.planar_essential_from_bearings``); False for a hand-held camera.
        enabled: False skips verification (every ratio-test match is accepted).
        below_floor_check: frame-to-frame inliers are refused when their two bearings could
            only meet below the floor (``verification.beyond_the_floor``): the epipolar
            constraint cannot see a floor texture that repeats along the direction of travel
            (a tile matched one period on moves within its epipolar plane), the floor's height
            can; on tiled floors most wrong pairs are such mismatches (docs/results/frontend.md,
            "The below-floor check").
    """

    threshold_rad: float = 0.004
    confidence: float = 0.999
    max_iterations: int = 300
    min_inliers: int = 10
    min_baseline_m: float = 0.02
    prior_rotation_tol_rad: float = 0.35
    planar_motion: bool = True
    enabled: bool = True
    below_floor_check: bool = True

    def __post_init__(self) -> None:
        if self.threshold_rad <= 0 or not 0 < self.confidence < 1:
            raise ConfigError("VerificationConfig: threshold_rad > 0 and confidence in (0, 1)")
        if self.max_iterations < 1 or self.min_inliers < 8:
            raise ConfigError("VerificationConfig: max_iterations >= 1 and min_inliers >= 8")


@dataclass(frozen=True, slots=True)
class TrackConfig:
    """Landmark tracks: stable ids, re-recognition against the map, pruning (thesis 4.2).

    Attributes:
        window_images: features are first matched against the tracks seen in the last this
            many processed images (1 = the previous image only; more bridges short gaps).
        relocalise: match the features not tracked from the previous image against the
            descriptors of every landmark of the map (this is what closes loops).
        young_images: tracks started within this many images are still matched against the
            map, and merged into the old landmark they turn out to be.
        relocalise_threshold_scale: re-recognised matches are verified with the inlier
            threshold times this (wider viewpoint changes move keypoints by more pixels).
        map_min_sightings: only tracks seen at least this often enter the map index.
        map_rebuild_every: rebuild the FLANN index of the map every this many processed images.
        max_reference_images: candidate matches are verified against at most this many
            earlier images (those that saw most of the candidate landmarks).
        prune_after_failures: a feature of a recognised object that failed to match this many
            times in a row is removed from the map (thesis 4.2).
        min_track_length: tracks with fewer sightings are dropped from the log at the end;
            3 because a bearing-only landmark needs 3 sightings to be initialised (docs/design.md,
            "Landmark insertion").
        sigma_px: keypoint localisation std at size 0 [px] ...
        sigma_px_per_size: ... plus this times the keypoint's SIFT diameter (2 sigma): the
            pixel noise turned into each bearing's angular sigma through the camera model's
            Jacobian (``bearing_noise``). Fitted to the RMS residuals of the tracks of the
            ``lab40`` and ``demo`` renders against their true points
            (``benchmarks/bearing_noise.py``); a real camera adds its calibration's residual.
    """

    window_images: int = 3
    relocalise: bool = True
    young_images: int = 10
    relocalise_threshold_scale: float = 1.0
    map_min_sightings: int = 2
    map_rebuild_every: int = 5
    max_reference_images: int = 8
    prune_after_failures: int = 5
    min_track_length: int = 3
    sigma_px: float = 0.09
    sigma_px_per_size: float = 0.027

    def __post_init__(self) -> None:
        if self.map_min_sightings < 1 or self.map_rebuild_every < 1:
            raise ConfigError("TrackConfig: map_min_sightings and map_rebuild_every >= 1")
        if self.max_reference_images < 1 or self.prune_after_failures < 1:
            raise ConfigError("TrackConfig: max_reference_images, prune_after_failures >= 1")
        if self.window_images < 1:
            raise ConfigError("TrackConfig.window_images must be >= 1")
        if self.min_track_length < 1 or self.sigma_px <= 0 or self.sigma_px_per_size < 0:
            raise ConfigError("TrackConfig: min_track_length >= 1, sigma_px > 0 and "
                              "sigma_px_per_size >= 0")


@dataclass(frozen=True, slots=True)
class ScheduleConfig:
    """Asynchronous processing (thesis 4.5): odometry flows every frame, images when scheduled.

    Attributes:
        mode: every k-th image or every d metres of odometry.
        every_k: process every k-th image (mode EVERY_K).
        every_m: process the first image after this odometry distance (mode EVERY_D);
            Barra & Costa use 0.375 m.
    """

    mode: ScheduleMode = ScheduleMode.EVERY_K
    every_k: int = 1
    every_m: float = 0.375

    def __post_init__(self) -> None:
        if self.every_k < 1 or self.every_m < 0:
            raise ConfigError("ScheduleConfig: every_k >= 1 and every_m >= 0")


@dataclass(frozen=True, slots=True)
class VerticalEdgeConfig:
    """Vertical-line extraction (Barra & Costa sec. 2).

    Attributes:
        enabled: extract vertical lines on processed images (on by default: the UKF consumes
            them, and they cost a fraction of SIFT; docs/results/real-time.md).
        azimuth_bins: angular resolution of the omni radial-edge histogram (bins over 360 deg).
        min_gradient: minimum gradient magnitude of an edge pixel (0-255 grey levels per px).
        max_direction_error_rad: an edge pixel's gradient must be within this of tangential
            (omni) or horizontal (perspective).
        min_support: a line needs at least this fraction of the radial (or vertical) extent.
        profile_half_width: n of the PMC profile (W = 2n + 1 samples across the line).
        profile_step_rad: angular spacing of PMC samples (omni) [rad]; perspective: 1 px.
        sigma_bearing_rad: bearing std reported with each line [rad].
    """

    enabled: bool = True
    azimuth_bins: int = 720
    min_gradient: float = 20.0
    max_direction_error_rad: float = 0.3
    min_support: float = 0.3
    profile_half_width: int = 5
    profile_step_rad: float = 0.004
    sigma_bearing_rad: float = 0.005

    def __post_init__(self) -> None:
        if self.azimuth_bins < 36 or self.profile_half_width < 1 or self.min_support <= 0:
            raise ConfigError("VerticalEdgeConfig: azimuth_bins >= 36, profile_half_width >= 1")


class LineLandmarks(enum.Enum):
    """Which points a laser scan's RANSAC lines become (``frontend.laser_landmarks``)."""

    CORNERS = "corners"
    FEET = "feet"


@dataclass(frozen=True, slots=True)
class LaserLandmarkConfig:
    """Laser landmarks (SLAM for Dummies, "landmark extraction").

    Attributes:
        enabled: extract landmarks when the sequence has scans.
        merge_with_sightings: also extract them when the sequence brings range-bearing
            sightings of its own (the synthetic presets' pole sightings, with true ids), and
            merge the two. Off by default: the loader's sightings are the experiment (the
            thesis's route-1/2 pole sightings), and id-less wall corners and door spikes beside
            them change it; a laser-only log (CARMEN, a preset without poles) always gets them.
        spike_jump_m: a beam whose range is this much shorter than both neighbours' is a spike.
        spike_max_beams: runs of up to this many beams standing out count as one spike.
        max_valid_range_m: ranges beyond are invalid (SICK: 8.1 m); None = sensor maximum.
        ransac_trials: N, attempts to find lines.
        ransac_samples: S, points sampled around a random beam.
        ransac_window_rad: D, the sample window [rad].
        ransac_max_distance_m: X, a point within this distance of a line supports it.
        ransac_consensus: C, minimum support of a line.
        sigma_range_fraction: range std as a fraction of the range (1 %).
        sigma_bearing_rad: bearing std (1 deg).
        sigma_floor_m: a position std every laser landmark has whatever its range [m], added
            in quadrature to the range std and, divided by the range, to the bearing std: a
            spike is the nearest beam of an object a few cm wide (which beam depends on the
            viewpoint), a corner the intersection of two fitted lines, and the beams are 1 deg
            apart. Default 0.03: consecutive CARMEN sightings of one landmark lie a few cm
            apart at every range, which the range-proportional model alone states as 1-2 cm
            near the robot (docs/results/frontend.md, "A noise floor for the laser landmarks").
            0: the tutorial's range-proportional noise only.
        line_landmarks: ``corners`` (default: intersections of two lines that both reach
            them, points fixed in the world) or ``feet`` (the tutorial's feet of the
            perpendicular from the odometry origin, which slide along the walls as the odometry
            drifts); see ``laser_landmarks`` and docs/results/frontend.md for both on CARMEN.
        corner_min_angle_deg: two lines closer than this to parallel make no corner.
        corner_max_gap_m: a corner needs a supporting reading of each line within this.
        persistence_radius_m: keep only the sightings the previous scan saw within this
            distance (placed through the estimators' odometry;
            ``laser_landmarks.persistent_sightings``); None: every sighting. Default 0.2: a
            spike seen in one scan only is clutter, not a landmark (docs/results/frontend.md,
            "The laser front end").
        persistence_scans: how many previous scans must all have seen a sighting within
            ``persistence_radius_m`` for it to be kept. Default 1 (the previous scan): 3 leaves
            CARMEN csail's filters near its laser odometry but costs intel (EKF-SLAM 0.26 ->
            0.82 m; docs/results/frontend.md, "A CARMEN log the laser path was not tuned on").
        min_separation_m: a sighting with another of the same scan (spike or corner) within
            this distance is dropped, and so is the other: objects closer together than an
            association can tell apart (a chair's legs, a railing) pair with each other's
            landmarks. Default None (every sighting): 0.5 with two persistence scans brings
            EKF-SLAM and both FastSLAMs under dead reckoning on CARMEN csail but costs EKF-SLAM
            on intel and aces (docs/results/frontend.md, "A CARMEN log the laser path was not
            tuned on").
    """

    enabled: bool = True
    merge_with_sightings: bool = False
    spike_jump_m: float = 0.5
    spike_max_beams: int = 6
    max_valid_range_m: float | None = 8.1
    ransac_trials: int = 100
    ransac_samples: int = 6
    ransac_window_rad: float = 0.17
    ransac_max_distance_m: float = 0.05
    ransac_consensus: int = 30
    sigma_range_fraction: float = 0.01
    sigma_bearing_rad: float = 0.0175
    sigma_floor_m: float = 0.03
    line_landmarks: LineLandmarks = LineLandmarks.CORNERS
    corner_min_angle_deg: float = 45.0
    corner_max_gap_m: float = 0.3
    persistence_radius_m: float | None = 0.2
    persistence_scans: int = 1
    min_separation_m: float | None = None

    def __post_init__(self) -> None:
        if self.ransac_samples < 2 or self.ransac_consensus < self.ransac_samples:
            raise ConfigError("LaserLandmarkConfig: samples >= 2 and consensus >= samples")
        if self.persistence_scans < 1:
            raise ConfigError(
                f"LaserLandmarkConfig: persistence_scans must be >= 1, got {self.persistence_scans}"
            )
        if self.min_separation_m is not None and not self.min_separation_m > 0:
            raise ConfigError(
                "LaserLandmarkConfig: min_separation_m must be > 0 or unset, "
                f"got {self.min_separation_m}"
            )
        if self.sigma_floor_m < 0:
            raise ConfigError(
                f"LaserLandmarkConfig: sigma_floor_m must be >= 0, got {self.sigma_floor_m}"
            )
        if not 0 < self.corner_min_angle_deg <= 90 or self.corner_max_gap_m <= 0:
            raise ConfigError(
                "LaserLandmarkConfig: corner_min_angle_deg in (0, 90] and corner_max_gap_m > 0"
            )


@dataclass(frozen=True, slots=True)
class LaserOdometryConfig:
    """Laser odometry: each scan registered to its predecessor by ICP
    (``omnislam.frontend.scan_matching``), handed to every estimator as its odometry.

    Attributes:
        enabled: register the scans when the sequence has them (the log's odometry is then the
            laser odometry, with the wheel odometry where a match is rejected).
        with_images: also on sequences with images (the synthetic renders, which all carry a
            laser). Off by default: there the omni experiments are the thesis's, on wheel
            odometry, and laser odometry under them would change what they measure; a
            laser-only sequence (CARMEN) always gets it.
        max_valid_range_m: ranges beyond are not used (None: below the sensor's maximum).
        min_range_m: ranges at or below are not used.
        submap_scans: register to the union of this many previous scans (1: the previous scan),
            placed with the laser odometry (default 3: a single scan holds too few constraints;
            docs/results/frontend.md, "The laser front end").
        submap_radius_m: keep the submap's points within this distance of the previous scan
            (None: all).
        submap_voxel_m: thin the submap to one point per cell of this size (0: not thinned).
        correspondence_distances_m: ICP's maximum correspondence distance, one ICP per value
            (coarse to fine, each starting from the previous result).
        max_iterations: ICP iterations per value.
        normal_neighbours: neighbours of the 2-D PCA normals of the target.
        min_points: fewer valid points in a scan (or correspondences) rejects the match.
        min_fitness: smallest share of the new scan's points with a correspondence (0.4: a
            turn of ~80 deg in one step leaves half of a 180-deg scan overlapping).
        max_rmse_m: largest inlier RMSE.
        min_translation_information: smallest eigenvalue of the translational block of the
            point-to-line Hessian per correspondence (0.5 for two perpendicular walls equally
            seen, 0 in a corridor): below, the match is degenerate and the odometry's
            translation is kept along the unconstrained direction, with std
        degenerate_sigma_m: + ``degenerate_sigma_fraction`` x the distance travelled.
        gate_translation_m: largest disagreement with the wheel odometry's translation, plus
        gate_translation_fraction: this fraction of the distance travelled.
        gate_rotation_rad: largest disagreement with the wheel odometry's rotation.
        sigma_floor_m: smallest residual std used for the covariance.
        covariance_inflation: the Gauss-Newton covariance multiplied by this, plus independent
        min_sigma: (x, y, theta) stds [m, m, rad] +
        sigma_per_m: these per metre travelled +
        sigma_per_rad: these per radian turned. Together they calibrate the stated covariance
            against the corrected CARMEN poses, which the plain Hessian states far too narrow
            (docs/results/frontend.md, "The laser front end").
    """

    enabled: bool = True
    with_images: bool = False
    max_valid_range_m: float | None = None
    min_range_m: float = 0.05
    submap_scans: int = 3
    submap_radius_m: float | None = None
    submap_voxel_m: float = 0.0
    correspondence_distances_m: tuple[float, ...] = (0.5, 0.2)
    max_iterations: int = 30
    normal_neighbours: int = 6
    min_points: int = 30
    min_fitness: float = 0.4
    max_rmse_m: float = 0.1
    min_translation_information: float = 0.05
    degenerate_sigma_m: float = 0.05
    degenerate_sigma_fraction: float = 0.1
    gate_translation_m: float = 0.3
    gate_translation_fraction: float = 0.3
    gate_rotation_rad: float = 0.35
    sigma_floor_m: float = 0.003
    covariance_inflation: float = 12.0
    min_sigma: tuple[float, float, float] = (0.002, 0.002, 0.0005)
    sigma_per_m: tuple[float, float, float] = (0.02, 0.02, 0.005)
    sigma_per_rad: tuple[float, float, float] = (0.02, 0.02, 0.01)

    def __post_init__(self) -> None:
        for name in ("correspondence_distances_m", "min_sigma", "sigma_per_m", "sigma_per_rad"):
            object.__setattr__(self, name, tuple(float(v) for v in getattr(self, name)))
        if any(len(getattr(self, n)) != 3 for n in ("min_sigma", "sigma_per_m", "sigma_per_rad")):
            raise ConfigError(
                "LaserOdometryConfig: min_sigma, sigma_per_m, sigma_per_rad need three stds"
            )
        if self.submap_scans < 1 or not self.correspondence_distances_m:
            raise ConfigError(
                "LaserOdometryConfig: submap_scans >= 1 and at least one correspondence distance"
            )


@dataclass(frozen=True, slots=True)
class FloorTrackConfig:
    """Floor tracks: keypoints on the floor matched by where the odometry moves them
    (``frontend.floor_tracks``).

    A keypoint seen at least ``min_depression_deg`` below the horizon is taken to lie on the
    floor plane, ``h`` below the camera's viewpoint (the rig's ``viewpoint_r``), which places
    it in the world of the dead-reckoned pose. A floor track is continued by the keypoint whose
    floor point lies within ``gate_m`` of the track's and whose descriptor is within
    ``max_descriptor_distance``: the feature groups drop the floor's isolated corners, and its
    repeated texture (tiles) leaves the ratio test no distinct match, while the floor plane and
    the odometry tell the tiles apart (they are tens of cm apart; the odometry errs by mm
    between images).
    Keypoints fixed to the robot (its body in the mirror) move with the robot and start a new
    track in every image, which ``tracks.min_track_length`` drops. On by default: the floor
    tracks are a stream of their own (``ObservationLog.floor_ids_from``), fed only to the
    estimators that model the floor (the graphs, which place them on the floor plane and take
    the map's metric scale from them; docs/results/graph.md, "The odometry's scale from the
    floor").

    Attributes:
        enabled: track floor keypoints (on top of the landmark tracks).
        min_depression_deg: keypoints at least this far below the horizon are floor
            candidates (as ``graphslam.floor_scale``) [deg].
        gate_m: a candidate continues a track only within this distance of the track's floor
            point, both placed with the dead-reckoned poses [m].
        max_descriptor_distance: ... and within this L2 distance of its last descriptor
            (SIFT descriptors of norm 512).
        window_images: a track is looked for in this many images after its last sighting.
    """

    enabled: bool = True
    min_depression_deg: float = 35.0
    gate_m: float = 0.04
    max_descriptor_distance: float = 300.0
    window_images: int = 3

    def __post_init__(self) -> None:
        if not 0 < self.min_depression_deg < 90:
            raise ConfigError("FloorTrackConfig: min_depression_deg must be in (0, 90)")
        if not self.gate_m > 0 or not self.max_descriptor_distance > 0:
            raise ConfigError("FloorTrackConfig: gate_m and max_descriptor_distance must be > 0")
        if self.window_images < 1:
            raise ConfigError("FloorTrackConfig: window_images must be >= 1")


@dataclass(frozen=True, slots=True)
class FrontendConfig:
    """Everything the front end does, in one hashable record (see ``config_hash``)."""

    sift: SiftConfig = OMNI_THESIS
    groups: GroupConfig = field(default_factory=GroupConfig)
    matching: MatchConfig = field(default_factory=MatchConfig)
    verification: VerificationConfig = field(default_factory=VerificationConfig)
    tracks: TrackConfig = field(default_factory=TrackConfig)
    schedule: ScheduleConfig = field(default_factory=ScheduleConfig)
    vertical_edges: VerticalEdgeConfig = field(default_factory=VerticalEdgeConfig)
    laser: LaserLandmarkConfig = field(default_factory=LaserLandmarkConfig)
    laser_odometry: LaserOdometryConfig = field(default_factory=LaserOdometryConfig)
    floor: FloorTrackConfig = field(default_factory=FloorTrackConfig)


def config_to_dict(config: object) -> dict[str, Any]:
    """Plain-Python form of a (nested) config dataclass; enums become their values."""

    def plain(value: object) -> object:
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            return {f.name: plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
        if isinstance(value, enum.Enum):
            return value.value
        return value

    out = plain(config)
    assert isinstance(out, dict)
    return out


def config_hash(config: FrontendConfig) -> str:
    """16 hex digits of SHA-256 over the canonical JSON of the configuration."""
    text = json.dumps(config_to_dict(config), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


#: the Python types a YAML value may have for a field of each scalar type
_SCALARS: dict[type, tuple[type, ...]] = {bool: (bool,), int: (int,), float: (int, float)}


def _is_a(value: object, hint: type) -> bool:
    """True when a YAML ``value`` fits a field of scalar type ``hint`` (a bool is no number)."""
    return isinstance(value, _SCALARS[hint]) and (hint is bool or not isinstance(value, bool))


def _build(cls: type, doc: object, where: str) -> object:
    """Instantiate config dataclass ``cls`` from a mapping, converting nested records/enums."""
    if not isinstance(doc, dict):
        raise ConfigError(f"{where} must be a mapping, got {type(doc).__name__}")
    hints = typing.get_type_hints(cls)
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(doc) - names)
    if unknown:
        raise ConfigError(f"{where}: unknown key(s) {', '.join(unknown)}")
    kwargs: dict[str, object] = {}
    for key, value in doc.items():
        hint = hints[key]
        if dataclasses.is_dataclass(hint):
            kwargs[key] = _build(hint, value, f"{where}.{key}")
        elif isinstance(hint, type) and issubclass(hint, enum.Enum):
            try:
                kwargs[key] = hint(value)
            except ValueError as exc:
                options = ", ".join(m.value for m in hint)
                raise ConfigError(f"{where}.{key}: {value!r} is not one of {options}") from exc
        elif hint in _SCALARS and not _is_a(value, hint):
            raise ConfigError(f"{where}.{key}: expected {hint.__name__}, got {value!r}")
        elif hint is float:
            kwargs[key] = float(value)
        else:
            kwargs[key] = value
    return cls(**kwargs)


def frontend_config_from_dict(
    doc: dict[str, Any] | None, source: str | Path | None = None
) -> FrontendConfig:
    """Merge overrides onto the defaults.

    ``sift`` may also be a preset name (``"lowe"``, ``"omni-thesis"``) or a mapping with a
    ``preset`` key plus overrides.

    Args:
        doc: the overrides, by section (``{"laser": {"min_points": 5}}``); None: the defaults.
        source: the file the overrides were read from; every error message starts with it.

    Raises:
        ConfigError: unknown keys, bad enum values, values of the wrong type or out of range.
    """
    try:
        return _merge_overrides(doc)
    except ConfigError as exc:
        if source is None:
            raise
        raise ConfigError(f"{source}: {exc}") from None
    except (TypeError, ValueError) as exc:  # a value of the wrong type met a range check
        where = f"{source}: " if source is not None else ""
        raise ConfigError(f"{where}a value of the wrong type ({exc})") from None


def _merge_overrides(doc: dict[str, Any] | None) -> FrontendConfig:
    """``frontend_config_from_dict`` without the file's name in its errors."""
    doc = dict(doc or {})
    sift = doc.pop("sift", None)
    base = FrontendConfig()
    if isinstance(sift, str) or (isinstance(sift, dict) and "preset" in sift):
        overrides = {} if isinstance(sift, str) else dict(sift)
        name = sift if isinstance(sift, str) else overrides.pop("preset")
        if name not in SIFT_PRESETS:
            raise ConfigError(f"unknown SIFT preset {name!r}; known: {', '.join(SIFT_PRESETS)}")
        merged = config_to_dict(SIFT_PRESETS[name]) | overrides
        sift_config = _build(SiftConfig, merged, "sift")
    elif sift is not None:
        sift_config = _build(SiftConfig, config_to_dict(base.sift) | dict(sift), "sift")
    else:
        sift_config = base.sift
    config = _build(FrontendConfig, doc, "frontend")
    assert isinstance(config, FrontendConfig)
    return dataclasses.replace(config, sift=sift_config)
