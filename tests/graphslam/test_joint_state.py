"""The association's joint Gaussian read from iSAM2 against gtsam's batch marginals."""

from __future__ import annotations

import numpy as np
import pytest
from graphslam_scenarios import MOTION_NOISE, simulate_planar

from omnislam.core.modality import Modality
from omnislam.core.types import FrameInput
from omnislam.graphslam import GraphSLAM, GraphSLAMConfig
from omnislam.graphslam import factors as fx
from omnislam.graphslam.config import LandmarkConfig, PoseConfig, PoseVariables
from omnislam.graphslam.joint_state import joint_state

gtsam = pytest.importorskip("gtsam")

#: relative agreement of the joint marginal with gtsam's batch marginals at the same point
COVARIANCE_RTOL = 1e-6
#: Frobenius-relative agreement of the propagated covariance with iSAM2's after adding the
#: pose: the first-order propagation uses the estimate, iSAM2 its linearisation point (up to
#: the relinearisation threshold away), and the odometry noise in the delta's frame
PROPAGATION_RTOL = 0.02


def _world(cov: np.ndarray, thetas: list[float]) -> np.ndarray:
    """Rotate the pose blocks (first 3 * len(thetas) rows) of a tangent-space covariance."""
    T = np.eye(len(cov))
    for i, theta in enumerate(thetas):
        c, s = np.cos(theta), np.sin(theta)
        T[3 * i : 3 * i + 2, 3 * i : 3 * i + 2] = [[c, -s], [s, c]]
    return T @ cov @ T.T


def test_joint_state_is_the_joint_marginal_and_propagates_the_newest_pose(rng):
    scenario = simulate_planar(rng)
    estimator = GraphSLAM(
        Modality.RANGE_BEARING_2D,
        GraphSLAMConfig(
            motion_noise=MOTION_NOISE,
            landmarks=LandmarkConfig(min_consistent_sightings=1),
            # the blind frame below gets a variable
            poses=PoseConfig(pose_variables=PoseVariables.FRAMES),
        ),
        scenario.poses_true[0],
    )
    k = 40
    for frame in scenario.frames[:k]:
        estimator.step(frame)
    session = estimator.session
    landmarks = [int(i) for i in scenario.frames[k - 1].range_bearing.landmark_ids[:3]]
    # poses k-3 and k-2 and the landmarks, as batch marginals of the same graph linearised
    # where iSAM2 linearised it (the rotation into the world uses the estimate)
    state = joint_state(session, [k - 3, k - 2], landmarks)
    marginals = gtsam.Marginals(estimator.factor_graph(), session.linearization_point())
    keys = [fx.pose_key(k - 3), fx.pose_key(k - 2)] + [fx.landmark_key(i) for i in landmarks]
    batch = marginals.jointMarginalCovariance(keys).fullMatrix()
    thetas = [state.pose(k - 3)[2], state.pose(k - 2)[2]]
    np.testing.assert_allclose(
        state.covariance, _world(batch, thetas), rtol=COVARIANCE_RTOL, atol=1e-12
    )
    # the frame being added: propagated from k-1 with the odometry factor's covariance; iSAM2
    # holds the same Gaussian once the pose is added without sightings
    blind = FrameInput(k, scenario.frames[k].odometry)
    estimator._poses.fold(k, blind)  # what ``step`` does before the builder is called
    a, delta, Q = estimator._poses.odometry_step()
    assert a == k - 1
    np.testing.assert_allclose(delta, blind.odometry.delta)
    predicted = joint_state(session, [k - 2], landmarks, (k, a, delta, Q))
    estimator.step(blind)
    after = joint_state(session, [k - 2, k], landmarks)
    order = [0, 1, 2, *range(6, 12), 3, 4, 5]  # after: k-2, k, landmarks; predicted: k last
    reordered = after.covariance[np.ix_(order, order)]
    np.testing.assert_allclose(predicted.mean, after.mean[order], atol=1e-9)
    error = np.linalg.norm(predicted.covariance - reordered) / np.linalg.norm(reordered)
    assert error < PROPAGATION_RTOL
