"""Feature groups: the thesis's "objects" (section 4.1.3, after Jung 2004).

Keypoints that are close to each other in the image and of similar contrast are grown into
clusters: starting from one keypoint, every keypoint within the distance threshold whose
contrast is within the contrast threshold joins, and the growth repeats from the new members
until nothing more joins. This is exactly a connected component of the graph whose edges are
the (distance, contrast) links, which is how it is computed here. Clusters with fewer members
than the size threshold are discarded ("the number of landmarks per instant drops
considerably, but the ones kept are more stable").
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from omnislam.frontend.config import GroupConfig

#: group label of a feature whose cluster was discarded
NO_GROUP = -1


def group_features(
    pixels: np.ndarray, sizes_px: np.ndarray, contrast: np.ndarray, config: GroupConfig
) -> np.ndarray:
    """Label each keypoint with its group (thesis 4.1.3).

    Args:
        pixels: (N, 2) keypoint positions [px].
        sizes_px: (N,) keypoint diameters [px].
        contrast: (N,) detector responses (positive).
        config: link distance, contrast ratio and minimum size.

    Returns:
        (N,) int64 labels ``0..G-1`` numbered by first member, ``NO_GROUP`` for keypoints
        whose cluster has fewer than ``config.min_size`` members.
    """
    n = pixels.shape[0]
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    sizes_px = np.asarray(sizes_px, dtype=float)
    reach = max(config.distance_px, config.scale_factor * float(sizes_px.max()))
    pairs = cKDTree(pixels).query_pairs(reach, output_type="ndarray")
    if pairs.size:
        i, j = pairs[:, 0], pairs[:, 1]
        gap = np.linalg.norm(pixels[i] - pixels[j], axis=1)
        limit = np.maximum(config.distance_px, config.scale_factor * np.maximum(sizes_px[i],
                                                                                 sizes_px[j]))
        c = np.maximum(np.abs(np.asarray(contrast, dtype=float)), 1e-12)
        ratio = np.maximum(c[i], c[j]) / np.minimum(c[i], c[j])
        link = (gap <= limit) & (ratio <= config.contrast_ratio)
        i, j = i[link], j[link]
    else:
        i = j = np.zeros(0, dtype=np.int64)
    graph = coo_matrix((np.ones(i.shape[0]), (i, j)), shape=(n, n))
    _, component = connected_components(graph, directed=False)
    sizes = np.bincount(component)
    keep = sizes[component] >= config.min_size
    labels = np.full(n, NO_GROUP, dtype=np.int64)
    # renumber the kept components 0..G-1 in order of their first member
    kept_components, first = np.unique(component[keep], return_index=True)
    order = np.argsort(first)
    renumber = np.full(sizes.shape[0], NO_GROUP, dtype=np.int64)
    renumber[kept_components[order]] = np.arange(kept_components.shape[0])
    labels[keep] = renumber[component[keep]]
    return labels
