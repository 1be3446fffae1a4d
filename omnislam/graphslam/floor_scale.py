"""The odometry's scale from floor points seen from the known camera height (omni bearings).

Bearings carry no scale: every viewpoint is at the rig's camera height h, and scaling the world
about that plane leaves every bearing unchanged, so a graph of bearings and odometry takes the
odometry's scale -- a wheel-radius error of 1% gives a 1% smaller map, whatever the bearings.
A point *on the floor* breaks the symmetry: seen at depression angle delta from height h it
lies ``d = h / tan(delta)`` away, so one sighting fixes it in the robot frame, metrically. This
is the ground-plane scale cue of monocular visual odometry (the camera height above a planar
floor, from the rig calibration ``rTc``).

``FloorScale`` estimates, online, the factor ``s`` by which the wheel odometry's translations
must be multiplied:

* every bearing pointing at least ``FLOOR_MIN_DEPRESSION_DEG`` below the horizon is
  intersected with the floor plane z = 0: ``p = h u_xy / -u_z`` in its image's robot frame,
  with std ``h sigma / sin^2(delta)`` (the radial one, the larger);
* per track, the first and the latest such sighting form a pair. With ``(R, t)`` the raw
  odometry between the two images (composed, unscaled), a floor point satisfies
  ``p_first = R p_latest + s t``; the pair's estimate is ``s_pair = t . (p_first - R p_latest)
  / |t|^2`` with std ``sqrt(sigma_1^2 + sigma_2^2) / |t|``. Pairs whose residual across ``t``
  exceeds ``PERPENDICULAR_GATE_SIGMAS`` are no floor point (or a wrong track) and are dropped;
  pairs with a baseline under ``MIN_BASELINE_M`` say little and are not used;
* a point at height z > 0 projected onto the floor moves with the robot by ``h / (h - z)``
  times the motion: it looks like a scale of ``h / (h - z)`` along ``t`` and no single pair
  tells it from the floor; features fixed in the robot frame (the robot's own body in the
  mirror) give ``s = 0``. The floor is the *lowest mode*: of the local maxima of the
  inverse-variance weighted kernel density of ``log s_pair`` (bandwidth ``MODE_BANDWIDTH``)
  within ``[1 / MAX_SCALE, MAX_SCALE]`` that reach ``MODE_MIN_RELATIVE`` of the highest, the
  lowest, refined by mean shift over the pairs within ``MODE_WINDOW`` bandwidths (points a few
  cm above the floor -- skirting boards, the feet of boxes -- form a mode of their own a few %
  higher, which may be the larger one). Until ``MIN_PAIRS`` pairs support the mode the scale
  is 1 (the odometry as it is). On lab40 (528 of the 8512 tracks lie on the floor, 3 sightings
  each, 39-57 deg below the horizon) the highest mode was 0.9894 against the true 1 / 1.01 =
  0.9901; on the log of today's render (256 floor tracks, 171 floor pairs and 27 heavy pairs of
  points 2-10 cm above the floor) the highest mode was 1.0065 and the lowest is 0.9871.

``odometry_scale.OdometryScaling`` multiplies each frame's odometry translation (and its stated
covariance) by the current estimate before the graph builds the between-factors
(``FloorConfig.scale``), so the graph's map and trajectory take the floor's metric scale.
Without floor points (a textureless floor, or no camera height) nothing changes.
"""

from __future__ import annotations

import numpy as np

from omnislam.core.se import se2_between, se2_compose
from omnislam.core.triangulation import floor_points_r
from omnislam.core.types import UNKNOWN_ID, Bearings

#: bearings at least this far below the horizon are floor candidates [deg]
FLOOR_MIN_DEPRESSION_DEG = 35.0
#: shortest odometry baseline of a pair that is used [m]
MIN_BASELINE_M = 0.05
#: a pair whose residual across the baseline exceeds this many sigmas is no floor point
PERPENDICULAR_GATE_SIGMAS = 3.0
#: scales considered: within [1 / MAX_SCALE, MAX_SCALE] of the odometry's (a wheel odometry off
#: by more than 10% is a broken one; a point 0.08 m above the floor already looks like 1.1)
MAX_SCALE = 1.1
#: bandwidth of the kernel density of log(s_pair) whose lowest mode is the floor
MODE_BANDWIDTH = 0.01
#: a local maximum of that density at least this fraction of the highest is a surface's mode
MODE_MIN_RELATIVE = 0.3
#: pairs within this many bandwidths of the mode are its support (and its mean)
MODE_WINDOW = 2.0
#: pairs that must support the mode before the estimate replaces 1
MIN_PAIRS = 20


class FloorScale:
    """Online estimate of the odometry's translation scale from floor points (module docstring).

    Args:
        sensor_height_m: the camera's viewpoint height above the floor (the robot frame's
            origin) [m], > 0.
        min_depression_deg: bearings at least this far below the horizon are floor candidates.
    """

    def __init__(
        self, sensor_height_m: float, min_depression_deg: float = FLOOR_MIN_DEPRESSION_DEG
    ) -> None:
        if not sensor_height_m > 0:
            raise ValueError(f"sensor_height_m must be positive, got {sensor_height_m}")
        self._h = float(sensor_height_m)
        self._max_uz = -np.sin(np.radians(min_depression_deg))
        self._pose = np.zeros(3)  # raw dead reckoning of the current frame
        # per track: (raw pose, floor point (2,), sigma) of its first candidate sighting
        self._first: dict[int, tuple[np.ndarray, np.ndarray, float]] = {}
        self._row: dict[int, int] = {}  # track -> row of its pair in the arrays below
        self._s = np.zeros(64)
        self._sigma = np.zeros(64)
        self._pairs = 0
        self._scale = 1.0
        self._inliers = 0
        self._mode = np.nan  # log of the floor's mode once estimated
        self._frames = 0
        # every frame's floor candidates (frame, track ids, floor points, sigmas), for refined()
        self._candidates: list[tuple[int, list[int], np.ndarray, list[float]]] = []

    @property
    def scale(self) -> float:
        """The current estimate of the odometry's translation scale (1 until ``MIN_PAIRS``)."""
        return self._scale

    @property
    def inliers(self) -> int:
        """Pairs in the current estimate's weighted mean (0 while the scale is 1)."""
        return self._inliers

    @property
    def pairs(self) -> int:
        """Tracks with a usable pair (floor-consistent across the baseline) so far."""
        return self._pairs

    def floor_tracks(self) -> np.ndarray:
        """(M,) ids of the tracks whose pair supports the floor's mode, ascending (none while
        the scale is 1): the tracks taken to lie on the floor."""
        if not self._inliers:
            return np.zeros(0, dtype=np.int64)
        ids = np.array(list(self._row), dtype=np.int64)
        rows = np.array(list(self._row.values()), dtype=np.int64)
        s, sigma = self._s[rows], self._sigma[rows]
        usable = np.isfinite(sigma) & (s > 0)
        log_s = np.log(np.where(usable, s, 1.0))
        inlier = usable & (np.abs(log_s - self._mode) <= MODE_WINDOW * MODE_BANDWIDTH)
        return np.sort(ids[inlier])

    def observe(self, raw_delta: np.ndarray, bearings: Bearings | None) -> None:
        """Consume one frame: its raw odometry delta, then its bearings (None: none)."""
        self._pose = se2_compose(self._pose, np.asarray(raw_delta, dtype=float))
        self._frames += 1
        if bearings is None or len(bearings) == 0:
            return
        u = bearings.unit_vectors_r
        down = (u[:, 2] <= self._max_uz) & (bearings.landmark_ids != UNKNOWN_ID)
        if not down.any():
            return
        u = u[down]
        ids = bearings.landmark_ids[down].tolist()
        points, sigmas_m = floor_points_r(u, bearings.sigmas_rad[down], self._h)
        sigmas = sigmas_m.tolist()
        self._candidates.append((self._frames - 1, ids, points, sigmas))
        if self._add(ids, points, sigmas):
            self._estimate()

    def refined(self, poses: np.ndarray) -> FloorScale:
        """The same floor points paired over an estimated trajectory instead of the raw odometry.

        ``poses`` (N, 3) [x, y, theta]: every frame observed so far, as a graph built with the
        odometry at some scale estimates them. Its pairs measure what *that* trajectory's
        translations must be multiplied by (its ``scale``, 1 when fewer than ``MIN_PAIRS``
        agree): near 1 once the graph is at the floor's scale. Over 5-15 cm the odometry's
        per-step noise spreads the raw pairs' scales by ~16 % (lab40), the graph's trajectory,
        held by the bearings of every landmark, far less -- this is the graph's final floor
        scale (``FloorConfig.scale_refine``).

        Raises:
            ValueError: ``poses`` does not hold one pose per frame observed.
        """
        poses = np.asarray(poses, dtype=float)
        if poses.shape != (self._frames, 3):
            raise ValueError(f"poses must be ({self._frames}, 3), got {poses.shape}")
        again = FloorScale(self._h)
        again._max_uz = self._max_uz
        again._frames = self._frames
        changed = False
        for frame, ids, points, sigmas in self._candidates:
            again._pose = poses[frame]
            changed |= again._add(ids, points, sigmas)
        if changed:
            again._estimate()
        return again

    def _add(self, ids: list[int], points: np.ndarray, sigmas: list[float]) -> bool:
        """One frame's floor candidates at the current pose; True if a usable pair changed."""
        changed = False
        for lid, point, sigma in zip(ids, points, sigmas, strict=True):
            first = self._first.get(lid)
            if first is None:
                self._first[lid] = (self._pose.copy(), point, sigma)
                continue
            changed |= self._pair(lid, first, point, sigma)
        return changed

    def _pair(
        self, lid: int, first: tuple[np.ndarray, np.ndarray, float], point: np.ndarray, sigma: float
    ) -> bool:
        """Update track ``lid``'s pair with its latest sighting; True if the pair is usable."""
        pose0, point0, sigma0 = first
        dx, dy, dtheta = se2_between(pose0, self._pose)
        t = np.array([dx, dy])
        baseline = float(np.hypot(dx, dy))
        if baseline < MIN_BASELINE_M:
            return False
        c, s = np.cos(dtheta), np.sin(dtheta)
        residual = point0 - np.array([c * point[0] - s * point[1], s * point[0] + c * point[1]])
        noise = float(np.hypot(sigma0, sigma))
        across = abs(t[0] * residual[1] - t[1] * residual[0]) / baseline
        row = self._row.get(lid)
        if across > PERPENDICULAR_GATE_SIGMAS * noise:
            if row is not None:  # its pair no longer looks like a floor point
                self._sigma[row] = np.inf
            return row is not None
        if row is None:
            row = self._row[lid] = self._pairs
            self._pairs += 1
            if row == len(self._s):
                self._s = np.concatenate([self._s, np.zeros(row)])
                self._sigma = np.concatenate([self._sigma, np.zeros(row)])
        self._s[row] = float(t @ residual) / baseline**2
        self._sigma[row] = noise / baseline
        return True

    def _estimate(self) -> None:
        """The floor's mode among the pairs (module docstring)."""
        n = self._pairs
        usable = np.isfinite(self._sigma[:n]) & (self._s[:n] > 0)
        log_s = np.log(np.where(usable, self._s[:n], 1.0))
        usable &= np.abs(log_s) <= np.log(MAX_SCALE)
        log_s, sigma = log_s[usable], self._sigma[:n][usable]
        if len(log_s) < MIN_PAIRS:
            return
        weights = 1.0 / sigma**2
        grid = np.arange(-np.log(MAX_SCALE), np.log(MAX_SCALE), MODE_BANDWIDTH / 4)
        density = np.exp(-0.5 * ((grid[:, None] - log_s[None, :]) / MODE_BANDWIDTH) ** 2) @ weights
        # the floor is the lowest surface: points above it look like larger scales, so of the
        # substantial modes (low objects' points form their own) the lowest is the floor's
        padded = np.concatenate([[-np.inf], density, [-np.inf]])
        peaks = np.flatnonzero(
            (density >= padded[:-2])
            & (density >= padded[2:])
            & (density >= MODE_MIN_RELATIVE * density.max())
        )
        mode = float(grid[peaks[0]])
        for _ in range(20):  # mean shift inside the window
            inlier = np.abs(log_s - mode) <= MODE_WINDOW * MODE_BANDWIDTH
            shifted = float(np.sum(weights[inlier] * log_s[inlier]) / np.sum(weights[inlier]))
            if abs(shifted - mode) < 1e-6:
                break
            mode = shifted
        inlier = np.abs(log_s - mode) <= MODE_WINDOW * MODE_BANDWIDTH
        if inlier.sum() < MIN_PAIRS:
            return
        self._scale = float(np.exp(mode))
        self._inliers = int(inlier.sum())
        self._mode = mode


class KnownScale:
    """A known odometry scale in ``FloorScale``'s place (``FloorConfig.known_odometry_scale``):
    the same reads, no floor points used."""

    def __init__(self, scale: float) -> None:
        if not scale > 0:
            raise ValueError(f"scale must be positive, got {scale}")
        self._scale = float(scale)

    @property
    def scale(self) -> float:
        return self._scale

    @property
    def inliers(self) -> int:
        """No floor pairs: 0."""
        return 0

    def floor_tracks(self) -> np.ndarray:
        """No floor tracks: (0,)."""
        return np.zeros(0, dtype=np.int64)

    def observe(self, raw_delta: np.ndarray, bearings: Bearings | None) -> None:
        """Nothing to learn."""
