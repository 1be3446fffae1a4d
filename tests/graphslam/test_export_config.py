"""g2o export (round trip through gtsam.readG2o) and configuration validation."""

from __future__ import annotations

import numpy as np
import pytest
from graphslam_scenarios import MOTION_NOISE, SENSOR_HEIGHT_M, run, simulate_omni, simulate_planar

from omnislam.core.modality import Modality
from omnislam.errors import ConfigError
from omnislam.graphslam import GraphSLAM, GraphSLAMConfig, RobustKernel
from omnislam.graphslam.config import PRESETS
from omnislam.graphslam.export import write_g2o

gtsam = pytest.importorskip("gtsam")


def test_g2o_2d_round_trip(tmp_path, rng):
    scenario = simulate_planar(rng, n=40, laps=0.5)
    estimator = GraphSLAM(
        Modality.RANGE_BEARING_2D,
        GraphSLAMConfig(motion_noise=MOTION_NOISE),
        scenario.poses_true[0],
    )
    estimate = run(estimator, scenario.frames)
    report = write_g2o(estimator.factor_graph(), estimator.values(), tmp_path / "g.g2o")
    assert report.poses == 40 and report.odometry_edges == 39
    assert report.landmarks == len(estimate.landmark_ids)
    sightings = sum(len(f.range_bearing) for f in scenario.frames)
    assert report.landmark_edges == sightings and report.factors_skipped == 1  # the prior
    graph, values = gtsam.readG2o(str(tmp_path / "g.g2o"), False)
    assert graph.size() >= 39  # the odometry edges (gtsam may also read the landmark edges)
    poses = gtsam.utilities.extractPose2(values)
    # gtsam.writeG2o prints 6 significant digits
    np.testing.assert_allclose(poses, estimate.trajectory.se2, rtol=1e-5, atol=1e-5)
    lines = (tmp_path / "g.g2o").read_text().splitlines()
    xy = np.array(
        [[float(v) for v in ln.split()[2:]] for ln in lines if ln.startswith("VERTEX_XY")]
    )
    np.testing.assert_allclose(xy, estimate.landmarks_w[:, :2], atol=1e-6)
    edge = next(ln for ln in lines if ln.startswith("EDGE_SE2_XY")).split()
    assert len(edge) == 8 and float(edge[5]) > 0 and float(edge[7]) > 0


def test_g2o_3d_writes_poses_and_points_and_counts_bearing_factors(tmp_path, rng):
    scenario = simulate_omni(rng, n=30, laps=0.5)
    estimator = GraphSLAM(
        Modality.BEARINGS_3D,
        GraphSLAMConfig(motion_noise=MOTION_NOISE, sensor_height_m=SENSOR_HEIGHT_M),
        scenario.poses_true[0],
    )
    run(estimator, scenario.frames)
    report = write_g2o(estimator.factor_graph(), estimator.values(), tmp_path / "g.g2o")
    assert report.poses == 30 and report.odometry_edges == 29 and report.landmark_edges == 0
    bearing_factors = estimator.factor_graph().size() - 29 - 30  # minus odometry and priors
    assert report.factors_skipped == bearing_factors + 30
    text = (tmp_path / "g.g2o").read_text()
    assert text.count("VERTEX_SE3:QUAT") == 30
    assert text.count("VERTEX_TRACKXYZ") == report.landmarks > 0


@pytest.mark.parametrize(
    "overrides",
    [
        {"relinearize_threshold": 0.0},
        {"min_sightings": 1},
        {"prior_sigmas": (1.0, -1.0, 1.0)},
        {"association_gate_probability": 0.999, "new_landmark_probability": 0.99},
        {"robust_threshold": -1.0},
        {"robust_kernel": "cauchy"},
    ],
)
def test_config_rejects_bad_values(overrides):
    with pytest.raises(ConfigError):
        GraphSLAMConfig(**overrides)


def test_presets_and_kernel_thresholds():
    assert GraphSLAMConfig().kernel_threshold == 0.0
    assert GraphSLAMConfig(robust_kernel=RobustKernel.HUBER).kernel_threshold == 1.345
    assert PRESETS["robust"].robust_kernel is RobustKernel.CAUCHY
    assert PRESETS["victoria-park-gtsam"].odometry_sigmas == (0.01, 0.002, 0.002)
