"""How diverse the particle set stays: distinct ancestors and effective sample size per step.

Resampling (thesis eq. 4.49) replaces the particle set by copies of some of its members. When
the weights are very uneven, every new particle descends from the same old one: the set has
*collapsed* onto one ancestor, its spread no longer says anything about the pose's uncertainty
(the pose NEES explodes) and a later loop closure has only one path history left to choose from
(Bailey, Nieto & Nebot 2006, "Consistency of the FastSLAM algorithm"). This record keeps, for
every step, the number of distinct particles of the previous step that the current set descends
from (P when the step did not resample) and the effective sample size before resampling
(thesis eq. 4.51), so that collapse can be measured instead of guessed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, slots=True)
class DiversitySummary:
    """Summary of a ``DiversityLog``.

    Attributes:
        steps: steps recorded.
        resamplings: steps that resampled.
        distinct_min: fewest distinct ancestors of any step (P when it never resampled).
        distinct_median_at_resampling: median distinct ancestors over the resampling steps
            (P when it never resampled).
        single_ancestor_steps: steps whose set descends from one particle of the previous step.
        single_ancestor_longest_run: longest run of consecutive such steps (steps without
            resampling break a run: the set keeps its members).
        ess_min: smallest effective sample size before resampling (P when nothing was weighed).
    """

    steps: int
    resamplings: int
    distinct_min: int
    distinct_median_at_resampling: float
    single_ancestor_steps: int
    single_ancestor_longest_run: int
    ess_min: float


class DiversityLog:
    """Per-step distinct-ancestor counts and effective sample sizes of one filter.

    Args:
        n_particles: P.
    """

    def __init__(self, n_particles: int) -> None:
        self._p = int(n_particles)
        self._distinct: list[int] = []
        self._ess: list[float] = []
        self._resampled: list[bool] = []

    def record(self, ess: float, ancestors: np.ndarray | None) -> None:
        """One step: its ESS before resampling and the resampling's ancestors (None: the step
        did not resample)."""
        self._ess.append(float(ess))
        if ancestors is None:
            self._distinct.append(self._p)
            self._resampled.append(False)
        else:
            self._distinct.append(int(np.unique(ancestors).size))
            self._resampled.append(True)

    @property
    def distinct(self) -> np.ndarray:
        """(steps,) distinct ancestors of each step's particle set."""
        return np.array(self._distinct, dtype=np.int64)

    @property
    def ess(self) -> np.ndarray:
        """(steps,) effective sample size of each step before resampling."""
        return np.array(self._ess, dtype=float)

    @property
    def resampled(self) -> np.ndarray:
        """(steps,) whether each step resampled."""
        return np.array(self._resampled, dtype=bool)

    def summary(self) -> DiversitySummary:
        """The counts of ``DiversitySummary``."""
        distinct = self.distinct
        resampled = self.resampled
        single = distinct == 1
        longest = run = 0
        for one in single.tolist():
            run = run + 1 if one else 0
            longest = max(longest, run)
        at_resampling = distinct[resampled]
        return DiversitySummary(
            steps=int(distinct.size),
            resamplings=int(np.count_nonzero(resampled)),
            distinct_min=int(distinct.min(initial=self._p)),
            distinct_median_at_resampling=(
                float(np.median(at_resampling)) if at_resampling.size else float(self._p)
            ),
            single_ancestor_steps=int(np.count_nonzero(single)),
            single_ancestor_longest_run=longest,
            ess_min=float(min(self._ess, default=float(self._p))),
        )
