"""Landmark slots shared by all particles: known id -> slot, reported ids, gating positions.

FastSLAM addresses every landmark EKF by a slot index that means the same landmark in every
particle (``landmark_store``). A known landmark id always maps to the same slot; for a sighting
of unknown association a particle that creates a new landmark (Montemerlo 2003 sec. 3.4) gets a
fresh slot, used by the particles that created it and absent in the others, and reported with
the id ``UNKNOWN_SLOT_ID_BASE + slot``.

Each slot also keeps the last position any particle wrote for it: association and the existence
index (thesis sec. 5.1.2) only look at the slots near the robot (``near``), which keeps them
O(nearby landmarks) instead of O(map).
"""

from __future__ import annotations

import numpy as np

from omnislam.fastslam.landmark_store import LandmarkStore

#: ids reported for landmarks created from sightings of unknown association: base + slot
UNKNOWN_SLOT_ID_BASE = 1 << 32


class SlotRegistry:
    """The slots of one filter's landmark store.

    Args:
        store: the landmark store whose slots are registered here; ``add`` allocates them.
    """

    def __init__(self, store: LandmarkStore) -> None:
        self._store = store
        self._slot_of_id: dict[int, int] = {}
        self._slot_ids = np.zeros(0, dtype=np.int64)
        self._reference_xy = np.zeros((0, 2))  # last written position of each slot (gating)
        self._reference_valid = np.zeros(0, dtype=bool)
        self._n_slots = 0
        self._n_unknown = 0

    @property
    def n_slots(self) -> int:
        """Number of slots M (landmarks known to any particle)."""
        return self._n_slots

    @property
    def n_unknown(self) -> int:
        """Slots created for sightings of unknown association."""
        return self._n_unknown

    def ids(self, slots: np.ndarray) -> np.ndarray:
        """The reported landmark ids of ``slots``."""
        return self._slot_ids[slots]

    def add(self, external_ids: np.ndarray | None, count: int) -> np.ndarray:
        """Allocate ``count`` slots in the store; ids default to UNKNOWN_SLOT_ID_BASE + slot.

        Returns:
            (count,) the new slots.
        """
        slots = self._store.add_landmarks(count)
        end = self._n_slots + count
        if end > self._slot_ids.size:
            capacity = max(end, 2 * self._slot_ids.size, 16)
            self._slot_ids = np.resize(self._slot_ids, capacity)
            self._reference_xy = np.concatenate(
                [self._reference_xy, np.zeros((capacity - self._reference_xy.shape[0], 2))]
            )
            valid = np.zeros(capacity, dtype=bool)
            valid[: self._n_slots] = self._reference_valid[: self._n_slots]
            self._reference_valid = valid
        if external_ids is None:
            ids = UNKNOWN_SLOT_ID_BASE + slots
            self._n_unknown += count
        else:
            ids = external_ids
        self._slot_ids[self._n_slots : end] = ids
        self._reference_valid[self._n_slots : end] = False
        self._n_slots = end
        return slots

    def slots_for_ids(self, ids: np.ndarray) -> np.ndarray:
        """Slots of known landmark ids, allocating slots for ids seen for the first time."""
        slots = np.empty(ids.size, dtype=np.int64)
        fresh: list[int] = []
        for i, landmark_id in enumerate(ids.tolist()):
            slot = self._slot_of_id.get(landmark_id)
            if slot is None:
                slot = self._n_slots + len(fresh)
                self._slot_of_id[landmark_id] = slot
                fresh.append(landmark_id)
            slots[i] = slot
        if fresh:
            self.add(np.array(fresh, dtype=np.int64), len(fresh))
        return slots

    def record_positions(self, slots: np.ndarray, positions_xy: np.ndarray) -> None:
        """Remember the positions (N, 2) just written for ``slots`` (N,) (the gating reference)."""
        self._reference_xy[slots] = positions_xy
        self._reference_valid[slots] = True

    def near(self, center_xy: np.ndarray, radius_m: float) -> np.ndarray:
        """Slots whose last written position lies within ``radius_m`` of ``center_xy`` (2,)."""
        n = self._n_slots
        offsets = self._reference_xy[:n] - center_xy
        near = np.einsum("ij,ij->i", offsets, offsets) <= radius_m * radius_m
        return np.flatnonzero(near & self._reference_valid[:n])
