"""Delayed (bearing-only) and consistent (range-bearing) insertion bookkeeping."""

from __future__ import annotations

import numpy as np
import pytest

from omnislam.graphslam.landmark_init import ConsistentInsertion, DelayedInsertion


def _viewpoints(origins):
    return lambda frame: (origins[frame], np.eye(3))


def _ray(origin, point):
    d = np.asarray(point) - origin
    return d / np.linalg.norm(d)


def test_track_waits_for_sightings_and_parallax_then_triangulates():
    point = np.array([5.0, 2.0, 1.5])
    origins = np.array([[x, 0.0, 0.8] for x in (0.0, 0.02, 0.04, 1.0)])
    delayed = DelayedInsertion(min_sightings=3, min_parallax_rad=np.deg2rad(3.0))
    view = _viewpoints(origins)
    for frame in range(3):  # three sightings but < 3 deg of parallax
        delayed.hold(9, frame, _ray(origins[frame], point), f"factor{frame}")
        assert delayed.try_insert(9, view) is None
    assert delayed.stats().tracks_pending == 1 and delayed.stats().sightings_pending == 3
    delayed.hold(9, 3, _ray(origins[3], point), "factor3")
    insertion = delayed.try_insert(9, view)
    assert insertion is not None
    np.testing.assert_allclose(insertion.point_w, point, atol=1e-9)
    assert insertion.factors == ["factor0", "factor1", "factor2", "factor3"]
    assert not delayed.is_pending(9)
    assert delayed.stats().tracks_inserted == 1 and delayed.stats().tracks_pending == 0


def test_point_behind_the_rays_is_rejected():
    origins = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    point = np.array([1.0, 5.0, 0.0])
    delayed = DelayedInsertion(3, np.deg2rad(3.0))
    for frame in range(3):
        delayed.hold(1, frame, -_ray(origins[frame], point), None)  # pointing away
    assert delayed.try_insert(1, _viewpoints(origins)) is None
    assert delayed.stats().triangulations_rejected == 1


@pytest.mark.parametrize("release_disagreeing", [True, False])
def test_consistent_insertion_ignores_a_wrong_first_sighting(release_disagreeing):
    """The wrong first sighting disagrees (10 m at 0.1 m sigma): the landmark starts at the
    mean of the two agreeing ones; the wrong factor is released for a robust kernel, or
    dropped and counted as rejected."""
    gate = 9.21
    consistent = ConsistentInsertion(2, gate, release_disagreeing=release_disagreeing)
    cov = 0.01 * np.eye(2)
    consistent.hold(4, np.array([10.0, 0.0]), cov, "wrong")
    assert consistent.try_insert(4) is None
    consistent.hold(4, np.array([0.0, 0.0]), cov, "right1")
    assert consistent.try_insert(4) is None
    assert consistent.stats().tracks_pending == 1 and consistent.stats().sightings_pending == 2
    consistent.hold(4, np.array([0.05, 0.0]), cov, "right2")
    insertion = consistent.try_insert(4)
    assert insertion is not None
    np.testing.assert_allclose(insertion.point_w, [0.025, 0.0])
    if release_disagreeing:
        assert insertion.factors == ["wrong", "right1", "right2"] and consistent.rejected == 0
    else:
        assert insertion.factors == ["right1", "right2"] and consistent.rejected == 1
    stats = consistent.stats()
    assert stats.tracks_inserted == 1 and stats.tracks_pending == 0
    assert consistent.try_insert(4) is None  # inserted once, then forgotten


def test_min_consistent_one_inserts_at_once():
    consistent = ConsistentInsertion(1, 9.21)
    consistent.hold(2, np.array([1.0, 2.0]), np.eye(2), "f")
    insertion = consistent.try_insert(2)
    assert insertion is not None
    np.testing.assert_array_equal(insertion.point_w, [1.0, 2.0])
    assert insertion.factors == ["f"] and consistent.stats().tracks_inserted == 1
