"""How far a ray travels to the quad it hits, shared by the ray casters and the loader.

Both ray-casting back ends (``raycast_numpy``, ``raycast_open3d``) return the distance
recomputed in float64 as the intersection of the ray with the hit quad's plane
(``plane_distances``), so the ground-truth points do not inherit open3d's float32; hits closer
than ``MIN_DISTANCE_M`` to their origin are ignored.
"""

from __future__ import annotations

import numpy as np

from omnislam.datasets.synthetic.world import QuadArrays

#: rays closer than this to their origin are ignored [m]
MIN_DISTANCE_M = 1e-4


def plane_distances(
    quads: QuadArrays, origin_w: np.ndarray, directions_w: np.ndarray, surface_ids: np.ndarray
) -> np.ndarray:
    """Exact (float64) distance along each ray to the plane of its hit quad; inf where id < 0.

    t = n.(o_q - o) / n.d for the quad's normal n and origin o_q, the ray's origin o and
    direction d.

    Args:
        quads: the world's quads.
        origin_w: (3,) ray origin in the world [m].
        directions_w: (N, 3) ray directions in the world.
        surface_ids: (N,) hit quad of each ray, -1 where none.

    Returns:
        (N,) distances [m] in units of ``directions_w`` (metres for unit directions).
    """
    hit = surface_ids >= 0
    out = np.full(surface_ids.shape, np.inf)
    q = surface_ids[hit]
    num = np.einsum("ij,ij->i", quads.normals_w, quads.origins_w - origin_w)  # per quad (M,)
    out[hit] = num[q] / np.einsum("ij,ij->i", quads.normals_w[q], directions_w[hit])
    return out
