"""SE(2) / SE(3) helpers and angle wrapping, vectorised over leading axes.

Planar poses are arrays ``[..., 3]`` = [x, y, theta]; SE(3) poses are ``[..., 4, 4]``
homogeneous matrices. ``aTb`` maps points in frame b to frame a:  ``p_a = aTb p_b``.
"""

from __future__ import annotations

import numpy as np

#: 2 pi as used by ``wrap_angle``'s modulo.
_TWO_PI = 2.0 * np.pi
#: below this many elements one ``np.remainder`` pass is cheaper than the exact turn corrections
_WRAP_MASK_MIN_SIZE = 512


def wrap_angle(angle: np.ndarray | float) -> np.ndarray:
    """Wrap angles to [-pi, pi).

    The result is bit-for-bit ``(angle + pi) % (2 pi) - pi`` (numpy's floored modulo), in a new
    array (a numpy scalar for scalar input); see ``wrap_angle_inplace``.
    """
    shifted = np.asarray(angle, dtype=float) + np.pi
    if not isinstance(shifted, np.ndarray):  # 0-d input: numpy returned a scalar
        return shifted % _TWO_PI - np.pi
    return _unshift(shifted)


def wrap_angle_inplace(angle: np.ndarray) -> np.ndarray:
    """Wrap a float array to [-pi, pi) in place and return it (same values as ``wrap_angle``).

    For callers that own a temporary (a bearing just computed): saves the allocations.
    """
    angle += np.pi
    return _unshift(angle)


def _unshift(shifted: np.ndarray) -> np.ndarray:
    """``shifted % 2 pi - pi`` in place, for a float array ``shifted = angle + pi``.

    Float ``%`` costs ~10 ns per element; most angles handed to ``wrap_angle`` (bearings as
    differences of two wrapped angles, residuals, pose headings plus a small turn) are within
    one turn of the range. For those, floored modulo reduces to one exact subtraction or
    addition of 2 pi: ``fmod(s, 2 pi)`` is ``s - 2 pi`` for s in [2 pi, 4 pi) (exact by
    Sterbenz's lemma) and ``s`` for s in [-2 pi, 0), which numpy's ``%`` then shifts by
    ``+ 2 pi``; so ``s - k 2 pi`` with k in {-1, 0, 1} gives bit-for-bit the result of ``%``.
    Anything further out, and small arrays (where the two extra reductions do not pay), take
    the plain ``np.remainder``.
    """
    if shifted.size >= _WRAP_MASK_MIN_SIZE:
        low, high = shifted.min(), shifted.max()
        if low >= -_TWO_PI and high < 2.0 * _TWO_PI:  # False for NaN as well
            if low < 0.0 or high >= _TWO_PI:
                turns = np.subtract(shifted >= _TWO_PI, shifted < 0.0, dtype=float)
                turns *= _TWO_PI
                shifted -= turns
            shifted -= np.pi
            return shifted
    np.remainder(shifted, _TWO_PI, out=shifted)
    shifted -= np.pi
    return shifted


def se2_compose(aTb: np.ndarray, bTc: np.ndarray) -> np.ndarray:
    """aTc = aTb * bTc for planar poses [..., 3] (broadcasting)."""
    aTb = np.asarray(aTb, dtype=float)
    bTc = np.asarray(bTc, dtype=float)
    c, s = np.cos(aTb[..., 2]), np.sin(aTb[..., 2])
    x = aTb[..., 0] + c * bTc[..., 0] - s * bTc[..., 1]
    y = aTb[..., 1] + s * bTc[..., 0] + c * bTc[..., 1]
    theta = wrap_angle(aTb[..., 2] + bTc[..., 2])
    return np.stack(np.broadcast_arrays(x, y, theta), axis=-1)


def se2_integrate(deltas_r: np.ndarray, wT0: np.ndarray | None = None) -> np.ndarray:
    """Dead reckoning: the poses wT0, wT0 * d_1, wT0 * d_1 * d_2, ... of odometry steps.

    The one integration of odometry in the package (dead reckoning, the graphs' initial guess,
    the front end's predicted poses). ``deltas_r[0]`` is the step *into* the first frame and is
    not applied: frame 0 sits at ``wT0`` (``FrameInput`` convention).

    Args:
        deltas_r: (N, 3) robot-frame steps [dx, dy, dtheta] into each frame.
        wT0: (3,) pose of frame 0 in the world; the origin by default.

    Returns:
        (N, 3) poses of the frames in the world [x, y, theta].
    """
    deltas = np.asarray(deltas_r, dtype=float).reshape(-1, 3)
    poses = np.empty_like(deltas)
    if not len(deltas):
        return poses
    poses[0] = np.zeros(3) if wT0 is None else np.asarray(wT0, dtype=float).reshape(3)
    for k in range(1, len(deltas)):  # sequential: each pose depends on the last
        poses[k] = se2_compose(poses[k - 1], deltas[k])
    return poses


def se2_inverse(aTb: np.ndarray) -> np.ndarray:
    """bTa for planar poses [..., 3]."""
    aTb = np.asarray(aTb, dtype=float)
    c, s = np.cos(aTb[..., 2]), np.sin(aTb[..., 2])
    x = -c * aTb[..., 0] - s * aTb[..., 1]
    y = s * aTb[..., 0] - c * aTb[..., 1]
    return np.stack([x, y, wrap_angle(-aTb[..., 2])], axis=-1)


def se2_between(wTa: np.ndarray, wTb: np.ndarray) -> np.ndarray:
    """aTb = inverse(wTa) * wTb: the pose of b seen from a (odometry between two poses)."""
    return se2_compose(se2_inverse(wTa), wTb)


def se2_compose_jacobians(aTb: np.ndarray, bTc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians of ``se2_compose`` w.r.t. the vector parameters of ``aTb`` and of ``bTc``.

    Returns:
        (J_a, J_b), each [..., 3, 3], derivatives of [x, y, theta] of aTc with respect to
        [x, y, theta] of aTb and of bTc (additive parameterisation, as used by the EKFs).
    """
    aTb = np.asarray(aTb, dtype=float)
    bTc = np.asarray(bTc, dtype=float)
    shape = np.broadcast_shapes(aTb.shape, bTc.shape)[:-1]
    c, s = np.cos(aTb[..., 2]), np.sin(aTb[..., 2])
    bx, by = bTc[..., 0], bTc[..., 1]
    J_a = np.zeros((*shape, 3, 3))
    J_a[..., 0, 0] = 1.0
    J_a[..., 1, 1] = 1.0
    J_a[..., 2, 2] = 1.0
    J_a[..., 0, 2] = -s * bx - c * by
    J_a[..., 1, 2] = c * bx - s * by
    J_b = np.zeros((*shape, 3, 3))
    J_b[..., 0, 0] = c
    J_b[..., 0, 1] = -s
    J_b[..., 1, 0] = s
    J_b[..., 1, 1] = c
    J_b[..., 2, 2] = 1.0
    return J_a, J_b


def se2_to_matrix(aTb: np.ndarray) -> np.ndarray:
    """[..., 3] planar poses -> [..., 3, 3] homogeneous matrices."""
    aTb = np.asarray(aTb, dtype=float)
    c, s = np.cos(aTb[..., 2]), np.sin(aTb[..., 2])
    out = np.zeros((*aTb.shape[:-1], 3, 3))
    out[..., 0, 0], out[..., 0, 1], out[..., 0, 2] = c, -s, aTb[..., 0]
    out[..., 1, 0], out[..., 1, 1], out[..., 1, 2] = s, c, aTb[..., 1]
    out[..., 2, 2] = 1.0
    return out


def se2_from_matrix(aTb: np.ndarray) -> np.ndarray:
    """[..., 3, 3] homogeneous matrices -> [..., 3] planar poses."""
    aTb = np.asarray(aTb, dtype=float)
    theta = np.arctan2(aTb[..., 1, 0], aTb[..., 0, 0])
    return np.stack([aTb[..., 0, 2], aTb[..., 1, 2], theta], axis=-1)


def se2_transform_points(aTb: np.ndarray, points_b: np.ndarray) -> np.ndarray:
    """Map 2-D points [..., 2] from frame b to frame a."""
    aTb = np.asarray(aTb, dtype=float)
    points_b = np.asarray(points_b, dtype=float)
    c, s = np.cos(aTb[..., 2]), np.sin(aTb[..., 2])
    x = aTb[..., 0] + c * points_b[..., 0] - s * points_b[..., 1]
    y = aTb[..., 1] + s * points_b[..., 0] + c * points_b[..., 1]
    return np.stack([x, y], axis=-1)


def se2_rotate_vectors(aTb: np.ndarray, vectors_b: np.ndarray) -> np.ndarray:
    """Rotate 3-D vectors [..., 3] from planar frame b into frame a (about z; z unchanged).

    The direction part of a bearing seen from a robot at pose ``aTb`` = [x, y, theta]; the
    translation is not applied (directions, not points).
    """
    aTb = np.asarray(aTb, dtype=float)
    v = np.asarray(vectors_b, dtype=float)
    c, s = np.cos(aTb[..., 2]), np.sin(aTb[..., 2])
    x = c * v[..., 0] - s * v[..., 1]
    y = s * v[..., 0] + c * v[..., 1]
    return np.stack([x, y, v[..., 2]], axis=-1)


def se3_from_se2(aTb: np.ndarray, z: np.ndarray | float = 0.0) -> np.ndarray:
    """Planar poses [..., 3] -> SE(3) [..., 4, 4] with rotation about z and height ``z``."""
    aTb = np.asarray(aTb, dtype=float)
    c, s = np.cos(aTb[..., 2]), np.sin(aTb[..., 2])
    out = np.zeros((*aTb.shape[:-1], 4, 4))
    out[..., 0, 0], out[..., 0, 1], out[..., 0, 3] = c, -s, aTb[..., 0]
    out[..., 1, 0], out[..., 1, 1], out[..., 1, 3] = s, c, aTb[..., 1]
    out[..., 2, 2] = 1.0
    out[..., 2, 3] = z
    out[..., 3, 3] = 1.0
    return out


def se2_from_se3(aTb: np.ndarray) -> np.ndarray:
    """SE(3) [..., 4, 4] -> planar [..., 3]: x, y and the yaw of the rotated x axis."""
    aTb = np.asarray(aTb, dtype=float)
    yaw = np.arctan2(aTb[..., 1, 0], aTb[..., 0, 0])
    return np.stack([aTb[..., 0, 3], aTb[..., 1, 3], yaw], axis=-1)


def se3_inverse(aTb: np.ndarray) -> np.ndarray:
    """bTa for SE(3) [..., 4, 4]."""
    aTb = np.asarray(aTb, dtype=float)
    R = aTb[..., :3, :3]
    t = aTb[..., :3, 3]
    out = np.zeros_like(aTb)
    Rt = np.swapaxes(R, -1, -2)
    out[..., :3, :3] = Rt
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", Rt, t)
    out[..., 3, 3] = 1.0
    return out


def se3_transform_points(aTb: np.ndarray, points_b: np.ndarray) -> np.ndarray:
    """Map 3-D points [..., 3] from frame b to frame a."""
    aTb = np.asarray(aTb, dtype=float)
    return np.einsum("...ij,...j->...i", aTb[..., :3, :3], points_b) + aTb[..., :3, 3]


def _rotation() -> type:
    """scipy's ``Rotation``, imported on first use: importing ``scipy.spatial`` takes ~0.2 s,
    which every process that only needs SE(2) (the front end's image workers) would pay."""
    from scipy.spatial.transform import Rotation

    return Rotation


def se3_from_xyz_quat(xyz: np.ndarray, quat_wxyz: np.ndarray) -> np.ndarray:
    """Positions [..., 3] and unit quaternions [..., 4] (w, x, y, z) -> SE(3) [..., 4, 4]."""
    xyz = np.asarray(xyz, dtype=float)
    quat_wxyz = np.asarray(quat_wxyz, dtype=float)
    flat = quat_wxyz.reshape(-1, 4)
    R = _rotation().from_quat(flat[:, [1, 2, 3, 0]]).as_matrix()
    R = R.reshape(*quat_wxyz.shape[:-1], 3, 3)
    out = np.zeros((*xyz.shape[:-1], 4, 4))
    out[..., :3, :3] = R
    out[..., :3, 3] = xyz
    out[..., 3, 3] = 1.0
    return out


def quat_wxyz_from_se3(aTb: np.ndarray) -> np.ndarray:
    """SE(3) [..., 4, 4] -> unit quaternions [..., 4] (w, x, y, z) with w >= 0."""
    aTb = np.asarray(aTb, dtype=float)
    flat = aTb[..., :3, :3].reshape(-1, 3, 3)
    xyzw = _rotation().from_matrix(flat).as_quat()
    wxyz = xyzw[:, [3, 0, 1, 2]]
    wxyz *= np.where(wxyz[:, :1] < 0, -1.0, 1.0)
    return wxyz.reshape(*aTb.shape[:-2], 4)


def se3_exp(xi: np.ndarray) -> np.ndarray:
    """Exponential map [..., 6] = [rho (translation), phi (rotation vector)] -> SE(3)."""
    xi = np.asarray(xi, dtype=float)
    flat = xi.reshape(-1, 6)
    rho, phi = flat[:, :3], flat[:, 3:]
    R = _rotation().from_rotvec(phi).as_matrix()
    theta = np.linalg.norm(phi, axis=1)
    K = _hat(phi)
    small = theta < 1e-8
    th = np.where(small, 1.0, theta)
    a = np.where(small, 0.5, (1.0 - np.cos(th)) / th**2)
    b = np.where(small, 1.0 / 6.0, (th - np.sin(th)) / th**3)
    V = np.eye(3) + a[:, None, None] * K + b[:, None, None] * (K @ K)
    out = np.zeros((flat.shape[0], 4, 4))
    out[:, :3, :3] = R
    out[:, :3, 3] = np.einsum("nij,nj->ni", V, rho)
    out[:, 3, 3] = 1.0
    return out.reshape(*xi.shape[:-1], 4, 4)


def se3_log(aTb: np.ndarray) -> np.ndarray:
    """Logarithm map SE(3) [..., 4, 4] -> [..., 6] = [rho, phi] (inverse of ``se3_exp``)."""
    aTb = np.asarray(aTb, dtype=float)
    flat = aTb.reshape(-1, 4, 4)
    phi = _rotation().from_matrix(flat[:, :3, :3]).as_rotvec()
    theta = np.linalg.norm(phi, axis=1)
    K = _hat(phi)
    small = theta < 1e-8
    th = np.where(small, 1.0, theta)
    c = np.where(small, 1.0 / 12.0, (1.0 - th * np.sin(th) / (2.0 * (1.0 - np.cos(th)))) / th**2)
    V_inv = np.eye(3) - 0.5 * K + c[:, None, None] * (K @ K)
    rho = np.einsum("nij,nj->ni", V_inv, flat[:, :3, 3])
    return np.concatenate([rho, phi], axis=1).reshape(*aTb.shape[:-2], 6)


def _hat(v: np.ndarray) -> np.ndarray:
    """[N, 3] vectors -> [N, 3, 3] skew-symmetric matrices."""
    out = np.zeros((v.shape[0], 3, 3))
    out[:, 0, 1], out[:, 0, 2] = -v[:, 2], v[:, 1]
    out[:, 1, 0], out[:, 1, 2] = v[:, 2], -v[:, 0]
    out[:, 2, 0], out[:, 2, 1] = -v[:, 1], v[:, 0]
    return out
