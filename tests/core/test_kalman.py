"""The Kalman (EKF) update against its information form, dense references and the numerical
Jacobian of the inverse model."""

import numpy as np
import pytest

from omnislam.core.batch_linalg import entry_major, stack_major
from omnislam.core.jacobian import numerical_jacobian
from omnislam.core.kalman import ekf_update, initialize_from_inverse, kalman_update
from omnislam.core.measurement import RangeAzimuthElevation3D, RangeBearing2D

MODELS = [RangeBearing2D(), RangeAzimuthElevation3D(0.8)]


def _case(rng, model, n=5):
    d, k = model.dim_landmark, model.dim_z
    poses = np.column_stack([rng.normal(0, 1, (n, 2)), rng.uniform(-np.pi, np.pi, n)])
    landmarks = np.zeros((n, d))
    landmarks[:, :2] = poses[:, :2] + rng.uniform(2, 5, (n, 2))
    if d == 3:
        landmarks[:, 2] = rng.uniform(0.5, 2.5, n)
    A = rng.normal(size=(n, d, d)) * 0.1
    cov = A @ np.swapaxes(A, 1, 2) + 0.01 * np.eye(d)
    R = np.broadcast_to(np.diag([0.1**2, 0.02**2, 0.03**2][:k]), (n, k, k)).copy()
    z, _, _ = model.predict(poses, landmarks + rng.normal(0, 0.1, (n, d)))
    return poses, landmarks, cov, z, R


@pytest.mark.parametrize("model", MODELS, ids=lambda m: type(m).__name__)
@pytest.mark.parametrize("joseph", [False, True])
def test_ekf_update_matches_information_form(rng, joseph, model):
    """Sigma' = (Sigma^-1 + H^T R^-1 H)^-1, mu' = mu + Sigma' H^T R^-1 y (thesis 4.35-4.37)."""
    poses, landmarks, cov, z, R = _case(rng, model)
    update = ekf_update(poses, landmarks, cov, z, R, model, joseph=joseph)
    z_hat, _, H = model.predict(poses, landmarks)
    y = model.residual(z, z_hat)
    for i in range(len(z)):
        info = np.linalg.inv(cov[i]) + H[i].T @ np.linalg.inv(R[i]) @ H[i]
        Sigma = np.linalg.inv(info)
        np.testing.assert_allclose(update.cov[i], Sigma, rtol=1e-9, atol=1e-12)
        mu = landmarks[i] + Sigma @ H[i].T @ np.linalg.inv(R[i]) @ y[i]
        np.testing.assert_allclose(update.mean[i], mu, rtol=1e-9)
        S = H[i] @ cov[i] @ H[i].T + R[i]
        ll = -0.5 * (y[i] @ np.linalg.solve(S, y[i]) + np.log(np.linalg.det(2 * np.pi * S)))
        np.testing.assert_allclose(update.log_likelihood[i], ll, rtol=1e-9)
        np.testing.assert_allclose(update.mahalanobis[i], y[i] @ np.linalg.solve(S, y[i]))


def test_a_bearing_across_pi_updates_like_the_same_bearing_unwrapped():
    """A landmark behind the robot is predicted at bearing pi - 0.01; a measured -pi + 0.01 is
    the same direction as pi + 0.01, so both must give the same update (innovation 0.02 rad)."""
    pose = np.array([[0.0, 0.0, 0.0]])
    landmark = np.array([[-4.0, 4.0 * np.tan(0.01)]])  # bearing pi - 0.01
    cov = 0.04 * np.eye(2)[None]
    R = np.diag([0.1**2, 0.02**2])[None]
    model = RangeBearing2D()
    across = ekf_update(pose, landmark, cov, np.array([[4.0, -np.pi + 0.01]]), R, model)
    unwrapped = ekf_update(pose, landmark, cov, np.array([[4.0, np.pi + 0.01]]), R, model)
    np.testing.assert_allclose(across.mean, unwrapped.mean, rtol=1e-12)
    np.testing.assert_allclose(across.mahalanobis, unwrapped.mahalanobis, rtol=1e-9)
    assert across.mahalanobis[0] < 9.0  # 0.02 rad is within a few sigma, not 2 pi away


@pytest.mark.parametrize(("n", "k"), [(2, 1), (3, 2), (3, 3), (2, 3)])
def test_kalman_update_matches_the_dense_kalman_filter(rng, n, k):
    """Plain and Joseph forms against K = P H^T S^-1, P' = (I - K H) P written with numpy."""
    N = 6
    A = rng.normal(size=(N, n, n))
    P = A @ np.swapaxes(A, 1, 2) + 0.1 * np.eye(n)
    H = rng.normal(size=(N, k, n))
    B = rng.normal(size=(N, k, k)) * 0.3
    R = B @ np.swapaxes(B, 1, 2) + 0.05 * np.eye(k)
    y = rng.normal(size=(N, k))
    for joseph in (False, True):
        step = kalman_update(
            entry_major(P), entry_major(H), entry_major(R), entry_major(y[..., None]), joseph=joseph
        )
        for i in range(N):
            S = H[i] @ P[i] @ H[i].T + R[i]
            K = P[i] @ H[i].T @ np.linalg.inv(S)
            np.testing.assert_allclose(stack_major(step.mean_step)[i, :, 0], K @ y[i], rtol=1e-9)
            expected = (np.eye(n) - K @ H[i]) @ P[i]
            np.testing.assert_allclose(stack_major(step.cov)[i], expected, rtol=1e-8, atol=1e-12)
            np.testing.assert_allclose(step.logdet_S[i], np.linalg.slogdet(S)[1], rtol=1e-10)
            np.testing.assert_allclose(step.mahalanobis[i], y[i] @ np.linalg.solve(S, y[i]))
        np.testing.assert_array_equal(step.cov, np.swapaxes(step.cov, 0, 1))


@pytest.mark.parametrize("model", MODELS, ids=lambda m: type(m).__name__)
def test_first_estimate_propagates_the_noise_through_the_numerical_inverse_jacobian(rng, model):
    """Sigma = J_z R J_z^T (thesis 4.26-4.27) with J_z checked against central differences."""
    k = model.dim_z
    pose = np.array([0.5, -1.0, 0.7])
    z = np.array([3.0, 0.4, 0.2][:k])
    R = np.diag([0.05**2, 0.01**2, 0.02**2][:k])
    mean, cov = initialize_from_inverse(pose[None], z[None], R[None], model.inverse)
    J = numerical_jacobian(lambda zz: model.inverse(pose, zz)[0], z)
    np.testing.assert_allclose(mean[0], model.inverse(pose, z)[0])
    np.testing.assert_allclose(cov[0], J @ R @ J.T, rtol=1e-6, atol=1e-14)
    z_back, _, _ = model.predict(pose, mean[0])
    np.testing.assert_allclose(model.residual(z_back, z), 0.0, atol=1e-12)
