"""Ray caster on open3d's Embree ``RaycastingScene`` (extra ``render``).

Each quad is added as two triangles (``QuadArrays.triangles``); triangle k belongs to quad
k // 2. open3d works in float32, so the distance is recomputed in float64 against the hit
quad's plane (``plane_distances``).
"""

from __future__ import annotations

import numpy as np

from omnislam._optional import require
from omnislam.datasets.synthetic.hit_distances import MIN_DISTANCE_M, plane_distances
from omnislam.datasets.synthetic.world import QuadArrays


class Open3DRayCaster:
    """First-hit ray caster backed by ``open3d.t.geometry.RaycastingScene``."""

    def __init__(self, quads: QuadArrays) -> None:
        o3d = require("open3d")
        self._o3d = o3d
        self.quads = quads
        self._scene = o3d.t.geometry.RaycastingScene()
        if len(quads):
            vertices, triangles = quads.triangles()
            self._scene.add_triangles(
                o3d.core.Tensor(vertices.astype(np.float32)),
                o3d.core.Tensor(triangles.astype(np.uint32)),
            )
        # INVALID_ID is 2**32 - 1: -1 as int32, and it stays -1 through ``>> 1`` (quad id)
        if int(o3d.t.geometry.RaycastingScene.INVALID_ID) != 2**32 - 1:  # pragma: no cover
            raise RuntimeError("unexpected open3d RaycastingScene.INVALID_ID")

    def first_hits(self, origin_w: np.ndarray, directions_w: np.ndarray) -> np.ndarray:
        """See ``RayCaster.first_hits``."""
        n = directions_w.shape[0]
        rays = np.empty((n, 6), dtype=np.float32)
        rays[:, :3] = origin_w
        rays[:, 3:] = directions_w
        result = self._scene.cast_rays(self._o3d.core.Tensor.from_numpy(rays))
        prim = result["primitive_ids"].numpy().view(np.int32)
        return prim >> 1

    def cast(self, origin_w: np.ndarray, directions_w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """See ``RayCaster.cast``."""
        directions_w = np.asarray(directions_w, dtype=float)
        ids = self.first_hits(origin_w, directions_w).astype(np.int64)
        distances = plane_distances(self.quads, np.asarray(origin_w, float), directions_w, ids)
        too_close = distances <= MIN_DISTANCE_M
        ids[too_close] = -1
        distances[too_close] = np.inf
        return distances, ids
