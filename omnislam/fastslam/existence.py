"""The existence index of thesis sec. 5.1.2: which landmarks the sensor should have seen.

A landmark's index rises by one when it is seen and falls by one when it lies inside the
sensor's field (range, horizontal field of view and, for the omni camera, elevation band) from
the particle's pose but was not seen; it is deleted once negative. This removes landmarks born
from wrong correspondences.
"""

from __future__ import annotations

import numpy as np

from omnislam.core.se import wrap_angle
from omnislam.fastslam.config import ExistenceIndexConfig
from omnislam.fastslam.landmark_store import ABSENT, ESTIMATED, LandmarkStore
from omnislam.fastslam.sightings import Pairs
from omnislam.fastslam.slot_registry import SlotRegistry


def predicted_visible(
    config: ExistenceIndexConfig,
    wTr: np.ndarray,
    landmarks_w: np.ndarray,
    sensor_height_m: float = 0.0,
) -> np.ndarray:
    """Whether each landmark lies inside the sensor's field from each pose.

    Args:
        config: the sensor field.
        wTr: (N, 3) poses.
        landmarks_w: (N, 2) or (N, 3) landmark positions.
        sensor_height_m: viewpoint height for 3-D landmarks [m].

    Returns:
        (N,) bool.
    """
    dx = landmarks_w[:, 0] - wTr[:, 0]
    dy = landmarks_w[:, 1] - wTr[:, 1]
    horizontal = np.hypot(dx, dy)
    if landmarks_w.shape[1] > 2:
        dz = landmarks_w[:, 2] - sensor_height_m
        distance = np.hypot(horizontal, dz)
        elevation = np.arctan2(dz, horizontal)
        in_band = (elevation >= config.min_elevation_rad) & (elevation <= config.max_elevation_rad)
    else:
        distance = horizontal
        in_band = np.ones(len(dx), dtype=bool)
    bearing = wrap_angle(np.arctan2(dy, dx) - wTr[:, 2])
    in_range = (distance >= config.min_range_m) & (distance <= config.max_range_m)
    return in_range & in_band & (np.abs(bearing) <= config.half_fov_rad)


class ExistenceIndex:
    """Applies thesis 5.1.2 after each update: -1 for every established landmark predicted
    inside the sensor's field but not seen; negative -> deleted from that particle's map (the
    +1 of a sighting is counted by the update).

    Args:
        config: the sensor field.
        margin_m: the slots considered lie within ``config.max_range_m`` plus this of the mean
            pose (by their last written position, ``SlotRegistry.near``) [m].
        sensor_height_m: viewpoint height for 3-D landmarks [m].
    """

    def __init__(
        self, config: ExistenceIndexConfig, margin_m: float, sensor_height_m: float
    ) -> None:
        self._config = config
        self._radius_m = config.max_range_m + margin_m
        self._sensor_height_m = sensor_height_m
        #: (particle, landmark) deletions so far
        self.pruned = 0

    def apply(
        self,
        store: LandmarkStore,
        registry: SlotRegistry,
        poses: np.ndarray,
        weights: np.ndarray,
        pairs: Pairs,
    ) -> None:
        """Decrement (and delete) the landmarks that ``pairs`` did not address but should have.

        Args:
            store: the landmark store, changed in place.
            registry: the filter's slots.
            poses: (P, 3) the particles' poses of this frame; weights: (P,) their weights.
            pairs: the (particle, slot) pairs this frame updated.
        """
        center = np.average(poses[:, :2], axis=0, weights=weights)
        candidates = registry.near(center, self._radius_m)
        if candidates.size == 0:
            return
        p = len(poses)
        who = np.repeat(np.arange(p), candidates.size)
        slots = np.broadcast_to(candidates, (p, candidates.size)).ravel()
        m = max(registry.n_slots, 1)
        unseen = ~np.isin(who * m + slots, pairs.particle * m + pairs.slot)
        who, slots = who[unseen], slots[unseen]
        block = store.gather(who, slots)
        missed = (block.status == ESTIMATED) & predicted_visible(
            self._config, poses[who], block.mean, self._sensor_height_m
        )
        rows = np.flatnonzero(missed)
        if rows.size == 0:
            return
        changed = block.take(rows)
        changed.existence -= 1
        gone = changed.existence < 0
        self.pruned += int(np.count_nonzero(gone))
        changed.status[gone] = ABSENT
        changed.existence[gone] = 0
        changed.mean[gone] = 0.0
        changed.cov[gone] = 0.0
        changed.ray[gone] = 0.0
        store.scatter(who[rows], slots[rows], changed)
