"""Landmark positions from two or more rays (thesis section 4.3).

* ``triangulate_ground_plane``: the thesis's two-ray method, eq. 4.21: both rays are projected
  onto the ground plane, the 2-D lines are intersected for (x, y), and z is the mean of the two
  rays' heights there. Simple, but it ignores the elevation information in (x, y) and fails
  for rays whose ground projections are (nearly) parallel, e.g. a landmark straight ahead.
* ``triangulate_midpoint``: the midpoint of the shortest segment between two 3-D rays.
* ``triangulate_rays``: least squares over any number of rays (minimises the sum of squared
  perpendicular distances), with the smallest eigenvalue of the normal matrix as conditioning.
* ``floor_points_r``: one ray and the floor plane, for a viewpoint at a known height.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from omnislam.core.batch_linalg import rows_dot, rows_norm

#: rays whose (ground-projected) directions are closer to parallel than this are rejected
PARALLEL_SIN = 1e-9


def triangulate_ground_plane(
    origins1_w: np.ndarray, rays1_w: np.ndarray, origins2_w: np.ndarray, rays2_w: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Thesis eq. 4.21 (z read as the mean of the two rays' heights, see SEEDS.md errata).

    Args:
        origins1_w: [..., 3] origins of the first rays (sensor viewpoints) in the world [m].
        origins2_w: [..., 3] origins of the second rays in the world [m].
        rays1_w: [..., 3] directions of the first rays in the world (any positive norm).
        rays2_w: [..., 3] directions of the second rays in the world (any positive norm).

    Returns:
        points_w [..., 3] and valid [...] (False where the ground projections are parallel or
        the intersection lies behind either origin).
    """
    o1 = np.asarray(origins1_w, dtype=float)
    d1 = np.asarray(rays1_w, dtype=float)
    o2 = np.asarray(origins2_w, dtype=float)
    d2 = np.asarray(rays2_w, dtype=float)
    # o1 + t1 d1 = o2 + t2 d2 in x, y:  [d1 -d2] [t1 t2]^T = o2 - o1
    det = -d1[..., 0] * d2[..., 1] + d1[..., 1] * d2[..., 0]
    norm = np.hypot(d1[..., 0], d1[..., 1]) * np.hypot(d2[..., 0], d2[..., 1])
    parallel = np.abs(det) <= PARALLEL_SIN * np.maximum(norm, 1e-300)
    safe = np.where(parallel, 1.0, det)
    bx, by = o2[..., 0] - o1[..., 0], o2[..., 1] - o1[..., 1]
    t1 = (-bx * d2[..., 1] + by * d2[..., 0]) / safe
    t2 = (d1[..., 0] * by - d1[..., 1] * bx) / safe
    x = o1[..., 0] + t1 * d1[..., 0]
    y = o1[..., 1] + t1 * d1[..., 1]
    z = 0.5 * ((o1[..., 2] + t1 * d1[..., 2]) + (o2[..., 2] + t2 * d2[..., 2]))
    valid = ~parallel & (t1 > 0) & (t2 > 0)
    return np.stack([x, y, z], axis=-1), valid


def triangulate_midpoint(
    origins1_w: np.ndarray, rays1_w: np.ndarray, origins2_w: np.ndarray, rays2_w: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Midpoint of the common perpendicular of two 3-D rays.

    Returns:
        points_w [..., 3] and valid [...] (False for parallel rays or negative depths).
    """
    o1 = np.asarray(origins1_w, dtype=float)
    o2 = np.asarray(origins2_w, dtype=float)
    d1 = np.asarray(rays1_w, dtype=float)
    d2 = np.asarray(rays2_w, dtype=float)
    d1 = d1 / rows_norm(d1)[..., None]
    d2 = d2 / rows_norm(d2)[..., None]
    w = o1 - o2
    b = rows_dot(d1, d2)
    d = rows_dot(d1, w)
    e = rows_dot(d2, w)
    denom = 1.0 - b * b
    parallel = denom <= PARALLEL_SIN
    safe = np.where(parallel, 1.0, denom)
    t1 = (b * e - d) / safe
    t2 = (e - b * d) / safe
    points = 0.5 * ((o1 + t1[..., None] * d1) + (o2 + t2[..., None] * d2))
    return points, ~parallel & (t1 > 0) & (t2 > 0)


@dataclass(frozen=True, slots=True)
class RayTriangulation:
    """Result of ``triangulate_rays``.

    Attributes:
        point_w: (3,) the least-squares point [m].
        min_eigenvalue: smallest eigenvalue of sum(I - d d^T); ~0 means the rays are parallel.
        parallax_rad: largest angle between any two of the rays.
        depths_m: (K,) signed distance of the point along each ray.
    """

    point_w: np.ndarray
    min_eigenvalue: float
    parallax_rad: float
    depths_m: np.ndarray

    @property
    def in_front(self) -> bool:
        """True when the point lies in front of every ray origin."""
        return bool(np.all(self.depths_m > 0))


def triangulate_rays(origins_w: np.ndarray, rays_w: np.ndarray) -> RayTriangulation:
    """Least-squares intersection of K >= 2 rays.

    Minimises sum_k |(I - d_k d_k^T)(p - o_k)|^2, i.e. solves
    [sum (I - d d^T)] p = sum (I - d d^T) o.

    Args:
        origins_w: (K, 3) ray origins [m].
        rays_w: (K, 3) ray directions (any positive norm).
    """
    origins_w = np.asarray(origins_w, dtype=float)
    d = np.asarray(rays_w, dtype=float)
    if origins_w.shape != d.shape or origins_w.ndim != 2 or origins_w.shape[0] < 2:
        raise ValueError("triangulate_rays needs (K, 3) origins and rays with K >= 2")
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    projectors = np.eye(3) - d[:, :, None] * d[:, None, :]
    A = projectors.sum(axis=0)
    b = np.einsum("kij,kj->i", projectors, origins_w)
    eigenvalues = np.linalg.eigvalsh(A)
    point = np.linalg.lstsq(A, b, rcond=None)[0]
    cosines = np.clip(d @ d.T, -1.0, 1.0)
    return RayTriangulation(
        point_w=point,
        min_eigenvalue=float(eigenvalues[0]),
        parallax_rad=float(np.arccos(cosines.min())),
        depths_m=np.einsum("ki,ki->k", point - origins_w, d),
    )


def floor_points_r(
    unit_vectors_r: np.ndarray, sigmas_rad: np.ndarray, height_m: float
) -> tuple[np.ndarray, np.ndarray]:
    """Bearings pointing below the horizon intersected with the floor plane, from a viewpoint
    ``height_m`` above it (``graphslam.floor_scale``, ``frontend.floor_tracks``).

    Args:
        unit_vectors_r: (M, 3) unit bearings in the robot frame, u_z < 0.
        sigmas_rad: (M,) their angular stds [rad].
        height_m: the viewpoint's height above the floor [m].

    Returns:
        (M, 2) floor points in the robot frame, ``h u_xy / -u_z`` [m], and (M,) their radial
        stds ``h sigma / sin^2(depression)`` [m].
    """
    u = np.asarray(unit_vectors_r, dtype=float)
    depth = height_m / -u[:, 2]
    return u[:, :2] * depth[:, None], height_m * np.asarray(sigmas_rad) / u[:, 2] ** 2
