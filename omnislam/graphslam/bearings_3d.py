"""Graph builder of the omni front end's bearings (``Modality.BEARINGS_3D``).

Each bearing of a track becomes a ``BearingFactor3D(viewpoint, point, Unit3)`` (``factors.py``;
the Pose3 variables are the sensor viewpoints, ``poses.ViewpointPoses``). A track that is not
in the graph yet is held back until it can be triangulated (``builder.DelayedLandmarks``:
>= ``min_sightings`` sightings spanning >= ``min_parallax_deg``; docs/design.md "Landmark
insertion") and enters as a ``Point3`` with its held-back factors and the weak prior. Bearings
without a track id are ignored (counted).

Per-image landmark budget (``LandmarkConfig.per_image``, ``TrackBudget``): an omni
image carries ~200 bearings of tracks that mostly see the same few walls; each landmark adds 3
variables and a bearing factor per sighting, and on a route that revisits its landmarks the
Bayes tree's cliques grow with them. With a budget B, a track enters the graph only once it is
*admitted*: bearings of admitted tracks are always used; while an image shows fewer than B
admitted tracks, tracks seen in it are admitted, the most-sighted so far first, taking turns
over ``AZIMUTH_SECTORS`` azimuth sectors (the least covered first), so that the landmarks
surround the robot (a pose is determined by bearings spread in azimuth). An admitted track's
earlier sightings, kept aside while it waited, are held back with it for the delayed insertion.

Outlier gate: a bearing of a mapped landmark that points away from it -- the angle between the
measured ray and the direction from the guessed viewpoint to the landmark's insertion point
beyond max(5 sigma, 20 deg) -- is not added (counted as gated). A wrong front-end association
can point anywhere, and a Unit3 bearing error near 180 deg has a degenerate Jacobian that makes
iSAM2 throw "Indeterminate linear system".
"""

from __future__ import annotations

from typing import Any

import numpy as np

from omnislam._optional import require
from omnislam.core.modality import Modality
from omnislam.core.se import se2_rotate_vectors
from omnislam.core.track_budget import AZIMUTH_SECTORS, TrackBudget
from omnislam.core.types import UNKNOWN_ID, Bearings
from omnislam.graphslam import factors as fx
from omnislam.graphslam.builder import DelayedLandmarks, SightingCounts
from omnislam.graphslam.config import LandmarkConfig
from omnislam.graphslam.poses import ViewpointPoses

gtsam = require("gtsam")

__all__ = ["AZIMUTH_SECTORS", "Bearings3DGraph", "TrackBudget"]

#: smallest angle between a measured bearing and its mapped landmark that counts as an outlier
BEARING_GATE_RAD = np.radians(20.0)
#: ... or this many of the bearing's angular sigmas, when larger
BEARING_GATE_SIGMAS = 5.0


class Bearings3DGraph:
    """Omni bearings -> ``BearingFactor3D`` and delayed ``Point3`` landmarks.

    Args:
        config: the landmarks' section (insertion, weak prior, per-image budget).
        noise: the landmark factors' noise models (with the solver's robust kernel).
        poses: the viewpoint chain of the graph (and the viewpoint's height).
        budget_grace_images: ``ExperimentalConfig.budget_grace_images`` (None: off).
    """

    modality = Modality.BEARINGS_3D

    def __init__(
        self,
        config: LandmarkConfig,
        noise: fx.NoiseModels,
        poses: ViewpointPoses,
        budget_grace_images: int | None = None,
    ) -> None:
        self._noise = noise
        self._height_m = poses.sensor_height_m
        self._grace = budget_grace_images
        self._landmarks = DelayedLandmarks(config, poses, dim=3)
        self._ignored = 0
        self._gated = 0
        self._over_budget = 0
        self._budget = (
            TrackBudget(config.per_image, grace_images=budget_grace_images)
            if config.per_image > 0
            else None
        )
        # sightings (frame, ray, sigma) of tracks not admitted (yet) by the budget
        self._waiting: dict[int, list[tuple[int, np.ndarray, float]]] = {}

    def add(
        self, k: int, sightings: Bearings, guess_w: np.ndarray, graph: Any, values: Any
    ) -> None:
        """Add frame k's bearings (see the module docstring)."""
        ids = sightings.landmark_ids
        known = ids != UNKNOWN_ID
        self._ignored += int((~known).sum())
        rows = np.flatnonzero(known)
        rays = sightings.unit_vectors_r
        sigmas = sightings.sigmas_rad
        touched: list[int] = []
        if self._budget is not None:
            in_use = None
            if self._grace is not None:
                in_use = np.fromiter(
                    (lid in self._landmarks for lid in ids[rows].tolist()), bool, len(rows)
                )
            admitted = self._budget.admit(ids[rows], rays[rows], in_use)
            for row in rows[~admitted].tolist():
                self._waiting.setdefault(int(ids[row]), []).append(
                    (k, rays[row], float(sigmas[row]))
                )
            self._over_budget += int((~admitted).sum())
            rows = rows[admitted]
            for lid in ids[rows].tolist():  # admitted now: what it waited with goes first
                for frame, ray, sigma in self._waiting.pop(lid, ()):
                    factor = fx.bearing_3d(frame, lid, ray, self._noise.isotropic(2, sigma))
                    self._landmarks.hold(lid, frame, ray, factor, sigma)
                    self._over_budget -= 1
        for lid, ray, sigma in zip(
            ids[rows].tolist(), rays[rows], sigmas[rows].tolist(), strict=True
        ):
            factor = fx.bearing_3d(k, lid, ray, self._noise.isotropic(2, sigma))
            if lid in self._landmarks:
                if self._is_outlier(lid, ray, sigma, guess_w):
                    self._gated += 1
                    continue
                graph.add(factor)
            else:
                self._landmarks.hold(lid, k, ray, factor, sigma)
                touched.append(lid)
        self._landmarks.insert_ready(k, touched, graph, values)

    def _is_outlier(
        self, lid: int, ray_r: np.ndarray, sigma_rad: float, guess_w: np.ndarray
    ) -> bool:
        """True when a bearing of a mapped landmark points away from it (the outlier gate)."""
        point = self._landmarks.points_w.get(lid)
        if point is None:
            return False
        ray_w = se2_rotate_vectors(guess_w, ray_r)
        to_point = point - np.array([guess_w[0], guess_w[1], self._height_m])
        cosine = ray_w @ to_point / max(np.linalg.norm(to_point), 1e-12)
        return bool(cosine < np.cos(max(BEARING_GATE_SIGMAS * sigma_rad, BEARING_GATE_RAD)))

    def landmark_ids(self) -> np.ndarray:
        """(M,) ids of the landmarks in the graph, ascending."""
        return self._landmarks.registry.sorted_ids()

    def landmarks(self, values: Any) -> np.ndarray:
        """(M, 3) the ``Point3`` landmarks of ``values`` [m]."""
        return gtsam.utilities.extractPoint3(values).reshape(-1, 3)

    def counts(self) -> SightingCounts:
        """Counts so far."""
        return SightingCounts(
            landmarks=len(self._landmarks.registry),
            insertion=self._landmarks.stats(),
            sightings_ignored=self._ignored,
            sightings_gated=self._gated,
            sightings_over_budget=self._over_budget,
        )
