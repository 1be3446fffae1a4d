"""The per-image landmark budget of bearing-only back ends (graphslam's omni graph, EKF-SLAM).

An omni image carries ~200 bearings of feature tracks that mostly see the same few walls; each
landmark costs a back end variables (a graph's Point3, three rows and columns of an EKF's
covariance) and every later sighting an update. With a budget B a track is used only once it is
*admitted*: bearings of admitted tracks are always used; while an image shows fewer than B
admitted tracks, tracks seen in it are admitted, the most-sighted so far first, taking turns
over ``AZIMUTH_SECTORS`` azimuth sectors (the least covered first), so that the landmarks
surround the robot (a pose is determined by bearings spread in azimuth). (Moved here from
``graphslam.bearings_3d`` so that EKF-SLAM shares it without importing GTSAM.)
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
    """

    def __init__(self, per_image: int, sectors: int = AZIMUTH_SECTORS) -> None:
        if per_image < 1 or sectors < 1:
            raise ValueError("need per_image >= 1 and sectors >= 1")
        self._per_image = per_image
        self._sectors = sectors
        self._admitted: set[int] = set()
        self._sightings: dict[int, int] = {}  # sightings so far of every track

    def __contains__(self, track_id: object) -> bool:
        return track_id in self._admitted

    def admit(self, ids: np.ndarray, rays_r: np.ndarray) -> np.ndarray:
        """Count one image's sightings, admit tracks up to the budget, return the admitted mask.

        Args:
            ids: (K,) track ids of the image's bearings (no UNKNOWN_ID).
            rays_r: (K, 3) their unit vectors in the robot frame.

        Returns:
            (K,) bool: the bearings of admitted tracks (including those admitted now).
        """
        counts = self._sightings
        id_list = ids.tolist()
        for lid in id_list:
            counts[lid] = counts.get(lid, 0) + 1
        admitted = np.fromiter((lid in self._admitted for lid in id_list), bool, len(id_list))
        room = self._per_image - int(admitted.sum())
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
            self._admitted.add(id_list[row])
            admitted[row] = True
            load[q] += 1
            room -= 1
        return admitted | np.fromiter((lid in self._admitted for lid in id_list), bool)
