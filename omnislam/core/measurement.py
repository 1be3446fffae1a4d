"""Measurement models with analytic Jacobians, shared by every estimator and the simulator.

Every model maps a planar robot pose ``wTr = [x, y, theta]`` (world frame) and a landmark
position in the world to a measurement in the robot frame, vectorised over leading axes:

* ``RangeBearing2D``      z = (range, bearing)                 landmark (x, y)
* ``Bearing2D``           z = (bearing,)                       landmark (x, y)
* ``BearingElevation3D``  z = (azimuth, elevation)             landmark (x, y, z)
* ``RangeAzimuthElevation3D`` z = (d, theta, phi), thesis eqs. 4.25 / 4.31   landmark (x, y, z)

``predict`` returns (z, H_pose, H_landmark), or (z, None, None) with ``jacobians=False`` (for
callers that only need the predicted measurement); ``residual`` wraps the angular components;
``inverse`` gives the landmark from a pose and a measurement with its Jacobians (for landmark
initialisation and EKF augmentation). ``MeasurementModel`` is the protocol the shared Gaussian
algebra (``core.kalman``) takes. The 3-D models take the sensor's height above the ground
plane (``sensor_height_m``): the omni camera's single viewpoint is not on the floor.

Errata of the thesis (SEEDS.md): the printed Jacobian (4.32) mixes q = |delta|^2 and
d = dx^2 + dy^2 and has sign slips in its first and last rows; (4.26) has a garbled third row.
The derivatives below are derived from (4.31) and checked against numerical ones in the tests.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from omnislam.core.se import wrap_angle, wrap_angle_inplace

_EPS = 1e-12


class MeasurementModel(Protocol):
    """What the shared Gaussian algebra (``core.kalman``, FastSLAM's proposal and association,
    EKF-SLAM, the UKF's residuals) needs from a measurement model: every model of this module,
    or any other with the same shapes (a linear test model).

    Attributes:
        dim_z: the measurement's dimension k.
    """

    @property
    def dim_z(self) -> int: ...

    def predict(self, wTr: np.ndarray, landmarks_w: np.ndarray) -> tuple[np.ndarray, ...]:
        """z [..., k], H_pose [..., k, 3] and H_landmark [..., k, d] of poses [..., 3] and
        landmarks [..., d]."""
        ...

    def residual(self, z_measured: np.ndarray, z_predicted: np.ndarray) -> np.ndarray:
        """z_measured - z_predicted [..., k], angular components wrapped."""
        ...


def _deltas(wTr: np.ndarray, landmarks_w: np.ndarray, height: float = 0.0) -> tuple:
    wTr = np.asarray(wTr, dtype=float)
    landmarks_w = np.asarray(landmarks_w, dtype=float)
    dx = landmarks_w[..., 0] - wTr[..., 0]
    dy = landmarks_w[..., 1] - wTr[..., 1]
    dz = landmarks_w[..., 2] - height if landmarks_w.shape[-1] > 2 else None
    return wTr, dx, dy, dz


def unit_vectors_from_azimuth_elevation(azimuth: np.ndarray, elevation: np.ndarray) -> np.ndarray:
    """Azimuth / elevation [rad] -> unit vectors [..., 3] (x forward, y left, z up)."""
    azimuth = np.asarray(azimuth, dtype=float)
    elevation = np.asarray(elevation, dtype=float)
    ce = np.cos(elevation)
    return np.stack([ce * np.cos(azimuth), ce * np.sin(azimuth), np.sin(elevation)], axis=-1)


def azimuth_elevation_from_unit_vectors(vectors: np.ndarray) -> np.ndarray:
    """Vectors [..., 3] (any norm > 0) -> [..., 2] = (azimuth, elevation) [rad]."""
    vectors = np.asarray(vectors, dtype=float)
    azimuth = np.arctan2(vectors[..., 1], vectors[..., 0])
    elevation = np.arctan2(vectors[..., 2], np.hypot(vectors[..., 0], vectors[..., 1]))
    return np.stack([azimuth, elevation], axis=-1)


@dataclass(frozen=True, slots=True)
class RangeBearing2D:
    """z = (range, bearing) of a 2-D point landmark (SLAM for Dummies; Thrun et al. eq. 6.40)."""

    dim_z: int = 2
    dim_landmark: int = 2
    angular: tuple[bool, ...] = (False, True)

    def predict(
        self, wTr: np.ndarray, landmarks_w: np.ndarray, *, jacobians: bool = True
    ) -> tuple[np.ndarray, ...]:
        """Args: wTr [..., 3]; landmarks_w [..., 2] (or [..., 3], z ignored).

        Returns:
            z [..., 2], H_pose [..., 2, 3] = dz/d(x, y, theta), H_landmark [..., 2, 2];
            the Jacobians are None with ``jacobians=False``. The Jacobians are views of
            entry-major arrays (not C-contiguous).
        """
        # a hot path of FastSLAM: written with in-place ufuncs into the output arrays, same
        # operations (and so bit-for-bit the same numbers) as the textbook expressions
        # q = max(dx^2 + dy^2, eps), z = (sqrt(q), wrap(atan2(dy, dx) - theta)),
        # H_l = [[dx, dy] / r, [-dy, dx] / q], H_p = [-H_l | (0, -1)^T]
        wTr, dx, dy, _ = _deltas(wTr, landmarks_w)
        shape = np.shape(dx)
        q = np.multiply(dx, dx, out=np.empty(shape))
        q += dy * dy
        np.maximum(q, _EPS, out=q)
        r = np.sqrt(q)
        bearing = np.arctan2(dy, dx, out=np.empty(shape))  # contiguous: wrapped faster
        bearing -= wTr[..., 2]
        z = np.empty((*shape, 2))
        z[..., 0] = r
        z[..., 1] = wrap_angle_inplace(bearing)
        if not jacobians:
            return z, None, None
        # The Jacobians are filled entry by entry in entry-major memory (2, c, ...), each entry
        # one contiguous stretch, and returned as [..., 2, c] views of it: the values are the
        # same, and the entry-major algebra (``core.batch_linalg``) then gets them without a copy.
        H_l = np.empty((2, 2, *shape))
        np.divide(dx, r, out=H_l[0, 0, ...])
        np.divide(dy, r, out=H_l[0, 1, ...])
        np.divide(dy, q, out=H_l[1, 0, ...])
        np.negative(H_l[1, 0, ...], out=H_l[1, 0, ...])
        np.divide(dx, q, out=H_l[1, 1, ...])
        H_p = np.empty((2, 3, *shape))
        np.negative(H_l, out=H_p[:, :2])
        H_p[0, 2] = 0.0
        H_p[1, 2] = -1.0
        stack_axes = (*range(2, len(shape) + 2), 0, 1)
        return z, H_p.transpose(stack_axes), H_l.transpose(stack_axes)

    def residual(self, z_measured: np.ndarray, z_predicted: np.ndarray) -> np.ndarray:
        return _residual(z_measured, z_predicted, self.angular)

    def inverse(self, wTr: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, ...]:
        """Landmark [..., 2] from a pose and (range, bearing).

        Returns:
            landmark [..., 2], J_pose [..., 2, 3], J_z [..., 2, 2].
        """
        wTr = np.asarray(wTr, dtype=float)
        z = np.asarray(z, dtype=float)
        r, heading = z[..., 0], wTr[..., 2] + z[..., 1]
        c, s = np.cos(heading), np.sin(heading)
        landmark = np.stack([wTr[..., 0] + r * c, wTr[..., 1] + r * s], axis=-1)
        shape = landmark.shape[:-1]
        J_p = np.zeros((*shape, 2, 3))
        J_p[..., 0, 0] = J_p[..., 1, 1] = 1.0
        J_p[..., 0, 2], J_p[..., 1, 2] = -r * s, r * c
        J_z = np.empty((*shape, 2, 2))
        J_z[..., 0, 0], J_z[..., 0, 1] = c, -r * s
        J_z[..., 1, 0], J_z[..., 1, 1] = s, r * c
        return landmark, J_p, J_z


@dataclass(frozen=True, slots=True)
class Bearing2D:
    """z = (bearing,) of a 2-D point landmark: a vertical line seen by a camera (Barra & Costa)."""

    dim_z: int = 1
    dim_landmark: int = 2
    angular: tuple[bool, ...] = (True,)

    def predict(
        self, wTr: np.ndarray, landmarks_w: np.ndarray, *, jacobians: bool = True
    ) -> tuple[np.ndarray, ...]:
        """Returns z [..., 1], H_pose [..., 1, 3], H_landmark [..., 1, 2] (None, None with
        ``jacobians=False``)."""
        wTr, dx, dy, _ = _deltas(wTr, landmarks_w)
        z = wrap_angle(np.arctan2(dy, dx) - wTr[..., 2])[..., None]
        if not jacobians:
            return z, None, None
        q = np.maximum(dx * dx + dy * dy, _EPS)
        H_l = np.stack([-dy / q, dx / q], axis=-1)[..., None, :]
        H_p = np.concatenate([-H_l, -np.ones((*z.shape[:-1], 1, 1))], axis=-1)
        return z, H_p, H_l

    def residual(self, z_measured: np.ndarray, z_predicted: np.ndarray) -> np.ndarray:
        return _residual(z_measured, z_predicted, self.angular)

    def inverse(self, wTr: np.ndarray, z: np.ndarray, range_m: np.ndarray) -> np.ndarray:
        """Landmark [..., 2] at ``range_m`` along the bearing (a bearing alone fixes no depth)."""
        wTr = np.asarray(wTr, dtype=float)
        heading = wTr[..., 2] + np.asarray(z, dtype=float)[..., 0]
        return np.stack(
            [wTr[..., 0] + range_m * np.cos(heading), wTr[..., 1] + range_m * np.sin(heading)],
            axis=-1,
        )


@dataclass(frozen=True, slots=True)
class BearingElevation3D:
    """z = (azimuth, elevation) of a 3-D point seen from a planar pose at a sensor height.

    The omni camera's bearing: azimuth counter-clockwise from the heading, elevation above the
    horizontal plane through the single viewpoint at (x, y, sensor_height_m).
    """

    sensor_height_m: float = 0.0
    dim_z: int = 2
    dim_landmark: int = 3
    angular: tuple[bool, ...] = (True, True)

    def predict(
        self, wTr: np.ndarray, landmarks_w: np.ndarray, *, jacobians: bool = True
    ) -> tuple[np.ndarray, ...]:
        """Returns z [..., 2], H_pose [..., 2, 3], H_landmark [..., 2, 3] (None, None with
        ``jacobians=False``)."""
        wTr, dx, dy, dz = _deltas(wTr, landmarks_w, self.sensor_height_m)
        rho2 = np.maximum(dx * dx + dy * dy, _EPS)
        rho = np.sqrt(rho2)
        d2 = rho2 + dz * dz
        z = np.stack([wrap_angle(np.arctan2(dy, dx) - wTr[..., 2]), np.arctan2(dz, rho)], axis=-1)
        if not jacobians:
            return z, None, None
        H_l = np.zeros((*z.shape[:-1], 2, 3))
        H_l[..., 0, 0], H_l[..., 0, 1] = -dy / rho2, dx / rho2
        H_l[..., 1, 0] = -dz * dx / (rho * d2)
        H_l[..., 1, 1] = -dz * dy / (rho * d2)
        H_l[..., 1, 2] = rho / d2
        H_p = np.zeros((*z.shape[:-1], 2, 3))
        H_p[..., :, :2] = -H_l[..., :, :2]
        H_p[..., 0, 2] = -1.0
        return z, H_p, H_l

    def residual(self, z_measured: np.ndarray, z_predicted: np.ndarray) -> np.ndarray:
        return _residual(z_measured, z_predicted, self.angular)

    def inverse(self, wTr: np.ndarray, z: np.ndarray, range_m: np.ndarray) -> np.ndarray:
        """Landmark [..., 3] at ``range_m`` from the viewpoint along (azimuth, elevation)."""
        wTr = np.asarray(wTr, dtype=float)
        z = np.asarray(z, dtype=float)
        ray = unit_vectors_from_azimuth_elevation(wTr[..., 2] + z[..., 0], z[..., 1])
        origin = np.stack(
            np.broadcast_arrays(wTr[..., 0], wTr[..., 1], self.sensor_height_m), axis=-1
        )
        return origin + np.asarray(range_m, dtype=float)[..., None] * ray


@dataclass(frozen=True, slots=True)
class RangeAzimuthElevation3D:
    """z = (d, theta, phi) of thesis eqs. 4.25 / 4.31: distance, azimuth, elevation."""

    sensor_height_m: float = 0.0
    dim_z: int = 3
    dim_landmark: int = 3
    angular: tuple[bool, ...] = (False, True, True)

    def predict(
        self, wTr: np.ndarray, landmarks_w: np.ndarray, *, jacobians: bool = True
    ) -> tuple[np.ndarray, ...]:
        """Thesis eq. 4.31 and its Jacobian (eq. 4.32, corrected; see module docstring).

        Returns:
            z [..., 3], H_pose [..., 3, 3] = dz/d(x, y, theta), H_landmark [..., 3, 3];
            the Jacobians are None with ``jacobians=False``.
        """
        wTr, dx, dy, dz = _deltas(wTr, landmarks_w, self.sensor_height_m)
        rho2 = np.maximum(dx * dx + dy * dy, _EPS)
        rho = np.sqrt(rho2)
        d2 = rho2 + dz * dz
        d = np.sqrt(d2)
        z = np.stack(
            [d, wrap_angle(np.arctan2(dy, dx) - wTr[..., 2]), np.arctan2(dz, rho)], axis=-1
        )
        if not jacobians:
            return z, None, None
        H_l = np.zeros((*z.shape[:-1], 3, 3))
        H_l[..., 0, 0], H_l[..., 0, 1], H_l[..., 0, 2] = dx / d, dy / d, dz / d
        H_l[..., 1, 0], H_l[..., 1, 1] = -dy / rho2, dx / rho2
        H_l[..., 2, 0] = -dz * dx / (rho * d2)
        H_l[..., 2, 1] = -dz * dy / (rho * d2)
        H_l[..., 2, 2] = rho / d2
        H_p = np.zeros((*z.shape[:-1], 3, 3))
        H_p[..., :, :2] = -H_l[..., :, :2]
        H_p[..., 1, 2] = -1.0
        return z, H_p, H_l

    def residual(self, z_measured: np.ndarray, z_predicted: np.ndarray) -> np.ndarray:
        return _residual(z_measured, z_predicted, self.angular)

    def inverse(self, wTr: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, ...]:
        """Landmark [..., 3] from (d, theta, phi) with J_pose [..., 3, 3] and J_z [..., 3, 3].

        J_z is the spherical-to-Cartesian Jacobian R of thesis eq. 4.26 (corrected), so a
        first landmark covariance is ``J_z Q J_z^T`` (eq. 4.27).
        """
        wTr = np.asarray(wTr, dtype=float)
        z = np.asarray(z, dtype=float)
        d, azimuth, phi = z[..., 0], wTr[..., 2] + z[..., 1], z[..., 2]
        ca, sa, cp, sp = np.cos(azimuth), np.sin(azimuth), np.cos(phi), np.sin(phi)
        landmark = np.stack(
            [
                wTr[..., 0] + d * ca * cp,
                wTr[..., 1] + d * sa * cp,
                self.sensor_height_m + d * sp,
            ],
            axis=-1,
        )
        shape = landmark.shape[:-1]
        J_z = np.empty((*shape, 3, 3))
        J_z[..., 0, 0], J_z[..., 0, 1], J_z[..., 0, 2] = ca * cp, -d * sa * cp, -d * ca * sp
        J_z[..., 1, 0], J_z[..., 1, 1], J_z[..., 1, 2] = sa * cp, d * ca * cp, -d * sa * sp
        J_z[..., 2, 0], J_z[..., 2, 1], J_z[..., 2, 2] = sp, 0.0, d * cp
        J_p = np.zeros((*shape, 3, 3))
        J_p[..., 0, 0] = J_p[..., 1, 1] = 1.0
        J_p[..., :, 2] = J_z[..., :, 1]
        return landmark, J_p, J_z


def _residual(
    z_measured: np.ndarray, z_predicted: np.ndarray, angular: tuple[bool, ...]
) -> np.ndarray:
    """z_measured - z_predicted with angular components wrapped to [-pi, pi)."""
    r = np.asarray(z_measured, dtype=float) - np.asarray(z_predicted, dtype=float)
    if np.ndim(r) == 0 or r.shape[-1] != len(angular):  # broadcasts against the mask
        mask = np.asarray(angular)
        return np.where(mask, wrap_angle(r), r)
    for i, is_angle in enumerate(angular):  # r is a new array: wrap its angle columns in place
        if is_angle:
            wrap_angle_inplace(r[..., i])
    return r
