"""The pose uncertainty accumulated since each landmark was last seen, for re-association.

FastSLAM's per-particle association of a sighting of unknown id (Montemerlo 2003 sec. 3.4.1)
compares it with each landmark of the particle's map under S = H_m Sigma H_m^T (+ H_x P H_x^T)
+ R: the landmark's own covariance and, for FastSLAM 2.0, one step's motion noise. Conditional
on the particle's path that is right, but after resampling has narrowed the set onto a few
ancestors (MR.CLAM: pose NEES 1e7-1e32) the particle poses are far more certain than the pose
is: after a gap of tens of seconds without seeing a landmark the particle's prediction of it
lies outside the p0 gate and a new landmark starts. The particle's pose uncertainty since it
last saw the landmark is here the odometry's covariance composed over the steps since the
landmark's last sighting (``ExperimentalConfig.resighting_spread``), by the
first-order compounding of uncertain relations (Smith, Self & Cheeseman 1990, "Estimating
uncertain spatial relationships in robotics", eqs. for the compound ``(+)``; the same
composition as ``core.motion.compose_odometry``, Thrun et al. 2005 Table 7.1), added to S as
H_x C H_x^T for the association decision only.

Composing over every slot's own gap would cost O(slots) per step. With the error of step k
additive on its delta in the frame of pose k-1 (covariance Q_k), its effect on pose t in the
world frame is J_kt (Rot(theta_{k-1}) Q_k Rot(theta_{k-1})^T) J_kt^T with J_kt = A(p_t) A(-p_k),
A(p) = [[1, 0, -p_y], [0, 1, p_x], [0, 0, 1]] (a heading error at pose k moves pose t's position
by its lever arm p_t - p_k). So the covariance of pose t given pose i is
A(p_t) (M_t - M_i) A(p_t)^T with the running sum M_t = sum_k A(-p_k) W_k A(-p_k)^T: one 3x3
sum per step, and each slot keeps the sum M_i of its last sighting. The poses p_k are the dead
reckoning of the odometry (its own frame); the result is turned into the robot frame of the
current pose and from there into each particle's world frame by the particle's heading.
"""

from __future__ import annotations

import numpy as np

from omnislam.core.se import se2_compose


def _lever(p_xy: np.ndarray) -> np.ndarray:
    """A(p) = [[1, 0, -p_y], [0, 1, p_x], [0, 0, 1]] of a position p (2,)."""
    return np.array([[1.0, 0.0, -p_xy[1]], [0.0, 1.0, p_xy[0]], [0.0, 0.0, 1.0]])


def pose_rotation(theta: np.ndarray | float) -> np.ndarray:
    """(..., 3, 3) block-diag(Rot(theta), 1)."""
    theta = np.asarray(theta, dtype=float)
    c, s = np.cos(theta), np.sin(theta)
    out = np.zeros((*theta.shape, 3, 3))
    out[..., 0, 0] = c
    out[..., 0, 1] = -s
    out[..., 1, 0] = s
    out[..., 1, 1] = c
    out[..., 2, 2] = 1.0
    return out


class ResightingSpread:
    """Per slot, the odometry's pose covariance accumulated since the slot was last seen.

    Args:
        scale: the composed covariance is multiplied by this (1: the odometry noise as stated
            by the motion model the particles are sampled from).
    """

    def __init__(self, scale: float = 1.0) -> None:
        self._scale = scale
        self._pose = np.zeros(3)  # dead reckoning of the odometry, in its own frame
        self._sum = np.zeros((3, 3))  # M_t
        self._seen_sum = np.zeros((0, 3, 3))  # M_i of each slot's last sighting
        self._recorded = np.zeros(0, dtype=bool)  # slots seen at least once

    @property
    def pose(self) -> np.ndarray:
        """(3,) the dead-reckoned pose of the odometry so far (its own frame)."""
        return self._pose.copy()

    def advance(self, delta_r: np.ndarray, covariance: np.ndarray) -> None:
        """One odometry step: delta (3,) in the previous pose's frame, its covariance (3, 3)."""
        rotate = pose_rotation(self._pose[2])
        self._pose = se2_compose(self._pose, np.asarray(delta_r, dtype=float))
        inverse_lever = _lever(-self._pose[:2])
        W = rotate @ np.asarray(covariance, dtype=float) @ rotate.T
        self._sum = self._sum + inverse_lever @ W @ inverse_lever.T

    def seen(self, slots: np.ndarray) -> None:
        """The slots were seen at the current pose: their accumulated spread restarts."""
        slots = np.asarray(slots, dtype=np.int64)
        if slots.size == 0:
            return
        needed = int(slots.max()) + 1
        size = self._seen_sum.shape[0]
        if needed > size:
            capacity = max(needed, 2 * size, 16)
            self._seen_sum = np.concatenate([self._seen_sum, np.zeros((capacity - size, 3, 3))])
            self._recorded = np.concatenate([self._recorded, np.zeros(capacity - size, bool)])
        self._seen_sum[slots] = self._sum
        self._recorded[slots] = True

    def robot_frame(self, slots: np.ndarray) -> np.ndarray:
        """(C, 3, 3) covariance of the current pose given the pose of each slot's last
        sighting, in the current robot frame (zero for slots never recorded)."""
        slots = np.asarray(slots, dtype=np.int64)
        out = np.zeros((slots.size, 3, 3))
        known = slots < self._seen_sum.shape[0]
        known[known] = self._recorded[slots[known]]
        if not known.any():
            return out
        lever = _lever(self._pose[:2])
        to_robot = pose_rotation(-self._pose[2]) @ lever
        gap = self._sum - self._seen_sum[slots[known]]
        cov = to_robot @ gap @ to_robot.T
        out[known] = 0.5 * (cov + np.swapaxes(cov, -1, -2)) * self._scale
        return out

    def world_frame(self, slots: np.ndarray, headings_rad: np.ndarray) -> np.ndarray:
        """(P, C, 3, 3) the same covariance in each particle's world frame (heading (P,))."""
        robot = self.robot_frame(slots)
        rotate = pose_rotation(headings_rad)[:, None]  # (P, 1, 3, 3)
        return rotate @ robot[None] @ np.swapaxes(rotate, -1, -2)
