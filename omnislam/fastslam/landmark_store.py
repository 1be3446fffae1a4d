"""The ``LandmarkStore`` protocol: every particle's landmark EKFs behind gather / scatter.

FastSLAM keeps one small EKF per landmark per particle (thesis eq. 4.22). Landmarks are
addressed by a *slot* index 0..M-1 that means the same landmark in every particle (the filter
maps external ids to slots); a slot a particle has not (yet, or any more) mapped has status
``ABSENT``. A store holds, per (particle, slot): the mean (d,), covariance (d, d), status,
existence index (thesis 5.1.2) and, for bearing-only landmarks, the last sighting's ray
(origin, direction) in the world (thesis eqs. 4.24 / 4.28).

Implementations:

* ``DenseLandmarkStore`` (``dense_store.py``): arrays (P, M, ...), copied on resampling; the
  readable reference and test oracle.
* ``LandmarkTree`` (``landmark_tree.py``): a persistent balanced binary tree shared between
  particles, path copying on update (thesis sec. 4.4.1.3; Montemerlo 2003 sec. 3.3.5).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum
from typing import Protocol, runtime_checkable

import numpy as np


class LandmarkStatus(IntEnum):
    """Life cycle of one landmark in one particle (thesis sec. 4.4.1.1-4.4.1.2)."""

    ABSENT = 0  #: never seen by this particle, or deleted by the existence index
    RAY = 1  #: seen once by a bearing sensor: only the ray is stored (eq. 4.24)
    ESTIMATED = 2  #: has a mean and covariance (eq. 4.28)


#: the statuses as the int8 values of ``LandmarkBlock.status``, to compare and assign
ABSENT, RAY, ESTIMATED = (np.int8(status) for status in LandmarkStatus)


@dataclass(slots=True)
class LandmarkBlock:
    """Payload of N (particle, slot) pairs; the arrays are the caller's to modify.

    Attributes:
        mean: (N, d) landmark positions in the world [m].
        cov: (N, d, d) their covariances [m^2].
        status: (N,) int8 ``LandmarkStatus`` values.
        existence: (N,) int32 existence index (thesis 5.1.2).
        ray: (N, r) last sighting's ray [origin_w (3), unit direction_w (3)] for bearing-only
            landmarks (r = 6), or (N, 0) for range-bearing landmarks.
    """

    mean: np.ndarray
    cov: np.ndarray
    status: np.ndarray
    existence: np.ndarray
    ray: np.ndarray

    @classmethod
    def empty(cls, n: int, dim: int, ray_dim: int) -> LandmarkBlock:
        """N absent landmarks (zeros everywhere)."""
        return cls(
            mean=np.zeros((n, dim)),
            cov=np.zeros((n, dim, dim)),
            status=np.zeros(n, dtype=np.int8),
            existence=np.zeros(n, dtype=np.int32),
            ray=np.zeros((n, ray_dim)),
        )

    def __len__(self) -> int:
        return int(self.status.shape[0])

    def take(self, index: np.ndarray | slice) -> LandmarkBlock:
        """The rows ``index`` (a copy for an index array, a view for a slice)."""
        return LandmarkBlock(
            self.mean[index],
            self.cov[index],
            self.status[index],
            self.existence[index],
            self.ray[index],
        )

    def put(self, index: np.ndarray | slice, other: LandmarkBlock) -> None:
        """Overwrite the rows ``index`` with ``other``."""
        self.mean[index] = other.mean
        self.cov[index] = other.cov
        self.status[index] = other.status
        self.existence[index] = other.existence
        self.ray[index] = other.ray


@runtime_checkable
class LandmarkStore(Protocol):
    """Per-particle landmark maps with value semantics: writing one particle's copy of a
    landmark never changes another particle's (map independence)."""

    @property
    def n_particles(self) -> int:
        """Number of particles P."""
        ...

    @property
    def n_landmarks(self) -> int:
        """Number of slots M (landmarks known to any particle)."""
        ...

    def add_landmarks(self, count: int) -> np.ndarray:
        """Append ``count`` slots, absent in every particle; returns their slot indices."""
        ...

    def gather(self, particles: np.ndarray, slots: np.ndarray) -> LandmarkBlock:
        """Copies of the landmarks ``slots[i]`` of particles ``particles[i]`` (N pairs)."""
        ...

    def scatter(self, particles: np.ndarray, slots: np.ndarray, block: LandmarkBlock) -> None:
        """Write ``block[i]`` as landmark ``slots[i]`` of particle ``particles[i]``.

        The (particle, slot) pairs must be unique. Only the addressed particle's copy changes.
        """
        ...

    def resample(self, ancestors: np.ndarray) -> None:
        """Particle i becomes a copy of old particle ``ancestors[i]`` (P,)."""
        ...

    def particle_map(self, particle: int) -> LandmarkBlock:
        """All M slots of one particle."""
        ...

    @property
    def memory_bytes(self) -> int:
        """Bytes held by the payload and index arrays."""
        ...
