"""The ray-caster interface shared by the numpy and open3d back ends, and the backend choice.

A ray caster answers, for rays leaving one origin: which quad (surface id) is hit first and at
what distance. Both back ends return the distance recomputed in float64 as the intersection of
the ray with the hit quad's plane (``hit_distances``), so the ground-truth points do not inherit
open3d's float32.
"""

from __future__ import annotations

import enum
from typing import Protocol

import numpy as np

from omnislam._optional import available
from omnislam.datasets.synthetic.world import QuadArrays
from omnislam.errors import ConfigError


class Backend(enum.Enum):
    """Ray-casting implementation."""

    OPEN3D = "open3d"  # Embree through open3d.t.geometry.RaycastingScene (optional extra)
    NUMPY = "numpy"  # brute force over all quads; the test oracle

    @classmethod
    def default(cls) -> Backend:
        """open3d when installed, numpy otherwise."""
        return cls.OPEN3D if available("open3d") else cls.NUMPY


class RayCaster(Protocol):
    """First-hit queries against a fixed set of quads."""

    def cast(self, origin_w: np.ndarray, directions_w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Cast rays from one origin.

        Args:
            origin_w: (3,) ray origin in the world [m].
            directions_w: (N, 3) unit directions in the world.

        Returns:
            ``(distances_m (N,) float64, inf where nothing is hit; surface_ids (N,) int64, -1)``.
        """
        ...

    def first_hits(self, origin_w: np.ndarray, directions_w: np.ndarray) -> np.ndarray:
        """Only the surface ids of ``cast``: (N,) int32, -1 where nothing is hit (hits
        closer than ``hit_distances.MIN_DISTANCE_M`` may remain; ``cast`` removes them).
        ``origin_w`` may also be (N, 3), one origin per ray (a non-central camera)."""
        ...


def make_ray_caster(quads: QuadArrays, backend: Backend | str | None = None) -> RayCaster:
    """Build the ray caster of ``backend`` (default: ``Backend.default()``) for ``quads``."""
    backend = Backend.default() if backend is None else Backend(backend)
    if backend is Backend.OPEN3D:
        from omnislam.datasets.synthetic.raycast_open3d import Open3DRayCaster

        return Open3DRayCaster(quads)
    if backend is Backend.NUMPY:
        from omnislam.datasets.synthetic.raycast_numpy import NumpyRayCaster

        return NumpyRayCaster(quads)
    raise ConfigError(f"unknown ray-casting backend {backend}")  # pragma: no cover
