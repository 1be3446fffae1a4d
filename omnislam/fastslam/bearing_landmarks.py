"""Bearing-only (omni camera) landmarks: stored rays, triangulation and first covariance.

The thesis's life cycle (sec. 4.4.1.1-4.4.1.2): a first sighting stores the ray -- viewpoint and
direction in the world, from the particle's pose (eq. 4.24); the first later sighting with
enough parallax triangulates the landmark (sec. 4.3, eq. 4.21 or least squares) and sets
Sigma = R Q R^T (eqs. 4.26-4.27) with Q the sensor noise over (d, theta, phi) (eq. 4.23) and R
the spherical-to-Cartesian Jacobian; later sightings update it by EKF (eqs. 4.29-4.37).

A bearing gives no range, so the range entry of Q comes from the triangulation geometry: two
rays with angular noise sigma and parallax gamma fix the distance d to about
sigma_d = sqrt(2) d sigma / sin(gamma) (the depth error of two-view triangulation).

Each ray enters two successive triangulations -- as the new ray, then as the stored previous
sighting (eq. 4.28) -- so the thesis's pseudo-measurements count its information twice and the
landmark covariance becomes overconfident (the thesis ignores this correlation). Q is therefore
multiplied by the number of triangulations a ray enters (``ray_reuse``, 2; 1 reproduces the
thesis as printed), the usual covariance inflation for information that is used more than once.
"""

from __future__ import annotations

import numpy as np

from omnislam.core.batch_linalg import rows_dot, rows_norm
from omnislam.core.measurement import RangeAzimuthElevation3D
from omnislam.core.se import se2_rotate_vectors
from omnislam.core.triangulation import triangulate_ground_plane, triangulate_midpoint
from omnislam.fastslam.config import TriangulationMethod

RAY_DIM = 6


def world_rays(wTr: np.ndarray, unit_vectors_r: np.ndarray, sensor_height_m: float) -> np.ndarray:
    """Rays in the world from robot-frame bearings (the stored sighting of thesis eq. 4.24).

    Args:
        wTr: (N, 3) poses.
        unit_vectors_r: (N, 3) unit bearings in the robot frame.
        sensor_height_m: height of the viewpoint above the ground [m].

    Returns:
        (N, 6) [origin_w (3), direction_w (3)].
    """
    direction = se2_rotate_vectors(wTr, unit_vectors_r)
    origin = np.stack([wTr[:, 0], wTr[:, 1], np.full(len(wTr), sensor_height_m)], axis=-1)
    return np.concatenate([origin, direction], axis=-1)


def triangulate(
    method: TriangulationMethod, rays_a: np.ndarray, rays_b: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Triangulate pairs of rays.

    Args:
        method: thesis eq. 4.21 (ground plane) or the least-squares midpoint.
        rays_a: (N, 6) first rays [origin, direction].
        rays_b: (N, 6) second rays [origin, direction].

    Returns:
        points_w (N, 3), valid (N,) and parallax (N,) [rad], the angle between the rays.
    """
    o1, d1, o2, d2 = rays_a[:, :3], rays_a[:, 3:], rays_b[:, :3], rays_b[:, 3:]
    if method is TriangulationMethod.GROUND_PLANE:
        points, valid = triangulate_ground_plane(o1, d1, o2, d2)
    else:
        points, valid = triangulate_midpoint(o1, d1, o2, d2)
    cosine = rows_dot(d1, d2) / (rows_norm(d1) * rows_norm(d2))
    parallax = np.arccos(np.clip(cosine, -1.0, 1.0))
    return points, valid & np.all(np.isfinite(points), axis=-1), parallax


def triangulated_measurement(
    model: RangeAzimuthElevation3D,
    wTr: np.ndarray,
    points_w: np.ndarray,
    sigma_rad: np.ndarray,
    parallax_rad: np.ndarray,
    ray_reuse: float = 1.0,
) -> tuple[np.ndarray, np.ndarray]:
    """The "measured" z = (d, theta, phi) of a triangulated point (thesis eq. 4.25) and its
    noise Q (eq. 4.23, diagonal; range std from the parallax, see the module docstring).

    Args:
        model: the range-azimuth-elevation model (sensor height).
        wTr: (N, 3) current poses.
        points_w: (N, 3) triangulated points.
        sigma_rad: (N,) angular std of the bearings.
        parallax_rad: (N,) angle between the two rays.
        ray_reuse: Q is multiplied by this, the number of triangulations each ray enters
            (module docstring); 1.0: the thesis's Q.

    Returns:
        z (N, 3) and Q (N, 3, 3).
    """
    z, _, _ = model.predict(wTr, points_w)
    sigma_d = np.sqrt(2.0) * z[:, 0] * sigma_rad / np.maximum(np.sin(parallax_rad), 1e-6)
    Q = np.zeros((len(z), 3, 3))
    Q[:, 0, 0] = sigma_d**2
    Q[:, 1, 1] = Q[:, 2, 2] = sigma_rad**2
    return z, ray_reuse * Q


def first_estimate(
    model: RangeAzimuthElevation3D, wTr: np.ndarray, z: np.ndarray, Q: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Thesis eqs. 4.26-4.27: mean = the triangulated point, Sigma = R Q R^T with R = dp/dz.

    Returns:
        means (N, 3) and covariances (N, 3, 3).
    """
    point, _, R = model.inverse(wTr, z)
    return point, R @ Q @ np.swapaxes(R, -1, -2)
