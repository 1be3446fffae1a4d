"""The graph's pose covariances (iSAM2 marginals, computed by default) are consistent: on
simulated runs with the noise the graph assumes, the pose NEES the reports print lies inside its
95 % chi-square band."""

from __future__ import annotations

import numpy as np
import pytest
from graphslam_scenarios import MOTION_NOISE, configured, run, simulate_planar
from scipy.stats import chi2

from omnislam.core.modality import Modality
from omnislam.core.types import Trajectory
from omnislam.graphslam import GraphSLAM, GraphSLAMConfig
from omnislam.metrics.consistency import NEES_CONFIDENCE, pose_nees

pytest.importorskip("gtsam")

#: independent simulated runs (Monte Carlo) of the consistency test
RUNS = 8


def test_the_graph_gives_pose_covariances_by_default():
    assert GraphSLAMConfig().compute_covariances


def test_graph_pose_nees_on_simulated_runs_lies_inside_the_95_percent_band():
    config = configured(GraphSLAMConfig(motion_noise=MOTION_NOISE))
    final_nees, medians = [], []
    for seed in range(RUNS):
        scenario = simulate_planar(np.random.default_rng(100 + seed))
        estimate = run(
            GraphSLAM(Modality.RANGE_BEARING_2D, config, scenario.poses_true[0]), scenario.frames
        )
        assert estimate.pose_covariances is not None
        stamps = np.arange(len(scenario.poses_true), dtype=float)
        result = pose_nees(
            estimate.trajectory,
            estimate.pose_covariances,
            Trajectory.from_se2(stamps, scenario.poses_true),
        )
        assert result.dof == 3 and result.skipped == 0
        final_nees.append(result.values[-1])
        medians.append(result.median)
    # the final pose of independent runs: the sum of their NEES is chi-square with 3 * RUNS dof
    low, high = chi2.ppf([(1 - NEES_CONFIDENCE) / 2, (1 + NEES_CONFIDENCE) / 2], 3 * RUNS)
    assert low <= float(np.sum(final_nees)) <= high
    # every pose of every run: the median NEES near that of chi-square with 3 dof (2.37)
    assert 0.5 * chi2.median(3) < float(np.median(medians)) < 2.0 * chi2.median(3)
