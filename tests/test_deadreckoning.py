"""Dead reckoning and the estimator registry."""

import numpy as np
import pytest

from omnislam.core.se import se2_compose
from omnislam.core.sequence_info import SequenceInfo
from omnislam.core.types import Estimator, FrameInput, Odometry
from omnislam.deadreckoning import DeadReckoning
from omnislam.errors import ConfigError
from omnislam.estimators import ESTIMATORS, make_estimator


def frames(steps):
    for k, step in enumerate(steps):
        yield FrameInput(index=k, odometry=Odometry(step, float(k)))


def test_composes_odometry_exactly():
    rng = np.random.default_rng(0)
    steps = rng.normal(0, 0.3, size=(50, 3))
    steps[0] = 0
    estimator = DeadReckoning()
    for frame in frames(steps):
        estimator.step(frame)
    expected = np.zeros(3)
    for step in steps[1:]:
        expected = se2_compose(expected, step)
    estimate = estimator.estimate()
    assert len(estimate.trajectory) == 50
    assert np.allclose(estimate.trajectory.se2[-1], expected, atol=1e-12)
    assert len(estimate.landmark_ids) == 0


def test_registry_builds_dead_reckoning_and_rejects_unknowns():
    info = SequenceInfo(name="x", frames=3)
    rng = np.random.default_rng(0)
    estimator = make_estimator("deadreckoning", info, {}, rng)
    assert isinstance(estimator, Estimator)
    with pytest.raises(
        ConfigError, match="unknown estimator 'kalman'; known: deadreckoning, graphslam"
    ):
        make_estimator("kalman", info, {}, rng)
    with pytest.raises(ConfigError, match="takes no options"):
        make_estimator("deadreckoning", info, {"particles": "10"}, rng)
    assert set(ESTIMATORS) >= {
        "graphslam",
        "graphslam-batch",
        "fastslam1",
        "fastslam2",
        "ukf",
        "ekfslam",
    }
