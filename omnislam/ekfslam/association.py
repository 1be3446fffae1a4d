"""Data association of SLAM for Dummies ("Associação de dados"): nearest neighbour + gate + counter.

The tutorial's policy for sightings without ids:

1. each sighting is paired with the nearest landmark seen at least N times;
2. the pair passes the validation gate nu^T S^-1 nu <= lambda: the same landmark, re-observed;
3. otherwise the sighting is a new landmark with its counter set to 1.

Here "nearest" is the smallest Mahalanobis distance among the gated pairs (the tutorial notes it
is better than the Euclidean one it used), and a landmark seen fewer than N times is *tentative*:
it is kept outside the filter state (``TentativeLandmarks``), matched by the same gate on world
positions, and enters the state at its N-th sighting. A tentative landmark not re-observed
while the robot travels a given distance is dropped. ``nearest_gated`` chooses among landmarks
of the state, ``TentativeLandmarks`` holds the others.

With the joint test (``AssociationConfig.test``, joint by default) the frame's
sightings of unknown id are associated together (``core.compatibility.jcbb``, Neira & Tardos
2001) against the state landmarks and the tentative ones: ``frame_pairings`` builds the
linearised predictions from the filter's own P (robot and candidate blocks with their
cross-covariances); tentative candidates join with their own covariance, independent of the rest.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from omnislam.core.compatibility import Pairings
from omnislam.core.gaussian import mahalanobis_squared
from omnislam.core.measurement import RangeBearing2D


def nearest_gated(d2: np.ndarray, gate: float) -> int | None:
    """Index of the smallest squared Mahalanobis distance ``d2`` if it is inside ``gate``."""
    if d2.size == 0:
        return None
    best = int(np.argmin(d2))
    return best if d2[best] <= gate else None


@dataclass
class TentativeLandmarks:
    """Landmarks seen fewer than N times: world positions, covariances and counters.

    Each candidate stores the world point of its latest sighting, l = g(x_r, z), with the
    covariance J_xr P_rr J_xr^T + J_z R J_z^T of that point (robot and sighting uncertainty);
    a new point matches a candidate when the squared Mahalanobis distance of their difference
    under the sum of the two covariances is inside the gate (the correlation through the robot
    pose is ignored: the test is conservative, it accepts more than the exact one).
    """

    points_w: list[np.ndarray] = field(default_factory=list)
    covariances: list[np.ndarray] = field(default_factory=list)
    counts: list[int] = field(default_factory=list)
    last_seen_m: list[float] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.counts)

    def match(
        self, point_w: np.ndarray, cov: np.ndarray, gate: float, taken: set[int]
    ) -> int | None:
        """The nearest candidate (Mahalanobis) inside ``gate``, not among ``taken``, or None."""
        if not self.counts:
            return None
        diff = np.asarray(self.points_w) - point_w  # (k, 2)
        S = np.asarray(self.covariances) + cov  # (k, 2, 2)
        d2 = mahalanobis_squared(diff, np.linalg.inv(S))
        if taken:
            d2[list(taken)] = np.inf
        return nearest_gated(d2, gate)

    def add(self, point_w: np.ndarray, cov: np.ndarray, odometer_m: float) -> int:
        """A new candidate seen once, with the robot's path length ``odometer_m`` then; returns
        its index."""
        self.points_w.append(np.asarray(point_w, dtype=float))
        self.covariances.append(np.asarray(cov, dtype=float))
        self.counts.append(1)
        self.last_seen_m.append(float(odometer_m))
        return len(self.counts) - 1

    def observe(self, index: int, point_w: np.ndarray, cov: np.ndarray, odometer_m: float) -> int:
        """Count one more sighting of candidate ``index`` (latest point kept); returns the count."""
        self.points_w[index] = np.asarray(point_w, dtype=float)
        self.covariances[index] = np.asarray(cov, dtype=float)
        self.counts[index] += 1
        self.last_seen_m[index] = float(odometer_m)
        return self.counts[index]

    def remove(self, indices: list[int]) -> None:
        """Forget the candidates at ``indices``."""
        drop = set(indices)
        keep = [i for i in range(len(self.counts)) if i not in drop]
        self.points_w = [self.points_w[i] for i in keep]
        self.covariances = [self.covariances[i] for i in keep]
        self.counts = [self.counts[i] for i in keep]
        self.last_seen_m = [self.last_seen_m[i] for i in keep]

    def drop_stale(self, odometer_m: float, window_m: float) -> int:
        """Drop candidates last seen more than ``window_m`` of robot travel before
        ``odometer_m``; returns how many were dropped."""
        stale = [i for i, last in enumerate(self.last_seen_m) if odometer_m - last > window_m]
        if stale:
            self.remove(stale)
        return len(stale)


def frame_pairings(
    x_r: np.ndarray,
    P_sub: np.ndarray,
    landmarks_w: np.ndarray,
    z: np.ndarray,
    R: np.ndarray,
    model: RangeBearing2D,
) -> Pairings:
    """The linearised predictions of one frame's K sightings against M candidates.

    Args:
        x_r: (3,) robot pose.
        P_sub: (3 + 2M, 3 + 2M) covariance of [robot, candidate 1, ..., candidate M].
        landmarks_w: (M, 2) candidate positions.
        z: (K, 2) sightings (range, bearing); R: (K, 2, 2) their noise.
        model: the range-bearing model.
    """
    m, k = len(landmarks_w), len(z)
    z_hat, H_r, H_l = model.predict(np.broadcast_to(x_r, (m, 3)), landmarks_w)
    nu = model.residual(z[:, None, :], z_hat[None, :, :])
    H = np.zeros((k, m, 2, 3 + 2 * m))
    H[:, :, :, :3] = H_r[None]
    for j in range(m):
        H[:, j, :, 3 + 2 * j : 5 + 2 * j] = H_l[j]
    return Pairings(nu, H, P_sub, R)
