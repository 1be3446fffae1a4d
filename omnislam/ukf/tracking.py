"""Step 3 of Barra & Costa (sec. 3.1): projections of this frame matched to the previous one's.

The paper matches PMCs and uses the estimated displacement of the robot between the two frames
to limit the candidates, deferring the details to Barra & Costa (2005), which is not available.
Our reconstruction, documented:

* A line seen at bearing b_j from the previous pose lies somewhere on that ray, at an unknown
  depth d in [min_depth, max_depth]. Moved by the estimated displacement prevTcur, its bearing
  from the current pose sweeps an interval (the 1-D epipolar segment). Projection i of this
  frame may be line j only if its bearing lies in that interval, widened by a tolerance of
  ``track_tolerance_px`` expressed as an angle through the image line.
* Among compatible pairs, the cost is the PMC distance (mean absolute difference of the
  profiles, gated at ``max_profile_diff``) when both frames carry profiles, plus, as a
  tie-break and as the whole cost without profiles (MR.CLAM), the bearing change not explained
  by the rotation alone, |wrap(b_i - (b_j - dtheta))| (the motion of a line at infinity).
* One-to-one: the assignment of least total cost (scipy's ``linear_sum_assignment``).
"""

from __future__ import annotations

import numpy as np

from omnislam.core.se import wrap_angle
from omnislam.ukf.config import TrackingConfig
from omnislam.ukf.photometric import profile_distance

_DEPTHS = 24
_INFEASIBLE = 1e9


def track_lines(
    prev_bearings_rad: np.ndarray,
    bearings_rad: np.ndarray,
    prevTcur: np.ndarray,
    tolerance_rad: float,
    config: TrackingConfig,
    prev_profiles: np.ndarray | None = None,
    profiles: np.ndarray | None = None,
) -> np.ndarray:
    """For each projection of this frame, the index of the same line in the previous frame.

    Args:
        prev_bearings_rad: (J,) bearings of the previous processed frame (its robot frame).
        bearings_rad: (K,) bearings of this frame.
        prevTcur: (3,) estimated pose of this frame in the previous frame's robot frame.
        tolerance_rad: widening of the epipolar interval [rad] (``config.tolerance_px`` through
            the image line).
        config: the depths the interval spans and the PMC gate.
        prev_profiles: (J, 3, W) PMCs of the previous lines, or None (geometric match only).
        profiles: (K, 3, W) PMCs of the current lines, or None (geometric match only).

    Returns:
        (K,) int: previous index, or -1 when the projection is new.
    """
    from scipy.optimize import linear_sum_assignment

    prev = np.asarray(prev_bearings_rad, dtype=float)
    now = np.asarray(bearings_rad, dtype=float)
    out = np.full(now.shape[0], -1, dtype=np.int64)
    if not prev.size or not now.size:
        return out
    x, y, dtheta = (float(v) for v in prevTcur)
    depths = np.geomspace(config.min_depth_m, config.max_depth_m, _DEPTHS)
    px = depths[None, :] * np.cos(prev)[:, None] - x  # (J, D) in prev frame, minus translation
    py = depths[None, :] * np.sin(prev)[:, None] - y
    swept = np.arctan2(py, px) - dtheta  # bearings from the current pose, (J, D)
    reference = swept[:, -1:]
    offsets = wrap_angle(swept - reference)
    low, high = offsets.min(axis=1), offsets.max(axis=1)  # (J,)
    rel = wrap_angle(now[None, :] - reference)  # (J, K)
    inside = (rel >= low[:, None] - tolerance_rad) & (rel <= high[:, None] + tolerance_rad)
    cost = np.abs(wrap_angle(now[None, :] - (prev[:, None] - dtheta)))
    if prev_profiles is not None and profiles is not None:
        distance = profile_distance(prev_profiles, profiles)
        inside &= distance <= config.max_profile_diff
        cost = distance + cost
    cost = np.where(inside, cost, _INFEASIBLE)
    rows, cols = linear_sum_assignment(cost)
    keep = cost[rows, cols] < _INFEASIBLE
    out[cols[keep]] = rows[keep]
    return out
