"""Dense per-particle landmark arrays: the readable reference store and test oracle.

Every particle owns arrays (M, ...) inside one (P, M, ...) block; resampling copies the whole
block by fancy indexing (O(P M) per resampling), which is exactly what the landmark tree avoids.
Fancy indexing always copies, so particles never share memory (unlike the PythonRobotics
resampler, whose particles end up aliasing one landmark list).
"""

from __future__ import annotations

import numpy as np

from omnislam.fastslam.landmark_store import LandmarkBlock


class DenseLandmarkStore:
    """``LandmarkStore`` backed by arrays (P, capacity, ...), grown by doubling."""

    def __init__(
        self, n_particles: int, dim: int, ray_dim: int = 0, initial_capacity: int = 64
    ) -> None:
        """Args:
        n_particles: P.
        dim: landmark dimension d (2 or 3).
        ray_dim: 6 for bearing-only landmarks (stored ray), else 0.
        initial_capacity: slots allocated up front.
        """
        self._p = int(n_particles)
        self._dim = int(dim)
        self._ray_dim = int(ray_dim)
        self._m = 0
        self._data = self._allocate(max(1, int(initial_capacity)))

    def _allocate(self, capacity: int) -> LandmarkBlock:
        p, d, r = self._p, self._dim, self._ray_dim
        return LandmarkBlock(
            mean=np.zeros((p, capacity, d)),
            cov=np.zeros((p, capacity, d, d)),
            status=np.zeros((p, capacity), dtype=np.int8),
            existence=np.zeros((p, capacity), dtype=np.int32),
            ray=np.zeros((p, capacity, r)),
        )

    @property
    def n_particles(self) -> int:
        return self._p

    @property
    def n_landmarks(self) -> int:
        return self._m

    @property
    def capacity(self) -> int:
        return int(self._data.status.shape[1])

    def add_landmarks(self, count: int) -> np.ndarray:
        """Append ``count`` absent slots (grows the arrays by doubling when full)."""
        new_m = self._m + int(count)
        if new_m > self.capacity:
            bigger = self._allocate(max(new_m, 2 * self.capacity))
            m = self._m
            bigger.mean[:, :m] = self._data.mean[:, :m]
            bigger.cov[:, :m] = self._data.cov[:, :m]
            bigger.status[:, :m] = self._data.status[:, :m]
            bigger.existence[:, :m] = self._data.existence[:, :m]
            bigger.ray[:, :m] = self._data.ray[:, :m]
            self._data = bigger
        slots = np.arange(self._m, new_m)
        self._m = new_m
        return slots

    def gather(self, particles: np.ndarray, slots: np.ndarray) -> LandmarkBlock:
        """Copies of the N addressed landmarks (fancy indexing copies)."""
        d = self._data
        return LandmarkBlock(
            d.mean[particles, slots],
            d.cov[particles, slots],
            d.status[particles, slots],
            d.existence[particles, slots],
            d.ray[particles, slots],
        )

    def scatter(self, particles: np.ndarray, slots: np.ndarray, block: LandmarkBlock) -> None:
        """Write the N addressed landmarks in place (each particle owns its rows)."""
        d = self._data
        d.mean[particles, slots] = block.mean
        d.cov[particles, slots] = block.cov
        d.status[particles, slots] = block.status
        d.existence[particles, slots] = block.existence
        d.ray[particles, slots] = block.ray

    def resample(self, ancestors: np.ndarray) -> None:
        """Copy whole maps: particle i <- old particle ancestors[i] (O(P M))."""
        ancestors = np.asarray(ancestors, dtype=np.int64)
        m = self._m
        d = self._data
        # only the used slots are copied; the spare capacity stays zero (= absent)
        for name in ("mean", "cov", "status", "existence", "ray"):
            array = getattr(d, name)
            array[:, :m] = array[ancestors, :m]

    def particle_map(self, particle: int) -> LandmarkBlock:
        m = self._m
        d = self._data
        return LandmarkBlock(
            d.mean[particle, :m].copy(),
            d.cov[particle, :m].copy(),
            d.status[particle, :m].copy(),
            d.existence[particle, :m].copy(),
            d.ray[particle, :m].copy(),
        )

    @property
    def memory_bytes(self) -> int:
        d = self._data
        return int(
            d.mean.nbytes + d.cov.nbytes + d.status.nbytes + d.existence.nbytes + d.ray.nbytes
        )
