"""A fake estimator for report tests: dead reckoning plus a wobble of a chosen size.

Options: ``amplitude`` [m] of the wobble and ``seed_gain``: the amplitude is scaled by
``1 + seed_gain * u`` with ``u`` drawn from the run's seeded generator, so seeds differ.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from omnislam.core.types import Estimate, Trajectory
from omnislam.deadreckoning import DeadReckoning


class Wobbly(DeadReckoning):
    def __init__(self, amplitude_m: float) -> None:
        super().__init__()
        self._amplitude_m = amplitude_m

    def estimate(self) -> Estimate:
        trajectory = super().estimate().trajectory
        se2 = trajectory.se2.copy()
        k = np.arange(len(se2))
        se2[:, 0] += self._amplitude_m * np.sin(0.9 * k)
        se2[:, 1] += self._amplitude_m * np.cos(1.3 * k)
        return Estimate(trajectory=Trajectory.from_se2(trajectory.stamps_s, se2))


def make_wobbly(info: object, options: Mapping[str, str], rng: np.random.Generator) -> Wobbly:
    del info
    gain = float(options.get("seed_gain", 0.0))
    return Wobbly(float(options.get("amplitude", 0.0)) * (1.0 + gain * rng.random()))
