"""Dead reckoning: compose the odometry, ignore every sighting. The baseline every SLAM back end
must beat, and the initial guess the graph back ends start from.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from omnislam.core.se import se2_integrate
from omnislam.core.sequence_info import SequenceInfo
from omnislam.core.types import Estimate, FrameInput, Trajectory
from omnislam.errors import ConfigError


class DeadReckoning:
    """``wTr_k = wTr_{k-1} * rTr'_k``: the odometry composed from a start pose.

    Args:
        initial_pose_w: (3,) pose of the first frame [x, y, theta]; the origin by default
            (evaluation aligns the estimate to the ground truth).
    """

    name = "deadreckoning"

    def __init__(self, initial_pose_w: np.ndarray | None = None) -> None:
        start = np.zeros(3) if initial_pose_w is None else np.asarray(initial_pose_w, float)
        if start.shape != (3,):
            raise ConfigError(f"initial_pose_w must have shape (3,), got {start.shape}")
        self._start = start
        self._stamps_s: list[float] = []
        self._deltas_r: list[np.ndarray] = []

    def step(self, frame: FrameInput) -> None:
        """Record the frame's odometry (the first frame places the start pose)."""
        self._deltas_r.append(frame.odometry.delta)
        self._stamps_s.append(frame.stamp_s)

    def estimate(self) -> Estimate:
        """The composed path so far (``core.se.se2_integrate``; no landmarks, no covariances)."""
        poses = se2_integrate(np.array(self._deltas_r).reshape(-1, 3), self._start)
        return Estimate(trajectory=Trajectory.from_se2(np.array(self._stamps_s), poses))


def make_estimator(
    info: SequenceInfo, options: Mapping[str, str], rng: np.random.Generator
) -> DeadReckoning:
    """Factory for ``omnislam.estimators``; dead reckoning takes no options and no randomness."""
    del info, rng
    check_options(options)
    return DeadReckoning()


def check_options(options: Mapping[str, str]) -> None:
    """Validate ``--set`` options without building anything (dead reckoning takes none)."""
    if options:
        raise ConfigError(f"deadreckoning takes no options, got: {', '.join(sorted(options))}")
