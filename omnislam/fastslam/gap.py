"""The odometry of a gap without sightings, composed into one Gaussian step.

A frame without sightings gives a particle filter nothing to weigh: FastSLAM samples each of
them from the motion model (thesis sec. 4.5: between processed images only prediction runs), and
at the next sighting FastSLAM 2.0's proposal (thesis eqs. 4.45-4.46, Montemerlo 2003 sec. 3.3)
refines the pose by the last step's motion noise only: a particle that drifted over the gap can
be moved by the sightings no further than one step's spread. Composing the gap instead -- the
deltas d_1..d_k in the robot frame of the pose at the gap's start, D = d_1 (+) ... (+) d_k, with
the linearised covariance C_k = J_a C_{k-1} J_a^T + J_b Q_k J_b^T (``core.motion.compose_odometry``;
Q_k the step's own covariance, Thrun et al. 2005 Table 7.1) -- gives the motion from the pose
sampled at the last sighting to the pose of the next one as one Gaussian: the next frame samples
it (FastSLAM 1.0) or refines it by its sightings (2.0) with the whole gap's uncertainty. This
is FastSLAM 2.0's proposal p(x_t | x_{t-k}, u_{t-k+1..t}, z_t) with the gap's poses marginalised
(Rao-Blackwellised) instead of sampled; the gap's own frames report x_{t-k} (+) D_j, the
composed mean.
"""

from __future__ import annotations

import numpy as np

from omnislam.core.motion import StatedOdometryMotion, compose_odometry
from omnislam.core.se import se2_compose


class ComposedGap:
    """The gap's motion since the last frame with sightings, in that frame's robot frame.

    Attributes:
        start: (P, 3) the particles' poses at the gap's start (None: no gap open).
        delta: (3,) the composed delta D.
        covariance: (3, 3) its covariance C.
    """

    def __init__(self) -> None:
        self.start: np.ndarray | None = None
        self.delta = np.zeros(3)
        self.covariance = np.zeros((3, 3))

    @property
    def open(self) -> bool:
        """Whether frames without sightings have been composed since the last sighting."""
        return self.start is not None

    def extend(self, poses: np.ndarray, delta_r: np.ndarray, covariance: np.ndarray) -> np.ndarray:
        """Compose one more step without sightings.

        Args:
            poses: (P, 3) the particles' poses (the gap's start when no gap is open).
            delta_r: (3,) the step's odometry delta.
            covariance: (3, 3) its covariance in the previous pose's frame.

        Returns:
            (P, 3) the particles' composed mean poses start (+) D.
        """
        if self.start is None:
            self.start = np.array(poses, dtype=float, copy=True)
        self.delta, self.covariance = self.composed(delta_r, covariance)
        return se2_compose(self.start, self.delta)

    def composed(
        self, delta_r: np.ndarray, covariance: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """(D (+) delta_r, J_a C J_a^T + J_b Q J_b^T): the gap extended by one step
        (``core.motion.compose_odometry``)."""
        return compose_odometry(
            self.delta, self.covariance, np.asarray(delta_r, dtype=float),
            np.asarray(covariance, dtype=float),
        )

    def close(
        self, delta_r: np.ndarray, covariance: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, StatedOdometryMotion]:
        """End the gap with the frame that has sightings.

        Returns:
            (start poses (P, 3), the composed delta (3,), the motion model of the whole gap).
        """
        assert self.start is not None
        delta, cov = self.composed(delta_r, covariance)
        start = self.start
        self.start = None
        self.delta = np.zeros(3)
        self.covariance = np.zeros((3, 3))
        return start, delta, StatedOdometryMotion(delta, cov)
