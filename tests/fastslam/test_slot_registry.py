"""The slot registry: stable slots per id, reported ids, and the positions near the robot."""

from __future__ import annotations

import numpy as np

from omnislam.fastslam.dense_store import DenseLandmarkStore
from omnislam.fastslam.slot_registry import UNKNOWN_SLOT_ID_BASE, SlotRegistry


def test_a_known_id_always_maps_to_the_same_slot():
    store = DenseLandmarkStore(3, 2, 0, 4)
    registry = SlotRegistry(store)
    first = registry.slots_for_ids(np.array([40, 7, 40]))
    np.testing.assert_array_equal(first, [0, 1, 0])
    np.testing.assert_array_equal(registry.slots_for_ids(np.array([7, 99])), [1, 2])
    assert registry.n_slots == store.n_landmarks == 3
    np.testing.assert_array_equal(registry.ids(np.arange(3)), [40, 7, 99])


def test_unknown_slots_get_reported_ids_and_gating_positions_survive_growth():
    store = DenseLandmarkStore(2, 2, 0, 1)
    registry = SlotRegistry(store)
    known = registry.slots_for_ids(np.array([5]))
    registry.record_positions(known, np.array([[1.0, 1.0]]))
    unknown = registry.add(None, 20)  # grows the arrays past their first capacity
    np.testing.assert_array_equal(registry.ids(unknown), UNKNOWN_SLOT_ID_BASE + unknown)
    assert registry.n_unknown == 20
    np.testing.assert_array_equal(registry.near(np.zeros(2), 2.0), known)
    registry.record_positions(unknown[3:4], np.array([[10.0, 0.0]]))
    np.testing.assert_array_equal(registry.near(np.array([9.0, 0.0]), 1.5), unknown[3:4])
    assert registry.near(np.array([50.0, 50.0]), 1.0).size == 0
