"""Point landmarks from a planar laser scan: spikes and RANSAC lines (SLAM for Dummies, sec.
"Landmark extraction"), as range-bearing sightings for the EKF-SLAM baseline.

- **Spikes**: a beam (or a run of a few beams) whose range is shorter than both neighbours' by
  more than a jump (0.5 m in the tutorial) sees something standing out (a pole, a table leg);
  the sighting is the run's nearest range at its mean bearing.
- **RANSAC lines**: repeatedly pick a random unassigned reading, sample S readings within
  D radians of it, fit a line by least squares, collect every unassigned reading within X of
  the line; with at least C supporters the line is refitted to all of them, kept, and its
  readings removed (N attempts at most). A line becomes point landmarks in one of two ways
  (``LaserLandmarkConfig.line_landmarks``):

  * ``corners`` (the default): the **intersection of two lines** at an angle of at least
    ``corner_min_angle_deg`` whose supporting readings both come within ``corner_max_gap_m``
    of it -- a wall corner, a door frame, the end of a cupboard: a point fixed in the world,
    seen the same from every pose;
  * ``feet`` (the tutorial's): the **foot of the perpendicular** from a fixed world point (the
    origin of the odometry frame, through the odometry pose) to the line, as the tutorial does
    with its estimated pose. Through a drifting pose the foot is not a fixed point: a heading
    error delta moves it along the wall by about delta times the distance to the origin. On
    CARMEN (``benchmarks/ekfslam_accuracy.py --diagnose``), projected with the corrected
    poses, the nearest foot of the same wall within 5 scans is 0.21 m away (median; intel and
    aces), a spike 0.03-0.05 m, a corner 0.035 m; after the odometry's metres of drift a
    revisited wall's feet lie metres from the first ones, so a revisit cannot close a loop
    through them.

**Persistence** (``persistent_sightings``, ``LaserLandmarkConfig.persistence_radius_m``): a
sighting reaches the estimators only when the previous scan saw one within 0.2 m of it,
both placed through the estimators' odometry (the laser odometry on CARMEN, accurate from one
scan to the next). On carmen-aces 271 of 680 spikes have no spike of the scan before or after
within 0.2 m (placed with the corrected poses: seen once, or not a fixed point); the check
keeps 280 spikes, 2 of them such. With every sighting, every estimator there ended worse than
its laser odometry alone (docs/results/frontend.md, "The laser front end (CARMEN)").

**Separation** (``separated``, ``LaserLandmarkConfig.min_separation_m``, off by default): a
sighting with another of the same scan within the distance is dropped, as is the other. On
CARMEN csail (0.5 deg beams) 6 of the 8.3 spikes per scan have another spike within 0.3 m (a
railing, chair legs, every other beam of an interlaced scan in front of an edge): objects that
close pair with each other's landmarks.

**Noise** (``sighting_noise``): the tutorial's 1 % of the range and 1 deg, plus an isotropic
position std that does not shrink with the range (``LaserLandmarkConfig.sigma_floor_m``, 3 cm):
on CARMEN two sightings of one landmark lie 3-7 cm apart at every range
(``benchmarks/laser_sighting_noise.py``), so without it the near ones were 2-3x overconfident.

Readings beyond the sensor's valid range (8.1 m for the tutorial's SICK) are ignored.
"""

from __future__ import annotations

import collections

import numpy as np

from omnislam.core.measurement import RangeBearing2D
from omnislam.core.types import UNKNOWN_ID, RangeBearing
from omnislam.frontend.config import LaserLandmarkConfig, LineLandmarks

#: smallest range standard deviation reported [m]
MIN_SIGMA_RANGE_M = 0.01


def find_spikes(
    ranges_m: np.ndarray, valid: np.ndarray, jump_m: float, max_beams: int
) -> list[np.ndarray]:
    """Runs of at most ``max_beams`` valid beams closer than both flanking beams by ``jump_m``.

    The tutorial's spike is one beam standing out from its neighbours; a pole a few beams wide
    is a short run bounded by a range drop on its left and a range rise on its right.

    Returns:
        One array of beam indices per spike.
    """
    r = np.where(valid, ranges_m, np.inf)
    n = r.shape[0]
    with np.errstate(invalid="ignore"):  # inf - inf next to invalid beams
        drop = np.flatnonzero(r[:-1] - r[1:] > jump_m) + 1  # run starts at i
        rise = np.flatnonzero(r[1:] - r[:-1] > jump_m)  # run ends at j
    spikes = []
    for start in drop:
        ends = rise[(rise >= start) & (rise < start + max_beams)]
        if ends.size == 0:
            continue
        run = np.arange(start, ends[0] + 1)
        if np.all(valid[run]) and np.all(r[run].max() + jump_m < r[[start - 1, min(ends[0] + 1,
                                                                                    n - 1)]]):
            spikes.append(run)
    return spikes


def fit_line(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Total-least-squares line ``n . p = d`` through (M, 2) points; returns (unit n, d)."""
    centre = points.mean(axis=0)
    _, _, Vt = np.linalg.svd(points - centre)
    normal = Vt[-1]
    return normal, float(normal @ centre)


def ransac_lines(
    points: np.ndarray, angles_rad: np.ndarray, config: LaserLandmarkConfig,
    rng: np.random.Generator,
) -> list[tuple[np.ndarray, float]]:
    """Lines ``(n, d)`` found by the tutorial's RANSAC among (M, 2) scan points.

    Args:
        points: (M, 2) valid scan points in the sensor frame [m].
        angles_rad: (M,) their beam angles.
        config: N (trials), S (samples), D (window), X (distance), C (consensus).
        rng: random generator.
    """
    return [(normal, d) for normal, d, _ in ransac_segments(points, angles_rad, config, rng)]


def ransac_segments(
    points: np.ndarray, angles_rad: np.ndarray, config: LaserLandmarkConfig,
    rng: np.random.Generator,
) -> list[tuple[np.ndarray, float, np.ndarray]]:
    """``ransac_lines`` with each line's supporting readings: ``(n, d, indices into points)``."""
    free = np.ones(points.shape[0], dtype=bool)
    lines: list[tuple[np.ndarray, float, np.ndarray]] = []
    for _ in range(config.ransac_trials):
        available = np.flatnonzero(free)
        if available.shape[0] < config.ransac_consensus:
            break
        centre = available[rng.integers(available.shape[0])]
        window = available[np.abs(angles_rad[available] - angles_rad[centre])
                           <= config.ransac_window_rad]
        if window.shape[0] < config.ransac_samples:
            continue
        sample = rng.choice(window, size=config.ransac_samples, replace=False)
        normal, d = fit_line(points[sample])
        support = available[np.abs(points[available] @ normal - d)
                            <= config.ransac_max_distance_m]
        if support.shape[0] < config.ransac_consensus:
            continue
        normal, d = fit_line(points[support])
        support = available[np.abs(points[available] @ normal - d)
                            <= config.ransac_max_distance_m]
        lines.append((normal, d, support))
        free[support] = False
    return lines


def line_corners(
    points: np.ndarray, segments: list[tuple[np.ndarray, float, np.ndarray]],
    min_angle_rad: float, max_gap_m: float,
) -> list[np.ndarray]:
    """Corners: intersections of two lines that both end there.

    Two lines ``n_i . p = d_i`` meeting at an angle of at least ``min_angle_rad`` intersect at
    c; c is a corner when each line has a supporting reading within ``max_gap_m`` of it (the
    two walls reach the corner, rather than their extensions crossing in free space).

    Returns:
        (2,) corners in the sensor frame.
    """
    corners: list[np.ndarray] = []
    sin_min = np.sin(min_angle_rad)
    for i in range(len(segments)):
        n_i, d_i, s_i = segments[i]
        for j in range(i + 1, len(segments)):
            n_j, d_j, s_j = segments[j]
            cross = n_i[0] * n_j[1] - n_i[1] * n_j[0]
            if abs(cross) < sin_min:
                continue
            corner = np.linalg.solve(np.array([n_i, n_j]), np.array([d_i, d_j]))
            gap_i = np.min(np.linalg.norm(points[s_i] - corner, axis=1))
            gap_j = np.min(np.linalg.norm(points[s_j] - corner, axis=1))
            if gap_i <= max_gap_m and gap_j <= max_gap_m:
                corners.append(corner)
    return corners


def extract_laser_landmarks(
    angles_rad: np.ndarray,
    ranges_m: np.ndarray,
    max_range_m: float,
    config: LaserLandmarkConfig,
    rng: np.random.Generator,
    pose_dr: np.ndarray | None = None,
) -> RangeBearing:
    """Spike and line landmarks of one scan as range-bearing sightings (ids unknown).

    Args:
        angles_rad: (B,) beam angles in the scanner frame (counter-clockwise from its heading;
            the sightings come out in this frame: ``mounted_laser`` moves them to the robot's).
        ranges_m: (B,) ranges [m]; ``>= max_range_m`` or NaN means no return.
        max_range_m: the sensor's maximum range.
        config: thresholds.
        rng: random generator for RANSAC.
        pose_dr: (3,) dead-reckoning pose [x, y, theta] of the scanner used to drop the
            perpendicular from the odometry frame's origin (None: from the sensor itself).

    Returns:
        Sightings with ``UNKNOWN_ID``: spikes first, then the line landmarks (corners or
        feet, ``config.line_landmarks``).
    """
    limit = max_range_m if config.max_valid_range_m is None else min(
        max_range_m, config.max_valid_range_m)
    ranges = np.asarray(ranges_m, dtype=float)
    with np.errstate(invalid="ignore"):
        valid = np.isfinite(ranges) & (ranges < limit) & (ranges > 0)
    angles_rad = np.asarray(angles_rad, dtype=float)
    spikes = find_spikes(ranges, valid, config.spike_jump_m, config.spike_max_beams)
    r_out = [float(ranges[run].min()) for run in spikes]
    b_out = [float(angles_rad[run].mean()) for run in spikes]
    keep = valid.copy()
    for run in spikes:
        keep[run] = False
    pts = np.column_stack([ranges[keep] * np.cos(angles_rad[keep]),
                           ranges[keep] * np.sin(angles_rad[keep])])
    if pose_dr is None:
        origin_r = np.zeros(2)
    else:  # the odometry frame's origin seen from the robot
        x, y, th = pose_dr
        c, s = np.cos(th), np.sin(th)
        origin_r = np.array([-c * x - s * y, s * x - c * y])
    segments = ransac_segments(pts, angles_rad[keep], config, rng)
    if config.line_landmarks is LineLandmarks.FEET:
        points = [origin_r - (normal @ origin_r - d) * normal for normal, d, _ in segments]
    else:
        points = line_corners(
            pts, segments, np.deg2rad(config.corner_min_angle_deg), config.corner_max_gap_m
        )
    for point in points:
        r_out.append(float(np.hypot(*point)))
        b_out.append(float(np.arctan2(point[1], point[0])))
    r = np.array(r_out, dtype=float)
    b = np.array(b_out, dtype=float)
    if config.min_separation_m is not None:
        isolated = separated(r, b, config.min_separation_m)
        r, b = r[isolated], b[isolated]
    sigma_range_m, sigma_bearing_rad = sighting_noise(r, config)
    return RangeBearing(
        landmark_ids=np.full(r.shape[0], UNKNOWN_ID, dtype=np.int64),
        ranges_m=r,
        bearings_rad=b,
        sigma_range_m=sigma_range_m,
        sigma_bearing_rad=sigma_bearing_rad,
    )


def separated(ranges_m: np.ndarray, bearings_rad: np.ndarray, min_separation_m: float
              ) -> np.ndarray:
    """Which point sightings of one scan have no other within ``min_separation_m``.

    Args:
        ranges_m: (K,) ranges [m].
        bearings_rad: (K,) bearings in the sensor frame.
        min_separation_m: smallest distance to the scan's other sightings [m].

    Returns:
        (K,) bool, True where the nearest other sighting is farther than ``min_separation_m``.
    """
    xy = np.column_stack([ranges_m * np.cos(bearings_rad), ranges_m * np.sin(bearings_rad)])
    gap = np.linalg.norm(xy[:, None, :] - xy[None, :, :], axis=2)
    np.fill_diagonal(gap, np.inf)
    return gap.min(axis=1, initial=np.inf) > min_separation_m


def sighting_noise(
    ranges_m: np.ndarray, config: LaserLandmarkConfig
) -> tuple[np.ndarray, np.ndarray]:
    """Range and bearing std of laser landmarks at ``ranges_m``.

    sigma_r = sqrt(max(f r, 1 cm)^2 + s0^2) and sigma_b = sqrt(sigma_b0^2 + (s0 / r)^2): the
    tutorial's range-proportional noise (f = ``sigma_range_fraction``, sigma_b0 =
    ``sigma_bearing_rad``) plus an isotropic position std s0 (``sigma_floor_m``) that does not
    shrink with the range (in Cartesian terms a covariance J diag(sigma_r^2, sigma_b^2) J^T =
    J diag((f r)^2, (sigma_b0 r / r)^2) J^T + s0^2 I, with J the polar-to-Cartesian Jacobian).

    Args:
        ranges_m: (K,) ranges [m].
        config: the noise parameters.

    Returns:
        (K,) range stds [m] and (K,) bearing stds [rad].
    """
    r = np.asarray(ranges_m, dtype=float)
    floor = config.sigma_floor_m
    proportional = np.maximum(config.sigma_range_fraction * r, MIN_SIGMA_RANGE_M)
    sigma_range_m = np.hypot(proportional, floor)
    sigma_bearing_rad = np.hypot(
        np.full(r.shape[0], config.sigma_bearing_rad), floor / np.maximum(r, MIN_SIGMA_RANGE_M)
    )
    return sigma_range_m, sigma_bearing_rad


def persistent_sightings(
    sightings: dict[int, RangeBearing], poses_w: np.ndarray, radius_m: float, scans: int = 1
) -> dict[int, RangeBearing]:
    """The sightings that the previous scans saw too: a landmark must be re-observable.

    Each frame's sightings are placed in the world through ``poses_w`` (the odometry the
    estimators get: laser odometry on CARMEN, accurate from one scan to the next); a sighting
    is kept when each of the ``scans`` previous frames with sightings had one within
    ``radius_m`` of it. A spike from a person walking by, a chair leg seen from one side only
    or a beam grazing a door frame rarely meets this; a pole or a wall corner does. The first
    ``scans`` sightings of every landmark are dropped: an estimator meets it ``scans`` scans
    later.

    Args:
        sightings: frame index -> that frame's sightings (ids unknown).
        poses_w: (N, 3) robot poses [x, y, theta] in the odometry's world frame.
        radius_m: largest distance to a sighting of each previous frame [m].
        scans: how many previous frames must all have seen it (1: the previous one).

    Returns:
        frame index -> the kept sightings (the same frames; possibly empty).
    """
    kept: dict[int, RangeBearing] = {}
    previous_w: collections.deque[np.ndarray] = collections.deque(maxlen=scans)
    for i in sorted(sightings):
        s = sightings[i]
        world, _, _ = RangeBearing2D().inverse(
            poses_w[i], np.column_stack([s.ranges_m, s.bearings_rad]))
        keep = np.full(world.shape[0], len(previous_w) == scans)
        for before_w in previous_w:
            if not before_w.shape[0]:
                keep[:] = False
                break
            gap = np.linalg.norm(world[:, None, :] - before_w[None, :, :], axis=2).min(axis=1)
            keep &= gap <= radius_m
        kept[i] = RangeBearing(
            s.landmark_ids[keep], s.ranges_m[keep], s.bearings_rad[keep],
            s.sigma_range_m[keep], s.sigma_bearing_rad[keep],
        )
        previous_w.append(world)
    return kept
