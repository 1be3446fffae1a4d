"""The mapping step: every addressed landmark EKF updated from the sampled poses (thesis 4.4.1).

Per (particle, slot, sighting) pair the modality's mapper initialises or updates the landmark
(``mapper.LandmarkMapper.update``) and returns its innovation log-likelihood, FastSLAM 1.0's
importance factor (thesis eq. 4.47); FastSLAM 2.0 weighs in its proposal instead. A landmark
seen twice in one frame is updated twice, in successive rounds (``sightings.Pairs.rounds``).
Each update also counts a sighting of the existence index (thesis 5.1.2: +1 when seen) and
records the landmark's position for the coarse gates (``SlotRegistry.record_positions``).
"""

from __future__ import annotations

import numpy as np

from omnislam.fastslam.landmark_store import ESTIMATED, LandmarkBlock, LandmarkStore
from omnislam.fastslam.mapper import LandmarkMapper
from omnislam.fastslam.resighting import ResightingSpread
from omnislam.fastslam.sightings import Pairs, Sightings, tentative_pairs
from omnislam.fastslam.slot_registry import SlotRegistry


class LandmarkUpdate:
    """Updates the landmarks a frame's pairs address and returns their weight factors.

    Args:
        mapper: the modality's landmark EKFs.
        store: the landmark store, changed in place.
        slots: the filter's slots.
        log_p0: the weight factor of a sighting a particle made a new landmark
            (``AssociationConfig.new_landmark_log_likelihood``).
        weigh: whether the innovation likelihoods are the weight factors (FastSLAM 1.0).
        confirm_sightings: a landmark of unknown association seen fewer times weighs log p0
            instead of its likelihood (``ExperimentalConfig.confirm_sightings``; FastSLAM 1.0).
        likelihood_temper: the likelihoods are raised to this power
            (``ExperimentalConfig.likelihood_temper``; FastSLAM 1.0).
        spread: the association's spread since each landmark was last seen, restarted for the
            landmarks updated (``resighting.ResightingSpread``), or None.
    """

    def __init__(
        self,
        mapper: LandmarkMapper,
        store: LandmarkStore,
        slots: SlotRegistry,
        log_p0: float,
        *,
        weigh: bool,
        confirm_sightings: int = 1,
        likelihood_temper: float = 1.0,
        spread: ResightingSpread | None = None,
    ) -> None:
        self._mapper = mapper
        self._store = store
        self._slots = slots
        self._log_p0 = log_p0
        self._weigh = weigh
        self._confirm = confirm_sightings
        self._temper = likelihood_temper
        self._spread = spread

    def __call__(
        self,
        poses: np.ndarray,
        sightings: Sightings,
        pairs: Pairs,
        gathered: LandmarkBlock | None = None,
    ) -> np.ndarray:
        """Update every addressed landmark EKF with the sampled poses, in rounds.

        Args:
            poses: (P, 3) the particles' poses of this frame.
            sightings: the frame's sightings; pairs: what they address.
            gathered: the landmarks of all ``pairs`` as gathered for the FastSLAM 2.0 proposal
                (unchanged since), reused when one round updates them all.

        Returns:
            (P,) log weight factors: the EKF innovation likelihoods for FastSLAM 1.0 (thesis
            eq. 4.47), plus log p0 for each unknown sighting a particle made a new landmark.
        """
        log_factors = np.zeros(len(poses))
        if pairs.new_unknown.any():
            np.add.at(log_factors, pairs.particle[pairs.new_unknown], self._log_p0)
        rounds = self._rounds(sightings, pairs)
        for these in rounds:
            if len(rounds) == 1 and gathered is not None:
                block = gathered
            else:
                block = self._store.gather(these.particle, these.slot)
            log_likelihood = self._update(block, poses[these.particle], sightings, these)
            if log_likelihood is not None:
                np.add.at(log_factors, these.particle, log_likelihood)
        return log_factors

    def _rounds(self, sightings: Sightings, pairs: Pairs) -> list[Pairs]:
        """The pairs split into rounds in which every (particle, slot) appears once; one round
        when every sighting has a distinct id."""
        known = sightings.ids[sightings.ids >= 0]
        if known.size == sightings.ids.size and np.unique(known).size == known.size:
            return [pairs]  # all (particle, slot) pairs distinct
        rank = pairs.rounds(self._slots.n_slots)
        rounds = int(rank.max(initial=0)) + 1
        if rounds == 1:
            return [pairs]
        out = []
        for r in range(rounds):
            rows = np.flatnonzero(rank == r)
            out.append(
                Pairs(
                    pairs.particle[rows], pairs.slot[rows], pairs.obs[rows], pairs.new_unknown[rows]
                )
            )
        return out

    def _update(
        self, block: LandmarkBlock, wTr: np.ndarray, sightings: Sightings, these: Pairs
    ) -> np.ndarray | None:
        """One round: the landmarks of ``block`` (those of ``these``) updated from the poses
        ``wTr`` and written back. Returns the pairs' weight factors (FastSLAM 1.0), else None."""
        tentative = None
        if self._weigh and self._confirm > 1:
            tentative = tentative_pairs(these, sightings, block.existence, self._confirm)
        log_likelihood = self._mapper.update(block, wTr, sightings, these.obs)
        if tentative is not None and tentative.any():
            # a tentative landmark's sighting weighs as a new landmark's (p0)
            log_likelihood = np.where(tentative, self._log_p0, log_likelihood)
        block.existence += 1  # thesis 5.1.2: +1 when seen
        slots = these.slot
        self._store.scatter(these.particle, slots, block)
        estimated = block.status == ESTIMATED
        self._slots.record_positions(slots[estimated], block.mean[estimated, :2])
        if self._spread is not None:
            self._spread.seen(np.unique(slots))
        if not self._weigh:
            return None
        if self._temper != 1.0:
            log_likelihood = self._temper * log_likelihood
        return log_likelihood
