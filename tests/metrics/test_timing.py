"""Step timing: the warm-up (compilation, the first frame) is reported apart from the steps."""

from __future__ import annotations

import numpy as np
import pytest

from omnislam.metrics.timing import WARMUP_FACTOR, timing_stats, warmup_steps


def test_the_first_step_is_always_warm_up_and_excluded_from_the_step_statistics():
    steps_s = np.full(100, 1e-3)
    steps_s[0] = 0.76  # the first frame compiles the kernels
    stats = timing_stats(steps_s)
    assert stats.warmup_steps == 1 and stats.warmup_s == pytest.approx(0.76)
    assert stats.max_ms == pytest.approx(1.0) and stats.mean_ms == pytest.approx(1.0)
    assert stats.steps_total_s == pytest.approx(0.76 + 99e-3)  # the total keeps it


def test_a_compiled_step_later_in_the_first_tenth_extends_the_warm_up():
    steps_s = np.full(200, 2e-3)
    steps_s[7] = 0.5  # a code path first reached at the eighth frame
    steps_s[150] = 0.5  # a slow step late in the run is a step like any other
    assert warmup_steps(steps_s) == 8
    stats = timing_stats(steps_s)
    assert stats.warmup_s == pytest.approx(7 * 2e-3 + 0.5)
    assert stats.max_ms == pytest.approx(500.0)  # the late one stays in the statistics
    assert stats.median_ms == pytest.approx(2.0)


def test_ordinary_variation_is_not_warm_up():
    rng = np.random.default_rng(0)
    steps_s = rng.uniform(1e-3, 0.9 * WARMUP_FACTOR * 1e-3, 300)
    steps_s[0] = 1e-3
    assert warmup_steps(steps_s) == 1
    assert timing_stats(np.zeros(0)).warmup_steps == 0
