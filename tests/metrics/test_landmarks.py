"""Landmark map error: by id after the trajectory's alignment, or by assignment within a gate."""

import numpy as np
import pytest

from omnislam.metrics.landmarks import LandmarkAssociation, landmark_error


def test_landmarks_by_id_after_alignment():
    rng = np.random.default_rng(40)
    truth = np.column_stack([rng.uniform(-10, 10, (20, 2)), np.zeros(20)])
    T = np.eye(4)
    T[:2, :2] = [[np.cos(0.3), -np.sin(0.3)], [np.sin(0.3), np.cos(0.3)]]
    T[:2, 3] = [1.0, -2.0]
    est = (truth - T[:3, 3]) @ T[:3, :3]  # the truth in the estimate's frame
    est[:5, 0] += 0.3  # five landmarks 0.3 m off
    ids = np.arange(20)
    result = landmark_error(
        np.r_[ids[:18], 99], np.r_[est[:18], est[18:19]], ids, truth, T, LandmarkAssociation.BY_ID
    )
    assert result.matched == 18 and result.missed == 2 and result.spurious == 1
    assert result.rmse_m == pytest.approx(np.sqrt(5 * 0.09 / 18))


def test_landmarks_by_assignment_count_duplicates_spurious_and_misses():
    truth = np.array([[0, 0, 0], [10, 0, 0], [0, 10, 0], [10, 10, 0]], float)
    est = np.array(
        [
            [0.1, 0, 0],  # matches 0
            [0.5, 0.2, 0],  # a duplicate of 0 (inside the gate, farther)
            [10, 0.2, 0],  # matches 1
            [0, 10.3, 0],  # matches 2
            [30, 30, 0],  # spurious
        ]
    )
    result = landmark_error(np.arange(5) + 100, est, np.arange(4), truth, gate_m=1.0)
    assert result.matched == 3 and result.duplicates == 1
    assert result.spurious == 1 and result.missed == 1
    assert sorted(result.errors_m) == pytest.approx([0.1, 0.2, 0.3])
