"""EKF-SLAM's association helpers: the gated nearest neighbour and the tentative landmarks."""

from __future__ import annotations

import numpy as np

from omnislam.core.gating import chi_square_gate
from omnislam.ekfslam.association import TentativeLandmarks, nearest_gated


def test_nearest_gated_takes_the_smallest_distance_inside_the_gate_inclusive():
    assert nearest_gated(np.array([4.0, 2.5, 3.0]), 2.5) == 1
    assert nearest_gated(np.array([4.0, 2.5, 3.0]), 2.4) is None
    assert nearest_gated(np.zeros(0), 10.0) is None


def test_a_tentative_match_skips_candidates_taken_in_the_frame():
    """Two candidates 0.45 m apart with 0.1 m sigma: a point on the first matches it, and with
    the first taken by another sighting of the frame it matches the second, never the taken
    one. The second is inside the 0.999 gate (13.8) only under the sum of both covariances:
    0.45^2 / (2 * 0.1^2) = 10.1, against 20.3 under one of them."""
    gate = chi_square_gate(0.999, 2)
    cov = 0.1**2 * np.eye(2)
    store = TentativeLandmarks()
    store.add(np.array([1.0, 1.0]), cov, 0.0)
    store.add(np.array([1.45, 1.0]), cov, 0.0)
    store.add(np.array([9.0, 9.0]), cov, 0.0)
    point = np.array([1.0, 1.0])
    assert store.match(point, cov, gate, taken=set()) == 0
    assert store.match(point, cov, gate, taken={0}) == 1
    assert store.match(point, cov, gate, taken={0, 1}) is None  # the third is far outside
