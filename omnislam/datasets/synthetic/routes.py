"""Differential-drive paths through waypoints, and the odometry they produce.

The robot follows the polyline of waypoints with a pure-pursuit controller (look-ahead point on
the polyline, curvature ``kappa = 2 sin(alpha) / L``), with speed limited by the maximum speed,
the maximum turn rate (``v <= omega_max / |kappa|``) and the acceleration; it turns on the spot
when the look-ahead point is far off its heading. The unicycle ``x' = v cos th, y' = v sin th,
th' = omega`` is integrated exactly over sub-steps and sampled at the odometry rate (10 Hz, the
thesis's acquisition rate, ch. 5.1.1). Everything is deterministic: no randomness here.

Odometry between samples is the true relative motion ``se2_between(wTr[i-1], wTr[i])``. The
measured odometry corrupts it twice, as real wheel odometry is corrupted (Borenstein & Feng 1996,
"Measurement and correction of systematic odometry errors in mobile robots"): first by the
robot's *systematic* calibration errors (``OdometryBias``: a wheel-radius scale error, an
effective-wheelbase error that scales every turn, unequal wheel diameters that bend straight
lines), then by the thesis's zero-mean alpha model (``core.motion``, eqs. 4.38-4.44). Zero-mean
noise at 10 Hz averages out (0.3-1 % drift per 10 m); the systematic part is what makes dead
reckoning drift by percent of the distance travelled.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import numpy as np

from omnislam.core.motion import MotionNoise, OdometryMotionModel
from omnislam.core.se import se2_between
from omnislam.errors import ConfigError

_TWO_PI = 2.0 * math.pi


@dataclass(frozen=True, slots=True)
class OdometryBias:
    """Systematic odometry errors of the simulated robot (Borenstein & Feng 1996, UMBmark).

    Applied to the (rot1, trans, rot2) components of each true step (thesis eq. 4.39) before the
    alpha noise: ``trans' = (1 + trans_scale) trans``; ``rot' = (1 + turn_scale) rot +
    curvature_per_m trans / 2`` for rot1 and rot2 each.

    The defaults (the same robot in every preset) give a dead-reckoning drift of 1.3-2.7 % of the
    distance over 10 m segments on every preset (``benchmarks/odometry_drift.py``).

    Attributes:
        trans_scale: relative error of the travelled distance (wheel radius; UMBmark's scale).
        turn_scale: relative error of every turn (effective wheelbase, UMBmark's E_b).
        curvature_per_m: heading error per metre driven straight [rad/m] (unequal wheel
            diameters, UMBmark's E_d).
    """

    trans_scale: float = 0.01
    turn_scale: float = -0.015
    curvature_per_m: float = 0.002

    def apply(self, components: np.ndarray) -> np.ndarray:
        """Biased (rot1, trans, rot2) [..., 3] of true components [..., 3]."""
        c = np.array(components, dtype=float)
        bend = 0.5 * self.curvature_per_m * c[..., 1]
        c[..., 1] *= 1.0 + self.trans_scale
        c[..., 0] = (1.0 + self.turn_scale) * c[..., 0] + bend
        c[..., 2] = (1.0 + self.turn_scale) * c[..., 2] + bend
        return c


NO_BIAS = OdometryBias(0.0, 0.0, 0.0)


@dataclass(frozen=True, slots=True)
class DriveLimits:
    """Limits and gains of the path follower.

    Attributes:
        max_speed_mps: forward speed limit [m/s].
        max_turn_rate_radps: turn-rate limit [rad/s].
        max_accel_mps2: forward acceleration / deceleration limit [m/s^2].
        lookahead_m: pure-pursuit look-ahead distance [m].
        rate_hz: odometry (and ground-truth) sample rate [Hz].
        substeps: integration sub-steps per sample.
        goal_tolerance_m: the route ends within this distance of the last waypoint [m].
    """

    max_speed_mps: float = 0.3
    max_turn_rate_radps: float = 0.6
    max_accel_mps2: float = 0.3
    lookahead_m: float = 0.5
    rate_hz: float = 10.0
    substeps: int = 10
    goal_tolerance_m: float = 0.05

    def __post_init__(self) -> None:
        if min(self.max_speed_mps, self.max_turn_rate_radps, self.max_accel_mps2,
               self.lookahead_m, self.rate_hz) <= 0 or self.substeps < 1:
            raise ConfigError(f"DriveLimits must be positive: {self}")


@dataclass(frozen=True, slots=True)
class Path:
    """A sampled robot path.

    Attributes:
        stamps_s: (N,) times [s], starting at 0.
        poses_w: (N, 3) true poses [x, y, theta] in the world.
    """

    stamps_s: np.ndarray
    poses_w: np.ndarray

    def __len__(self) -> int:
        return int(self.stamps_s.shape[0])

    @property
    def length_m(self) -> float:
        """Travelled distance [m]."""
        return float(np.sum(np.linalg.norm(np.diff(self.poses_w[:, :2], axis=0), axis=1)))

    def odometry_true(self) -> np.ndarray:
        """(N, 3) true robot-frame deltas from sample i-1 to i (row 0 is zero)."""
        out = np.zeros_like(self.poses_w)
        out[1:] = se2_between(self.poses_w[:-1], self.poses_w[1:])
        return out


def _polyline_points(points: np.ndarray, cumlen: np.ndarray, s: np.ndarray) -> np.ndarray:
    """(S, 2) points at arc lengths ``s`` (S,) along the polyline (clamped to its ends)."""
    s = np.clip(s, 0.0, cumlen[-1])
    k = np.clip(np.searchsorted(cumlen, s, side="right") - 1, 0, len(points) - 2)
    seg = cumlen[k + 1] - cumlen[k]
    a = np.where(seg > 0, (s - cumlen[k]) / np.where(seg > 0, seg, 1.0), 0.0)
    return points[k] + a[:, None] * (points[k + 1] - points[k])


def _polyline_point(
    points: list[tuple[float, float]], cumlen: list[float], s: float
) -> tuple[float, float]:
    """``_polyline_points`` of one arc length on Python floats, bit for bit (the same IEEE
    operations in the same order, without numpy's per-call cost: the path follower asks for one
    point per sub-step)."""
    s = min(max(s, 0.0), cumlen[-1])
    k = min(max(bisect.bisect_right(cumlen, s) - 1, 0), len(points) - 2)
    seg = cumlen[k + 1] - cumlen[k]
    a = (s - cumlen[k]) / seg if seg > 0 else 0.0
    (x0, y0), (x1, y1) = points[k], points[k + 1]
    return x0 + a * (x1 - x0), y0 + a * (y1 - y0)


def _wrap(angle: float) -> float:
    """``core.se.wrap_angle`` of one Python float: the same floored modulo, bit for bit."""
    return (angle + math.pi) % _TWO_PI - math.pi


def drive_through(
    waypoints_w: np.ndarray,
    limits: DriveLimits = DriveLimits(),
    initial_yaw_rad: float | None = None,
    max_duration_s: float = 36000.0,
) -> Path:
    """Drive a differential robot through ``waypoints_w`` (see module docstring).

    Args:
        waypoints_w: (K, 2) waypoints [m], K >= 2; the robot starts on the first one.
        limits: speed, turn-rate and acceleration limits and the sample rate.
        initial_yaw_rad: starting heading; default: towards the second waypoint.
        max_duration_s: safety limit of the simulated time [s].

    Returns:
        The path sampled at ``limits.rate_hz``.
    """
    points = np.asarray(waypoints_w, dtype=float)
    if points.ndim != 2 or points.shape[1] != 2 or len(points) < 2:
        raise ConfigError(f"waypoints must be (K >= 2, 2), got {points.shape}")
    cumlen = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    total = float(cumlen[-1])
    point_list = [(float(px), float(py)) for px, py in points]
    cumlen_list = [float(c) for c in cumlen]
    d0 = points[1] - points[0]
    yaw = math.atan2(d0[1], d0[0]) if initial_yaw_rad is None else float(initial_yaw_rad)
    x, y = float(points[0, 0]), float(points[0, 1])
    v = 0.0
    s_progress = 0.0  # arc length of the closest polyline point so far (monotone)
    dt = 1.0 / (limits.rate_hz * limits.substeps)
    samples = [(x, y, yaw)]
    steps = 0
    max_steps = int(max_duration_s * limits.rate_hz * limits.substeps)
    while steps < max_steps:
        if steps % limits.substeps == 0:
            # progress: the closest polyline point a little ahead of the previous one
            window = np.linspace(s_progress, min(total, s_progress + 2 * limits.lookahead_m), 41)
            pts = _polyline_points(points, cumlen, window)
            s_progress = float(window[np.argmin(np.hypot(pts[:, 0] - x, pts[:, 1] - y))])
        goal_dist = math.hypot(points[-1, 0] - x, points[-1, 1] - y)
        if total - s_progress < limits.lookahead_m and goal_dist < limits.goal_tolerance_m:
            break
        target = _polyline_point(point_list, cumlen_list, s_progress + limits.lookahead_m)
        alpha = _wrap(math.atan2(target[1] - y, target[0] - x) - yaw)
        dist = max(math.hypot(target[0] - x, target[1] - y), 1e-6)
        kappa = 2.0 * math.sin(alpha) / dist
        remaining = max(total - s_progress, goal_dist) - 0.5 * limits.goal_tolerance_m
        v_stop = math.sqrt(2.0 * limits.max_accel_mps2 * max(remaining, 0.0))
        v_goal = limits.max_speed_mps if abs(alpha) < math.pi / 3 else 0.0
        v_goal = min(v_goal, v_stop + 0.01,
                     limits.max_turn_rate_radps / max(abs(kappa), 1e-9))
        v += min(max(v_goal - v, -limits.max_accel_mps2 * dt), limits.max_accel_mps2 * dt)
        v = max(v, 0.0)
        if v_goal == 0.0 and v < 1e-3:
            omega = math.copysign(limits.max_turn_rate_radps, alpha) * min(1.0, abs(alpha) / 0.3)
        else:
            omega = min(max(v * kappa, -limits.max_turn_rate_radps), limits.max_turn_rate_radps)
        # exact unicycle step
        if abs(omega) < 1e-9:
            x += v * dt * math.cos(yaw)
            y += v * dt * math.sin(yaw)
        else:
            x += v / omega * (math.sin(yaw + omega * dt) - math.sin(yaw))
            y -= v / omega * (math.cos(yaw + omega * dt) - math.cos(yaw))
        yaw = _wrap(yaw + omega * dt)
        steps += 1
        if steps % limits.substeps == 0:
            samples.append((x, y, yaw))
    poses = np.array(samples)
    stamps = np.arange(len(poses)) / limits.rate_hz
    return Path(stamps_s=stamps, poses_w=poses)


def measured_odometry(
    odometry_true_r: np.ndarray,
    noise: MotionNoise,
    rng: np.random.Generator,
    bias: OdometryBias = NO_BIAS,
) -> np.ndarray:
    """Corrupt true odometry deltas (N, 3): systematic ``bias``, then the thesis's alpha model.

    The alpha noise (eqs. 4.38-4.44) is drawn around the biased step, with the sigmas of the
    biased components. Row 0 (no motion before the first frame) stays zero.
    """
    model = OdometryMotionModel(noise)
    out = np.zeros_like(odometry_true_r)
    if odometry_true_r.shape[0] < 2:
        return out
    biased = model.recompose(bias.apply(model.decompose(odometry_true_r[1:])))
    for i in range(1, odometry_true_r.shape[0]):
        out[i] = model.sample_delta(biased[i - 1], rng)
    return out
