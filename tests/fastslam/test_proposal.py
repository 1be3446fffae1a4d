"""The FastSLAM 2.0 proposal (sequential refinement) against its textbook forms."""

from __future__ import annotations

import numpy as np

from omnislam.core.gating import chi_square_gate
from omnislam.core.measurement import BearingElevation3D, RangeBearing2D
from omnislam.core.motion import MotionNoise, OdometryMotionModel
from omnislam.core.se import wrap_angle
from omnislam.fastslam.proposal import joint_proposal, refine_proposal, sample_poses


def _case(rng, n=5):
    poses = np.column_stack([rng.normal(0, 1, (n, 2)), rng.uniform(-np.pi, np.pi, n)])
    landmarks = poses[:, :2] + rng.uniform(2, 5, (n, 2))
    A = rng.normal(size=(n, 2, 2)) * 0.1
    cov = A @ np.swapaxes(A, 1, 2) + 0.01 * np.eye(2)
    R = np.broadcast_to(np.diag([0.1**2, 0.02**2]), (n, 2, 2)).copy()
    z, _, _ = RangeBearing2D().predict(poses, landmarks + rng.normal(0, 0.1, (n, 2)))
    return poses, landmarks, cov, z, R


def test_proposal_matches_montemerlo_information_form(rng):
    """Sigma_x = [H_x^T Q^-1 H_x + P^-1]^-1, mu_x = Sigma_x H_x^T Q^-1 (z - z_hat) + x_hat."""
    poses, landmarks, cov, z, R = _case(rng)
    motion = OdometryMotionModel(MotionNoise())
    x_hat, P = motion.predict(poses, None, np.array([0.5, 0.05, 0.2]))
    model = RangeBearing2D()
    update = refine_proposal(x_hat, P, z, R, landmarks, cov, model)
    z_hat, H_x, H_m = model.predict(x_hat, landmarks)
    y = model.residual(z, z_hat)
    for i in range(len(z)):
        Q = H_m[i] @ cov[i] @ H_m[i].T + R[i]
        Sigma = np.linalg.inv(H_x[i].T @ np.linalg.inv(Q) @ H_x[i] + np.linalg.inv(P[i]))
        np.testing.assert_allclose(update.cov[i], Sigma, rtol=1e-6, atol=1e-12)
        mu = Sigma @ H_x[i].T @ np.linalg.inv(Q) @ y[i] + x_hat[i]
        np.testing.assert_allclose(update.mean[i, :2], mu[:2], rtol=1e-7)
        L = H_x[i] @ P[i] @ H_x[i].T + Q
        ll = -0.5 * (y[i] @ np.linalg.solve(L, y[i]) + np.log(np.linalg.det(2 * np.pi * L)))
        np.testing.assert_allclose(update.log_likelihood[i], ll, rtol=1e-9)


def test_sample_poses_has_the_requested_moments(rng):
    mean = np.array([1.0, -1.0, 0.5])
    cov = np.array([[0.04, 0.01, 0.0], [0.01, 0.09, 0.002], [0.0, 0.002, 0.01]])
    samples = sample_poses(np.tile(mean, (200_000, 1)), np.tile(cov, (200_000, 1, 1)), rng)
    np.testing.assert_allclose(samples.mean(axis=0), mean, atol=2e-3)
    np.testing.assert_allclose(np.cov(samples.T), cov, rtol=0.02, atol=2e-4)


def test_proposal_covariance_stays_positive_definite_over_hundreds_of_bearings(rng):
    """Omni camera: ~200 bearings refine one proposal, each far more precise than the motion
    prediction. The covariance must stay symmetric positive definite (Joseph form) so that
    ``sample_poses`` can factorise it, and match the batch information form."""
    model = BearingElevation3D(0.85)
    n, steps = 20, 300
    mean = np.zeros((n, 3))
    P0 = np.diag([1e-4, 1e-4, 1e-5])
    cov = np.tile(P0, (n, 1, 1))
    information = np.tile(np.linalg.inv(P0), (n, 1, 1))
    R = np.tile(np.eye(2) * 1e-16, (n, 1, 1))
    exact_landmark = np.zeros((n, 3, 3))
    for _ in range(steps):
        landmarks = np.column_stack([rng.uniform(-4, 4, (n, 2)), rng.uniform(0.0, 2.5, n)])
        z, H_x, _ = model.predict(np.zeros((n, 3)), landmarks)
        update = refine_proposal(mean, cov, z, R, landmarks, exact_landmark, model)
        mean, cov = update.mean, update.cov
        information += np.swapaxes(H_x, 1, 2) @ np.linalg.inv(R) @ H_x
        assert np.all(np.linalg.eigvalsh(cov)[:, 0] > 0)
    np.testing.assert_allclose(cov, np.swapaxes(cov, 1, 2))
    np.testing.assert_allclose(cov, np.linalg.inv(information), rtol=1e-3, atol=1e-21)
    sample_poses(mean, cov, rng)  # the Cholesky factorisation succeeds


def test_gated_proposal_ignores_an_outlier_and_truncates_its_likelihood(rng):
    """An innovation outside the gate leaves the proposal as it was; inside, the gate changes
    nothing. The outlier's factor is the Gaussian at the gate's Mahalanobis distance."""
    poses, landmarks, cov, _, R = _case(rng)
    motion = OdometryMotionModel(MotionNoise())
    x_hat, P = motion.predict(poses, None, np.array([0.5, 0.05, 0.2]))
    model = RangeBearing2D()
    z, _, _ = model.predict(x_hat, landmarks)
    z += rng.normal(0.0, [0.1, 0.02], z.shape)  # a one-sigma sensor error
    gate = chi_square_gate(0.999, 2)
    plain = refine_proposal(x_hat, P, z, R, landmarks, cov, model)
    gated = refine_proposal(x_hat, P, z, R, landmarks, cov, model, gate)
    assert gated.accepted.all()
    np.testing.assert_array_equal(gated.mean, plain.mean)
    np.testing.assert_array_equal(gated.cov, plain.cov)
    np.testing.assert_array_equal(gated.log_likelihood, plain.log_likelihood)

    outlier = z.copy()
    outlier[0, 1] += 1.0  # a bearing 57 deg off
    update = refine_proposal(x_hat, P, outlier, R, landmarks, cov, model, gate)
    assert not update.accepted[0] and update.accepted[1:].all()
    np.testing.assert_array_equal(update.mean[0], x_hat[0])
    np.testing.assert_array_equal(update.cov[0], P[0])
    _, H_x, H_m = model.predict(x_hat[:1], landmarks[:1])
    L = H_x[0] @ P[0] @ H_x[0].T + H_m[0] @ cov[0] @ H_m[0].T + R[0]
    at_gate = -0.5 * (gate + np.log(np.linalg.det(2 * np.pi * L)))
    np.testing.assert_allclose(update.log_likelihood[0], at_gate, rtol=1e-9)


def test_a_refined_heading_past_pi_is_wrapped_on_both_update_paths():
    """Headings pi - 0.005 and a bearing 0.05 rad short of the prediction: the refinement
    turns the heading by ~+0.048 (P_theta = 0.01 against a bearing variance of 4e-4), past
    pi. The refined mean is the information form's (thesis 4.45), wrapped into [-pi, pi)."""
    n = 4
    model = RangeBearing2D()
    x_hat = np.column_stack([np.zeros((n, 2)), np.full(n, np.pi - 0.005)])
    P = np.broadcast_to(np.diag([1e-4, 1e-4, 0.01]), (n, 3, 3)).copy()
    landmarks = np.array([[-3.0, 0.5], [-4.0, -1.0], [-2.0, 2.0], [-5.0, 0.0]])
    cov = np.broadcast_to(1e-4 * np.eye(2), (n, 2, 2)).copy()
    R = np.broadcast_to(np.diag([0.1**2, 0.02**2]), (n, 2, 2)).copy()
    z_hat, H_x, H_m = model.predict(x_hat, landmarks)
    z = z_hat - [0.0, 0.05]
    expected = np.empty((n, 3))
    for i in range(n):
        Q = H_m[i] @ cov[i] @ H_m[i].T + R[i]
        Sigma = np.linalg.inv(H_x[i].T @ np.linalg.inv(Q) @ H_x[i] + np.linalg.inv(P[i]))
        expected[i] = x_hat[i] + Sigma @ H_x[i].T @ np.linalg.inv(Q) @ (z[i] - z_hat[i])
    assert np.all(expected[:, 2] > np.pi)  # the unwrapped heading is past pi
    sequential = refine_proposal(x_hat, P, z, R, landmarks, cov, model).mean
    joint = joint_proposal(x_hat, P, np.arange(n), z, R, landmarks, cov, model).mean
    for mean in (sequential, joint):
        assert np.all((mean[:, 2] >= -np.pi) & (mean[:, 2] < np.pi))
        np.testing.assert_allclose(mean[:, :2], expected[:, :2], rtol=1e-7, atol=1e-12)
        np.testing.assert_allclose(wrap_angle(mean[:, 2] - expected[:, 2]), 0.0, atol=1e-9)


def test_sampled_headings_are_wrapped(rng):
    """Heading pi - 0.01 with std 0.1: about 46 % of the draws cross pi and are wrapped."""
    n = 2000
    mean = np.tile([0.0, 0.0, np.pi - 0.01], (n, 1))
    samples = sample_poses(mean, np.tile(np.diag([1e-4, 1e-4, 0.01]), (n, 1, 1)), rng)
    assert np.all((samples[:, 2] >= -np.pi) & (samples[:, 2] < np.pi))
    assert np.mean(samples[:, 2] < 0) > 0.3  # the draws past pi, now near -pi
