"""The per-image landmark budget of bearing-only back ends (graphslam's omni graph, EKF-SLAM).

An omni image carries ~200 bearings of feature tracks that mostly see the same few walls; each
landmark costs a back end variables (a graph's Point3, three rows and columns of an EKF's
covariance) and every later sighting an update. With a budget B a track is used only once it is
*admitted*: bearings of admitted tracks are always used; while an image shows fewer than B
admitted tracks, tracks seen in it are admitted, the most-sighted so far first, taking turns
over ``AZIMUTH_SECTORS`` azimuth sectors (the least covered first), so that the landmarks
surround the robot (a pose is determined by bearings spread in azimuth). (Moved here from
``graphslam.bearings_3d`` so that EKF-SLAM shares it without importing GTSAM.)

Grace (``grace_images``, off by default): an admitted track that the back end has not put to
use (``admit``'s ``in_use``: a graph landmark, not a track still waiting for its triangulation)
within that many images of its admission stops counting against the budget, so the image can
admit another. Outdoors most tracks are far and never triangulate: on campus1500 seed 0 the 40
admitted tracks in view were mostly such, and the graph mapped 1278 of 13 597 tracks.
"""

from __future__ import annotations

import numpy as np

#: azimuth sectors over which the landmark budget spreads the admitted tracks
AZIMUTH_SECTORS = 8


class TrackBudget:
    """Which tracks a back end admits under a per-image budget (see the module docstring).

    Args:
        per_image: the budget B (> 0).
        sectors: azimuth sectors the admissions take turns over.
        grace_images: admitted tracks not in use this many images after their admission stop
            counting against B (None: every admitted track counts).
    """

    def __init__(
        self, per_image: int, sectors: int = AZIMUTH_SECTORS, grace_images: int | None = None
    ) -> None:
        if per_image < 1 or sectors < 1:
            raise ValueError("need per_image >= 1 and sectors >= 1")
        if grace_images is not None and grace_images < 1:
            raise ValueError("need grace_images >= 1 or None")
        self._per_image = per_image
        self._sectors = sectors
        self._grace = grace_images
        self._admitted: dict[int, int] = {}  # admitted track -> the image it was admitted in
        self._sightings: dict[int, int] = {}  # sightings so far of every track
        self._images = 0

    def __contains__(self, track_id: object) -> bool:
        return track_id in self._admitted

    def admit(
        self, ids: np.ndarray, rays_r: np.ndarray, in_use: np.ndarray | None = None
    ) -> np.ndarray:
        """Count one image's sightings, admit tracks up to the budget, return the admitted mask.

        Args:
            ids: (K,) track ids of the image's bearings (no UNKNOWN_ID).
            rays_r: (K, 3) their unit vectors in the robot frame.
            in_use: (K,) bool, the tracks the back end uses (with ``grace_images``; None: all).

        Returns:
            (K,) bool: the bearings of admitted tracks (including those admitted now).
        """
        self._images += 1
        counts = self._sightings
        id_list = ids.tolist()
        for lid in id_list:
            counts[lid] = counts.get(lid, 0) + 1
        admitted = np.fromiter((lid in self._admitted for lid in id_list), bool, len(id_list))
        counted = admitted
        if self._grace is not None and in_use is not None:
            since = self._images - self._grace
            recent = np.fromiter(
                (self._admitted.get(lid, since) > since for lid in id_list), bool, len(id_list)
            )
            counted = admitted & (in_use | recent)
        room = self._per_image - int(counted.sum())
        if room <= 0:
            return admitted
        azimuth = np.arctan2(rays_r[:, 1], rays_r[:, 0])
        sector = np.floor((azimuth + np.pi) / (2 * np.pi) * self._sectors).astype(np.int64)
        sector %= self._sectors
        load = np.bincount(sector[admitted], minlength=self._sectors)
        candidates = np.flatnonzero(~admitted)
        # most-sighted first (stable: the front end's order breaks ties)
        order = candidates[
            np.argsort([-counts[id_list[i]] for i in candidates.tolist()], kind="stable")
        ]
        queues = [order[sector[order] == q].tolist() for q in range(self._sectors)]
        heads = [0] * self._sectors
        while room > 0:
            open_sectors = [q for q in range(self._sectors) if heads[q] < len(queues[q])]
            if not open_sectors:
                break
            q = min(open_sectors, key=lambda q: load[q])
            row = queues[q][heads[q]]
            heads[q] += 1
            if id_list[row] in self._admitted:  # a track seen twice in one image
                continue
            self._admitted[id_list[row]] = self._images
            admitted[row] = True
            load[q] += 1
            room -= 1
        return admitted | np.fromiter((lid in self._admitted for lid in id_list), bool)
