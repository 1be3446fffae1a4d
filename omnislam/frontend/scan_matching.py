"""Laser odometry: each planar scan registered to the last few by ICP (open3d), the wheel
odometry as the initial guess and the fallback.

Scan k is registered to the union of scans k-``submap_scans`` .. k-1 (placed with the laser
odometry itself, expressed in scan k-1's frame) by open3d's point-to-plane ICP
(``open3d.pipelines.registration.registration_icp``, ``TransformationEstimationPointToPlane``;
Chen & Medioni 1992) on the points lifted to z = 0, the target's normals estimated in the
plane (2-D PCA of each point's neighbours: open3d's own normals of a flat cloud point along z).
The wheel odometry increment is the initial guess; one ICP per correspondence distance, coarse
to fine. The match is

* **accepted** when enough points of both clouds are valid (``min_points``), the fitness
  (share of the new scan's points with a correspondence) and the point-to-line RMSE pass
  ``min_fitness`` / ``max_rmse_m``, and the increment agrees with the wheel odometry within
  ``gate_translation_m`` + ``gate_translation_fraction`` x the distance travelled and
  ``gate_rotation_rad``;
* **degenerate** when, besides, the point-to-line Hessian's translational block has a
  smallest eigenvalue per correspondence below ``min_translation_information`` (a corridor, one
  straight wall: nothing fixes the motion along it). The ICP's rotation and its translation
  across the unconstrained direction v are kept; along v the wheel odometry's translation is
  kept, with std ``degenerate_sigma_m`` + ``degenerate_sigma_fraction`` x the distance
  travelled in place of what the Hessian says along v;
* **rejected** otherwise (too few points, a poor fit, disagreeing with the odometry): the
  wheel odometry increment is kept as it is, with the covariance the data states for it (None:
  each estimator's own motion model), so a failed registration never makes the odometry worse.

**Covariance** of an accepted increment: the Gauss-Newton covariance of point-to-line ICP,
``sigma^2 H^-1`` with ``H = sum_i J_i^T J_i`` over the correspondences
(``J_i = n_i^T [I, perp(q_i)]``: left perturbation in the previous scan's frame) and
``sigma = max(point-to-line RMSE, sigma_floor_m)``, multiplied by ``covariance_inflation``
(correlated residuals and wrong correspondences make the plain Hessian far too confident), moved
to the increment's own parameters (x, y, theta) and widened by independent stds ``min_sigma``
+ ``sigma_per_m`` x the distance travelled + ``sigma_per_rad`` x the rotation (the config
docstring gives the values and the NEES they reach).

**Determinism.** open3d (0.20, oneTBB) parallelises the ICP's correspondence search and its
``J^T J`` / ``J^T r`` sums across threads, whose work stealing merges the threads' partial sums in
an order that varies from run to run: the same scans then give increments that differ in the
last bits, and through the submap (placed with the laser odometry itself) the whole chain
drifts apart (two ``omnislam frontend carmen-aces`` runs: 439 of 440 increments differ, up to
1.7 cm). The registration and the submap thinning therefore run with open3d limited to one
thread (``open3d.utility.set_max_threads``; the previous limit restored afterwards), which
makes them bit-reproducible at little cost for a scan's few hundred points (aces' 440 scans,
interleaved runs on a loaded 2-core machine: 2.1-2.5 s on one thread, 1.4-2.4 s on two).
"""

from __future__ import annotations

import enum
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from omnislam._optional import require
from omnislam.core.se import (
    se2_compose,
    se2_from_matrix,
    se2_inverse,
    se2_to_matrix,
    se2_transform_points,
    wrap_angle,
)
from omnislam.frontend.config import LaserOdometryConfig


class Reason(enum.Enum):
    """Why a match was accepted or rejected."""

    ACCEPTED = "accepted"
    DEGENERATE = "degenerate"  # used, with the odometry along the unconstrained direction
    TOO_FEW_POINTS = "too-few-points"
    POOR_FIT = "poor-fit"
    DISAGREES_WITH_ODOMETRY = "disagrees-with-odometry"


@dataclass(frozen=True, slots=True)
class ScanMatch:
    """One registration of a scan to the previous one (or to a submap).

    Attributes:
        delta: (3,) the increment [dx, dy, dtheta] of the new pose in the previous pose's frame
            (the ICP's when accepted, else the initial guess).
        covariance: (3, 3) its covariance when accepted, else None.
        fitness: share of source points with a correspondence.
        rmse_m: RMS point-to-line distance of the correspondences [m].
        min_translation_information: smallest eigenvalue of the translational block of the
            point-to-line Hessian, per correspondence (0: a direction not constrained at all).
        reason: accepted or why not.
    """

    delta: np.ndarray
    covariance: np.ndarray | None
    fitness: float
    rmse_m: float
    min_translation_information: float
    reason: Reason

    @property
    def accepted(self) -> bool:
        """True when the increment is the ICP's (fully, or partly when degenerate)."""
        return self.reason in (Reason.ACCEPTED, Reason.DEGENERATE)


def scan_points(
    angles_rad: np.ndarray, ranges_m: np.ndarray, max_range_m: float, config: LaserOdometryConfig
) -> np.ndarray:
    """(M, 2) points of the valid beams of one scan in the sensor frame [m]."""
    limit = max_range_m if config.max_valid_range_m is None else min(
        max_range_m, config.max_valid_range_m)
    ranges = np.asarray(ranges_m, dtype=float)
    with np.errstate(invalid="ignore"):
        valid = np.isfinite(ranges) & (ranges < limit) & (ranges > config.min_range_m)
    r, a = ranges[valid], np.asarray(angles_rad, dtype=float)[valid]
    return np.column_stack([r * np.cos(a), r * np.sin(a)])


def normals_2d(points: np.ndarray, neighbours: int) -> np.ndarray:
    """(M, 2) unit normals: the direction of least spread of each point's neighbours."""
    from scipy.spatial import cKDTree

    k = min(neighbours, points.shape[0])
    _, idx = cKDTree(points).query(points, k)
    nb = points[idx] - points[idx].mean(axis=1, keepdims=True)
    _, vectors = np.linalg.eigh(np.einsum("nki,nkj->nij", nb, nb))
    return vectors[:, :, 0]


def _cloud(o3d: object, points: np.ndarray, normals: np.ndarray | None = None) -> object:
    cloud = o3d.geometry.PointCloud()  # type: ignore[attr-defined]
    zeros = np.zeros((points.shape[0], 1))
    cloud.points = o3d.utility.Vector3dVector(np.hstack([points, zeros]))  # type: ignore[attr-defined]
    if normals is not None:
        cloud.normals = o3d.utility.Vector3dVector(np.hstack([normals, zeros]))  # type: ignore[attr-defined]
    return cloud


@contextmanager
def _one_thread(o3d: object) -> Iterator[None]:
    """Limit open3d to one thread inside the block (module docstring, "Determinism").

    An open3d without ``set_max_threads`` (older releases parallelised with OpenMP) is left as
    it is: there ``OMP_NUM_THREADS=1`` gives the same guarantee.
    """
    utility = o3d.utility  # type: ignore[attr-defined]
    if not hasattr(utility, "set_max_threads") or utility.get_max_threads() == 1:
        yield  # (changing the limit rebuilds TBB's arena: ~2 ms, so a sequence sets it once)
        return
    previous = utility.get_max_threads()
    utility.set_max_threads(1)
    try:
        yield
    finally:
        utility.set_max_threads(previous)


def _left_to_delta(delta: np.ndarray) -> np.ndarray:
    """Jacobian of the increment's (x, y, theta) w.r.t. a left perturbation (dx, dy, dtheta)
    applied in the previous frame: ``exp(xi) * T`` moves the translation by ``dtheta x t``."""
    return np.array([[1.0, 0.0, -delta[1]], [0.0, 1.0, delta[0]], [0.0, 0.0, 1.0]])


def match_scans(
    source: np.ndarray,
    target: np.ndarray,
    guess: np.ndarray,
    config: LaserOdometryConfig,
    target_normals: np.ndarray | None = None,
) -> ScanMatch:
    """Register the ``source`` scan (new frame) to ``target`` (previous frame) by ICP.

    Args:
        source: (M, 2) points of the new scan in its own frame [m].
        target: (K, 2) points in the previous frame [m] (a scan or a submap).
        guess: (3,) initial increment (the wheel odometry's).
        config: thresholds (module docstring).
        target_normals: (K, 2) the target's normals (default: ``normals_2d``).

    Returns:
        The ScanMatch (``delta`` = ``guess`` when rejected).
    """
    guess = np.asarray(guess, dtype=float)
    if source.shape[0] < config.min_points or target.shape[0] < config.min_points:
        return ScanMatch(guess, None, 0.0, float("nan"), 0.0, Reason.TOO_FEW_POINTS)
    o3d = require("open3d")
    registration = o3d.pipelines.registration
    normals = target_normals if target_normals is not None else normals_2d(
        target, config.normal_neighbours)
    src, tgt = _cloud(o3d, source), _cloud(o3d, target, normals)
    transform = se2_to_matrix(guess)
    init = np.eye(4)
    init[:2, :2], init[:2, 3] = transform[:2, :2], transform[:2, 2]
    result = None
    with _one_thread(o3d):  # bit-reproducible sums (module docstring)
        for distance in config.correspondence_distances_m:  # coarse to fine
            result = registration.registration_icp(
                src, tgt, distance, init,
                registration.TransformationEstimationPointToPlane(),
                registration.ICPConvergenceCriteria(max_iteration=config.max_iterations),
            )
            init = np.asarray(result.transformation)
    assert result is not None
    T = np.asarray(result.transformation)
    planar = np.eye(3)
    planar[:2, :2], planar[:2, 2] = T[:2, :2], T[:2, 3]
    delta = se2_from_matrix(planar)
    fitness = float(result.fitness)
    pairs = np.asarray(result.correspondence_set)
    if pairs.shape[0] < config.min_points:
        return ScanMatch(guess, None, fitness, float("nan"), 0.0, Reason.POOR_FIT)
    q = (planar[:2, :2] @ source[pairs[:, 0]].T).T + planar[:2, 2]
    n = normals[pairs[:, 1]]
    # point-to-line residuals (open3d's inlier_rmse is point-to-point: the beam spacing)
    rmse = float(np.sqrt(np.mean(np.sum(n * (q - target[pairs[:, 1]]), axis=1) ** 2)))
    J = np.column_stack([n, n[:, 1] * q[:, 0] - n[:, 0] * q[:, 1]])  # n^T [I, perp(q)]
    H = J.T @ J
    info_t = float(np.linalg.eigvalsh(H[:2, :2])[0]) / pairs.shape[0]
    if fitness < config.min_fitness or rmse > config.max_rmse_m:
        return ScanMatch(guess, None, fitness, rmse, info_t, Reason.POOR_FIT)
    sigma = max(rmse, config.sigma_floor_m)
    information = H / (sigma**2 * config.covariance_inflation)  # left perturbation
    reason = Reason.ACCEPTED
    travelled = float(np.hypot(guess[0], guess[1]))
    if info_t < config.min_translation_information:
        # along the least constrained direction v the ICP did not move the guess: keep the
        # odometry's translation there, with the odometry's uncertainty as its information
        reason = Reason.DEGENERATE
        v = np.linalg.eigh(H[:2, :2])[1][:, 0]
        delta = delta.copy()
        delta[:2] += v * float(v @ (guess[:2] - delta[:2]))
        sigma_along = config.degenerate_sigma_m + config.degenerate_sigma_fraction * travelled
        keep = np.eye(3)
        keep[:2, :2] -= np.outer(v, v)  # what the ICP's Hessian says along v is noise: drop it
        information = keep @ information @ keep
        information[:2, :2] += np.outer(v, v) / sigma_along**2
    diff = delta - guess
    if (
        np.hypot(diff[0], diff[1])
        > config.gate_translation_m + config.gate_translation_fraction * travelled
        or abs(float(wrap_angle(diff[2]))) > config.gate_rotation_rad
    ):
        return ScanMatch(guess, None, fitness, rmse, info_t, Reason.DISAGREES_WITH_ODOMETRY)
    A = _left_to_delta(delta)
    floor = (
        np.asarray(config.min_sigma)
        + travelled * np.asarray(config.sigma_per_m)
        + abs(float(wrap_angle(guess[2]))) * np.asarray(config.sigma_per_rad)
    )
    cov = A @ np.linalg.inv(information) @ A.T + np.diag(np.square(floor))
    return ScanMatch(delta, 0.5 * (cov + cov.T), fitness, rmse, info_t, reason)


@dataclass(frozen=True, slots=True)
class LaserOdometry:
    """The laser odometry of a sequence: one increment per frame (row 0 is zeros).

    Attributes:
        deltas: (N, 3) increments (accepted matches; the wheel odometry elsewhere).
        covariances: (N, 3, 3) their covariances (NaN where the wheel odometry is kept and
            the data states no covariance for it).
        accepted: (N,) True where the match was accepted.
        reasons: (N,) the ``Reason`` value of each frame ("" for frame 0 and frames without
            a scan).
    """

    deltas: np.ndarray
    covariances: np.ndarray
    accepted: np.ndarray
    reasons: tuple[str, ...]


def laser_odometry(
    angles_rad: np.ndarray,
    ranges_m: np.ndarray,
    max_range_m: float,
    odometry_r: np.ndarray,
    config: LaserOdometryConfig,
    odometry_covariance_r: np.ndarray | None = None,
) -> LaserOdometry:
    """Register every scan to its predecessor (or the submap of the last ``submap_scans``).

    Args:
        angles_rad: (B,) beam angles.
        ranges_m: (N, B) ranges (a row of NaN: no scan in that frame; the wheel odometry
            carries the chain over it).
        max_range_m: the sensor's maximum range.
        odometry_r: (N, 3) wheel odometry (row i: frame i-1 -> i).
        config: thresholds.
        odometry_covariance_r: (N, 3, 3) the wheel odometry's stated covariance, or None.

    Returns:
        The LaserOdometry.
    """
    n = odometry_r.shape[0]
    deltas = np.array(odometry_r, dtype=float, copy=True)
    covs = np.full((n, 3, 3), np.nan)
    if odometry_covariance_r is not None:
        covs[:] = odometry_covariance_r
    accepted = np.zeros(n, dtype=bool)
    reasons = [""] * n
    # submap: (pose of the scan in the chain, its points), the newest last
    history: list[tuple[np.ndarray, np.ndarray]] = []  # (chain pose, points in the chain frame)
    pose = np.zeros(3)  # laser-odometry chain pose of the previous scanned frame
    pending = np.zeros(3)  # wheel motion since the previous scanned frame
    skipped = 0  # frames without a scan since then
    with _one_thread(require("open3d")):  # once for the whole chain (_one_thread)
        for i in range(n):
            if i > 0:
                pending = se2_compose(pending, odometry_r[i])
            if np.all(np.isnan(ranges_m[i])):
                skipped += 1
                continue
            points = scan_points(angles_rad, ranges_m[i], max_range_m, config)
            if history and i > 0:
                previous_pose = history[-1][0]
                world = np.concatenate([pts for _, pts in history[-config.submap_scans:]])
                target = se2_transform_points(se2_inverse(previous_pose), world)
                if config.submap_radius_m is not None:
                    target = target[np.hypot(target[:, 0], target[:, 1]) <= config.submap_radius_m]
                if config.submap_voxel_m > 0 and len(history) > 1:
                    target = _voxel(target, config.submap_voxel_m)
                match = match_scans(points, target, pending, config)
                reasons[i] = match.reason.value
                if match.accepted and skipped == 0:  # one frame's increment, not several
                    deltas[i], covs[i], accepted[i] = match.delta, match.covariance, True
                step = match.delta if match.accepted else pending
                pose = se2_compose(previous_pose, step)
            history.append((pose.copy(), se2_transform_points(pose, points)))
            del history[: -max(config.submap_scans, 1)]
            pending = np.zeros(3)
            skipped = 0
    return LaserOdometry(deltas, covs, accepted, tuple(reasons))


def _voxel(points: np.ndarray, size_m: float) -> np.ndarray:
    """One point per occupied ``size_m`` cell, the mean of the cell's points (open3d's
    ``voxel_down_sample`` on the points at z = 0; its grid starts at the points' lower bound)."""
    o3d = require("open3d")
    with _one_thread(o3d):
        thinned = _cloud(o3d, points).voxel_down_sample(size_m)  # type: ignore[attr-defined]
    return np.asarray(thinned.points)[:, :2]
