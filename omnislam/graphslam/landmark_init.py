"""Delayed insertion of bearing-only landmarks (docs/design.md "Landmark insertion").

A bearing fixes no depth: a landmark added to iSAM2 after one bearing leaves its linear system
rank deficient and GTSAM throws "Indeterminate linear system". A track is therefore held back
until it has ``min_sightings`` sightings whose world rays span at least ``min_parallax_deg``;
then it is triangulated (``omnislam.core.triangulation.triangulate_rays``) and enters the graph
together with all its held-back factors in one iSAM2 update. Tracks that never qualify are
counted (``DelayedInsertionStats``), not silently lost.

This module is pure bookkeeping and numpy: it never touches GTSAM. The caller supplies the
factors to hold back (opaque objects) and, at insertion time, the current estimates of the poses
the sightings were taken from.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from omnislam.core.triangulation import triangulate_rays

#: a triangulated point must lie within this many angular sigmas of every ray of its track
_CONSISTENCY_SIGMAS = 4.0
#: relative floor of the smallest eigenvalue of sum(I - d d^T) (near-parallel rays are rejected)
_MIN_EIGENVALUE = 1e-6


def _subtended_rad(origins_w: np.ndarray, point_w: np.ndarray) -> float:
    """Largest angle at ``point_w`` between the directions to any two of ``origins_w``."""
    to_origins = origins_w - point_w
    norms = np.linalg.norm(to_origins, axis=1)
    if np.any(norms < 1e-9):
        return 0.0
    unit = to_origins / norms[:, None]
    return float(np.arccos(np.clip(unit @ unit.T, -1.0, 1.0)).max())


@dataclass(slots=True)
class PendingTrack:
    """A track not yet in the graph: its sightings and the factors they became.

    Attributes:
        frames: frame index of each sighting.
        rays_s: unit bearing of each sighting in its sensor frame (3,) (z = 0 in 2-D modes).
        sigmas_rad: angular standard deviation of each sighting (0: not checked).
        factors: the held-back factor of each sighting.
    """

    frames: list[int] = field(default_factory=list)
    rays_s: list[np.ndarray] = field(default_factory=list)
    sigmas_rad: list[float] = field(default_factory=list)
    factors: list[Any] = field(default_factory=list)


@dataclass(frozen=True, slots=True)
class DelayedInsertionStats:
    """Counts of the delayed-insertion bookkeeping.

    Attributes:
        tracks_inserted: tracks triangulated and added to the graph.
        tracks_pending: tracks still held back (never qualified so far).
        sightings_pending: held-back sightings of the pending tracks.
        triangulations_rejected: attempts whose point lay behind a ray, whose rays were
            (nearly) parallel in 3-D although the pairwise parallax passed, or whose point
            missed one of the rays by more than ``_CONSISTENCY_SIGMAS`` of its noise.
    """

    tracks_inserted: int
    tracks_pending: int
    sightings_pending: int
    triangulations_rejected: int


@dataclass(frozen=True, slots=True)
class Insertion:
    """A track that qualified: its id, triangulated point and held-back factors."""

    track_id: int
    point_w: np.ndarray
    factors: list[Any]


class DelayedInsertion:
    """Holds bearing-only tracks back until they can be triangulated.

    Args:
        min_sightings: sightings needed (>= 2).
        min_parallax_rad: largest pairwise angle between world rays needed [rad].
    """

    def __init__(self, min_sightings: int, min_parallax_rad: float) -> None:
        self._min_sightings = min_sightings
        self._min_parallax_rad = min_parallax_rad
        self._pending: dict[int, PendingTrack] = {}
        self._inserted = 0
        self._rejected = 0

    def hold(
        self, track_id: int, frame: int, ray_s: np.ndarray, factor: Any, sigma_rad: float = 0.0
    ) -> None:
        """Hold back one sighting of a track that is not in the graph."""
        track = self._pending.setdefault(track_id, PendingTrack())
        track.frames.append(frame)
        track.rays_s.append(ray_s)
        track.sigmas_rad.append(sigma_rad)
        track.factors.append(factor)

    def try_insert(
        self, track_id: int, viewpoint: Callable[[int], tuple[np.ndarray, np.ndarray]]
    ) -> Insertion | None:
        """Triangulate a held-back track if it qualifies, and release it.

        Args:
            track_id: the track.
            viewpoint: ``viewpoint(frame) -> (origin_w (3,), wRs (3, 3))``, the current estimate
                of the sensor viewpoint of a frame (position [m] and rotation sensor -> world).

        Returns:
            The insertion (the track is forgotten here) or None (the track stays pending).
        """
        track = self._pending.get(track_id)
        if track is None or len(track.frames) < self._min_sightings:
            return None
        origins = np.empty((len(track.frames), 3))
        rays_w = np.empty_like(origins)
        for k, (frame, ray_s) in enumerate(zip(track.frames, track.rays_s, strict=True)):
            origins[k], wRs = viewpoint(frame)
            rays_w[k] = wRs @ ray_s
        result = triangulate_rays(origins, rays_w)
        # parallax is the angle the viewpoints subtend at the point, not the spread of the ray
        # directions: rays from one viewpoint (a robot turning on the spot, a mismatched track)
        # can differ by degrees and still meet at the viewpoint itself, at zero depth
        if min(result.parallax_rad, _subtended_rad(origins, result.point_w)) < (
            self._min_parallax_rad
        ):
            return None
        if not result.in_front or result.min_eigenvalue < _MIN_EIGENVALUE * len(track.frames):
            self._rejected += 1
            return None
        # every ray must pass within its noise of the point: a track with one wrong sighting
        # (a front-end mismatch) would enter the graph badly conditioned and pull it apart
        to_point = result.point_w - origins
        to_point /= np.linalg.norm(to_point, axis=1, keepdims=True)
        miss_rad = np.arccos(np.clip(np.sum(to_point * rays_w, axis=1), -1.0, 1.0))
        if np.any(miss_rad > _CONSISTENCY_SIGMAS * np.asarray(track.sigmas_rad)) and all(
            track.sigmas_rad
        ):
            self._rejected += 1
            return None
        del self._pending[track_id]
        self._inserted += 1
        return Insertion(track_id, result.point_w, track.factors)

    def is_pending(self, track_id: int) -> bool:
        """True when the track has held-back sightings."""
        return track_id in self._pending

    def stats(self) -> DelayedInsertionStats:
        """Counts so far."""
        return DelayedInsertionStats(
            tracks_inserted=self._inserted,
            tracks_pending=len(self._pending),
            sightings_pending=sum(len(t.frames) for t in self._pending.values()),
            triangulations_rejected=self._rejected,
        )


class ConsistentInsertion:
    """Holds range-bearing landmarks back until ``min_consistent`` sightings agree on the point.

    A range-bearing sighting fixes a 2-D landmark on its own, so without wrong associations a
    landmark can enter on its first sighting (``min_consistent = 1``). With wrong ids, a
    landmark initialised from a wrong first sighting sits metres away; a robust kernel then
    down-weights its *correct* sightings and iSAM2 can stay in that minimum. Waiting until
    sightings agree -- squared Mahalanobis distance ``(p_i - p_j)^T (C_i + C_j)^-1 (p_i - p_j)``
    inside ``gate`` -- and starting at their mean avoids it. The agreeing sightings' factors
    are released; the disagreeing ones too with ``release_disagreeing`` (a robust kernel then
    handles them), else they are dropped and counted (``rejected``), as an outlier gate on the
    landmark would have done.

    Args:
        min_consistent: agreeing sightings needed (1 inserts on the first sighting).
        gate: chi-square threshold on the squared distance (2 degrees of freedom).
        release_disagreeing: release every held-back factor, not only the agreeing ones.
    """

    def __init__(self, min_consistent: int, gate: float, release_disagreeing: bool = True) -> None:
        self._min_consistent = min_consistent
        self._gate = gate
        self._release_disagreeing = release_disagreeing
        self._pending: dict[int, tuple[list[np.ndarray], list[np.ndarray], list[Any]]] = {}
        self._inserted = 0
        self.rejected = 0

    def hold(
        self, track_id: int, point_w: np.ndarray, covariance_w: np.ndarray, factor: Any
    ) -> None:
        """Hold back one sighting: its world point (2,), covariance (2, 2) and factor."""
        points, covariances, factors = self._pending.setdefault(track_id, ([], [], []))
        points.append(point_w)
        covariances.append(covariance_w)
        factors.append(factor)

    def try_insert(self, track_id: int) -> Insertion | None:
        """Insert when the newest sighting agrees with enough earlier ones (then forget it)."""
        if track_id not in self._pending:
            return None
        points, covariances, factors = self._pending[track_id]
        newest, newest_cov = points[-1], covariances[-1]
        agrees = [
            bool((d := p - newest) @ np.linalg.solve(c + newest_cov, d) <= self._gate)
            for p, c in zip(points, covariances, strict=True)
        ]  # includes the newest itself (distance 0)
        if sum(agrees) < self._min_consistent:
            return None
        del self._pending[track_id]
        self._inserted += 1
        point = np.mean([p for p, a in zip(points, agrees, strict=True) if a], axis=0)
        if self._release_disagreeing:
            return Insertion(track_id, point, factors)
        self.rejected += len(agrees) - sum(agrees)
        return Insertion(track_id, point, [f for f, a in zip(factors, agrees, strict=True) if a])

    def stats(self) -> DelayedInsertionStats:
        """Counts so far (no triangulation here: ``triangulations_rejected`` is 0)."""
        return DelayedInsertionStats(
            tracks_inserted=self._inserted,
            tracks_pending=len(self._pending),
            sightings_pending=sum(len(p[0]) for p in self._pending.values()),
            triangulations_rejected=0,
        )
