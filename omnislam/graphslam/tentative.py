"""Tentative landmarks: unlabelled range-bearing sightings held back until re-observed.

A landmark started by the association (``association.py``) from one unlabelled sighting may be
clutter: a spurious detection (Victoria Park's tree detector fires on bushes, cars, people) or
a sighting of a mapped landmark pushed outside the gate by drift. Entering it in the graph at
once keeps it for ever and lets later sightings match it. Instead it waits here until
``min_sightings`` sightings (the first included) have been associated to it, each within
``window_frames`` frames of the previous one; then it is *committed*: it enters the graph at the
information-weighted mean of its sightings' world points, with all their held-back factors.
A tentative landmark not re-observed in time is *dropped* with its sightings.

While it waits, a tentative landmark is a candidate of the association like a mapped one, with
the fused position and covariance of its sightings (``position``), so its re-observations find
it (and a sighting is never given to both a tentative and a mapped landmark in one frame).
The sightings' world points come from the pose *guesses* of their frames, so the fused position
is only as good as the odometry over the window -- short by design.

Reference: the "provisional landmark list" of Dissanayake et al., "A solution to the simultaneous
localization and map building (SLAM) problem", IEEE T-RA 17(3), 2001 (on Victoria Park's sister
data), and the landmark quality / "M of N" track confirmation of target tracking (Bar-Shalom).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass(slots=True)
class _Track:
    """Held-back sightings of one tentative landmark."""

    last_frame: int
    information: np.ndarray = field(default_factory=lambda: np.zeros((2, 2)))
    information_point: np.ndarray = field(default_factory=lambda: np.zeros(2))
    factors: list[Any] = field(default_factory=list)


@dataclass(frozen=True, slots=True)
class Commitment:
    """A tentative landmark confirmed: its id, initial point (2,) [m] and held-back factors."""

    landmark_id: int
    point_w: np.ndarray
    factors: tuple[Any, ...]


@dataclass(frozen=True, slots=True)
class TentativeStats:
    """Counts of the tentative stage.

    Attributes:
        committed: tentative landmarks confirmed and entered in the graph.
        dropped: tentative landmarks forgotten (not re-observed in time).
        sightings_dropped: sightings held by the dropped ones.
        pending: tentative landmarks still waiting.
    """

    committed: int = 0
    dropped: int = 0
    sightings_dropped: int = 0
    pending: int = 0


class TentativeLandmarks:
    """Tentative landmarks keyed by id (ids chosen by the caller).

    Args:
        min_sightings: sightings needed to commit (>= 2; 1 would mean "no tentative stage").
        window_frames: largest gap, in frames, between consecutive sightings of one tentative
            landmark; a longer gap drops it.
    """

    def __init__(self, min_sightings: int, window_frames: int) -> None:
        if min_sightings < 2 or window_frames < 1:
            raise ValueError("need min_sightings >= 2 and window_frames >= 1")
        self._min_sightings = min_sightings
        self._window = window_frames
        self._tracks: dict[int, _Track] = {}
        self._committed = self._dropped = self._sightings_dropped = 0

    def __len__(self) -> int:
        return len(self._tracks)

    def __contains__(self, landmark_id: object) -> bool:
        return landmark_id in self._tracks

    def expire(self, frame: int) -> None:
        """Drop every tentative landmark last seen more than ``window_frames`` before ``frame``."""
        stale = [i for i, t in self._tracks.items() if frame - t.last_frame > self._window]
        for landmark_id in stale:
            self._sightings_dropped += len(self._tracks.pop(landmark_id).factors)
            self._dropped += 1

    def candidates(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(ids (T,), fused positions (T, 2) [m], their covariances (T, 2, 2) [m^2])."""
        ids = np.fromiter(self._tracks, dtype=np.int64, count=len(self._tracks))
        points = np.zeros((len(ids), 2))
        covariances = np.zeros((len(ids), 2, 2))
        for row, landmark_id in enumerate(ids.tolist()):
            points[row], covariances[row] = self.position(landmark_id)
        return ids, points, covariances

    def position(self, landmark_id: int) -> tuple[np.ndarray, np.ndarray]:
        """Information-weighted mean (2,) of a tentative landmark's points and its covariance.

        ``C = (sum C_i^-1)^-1``, ``p = C sum C_i^-1 p_i`` (independent sightings).
        """
        track = self._tracks[landmark_id]
        covariance = np.linalg.inv(track.information)
        return covariance @ track.information_point, covariance

    def add(
        self,
        landmark_id: int,
        frame: int,
        point_w: np.ndarray,
        covariance_w: np.ndarray,
        factor: Any,
    ) -> Commitment | None:
        """Hold one sighting (world point (2,), covariance (2, 2), its factor).

        Returns:
            The Commitment when this sighting completes ``min_sightings`` (the landmark then
            leaves the tentative store), else None.
        """
        track = self._tracks.get(landmark_id)
        if track is None:
            track = self._tracks[landmark_id] = _Track(frame)
        information = np.linalg.inv(covariance_w)
        track.information += information
        track.information_point += information @ point_w
        track.factors.append(factor)
        track.last_frame = frame
        if len(track.factors) < self._min_sightings:
            return None
        point, _ = self.position(landmark_id)
        del self._tracks[landmark_id]
        self._committed += 1
        return Commitment(landmark_id, point, tuple(track.factors))

    def stats(self) -> TentativeStats:
        """Counts so far."""
        return TentativeStats(
            committed=self._committed,
            dropped=self._dropped,
            sightings_dropped=self._sightings_dropped,
            pending=len(self._tracks),
        )
