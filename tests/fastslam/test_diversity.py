"""The particle-diversity record: distinct ancestors, single-ancestor runs, ESS."""

from __future__ import annotations

import numpy as np
from fastslam_scenario import SCENARIO_NOISE, make_scenario

from omnislam.core.modality import Modality
from omnislam.fastslam import FastSLAMConfig, Variant, make_fastslam
from omnislam.fastslam.diversity import DiversityLog


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
    config = FastSLAMConfig(variant=Variant.FASTSLAM1, n_particles=20, motion_noise=SCENARIO_NOISE)
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
