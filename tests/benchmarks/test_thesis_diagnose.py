"""``benchmarks/thesis_diagnose.py``: the path-coalescence count against ``PathHistory``'s own
(``particles.PathHistory.lineages``), and the effective sample size of one frame's factors."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from omnislam.fastslam.particles import ParticleSet, PathHistory

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "benchmarks"))  # thesis_diagnose imports thesis_metrics
_spec = importlib.util.spec_from_file_location(
    "thesis_diagnose", REPO / "benchmarks" / "thesis_diagnose.py"
)
td = importlib.util.module_from_spec(_spec)
sys.modules["thesis_diagnose"] = td
_spec.loader.exec_module(td)

P, FRAMES = 8, 30


def test_lineages_agree_with_the_path_history() -> None:
    """Random resamplings on some frames: the distinct ancestors at every lag from the last
    frame are the ones ``PathHistory.lineages`` traces."""
    rng = np.random.default_rng(3)
    history = PathHistory(keep_particles=True)
    particles = ParticleSet(np.zeros((P, 3)))
    ancestors = {}
    for frame in range(FRAMES):
        history.record(float(frame), particles)
        if rng.random() < 0.5:
            chosen = np.sort(rng.integers(0, P, P))
            history.record_resampling(chosen)
            particles.resample(chosen)
            ancestors[frame] = chosen
    expected = history.lineages()[::-1]  # lag 0 (the last frame) first
    assert np.array_equal(td.lineages(ancestors, P, FRAMES - 1, FRAMES - 1), expected)
    assert expected[-1] < P  # the draw did coalesce some paths: the test can fail


def test_ess_alone() -> None:
    """Equal factors give P; one particle holding all the weight gives 1; two equal halves 2."""
    assert td.ess_alone(np.zeros(P)) == pytest.approx(P)
    assert td.ess_alone(np.r_[0.0, np.full(P - 1, -1e3)]) == pytest.approx(1.0)
    assert td.ess_alone(np.r_[0.0, 0.0, np.full(P - 2, -1e3)]) == pytest.approx(2.0)
