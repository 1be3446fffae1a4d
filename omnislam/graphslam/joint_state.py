"""The joint Gaussian the association needs: a few poses and candidate landmarks, from iSAM2.

Gating and joint compatibility (``core.compatibility``) need the covariance the back end really
has of the poses the sightings were taken from and of the landmarks they may belong to, with
their cross-covariances -- not the whole map's. ``joint_state`` reads it from the Bayes tree for
those variables only (``ISAM2Session.joint_marginal_covariance``), in world coordinates:

* a ``Pose2`` marginal is in the pose's body-frame tangent space; to first order the world
  [x, y, theta] perturbation is ``A d`` with ``A = blkdiag(R(theta), 1)``, so every pose block
  row and column is rotated by its ``A`` (``PlanarPoses.world_covariance`` for one pose);
* the frame being added is not in iSAM2 yet: its guess ``x_k = x_a (+) delta`` (the newest
  key frame a's estimate composed with the odometry since, ``poses.PoseChain.odometry_step``)
  gets, to first order, ``P_kk = J_a P_a J_a^T + J_b Q J_b^T`` and ``P_k,y = J_a P_a,y`` for
  every other variable y (``core.se.se2_compose_jacobians``, Q the composed odometry's
  covariance).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from omnislam.core.se import se2_compose, se2_compose_jacobians
from omnislam.graphslam import factors as fx
from omnislam.graphslam.session import ISAM2Session

#: dimension of a planar pose block and of a planar landmark block
POSE_DIM, POINT_DIM = 3, 2


@dataclass(frozen=True, slots=True)
class JointState:
    """Mean and covariance of some poses and landmarks, in world coordinates.

    Attributes:
        mean: (n,) the stacked [x, y, theta] of each pose, then [x, y] of each landmark.
        covariance: (n, n) their joint covariance.
        pose_column: frame -> first column of its pose block.
        landmark_column: landmark id -> first column of its block.
    """

    mean: np.ndarray
    covariance: np.ndarray
    pose_column: dict[int, int]
    landmark_column: dict[int, int]

    @property
    def dim(self) -> int:
        """n."""
        return int(self.mean.shape[0])

    def pose(self, frame: int) -> np.ndarray:
        """(3,) the mean of a frame's pose."""
        c = self.pose_column[frame]
        return self.mean[c : c + POSE_DIM]

    def landmark(self, landmark_id: int) -> np.ndarray:
        """(2,) the mean of a landmark."""
        c = self.landmark_column[landmark_id]
        return self.mean[c : c + POINT_DIM]


def _yaw_block(theta: float) -> np.ndarray:
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def joint_state(
    session: ISAM2Session,
    frames: Sequence[int],
    landmark_ids: Sequence[int],
    newest: tuple[int, int, np.ndarray, np.ndarray] | None = None,
) -> JointState:
    """The joint Gaussian of the poses of ``frames``, the landmarks, and the frame being added.

    Args:
        session: the iSAM2 session (every pose of ``frames`` and every landmark in the graph).
        frames: frames whose poses are in iSAM2.
        landmark_ids: landmarks in iSAM2.
        newest: (k, a, delta (3,), Q (3, 3)) of the frame k being added (not in iSAM2 yet): its
            pose is key frame a's composed with ``delta``; None: no such frame.

    Returns:
        The state: the poses of ``frames``, the landmarks, then frame k's pose.
    """
    frames = list(dict.fromkeys(int(f) for f in frames))
    landmark_ids = list(dict.fromkeys(int(i) for i in landmark_ids))
    read = list(frames)
    if newest is not None and newest[1] not in read:
        read.append(newest[1])  # read only to propagate from
    keys = [fx.pose_key(f) for f in read] + [fx.landmark_key(i) for i in landmark_ids]
    n = POSE_DIM * len(read) + POINT_DIM * len(landmark_ids)
    covariance = session.joint_marginal_covariance(keys) if keys else np.zeros((0, 0))
    poses = [fx.planar_from_pose2(session.pose2(fx.pose_key(f))) for f in read]
    points = [np.asarray(session.point2(fx.landmark_key(i)), dtype=float) for i in landmark_ids]
    mean = np.concatenate([np.zeros(0), *poses, *points])
    # body-frame tangent -> world [x, y, theta] for every pose block
    rotation = np.eye(n)
    for row, pose in enumerate(poses):
        c = POSE_DIM * row
        rotation[c : c + POSE_DIM, c : c + POSE_DIM] = _yaw_block(pose[2])
    covariance = rotation @ covariance @ rotation.T
    blocks = [("pose", f) for f in read] + [("landmark", i) for i in landmark_ids]
    if newest is not None:
        k, a, delta, Q = newest
        c = POSE_DIM * read.index(a)
        previous = mean[c : c + POSE_DIM]
        delta = np.asarray(delta, dtype=float)
        J_a, J_b = se2_compose_jacobians(previous, delta)
        cross = J_a @ covariance[c : c + POSE_DIM]  # (3, n) cov(x_k, everything read)
        P_kk = J_a @ covariance[c : c + POSE_DIM, c : c + POSE_DIM] @ J_a.T + J_b @ Q @ J_b.T
        covariance = np.block([[covariance, cross.T], [cross, P_kk]])
        mean = np.concatenate([mean, se2_compose(previous, delta)])
        blocks.append(("pose", k))
        if a not in frames:
            keep = np.r_[0:c, c + POSE_DIM : mean.shape[0]]
            covariance, mean = covariance[np.ix_(keep, keep)], mean[keep]
            blocks.remove(("pose", a))
    pose_column: dict[int, int] = {}
    landmark_column: dict[int, int] = {}
    column = 0
    for kind, name in blocks:
        if kind == "pose":
            pose_column[name] = column
            column += POSE_DIM
        else:
            landmark_column[name] = column
            column += POINT_DIM
    return JointState(mean, 0.5 * (covariance + covariance.T), pose_column, landmark_column)
