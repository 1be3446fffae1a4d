"""Configuration validation and presets of the GTSAM back end."""

from __future__ import annotations

import pytest

from omnislam.core.modality import Modality
from omnislam.errors import ConfigError
from omnislam.graphslam import GraphSLAMConfig, RobustKernel
from omnislam.graphslam.config import PRESETS


@pytest.mark.parametrize(
    "overrides",
    [
        {"relinearize_threshold": 0.0},
        {"min_sightings": 1},
        {"prior_sigmas": (1.0, -1.0, 1.0)},
        {"association_gate_probability": 0.999, "new_landmark_probability": 0.99},
        {"robust_threshold": -1.0},
        {"robust_kernel": "cauchy"},
        {"budget_grace_images": 0},
        {"outlier_gate_votes": -1},
    ],
)
def test_config_rejects_bad_values(overrides):
    with pytest.raises(ConfigError):
        GraphSLAMConfig(**overrides)


def test_presets_and_kernel_thresholds():
    auto = GraphSLAMConfig()
    assert auto.landmark_kernel(Modality.BEARINGS_3D) == (RobustKernel.HUBER, 3.0)
    assert auto.landmark_kernel(Modality.RANGE_BEARING_2D) == (RobustKernel.NONE, 0.0)
    assert auto.landmark_kernel(Modality.VERTICAL_LINES) == (RobustKernel.NONE, 0.0)
    off = GraphSLAMConfig(robust_kernel=RobustKernel.NONE, robust_threshold=2.0)
    assert off.landmark_kernel(Modality.BEARINGS_3D) == (RobustKernel.NONE, 0.0)
    huber = GraphSLAMConfig(robust_kernel=RobustKernel.HUBER)
    assert huber.landmark_kernel(Modality.RANGE_BEARING_2D) == (RobustKernel.HUBER, 1.345)
    wide = GraphSLAMConfig(robust_threshold=5.0)
    assert wide.landmark_kernel(Modality.BEARINGS_3D) == (RobustKernel.HUBER, 5.0)
    assert PRESETS["robust"].robust_kernel is RobustKernel.CAUCHY
    assert PRESETS["victoria-park-gtsam"].odometry_sigmas == (0.01, 0.002, 0.002)
