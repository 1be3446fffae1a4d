"""Batch re-association of unlabelled range-bearing sightings (``graphslam-batch``).

The incremental association (``association.py``) decides each frame's sightings once, against
the map and pose as they were then: early in a run a landmark seen once or twice is uncertain,
and on MR.CLAM, whose landmarks stand in groups 0.15-0.25 m apart, a sighting of one member
is then given to its neighbour. Offline, the whole map is known. After the warm-started LM,
this module gives every sighting that the association decided (the ``BearingRangeFactor2D``
factors on landmarks it created) to a landmark again:

1. per frame, the sightings' squared Mahalanobis distances to every candidate landmark at the
   LM solution, under the sighting's own noise (the factor's Gaussian part), the map taken as
   exact -- after a batch solve it is far more certain than one sighting;
2. a minimum-cost assignment per frame (``scipy.optimize.linear_sum_assignment``): a landmark
   takes at most one sighting of a frame (mutual exclusion, as in the online association),
   and only pairings inside the chi-square gate count; a sighting that no landmark takes keeps
   the landmark it had;
3. a move that would leave a landmark without any sighting is not made (its variable would be
   unconstrained);
4. LM again from the previous solution, on the graph with the moved factors; repeated until no
   sighting moves or the rounds run out.

This is the re-association step of batch data association in the expectation-maximisation
sense (Dellaert, Seitz, Thorpe & Thrun 2003, "EM, MCMC, and chain flipping for structure from
motion with unknown correspondence"): the hard E-step given the current map, then the M-step.
Sightings with given ids, landmarks not created by the association and landmarks merged by the
loop closure are never touched.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import linear_sum_assignment

from omnislam._optional import require
from omnislam.core.measurement import RangeBearing2D

gtsam = require("gtsam")

_MODEL = RangeBearing2D()
#: cost of a pairing outside the gate in the assignment (never chosen over one inside)
_OUTSIDE = 1e12


@dataclass(frozen=True, slots=True)
class Reassociation:
    """Outcome of ``reassociate``.

    Attributes:
        graph: the factor graph with the moved sightings.
        values: the LM solution on it.
        moved: sightings given to another landmark, summed over the rounds.
        rounds: rounds run (the last one moved nothing, unless the rounds ran out).
    """

    graph: Any
    values: Any
    moved: int
    rounds: int


@dataclass(slots=True)
class _Sighting:
    """One movable factor: its pose key, landmark key, measurement and noise."""

    pose: int
    landmark: int
    bearing_rad: float
    range_m: float
    noise: Any
    sigmas: np.ndarray  # (bearing, range) of the Gaussian part


def _split(graph: Any, movable: Callable[[int], bool]) -> tuple[Any, list[_Sighting]]:
    """The graph's factors: the fixed ones, and the range-bearing sightings of movable landmarks."""
    fixed = gtsam.NonlinearFactorGraph()
    sightings: list[_Sighting] = []
    for i in range(graph.size()):
        factor = graph.at(i)
        if factor is None:
            continue
        if isinstance(factor, gtsam.BearingRangeFactor2D) and movable(factor.keys()[1]):
            noise = factor.noiseModel()
            gaussian = noise.noise() if isinstance(noise, gtsam.noiseModel.Robust) else noise
            z = factor.measured()
            sightings.append(
                _Sighting(
                    factor.keys()[0],
                    factor.keys()[1],
                    float(z.bearing().theta()),
                    float(z.range()),
                    noise,
                    np.asarray(gaussian.sigmas(), dtype=float),
                )
            )
        else:
            fixed.add(factor)
    return fixed, sightings


def _graph(fixed: Any, sightings: list[_Sighting]) -> Any:
    graph = gtsam.NonlinearFactorGraph(fixed)
    for s in sightings:
        graph.add(
            gtsam.BearingRangeFactor2D(
                s.pose, s.landmark, gtsam.Rot2(s.bearing_rad), s.range_m, s.noise
            )
        )
    return graph


def squared_distances(values: Any, rows: list[_Sighting], landmarks: list[int]) -> np.ndarray:
    """(len(rows), len(landmarks)) squared Mahalanobis distances of sightings of one pose to
    landmarks at ``values``, under each sighting's (bearing, range) sigmas."""
    pose = values.atPose2(rows[0].pose)
    wTr = np.array([pose.x(), pose.y(), pose.theta()])
    points = np.array([values.atPoint2(k) for k in landmarks]).reshape(-1, 2)
    predicted, _, _ = _MODEL.predict(wTr, points, jacobians=False)  # (M, 2): range, bearing
    measured = np.array([[s.range_m, s.bearing_rad] for s in rows])
    residual = _MODEL.residual(measured[:, None, :], predicted[None, :, :])  # (K, M, 2)
    sigmas = np.array([[s.sigmas[1], s.sigmas[0]] for s in rows])[:, None, :]  # range, bearing
    return np.sum((residual / sigmas) ** 2, axis=-1)


def reassociate(
    graph: Any,
    values: Any,
    movable: Callable[[int], bool],
    gate: float,
    rounds: int,
    optimize: Callable[[Any, Any], Any],
) -> Reassociation:
    """Re-associate the sightings of ``movable`` landmarks (see the module docstring).

    Args:
        graph: the factor graph (``gtsam.NonlinearFactorGraph``) the LM solution is of.
        values: that solution (``gtsam.Values``).
        movable: whether a landmark key's sightings may move, and whether it is a candidate.
        gate: squared Mahalanobis distance inside which a pairing counts (chi-square, 2 dof).
        rounds: most assignment-and-LM rounds (>= 1).
        optimize: ``(graph, initial values) -> gtsam.Values``, the LM of the caller.

    Returns:
        The Reassociation; with nothing to move, ``graph`` and ``values`` as given.
    """
    fixed, sightings = _split(graph, movable)
    if not sightings or rounds < 1:
        return Reassociation(graph, values, 0, 0)
    moved_total, ran = 0, 0
    for _ in range(rounds):
        ran += 1
        moved = _assign(values, sightings, gate)
        if moved == 0:
            break
        moved_total += moved
        graph = _graph(fixed, sightings)
        values = optimize(graph, values)
    return Reassociation(graph, values, moved_total, ran)


def _assign(values: Any, sightings: list[_Sighting], gate: float) -> int:
    """One assignment round in place; the number of sightings moved."""
    landmarks = sorted({s.landmark for s in sightings})
    column = {k: j for j, k in enumerate(landmarks)}
    held = np.bincount([column[s.landmark] for s in sightings], minlength=len(landmarks))
    by_pose: dict[int, list[int]] = {}
    for i, s in enumerate(sightings):
        by_pose.setdefault(s.pose, []).append(i)
    moved = 0
    for rows in by_pose.values():
        d2 = squared_distances(values, [sightings[i] for i in rows], landmarks)
        cost = np.where(d2 < gate, d2, _OUTSIDE)
        chosen_rows, chosen_columns = linear_sum_assignment(cost)
        for a, j in zip(chosen_rows.tolist(), chosen_columns.tolist(), strict=True):
            s = sightings[rows[a]]
            old = column[s.landmark]
            if cost[a, j] >= _OUTSIDE or j == old or held[old] <= 1:
                continue
            s.landmark = landmarks[j]
            held[old] -= 1
            held[j] += 1
            moved += 1
    return moved
