"""Feature groups (thesis 4.1.3) and matching (ratio test, map index, object validation)."""

from __future__ import annotations

import numpy as np
import pytest

from omnislam.frontend.config import GroupConfig, MatchConfig
from omnislam.frontend.groups import NO_GROUP, group_features
from omnislam.frontend.matching import (
    MapIndex,
    match_brute_force,
    ratio_test,
    validate_objects,
)


def test_groups_grow_by_distance_and_contrast_and_drop_small_ones():
    # cluster A: 4 points in a chain 5 px apart, similar contrast; cluster B: 3 points close
    # but one has 10x the contrast (not linked); C: an isolated point
    pixels = np.array([[0, 0], [5, 0], [10, 0], [15, 0],
                       [100, 100], [104, 100], [108, 100],
                       [300, 300]], dtype=float)
    contrast = np.array([1.0, 1.2, 0.9, 1.1, 1.0, 1.0, 10.0, 1.0])
    sizes = np.full(8, 2.0)
    config = GroupConfig(distance_px=6.0, scale_factor=0.0, contrast_ratio=2.0, min_size=3)
    labels = group_features(pixels, sizes, contrast, config)
    assert np.all(labels[:4] == 0)
    assert np.all(labels[4:] == NO_GROUP)  # B breaks into a pair and a single; C alone
    loose = GroupConfig(distance_px=6.0, scale_factor=0.0, contrast_ratio=20.0, min_size=3)
    labels = group_features(pixels, sizes, contrast, loose)
    assert labels[4] == labels[5] == labels[6] == 1 and labels[7] == NO_GROUP


def test_ratio_test_keeps_distinctive_matches_only():
    distances = np.array([[1.0, 10.0], [9.0, 10.0]])
    indices = np.array([[3, 4], [5, 6]])
    m = ratio_test(distances, indices, 0.8)
    assert m.query.tolist() == [0] and m.train.tolist() == [3]


@pytest.fixture
def descriptors(rng):
    d = rng.random((300, 128)).astype(np.float32)
    return 512 * d / np.linalg.norm(d, axis=1, keepdims=True)


def test_brute_force_recovers_a_permutation(descriptors, rng):
    order = rng.permutation(300)
    noisy = descriptors[order] + rng.normal(scale=2.0, size=(300, 128)).astype(np.float32)
    m = match_brute_force(noisy, descriptors, MatchConfig())
    assert len(m) > 290
    np.testing.assert_array_equal(m.train, order[m.query])
    assert len(np.unique(m.train)) == len(m)


def test_map_ratio_test_ignores_duplicates_of_the_same_object(descriptors):
    # landmark 7 and 8 are one point seen twice (same object 1): not ambiguous
    map_desc = np.vstack([descriptors[:50], descriptors[:1]])
    labels = np.arange(51)
    objects = np.arange(51)
    objects[50] = objects[0]
    index = MapIndex(map_desc, labels, objects, MatchConfig(flann_checks=256))
    q, found, _ = index.query(descriptors[:1])
    assert q.tolist() == [0] and found[0] in (0, 50)
    # the same duplicate in another object is ambiguous and is rejected
    objects[50] = 99
    index = MapIndex(map_desc, labels, objects, MatchConfig(flann_checks=256))
    q, _, _ = index.query(descriptors[:1])
    assert q.size == 0


def test_object_validation_needs_enough_matches_of_the_object():
    objects = np.array([1, 1, 1, 2, 2, 3])
    live = np.array([0, 3, 40, 1])
    keep = validate_objects(objects, live, MatchConfig(min_object_matches=2,
                                                       min_object_fraction=0.1))
    # object 1: 3 of 3; object 2: 2 of 40 (5 % < 10 %); object 3: 1 match < 2
    assert keep.tolist() == [True, True, True, False, False, False]
