"""Planar vehicle kinematics: the unicycle and the Ackermann car of Guivant & Nebot.

The Ackermann model is the one published with the Victoria Park data (Guivant & Nebot,
"Optimization of the simultaneous localization and map-building algorithm for real-time
implementation", IEEE T-RA 17(3), 2001, eqs. for the "vehicle model"):

    v_c = v_e / (1 - tan(alpha) H / L)
    x'   = v_c cos(phi) - (v_c / L) tan(alpha) (a sin(phi) + b cos(phi))
    y'   = v_c sin(phi) + (v_c / L) tan(alpha) (a cos(phi) - b sin(phi))
    phi' = (v_c / L) tan(alpha)

where v_e is the speed measured by the encoder on the rear-left wheel, alpha the steering angle,
L the wheelbase, H the lateral offset of the encoder from the rear axle centre, and (x, y) the
position of the laser, mounted at (a, b) (forward, left) from the rear axle centre. These are the
equations of a rigid body: the rear axle centre moves as a unicycle with forward speed v_c and
yaw rate omega = v_c tan(alpha) / L, and the laser is the fixed point (a, b) of that body. So the
model is integrated exactly here: the rear axle with the closed-form unicycle arc (velocities held
constant between samples, zero-order hold), then the laser frame ``rTl = (a, b, 0)`` composed on.
That gives the same trajectory as Euler integration of the equations above in the limit dt -> 0.

Pure numpy; poses are [x, y, theta] arrays (``omnislam.core.se`` conventions).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from omnislam.core.se import se2_compose


@dataclass(frozen=True, slots=True)
class AckermannGeometry:
    """Vehicle geometry of the Victoria Park car (Guivant & Nebot 2001; data README).

    Attributes:
        wheelbase_m: L, rear axle to front axle [m].
        encoder_offset_m: H, lateral offset of the rear-left wheel encoder from the axle centre [m].
        laser_forward_m: a, laser position ahead of the rear axle [m].
        laser_left_m: b, laser position to the left of the vehicle's centre line [m].
    """

    wheelbase_m: float = 2.83
    encoder_offset_m: float = 0.76
    laser_forward_m: float = 3.78
    laser_left_m: float = 0.50

    def __post_init__(self) -> None:
        if not self.wheelbase_m > 0:
            raise ValueError("wheelbase_m must be positive")

    @property
    def rTl(self) -> np.ndarray:
        """(3,) pose of the laser in the rear-axle frame [m, m, rad]."""
        return np.array([self.laser_forward_m, self.laser_left_m, 0.0])


def rear_axle_velocities(
    encoder_speed_mps: np.ndarray, steering_rad: np.ndarray, geometry: AckermannGeometry
) -> tuple[np.ndarray, np.ndarray]:
    """Forward speed and yaw rate of the rear axle centre from encoder speed and steering.

    Args:
        encoder_speed_mps: (N,) speed measured at the rear-left wheel [m/s].
        steering_rad: (N,) steering angle alpha, positive to the left [rad].
        geometry: vehicle geometry.

    Returns:
        (v_c (N,) [m/s], omega (N,) [rad/s]):  v_c = v_e / (1 - tan(alpha) H / L) and
        omega = v_c tan(alpha) / L (Guivant & Nebot 2001).
    """
    tan_alpha = np.tan(np.asarray(steering_rad, dtype=float))
    L = geometry.wheelbase_m
    v_c = np.asarray(encoder_speed_mps, dtype=float) / (
        1.0 - tan_alpha * geometry.encoder_offset_m / L
    )
    return v_c, v_c * tan_alpha / L


def integrate_unicycle(
    stamps_s: np.ndarray,
    speed_mps: np.ndarray,
    yaw_rate_rps: np.ndarray,
    query_stamps_s: np.ndarray,
) -> np.ndarray:
    """Poses at ``query_stamps_s`` of a unicycle driven by piecewise-constant velocities.

    Sample k's (v_k, omega_k) holds from ``stamps_s[k]`` until ``stamps_s[k + 1]`` (the last one
    forever); before the first sample the vehicle stands still. Each constant-velocity piece is
    integrated in closed form (circular arc), so the result does not depend on step size.

    Args:
        stamps_s: (K,) non-decreasing sample times [s].
        speed_mps: (K,) forward speed [m/s].
        yaw_rate_rps: (K,) yaw rate, counter-clockwise [rad/s].
        query_stamps_s: (Q,) non-decreasing times at which poses are wanted [s].

    Returns:
        (Q, 3) poses [x, y, theta] in the frame of the pose at ``query_stamps_s[0]`` composed from
        the origin: pose 0 is [0, 0, 0]. Theta is continuous (not wrapped) so headings stay exact
        over long runs; wrap if needed.
    """
    stamps_s = np.asarray(stamps_s, dtype=float)
    query = np.asarray(query_stamps_s, dtype=float)
    if query.size == 0:
        return np.zeros((0, 3))
    # one timeline with every sample and query time; each interval uses the latest sample
    timeline = np.union1d(stamps_s[stamps_s > query[0]], query)
    timeline = timeline[timeline >= query[0]]
    starts = timeline[:-1]
    dt = np.diff(timeline)
    active = np.searchsorted(stamps_s, starts, side="right") - 1
    moving = active >= 0
    v = np.where(moving, np.asarray(speed_mps, dtype=float)[np.maximum(active, 0)], 0.0)
    w = np.where(moving, np.asarray(yaw_rate_rps, dtype=float)[np.maximum(active, 0)], 0.0)
    dtheta = w * dt
    theta = np.concatenate([[0.0], np.cumsum(dtheta)])
    # closed-form arc in the frame at the start of each piece: sin(phi)/phi, (1 - cos(phi))/phi
    arc = v * dt
    local_x = arc * np.sinc(dtheta / np.pi)
    local_y = arc * np.sin(dtheta / 2.0) * np.sinc(dtheta / (2.0 * np.pi))
    c, s = np.cos(theta[:-1]), np.sin(theta[:-1])
    x = np.concatenate([[0.0], np.cumsum(c * local_x - s * local_y)])
    y = np.concatenate([[0.0], np.cumsum(s * local_x + c * local_y)])
    index = np.searchsorted(timeline, query)
    return np.stack([x[index], y[index], theta[index]], axis=-1)


def integrate_ackermann(
    stamps_s: np.ndarray,
    encoder_speed_mps: np.ndarray,
    steering_rad: np.ndarray,
    query_stamps_s: np.ndarray,
    geometry: AckermannGeometry,
) -> np.ndarray:
    """Laser poses at ``query_stamps_s`` from the Guivant-Nebot Ackermann model.

    Args:
        stamps_s: (K,) sample times of the (speed, steering) stream [s].
        encoder_speed_mps: (K,) rear-left wheel speed v_e [m/s].
        steering_rad: (K,) steering angle alpha [rad].
        query_stamps_s: (Q,) non-decreasing times of the wanted poses [s].
        geometry: vehicle geometry (L, H, a, b).

    Returns:
        (Q, 3) poses ``wTl`` of the laser frame [x, y, theta], in a world frame whose origin is the
        rear axle centre at ``query_stamps_s[0]`` (so pose 0 is ``(a, b, 0)``); theta continuous.
    """
    v_c, omega = rear_axle_velocities(encoder_speed_mps, steering_rad, geometry)
    wTr = integrate_unicycle(stamps_s, v_c, omega, query_stamps_s)
    wTl = se2_compose(wTr, geometry.rTl)
    wTl[:, 2] = wTr[:, 2]  # keep the continuous heading (rTl has no rotation)
    return wTl
