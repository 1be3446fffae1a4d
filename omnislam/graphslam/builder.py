"""What the graph builders of the modalities share: their protocol, counts and landmark records.

A *graph builder* turns one modality's sightings of a frame into factors and new landmark
variables (``bearings_3d.py``, ``range_bearing.py``, ``vertical_lines.py``); ``GraphSLAM``
adds the pose chain (``poses.py``) and runs the iSAM2 update (``session.py``).

* ``LandmarkRegistry``: the landmarks in the graph, in insertion order, with their positions
  at insertion (refreshed by the association where it needs them);
* ``DelayedLandmarks``: the bearing-only path shared by omni and vertical-line bearings --
  tracks held back until they can be triangulated (``landmark_init.DelayedInsertion``), then
  inserted with their held-back factors and the weak landmark prior
  (``LandmarkConfig.prior_sigma_m``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from omnislam._optional import require
from omnislam.core.modality import Modality
from omnislam.graphslam import factors as fx
from omnislam.graphslam.config import LandmarkConfig
from omnislam.graphslam.landmark_init import DelayedInsertion, DelayedInsertionStats
from omnislam.graphslam.poses import PoseChain
from omnislam.graphslam.tentative import TentativeStats

gtsam = require("gtsam")


@dataclass(frozen=True, slots=True)
class SightingCounts:
    """What a graph builder did with its modality's sightings (see ``GraphSLAMInfo``).

    Attributes:
        landmarks: landmarks in the graph.
        insertion: the held-back landmarks (delayed or consistent insertion).
        landmarks_created: landmarks started by the association of unlabelled sightings.
        sightings_associated: unlabelled sightings matched to a mapped landmark.
        sightings_ambiguous: unlabelled sightings dropped between the two gates.
        sightings_ignored: sightings the builder cannot use (bearings without a track id).
        sightings_gated: bearings of mapped landmarks rejected by the outlier gate.
        sightings_readmitted: sightings the outlier gate rejected that entered the graph once
            enough re-sightings of their landmark agreed with them
            (``core.gating.GatedResightings``).
        sightings_over_budget: bearings of tracks left out by the per-image landmark budget.
        tentative: the tentative stage of the association.
        landmarks_merged: landmarks merged into another by the loop closure (``loop_closure.py``).
        loop_closures: loop closures accepted (each merged one or more landmarks).
    """

    landmarks: int
    insertion: DelayedInsertionStats
    landmarks_created: int = 0
    sightings_associated: int = 0
    sightings_ambiguous: int = 0
    sightings_ignored: int = 0
    sightings_gated: int = 0
    sightings_readmitted: int = 0
    sightings_over_budget: int = 0
    tentative: TentativeStats = field(default_factory=TentativeStats)
    landmarks_merged: int = 0
    loop_closures: int = 0


class GraphBuilder(Protocol):
    """Turns one modality's sightings into factors (implemented once per modality)."""

    modality: Modality

    def add(self, k: int, sightings: Any, guess_w: np.ndarray, graph: Any, values: Any) -> None:
        """Add frame k's sightings (a non-empty record of the modality) to ``graph``/``values``.

        Args:
            k: the frame's pose index.
            sightings: ``Bearings``, ``RangeBearing`` or ``VerticalLines`` of the frame.
            guess_w: (3,) the frame's pose guess [x, y, theta] in the world.
            graph: the frame's new factors (a gtsam container).
            values: the frame's new variables (a gtsam container).
        """
        ...

    def landmark_ids(self) -> np.ndarray:
        """(M,) ids of the landmarks in the graph, ascending (the key order of ``values``)."""
        ...

    def landmarks(self, values: Any) -> np.ndarray:
        """(M, 3) landmark positions in ``values`` in ``landmark_ids`` order (z = 0 in 2-D)."""
        ...

    def counts(self) -> SightingCounts:
        """Counts so far."""
        ...


class LandmarkRegistry:
    """The landmarks in the graph: ids in insertion order and a cache of planar positions.

    The positions (2,) are those at insertion; the association refreshes the rows it needs
    from iSAM2 (``range_bearing.py``).
    """

    def __init__(self) -> None:
        self._row: dict[int, int] = {}
        self._ids: list[int] = []
        self._xy = np.zeros((64, 2))
        self._merged_into: dict[int, int] = {}  # retired landmark -> the one it was merged into

    def __len__(self) -> int:
        return len(self._ids)

    def __contains__(self, landmark_id: object) -> bool:
        return landmark_id in self._row

    def add(self, landmark_id: int, point_w: np.ndarray) -> None:
        """Register a landmark entering the graph at ``point_w`` ((2,) or (3,) [m])."""
        row = len(self._ids)
        if row == len(self._xy):
            grown = np.zeros((2 * row, 2))
            grown[:row] = self._xy
            self._xy = grown
        self._xy[row] = point_w[:2]
        self._row[landmark_id] = row
        self._ids.append(landmark_id)

    def retire(self, landmark_id: int, kept: int) -> None:
        """``landmark_id`` was merged into ``kept`` (``loop_closure.py``): its variable stays in
        the graph, tied to ``kept``, but the association no longer offers it and the map does
        not list it."""
        self._merged_into[landmark_id] = kept

    def active(self, landmark_id: int) -> bool:
        """True for a landmark in the graph that was not merged into another."""
        return landmark_id in self._row and landmark_id not in self._merged_into

    def resolve(self, landmark_id: int) -> int:
        """The landmark that ``landmark_id`` stands for now (itself unless merged)."""
        while landmark_id in self._merged_into:
            landmark_id = self._merged_into[landmark_id]
        return landmark_id

    @property
    def retired(self) -> int:
        """Landmarks merged into another."""
        return len(self._merged_into)

    def row(self, landmark_id: int) -> int:
        """The row of ``landmark_id`` in ``xy`` (insertion order)."""
        return self._row[landmark_id]

    def id_at(self, row: int) -> int:
        """The id of the landmark in ``row`` (insertion order)."""
        return self._ids[row]

    @property
    def xy(self) -> np.ndarray:
        """(M, 2) cached positions in insertion order: a view the caller may refresh."""
        return self._xy[: len(self._ids)]

    def sorted_ids(self) -> np.ndarray:
        """(M,) the ids ascending (the key order of landmark variables in ``gtsam.Values``)."""
        return np.array(sorted(self._ids), dtype=np.int64)


class DelayedLandmarks:
    """Bearing-only tracks into the graph: delayed insertion, then the weak landmark prior.

    Args:
        config: the landmarks' section (``min_sightings``, ``min_parallax_deg``,
            ``prior_sigma_m``).
        poses: the pose chain (viewpoints of earlier frames for the triangulation).
        dim: landmark dimension, 3 (``Point3``, omni) or 2 (``Point2``, vertical lines).
    """

    def __init__(self, config: LandmarkConfig, poses: PoseChain, dim: int) -> None:
        self._poses = poses
        self._dim = dim
        self._delayed = DelayedInsertion(config.min_sightings, np.deg2rad(config.min_parallax_deg))
        self._prior = None  # the weak prior's noise model (never robust: not a measurement)
        if config.prior_sigma_m is not None:
            sigma = float(config.prior_sigma_m)
            self._prior = gtsam.noiseModel.Isotropic.Sigma(dim, sigma)
        self.registry = LandmarkRegistry()
        self.points_w: dict[int, np.ndarray] = {}  # each landmark's point at insertion

    def __contains__(self, landmark_id: object) -> bool:
        return landmark_id in self.registry

    def hold(
        self, landmark_id: int, k: int, ray_s: np.ndarray, factor: Any, sigma_rad: float = 0.0
    ) -> None:
        """Hold back one sighting of a track not yet in the graph."""
        self._delayed.hold(landmark_id, k, ray_s, factor, sigma_rad)

    def insert_ready(self, k: int, touched: list[int], graph: Any, values: Any) -> None:
        """Triangulate and insert every track of ``touched`` that qualifies (frame k)."""
        viewpoint = self._poses.viewpoint_callback(k)
        for lid in dict.fromkeys(touched):
            insertion = self._delayed.try_insert(lid, viewpoint)
            if insertion is None:
                continue
            key = fx.landmark_key(lid)
            if self._dim == 3:
                point = gtsam.Point3(insertion.point_w)
                values.insert(key, point)
                self.points_w[lid] = np.asarray(insertion.point_w, dtype=float)
                if self._prior is not None:  # see LandmarkConfig.prior_sigma_m
                    graph.add(gtsam.PriorFactorPoint3(key, point, self._prior))
            else:
                point = gtsam.Point2(insertion.point_w[:2])
                values.insert(key, point)
                if self._prior is not None:
                    graph.add(gtsam.PriorFactorPoint2(key, point, self._prior))
            for factor in insertion.factors:
                graph.add(factor)
            self.registry.add(lid, insertion.point_w)

    def stats(self) -> DelayedInsertionStats:
        """The delayed-insertion counts."""
        return self._delayed.stats()
