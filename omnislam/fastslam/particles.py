"""The particle set over robot poses and the record of its path.

Poses are one (P, 3) array [x, y, theta] and weights one (P,) array of logarithms (thesis eqs.
4.47-4.48 in log space), so every operation is vectorised across particles.
"""

from __future__ import annotations

import numpy as np

from omnislam.core.se import wrap_angle
from omnislam.core.types import Trajectory
from omnislam.errors import ConfigError
from omnislam.fastslam.resampling import (
    effective_sample_size,
    normalize_log_weights,
    normalize_per_island,
)
from omnislam.fastslam.smoother import ffbsm_log_weights


def weighted_mean_pose(poses: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """(3,) weighted mean of poses (P, 3) under weights (P,) summing to 1; the heading is the
    circular mean atan2(E sin, E cos)."""
    heading = np.arctan2(weights @ np.sin(poses[:, 2]), weights @ np.cos(poses[:, 2]))
    return np.array([weights @ poses[:, 0], weights @ poses[:, 1], heading])


def weighted_covariance_about(
    poses: np.ndarray, weights: np.ndarray, mean: np.ndarray
) -> np.ndarray:
    """(3, 3) weighted covariance of poses (P, 3) about ``mean`` (heading residuals wrapped)."""
    d = poses - mean
    d[:, 2] = wrap_angle(d[:, 2])
    return (d * weights[:, None]).T @ d


def initial_poses(
    n_particles: int,
    wTr0: np.ndarray | None,
    sigma: tuple[float, float, float],
    rng: np.random.Generator,
) -> np.ndarray:
    """(P, 3) the particles' first poses: ``wTr0`` (the origin when None), each perturbed by
    a draw of N(0, diag(sigma^2)) when ``sigma`` [m, m, rad] is not zero.

    Raises:
        ConfigError: ``wTr0`` is not a finite (3,) pose.
    """
    pose = np.zeros(3) if wTr0 is None else np.asarray(wTr0, dtype=float)
    if pose.shape != (3,) or not np.all(np.isfinite(pose)):
        raise ConfigError(f"initial_pose must be a finite (3,) array, got {pose!r}")
    poses = np.tile(pose, (n_particles, 1))
    std = np.asarray(sigma, dtype=float)
    if np.any(std > 0):
        poses = poses + std * rng.standard_normal((n_particles, 3))
    return poses


class ParticleSet:
    """P pose hypotheses with log weights.

    Attributes:
        poses: (P, 3) poses [x, y, theta] in the world.
        log_weights: (P,) normalised log weights.
        log_evidence: sum over the reweightings of log sum_i w_i exp(log_factor_i) (w the
            normalised weights before): the particle filter's estimate of the log-likelihood of
            the sightings so far, log p(z_1:t) (Doucet & Johansen 2011, "A tutorial on particle
            filtering and smoothing", eq. 31), up to the constant of the new-landmark density.
    """

    def __init__(self, poses: np.ndarray) -> None:
        self.poses = np.array(poses, dtype=float)
        p = self.poses.shape[0]
        self.log_weights = np.full(p, -np.log(p))
        self._best_after_resampling: int | None = 0
        self.log_evidence = 0.0

    def __len__(self) -> int:
        return int(self.poses.shape[0])

    @property
    def weights(self) -> np.ndarray:
        """(P,) normalised weights."""
        return np.exp(self.log_weights)

    def reweight(self, log_factors: np.ndarray, islands: np.ndarray | None = None) -> None:
        """Multiply the weights by exp(log_factors) and normalise (thesis 4.47-4.48); add the
        normaliser to ``log_evidence``. With ``islands`` (K + 1 start indices,
        ``resampling.island_bounds``) each island is normalised to 1/K instead (independent
        filters averaged with equal weights; ``log_evidence`` is then the equal mixture's)."""
        unnormalised = self.log_weights + log_factors
        top = np.max(unnormalised)
        if np.isfinite(top):
            self.log_evidence += float(top + np.log(np.sum(np.exp(unnormalised - top))))
        if islands is None:
            self.log_weights = normalize_log_weights(unnormalised)
        else:
            self.log_weights = normalize_per_island(unnormalised, islands)
        self._best_after_resampling = None

    def effective_sample_size(self) -> float:
        """Thesis eq. 4.51."""
        return effective_sample_size(self.log_weights)

    def best(self) -> int:
        """Index of the highest-weight particle (after resampling, when all weights are equal:
        a copy of the particle that was best before it)."""
        if self._best_after_resampling is not None:
            return self._best_after_resampling
        return int(np.argmax(self.log_weights))

    def resample(self, ancestors: np.ndarray) -> None:
        """Particle i <- old particle ancestors[i]; weights become uniform."""
        best = self.best()
        ancestors = np.asarray(ancestors, dtype=np.int64)
        self.poses = self.poses[ancestors]
        p = len(self)
        self.log_weights = np.full(p, -np.log(p))
        copies = np.flatnonzero(ancestors == best)
        self._best_after_resampling = int(copies[0]) if copies.size else 0

    def mean_pose(self) -> np.ndarray:
        """(3,) weighted mean pose; the heading is the circular mean atan2(E sin, E cos)."""
        return weighted_mean_pose(self.poses, self.weights)

    def pose_covariance(self, mean: np.ndarray) -> np.ndarray:
        """(3, 3) weighted covariance about ``mean`` (heading residuals wrapped)."""
        return weighted_covariance_about(self.poses, self.weights, mean)


class PathHistory:
    """Per-step record of the particle set, from which ``Trajectory`` is built.

    Always keeps the weighted mean and covariance per step; with ``keep_particles`` it also
    keeps every particle's pose and log weight and the resampling ancestry, so the path of any
    current particle can be traced back (FastSLAM's path posterior sample), and, with each
    step's odometry delta and covariance (``record``'s ``transition``), the recorded clouds can
    be smoothed backwards (``smoothed_trajectory``, ``smoother.py``).
    """

    def __init__(self, keep_particles: bool, kernels: object | None = None) -> None:
        """Args:
        keep_particles: keep every particle's pose and the ancestry (BEST_ANCESTRY).
        kernels: the compiled kernels (``kernels.compiled()``) for the weighted moments, or
            None for ``ParticleSet.mean_pose`` / ``pose_covariance`` (the reference).
        """
        self._keep = keep_particles
        self._kernels = kernels
        self._stamps: list[float] = []
        self._means: list[np.ndarray] = []
        self._covs: list[np.ndarray] = []
        self._poses: list[np.ndarray] = []
        self._log_weights: list[np.ndarray] = []
        self._ancestors: list[np.ndarray | None] = []
        self._transitions: list[tuple[np.ndarray, np.ndarray] | None] = []

    def __len__(self) -> int:
        return len(self._stamps)

    def record(
        self,
        stamp_s: float,
        particles: ParticleSet,
        transition: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> None:
        """Record the particle set of one step (before any resampling).

        Args:
            stamp_s: the step's time [s].
            particles: the set after the step's update.
            transition: (delta (3,), covariance (3, 3)) of the Gaussian robot-frame odometry
                delta the step's poses were sampled with (for ``smoothed_trajectory``).
        """
        if self._kernels is not None:
            mean, cov = np.empty(3), np.empty((3, 3))
            self._kernels.weighted_moments(particles.weights, particles.poses, mean, cov)
        else:
            mean = particles.mean_pose()
            cov = particles.pose_covariance(mean)
        self._stamps.append(float(stamp_s))
        self._means.append(mean)
        self._covs.append(cov)
        if self._keep:
            self._poses.append(particles.poses.copy())
            self._log_weights.append(particles.log_weights.copy())
            self._ancestors.append(None)
            self._transitions.append(transition)

    def record_resampling(self, ancestors: np.ndarray) -> None:
        """Remember the ancestors of the resampling that followed the last record."""
        if self._keep and self._ancestors:
            self._ancestors[-1] = np.asarray(ancestors, dtype=np.int64).copy()

    def mean_trajectory(self) -> tuple[Trajectory, np.ndarray]:
        """The per-step weighted means (N poses) and covariances (N, 3, 3)."""
        means = np.array(self._means).reshape(-1, 3)
        covs = np.array(self._covs).reshape(-1, 3, 3)
        return Trajectory.from_se2(np.array(self._stamps), means), covs

    def ancestry_trajectory(self, particle: int) -> Trajectory:
        """The path of current particle ``particle`` traced back through every resampling."""
        if not self._keep:
            raise ValueError("PathHistory was created without keep_particles")
        path = np.empty((len(self), 3))
        index = int(particle)
        for t in range(len(self) - 1, -1, -1):
            ancestors = self._ancestors[t]
            if ancestors is not None:
                index = int(ancestors[index])
            path[t] = self._poses[t][index]
        return Trajectory.from_se2(np.array(self._stamps), path)

    def smoothed_trajectory(self) -> tuple[Trajectory, np.ndarray]:
        """The FFBSm marginal means and covariances of every step (``smoother.py``).

        Each step's recorded cloud reweighted by the forward-filtering backward-smoothing
        recursion (Doucet, Godsill & Andrieu 2000 eq. 43) with the recorded transitions; the
        weighted mean (circular heading) and covariance about it of each step.

        Returns:
            The trajectory (N poses) and (N, 3, 3) covariances.

        Raises:
            ValueError: created without keep_particles, or a step after the first recorded
                without its transition.
        """
        if not self._keep:
            raise ValueError("PathHistory was created without keep_particles")
        n = len(self)
        deltas = np.zeros((n, 3))
        covs = np.tile(np.eye(3), (n, 1, 1))
        for t in range(1, n):
            transition = self._transitions[t]
            if transition is None:
                raise ValueError(f"step {t} was recorded without its transition")
            deltas[t], covs[t] = transition
        smoothed = ffbsm_log_weights(self._poses, self._log_weights, deltas, covs)
        means = np.empty((n, 3))
        out_covs = np.empty((n, 3, 3))
        for t in range(n):
            w = np.exp(smoothed[t])
            means[t] = weighted_mean_pose(self._poses[t], w)
            out_covs[t] = weighted_covariance_about(self._poses[t], w, means[t])
        return Trajectory.from_se2(np.array(self._stamps), means), out_covs

    def covariances_about(self, path: np.ndarray) -> np.ndarray:
        """(N, 3, 3) each step's weighted second moment of the particle set about ``path``.

        E[(x - a)(x - a)^T] = Sigma + (mu - a)(mu - a)^T per step (mu, Sigma the recorded
        weighted mean and covariance, a the reported pose; heading residual wrapped): the
        filtered uncertainty of a pose the filter reports away from its weighted mean, so a
        reported path gets the spread it came from plus its own offset from the mean.

        Args:
            path: (N, 3) the reported poses [m, m, rad], one per recorded step.
        """
        means = np.array(self._means).reshape(-1, 3)
        covs = np.array(self._covs).reshape(-1, 3, 3)
        offset = means - np.asarray(path, dtype=float).reshape(-1, 3)
        offset[:, 2] = wrap_angle(offset[:, 2])
        return covs + offset[:, :, None] * offset[:, None, :]

    def lineages(self) -> np.ndarray:
        """(N,) for every recorded step, how many distinct particles of that step the current
        set's paths pass through (1: every current path shares that pose).

        The path degeneracy of a particle filter (Bailey, Nieto & Nebot 2006; Kantas et al.
        2015): resampling prunes lineages, so going back in time the current paths coalesce
        onto one ancestor, and a later observation (a loop closure) can only choose among the
        path histories that are still distinct.
        """
        if not self._keep:
            raise ValueError("PathHistory was created without keep_particles")
        counts = np.empty(len(self), dtype=np.int64)
        index = np.arange(len(self._poses[-1])) if self._poses else np.empty(0, np.int64)
        for t in range(len(self) - 1, -1, -1):
            ancestors = self._ancestors[t]
            if ancestors is not None:
                index = np.unique(ancestors[index])
            counts[t] = index.size
        return counts
