"""Loop closure by map matching: duplicate landmarks of a revisited place found and merged.

Landmarks started by the association of unlabelled sightings (``range_bearing.py``) can be
duplicates: after a long stretch of odometry the robot's pose is too uncertain for its sightings
to be given to the landmarks of a place it has mapped before, so they start new ones (or are
dropped as ambiguous). The odometry keeps tying those new landmarks to the robot's recent poses,
so together they form a *local map* that is rigid up to one pose error: the error that separates
them from the old map. ``LandmarkMerger`` recognises the revisit by matching that local map
against the old one and merges the landmarks found to be the same:

* **local map**: the created landmarks observed within the last ``window_frames`` frames
  (``LoopClosureConfig``; positions from iSAM2);
* **candidates**: for each local landmark, every older created landmark it was never seen in the
  same frame with (two landmarks seen together are two landmarks) whose position is within a
  loose Euclidean reach of it;
* **verification by joint compatibility**: "landmark b is landmark a" predicts
  ``x_b - x_a = 0``. With the iSAM2 joint marginal covariance P of every landmark involved --
  which carries the local map's common pose error as correlation -- the innovation
  ``nu = x_a - x_b`` has ``H = [I at b, -I at a]`` and ``S = H P H^T``; JCBB
  (``core.compatibility.jcbb``, Neira & Tardos 2001) finds the largest jointly compatible set of
  such pairings, each old landmark taken once. This is map-to-map joint compatibility as in
  Neira, Tardos & Castellanos, "Linear time vehicle relocation in SLAM", ICRA 2003: one shared
  correction must explain every pairing, so a lone landmark that happens to lie near an old one
  is not enough;
* **acceptance**: at least ``min_landmarks`` pairings that the runner-up hypothesis (as many
  pairings) does not make differently within the association's ``ambiguity_margin``
  (``core.compatibility.decide``);
* **merge**: a ``BetweenFactorPoint2(b, a, 0)`` with std ``merge_sigma_m`` per axis
  ties the two variables (GTSAM has no variable elimination by identity; the factor is an
  ordinary measurement, so iSAM2 takes it in its next update, and the estimate moves both
  landmarks -- and with them the poses -- to one place). Afterwards b is *retired*: the
  association offers only a, the exported map lists only a.

With given landmark ids nothing is merged (only created landmarks take part).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from omnislam._optional import require
from omnislam.core.compatibility import Decision, Pairings, decide, jcbb
from omnislam.graphslam import factors as fx
from omnislam.graphslam.association import Gates
from omnislam.graphslam.builder import LandmarkRegistry
from omnislam.graphslam.config import LoopClosureConfig

gtsam = require("gtsam")

#: innovation given to pairings that are not candidates (far outside every gate) [m]
_EXCLUDED = 1e6


@dataclass(frozen=True, slots=True)
class Merge:
    """One landmark found to be another: ``duplicate`` is retired, ``kept`` stays."""

    duplicate: int
    kept: int


class LandmarkMerger:
    """Finds created landmarks that duplicate older ones and adds the merging factors.

    Args:
        config: the loop closure's section (``every_frames``, ``window_frames``,
            ``min_landmarks``, ``merge_sigma_m``).
        session: the iSAM2 session (landmark estimates and their joint marginal).
        registry: the landmarks in the graph (merged ones are retired there).
        is_created: ``is_created(id)`` True for landmarks the association created (only those
            take part).
        gate_probability: the association's chi-square gate (``AssociationConfig``): a merge
            is decided as a sighting's association is.
        new_landmark_probability: the association's chi-square gate for a new landmark
            (``AssociationConfig``).
        ambiguity_margin: the association's ambiguity margin (``AssociationConfig``).
        landmark_sigma_m: the association's fixed landmark sigma [m], widening the reach
            within which an old landmark is a candidate (``AssociationConfig``).
    """

    def __init__(
        self,
        config: LoopClosureConfig,
        session: Any,
        registry: LandmarkRegistry,
        is_created: Any,
        *,
        gate_probability: float,
        new_landmark_probability: float,
        ambiguity_margin: float,
        landmark_sigma_m: float,
    ) -> None:
        self._config = config
        self._session = session
        self._registry = registry
        self._is_created = is_created
        self._gate_probability = gate_probability
        self._gates = Gates.from_probabilities(gate_probability, new_landmark_probability)
        self._ambiguity_margin = ambiguity_margin
        self._landmark_sigma_m = landmark_sigma_m
        self._noise = gtsam.noiseModel.Isotropic.Sigma(2, config.merge_sigma_m)
        self._frames: dict[int, set[int]] = {}  # landmark -> frames it was seen in
        self._last_seen: dict[int, int] = {}
        self._order: dict[int, int] = {}  # landmark -> rank of its first sighting
        self._calls = 0
        self.merged = 0
        self.loop_closures = 0
        self.checks = 0

    def seen(self, landmark_id: int, k: int) -> None:
        """Landmark ``landmark_id`` was observed in frame k (a factor was added or held).

        Only landmarks that take part (``is_created``) are tracked.
        """
        if not self._is_created(landmark_id):
            return
        kept = self._registry.resolve(landmark_id)
        self._frames.setdefault(kept, set()).add(k)
        self._order.setdefault(kept, len(self._order))
        self._last_seen[kept] = max(k, self._last_seen.get(kept, k))

    def check(self, k: int, graph: Any) -> list[Merge]:
        """Every ``every_frames`` calls: match the local map, merge (see the module).

        Args:
            k: the frame being added (its own sightings are not in iSAM2 yet).
            graph: the frame's new factors; the merging factors are added to it.

        Returns:
            The merges made now.
        """
        self._calls += 1
        if self._calls % self._config.every_frames:
            return []
        active = [
            lid
            for lid in self._frames
            if self._is_created(lid)
            and self._registry.active(lid)
            and self._session.exists(fx.landmark_key(lid))
        ]
        local = [lid for lid in active if k - self._last_seen[lid] <= self._config.window_frames]
        if not local or len(active) < 2:
            return []
        self.checks += 1
        xy: dict[int, np.ndarray] = {}  # iSAM2's estimates read in this check
        candidates = self._candidates(local, active, xy)
        if not candidates:
            return []
        pairs = self._verify(candidates, xy)
        if len(pairs) < self._config.min_landmarks:
            return []
        return self._merge(pairs, graph)

    def _position(self, lid: int, xy: dict[int, np.ndarray]) -> np.ndarray:
        """iSAM2's estimate of a landmark, read once per check (into ``xy``), its cached
        position in the registry refreshed."""
        if lid not in xy:
            xy[lid] = np.asarray(self._session.point2(fx.landmark_key(lid)))
            self._registry.xy[self._registry.row(lid)] = xy[lid]
        return xy[lid]

    def _candidates(
        self, local: list[int], active: list[int], xy: dict[int, np.ndarray]
    ) -> dict[int, list[int]]:
        """Per local landmark, the older created landmarks it may duplicate: never seen in one
        frame with it, and within a loose reach of it (its largest marginal std twice, plus the
        association's landmark sigma, times the new-landmark gate's radius)."""
        cached = self._registry.xy  # positions at insertion or last refresh: a coarse filter
        loose = np.sqrt(4.0 * self._gates.new_landmark)
        candidates: dict[int, list[int]] = {}
        for b in local:
            spread = np.sqrt(
                np.linalg.eigvalsh(self._session.marginal_covariance(fx.landmark_key(b)))[-1]
            )
            reach = loose * (2.0 * spread + self._landmark_sigma_m)
            # only landmarks whose cached position is within 3x the reach are read from iSAM2
            # (one back-substitution each): the cache is at most one loop's correction stale
            coarse = cached[self._registry.row(b)]
            near = [
                a
                for a in active
                if self._order[a] < self._order[b]
                and np.hypot(*(cached[self._registry.row(a)] - coarse)) <= 3.0 * reach
                and not (self._frames[a] & self._frames[b])
                and np.hypot(*(self._position(a, xy) - self._position(b, xy))) <= reach
            ]
            if near:
                candidates[b] = near
        return candidates

    def _verify(
        self, candidates: dict[int, list[int]], xy: dict[int, np.ndarray]
    ) -> list[tuple[int, int]]:
        """(local, old) pairings of the largest jointly compatible set that the runner-up
        hypothesis does not make differently (see the module)."""
        measured = list(candidates)
        olds = sorted({a for near in candidates.values() for a in near}, key=self._order.get)
        involved = list(dict.fromkeys([*measured, *olds]))
        column = {lid: 2 * i for i, lid in enumerate(involved)}
        P = self._session.joint_marginal_covariance([fx.landmark_key(i) for i in involved])
        K, M, n = len(measured), len(olds), 2 * len(involved)
        nu = np.full((K, M, 2), _EXCLUDED)
        H = np.zeros((K, M, 2, n))
        for i, b in enumerate(measured):
            for j, a in enumerate(olds):
                if a == b or a not in candidates[b]:
                    continue
                nu[i, j] = xy[a] - xy[b]
                H[i, j, :, column[b] : column[b] + 2] = np.eye(2)
                H[i, j, :, column[a] : column[a] + 2] = -np.eye(2)
        R = np.tile(1e-12 * np.eye(2), (K, 1, 1))
        result = jcbb(Pairings(nu, H, P, R), self._gate_probability)
        decisions = decide(
            result,
            np.zeros(K, dtype=np.int64),
            self._gates.match,
            self._gates.new_landmark,
            self._ambiguity_margin,
        )
        return [
            (measured[i], olds[int(result.assignment[i])])
            for i in range(K)
            if decisions[i] == Decision.PAIRED
        ]

    def _merge(self, pairs: list[tuple[int, int]], graph: Any) -> list[Merge]:
        """Tie each pairing's landmarks by a merging factor in ``graph`` and retire the newer."""
        merges = []
        for b, a in pairs:
            kept = self._registry.resolve(a)
            if kept == b or not self._registry.active(b):
                continue
            graph.add(
                gtsam.BetweenFactorPoint2(
                    fx.landmark_key(b), fx.landmark_key(kept), gtsam.Point2(0.0, 0.0), self._noise
                )
            )
            self._registry.retire(b, kept)
            self._frames[kept] |= self._frames.pop(b)
            self._last_seen[kept] = max(self._last_seen[kept], self._last_seen.pop(b))
            merges.append(Merge(b, kept))
        self.merged += len(merges)
        self.loop_closures += int(bool(merges))
        return merges
