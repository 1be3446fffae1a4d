"""Nearest-neighbour association with chi-square gates."""

from __future__ import annotations

import numpy as np

from omnislam.graphslam.association import (
    AMBIGUOUS,
    NEW_LANDMARK,
    Gates,
    associate,
    sighting_points,
)


def test_gates_are_chi_square_quantiles():
    gates = Gates.from_probabilities(0.99, 0.9999)
    np.testing.assert_allclose([gates.match, gates.new_landmark], [9.2103, 18.4207], atol=1e-3)


def test_sighting_points_invert_range_bearing_and_grow_with_pose_uncertainty():
    wTr = np.array([1.0, 1.0, np.pi / 2])
    points, covs = sighting_points(
        wTr, np.array([2.0]), np.array([0.0]), np.array([0.1]), np.array([0.01])
    )
    np.testing.assert_allclose(points[0], [1.0, 3.0], atol=1e-12)
    np.testing.assert_allclose(np.diag(covs[0]), [0.02**2, 0.1**2], atol=1e-12)
    _, wider = sighting_points(
        wTr,
        np.array([2.0]),
        np.array([0.0]),
        np.array([0.1]),
        np.array([0.01]),
        np.diag([0.1, 0.1, 0.01]),
    )
    assert np.all(np.linalg.eigvalsh(wider[0] - covs[0]) > 0)


def test_match_new_and_ambiguous():
    gates = Gates.from_probabilities(0.99, 0.9999)
    landmarks = np.array([[0.0, 0.0], [10.0, 0.0]])
    points = np.array([[0.1, 0.0], [5.0, 5.0], [10.0, 0.5], [0.15, 0.0]])
    covs = np.tile(0.01 * np.eye(2), (4, 1, 1))
    indices, d2 = associate(points, covs, landmarks, 0.1, gates)
    # sighting 0 takes landmark 0; 3 also gates on 0 but is farther: ambiguous, not a duplicate
    assert indices.tolist() == [0, NEW_LANDMARK, AMBIGUOUS, AMBIGUOUS]
    assert d2[0] < gates.match < d2[2] <= gates.new_landmark


def test_empty_map_makes_everything_new():
    gates = Gates.from_probabilities(0.99, 0.9999)
    indices, d2 = associate(
        np.zeros((2, 2)), np.tile(np.eye(2), (2, 1, 1)), np.zeros((0, 2)), 0.1, gates
    )
    assert indices.tolist() == [NEW_LANDMARK, NEW_LANDMARK] and np.all(np.isinf(d2))


def test_the_closer_sighting_takes_a_shared_landmark_whatever_its_order():
    """Two sightings gate on one landmark (d2 = 1 and 0.25 with S = 0.02 I): the closer
    one, listed second, takes it; the farther is ambiguous, with its own d2 kept."""
    gates = Gates.from_probabilities(0.99, 0.9999)
    points = np.array([[0.1414213562373095, 0.0], [0.0, 0.07071067811865475]])
    covs = np.tile(0.01 * np.eye(2), (2, 1, 1))
    indices, d2 = associate(points, covs, np.zeros((1, 2)), 0.1, gates)
    assert indices.tolist() == [AMBIGUOUS, 0]
    np.testing.assert_allclose(d2, [1.0, 0.25], rtol=1e-12)
