"""Geometric verification of matches on the sphere: RANSAC essential matrix on bearing vectors.

A catadioptric camera with a single viewpoint is a calibrated central camera, so two images
are related by the essential matrix acting on **unit bearing vectors**, whatever the mirror:
with ``f1``, ``f2`` the bearings of one world point in viewpoint frames 1 and 2, and
``(R, t)`` the pose of viewpoint 2 in frame 1 (``lambda1 f1 = t + lambda2 R f2``),

    f1^T E f2 = 0,        E = [t]_x R                                   (Hartley & Zisserman 9.6)

Unlike ``cv2.findEssentialMat`` nothing assumes a pinhole or points in front of an image
plane: bearings cover the whole sphere. The residual is the **angular epipolar error**, the
angle between a bearing and the epipolar plane of its partner, ``asin(|f1^T E f2| / |E f2|)``
(and symmetrically with ``E^T f1``); the larger of the two is used.

Hypotheses come from the linear 8-point algorithm on unit vectors (already well conditioned;
no Hartley normalisation is needed) projected onto the essential manifold, drawn in batches
and scored together. The odometry prior (the robot's planar motion between the two images and
the mount of the viewpoint on the robot) **seeds** RANSAC (its own E is the first hypothesis),
**guides** the sampling (samples are drawn from matches that roughly agree with it) and
**guards** the result (a model whose rotation disagrees with odometry is refused). When the
baseline is too small for epipolar geometry, the pure-rotation model ``f1 = R f2`` is
verified instead (2-point Kabsch hypotheses).
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

import numpy as np

from omnislam.frontend.config import VerificationConfig

#: minimum sample of the linear essential-matrix solver
SAMPLE_ESSENTIAL = 8
#: minimum sample of the linear planar-motion essential-matrix solver
SAMPLE_PLANAR = 3
#: minimum sample of the rotation solver
SAMPLE_ROTATION = 2
#: hypotheses drawn and scored together
BATCH = 16
#: pure-rotation mode tolerates the parallax of points at least this far away [m]
NEAR_DEPTH_M = 1.0
#: matches whose error under the prior exceeds this are not sampled (still scored) [rad]
PRIOR_GATE_RAD = 0.06
#: ``beyond_the_floor`` shortens the odometry's baseline by this fraction (its distance error
#: over a few images is ~1 %, the synthetic robot's wheel scale 1 %)
FLOOR_BASELINE_SLACK = 0.1


def skew(v: np.ndarray) -> np.ndarray:
    """(3, 3) cross-product matrix ``[v]_x``."""
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def rotation_angle(R: np.ndarray) -> float:
    """Angle of a rotation matrix [rad]."""
    return float(math.acos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)))


@dataclass(frozen=True, slots=True)
class RelativePose:
    """Pose of viewpoint 2 in viewpoint frame 1: ``p_1 = R p_2 + t``.

    Attributes:
        R: (3, 3) rotation.
        t: (3,) translation [m] (unit length when estimated from images: scale is unknown).
    """

    R: np.ndarray
    t: np.ndarray

    @classmethod
    def from_planar_motion(cls, delta_r: np.ndarray, viewpoint_r: np.ndarray) -> RelativePose:
        """The viewpoint motion implied by a planar robot motion.

        Args:
            delta_r: (3,) [dx, dy, dtheta] of robot pose 2 in robot frame 1 [m, m, rad].
            viewpoint_r: (3,) the camera viewpoint in the robot frame [m] (the viewpoint frame
                is the robot frame translated to it).
        """
        dx, dy, dth = (float(x) for x in delta_r)
        c, s = math.cos(dth), math.sin(dth)
        R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        v = np.asarray(viewpoint_r, dtype=float)
        return cls(R, R @ v + np.array([dx, dy, 0.0]) - v)

    @property
    def baseline_m(self) -> float:
        return float(np.linalg.norm(self.t))

    def essential(self) -> np.ndarray:
        """(3, 3) ``E = [t]_x R`` (``f1^T E f2 = 0``)."""
        return skew(self.t) @ self.R


class ModelKind(enum.Enum):
    """Which two-view model verified the matches."""

    ESSENTIAL = "essential"
    ROTATION = "rotation"  # baseline below min_baseline_m
    NONE = "none"  # too few matches, or verification disabled


@dataclass(frozen=True, slots=True)
class VerificationResult:
    """Outcome of RANSAC.

    Attributes:
        inliers: (N,) bool.
        kind: the model used.
        pose: the estimated relative pose (t unit; zero for rotation-only), or None.
        iterations: hypotheses drawn.
    """

    inliers: np.ndarray
    kind: ModelKind
    pose: RelativePose | None
    iterations: int

    @property
    def n_inliers(self) -> int:
        return int(self.inliers.sum())


# --- models ---------------------------------------------------------------------------------
def epipolar_errors(E: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
    """Angular epipolar error of bearing pairs under one or many essential matrices.

    Args:
        E: (3, 3) or (M, 3, 3) essential matrices (``f1^T E f2 = 0``).
        f1: (N, 3) unit bearings in frame 1.
        f2: (N, 3) unit bearings in frame 2.

    Returns:
        (N,) or (M, N) ``asin(|f1^T E f2| / min(|E f2|, |E^T f1|))`` [rad]: the larger of the
        two angles between a bearing and its partner's epipolar plane.
    """
    single = E.ndim == 2
    Es = E[None] if single else E
    n1 = np.einsum("mij,nj->mni", Es, f2)  # epipolar plane normals in frame 1
    n2 = np.einsum("mji,nj->mni", Es, f1)  # ... in frame 2
    algebraic = np.abs(np.einsum("ni,mni->mn", f1, n1))
    scale = np.minimum(np.linalg.norm(n1, axis=2), np.linalg.norm(n2, axis=2))
    with np.errstate(divide="ignore", invalid="ignore"):
        sine = np.where(scale > 1e-12, algebraic / scale, 0.0)
    err = np.arcsin(np.clip(sine, 0.0, 1.0))
    return err[0] if single else err


def essential_from_bearings(f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
    """Linear 8-point essential matrices from bearing pairs (batched).

    Solves ``A e = 0`` with rows ``kron(f1, f2)`` in the least-squares sense (smallest right
    singular vector) and projects onto the essential manifold (singular values (1, 1, 0)).

    Args:
        f1: (N, 3) or (M, N, 3) bearings in frame 1, N >= 8.
        f2: same shape, frame 2.

    Returns:
        (3, 3) or (M, 3, 3) essential matrices of unit Frobenius norm / sqrt(2).
    """
    single = f1.ndim == 2
    a = f1[None] if single else f1
    b = f2[None] if single else f2
    A = (a[:, :, :, None] * b[:, :, None, :]).reshape(a.shape[0], a.shape[1], 9)
    if A.shape[1] > 9:  # least squares via the 9 x 9 normal matrix (cheaper for many rows)
        _, vecs = np.linalg.eigh(np.swapaxes(A, 1, 2) @ A)
        e = vecs[:, :, 0]
    else:
        _, _, Vt = np.linalg.svd(A, full_matrices=True)
        e = Vt[:, -1, :]
    E = e.reshape(-1, 3, 3)
    U, _, Vt = np.linalg.svd(E)
    E = U @ np.diag([1.0, 1.0, 0.0]) @ Vt
    return E[0] if single else E


def planar_essential_from_bearings(f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
    """Linear essential matrices of planar motion from bearing pairs (batched).

    When both viewpoints move on a horizontal plane and turn about the vertical (a camera on a
    wheeled robot: ``t = (tx, ty, 0)``, ``R = Rz(theta)``), ``E = [t]_x R`` has the form
    ``[[0, 0, a], [0, 0, b], [c, d, 0]]`` with ``(a, b) = (ty, -tx)`` and
    ``|(c, d)| = |(a, b)|``: 2 degrees of freedom up to scale, so 3 bearing pairs give a linear
    solution (``f1^T E f2 = a f1x f2z + b f1y f2z + c f1z f2x + d f1z f2y = 0``) where the
    general case needs 8. The least-squares ``(a, b, c, d)`` is projected onto the manifold by
    giving both halves their mean norm (the nearest such matrix).

    Args:
        f1: (N, 3) or (M, N, 3) bearings in frame 1, N >= 3.
        f2: same shape, frame 2.

    Returns:
        (3, 3) or (M, 3, 3) essential matrices.
    """
    single = f1.ndim == 2
    a = f1[None] if single else f1
    b = f2[None] if single else f2
    A = np.stack([a[..., 0] * b[..., 2], a[..., 1] * b[..., 2], a[..., 2] * b[..., 0],
                  a[..., 2] * b[..., 1]], axis=-1)
    if A.shape[1] > 4:
        _, vecs = np.linalg.eigh(np.swapaxes(A, 1, 2) @ A)
        e = vecs[:, :, 0]
    else:
        _, _, Vt = np.linalg.svd(A, full_matrices=True)
        e = Vt[:, -1, :]
    n1 = np.linalg.norm(e[:, :2], axis=1, keepdims=True)
    n2 = np.linalg.norm(e[:, 2:], axis=1, keepdims=True)
    mean = 0.5 * (n1 + n2)
    e = np.concatenate([e[:, :2] * mean / np.maximum(n1, 1e-300),
                        e[:, 2:] * mean / np.maximum(n2, 1e-300)], axis=1)
    E = np.zeros((e.shape[0], 3, 3))
    E[:, 0, 2], E[:, 1, 2], E[:, 2, 0], E[:, 2, 1] = e.T
    return E[0] if single else E


def planar_rotation_angle(E: np.ndarray) -> float:
    """The turn ``theta`` of a planar-motion essential matrix (the sign of E does not matter).

    From ``(c, d) = -[[a, b], [b, -a]] (cos theta, sin theta)`` with ``(a, b, c, d)`` as in
    ``planar_essential_from_bearings``.
    """
    a, b, c, d = E[0, 2], E[1, 2], E[2, 0], E[2, 1]
    return float(math.atan2(a * d - b * c, -(a * c + b * d)))


def decompose_planar_essential(E: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> RelativePose:
    """The planar (R, t) of a planar-motion essential matrix, t's sign by cheirality.

    Args:
        E: (3, 3) from ``planar_essential_from_bearings``.
        f1: (N, 3) inlier bearings in viewpoint 1, for the cheirality test.
        f2: (N, 3) inlier bearings in viewpoint 2, for the cheirality test.

    Returns:
        The relative pose with unit ``t`` (horizontal) and ``R = Rz(theta)``.
    """
    theta = planar_rotation_angle(E)
    c, s = math.cos(theta), math.sin(theta)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    t = np.array([-E[1, 2], E[0, 2], 0.0])
    t /= max(float(np.linalg.norm(t)), 1e-300)
    front = [int(np.sum(np.all(_depths(R, sign * t, f1, f2) > 0, axis=1))) for sign in (1, -1)]
    return RelativePose(R, t if front[0] >= front[1] else -t)


def _depths(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
    """(N, 2) depths ``(lambda1, lambda2)`` solving ``lambda1 f1 - lambda2 R f2 = t`` (LSQ)."""
    g = f2 @ R.T
    # normal equations of the 3 x 2 system [f1, -g] [l1, l2]^T = t, per point
    a11 = np.ones(f1.shape[0])
    a12 = -np.sum(f1 * g, axis=1)
    a22 = np.ones(f1.shape[0])
    b1 = f1 @ t
    b2 = -(g @ t)
    det = a11 * a22 - a12 * a12
    with np.errstate(divide="ignore", invalid="ignore"):
        l1 = (a22 * b1 - a12 * b2) / det
        l2 = (a11 * b2 - a12 * b1) / det
    return np.column_stack([l1, l2])


def decompose_essential(E: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> RelativePose:
    """The (R, t) of ``E = [t]_x R`` that puts most points in front of both viewpoints.

    Args:
        E: (3, 3) essential matrix.
        f1: (N, 3) inlier bearings in viewpoint 1, for the cheirality test.
        f2: (N, 3) inlier bearings in viewpoint 2, for the cheirality test.

    Returns:
        The relative pose with unit ``t``.
    """
    U, _, Vt = np.linalg.svd(E)
    if np.linalg.det(U) < 0:
        U = -U
    if np.linalg.det(Vt) < 0:
        Vt = -Vt
    W = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    best, best_front = None, -1
    for R in (U @ W @ Vt, U @ W.T @ Vt):
        for t in (U[:, 2], -U[:, 2]):
            depths = _depths(R, t, f1, f2)
            front = int(np.sum(np.all(depths > 0, axis=1)))
            if front > best_front:
                best, best_front = RelativePose(R, t.copy()), front
    assert best is not None
    return best


def rotation_errors(R: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
    """Angle between ``f1`` and ``R f2`` [rad] for one (3, 3) or many (M, 3, 3) rotations."""
    single = R.ndim == 2
    Rs = R[None] if single else R
    cos = np.einsum("ni,mij,nj->mn", f1, Rs, f2)
    err = np.arccos(np.clip(cos, -1.0, 1.0))
    return err[0] if single else err


def rotation_from_bearings(f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
    """Rotations with ``f1 ~ R f2`` (Kabsch / orthogonal Procrustes), batched like the 8-point."""
    single = f1.ndim == 2
    a = f1[None] if single else f1
    b = f2[None] if single else f2
    H = np.swapaxes(b, 1, 2) @ a  # sum f2 f1^T
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(np.swapaxes(Vt, 1, 2) @ np.swapaxes(U, 1, 2)))
    D = np.zeros((a.shape[0], 3, 3))
    D[:, 0, 0] = 1.0
    D[:, 1, 1] = 1.0
    D[:, 2, 2] = d
    R = np.swapaxes(Vt, 1, 2) @ D @ np.swapaxes(U, 1, 2)
    return R[0] if single else R


# --- RANSAC ---------------------------------------------------------------------------------
def _needed_iterations(inlier_ratio: float, sample: int, confidence: float) -> float:
    good = inlier_ratio**sample
    if good <= 0.0:
        return math.inf
    if good >= 1.0:
        return 0.0
    return math.log(1.0 - confidence) / math.log(1.0 - good)


class _Ransac:
    """One verification's model and matches: which model is fitted (rotation alone below the
    minimum baseline, else a planar or general essential matrix), its solver, residual and
    threshold, and the odometry prior that seeds, guides and guards it.

    Args:
        f1, f2: (N, 3) unit bearings of the matches in viewpoint frames 1 and 2.
        prior: the relative pose predicted by odometry, or None.
        config: the verification's configuration.
    """

    def __init__(self, f1: np.ndarray, f2: np.ndarray, prior: RelativePose | None,
                 config: VerificationConfig) -> None:
        self.f1, self.f2, self.prior, self.config = f1, f2, prior, config
        self.rotation_only = prior is not None and prior.baseline_m < config.min_baseline_m
        self.planar = config.planar_motion and not self.rotation_only
        self.sample = (SAMPLE_ROTATION if self.rotation_only
                       else SAMPLE_PLANAR if self.planar else SAMPLE_ESSENTIAL)
        self.seed: np.ndarray | None
        if self.rotation_only:
            assert prior is not None
            # the parallax of points at NEAR_DEPTH_M or further is tolerated
            self.threshold_rad = config.threshold_rad + prior.baseline_m / NEAR_DEPTH_M
            self.solve, self.errors = rotation_from_bearings, rotation_errors
            self.seed = prior.R
        else:
            self.threshold_rad = config.threshold_rad
            self.solve = planar_essential_from_bearings if self.planar else essential_from_bearings
            self.errors = epipolar_errors
            self.seed = prior.essential() if prior is not None else None

    def enough(self, n_inliers: int) -> bool:
        """Whether this many inliers can be accepted."""
        return n_inliers >= max(self.config.min_inliers, self.sample)

    def start(self, guided: bool) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
        """The matches to sample from and the first (model, inliers): the prior's model and
        the matches it explains, and, ``guided``, only the matches near the prior to sample
        from (when enough of them agree with it to be accepted at all: otherwise the prior is
        wrong and the few that agree are chance)."""
        n = self.f1.shape[0]
        pool = np.arange(n)
        if self.seed is None:
            return pool, None, np.zeros(n, dtype=bool)
        seed_err = self.errors(self.seed, self.f1, self.f2)
        agreeing = np.flatnonzero(seed_err < max(PRIOR_GATE_RAD, self.threshold_rad))
        if guided and agreeing.shape[0] >= max(2 * self.sample, self.config.min_inliers):
            pool = agreeing
        return pool, self.seed, seed_err < self.threshold_rad

    def acceptable(self, model: np.ndarray, inliers: np.ndarray) -> bool:
        """Guard: the rotation of the model agrees with the odometry prior."""
        prior, tolerance_rad = self.prior, self.config.prior_rotation_tol_rad
        if prior is None:
            return True
        if self.planar:  # both turns are about the vertical
            turn = planar_rotation_angle(model) - math.atan2(prior.R[1, 0], prior.R[0, 0])
            return abs(math.remainder(turn, 2 * math.pi)) <= tolerance_rad
        if self.rotation_only:
            R = model
        else:
            R = decompose_essential(model, self.f1[inliers], self.f2[inliers]).R
        return rotation_angle(R @ prior.R.T) <= tolerance_rad

    def search(self, pool: np.ndarray, best_model: np.ndarray | None, best_inliers: np.ndarray,
               rng: np.random.Generator) -> tuple[np.ndarray | None, np.ndarray, int]:
        """RANSAC from (best_model, best_inliers): hypotheses from samples of ``pool`` in
        batches of ``BATCH``, the best acceptable one kept, until the confidence is reached or
        ``max_iterations``; returns the best (model, inliers) and the hypotheses drawn."""
        f1, f2, config, sample = self.f1, self.f2, self.config, self.sample
        iterations = 0
        needed = float(config.max_iterations)
        while iterations < min(needed, config.max_iterations):
            keys = rng.random((BATCH, pool.shape[0]))
            picks = pool[np.argpartition(keys, sample - 1, axis=1)[:, :sample]]
            models = self.solve(f1[picks], f2[picks])
            inliers = self.errors(models, f1, f2) < self.threshold_rad
            counts = inliers.sum(axis=1)
            iterations += BATCH
            for m in np.argsort(-counts):
                if counts[m] <= best_inliers.sum():
                    break
                if self.acceptable(models[m], inliers[m]):
                    best_model, best_inliers = models[m], inliers[m]
                    break
            needed = _needed_iterations(best_inliers.sum() / pool.shape[0], sample,
                                        config.confidence)
        return best_model, best_inliers, iterations

    def refit(self, model: np.ndarray, inliers: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Local optimisation: refit on all inliers while the consensus grows (twice at most)
        and the refit stays acceptable."""
        for _ in range(2):
            refit = self.solve(self.f1[inliers], self.f2[inliers])
            refit_inliers = self.errors(refit, self.f1, self.f2) < self.threshold_rad
            if refit_inliers.sum() < inliers.sum() or not self.acceptable(refit, refit_inliers):
                break
            model, inliers = refit, refit_inliers
        return model, inliers

    def result(self, model: np.ndarray, inliers: np.ndarray, iterations: int
               ) -> VerificationResult:
        """The verified matches and the relative pose of their model."""
        if self.rotation_only:
            return VerificationResult(inliers, ModelKind.ROTATION,
                                      RelativePose(model, np.zeros(3)), iterations)
        decompose = decompose_planar_essential if self.planar else decompose_essential
        pose = decompose(model, self.f1[inliers], self.f2[inliers])
        return VerificationResult(inliers, ModelKind.ESSENTIAL, pose, iterations)


def verify_matches(
    f1: np.ndarray,
    f2: np.ndarray,
    prior: RelativePose | None,
    config: VerificationConfig,
    rng: np.random.Generator,
    *,
    guided: bool = True,
) -> VerificationResult:
    """RANSAC on bearing pairs, seeded, guided and guarded by an odometry prior.

    Args:
        f1: (N, 3) unit bearings of the matches in viewpoint frame 1.
        f2: (N, 3) unit bearings in viewpoint frame 2.
        prior: the relative pose predicted by odometry (None: unguided, unchecked).
        config: threshold, confidence, iteration cap, minimum inliers, baseline and
            rotation tolerance.
        rng: random generator (injected for reproducibility).
        guided: False does not restrict the sampling to matches that agree with the prior
            (its model is still scored as one hypothesis, and its rotation still guards):
            for re-recognition after a loop, where dead reckoning may have drifted.

    Returns:
        The inlier mask and the model; all False when fewer than ``config.min_inliers``
        matches agree on one model.
    """
    n = f1.shape[0]
    if not config.enabled:
        return VerificationResult(np.ones(n, dtype=bool), ModelKind.NONE, None, 0)
    ransac = _Ransac(f1, f2, prior, config)
    if not ransac.enough(n):
        return VerificationResult(np.zeros(n, dtype=bool), ModelKind.NONE, None, 0)
    pool, model, inliers = ransac.start(guided)
    model, inliers, iterations = ransac.search(pool, model, inliers, rng)
    if model is None or not ransac.enough(int(inliers.sum())):
        return VerificationResult(np.zeros(n, dtype=bool), ModelKind.NONE, None, iterations)
    model, inliers = ransac.refit(model, inliers)
    return ransac.result(model, inliers, iterations)


def beyond_the_floor(
    f1: np.ndarray, f2: np.ndarray, R: np.ndarray, t: np.ndarray, height_m: float,
    slack_rad: float,
) -> np.ndarray:
    """Bearing pairs that can only meet below the floor: a texture repeating along the motion.

    The epipolar constraint is blind along the epipolar plane, and when the robot drives
    along a tiled floor that plane holds the next tile: a corner matched to the one a tile
    period further on fits ``E`` exactly. Its two rays are then parallel (the robot moved by
    the period too), i.e. they meet at infinity -- below the floor, for rays that point down.

    A point at depth ``lam`` on ray ``f1`` (viewpoint frame 1; the floor at ``z = -h``) is
    seen from viewpoint 2 at ``t`` along ``lam f1 - t``, so its parallax
    ``beta(lam) = angle(f1, lam f1 - t)`` falls monotonically from ``angle(f1, -t)`` at
    ``lam = 0`` to 0 as ``lam -> inf`` (``tan beta = |t_perp| / (lam - f1.t)``). A ray that
    points down meets the floor at ``lam_f = h / -f1_z``, so a point at or above the floor has
    ``beta >= beta(lam_f)``. A pair whose measured parallax ``angle(f1, R f2)`` is smaller
    than that by more than ``slack_rad`` meets beyond the floor and is flagged. The baseline is
    the odometry's, shortened by ``FLOOR_BASELINE_SLACK`` so that the odometry's distance error
    over a few images cannot flag a true floor point; rays within ~0.06 deg of the horizon are
    never flagged.

    Args:
        f1: (N, 3) unit bearings in viewpoint frame 1.
        f2: (N, 3) unit bearings of the same matches in viewpoint frame 2.
        R: (3, 3) rotation of frame 2 in frame 1 (the verified model's).
        t: (3,) viewpoint 2 in frame 1 [m] (metric: the odometry's).
        height_m: the viewpoint's height above the floor [m] (> 0).
        slack_rad: tolerance of the measured parallax (its noise and the rotation's error).

    Returns:
        (N,) bool: True where the pair meets below the floor.
    """
    flagged = np.zeros(f1.shape[0], dtype=bool)
    down = np.flatnonzero(f1[:, 2] < -1e-3)
    if down.shape[0] == 0 or not height_m > 0:
        return flagged
    a = f1[down]
    to_floor = (height_m / -a[:, 2])[:, None] * a - (1.0 - FLOOR_BASELINE_SLACK) * np.asarray(t)
    cos_floor = np.sum(a * to_floor, axis=1) / np.linalg.norm(to_floor, axis=1)
    cos_measured = np.sum(a * (f2[down] @ np.asarray(R).T), axis=1)
    floor = np.arccos(np.clip(cos_floor, -1.0, 1.0))
    measured = np.arccos(np.clip(cos_measured, -1.0, 1.0))
    flagged[down] = measured < floor - slack_rad
    return flagged
