"""The pose chain of the graph: one pose variable per frame, its prior or odometry factor.

Two kinds of pose variable, chosen by the modality (``GraphSLAM``):

* ``PlanarPoses``: ``Pose2`` robot poses ``wTr`` (range-bearing and vertical-line graphs);
  the first pose gets a ``PriorFactorPose2``, every later one a ``BetweenFactorPose2``.
* ``ViewpointPoses``: ``Pose3`` *sensor viewpoints* ``wTs = wTr * rTs`` with ``rTs`` the pure
  vertical offset (0, 0, h) (omni bearings; ``factors.py`` explains why the between-factor of
  the robot frames serves the viewpoints); every pose also gets the planar prior holding z,
  roll and pitch.

Each frame's initial guess is the newest iSAM2 estimate composed with the odometry,
``wTr_{k-1} (+) delta_k``; the odometry covariance is the dataset's fixed sigmas
(``GraphSLAMConfig.odometry_sigmas``), else the frame's own (``Odometry.covariance``), else the
motion model's (``OdometryMotionModel.covariance``, thesis eq. 4.41), raised to the
``odometry_min_sigma_m`` floor (``factors.condition_odometry_covariance``).
"""

from __future__ import annotations

import abc
from collections.abc import Callable
from typing import Any

import numpy as np

from omnislam._optional import require
from omnislam.core.motion import OdometryMotionModel
from omnislam.core.se import se2_from_se3, se3_from_se2
from omnislam.core.types import FrameInput
from omnislam.errors import EstimationError
from omnislam.graphslam import factors as fx
from omnislam.graphslam.config import GraphSLAMConfig
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
        config: settings (prior, odometry and planar sigmas, sensor height).
        initial_pose: (3,) pose [x, y, theta] of frame 0 in the world [m, m, rad].
        session: the iSAM2 session the estimates are read from.
        motion: the odometry motion model whose covariance weighs each odometry factor
            (when the data state no covariance and no fixed sigmas are configured).
    """

    def __init__(
        self,
        config: GraphSLAMConfig,
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
        self._newest = self._initial_pose.copy()  # newest pose estimate [x, y, theta]
        self._newest_pose2 = fx.pose2(self._initial_pose)  # the same as a gtsam.Pose2
        self._guess = self._initial_pose.copy()  # initial guess of the frame being added
        self._frame: FrameInput | None = None  # the frame being added

    @property
    def guess_w(self) -> np.ndarray:
        """(3,) initial guess [x, y, theta] of the frame being added (do not modify)."""
        return self._guess

    @property
    def newest_w(self) -> np.ndarray:
        """(3,) newest pose estimate [x, y, theta] of the robot frame (do not modify)."""
        return self._newest

    def _next_guess(self, k: int, frame: FrameInput) -> tuple[Any, Any]:
        """Set the guess of frame k; returns (guess as gtsam.Pose2, odometry as Pose2 or None)."""
        self._frame = frame
        if k == 0:
            self._guess = self._initial_pose.copy()
            return fx.pose2(self._guess), None
        odometry = fx.pose2(frame.odometry.delta)
        guess2 = self._newest_pose2.compose(odometry)
        self._guess = fx.planar_from_pose2(guess2)
        return guess2, odometry

    def odometry_step(self) -> tuple[np.ndarray, np.ndarray]:
        """(delta (3,), covariance (3, 3)) of the odometry factor of the frame being added.

        The association propagates the newest pose's uncertainty to the frame's guess with it.
        """
        if self._frame is None:
            raise EstimationError("no frame is being added")
        return np.asarray(self._frame.odometry.delta), self._odometry_covariance(self._frame)

    def _odometry_covariance(self, frame: FrameInput) -> np.ndarray:
        """(3, 3) covariance of the frame's odometry delta (see the module docstring)."""
        if self._fixed_odometry_cov is not None:
            cov = self._fixed_odometry_cov
        elif frame.odometry.covariance is not None:  # the data states its own noise
            cov = frame.odometry.covariance
        else:
            cov = self._motion.covariance(frame.odometry.delta)
        # a factor far more precise than the poses' absolute uncertainty makes iSAM2's
        # Cholesky reject the clique (see GraphSLAMConfig.odometry_min_sigma_m)
        return fx.condition_odometry_covariance(cov, self._config.odometry_min_sigma_m)

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

    @abc.abstractmethod
    def add(self, k: int, frame: FrameInput, graph: Any, values: Any) -> np.ndarray:
        """Add frame k's pose variable and its factors; returns its guess [x, y, theta]."""

    @abc.abstractmethod
    def read_newest(self, k: int) -> None:
        """Read frame k's pose back from iSAM2 after the update."""

    @abc.abstractmethod
    def trajectory(self, values: Any, frames: int) -> tuple[np.ndarray, np.ndarray]:
        """The robot poses in ``values``: planar (N, 3) [x, y, theta], SE(3) (N, 4, 4)."""

    @abc.abstractmethod
    def world_covariance(self, cov: np.ndarray, yaw: float) -> np.ndarray:
        """A pose marginal (tangent space, body frame) -> covariance of world [x, y, yaw]."""


class PlanarPoses(PoseChain):
    """``Pose2`` robot poses (range-bearing and vertical-line graphs)."""

    def __init__(
        self,
        config: GraphSLAMConfig,
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

    def add(self, k: int, frame: FrameInput, graph: Any, values: Any) -> np.ndarray:
        """Add frame k's pose variable with its prior (k = 0) or odometry factor.

        Returns:
            (3,) the pose's initial guess [x, y, theta] (also ``guess_w``).
        """
        guess2, odometry = self._next_guess(k, frame)
        if k == 0:
            graph.add(gtsam.PriorFactorPose2(fx.pose_key(0), guess2, self._prior_noise))
        elif self._odometry_noise is not None:
            graph.add(
                gtsam.BetweenFactorPose2(
                    fx.pose_key(k - 1), fx.pose_key(k), odometry, self._odometry_noise
                )
            )
        else:
            cov = self._odometry_covariance(frame)
            graph.add(fx.between_pose2(k - 1, k, frame.odometry.delta, cov))
        values.insert(fx.pose_key(k), guess2)
        return self._guess

    def read_newest(self, k: int) -> None:
        """Read frame k's pose back from iSAM2 after the update."""
        self._newest_pose2 = self._session.pose2(fx.pose_key(k))
        self._newest = fx.planar_from_pose2(self._newest_pose2)

    def _estimated_viewpoint(self, frame: int) -> tuple[np.ndarray, np.ndarray]:
        wTr = fx.planar_from_pose2(self._session.pose2(fx.pose_key(frame)))
        return _planar_viewpoint(wTr, 0.0)

    def trajectory(self, values: Any, frames: int) -> tuple[np.ndarray, np.ndarray]:
        """The poses in ``values``: planar (N, 3) [x, y, theta] and SE(3) (N, 4, 4) ``wTr``."""
        planar = gtsam.utilities.extractPose2(values).reshape(-1, 3)
        if len(planar) != frames:
            raise EstimationError("estimate does not hold one value per pose and landmark")
        return planar, se3_from_se2(planar)

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
        config: GraphSLAMConfig,
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
        """The omni viewpoint's height above the robot frame (``GraphSLAMConfig``) [m]."""
        return self._config.sensor_height_m

    def add(self, k: int, frame: FrameInput, graph: Any, values: Any) -> np.ndarray:
        """Add frame k's viewpoint with its priors (k = 0) or odometry and planar prior.

        Returns:
            (3,) the robot pose's initial guess [x, y, theta] (also ``guess_w``).
        """
        self._next_guess(k, frame)
        height = self._config.sensor_height_m
        viewpoint = fx.pose3_planar(self._guess, height)
        if k == 0:
            graph.add(gtsam.PriorFactorPose3(fx.pose_key(0), viewpoint, self._first_prior_noise))
        else:
            config = self._config
            cov = self._odometry_covariance(frame)
            graph.add(
                fx.between_pose3(
                    k - 1,
                    k,
                    frame.odometry.delta,
                    cov,
                    config.planar_sigma_m,
                    config.planar_sigma_rad,
                )
            )
            graph.add(gtsam.PriorFactorPose3(fx.pose_key(k), viewpoint, self._planar_prior_noise))
        values.insert(fx.pose_key(k), fx.pose3_planar(self._guess, height))
        return self._guess

    def read_newest(self, k: int) -> None:
        """Read frame k's viewpoint back from iSAM2 after the update."""
        self._newest = fx.planar_from_pose3(self._session.pose3(fx.pose_key(k)))
        self._newest_pose2 = fx.pose2(self._newest)

    def _estimated_viewpoint(self, frame: int) -> tuple[np.ndarray, np.ndarray]:
        wTs = self._session.pose3(fx.pose_key(frame))
        return np.asarray(wTs.translation()), wTs.rotation().matrix()

    def trajectory(self, values: Any, frames: int) -> tuple[np.ndarray, np.ndarray]:
        """The robot poses of the viewpoints in ``values``: planar (N, 3), SE(3) (N, 4, 4).

        The variables are the sensor viewpoints ``wTs``; the robot frame is ``sTr = (I, -h e_z)``.
        """
        rows = gtsam.utilities.extractPose3(values)
        if len(rows) != frames:
            raise EstimationError("estimate does not hold one value per pose and landmark")
        wTs = np.tile(np.eye(4), (frames, 1, 1))
        wTs[:, :3, :3] = rows[:, :9].reshape(frames, 3, 3)
        wTs[:, :3, 3] = rows[:, 9:]
        sTr = np.eye(4)
        sTr[2, 3] = -self._config.sensor_height_m
        poses_w = wTs @ sTr
        return se2_from_se3(poses_w), poses_w

    def world_covariance(self, cov: np.ndarray, yaw: float) -> np.ndarray:
        """A Pose3 marginal ([rx, ry, rz, tx, ty, tz], body frame) -> world [x, y, yaw]."""
        cov = cov[np.ix_(fx.POSE3_PLANAR_INDICES, fx.POSE3_PLANAR_INDICES)]
        A = _yaw_rotation(yaw)
        return A @ cov @ A.T
