"""The FFBSm read-out (``fastslam.smoother``) against the Rauch-Tung-Striebel smoother on a
linear-Gaussian model, its genealogy limit, and the filter's
``experimental.trajectory=smoothed``."""

from __future__ import annotations

import numpy as np
import pytest
from fastslam_scenario import ate_rmse, make_scenario
from fastslam_tolerances import ATE_FRACTION_OF_DEAD_RECKONING
from test_filter import _ate, _config, _experimental, _run

from omnislam.errors import ConfigError
from omnislam.fastslam import TrajectoryMode, Variant
from omnislam.fastslam.particles import weighted_covariance_about, weighted_mean_pose
from omnislam.fastslam.resampling import normalize_log_weights, systematic_resample
from omnislam.fastslam.smoother import ffbsm_log_weights, transition_log_density

#: particles of the bootstrap filter smoothed on the linear-Gaussian model
LINEAR_PARTICLES = 1500
#: steps of the linear-Gaussian model
LINEAR_STEPS = 12
#: the smoothed means must lie within this many of their Monte Carlo std of the RTS means
MC_STDS = 4.0


def _rts(deltas, q, r, ys, p0):
    """Kalman filter and RTS smoother of x_t = x_{t-1} + delta_t + N(0, q), y_t = x_t + N(0, r)
    on one coordinate; x_0 ~ N(0, p0) observed by ys[0]."""
    n = len(ys)
    m_f, p_f = np.empty(n), np.empty(n)
    m, p = 0.0, p0
    for t in range(n):
        if t:
            m, p = m + deltas[t], p + q
        k = p / (p + r)
        m, p = m + k * (ys[t] - m), (1 - k) * p
        m_f[t], p_f[t] = m, p
    m_s, p_s = m_f.copy(), p_f.copy()
    for t in range(n - 2, -1, -1):
        g = p_f[t] / (p_f[t] + q)
        m_s[t] = m_f[t] + g * (m_s[t + 1] - m_f[t] - deltas[t + 1])
        p_s[t] = p_f[t] + g * g * (p_s[t + 1] - p_f[t] - q)
    return m_f, m_s, p_s


def _bootstrap_filter(deltas, cov, ys, r, p0, rng):
    """A bootstrap particle filter over planar poses that move in x only (heading 0): each step
    samples x_t = x_{t-1} (+) (delta + e), e ~ N(0, cov), weighs by N(y_t; x_t, r), and resamples
    every step (the weights recorded before)."""
    p = LINEAR_PARTICLES
    poses = np.zeros((p, 3))
    poses[:, 0] = rng.normal(0.0, np.sqrt(p0), p)
    chol = np.linalg.cholesky(cov)
    recorded, log_weights = [], []
    for t, y in enumerate(ys):
        if t:
            step = deltas[t] + rng.standard_normal((p, 3)) @ chol.T
            poses = poses.copy()
            poses[:, 0] += step[:, 0]  # heading 0: the SE(2) composition is this sum
            poses[:, 1] += step[:, 1]
            poses[:, 2] = 0.0
        lw = normalize_log_weights(-0.5 * (y - poses[:, 0]) ** 2 / r)
        recorded.append(poses.copy())
        log_weights.append(lw)
        poses = poses[systematic_resample(np.exp(lw), rng)]
    return recorded, log_weights


def test_transition_density_is_the_delta_gaussian():
    wTa = np.array([[1.0, 2.0, 0.5]])
    delta = np.array([0.3, -0.1, 0.2])
    cov = np.diag([0.01, 0.04, 0.0025])
    noise = np.array([0.1, 0.2, -0.05])
    c, s = np.cos(0.5), np.sin(0.5)
    step = delta + noise
    wTb = np.array(
        [[1.0 + c * step[0] - s * step[1], 2.0 + s * step[0] + c * step[1], 0.5 + step[2]]]
    )
    expected = -0.5 * noise @ np.linalg.inv(cov) @ noise
    np.testing.assert_allclose(transition_log_density(wTa, wTb, delta, cov), [[expected]])


def test_ffbsm_matches_the_rts_smoother_on_a_linear_gaussian_model():
    """x moves by known deltas plus Gaussian noise and is observed directly: the FFBSm means
    of a bootstrap filter's recorded clouds agree with the RTS smoother's, and at the first
    steps they are closer to it than the filtered means are."""
    rng = np.random.default_rng(7)
    q, r, p0 = 0.04, 0.09, 0.01
    cov = np.diag([q, q, 1e-8])
    deltas = np.zeros((LINEAR_STEPS, 3))
    deltas[:, 0] = 0.5
    truth = np.cumsum(deltas[:, 0] + np.r_[0.0, rng.normal(0, np.sqrt(q), LINEAR_STEPS - 1)])
    ys = truth + rng.normal(0.0, np.sqrt(r), LINEAR_STEPS)
    m_f, m_s, p_s = _rts(deltas[:, 0], q, r, ys, p0)
    poses, log_weights = _bootstrap_filter(deltas, cov, ys, r, p0, rng)
    smoothed = ffbsm_log_weights(poses, log_weights, deltas, np.tile(cov, (LINEAR_STEPS, 1, 1)))
    means_xyt = [weighted_mean_pose(x, np.exp(lw)) for x, lw in zip(poses, smoothed, strict=True)]
    means = np.array([mean[0] for mean in means_xyt])
    variances = np.array(
        [
            weighted_covariance_about(x, np.exp(lw), mean)[0, 0]
            for x, lw, mean in zip(poses, smoothed, means_xyt, strict=True)
        ]
    )
    ess = np.array([1.0 / np.sum(np.exp(2 * lw)) for lw in smoothed])
    np.testing.assert_array_less(np.abs(means - m_s), MC_STDS * np.sqrt(p_s / ess))
    np.testing.assert_allclose(variances, p_s, rtol=0.35)
    filtered = np.array(
        [weighted_mean_pose(x, np.exp(lw))[0] for x, lw in zip(poses, log_weights, strict=True)]
    )
    np.testing.assert_allclose(filtered, m_f, atol=MC_STDS * np.sqrt(r / LINEAR_PARTICLES))
    assert np.mean(np.abs(means[:4] - m_s[:4])) < np.mean(np.abs(filtered[:4] - m_s[:4]))


def test_ffbsm_with_a_tight_transition_is_the_genealogy():
    """When every pose of step t+1 lies within a tiny transition noise of its own parent and
    far (in that noise) from every other particle of step t, the backward kernel picks the
    parent: the smoothed weight of a step-t particle is the sum of its children's."""
    rng = np.random.default_rng(3)
    p = 6
    delta = np.array([0.2, 0.0, 0.05])
    cov = np.diag([1e-6, 1e-6, 1e-8])
    x0 = np.c_[rng.normal(0, 0.5, (p, 2)), rng.normal(0, 0.2, p)]
    ancestors = np.array([0, 0, 0, 2, 5, 5])
    c, s = np.cos(x0[ancestors, 2]), np.sin(x0[ancestors, 2])
    x1 = np.c_[
        x0[ancestors, 0] + c * delta[0] - s * delta[1],
        x0[ancestors, 1] + s * delta[0] + c * delta[1],
        x0[ancestors, 2] + delta[2],
    ]
    w0 = normalize_log_weights(rng.normal(0, 1, p))
    w1 = normalize_log_weights(rng.normal(0, 1, p))
    smoothed = ffbsm_log_weights(
        [x0, x1], [w0, w1], np.array([np.zeros(3), delta]), np.array([cov, cov])
    )
    expected = np.bincount(ancestors, weights=np.exp(w1), minlength=p)
    np.testing.assert_allclose(np.exp(smoothed[0]), expected, atol=1e-9)
    np.testing.assert_allclose(smoothed[1], w1)


@pytest.mark.parametrize("variant", list(Variant))
def test_smoothed_trajectory_ends_at_the_filtered_mean_and_beats_dead_reckoning(variant):
    scenario = make_scenario(1, steps=80)
    _, estimate = _run(scenario, _experimental(variant, 50, trajectory=TrajectoryMode.SMOOTHED), 3)
    _, mean_estimate = _run(scenario, _config(variant, 50), 3)
    assert len(estimate.trajectory) == 80
    # the same draws: the last smoothed marginal is the filter's
    np.testing.assert_allclose(estimate.trajectory.se2[-1], mean_estimate.trajectory.se2[-1])
    np.testing.assert_allclose(
        estimate.pose_covariances[-1], mean_estimate.pose_covariances[-1], atol=1e-12
    )
    assert estimate.pose_covariances.shape == (80, 3, 3)
    assert np.all(np.linalg.eigvalsh(estimate.pose_covariances) > -1e-12)
    dead_reckoning = ate_rmse(scenario.dead_reckoning[1:, :2], scenario.true_poses[1:, :2])
    assert _ate(estimate, scenario) < ATE_FRACTION_OF_DEAD_RECKONING * dead_reckoning


def test_smoothed_trajectory_rejects_composed_gaps():
    with pytest.raises(ConfigError):
        _experimental(Variant.FASTSLAM1, 10, trajectory=TrajectoryMode.SMOOTHED, compose_gaps=True)
