"""A sensor rigidly mounted on the robot at ``rTs`` = [x, y, yaw] (its pose in the robot frame).

The sensor measures in its own frame s; the estimators work in the robot frame r. Three moves
between them, each the identity (its input returned unchanged, bit for bit) when ``rTs`` is
zero, so a sensor at the robot's origin costs nothing and changes no number:

* ``range_bearing_in_robot_frame``: a range-bearing sighting is a point p_s in the sensor
  frame; from the robot's origin it is p_r = rTs p_s, range |p_r| and bearing atan2(p_r).
* ``mounted_increments``: a frame b rigidly attached to a frame a at ``aTb`` moves by
  d_b = aTb^-1 (+) d_a (+) aTb when a moves by d_a (the increment conjugated by the mount);
  the robot's increments give the sensor's with ``aTb`` = rTs, the sensor's give the robot's
  with ``aTb`` = rTs^-1 (= sTr). Covariances follow to first order: J Sigma J^T with J the
  Jacobian of the conjugation on the increment's (x, y, theta) (for a small rotation of the
  increment, the adjoint of aTb^-1).
* the sensor's poses in the world are wTs = wTr (+) rTs (``se2_compose``).
"""

from __future__ import annotations

import numpy as np

from omnislam.core.se import se2_compose, se2_compose_jacobians, se2_inverse


def is_at_origin(rTs: np.ndarray | None) -> bool:
    """True when a mount is absent (None) or zero: the sensor frame is the robot frame."""
    return rTs is None or not np.any(np.asarray(rTs, dtype=float))


def range_bearing_in_robot_frame(
    ranges_m: np.ndarray, bearings_rad: np.ndarray, rTs: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray]:
    """Sightings of a sensor mounted at ``rTs`` seen from the robot's origin.

    Args:
        ranges_m: (K,) ranges from the sensor [m].
        bearings_rad: (K,) bearings in the sensor frame [rad].
        rTs: (3,) the sensor's pose [x, y, yaw] in the robot frame [m, m, rad], or None.

    Returns:
        (ranges_m, bearings_rad), (K,) each, from the robot's origin in the robot frame:
        p_r = (x + r cos(b + yaw), y + r sin(b + yaw)), range |p_r|, bearing atan2(p_r)
        (the inputs themselves when the sensor is at the origin).
    """
    if is_at_origin(rTs):
        return ranges_m, bearings_rad
    x, y, yaw = np.asarray(rTs, dtype=float)
    px = x + ranges_m * np.cos(bearings_rad + yaw)
    py = y + ranges_m * np.sin(bearings_rad + yaw)
    return np.hypot(px, py), np.arctan2(py, px)


def mounted_increments(
    deltas_a: np.ndarray, covariances_a: np.ndarray | None, aTb: np.ndarray
) -> tuple[np.ndarray, np.ndarray | None]:
    """The increments of frame b, rigidly mounted on frame a at ``aTb``, from those of a.

    Args:
        deltas_a: (N, 3) increments [dx, dy, dtheta] of frame a, each in a's previous pose.
        covariances_a: (N, 3, 3) their covariances (NaN rows stay NaN), or None.
        aTb: (3,) the pose of b in a [m, m, rad].

    Returns:
        (deltas_b, covariances_b): d_b = aTb^-1 (+) d_a (+) aTb, (N, 3), and J Sigma_a J^T with
        J = d d_b / d d_a (N, 3, 3), or None; the inputs themselves when ``aTb`` is zero.
    """
    if is_at_origin(aTb):
        return deltas_a, covariances_a
    aTb = np.asarray(aTb, dtype=float)
    bTa = se2_inverse(aTb)
    moved_a = se2_compose(deltas_a, aTb)  # d_a (+) aTb
    deltas_b = se2_compose(bTa, moved_a)
    if covariances_a is None:
        return deltas_b, None
    J_inner, _ = se2_compose_jacobians(deltas_a, aTb)  # d (d_a (+) aTb) / d d_a
    _, J_outer = se2_compose_jacobians(bTa, moved_a)  # d (bTa (+) m) / d m
    J = J_outer @ J_inner
    return deltas_b, J @ np.asarray(covariances_a, dtype=float) @ np.swapaxes(J, -1, -2)
