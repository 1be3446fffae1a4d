"""Occupancy grid from laser scans on given poses (thesis sec. 2.2.1; Thrun et al. 2005, ch. 9).

Each cell holds the log-odds ``l = log(p / (1 - p))`` of being occupied, starting at 0
(p = 0.5). For every beam, the cells the ray crosses before its end point receive ``l_free``
(< 0) and the cell of the end point ``l_occ`` (> 0) when the beam returned (range below the
sensor's maximum). The updates are sums, so they are accumulated with ``np.bincount`` over
all beams of a batch of scans at once; a beam's ray is sampled every half cell and each cell is
counted once per beam; beams without a return are skipped. The result is the inverse-sensor-model
grid without clamping (sums commute, so the scan order does not matter).

Pure numpy. Poses are planar ``wTr`` [x, y, yaw]; beam angles are in the robot frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from omnislam.errors import DataError

#: log-odds added to a cell a beam passes through (p = 0.3)
L_FREE = float(np.log(0.3 / 0.7))
#: log-odds added to the cell a beam ends in (p = 0.7)
L_OCC = float(np.log(0.7 / 0.3))


@dataclass(frozen=True, slots=True)
class OccupancyGrid:
    """A 2-D log-odds grid.

    Attributes:
        log_odds: (H, W) log-odds; row i covers y in [origin_y + i res, origin_y + (i+1) res).
        origin_w: (2,) world position of the lower-left corner of cell (0, 0) [m].
        resolution_m: cell size [m].
        scans: number of scans integrated.
    """

    log_odds: np.ndarray
    origin_w: np.ndarray
    resolution_m: float
    scans: int

    @property
    def probability(self) -> np.ndarray:
        """(H, W) occupancy probability ``1 - 1 / (1 + exp(l))``."""
        return 1.0 - 1.0 / (1.0 + np.exp(self.log_odds))

    @property
    def extent_w(self) -> tuple[float, float, float, float]:
        """(x_min, x_max, y_min, y_max) [m] for plotting."""
        h, w = self.log_odds.shape
        x0, y0 = self.origin_w
        return (
            float(x0),
            float(x0 + w * self.resolution_m),
            float(y0),
            float(y0 + h * self.resolution_m),
        )


def occupancy_grid(
    poses_w: np.ndarray,
    angles_rad: np.ndarray,
    ranges_m: np.ndarray,
    max_range_m: float,
    *,
    resolution_m: float = 0.1,
    usable_range_m: float = 20.0,
    margin_m: float = 2.0,
    batch_scans: int = 32,
) -> OccupancyGrid:
    """Integrate scans taken at ``poses_w`` into a log-odds occupancy grid.

    Args:
        poses_w: (N, 3) sensor poses [x, y, yaw] in the world [m, m, rad].
        angles_rad: (B,) beam angles in the sensor frame [rad].
        ranges_m: (N, B) ranges [m]; NaN rows (no scan) are skipped; a range >= ``max_range_m``
            is "no return" and skipped (it says nothing reliable about any cell); a range
            beyond ``usable_range_m`` marks its ray free up to there, with no end point.
        max_range_m: the sensor's maximum range [m].
        resolution_m: cell size [m].
        usable_range_m: rays are cut here (long beams are unreliable and slow) [m].
        margin_m: free border around the poses and end points [m].
        batch_scans: scans vectorised together (memory ~ batch x B x range / resolution).

    Returns:
        OccupancyGrid.
    """
    poses = np.asarray(poses_w, dtype=float).reshape(-1, 3)
    angles = np.asarray(angles_rad, dtype=float).reshape(-1)
    ranges = np.asarray(ranges_m, dtype=float)
    if ranges.shape != (len(poses), len(angles)):
        raise DataError(
            f"ranges must be (N, B) = ({len(poses)}, {len(angles)}), got {ranges.shape}"
        )
    if not resolution_m > 0:
        raise DataError(f"resolution_m must be positive, got {resolution_m}")
    keep = np.all(np.isfinite(ranges), axis=1)
    poses, ranges = poses[keep], ranges[keep]
    returned = ranges < max_range_m  # no-return beams carry no evidence and are skipped
    cut = np.minimum(ranges, usable_range_m)
    hit = returned & (ranges <= usable_range_m)

    world_angle = poses[:, 2:3] + angles[None, :]
    ends = np.stack(
        [
            poses[:, 0:1] + cut * np.cos(world_angle),
            poses[:, 1:2] + cut * np.sin(world_angle),
        ],
        axis=-1,
    )
    used = ends[returned]
    points = np.concatenate([poses[:, :2], used]) if len(poses) else np.zeros((1, 2))
    lo = points.min(axis=0) - margin_m
    hi = points.max(axis=0) + margin_m
    shape = (
        int(np.ceil((hi[1] - lo[1]) / resolution_m)),
        int(np.ceil((hi[0] - lo[0]) / resolution_m)),
    )
    cells = shape[0] * shape[1]
    free = np.zeros(cells)
    occupied = np.zeros(cells)

    step = resolution_m / 2.0
    for start in range(0, len(poses), batch_scans):
        stop = min(start + batch_scans, len(poses))
        r = np.where(returned[start:stop], cut[start:stop], 0.0)[:, :, None]
        samples = int(np.ceil(float(r.max(initial=0.0)) / step))
        if samples == 0:
            continue
        t = (np.arange(samples) + 0.5) * step  # sample distances along a ray
        theta = world_angle[start:stop, :, None]
        sx = poses[start:stop, 0, None, None] + t * np.cos(theta)
        sy = poses[start:stop, 1, None, None] + t * np.sin(theta)
        col = np.floor((sx - lo[0]) / resolution_m).astype(np.int64)
        row = np.floor((sy - lo[1]) / resolution_m).astype(np.int64)
        flat = row * shape[1] + col
        # free: samples before the end point's cell; a straight ray never re-enters a cell,
        # so counting a cell once per beam means dropping samples equal to their predecessor
        inside = t[None, None, :] < r - step
        first = np.ones_like(inside)
        first[:, :, 1:] = flat[:, :, 1:] != flat[:, :, :-1]
        free += np.bincount(flat[inside & first], minlength=cells)
        e = ends[start:stop][hit[start:stop]]
        ecol = np.floor((e[:, 0] - lo[0]) / resolution_m).astype(np.int64)
        erow = np.floor((e[:, 1] - lo[1]) / resolution_m).astype(np.int64)
        occupied += np.bincount(erow * shape[1] + ecol, minlength=cells)
    log_odds = (L_FREE * free + L_OCC * occupied).reshape(shape)
    return OccupancyGrid(log_odds, lo, float(resolution_m), len(poses))
