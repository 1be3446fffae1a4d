"""Fake estimators for report tests: dead reckoning plus a wobble of a chosen size.

Options: ``amplitude`` [m] of the wobble and ``seed_gain``: the amplitude is scaled by
``1 + seed_gain * u`` with ``u`` drawn from the run's seeded generator, so seeds differ.
``make_mapper`` also reports a landmark map (``landmarks`` points on the walls of the room log,
off by a seeded error, with covariances), so a report has a landmark figure to draw.
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


class WobblyMapper(Wobbly):
    """A Wobbly that also has a map of points on the room's walls (10 m x 8 m)."""

    def __init__(self, amplitude_m: float, landmarks: int, rng: np.random.Generator) -> None:
        super().__init__(amplitude_m)
        t = np.linspace(0.0, 36.0, landmarks, endpoint=False)  # along the walls' perimeter
        walls = np.where(
            t < 10,
            [t, 0 * t],
            np.where(
                t < 18, [10 + 0 * t, t - 10], np.where(t < 28, [28 - t, 8 + 0 * t], [0 * t, 36 - t])
            ),
        ).T
        self._landmarks_w = np.column_stack([walls + rng.normal(0, 0.1, walls.shape), 0 * t])
        sigma = rng.uniform(0.05, 0.2, landmarks)
        self._covariances = np.zeros((landmarks, 3, 3))
        self._covariances[:, 0, 0] = sigma**2
        self._covariances[:, 1, 1] = (0.5 * sigma) ** 2
        self._covariances[:, 2, 2] = 1.0

    def estimate(self) -> Estimate:
        return Estimate(
            super().estimate().trajectory,
            np.arange(len(self._landmarks_w)),
            self._landmarks_w,
            landmark_covariances=self._covariances,
        )


def make_wobbly(info: object, options: Mapping[str, str], rng: np.random.Generator) -> Wobbly:
    del info
    gain = float(options.get("seed_gain", 0.0))
    return Wobbly(float(options.get("amplitude", 0.0)) * (1.0 + gain * rng.random()))


def make_mapper(info: object, options: Mapping[str, str], rng: np.random.Generator) -> WobblyMapper:
    del info
    gain = float(options.get("seed_gain", 0.0))
    amplitude = float(options.get("amplitude", 0.0)) * (1.0 + gain * rng.random())
    return WobblyMapper(amplitude, int(options.get("landmarks", 12)), rng)
