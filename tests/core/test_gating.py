"""Chi-square validation gates and the gate-truncated likelihood."""

import math

import numpy as np
import pytest

from omnislam.core.gating import (
    GatedResightings,
    Resighting,
    chi_square_gate,
    gate_truncated_log_likelihood,
    lies_on_a_landmark,
)
from omnislam.core.gaussian import log_likelihood_from_mahalanobis


def test_chi_square_gate():
    assert math.isclose(chi_square_gate(0.999, 2), -2.0 * math.log(0.001))
    assert math.isclose(chi_square_gate(0.95, 3), 7.814727903251178)
    assert chi_square_gate(1.0, 2) == math.inf


def test_gate_keeps_its_probability_of_consistent_innovations(rng):
    """y ~ N(0, S): y^T S^-1 y <= gate for the gate's fraction of the draws."""
    gate = chi_square_gate(0.95, 3)
    y = rng.standard_normal((200_000, 3))
    inside = np.mean(np.einsum("ni,ni->n", y, y) <= gate)
    assert abs(inside - 0.95) < 3e-3


def test_truncated_likelihood_is_the_gaussian_inside_and_at_the_gate_outside():
    gate = chi_square_gate(0.999, 2)
    mahalanobis = np.array([0.5, gate, 3.0 * gate, 1e3])
    logdet = np.array([-3.0, -1.0, 0.5, 2.0])
    log_likelihood = log_likelihood_from_mahalanobis(mahalanobis, logdet, 2)
    truncated = gate_truncated_log_likelihood(log_likelihood, mahalanobis, gate)
    np.testing.assert_array_equal(truncated[:2], log_likelihood[:2])
    at_gate = log_likelihood_from_mahalanobis(np.full(2, gate), logdet[2:], 2)
    np.testing.assert_allclose(truncated[2:], at_gate, rtol=1e-12)
    unbounded = gate_truncated_log_likelihood(log_likelihood, mahalanobis, math.inf)
    np.testing.assert_array_equal(unbounded, log_likelihood)


def _resighting(frame: int, x: float, sigma: float = 0.05) -> Resighting:
    return Resighting(frame, np.array([x, 0.0]), sigma**2 * np.eye(2), frame)


def test_agreeing_gated_sightings_overrule_the_gate_once_there_are_enough():
    held = GatedResightings(chi_square_gate(0.999, 2), votes=3, window_frames=10)
    assert held.offer(7, _resighting(0, 1.00)) == []
    assert held.offer(7, _resighting(1, 1.02)) == []
    assert held.offer(8, _resighting(1, 5.00)) == []  # another landmark's: held apart
    overruled = held.offer(7, _resighting(2, 0.99))
    assert [r.payload for r in overruled] == [0, 1, 2]
    assert held.readmitted == 3
    assert held.offer(7, _resighting(3, 1.0)) == []  # they left with the overrule: start again


def test_disagreeing_or_stale_gated_sightings_are_dropped():
    held = GatedResightings(chi_square_gate(0.999, 2), votes=3, window_frames=10)
    held.offer(7, _resighting(0, 1.0))
    held.offer(7, _resighting(1, 1.0))
    # 0.5 m away at 5 cm per point: another point, so the two held ones are dropped
    assert held.offer(7, _resighting(2, 1.5)) == []
    assert held.offer(7, _resighting(3, 1.5)) == []
    assert len(held.offer(7, _resighting(4, 1.5))) == 3
    held.offer(9, _resighting(10, 2.0))
    held.offer(9, _resighting(11, 2.0))
    assert held.offer(9, _resighting(25, 2.0)) == []  # the first two are older than the window
    never = GatedResightings(chi_square_gate(0.999, 2), votes=0)
    assert all(never.offer(1, _resighting(k, 0.0)) == [] for k in range(5))
    with pytest.raises(ValueError, match="votes"):
        GatedResightings(1.0, votes=-1)


def test_a_point_lies_on_a_landmark_within_its_sighting_noise():
    gate = chi_square_gate(0.999, 2)
    landmarks = np.array([[0.0, 0.0], [3.0, 0.0]])
    covariance = 0.05**2 * np.eye(2)
    assert lies_on_a_landmark(np.array([3.1, 0.05]), covariance, landmarks, gate)
    assert not lies_on_a_landmark(np.array([3.5, 0.0]), covariance, landmarks, gate)
    assert not lies_on_a_landmark(np.zeros(2), covariance, np.zeros((0, 2)), gate)


def test_a_landmark_seen_within_the_window_holds_nothing_and_an_overrule_counts_as_seen():
    """A gated sighting of a landmark the back end used within ``window_frames`` (inclusive)
    is not held; an overrule marks the landmark seen, so the next gated ones are not held."""
    held = GatedResightings(chi_square_gate(0.999, 2), votes=2, window_frames=10)
    held.seen(7, 5)
    for frame in (10, 11, 15):  # 5, 6 and 10 frames after the landmark was used
        assert held.offer(7, _resighting(frame, 1.0)) == []
    assert held.offer(7, _resighting(16, 1.0)) == []  # 11 frames after: held, one vote
    assert [r.payload for r in held.offer(7, _resighting(17, 1.0))] == [16, 17]
    for frame in (18, 19, 27):  # within the window of the overrule at 17: not held
        assert held.offer(7, _resighting(frame, 1.0)) == []
    assert held.readmitted == 2
