"""The pose chain of the graph: one pose variable per frame, its prior or odometry factor.

Two kinds of pose variable, chosen by the modality (``GraphSLAM``):

* ``PlanarPoses``: ``Pose2`` robot poses ``wTr`` (range-bearing and vertical-line graphs);
  the first pose gets a ``PriorFactorPose2``, every later one a ``BetweenFactorPose2``.
* ``ViewpointPoses``: ``Pose3`` *sensor viewpoints* ``wTs = wTr * rTs`` with ``rTs`` the pure
  vertical offset (0, 0, h) (omni bearings; ``factors.py`` explains why the between-factor of
  the robot frames serves the viewpoints); every pose also gets the planar prior holding z,
  roll and pitch.

Pose variables only at *key frames* (``PoseConfig.pose_variables``): by default the
frames whose observation stream is not empty (every image of an omni log, ~1 frame in 5 on
lab40; every frame of MR.CLAM) and frame 0. The odometry of the frames in between is composed
with its covariance (``core.motion.compose_odometry``) into one between-factor from the
previous key frame, so the graph and the number of iSAM2 updates shrink without losing any
measurement; a frame without a variable is reported at its key frame's estimate composed with
the odometry since (``trajectory``), and its covariance propagated the same way.

Each key frame's initial guess is the newest iSAM2 estimate composed with the odometry since,
``wTr_key (+) delta``; the odometry covariance of one step is the dataset's fixed sigmas
(``PoseConfig.odometry_sigmas``), else the frame's own (``Odometry.covariance``), else the
motion model's (``OdometryMotionModel.covariance``, thesis eq. 4.41); the composed covariance
is turned into the between-factor's error convention (``factors.between_covariance``) and
raised to the ``odometry_min_sigma_m`` floor (``factors.condition_odometry_covariance``).
"""

from __future__ import annotations

import abc
from collections.abc import Callable
from typing import Any

import numpy as np

from omnislam._optional import require
from omnislam.core.motion import OdometryMotionModel, compose_odometry
from omnislam.core.se import (
    se2_between,
    se2_compose_jacobians,
    se2_from_se3,
    se3_from_se2,
    wrap_angle,
)
from omnislam.core.types import FrameInput
from omnislam.errors import EstimationError
from omnislam.graphslam import factors as fx
from omnislam.graphslam.config import PoseConfig
from omnislam.graphslam.session import ISAM2Session

gtsam = require("gtsam")

#: ``viewpoint(frame) -> (origin_w (3,), wRs (3, 3))``: a frame's sensor viewpoint estimate
Viewpoint = Callable[[int], tuple[np.ndarray, np.ndarray]]


def _yaw_rotation(yaw: float) -> np.ndarray:
    """(3, 3) rotation about z by ``yaw`` [rad]."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _planar_viewpoint(wTr: np.ndarray, height_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(origin_w, wRs) of a sensor at ``height_m`` above the planar pose ``wTr``, no tilt."""
    x, y, theta = wTr
    return np.array([x, y, height_m]), _yaw_rotation(theta)


class PoseChain(abc.ABC):
    """What both pose kinds share: the guess, the odometry covariance, the newest estimate.

    Args:
        config: the pose chain's section (prior, odometry and planar sigmas, sensor height).
        initial_pose: (3,) pose [x, y, theta] of frame 0 in the world [m, m, rad].
        session: the iSAM2 session the estimates are read from.
        motion: the odometry motion model whose covariance weighs each odometry factor
            (when the data state no covariance and no fixed sigmas are configured).
    """

    def __init__(
        self,
        config: PoseConfig,
        initial_pose: np.ndarray,
        session: ISAM2Session,
        motion: OdometryMotionModel,
    ) -> None:
        self._config = config
        self._session = session
        self._initial_pose = np.asarray(initial_pose, dtype=float).reshape(3)
        self._motion = motion
        self._fixed_odometry_cov = (
            None
            if config.odometry_sigmas is None
            else fx.condition_odometry_covariance(
                np.diag(np.square(config.odometry_sigmas)), config.odometry_min_sigma_m
            )
        )
        self._newest = self._initial_pose.copy()  # newest key frame's estimate [x, y, theta]
        self._newest_pose2 = fx.pose2(self._initial_pose)  # the same as a gtsam.Pose2
        self._guess = self._initial_pose.copy()  # initial guess of the frame being added
        self._guess2 = fx.pose2(self._guess)  # the same as a gtsam.Pose2
        self._key_frames: list[int] = []  # frames with a pose variable, ascending
        self._newest_key = 0  # the key frame newest_w was read from
        # odometry since the newest key frame: delta [x, y, theta] and its covariance
        self._since_key = np.zeros(3)
        self._since_key_cov = np.zeros((3, 3))
        self._steps_since_key = 0
        self._key_delta: list[np.ndarray] = []  # per key frame: odometry from the previous
        self._key_delta_cov: list[np.ndarray] = []  # ... and its covariance
        self._key_steps: list[int] = []  # ... and the odometry steps composed into it
        # per frame: what the estimate multiplies the translation of the odometry folded up to
        # that frame by (``rescale``); None: 1 everywhere
        self._ratio: np.ndarray | None = None
        self._frame_key: list[int] = []  # per frame: row of its key frame in _key_frames
        self._frame_offset: list[np.ndarray] = []  # per frame: delta from its key frame
        self._frame_offset_cov: list[np.ndarray] = []  # ... and its covariance

    @property
    def guess_w(self) -> np.ndarray:
        """(3,) initial guess [x, y, theta] of the frame being added (do not modify)."""
        return self._guess

    @property
    def newest_w(self) -> np.ndarray:
        """(3,) newest pose estimate [x, y, theta] of the robot frame (do not modify)."""
        return self._newest

    @property
    def newest_key(self) -> int:
        """Frame index of the newest key frame read back from iSAM2 (``newest_w``'s)."""
        return self._newest_key

    @property
    def key_frames(self) -> list[int]:
        """Frame indices with a pose variable, ascending (do not modify)."""
        return self._key_frames

    @property
    def since_key(self) -> np.ndarray:
        """(3,) the odometry folded in since the newest key frame [x, y, theta] (do not modify)."""
        return self._since_key

    def odometry_step(self) -> tuple[int, np.ndarray, np.ndarray]:
        """(newest key frame, delta (3,), covariance (3, 3)) of the odometry since it.

        The frame being added is the newest key frame's estimate composed with ``delta``
        (``guess_w``); the association propagates that key frame's uncertainty to the guess with
        the composed odometry's covariance (``core.motion.compose_odometry``, raised to the
        ``odometry_min_sigma_m`` floor). Call after ``fold`` and before ``read_newest``.
        """
        return (
            self._newest_key,
            self._since_key.copy(),
            fx.condition_odometry_covariance(
                self._since_key_cov, self._config.odometry_min_sigma_m
            ),
        )

    def fold(self, k: int, frame: FrameInput) -> np.ndarray:
        """Fold frame k's odometry into the odometry since the newest key frame; set its guess.

        Call once per frame, before ``add``.

        Returns:
            (3,) the frame's guess [x, y, theta]: the newest key frame's estimate composed with
            the odometry since (also ``guess_w``).
        """
        if k == 0:
            self._guess = self._initial_pose.copy()
            self._since_key = np.zeros(3)
            self._since_key_cov = np.zeros((3, 3))
            self._guess2 = fx.pose2(self._guess)
            return self._guess
        delta = np.asarray(frame.odometry.delta, dtype=float)
        if self._key_frames[-1] == k - 1:  # the first step since the key frame
            self._since_key, self._since_key_cov = delta, self._step_covariance(frame)
            self._steps_since_key = 1
        else:
            self._steps_since_key += 1
            self._since_key, self._since_key_cov = compose_odometry(
                self._since_key, self._since_key_cov, delta, self._step_covariance(frame)
            )
        self._guess2 = self._newest_pose2.compose(fx.pose2(self._since_key))
        self._guess = fx.planar_from_pose2(self._guess2)
        return self._guess

    def _record(self, k: int, key: bool) -> None:
        """Remember frame k's key frame and offset (a key frame is its own, at zero offset)."""
        if key:
            self._key_frames.append(k)
            # the odometry from the previous key frame (what the between-factor measures)
            self._key_delta.append(self._since_key.copy() if k else np.zeros(3))
            self._key_delta_cov.append(self._since_key_cov.copy() if k else np.zeros((3, 3)))
            self._key_steps.append(self._steps_since_key if k else 0)
            self._frame_offset.append(np.zeros(3))
            self._frame_offset_cov.append(np.zeros((3, 3)))
        else:
            self._frame_offset.append(self._since_key.copy())
            self._frame_offset_cov.append(self._since_key_cov.copy())
        self._frame_key.append(len(self._key_frames) - 1)

    def _step_covariance(self, frame: FrameInput) -> np.ndarray:
        """(3, 3) covariance of one frame's odometry delta (see the module docstring)."""
        if self._fixed_odometry_cov is not None:
            return self._fixed_odometry_cov
        if frame.odometry.covariance is not None:  # the data states its own noise
            return frame.odometry.covariance
        return self._motion.covariance(frame.odometry.delta)

    def _odometry_covariance(
        self, delta: np.ndarray | None = None, cov: np.ndarray | None = None, steps: int = 0
    ) -> np.ndarray:
        """(3, 3) between-factor covariance of the odometry since the previous key frame (or of
        ``delta`` with covariance ``cov`` composed of ``steps`` steps).

        A composed delta's covariance is turned into the factor's error convention
        (``factors.between_covariance``); one step keeps the step's covariance as the factor's,
        as the graph always did: converting it too changed MR.CLAM dataset 6's ATE from
        0.113 / 0.115 / 0.605 / 0.124 / 0.460 m (robots 1-5) to 0.128 / 0.104 / 0.815 / 0.124 /
        0.648 m -- the alpha model is not calibrated for MR.CLAM, so the exact convention is
        not the better one there.
        """
        if delta is None:
            delta, cov, steps = self._since_key, self._since_key_cov, self._steps_since_key
        if steps > 1:
            cov = fx.between_covariance(delta, cov)
        # a factor far more precise than the poses' absolute uncertainty makes iSAM2's
        # Cholesky reject the clique (see PoseConfig.odometry_min_sigma_m)
        return fx.condition_odometry_covariance(cov, self._config.odometry_min_sigma_m)

    def rescale(self, ratios: np.ndarray | None) -> None:
        """Multiply, in the estimate only, the translation of the odometry folded up to each
        frame (into a key frame: its between-factor's; else its offset from its key frame) by
        ``ratios`` (N,), one per frame (None: as added). ``GraphSLAM`` uses it to give the final
        estimate the run's final floor scale (``FloorConfig.scale``)."""
        if ratios is not None:
            ratios = np.asarray(ratios, dtype=float).reshape(-1)
            if ratios.shape[0] != len(self._frame_key):
                raise ValueError("one ratio per frame")
        self._ratio = ratios

    def _scaled_odometry(
        self, deltas: np.ndarray, covs: np.ndarray, frames: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """(N, 3) deltas and (N, 3, 3) covariances with their translations multiplied by the
        ratios of ``frames`` (``rescale``)."""
        if self._ratio is None:
            return deltas, covs
        factors = np.ones((len(frames), 3))
        factors[:, :2] = self._ratio[frames, None]
        return deltas * factors, covs * factors[:, :, None] * factors[:, None, :]

    def odometry_factor_inputs(self, row: int) -> tuple[int, int, np.ndarray, np.ndarray]:
        """(previous key frame, key frame, delta, between-factor covariance) of the odometry
        factor into key-frame row ``row`` (>= 1), with ``rescale``'s ratio applied."""
        if not 1 <= row < len(self._key_frames):
            raise ValueError(f"no odometry factor into key-frame row {row}")
        (delta,), (cov,) = self._scaled_odometry(
            np.asarray(self._key_delta[row])[None], np.asarray(self._key_delta_cov[row])[None],
            np.array([self._key_frames[row]]))
        return (self._key_frames[row - 1], self._key_frames[row], delta,
                self._odometry_covariance(delta, cov, self._key_steps[row]))

    def offset_factor_inputs(self, frame: int) -> tuple[int, np.ndarray, np.ndarray]:
        """(key frame, delta, between-factor covariance) of the odometry from a frame's key
        frame to the frame (a frame without a pose variable of its own), with ``rescale``'s
        ratio applied: what a between-factor into a pose variable of that frame would measure.
        """
        if not 0 <= frame < len(self._frame_key):
            raise ValueError(f"no frame {frame}")
        (delta,), (cov,) = self._scaled_odometry(
            np.asarray(self._frame_offset[frame])[None],
            np.asarray(self._frame_offset_cov[frame])[None], np.array([frame]))
        steps = frame - self._key_frames[self._frame_key[frame]]
        return (self._key_frames[self._frame_key[frame]], delta,
                self._odometry_covariance(delta, cov, steps))

    def frame_poses(self, key_poses_w: np.ndarray) -> np.ndarray:
        """(N, 4, 4) every frame's pose from the key frames' (K, 4, 4) and the odometry.

        A key frame keeps its own pose. Frame j between key frames a and b is ``wTa * aTj``
        with ``aTj`` the odometry composed since a, *conditioned on the estimated* ``aTb``: to
        first order the composed odometry ``D_ab = D_aj (+) D_jb`` has ``Cov(D_aj, D_ab) =
        C_aj J^T`` (J the composition's Jacobian in ``D_aj``), so given the residual
        ``r = between(wTa, wTb) - D_ab`` the mean of ``aTj`` is ``D_aj + C_aj J^T C_ab^-1 r``
        -- what a pose variable per frame, with no sighting between a and b, would give (the
        odometry chain smoothed between its ends). After the newest key frame: ``D_aj``.
        """
        if len(key_poses_w) != len(self._key_frames):
            raise EstimationError("estimate does not hold one value per pose and landmark")
        rows = np.asarray(self._frame_key, dtype=np.int64)
        offsets, offset_covs = self._scaled_odometry(
            np.asarray(self._frame_offset, dtype=float).reshape(-1, 3),
            np.asarray(self._frame_offset_cov, dtype=float).reshape(-1, 3, 3),
            np.arange(len(rows)))
        offsets = offsets.copy()
        inside = np.flatnonzero(rows + 1 < len(self._key_frames))  # a later key frame exists
        inside = inside[np.asarray(self._key_frames)[rows[inside]] != inside]  # not keys
        if len(inside):
            planar = se2_from_se3(key_poses_w)
            nxt = rows[inside] + 1
            d_ab, c_ab = self._scaled_odometry(
                np.asarray(self._key_delta)[nxt], np.asarray(self._key_delta_cov)[nxt],
                np.asarray(self._key_frames)[nxt])
            residual = se2_between(planar[rows[inside]], planar[nxt]) - d_ab
            residual[:, 2] = wrap_angle(residual[:, 2])
            d_aj = offsets[inside]
            c_aj = offset_covs[inside]
            J, _ = se2_compose_jacobians(d_aj, se2_between(d_aj, d_ab))
            gain = c_aj @ np.swapaxes(J, 1, 2) @ np.linalg.inv(c_ab)
            offsets[inside] = d_aj + np.einsum("nij,nj->ni", gain, residual)
        return key_poses_w[rows] @ se3_from_se2(offsets)

    def frame_covariances(self, key_covariances_w: np.ndarray, planar_w: np.ndarray) -> np.ndarray:
        """(N, 3, 3) world [x, y, yaw] covariance of every frame from its key frame's (K, 3, 3).

        ``J_a P_a J_a^T + J_b C J_b^T`` with the composition's Jacobians at (key pose, offset)
        and C the offset's odometry covariance (zero for a key frame: its own marginal).
        """
        rows = np.asarray(self._frame_key, dtype=np.int64)
        keys_w = planar_w[np.asarray(self._key_frames, dtype=np.int64)][rows]
        offsets, C = self._scaled_odometry(
            np.asarray(self._frame_offset, dtype=float).reshape(-1, 3),
            np.asarray(self._frame_offset_cov, dtype=float).reshape(-1, 3, 3),
            np.arange(len(rows)))
        J_a, J_b = se2_compose_jacobians(keys_w, offsets)
        P = key_covariances_w[rows]
        return J_a @ P @ np.swapaxes(J_a, 1, 2) + J_b @ C @ np.swapaxes(J_b, 1, 2)

    def viewpoint_callback(self, k: int) -> Viewpoint:
        """Sensor viewpoints for triangulation: the guess for frame k, iSAM2's before it."""
        height = self.sensor_height_m

        def viewpoint(frame: int) -> tuple[np.ndarray, np.ndarray]:
            if frame == k:
                return _planar_viewpoint(self._guess, height)
            return self._estimated_viewpoint(frame)

        return viewpoint

    @property
    @abc.abstractmethod
    def sensor_height_m(self) -> float:
        """Height of the sensor above the robot frame [m]."""

    @abc.abstractmethod
    def _estimated_viewpoint(self, frame: int) -> tuple[np.ndarray, np.ndarray]:
        """(origin_w, wRs) of an earlier frame's sensor, from iSAM2."""

    def add(self, k: int, graph: Any, values: Any, key: bool) -> None:
        """Add frame k (after ``fold``): a pose variable and its factors if ``key``, else only
        its offset from the newest key frame."""
        previous = self._key_frames[-1] if self._key_frames else None
        self._record(k, key)
        if key:
            self._add_variable(k, previous, graph, values)

    @abc.abstractmethod
    def _add_variable(self, k: int, previous: int | None, graph: Any, values: Any) -> None:
        """Key frame k's variable with its prior (k = 0) or odometry factor from ``previous``."""

    @abc.abstractmethod
    def read_newest(self, k: int) -> None:
        """Read key frame k's pose back from iSAM2 after the update."""

    @abc.abstractmethod
    def key_poses(self, values: Any) -> np.ndarray:
        """(K, 4, 4) robot poses ``wTr`` of the key frames' variables in ``values``."""

    def trajectory(self, values: Any, frames: int) -> tuple[np.ndarray, np.ndarray]:
        """Every frame's robot pose from ``values``: planar (N, 3) [x, y, theta], SE(3) (N, 4, 4).

        Raises:
            EstimationError: ``values`` does not hold one pose per key frame, or ``frames`` is
                not the number of frames added.
        """
        if frames != len(self._frame_key):
            raise EstimationError("estimate does not hold one value per pose and landmark")
        poses_w = self.frame_poses(self.key_poses(values))
        return se2_from_se3(poses_w), poses_w

    @abc.abstractmethod
    def world_covariance(self, cov: np.ndarray, yaw: float) -> np.ndarray:
        """A pose marginal (tangent space, body frame) -> covariance of world [x, y, yaw]."""


class PlanarPoses(PoseChain):
    """``Pose2`` robot poses (range-bearing and vertical-line graphs)."""

    def __init__(
        self,
        config: PoseConfig,
        initial_pose: np.ndarray,
        session: ISAM2Session,
        motion: OdometryMotionModel,
    ) -> None:
        super().__init__(config, initial_pose, session, motion)
        self._prior_noise = gtsam.noiseModel.Diagonal.Sigmas(np.asarray(config.prior_sigmas))
        self._odometry_noise = None  # fixed sigmas: one shared noise model
        if self._fixed_odometry_cov is not None:
            sigmas = np.sqrt(np.diag(self._fixed_odometry_cov))
            self._odometry_noise = gtsam.noiseModel.Diagonal.Sigmas(sigmas)

    @property
    def sensor_height_m(self) -> float:
        """0: planar sensors measure in the robot frame's plane."""
        return 0.0

    def _add_variable(self, k: int, previous: int | None, graph: Any, values: Any) -> None:
        """Key frame k's Pose2 with its prior (k = 0) or odometry factor from ``previous``."""
        guess2 = self._guess2
        if previous is None:
            graph.add(gtsam.PriorFactorPose2(fx.pose_key(0), guess2, self._prior_noise))
        elif self._odometry_noise is not None and previous == k - 1:
            odometry = fx.pose2(self._since_key)
            graph.add(
                gtsam.BetweenFactorPose2(
                    fx.pose_key(previous), fx.pose_key(k), odometry, self._odometry_noise
                )
            )
        else:
            graph.add(fx.between_pose2(previous, k, self._since_key, self._odometry_covariance()))
        values.insert(fx.pose_key(k), guess2)

    def read_newest(self, k: int) -> None:
        """Read frame k's pose back from iSAM2 after the update."""
        self._newest_pose2 = self._session.pose2(fx.pose_key(k))
        self._newest = fx.planar_from_pose2(self._newest_pose2)
        self._newest_key = k

    def _estimated_viewpoint(self, frame: int) -> tuple[np.ndarray, np.ndarray]:
        wTr = fx.planar_from_pose2(self._session.pose2(fx.pose_key(frame)))
        return _planar_viewpoint(wTr, 0.0)

    def key_poses(self, values: Any) -> np.ndarray:
        """(K, 4, 4) the key frames' Pose2 variables in ``values`` as SE(3) ``wTr``."""
        return se3_from_se2(gtsam.utilities.extractPose2(values).reshape(-1, 3))

    def world_covariance(self, cov: np.ndarray, yaw: float) -> np.ndarray:
        """A Pose2 marginal (body frame [x, y, theta]) -> covariance of world [x, y, yaw].

        To first order the world-frame position covariance is R(yaw) C R(yaw)^T.
        """
        A = _yaw_rotation(yaw)
        return A @ cov @ A.T


class ViewpointPoses(PoseChain):
    """``Pose3`` sensor viewpoints held near the plane (omni bearings)."""

    def __init__(
        self,
        config: PoseConfig,
        initial_pose: np.ndarray,
        session: ISAM2Session,
        motion: OdometryMotionModel,
    ) -> None:
        super().__init__(config, initial_pose, session, motion)
        sigmas = np.zeros(6)
        sigmas[fx.POSE3_PLANAR_INDICES] = config.prior_sigmas
        sigmas[fx.POSE3_OFF_PLANE_INDICES] = [
            config.planar_sigma_rad,
            config.planar_sigma_rad,
            config.planar_sigma_m,
        ]
        self._first_prior_noise = gtsam.noiseModel.Diagonal.Sigmas(sigmas)
        self._planar_prior_noise = fx.planar_prior_noise(
            config.planar_sigma_m, config.planar_sigma_rad
        )

    @property
    def sensor_height_m(self) -> float:
        """The omni viewpoint's height above the robot frame [m] (``PoseConfig``)."""
        return self._config.sensor_height_m

    def _add_variable(self, k: int, previous: int | None, graph: Any, values: Any) -> None:
        """Key frame k's viewpoint with its priors (k = 0) or odometry from ``previous`` and
        the planar prior."""
        height = self._config.sensor_height_m
        viewpoint = fx.pose3_planar(self._guess, height)
        if previous is None:
            graph.add(gtsam.PriorFactorPose3(fx.pose_key(0), viewpoint, self._first_prior_noise))
        else:
            config = self._config
            graph.add(
                fx.between_pose3(
                    previous,
                    k,
                    self._since_key,
                    self._odometry_covariance(),
                    config.planar_sigma_m,
                    config.planar_sigma_rad,
                )
            )
            graph.add(gtsam.PriorFactorPose3(fx.pose_key(k), viewpoint, self._planar_prior_noise))
        values.insert(fx.pose_key(k), fx.pose3_planar(self._guess, height))

    def read_newest(self, k: int) -> None:
        """Read frame k's viewpoint back from iSAM2 after the update."""
        self._newest = fx.planar_from_pose3(self._session.pose3(fx.pose_key(k)))
        self._newest_pose2 = fx.pose2(self._newest)
        self._newest_key = k

    def _estimated_viewpoint(self, frame: int) -> tuple[np.ndarray, np.ndarray]:
        wTs = self._session.pose3(fx.pose_key(frame))
        return np.asarray(wTs.translation()), wTs.rotation().matrix()

    def key_poses(self, values: Any) -> np.ndarray:
        """(K, 4, 4) robot poses of the key frames' viewpoints in ``values``.

        The variables are the sensor viewpoints ``wTs``; the robot frame is ``sTr = (I, -h e_z)``.
        """
        rows = gtsam.utilities.extractPose3(values)
        wTs = np.tile(np.eye(4), (len(rows), 1, 1))
        wTs[:, :3, :3] = rows[:, :9].reshape(-1, 3, 3)
        wTs[:, :3, 3] = rows[:, 9:]
        sTr = np.eye(4)
        sTr[2, 3] = -self._config.sensor_height_m
        return wTs @ sTr

    def world_covariance(self, cov: np.ndarray, yaw: float) -> np.ndarray:
        """A Pose3 marginal ([rx, ry, rz, tx, ty, tz], body frame) -> world [x, y, yaw]."""
        cov = cov[np.ix_(fx.POSE3_PLANAR_INDICES, fx.POSE3_PLANAR_INDICES)]
        A = _yaw_rotation(yaw)
        return A @ cov @ A.T
