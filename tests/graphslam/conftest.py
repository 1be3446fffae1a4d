"""Fixtures of the GTSAM back-end tests (scenarios and tolerances: graphslam_scenarios.py)."""

from __future__ import annotations

import pytest

pytest.importorskip("gtsam")

from graphslam_scenarios import Scenario, simulate_omni, simulate_planar


@pytest.fixture
def planar(rng) -> Scenario:
    return simulate_planar(rng)


@pytest.fixture
def omni(rng) -> Scenario:
    return simulate_omni(rng)
