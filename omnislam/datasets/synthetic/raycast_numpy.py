"""Pure numpy ray caster: every ray against every quad, in chunks (the test oracle).

Ray-plane intersection ``t = n.(o_q - o) / n.d``, then the parallelogram test with the dual
basis of the quad's edges (``QuadArrays.dual_u_w``): the hit point ``p`` is inside when both
``(p - o_q).dual_u`` and ``(p - o_q).dual_v`` lie in [0, 1]. Cost O(rays x quads): fine for a
few hundred quads, slow for thousands (use open3d there).
"""

from __future__ import annotations

import numpy as np

from omnislam.datasets.synthetic.hit_distances import MIN_DISTANCE_M, plane_distances
from omnislam.datasets.synthetic.world import QuadArrays

#: ray x quad products evaluated at once: small enough to stay in cache and to keep OpenBLAS
#: single-threaded (its threads made the (rays, 3) @ (3, quads) products ~7x slower on a
#: loaded 2-core machine with 2**21); at least _MIN_CHUNK_RAYS rays per chunk
_CHUNK_ELEMENTS = 1 << 15
_MIN_CHUNK_RAYS = 256


class NumpyRayCaster:
    """Brute-force first-hit ray caster (see module docstring)."""

    def __init__(self, quads: QuadArrays) -> None:
        self.quads = quads
        self._normals_t = np.ascontiguousarray(quads.normals_w.T)
        self._dual_t = np.ascontiguousarray(np.concatenate([quads.dual_u_w, quads.dual_v_w]).T)

    def cast(self, origin_w: np.ndarray, directions_w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """See ``RayCaster.cast``."""
        directions_w = np.asarray(directions_w, dtype=float)
        ids = self.first_hits(origin_w, directions_w).astype(np.int64)
        return plane_distances(self.quads, np.asarray(origin_w, float), directions_w, ids), ids

    def first_hits(self, origin_w: np.ndarray, directions_w: np.ndarray) -> np.ndarray:
        """See ``RayCaster.first_hits``."""
        q = self.quads
        m = len(q)
        origin_w = np.asarray(origin_w, dtype=float)
        directions_w = np.asarray(directions_w, dtype=float)
        n_rays = directions_w.shape[0]
        ids = np.full(n_rays, -1, dtype=np.int32)
        if m == 0 or n_rays == 0:
            return ids
        per_ray = origin_w.ndim == 2
        if per_ray:  # n.(o_q - o) and (o - o_q).dual as quad constants minus per-ray products
            num_q = np.sum(q.normals_w * q.origins_w, axis=1)
            ab0_q = -np.concatenate([np.sum(q.dual_u_w * q.origins_w, axis=1),
                                     np.sum(q.dual_v_w * q.origins_w, axis=1)])
        else:
            rel = q.origins_w - origin_w  # (M, 3)
            num = np.sum(q.normals_w * rel, axis=1)  # n.(o_q - o)
            a0 = -np.sum(q.dual_u_w * rel, axis=1)  # (o - o_q).dual_u
            b0 = -np.sum(q.dual_v_w * rel, axis=1)
        chunk = max(_MIN_CHUNK_RAYS, _CHUNK_ELEMENTS // m)
        for start in range(0, n_rays, chunk):
            d = directions_w[start:start + chunk]
            if per_ray:
                o = origin_w[start:start + chunk]
                num = num_q - o @ self._normals_t
                ab0 = ab0_q + o @ self._dual_t
                a0, b0 = ab0[:, :m], ab0[:, m:]
            with np.errstate(divide="ignore", invalid="ignore"):
                t = num / (d @ self._normals_t)
                ab = d @ self._dual_t
                a = a0 + t * ab[:, :m]
                b = b0 + t * ab[:, m:]
            inside = (t > MIN_DISTANCE_M) & (a >= 0) & (a <= 1) & (b >= 0) & (b <= 1)
            t = np.where(inside, t, np.inf)
            best = np.argmin(t, axis=1)
            hit = np.isfinite(t[np.arange(t.shape[0]), best])
            ids[start:start + chunk] = np.where(hit, best, -1)
        return ids
