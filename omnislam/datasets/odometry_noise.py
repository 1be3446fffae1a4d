"""The odometry noise of a recorded run: a maximum-likelihood fit of the thesis's alphas.

One procedure for every dataset with ground truth (Guizilini 2008, eqs. 4.39-4.41, as
``core.motion`` implements them; the same model every estimator samples or linearises):

1. **Data.** The first ``fraction`` (a quarter) of the recording, by time. Frames with ground
   truth split it into **windows**: consecutive, non-overlapping runs of odometry steps between
   two such frames. A window's residual compares the odometry composed over it with the ground
   truth's motion over it.
2. **Windows long enough for the ground truth's own noise to be small.** A window closes at the
   first frame with ground truth where the ground truth's stated per-sample noise accounts for at
   most ``max_ground_truth_share`` (10 %) of the window's predicted residual variance, in every
   compared component (x, y and heading in the window's start frame), and not before it lasts
   ``min_window_s`` (1 s; ``FitConfig.size_window_s`` says why). The prediction needs
   alphas: the windows are chosen under a pilot (the project's default ``MotionNoise``), the
   alphas fitted, the windows chosen again under the fit, until the windows stop changing
   (``max_rounds``). A robot standing still adds no odometry variance: its window runs on.
3. **Model of a window's residual.** Each step's components (rot1, trans, rot2) of the
   measured odometry get independent Gaussian errors with the stds of eq. 4.41
   (``OdometryMotionModel.component_sigmas``: linear in the alphas; the components' sizes
   averaged over 2 s, ``component_sizes``), mapped to the step's
   [dx, dy, dtheta] by the Jacobian of eq. 4.44 (``OdometryMotionModel.apply_jacobians``) and
   carried to the window's end by the first-order composition of SE(2) (``compose_odometry``'s
   Jacobians, written for all steps at once). The window's covariance is therefore a quadratic
   form in the alphas, ``C = sum_ij a_i a_j Q_ij + C_0``, with ``C_0`` the ground truth's noise
   and a micrometre / microradian floor per step (``step_floor``; it keeps a window of pure
   rotation positive definite, as ``OdometryMotionModel.covariance``'s floor does).
4. **Residuals.** With the ground truth's heading (motion capture, corrected poses, synthetic):
   the ground truth's relative pose minus the odometry's, in the window's start frame. Without it
   (GPS): the *shape* of three consecutive ground-truth positions -- the first chord's length,
   and the second chord along and across the first -- against the shape the odometry predicts
   for two consecutive windows (pairs of windows do not overlap); rotation and translation of
   the GPS frame drop out, and a heading error over the first window shows in the across term.
   The GPS antenna may sit off the odometry's point (``lever_arm_m`` in the robot frame).
5. **Maximum likelihood** over the four alphas (bounded below by 0; ``scipy``'s L-BFGS-B with
   the analytic gradient), **standard errors** from the inverse of the expected Fisher
   information ``I_ij = 1/2 sum_w tr(C^-1 dC/da_i C^-1 dC/da_j)``, and **residual statistics**
   under the fit: per component, the mean and std of the residual divided by its predicted std
   (0 and 1 when the model fits), and the mean squared Mahalanobis distance (3 expected) with the
   fraction of windows beyond the chi-square(3) 99 % quantile (1 % expected).

Two things the procedure does not do: it does not reject outliers (a slip or a bump shows in the
residual statistics instead), and it fits the alphas of the dataset's own odometry step: eq. 4.41
is not step-size invariant (``MotionNoise.reference_step_m``), so alphas of data stepping at
10 Hz and at 1 Hz are not comparable unless fitted with a reference step.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize, stats

from omnislam.core.jacobian import numerical_jacobian
from omnislam.core.motion import MotionNoise, OdometryMotionModel, compose_odometry
from omnislam.core.se import se2_between, se2_compose, se2_integrate, wrap_angle
from omnislam.datasets.sequence import Sequence
from omnislam.errors import ConfigError, DataError

#: the alphas in the order of every array here (``MotionNoise`` field names)
ALPHAS = ("a_vv", "a_vw", "a_wv", "a_ww")
#: the residual's components (windows with ground-truth heading, and GPS shapes)
POSE_COMPONENTS = ("x", "y", "theta")
SHAPE_COMPONENTS = ("chord", "along", "across")
#: 90 deg rotation: d/dtheta R(theta) = J R(theta)
_J = np.array([[0.0, -1.0], [1.0, 0.0]])


@dataclass(frozen=True, slots=True)
class GroundTruthNoise:
    """The per-sample noise of a ground truth.

    Attributes:
        sigma_position_m: std of each position coordinate [m].
        sigma_heading_rad: std of the heading [rad]; None when the ground truth has no heading
            (GPS): windows are then compared by their shapes (module docstring, step 4).
        source: how the numbers were obtained, one line for the report.
    """

    sigma_position_m: float
    sigma_heading_rad: float | None
    source: str

    def __post_init__(self) -> None:
        heading = 0.0 if self.sigma_heading_rad is None else self.sigma_heading_rad
        if not (self.sigma_position_m >= 0 and heading >= 0):
            raise ConfigError(f"ground-truth noise must be non-negative: {self}")


@dataclass(frozen=True, slots=True)
class FitConfig:
    """How the alphas are fitted (module docstring).

    Attributes:
        fraction: the leading fraction of the recording used, by time (0.25: the first quarter,
            leaving the rest for evaluation).
        max_ground_truth_share: a window closes once the ground truth's noise is at most this
            share of its predicted residual variance in every component (0.1).
        pilot: the alphas the first windows are chosen under (the project's default).
        max_rounds: window choices at most (each after a fit); 4 is ample: they settle in 2-3.
        step_floor: stds added per step to x, y [m] and heading [rad] (1e-6 each: only to keep
            a window of pure rotation positive definite; ``MotionNoise.min_sigma``'s 1e-4 m
            would be 1e-8 m^2 per step, a third of the lateral variance of a straight 5 cm
            step under the thesis presets' alphas).
        reference_step_m: fit the alphas of ``MotionNoise.reference_step_m`` = this step (None:
            of eq. 4.41 for every step, as the estimators use them by default).
        lever_arm_m: where the ground truth's point sits in the robot frame [m] (a GPS antenna
            off the odometry's point; positions-only ground truth).
        min_window_s: a window lasts at least this long [s] (1: ten steps at 10 Hz; see
            ``size_window_s``).
        size_window_s: the steps' component sizes for eq. 4.41 are their rates averaged over
            this window [s] (``component_sizes``). With 2 s and windows of at least 1 s the fit
            recovers simulated alphas within their standard errors (rms z 0.5-1.2 over 8 runs,
            ``tests/datasets/test_odometry_noise.py``); with each step's own components and
            one-step windows ``a_vw`` came out 5-7 standard errors low and ``a_ww`` high.
    """

    fraction: float = 0.25
    max_ground_truth_share: float = 0.1
    pilot: MotionNoise = field(default_factory=MotionNoise)
    max_rounds: int = 4
    step_floor: tuple[float, float, float] = (1e-6, 1e-6, 1e-6)
    reference_step_m: float | None = None
    lever_arm_m: tuple[float, float] = (0.0, 0.0)
    min_window_s: float = 1.0
    size_window_s: float = 2.0

    def __post_init__(self) -> None:
        if not 0 < self.fraction <= 1 or not 0 < self.max_ground_truth_share < 1:
            raise ConfigError(f"fraction in (0, 1] and share in (0, 1) required: {self}")
        if self.max_rounds < 1 or min(self.step_floor) <= 0:
            raise ConfigError(f"max_rounds >= 1 and positive floors required: {self}")


@dataclass(frozen=True, slots=True)
class ResidualStatistics:
    """How the residuals look under the fitted model.

    Attributes:
        components: the names of the residual's components.
        mean: (3,) mean of each component divided by its predicted std (0 expected).
        std: (3,) std of the same (1 expected).
        nees_mean: mean squared Mahalanobis distance of the windows (3 expected).
        beyond_99: fraction of windows beyond the chi-square(3) 99 % quantile (0.01 expected).
    """

    components: tuple[str, ...]
    mean: np.ndarray
    std: np.ndarray
    nees_mean: float
    beyond_99: float


@dataclass(frozen=True, slots=True)
class OdometryNoiseFit:
    """The fitted odometry noise of one dataset.

    Attributes:
        noise: the fitted alphas (``FitConfig.reference_step_m`` and the pilot's floors).
        standard_errors: (4,) standard errors of ``ALPHAS`` (inverse Fisher information).
        log_likelihood: the maximum.
        windows: number of residuals (windows; pairs of windows for GPS shapes).
        window_length_m: median distance the odometry travelled in a window [m].
        window_duration_s: median duration of a window [s].
        window_steps: median number of odometry steps in a window.
        ground_truth_share: (3,) median share of the ground truth's noise in each component's
            predicted residual variance under the fit.
        residuals: residual statistics under the fit.
        ground_truth: the ground truth's noise used.
        span_s: (start, end) of the data used [s].
        rounds: window choices made.
    """

    noise: MotionNoise
    standard_errors: np.ndarray
    log_likelihood: float
    windows: int
    window_length_m: float
    window_duration_s: float
    window_steps: float
    ground_truth_share: np.ndarray
    residuals: ResidualStatistics
    ground_truth: GroundTruthNoise
    span_s: tuple[float, float]
    rounds: int

    @property
    def alphas(self) -> np.ndarray:
        """(4,) the fitted ``ALPHAS``."""
        return np.array([getattr(self.noise, name) for name in ALPHAS])


@dataclass(frozen=True, slots=True)
class Residuals:
    """Residuals whose covariance is a quadratic form in the alphas (module docstring, step 3).

    Attributes:
        r: (W, 3) residuals.
        Q: (W, 4, 4, 3, 3) ``C = sum_ij a_i a_j Q[:, i, j] + C0`` (symmetric in i, j).
        C0: (W, 3, 3) the alpha-free part: ground-truth noise and step floors.
        C_gt: (W, 3, 3) the ground truth's part of ``C0``.
        components: names of the 3 components.
    """

    r: np.ndarray
    Q: np.ndarray
    C0: np.ndarray
    C_gt: np.ndarray
    components: tuple[str, ...]

    def covariance(self, alphas: np.ndarray) -> np.ndarray:
        """(W, 3, 3) predicted covariance of every residual under ``alphas`` (4,)."""
        return np.einsum("wijab,i,j->wab", self.Q, alphas, alphas) + self.C0


# --- one window's odometry covariance ---------------------------------------------------------
def component_sizes(odometry_r: np.ndarray, stamps_s: np.ndarray, window_s: float
                    ) -> np.ndarray:
    """(N, 3) the size of each step's (rot1, trans, rot2) that eq. 4.41 scales the stds by.

    A measured component is the true one plus its error, and where the true one is near zero
    (rot1 and rot2 of a straight step) its magnitude is mostly the error itself: stds taken from
    it grow with the very errors they describe, and a fit turns ``a_vw`` into ``a_ww``. The size
    of a step's component is therefore its rate averaged over the ``window_s`` centred on the
    step (the truth changes slowly at the odometry's rate, the errors from step to step), times
    the step's duration; 0 takes each step's own components.

    Args:
        odometry_r: (N, 3) measured steps (row k: from frame k-1 to frame k).
        stamps_s: (N,) frame stamps [s].
        window_s: length of the averaging window [s].
    """
    components = OdometryMotionModel().decompose(odometry_r).reshape(-1, 3)
    components[0] = 0.0
    if window_s <= 0:
        return np.abs(components)
    dt = np.diff(stamps_s, prepend=stamps_s[0])
    summed = np.vstack([np.zeros(3), np.cumsum(components, axis=0)])
    time = np.concatenate([[0.0], np.cumsum(dt)])
    middle = stamps_s - dt / 2  # the middle of each step's interval
    lo = np.searchsorted(stamps_s, middle - window_s / 2, side="left")
    hi = np.searchsorted(stamps_s, middle + window_s / 2, side="right")
    hi = np.maximum(hi, np.arange(len(stamps_s)) + 1)  # at least the step itself
    lo = np.minimum(lo, np.arange(len(stamps_s)))
    span = time[hi] - time[lo]
    rate = (summed[hi] - summed[lo]) / np.where(span > 0, span, 1.0)[:, None]
    sizes = np.abs(np.where(span[:, None] > 0, rate * dt[:, None], components))
    sizes[0] = 0.0
    return sizes


def step_terms(components: np.ndarray, sizes: np.ndarray, reference_step_m: float | None = None
               ) -> tuple[np.ndarray, np.ndarray]:
    """Per-step linear maps of eqs. 4.41 and 4.44.

    Args:
        components: (K, 3) measured (rot1, trans, rot2) of each step (eq. 4.39).
        sizes: (K, 3) their sizes for eq. 4.41 (``component_sizes``).
        reference_step_m: ``MotionNoise.reference_step_m`` of the alphas fitted.

    Returns:
        (A (K, 3, 4), V (K, 3, 3)): the component stds are ``A @ alphas`` (``component_sigmas``
        of each unit alpha: the project's eq. 4.41, linear in the alphas), and ``V`` maps
        component errors to the step's [dx, dy, dtheta] (``apply_jacobians`` at the origin).
    """
    A = np.empty((components.shape[0], 3, len(ALPHAS)))
    for i, name in enumerate(ALPHAS):
        unit = MotionNoise(**{a: float(a == name) for a in ALPHAS}, min_sigma=(0.0, 0.0, 0.0),
                           reference_step_m=reference_step_m)
        A[:, :, i] = OdometryMotionModel(unit).component_sigmas(sizes)
    _, V = OdometryMotionModel().apply_jacobians(np.zeros(3), components)
    return A, V


def window_quadratic_forms(
    odometry_r: np.ndarray, sizes: np.ndarray, bounds: np.ndarray,
    step_floor: tuple[float, float, float], reference_step_m: float | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The odometry composed over each window and its covariance as a quadratic form.

    A step k of window [s, e] perturbed by d (additive on its [dx, dy, dtheta]) moves the
    window's composed motion T by ``G_k d`` with ``G_k = [[R(phi_{k-1}), J (T - P_k)], [0, 1]]``
    (``P_k`` the composed motion up to step k, ``phi`` its heading; the first-order composition
    of ``compose_odometry`` unrolled over the window).

    Args:
        odometry_r: (N, 3) measured steps (row k: from frame k-1 to frame k).
        sizes: (N, 3) the steps' component sizes for eq. 4.41 (``component_sizes``).
        bounds: (W, 2) window start and end frames, s < e (steps s+1..e).
        step_floor: stds added per step to x, y [m] and heading [rad].
        reference_step_m: see ``step_terms``.

    Returns:
        (T (W, 3) the composed odometry, Q (W, 4, 4, 3, 3), F (W, 3, 3) the floors' part).
    """
    bounds = np.asarray(bounds, dtype=np.int64).reshape(-1, 2)
    X = se2_integrate(odometry_r)
    counts = bounds[:, 1] - bounds[:, 0]
    steps = np.concatenate([np.arange(s + 1, e + 1) for s, e in bounds])
    window = np.repeat(np.arange(len(bounds)), counts)
    start, end = X[bounds[window, 0]], X[bounds[window, 1]]
    phi = X[steps - 1, 2] - start[:, 2]
    c, s = np.cos(phi), np.sin(phi)
    G = np.zeros((steps.size, 3, 3))
    G[:, 0, 0], G[:, 0, 1], G[:, 1, 0], G[:, 1, 1] = c, -s, s, c
    c0, s0 = np.cos(start[:, 2]), np.sin(start[:, 2])
    dx, dy = end[:, 0] - X[steps, 0], end[:, 1] - X[steps, 1]
    lever = np.stack([c0 * dx + s0 * dy, -s0 * dx + c0 * dy], axis=-1)  # R(-th_s) (X_e - X_k)
    G[:, :2, 2] = lever @ _J.T
    G[:, 2, 2] = 1.0
    components = OdometryMotionModel().decompose(odometry_r[steps]).reshape(-1, 3)
    A, V = step_terms(components, sizes[steps], reference_step_m)
    B = G @ V
    per_step = np.einsum("kci,kcj,kac,kbc->kijab", A, A, B, B)
    firsts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    Q = np.add.reduceat(per_step, firsts, axis=0)
    floor = np.diag(np.square(step_floor))
    F = np.add.reduceat(G @ floor @ np.swapaxes(G, 1, 2), firsts, axis=0)
    return se2_between(X[bounds[:, 0]], X[bounds[:, 1]]), Q, F


# --- windows ------------------------------------------------------------------------------
def pose_ground_truth_covariance(t_r: np.ndarray, gt: GroundTruthNoise) -> np.ndarray:
    """(..., 3, 3) covariance of the ground truth's relative motion ``t_r`` (..., 3) from its
    per-sample noise: ``between(G_a, G_b)`` moves by ``R(-th_a)(e_b - e_a) - n_a J t`` in x, y
    and by ``n_b - n_a`` in heading (e position errors, n heading errors). Without a heading
    (GPS) only the positions' part, in x and y."""
    t_r = np.asarray(t_r, dtype=float)
    C = np.zeros((*t_r.shape[:-1], 3, 3))
    C[..., 0, 0] = C[..., 1, 1] = 2.0 * gt.sigma_position_m**2
    if gt.sigma_heading_rad is not None:
        var = gt.sigma_heading_rad**2
        Jt = t_r[..., :2] @ _J.T
        C[..., :2, :2] += var * Jt[..., :, None] * Jt[..., None, :]
        C[..., :2, 2] = C[..., 2, :2] = var * Jt
        C[..., 2, 2] = 2.0 * var
    return C


def choose_windows(
    odometry_r: np.ndarray, stamps_s: np.ndarray, gt_frames: np.ndarray, noise: MotionNoise,
    gt: GroundTruthNoise, config: FitConfig,
) -> np.ndarray:
    """Consecutive windows between frames with ground truth, each closed at the first such frame
    where the ground truth's noise is at most ``config.max_ground_truth_share`` of the predicted
    residual variance in every compared component (module docstring, step 2).

    Args:
        odometry_r: (N, 3) measured steps.
        stamps_s: (N,) frame stamps [s] (a window lasts ``config.min_window_s`` at least).
        gt_frames: (M,) increasing frames that have ground truth (within the span used).
        noise: the alphas the prediction uses.
        gt: the ground truth's noise (its heading compared when it has one).
        config: the fit's configuration.

    Returns:
        (W, 2) start and end frames.
    """
    model = OdometryMotionModel(dataclasses.replace(
        noise, min_sigma=(0.0, 0.0, 0.0), reference_step_m=config.reference_step_m))
    floor = np.diag(np.square(config.step_floor))
    compared = slice(0, 2 if gt.sigma_heading_rad is None else 3)
    is_gt = np.zeros(len(odometry_r), dtype=bool)
    is_gt[gt_frames] = True
    out = []
    start = int(gt_frames[0])
    T, C = np.zeros(3), np.zeros((3, 3))
    for k in range(start + 1, int(gt_frames[-1]) + 1):
        u = odometry_r[k]
        T, C = compose_odometry(T, C, u, model.covariance(u) + floor)
        if not is_gt[k] or stamps_s[k] - stamps_s[start] < config.min_window_s:
            continue
        gt_part = np.diag(pose_ground_truth_covariance(T, gt))[compared]
        odometry_part = np.diag(C)[compared]
        if np.all(gt_part <= config.max_ground_truth_share * (odometry_part + gt_part)):
            out.append((start, k))
            start, T, C = k, np.zeros(3), np.zeros((3, 3))
    return np.array(out, dtype=np.int64).reshape(-1, 2)


# --- residuals ----------------------------------------------------------------------------
def pose_residuals(
    odometry_r: np.ndarray, sizes: np.ndarray, gt_w: np.ndarray, bounds: np.ndarray,
    gt: GroundTruthNoise, config: FitConfig,
) -> Residuals:
    """Ground truth's relative pose minus the odometry's, per window, in the window's start frame.

    Args:
        odometry_r: (N, 3) measured steps.
        sizes: (N, 3) their component sizes (``component_sizes``).
        gt_w: (N, 3) ground-truth poses [x, y, theta] (rows of frames without ground truth are
            not read).
        bounds: (W, 2) windows.
        gt: the ground truth's noise (with a heading).
        config: the fit's configuration.
    """
    T, Q, F = window_quadratic_forms(odometry_r, sizes, bounds, config.step_floor,
                                     config.reference_step_m)
    truth = se2_between(gt_w[bounds[:, 0]], gt_w[bounds[:, 1]])
    r = truth - T
    r[:, 2] = wrap_angle(r[:, 2])
    C_gt = pose_ground_truth_covariance(truth, gt)
    return Residuals(r, Q, F + C_gt, C_gt, POSE_COMPONENTS)


def shape_of_points(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(..., 3) the shape of three points (..., 2): the chord a->b's length, and the chord b->c
    along and across the first (invariant to rotating and moving the three together)."""
    chord = b - a
    length = np.hypot(chord[..., 0], chord[..., 1])
    u = chord / length[..., None]
    v = c - b
    return np.stack([length, np.sum(u * v, axis=-1), u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]],
                    axis=-1)


def shape_of_motion(d_ab: np.ndarray, d_bc: np.ndarray, lever_arm_m: np.ndarray) -> np.ndarray:
    """(..., 3) the shape the odometry predicts for the ground truth's point (at ``lever_arm_m``
    in the robot frame) at the three frames of two consecutive motions ``d_ab``, ``d_bc``
    (..., 3)."""
    def point(pose: np.ndarray) -> np.ndarray:
        c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
        return pose[..., :2] + np.stack([c * lever_arm_m[0] - s * lever_arm_m[1],
                                         s * lever_arm_m[0] + c * lever_arm_m[1]], axis=-1)

    origin = np.zeros_like(d_ab)
    return shape_of_points(point(origin), point(d_ab), point(se2_compose(d_ab, d_bc)))


def _row_jacobians(f: Callable[[np.ndarray], np.ndarray], rows: np.ndarray) -> np.ndarray:
    """(W, m, n) central-difference Jacobians (``core.jacobian``) of ``f`` at each row (W, n)."""
    return np.stack([numerical_jacobian(f, row) for row in rows])


def shape_residuals(
    odometry_r: np.ndarray, sizes: np.ndarray, gt_xy: np.ndarray, bounds: np.ndarray,
    gt: GroundTruthNoise, config: FitConfig,
) -> Residuals:
    """Shape of three ground-truth positions minus the odometry's, per pair of consecutive
    windows (module docstring, step 4); for ground truth without a heading.

    Args:
        odometry_r: (N, 3) measured steps.
        sizes: (N, 3) their component sizes (``component_sizes``).
        gt_xy: (N, 2) ground-truth positions (rows of frames without one are not read).
        bounds: (W, 2) consecutive windows; pairs (0, 1), (2, 3), ... are used.
        gt: the ground truth's noise.
        config: the fit's configuration (its lever arm).
    """
    pairs = len(bounds) // 2
    T, Q, F = window_quadratic_forms(odometry_r, sizes, bounds[:2 * pairs], config.step_floor,
                                     config.reference_step_m)
    first, second = slice(0, 2 * pairs, 2), slice(1, 2 * pairs, 2)
    lever = np.asarray(config.lever_arm_m, dtype=float)
    motions = np.hstack([T[first], T[second]])
    J = _row_jacobians(lambda m: shape_of_motion(m[:3], m[3:], lever), motions)
    J1, J2 = J[:, :, :3], J[:, :, 3:]
    a, b, c = (gt_xy[bounds[:2 * pairs:2, 0]], gt_xy[bounds[:2 * pairs:2, 1]],
               gt_xy[bounds[1:2 * pairs:2, 1]])
    truth = shape_of_points(a, b, c)
    Jp = _row_jacobians(lambda p: shape_of_points(p[:2], p[2:4], p[4:]), np.hstack([a, b, c]))
    C_gt = gt.sigma_position_m**2 * Jp @ np.swapaxes(Jp, 1, 2)

    def carry(M1: np.ndarray, M2: np.ndarray) -> np.ndarray:
        """J1 M1 J1^T + J2 M2 J2^T over the trailing (3, 3) axes."""
        return (np.einsum("wam,w...mn,wbn->w...ab", J1, M1, J1)
                + np.einsum("wam,w...mn,wbn->w...ab", J2, M2, J2))

    return Residuals(
        r=truth - shape_of_motion(T[first], T[second], lever),
        Q=carry(Q[first], Q[second]),
        C0=carry(F[first], F[second]) + C_gt,
        C_gt=C_gt,
        components=SHAPE_COMPONENTS,
    )


# --- maximum likelihood -------------------------------------------------------------------
def negative_log_likelihood(residuals: Residuals, alphas: np.ndarray
                            ) -> tuple[float, np.ndarray]:
    """``-log L`` (without the constant) and its gradient with respect to the alphas.

    ``-log L = 1/2 sum_w (r^T C^-1 r + log det C)``;
    ``d/da_i = 1/2 sum_w tr((C^-1 - C^-1 r r^T C^-1) dC/da_i)``, ``dC/da_i = 2 sum_j a_j Q_ij``.
    """
    C = residuals.covariance(alphas)
    Ci = np.linalg.inv(C)
    Cir = np.einsum("wab,wb->wa", Ci, residuals.r)
    _, logdet = np.linalg.slogdet(C)
    value = 0.5 * float(np.sum(np.einsum("wa,wa->w", residuals.r, Cir) + logdet))
    dC = 2.0 * np.einsum("wijab,j->iwab", residuals.Q, alphas)
    P = Ci - Cir[:, :, None] * Cir[:, None, :]
    return value, 0.5 * np.einsum("wab,iwba->i", P, dC)


def fisher_information(residuals: Residuals, alphas: np.ndarray) -> np.ndarray:
    """(4, 4) expected Fisher information ``1/2 sum_w tr(C^-1 dC_i C^-1 dC_j)``."""
    Ci = np.linalg.inv(residuals.covariance(alphas))
    dC = 2.0 * np.einsum("wijab,j->iwab", residuals.Q, alphas)
    M = np.einsum("wab,iwbc->iwac", Ci, dC)
    return 0.5 * np.einsum("iwab,jwba->ij", M, M)


def maximise_likelihood(residuals: Residuals, start: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray, float]:
    """The alphas of maximum likelihood (each >= 0), their standard errors and the maximum.

    Raises:
        DataError: the optimiser fails (too few or degenerate residuals).
    """
    result = optimize.minimize(
        lambda a: negative_log_likelihood(residuals, a), np.asarray(start, dtype=float),
        jac=True, method="L-BFGS-B", bounds=[(0.0, None)] * len(ALPHAS),
        options={"ftol": 1e-13, "gtol": 1e-9, "maxiter": 2000},
    )
    if not np.all(np.isfinite(result.x)):
        raise DataError(f"the likelihood could not be maximised ({result.message})")
    information = fisher_information(residuals, result.x)
    try:
        covariance = np.linalg.inv(information)
    except np.linalg.LinAlgError:
        covariance = np.linalg.pinv(information)
    errors = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
    return result.x, errors, -float(result.fun)


def residual_statistics(residuals: Residuals, alphas: np.ndarray) -> ResidualStatistics:
    """Normalised residuals and Mahalanobis distances under ``alphas`` (module docstring)."""
    C = residuals.covariance(alphas)
    z = residuals.r / np.sqrt(np.einsum("waa->wa", C))
    nees = np.einsum("wa,wab,wb->w", residuals.r, np.linalg.inv(C), residuals.r)
    return ResidualStatistics(
        components=residuals.components,
        mean=z.mean(axis=0),
        std=z.std(axis=0, ddof=1) if len(z) > 1 else np.full(3, math.nan),
        nees_mean=float(nees.mean()),
        beyond_99=float(np.mean(nees > stats.chi2.ppf(0.99, 3))),
    )


# --- a sequence ---------------------------------------------------------------------------
def ground_truth_frames(sequence: Sequence) -> tuple[np.ndarray, np.ndarray]:
    """The frames that have ground truth and their poses.

    Returns:
        (frames (M,) increasing indices, poses (N, 3) [x, y, theta] with NaN rows elsewhere).

    Raises:
        DataError: no ground-truth trajectory, or a ground-truth stamp that is no frame's.
    """
    truth = sequence.ground_truth.trajectory
    if truth is None or len(truth) < 2:
        raise DataError(f"{sequence.name}: no ground-truth trajectory to fit the odometry to")
    frames = np.searchsorted(sequence.stamps_s, truth.stamps_s)
    inside = frames < len(sequence.stamps_s)
    if not inside.all() or np.any(sequence.stamps_s[frames] != truth.stamps_s):
        raise DataError(f"{sequence.name}: a ground-truth stamp is not a frame stamp")
    poses = np.full((len(sequence.stamps_s), 3), np.nan)
    poses[frames] = truth.se2
    return frames, poses


def fit_odometry_noise(
    sequence: Sequence, gt: GroundTruthNoise, config: FitConfig = FitConfig()
) -> OdometryNoiseFit:
    """Fit the alphas of ``sequence``'s odometry to its ground truth (module docstring).

    Args:
        sequence: a loaded dataset with a ground-truth trajectory.
        gt: its ground truth's per-sample noise (e.g. ``second_difference_noise`` of its stream).
        config: the procedure's settings.

    Raises:
        DataError: no ground truth, or too few windows in the span to fit four alphas.
    """
    frames, poses = ground_truth_frames(sequence)
    stamps = sequence.stamps_s
    end_s = stamps[0] + config.fraction * (stamps[-1] - stamps[0])
    frames = frames[stamps[frames] <= end_s]
    positions_only = gt.sigma_heading_rad is None
    noise, previous, rounds = config.pilot, None, 0
    while rounds < config.max_rounds:
        bounds = choose_windows(sequence.odometry_r, stamps, frames, noise, gt, config)
        if previous is not None and np.array_equal(bounds, previous):
            break
        rounds += 1
        residuals = _residuals(sequence, poses, bounds, gt, config, positions_only)
        start = np.array([getattr(noise, name) for name in ALPHAS])
        alphas, errors, log_likelihood = maximise_likelihood(residuals, start)
        noise = dataclasses.replace(config.pilot, reference_step_m=config.reference_step_m,
                                    **dict(zip(ALPHAS, alphas.tolist(), strict=True)))
        previous = bounds
    C = residuals.covariance(alphas)
    share = np.median(np.einsum("waa->wa", residuals.C_gt) / np.einsum("waa->wa", C), axis=0)
    return OdometryNoiseFit(
        noise=noise,
        standard_errors=errors,
        log_likelihood=log_likelihood,
        windows=len(residuals.r),
        window_length_m=float(np.median(_window_lengths(sequence.odometry_r, previous))),
        window_duration_s=float(np.median(stamps[previous[:, 1]] - stamps[previous[:, 0]])),
        window_steps=float(np.median(previous[:, 1] - previous[:, 0])),
        ground_truth_share=share,
        residuals=residual_statistics(residuals, alphas),
        ground_truth=gt,
        span_s=(float(stamps[0]), float(end_s)),
        rounds=rounds,
    )


#: fewer residuals than this cannot fit four alphas with any confidence
MIN_RESIDUALS = 12


def _residuals(sequence: Sequence, poses: np.ndarray, bounds: np.ndarray,
               gt: GroundTruthNoise, config: FitConfig, positions_only: bool) -> Residuals:
    """The residuals of ``bounds``, checked to be enough for a fit."""
    sizes = component_sizes(sequence.odometry_r, sequence.stamps_s, config.size_window_s)
    if positions_only:
        residuals = shape_residuals(sequence.odometry_r, sizes, poses[:, :2], bounds, gt, config)
    else:
        residuals = pose_residuals(sequence.odometry_r, sizes, poses, bounds, gt, config)
    if len(residuals.r) < MIN_RESIDUALS:
        raise DataError(
            f"{sequence.name}: {len(residuals.r)} residuals in the first "
            f"{config.fraction:.0%} of the run, at least {MIN_RESIDUALS} needed")
    return residuals


def _window_lengths(odometry_r: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """(W,) distance the odometry travelled in each window [m]."""
    travelled = np.concatenate([[0.0], np.cumsum(np.hypot(odometry_r[1:, 0], odometry_r[1:, 1]))])
    return travelled[bounds[:, 1]] - travelled[bounds[:, 0]]


# --- the ground truth's own noise -----------------------------------------------------------
def second_difference_noise(
    stamps_s: np.ndarray, poses: np.ndarray, observes_heading: bool, source: str
) -> GroundTruthNoise:
    """The per-sample noise of a ground-truth stream at its own rate, from its second
    differences (von Neumann): for white noise of std s on a smooth path sampled fast,
    ``x[k+1] - 2 x[k] + x[k-1]`` has std ``sqrt(6) s`` (the path's own curvature adds
    ``a dt^2``: an upper bound when the stream is slow). Robust: 1.4826 x the median absolute
    deviation, so dropouts and jumps do not count.

    Args:
        stamps_s: (M,) sample times [s] (the stream as recorded, not interpolated at frames).
        poses: (M, 2) positions or (M, 3) poses [x, y, theta].
        observes_heading: the stream's third column is a heading.
        source: what the stream is, for ``GroundTruthNoise.source``.
    """
    values = np.asarray(poses, dtype=float).copy()
    if observes_heading:
        values[:, 2] = np.unwrap(values[:, 2])
    second = values[2:] - 2.0 * values[1:-1] + values[:-2]
    mad = np.median(np.abs(second - np.median(second, axis=0)), axis=0)
    sigma = 1.4826 * mad / math.sqrt(6.0)
    rate = 1.0 / float(np.median(np.diff(stamps_s)))
    return GroundTruthNoise(
        sigma_position_m=float(np.sqrt((sigma[0] ** 2 + sigma[1] ** 2) / 2)),
        sigma_heading_rad=float(sigma[2]) if observes_heading else None,
        source=f"{source}: second differences at {rate:.0f} Hz ({len(values)} samples)",
    )
