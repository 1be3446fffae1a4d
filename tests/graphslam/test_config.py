"""Configuration validation, sections and presets of the GTSAM back end."""

from __future__ import annotations

import dataclasses
import re

import pytest

from omnislam.core.modality import Modality
from omnislam.errors import ConfigError
from omnislam.graphslam import GraphSLAMConfig, RobustKernel
from omnislam.graphslam.config import (
    PRESETS,
    AssociationConfig,
    ExperimentalConfig,
    LandmarkConfig,
    LoopClosureConfig,
    PoseConfig,
    SolverConfig,
)
from omnislam.options import apply_options, describe_options


@pytest.mark.parametrize(
    "section, overrides",
    [
        (SolverConfig, {"relinearize_threshold": 0.0}),
        (LandmarkConfig, {"min_sightings": 1}),
        (PoseConfig, {"prior_sigmas": (1.0, -1.0, 1.0)}),
        (AssociationConfig, {"gate_probability": 0.999, "new_landmark_probability": 0.99}),
        (SolverConfig, {"robust_threshold": -1.0}),
        (SolverConfig, {"robust_kernel": "cauchy"}),
        (ExperimentalConfig, {"budget_grace_images": 0}),
        (LandmarkConfig, {"outlier_gate_votes": -1}),
        (AssociationConfig, {"tentative_window_frames": 0}),
        (LoopClosureConfig, {"every_frames": 0}),
    ],
)
def test_sections_reject_bad_values(section, overrides):
    with pytest.raises(ConfigError):
        section(**overrides)


def test_kernel_thresholds_by_modality():
    auto = SolverConfig()
    assert auto.landmark_kernel(Modality.BEARINGS_3D) == (RobustKernel.HUBER, 3.0)
    assert auto.landmark_kernel(Modality.RANGE_BEARING_2D) == (RobustKernel.NONE, 0.0)
    assert auto.landmark_kernel(Modality.VERTICAL_LINES) == (RobustKernel.NONE, 0.0)
    off = SolverConfig(robust_kernel=RobustKernel.NONE, robust_threshold=2.0)
    assert off.landmark_kernel(Modality.BEARINGS_3D) == (RobustKernel.NONE, 0.0)
    huber = SolverConfig(robust_kernel=RobustKernel.HUBER)
    assert huber.landmark_kernel(Modality.RANGE_BEARING_2D) == (RobustKernel.HUBER, 1.345)
    wide = SolverConfig(robust_threshold=5.0)
    assert wide.landmark_kernel(Modality.BEARINGS_3D) == (RobustKernel.HUBER, 5.0)


def test_presets_differ_from_the_default_in_the_named_fields_only():
    default = GraphSLAMConfig()
    assert PRESETS["default"] == default
    assert PRESETS["robust"] == dataclasses.replace(
        default,
        solver=SolverConfig(robust_kernel=RobustKernel.CAUCHY),
        landmarks=LandmarkConfig(min_consistent_sightings=2),
    )
    gtsam_file = PRESETS["victoria-park-gtsam"]
    assert gtsam_file.poses.odometry_sigmas == (0.01, 0.002, 0.002)
    assert dataclasses.replace(gtsam_file, poses=PoseConfig()) == default


def test_dotted_keys_reach_the_sections_and_old_flat_keys_name_their_new_key():
    config = apply_options(
        GraphSLAMConfig(),
        {
            "association.gate_probability": "0.95",
            "experimental.loop_closure.enabled": "true",
            "poses.sensor_height_m": "0.4",
        },
    )
    assert config.association.gate_probability == 0.95
    assert config.experimental.loop_closure.enabled
    assert config.poses.sensor_height_m == 0.4
    with pytest.raises(ConfigError, match=re.escape("it is set as 'poses.sensor_height_m'")):
        apply_options(GraphSLAMConfig(), {"sensor_height_m": "0.4"})
    with pytest.raises(ConfigError, match=re.escape("it is set as 'solver.online_lag_key_frames'")):
        apply_options(GraphSLAMConfig(), {"online_lag_key_frames": "none"})
    with pytest.raises(ConfigError, match=re.escape("'association.gate_probability'")):
        apply_options(GraphSLAMConfig(), {"association_gate_probability": "0.95"})


def test_every_leaf_is_documented_and_unique():
    options = describe_options(GraphSLAMConfig())
    leaves = [o.key.rsplit(".", 1)[-1] for o in options]
    assert len(leaves) == len(set(leaves))
    assert all(o.meaning for o in options), [o.key for o in options if not o.meaning]
