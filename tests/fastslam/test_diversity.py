"""The particle-diversity record: distinct ancestors, single-ancestor runs, ESS."""

from __future__ import annotations

import numpy as np
import pytest
from fastslam_scenario import SCENARIO_NOISE, make_scenario

from omnislam.core.modality import Modality
from omnislam.fastslam import (
    ExperimentalConfig,
    FastSLAMConfig,
    ParticlesConfig,
    TrajectoryMode,
    Variant,
    make_fastslam,
)
from omnislam.fastslam.diversity import DiversityLog
from omnislam.fastslam.particles import ParticleSet, PathHistory


def test_counts_distinct_ancestors_and_runs_of_collapse():
    log = DiversityLog(4)
    log.record(4.0, None)  # no resampling: the set keeps its 4 members
    log.record(1.5, np.array([0, 0, 0, 0]))  # collapsed
    log.record(1.2, np.array([2, 2, 2, 2]))  # collapsed again
    log.record(3.0, None)
    log.record(1.1, np.array([1, 1, 1, 1]))
    log.record(2.0, np.array([0, 1, 1, 3]))
    np.testing.assert_array_equal(log.distinct, [4, 1, 1, 4, 1, 3])
    np.testing.assert_array_equal(log.resampled, [False, True, True, False, True, True])
    summary = log.summary()
    assert summary.steps == 6 and summary.resamplings == 4
    assert summary.distinct_min == 1
    assert summary.single_ancestor_steps == 3
    assert summary.single_ancestor_longest_run == 2  # a step without resampling ends a run
    assert summary.distinct_median_at_resampling == 1.0
    assert summary.ess_min == 1.1


def test_an_empty_record_reports_the_full_set():
    summary = DiversityLog(7).summary()
    assert (summary.steps, summary.resamplings, summary.distinct_min) == (0, 0, 7)
    assert summary.ess_min == 7.0 and summary.single_ancestor_longest_run == 0


def test_the_filter_records_every_step_with_sightings():
    frames = make_scenario(0, steps=60).frames
    config = FastSLAMConfig(
        variant=Variant.FASTSLAM1,
        particles=ParticlesConfig(n_particles=20),
        motion_noise=SCENARIO_NOISE,
    )
    slam = make_fastslam(config, Modality.RANGE_BEARING_2D, np.random.default_rng(0))
    for frame in frames:
        slam.step(frame)
    diversity = slam.diversity
    assert diversity.distinct.size == len(frames)
    assert int(diversity.resampled.sum()) == slam.resample_count > 0
    assert np.all(diversity.distinct[~diversity.resampled] == 20)
    assert np.all((diversity.distinct >= 1) & (diversity.distinct <= 20))
    assert np.all(diversity.ess[diversity.resampled] < 10.0)  # ESS < P/2 triggered them
    info = slam.info()
    summary = diversity.summary()
    assert info.distinct_ancestors_min == summary.distinct_min
    assert info.single_ancestor_longest_run == summary.single_ancestor_longest_run
    assert info.ess_min == summary.ess_min <= slam.last_ess


def test_lineages_count_the_distinct_poses_the_current_paths_pass_through():
    history = PathHistory(keep_particles=True)
    particles = ParticleSet(np.zeros((4, 3)))
    for step, ancestors in enumerate(
        [np.array([0, 0, 1, 1]), None, np.array([2, 2, 3, 3]), np.array([0, 1, 1, 1])]
    ):
        particles.poses = particles.poses + 1.0
        history.record(float(step), particles)
        if ancestors is not None:
            history.record_resampling(ancestors)
            particles.resample(ancestors)
    # back from the last step: step 3 draws from {0, 1}, which step 2 drew from {2}; step 1
    # kept its set ({2}), which step 0 drew from {1}
    np.testing.assert_array_equal(history.lineages(), [1, 1, 1, 2])


def test_lineages_agree_with_the_traced_paths_of_a_run():
    frames = make_scenario(1, steps=60).frames
    config = FastSLAMConfig(
        variant=Variant.FASTSLAM1,
        particles=ParticlesConfig(n_particles=20),
        motion_noise=SCENARIO_NOISE,
        experimental=ExperimentalConfig(trajectory=TrajectoryMode.BEST_ANCESTRY),
    )
    slam = make_fastslam(config, Modality.RANGE_BEARING_2D, np.random.default_rng(2))
    for frame in frames:
        slam.step(frame)
    paths = np.stack([slam.history.ancestry_trajectory(i).se2 for i in range(20)])
    distinct = [np.unique(paths[:, t], axis=0).shape[0] for t in range(len(frames))]
    lineages = slam.history.lineages()
    np.testing.assert_array_equal(lineages, distinct)  # sampled poses are all distinct
    assert lineages[-1] == 20 or slam.diversity.resampled[-1]
    assert np.all(np.diff(lineages) >= 0)  # going back in time, lineages only merge
    assert lineages[0] < 20  # 60 steps of resampling coalesce the paths


def test_lineages_need_the_kept_particles():
    with pytest.raises(ValueError, match="keep_particles"):
        PathHistory(keep_particles=False).lineages()
