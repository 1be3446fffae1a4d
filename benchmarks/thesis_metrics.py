"""What the thesis's simulated experiments look at (Guizilini 2008, sec. 5.1.2, Figs. 5.6 and
5.8), measured on one run: poles mapped twice, and whether and where the loop closes.

Both are read from what ``omnislam run`` leaves (the estimated trajectory and map) against the
data's truth (the true poses and the sightings with the poles' true ids, which the estimators
never see), so every estimator is measured alike, the graph and dead reckoning included.

* **Poles mapped twice** (``pole_duplicates``): each estimated landmark is given to its nearest
  true pole; a pole holding two or more estimated landmarks within ``radius_m`` is mapped twice.
* **Re-association of a pole seen long before** (``revisits``, ``revisit_errors``): a pole's
  sightings are grouped into visits, a new visit starting when the robot has travelled at least
  ``gap_m`` since the pole's previous sighting. A revisit re-associates when the sightings of
  its first ``window_m`` of travel, placed in the world with the estimated poses of their
  frames, land within ``close_m`` of where the same pole's first visit placed it (mean over the
  visit's sightings): the estimate then agrees with the map it made long before. A filter that
  fails to recognise the pole creates a new landmark where its drifted pose puts it, and its
  own pose stays drifted, so the two placements are as far apart as the drift.
* **The loop closure** (``loop_closure``) is the first revisit that re-associates: its frame and
  distance travelled; with it the first revisit of the route (the first chance) and the share of
  revisits that re-associate, over the whole route and after the longest stretch without any
  sighting (route 2's blind corridor, ``blind_stretch``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: a pole holding two estimated landmarks within this distance is mapped twice [m] (route 1's
#: poles stand ~4 m apart, route 2's ~3 m: a third of the spacing)
DUPLICATE_RADIUS_M = 1.0
#: travel since a pole's previous sighting that makes its next sighting a revisit [m] (many
#: times the 4 m sensor range: the pole left the robot's view long before)
REVISIT_GAP_M = 50.0
#: the revisit's first sightings within this travel are placed and averaged [m]
REVISIT_WINDOW_M = 2.0
#: a revisit placed within this distance of the pole's first placement re-associated [m]
#: (the sightings' own spread is ~0.2 m on route 2's thick poles; a missed association leaves
#: at least the association gate, several tenths of a metre, between the two)
CLOSE_M = 0.5


@dataclass(frozen=True, slots=True)
class Sightings:
    """Every pole sighting of a run, flattened over frames.

    Attributes:
        frames: (S,) frame index of each sighting.
        poles: (S,) the true pole id.
        ranges_m: (S,) range [m].
        bearings_rad: (S,) bearing in the robot frame, counter-clockwise from the heading [rad].
    """

    frames: np.ndarray
    poles: np.ndarray
    ranges_m: np.ndarray
    bearings_rad: np.ndarray

    def placed(self, wTr: np.ndarray) -> np.ndarray:
        """(S, 2) each sighting placed in the world from the pose of its frame in ``wTr`` (N, 3)
        [m] (the range-bearing model inverted, thesis eq. 4.25 in the plane)."""
        pose = wTr[self.frames]
        angle = pose[:, 2] + self.bearings_rad
        return pose[:, :2] + self.ranges_m[:, None] * np.column_stack([np.cos(angle),
                                                                       np.sin(angle)])


@dataclass(frozen=True, slots=True)
class Revisit:
    """A pole seen again after the robot travelled ``REVISIT_GAP_M`` without seeing it.

    Attributes:
        pole: the true pole id.
        frame: the frame of the revisit's first sighting.
        travel_m: distance travelled at that frame [m].
        first_visit: (A,) indices into ``Sightings`` of the pole's first visit.
        window: (B,) indices of the revisit's sightings within its first ``window_m``.
    """

    pole: int
    frame: int
    travel_m: float
    first_visit: np.ndarray
    window: np.ndarray


@dataclass(frozen=True, slots=True)
class Duplicates:
    """Estimated landmarks per true pole.

    Attributes:
        per_pole: (P,) estimated landmarks within the radius whose nearest true pole it is.
        mapped_twice: poles holding two or more.
        far: estimated landmarks farther than the radius from every pole.
    """

    per_pole: np.ndarray
    mapped_twice: int
    far: int


@dataclass(frozen=True, slots=True)
class LoopClosure:
    """Whether and where a run re-associated poles seen long before.

    Attributes:
        first_chance_frame, first_chance_m: frame and travel of the route's first revisit (the
            data's; None without revisits).
        closed_frame, closed_m: frame and travel of the first revisit that re-associated (None:
            the loop never closed).
        closed_share: share of all revisits that re-associated (NaN without revisits).
        after_blind_share: share of the revisits after the longest blind stretch that
            re-associated (NaN when none follows it).
    """

    first_chance_frame: int | None
    first_chance_m: float | None
    closed_frame: int | None
    closed_m: float | None
    closed_share: float
    after_blind_share: float


def travelled_m(truth_xy: np.ndarray) -> np.ndarray:
    """(N,) distance travelled along the true path at each frame [m], from (N, 2) positions."""
    steps = np.linalg.norm(np.diff(truth_xy, axis=0), axis=1)
    return np.concatenate([[0.0], np.cumsum(steps)])


def pole_duplicates(
    landmarks_xy: np.ndarray, poles_xy: np.ndarray, radius_m: float = DUPLICATE_RADIUS_M
) -> Duplicates:
    """How many estimated landmarks each true pole holds (the map aligned to the truth).

    Args:
        landmarks_xy: (M, 2) estimated landmarks in the truth's frame [m].
        poles_xy: (P, 2) true poles [m].
        radius_m: a landmark farther than this from its nearest pole belongs to none [m].
    """
    per_pole = np.zeros(len(poles_xy), dtype=int)
    if not len(landmarks_xy) or not len(poles_xy):
        return Duplicates(per_pole, 0, len(landmarks_xy))
    distance = np.linalg.norm(landmarks_xy[:, None, :] - poles_xy[None, :, :], axis=2)
    nearest = distance.argmin(axis=1)
    near = distance[np.arange(len(landmarks_xy)), nearest] <= radius_m
    np.add.at(per_pole, nearest[near], 1)
    return Duplicates(per_pole, int(np.count_nonzero(per_pole >= 2)), int(np.count_nonzero(~near)))


def revisits(
    sightings: Sightings,
    travel_m: np.ndarray,
    gap_m: float = REVISIT_GAP_M,
    window_m: float = REVISIT_WINDOW_M,
) -> list[Revisit]:
    """Every revisit of every pole, in frame order.

    Args:
        sightings: the run's sightings with true pole ids.
        travel_m: (N,) distance travelled at each frame [m] (``travelled_m``).
        gap_m: travel without a sighting of the pole that starts a new visit [m].
        window_m: the revisit's sightings within this travel of its first are kept [m].
    """
    found = []
    along = travel_m[sightings.frames]
    for pole in np.unique(sightings.poles):
        index = np.flatnonzero(sightings.poles == pole)
        index = index[np.argsort(sightings.frames[index], kind="stable")]
        starts = np.flatnonzero(np.diff(along[index]) >= gap_m) + 1
        if not len(starts):
            continue
        first_visit = index[: starts[0]]
        for start in starts:
            visit = index[start:]
            window = visit[along[visit] <= along[visit[0]] + window_m]
            found.append(Revisit(int(pole), int(sightings.frames[visit[0]]),
                                 float(along[visit[0]]), first_visit, window))
    return sorted(found, key=lambda r: (r.frame, r.pole))


def revisit_errors(sightings: Sightings, found: list[Revisit], wTr: np.ndarray) -> np.ndarray:
    """(R,) distance between each revisit's placement of its pole and the first visit's [m].

    Args:
        sightings: the run's sightings.
        found: its revisits (``revisits``).
        wTr: (N, 3) the estimated pose of every frame [m, m, rad].
    """
    placed = sightings.placed(wTr)
    return np.array([
        np.linalg.norm(placed[r.window].mean(axis=0) - placed[r.first_visit].mean(axis=0))
        for r in found
    ])


def blind_stretch(sightings: Sightings, travel_m: np.ndarray) -> tuple[float, float]:
    """(start, end) travel of the longest stretch of the route without any sighting [m]."""
    along = np.unique(travel_m[sightings.frames])
    if len(along) < 2:
        return 0.0, 0.0
    k = int(np.argmax(np.diff(along)))
    return float(along[k]), float(along[k + 1])


def loop_closure(
    found: list[Revisit],
    errors_m: np.ndarray,
    blind_end_m: float,
    close_m: float = CLOSE_M,
) -> LoopClosure:
    """The first revisit that re-associated, and the share that did.

    Args:
        found: the run's revisits (``revisits``), in frame order.
        errors_m: their placement errors (``revisit_errors``) [m].
        blind_end_m: travel where the longest blind stretch ends (``blind_stretch``) [m].
        close_m: a revisit within this of its first placement re-associated [m].
    """
    if not found:
        return LoopClosure(None, None, None, None, float("nan"), float("nan"))
    closed = np.asarray(errors_m) <= close_m
    after = np.array([r.travel_m >= blind_end_m for r in found])
    first = next((r for r, c in zip(found, closed, strict=True) if c), None)
    return LoopClosure(
        first_chance_frame=found[0].frame,
        first_chance_m=found[0].travel_m,
        closed_frame=None if first is None else first.frame,
        closed_m=None if first is None else first.travel_m,
        closed_share=float(closed.mean()),
        after_blind_share=float(closed[after].mean()) if after.any() else float("nan"),
    )
