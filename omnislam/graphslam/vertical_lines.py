"""Graph builder of vertical-line bearings (``Modality.VERTICAL_LINES``): 2-D bearing-only.

Each line's planar bearing becomes a ``BearingFactor2D(pose, point, Rot2)`` on the ``Pose2``
chain (``poses.PlanarPoses``). A line not in the graph yet is held back until it can be
triangulated (``builder.DelayedLandmarks``, rays in the plane) and enters as a ``Point2`` with
its held-back factors and the weak prior. Lines without an id are ignored (counted). The colour
profiles are the UKF's; the graph uses only the bearings.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from omnislam._optional import require
from omnislam.core.modality import Modality
from omnislam.core.types import UNKNOWN_ID, VerticalLines
from omnislam.graphslam import factors as fx
from omnislam.graphslam.builder import DelayedLandmarks, SightingCounts
from omnislam.graphslam.config import LandmarkConfig
from omnislam.graphslam.poses import PlanarPoses

gtsam = require("gtsam")


class VerticalLinesGraph:
    """Vertical-line bearings -> ``BearingFactor2D`` and delayed ``Point2`` landmarks.

    Args:
        config: the landmarks' section (insertion, weak prior).
        noise: the landmark factors' noise models (with the solver's robust kernel).
        poses: the planar pose chain of the graph.
    """

    modality = Modality.VERTICAL_LINES

    def __init__(
        self, config: LandmarkConfig, noise: fx.NoiseModels, poses: PlanarPoses
    ) -> None:
        self._noise = noise
        self._landmarks = DelayedLandmarks(config, poses, dim=2)
        self._ignored = 0

    def add(
        self, k: int, sightings: VerticalLines, guess_w: np.ndarray, graph: Any, values: Any
    ) -> None:
        """Add frame k's line bearings (see the module docstring)."""
        del guess_w  # the triangulation reads the guess through the pose chain
        touched: list[int] = []
        for lid, bearing, sigma in zip(
            sightings.landmark_ids.tolist(),
            sightings.bearings_rad.tolist(),
            sightings.sigma_bearing_rad.tolist(),
            strict=True,
        ):
            if lid == UNKNOWN_ID:
                self._ignored += 1
                continue
            factor = fx.bearing_2d(k, lid, bearing, self._noise.isotropic(1, sigma))
            if lid in self._landmarks:
                graph.add(factor)
            else:
                ray = np.array([np.cos(bearing), np.sin(bearing), 0.0])
                self._landmarks.hold(lid, k, ray, factor)
                touched.append(lid)
        self._landmarks.insert_ready(k, touched, graph, values)

    def landmark_ids(self) -> np.ndarray:
        """(M,) ids of the landmarks in the graph, ascending."""
        return self._landmarks.registry.sorted_ids()

    def landmarks(self, values: Any) -> np.ndarray:
        """(M, 3) the ``Point2`` landmarks of ``values`` with z = 0 [m]."""
        points = gtsam.utilities.extractPoint2(values).reshape(-1, 2)
        return np.column_stack([points, np.zeros(len(points))])

    def counts(self) -> SightingCounts:
        """Counts so far."""
        return SightingCounts(
            landmarks=len(self._landmarks.registry),
            insertion=self._landmarks.stats(),
            sightings_ignored=self._ignored,
        )
