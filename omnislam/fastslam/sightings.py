"""One frame's sightings in filter form, and the (particle, slot, sighting) pairs they address.

A mapper (``range_bearing_mapper``, ``bearing_mapper``) reads its modality's stream of a
``FrameInput`` into ``Sightings``; the association (``association``) turns them into ``Pairs``:
every particle's landmark slot for every sighting (thesis sec. 4.4.1; with unknown ids per
particle, Montemerlo 2003 sec. 3.4). The proposal, the landmark updates and the existence index
then work on the pairs, vectorised across particles and sightings.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np


@dataclass(frozen=True, slots=True)
class Sightings:
    """One frame's K observations of the filter's modality.

    Attributes:
        ids: (K,) landmark / track ids, ``UNKNOWN_ID`` where the association is unknown.
        z: (K, k) measurements: (range [m], bearing [rad]) in 2-D, (azimuth, elevation) [rad]
            in 3-D, in the robot frame.
        R: (K, k, k) their noise covariances.
        unit_vectors_r: (K, 3) unit bearings in the robot frame (3-D only, else None).
        sigmas_rad: (K,) angular std of each bearing (3-D only, else None).
    """

    ids: np.ndarray
    z: np.ndarray
    R: np.ndarray
    unit_vectors_r: np.ndarray | None = None
    sigmas_rad: np.ndarray | None = None


@dataclass(frozen=True, slots=True)
class Pairs:
    """N (particle, slot, sighting) triples to process.

    Attributes:
        particle: (N,) particle index.
        slot: (N,) landmark slot (``slot_registry``) in that particle's map.
        obs: (N,) index of the sighting in ``Sightings``.
        new_unknown: (N,) True where the particle made a new landmark for a sighting of unknown
            association.
    """

    particle: np.ndarray
    slot: np.ndarray
    obs: np.ndarray
    new_unknown: np.ndarray

    @classmethod
    def concatenate(cls, parts: list[Pairs]) -> Pairs:
        """The pairs of ``parts`` one after the other."""
        if len(parts) == 1:
            return parts[0]
        names = [f.name for f in fields(cls)]
        return cls(*(np.concatenate([getattr(part, name) for part in parts]) for name in names))

    def rounds(self, n_slots: int) -> np.ndarray:
        """Rank of each pair among the pairs with the same (particle, slot): a landmark seen
        twice in one frame is updated twice, in successive rounds.

        Returns:
            (N,) int64 ranks, 0 for the first pair of each (particle, slot).
        """
        key = self.particle * max(n_slots, 1) + self.slot
        order = np.argsort(key, kind="stable")
        sorted_key = key[order]
        n = key.size
        starts = np.r_[True, sorted_key[1:] != sorted_key[:-1]]
        group_start = np.maximum.accumulate(np.where(starts, np.arange(n), 0))
        rank = np.empty(n, dtype=np.int64)
        rank[order] = np.arange(n) - group_start
        return rank


def tentative_pairs(
    pairs: Pairs, sightings: Sightings, existence: np.ndarray, confirm_sightings: int
) -> np.ndarray:
    """Which pairs address a tentative landmark (``ExperimentalConfig.confirm_sightings``).

    A landmark of unknown association that its particle has seen fewer than
    ``confirm_sightings`` times before this frame is tentative; a landmark's ``existence``
    counts its sightings, the first included (``LandmarkBlock.existence``, thesis 5.1.2; net
    of the existence index's decrements when that is on).

    Args:
        pairs: the frame's N pairs; sightings: the frame's sightings.
        existence: (N,) the addressed landmarks' existence counts before this frame's update.
        confirm_sightings: sightings that confirm a landmark (1: none is tentative).

    Returns:
        (N,) bool, False for new landmarks and for sightings with ids.
    """
    if confirm_sightings <= 1:
        return np.zeros(pairs.particle.size, dtype=bool)
    unknown = sightings.ids[pairs.obs] < 0
    return unknown & ~pairs.new_unknown & (existence < confirm_sightings)
