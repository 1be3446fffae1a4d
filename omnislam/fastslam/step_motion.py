"""Which motion model one step's poses are drawn from: the filter's, or the odometry's own noise.

A frame's odometry may state its covariance (``Odometry.covariance``). Where the filter samples
it (``StatedOdometryNoise.resolve``: the front end's laser odometry by default) the step's poses
are drawn from that Gaussian on the delta (``core.motion.StatedOdometryMotion``); otherwise from
the filter's motion model (the alpha model of thesis eqs. 4.40-4.44). Either way the step's
covariance on the robot-frame delta is ``MotionModel.covariance``: what a composed gap, the
association's spreads and the smoothed read-out take as the step's noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from omnislam.core.motion import MotionModel, StatedOdometryMotion
from omnislam.core.types import Odometry


@dataclass(frozen=True, slots=True)
class StepMotion:
    """One step's odometry delta and the motion model its poses are drawn from.

    Attributes:
        delta: (3,) the robot-frame delta [m, m, rad].
        stated: the Gaussian of the odometry's stated covariance when the step samples it (or
            of a composed gap, ``gap.ComposedGap.close``), else None.
        model: the model the step samples from: ``stated``, or the filter's motion model.
    """

    delta: np.ndarray
    stated: StatedOdometryMotion | None
    model: MotionModel

    def covariance(self) -> np.ndarray:
        """(3, 3) the covariance of ``delta`` in the previous pose's frame."""
        return self.model.covariance(self.delta)

    def transition(self) -> tuple[np.ndarray, np.ndarray]:
        """(delta (3,), covariance (3, 3)): the Gaussian transition of the smoothed read-out
        (``particles.PathHistory.record``)."""
        return np.array(self.delta, dtype=float), self.covariance()


class OdometryNoise:
    """Chooses each step's motion model.

    Args:
        motion: the filter's motion model.
        sample_stated: whether a stated odometry covariance is sampled
            (``StatedOdometryNoise.resolve``).

    Attributes:
        frames_stated: steps drawn from a stated covariance so far.
    """

    def __init__(self, motion: MotionModel, sample_stated: bool) -> None:
        self._motion = motion
        self._sample_stated = sample_stated
        self.frames_stated = 0

    def step(self, odometry: Odometry) -> StepMotion:
        """The motion of the step with ``odometry``."""
        delta = odometry.delta
        if odometry.covariance is None or not self._sample_stated:
            return StepMotion(delta, None, self._motion)
        self.frames_stated += 1
        stated = StatedOdometryMotion(delta, odometry.covariance)
        return StepMotion(delta, stated, stated)
