"""The EKF-SLAM Gaussian against a dense textbook EKF written plainly here (the oracle), the
augmentation against numerical Jacobians, and P symmetric PSD over a 10 000-step run."""

from __future__ import annotations

import numpy as np
import pytest
from ekfslam_scenario import JACOBIAN_ATOL, NOISE, ORACLE_ATOL, make_scenario

from omnislam.core.jacobian import numerical_jacobian
from omnislam.core.motion import OdometryMotionModel
from omnislam.core.se import se2_compose, wrap_angle
from omnislam.ekfslam import EKFSLAM, EKFSLAMConfig, SlamGaussian

N_LANDMARKS = 5


def random_state(
    rng: np.random.Generator, n: int = N_LANDMARKS, heading: float = 0.4
) -> SlamGaussian:
    """A state with n landmarks and a random SPD covariance (capacity smaller than n, so the
    arrays had to grow)."""
    state = SlamGaussian(np.array([0.3, -0.2, heading]), np.eye(3) * 0.01, capacity=2)
    for _ in range(n):
        state.augment(np.array([rng.uniform(2, 6), rng.uniform(-np.pi, np.pi)]), np.eye(2) * 0.01)
    d = state.dim
    M = rng.standard_normal((d, d)) * 0.1
    state.cov = M @ M.T + 0.01 * np.eye(d)
    return state


# -- the oracle: a dense EKF as in the textbook ---------------------------------------------------


def dense_predict(x, P, delta, sigma_u):
    """X' = f(X, u) with F = dX'/dX = blockdiag(A, I), P' = F P F^T + G Sigma_u G^T."""
    theta = x[2]
    c, s = np.cos(theta), np.sin(theta)
    dx, dy = delta[0], delta[1]
    d = len(x)
    F = np.eye(d)
    F[0, 2] = -s * dx - c * dy
    F[1, 2] = c * dx - s * dy
    G = np.zeros((d, 3))
    G[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
    x_new = x.copy()
    x_new[:3] = se2_compose(x[:3], delta)
    return x_new, F @ P @ F.T + G @ sigma_u @ G.T


def dense_update(x, P, slot, z, R):
    """The tutorial's "Passo 2" with a dense H_i (a b c ... -a -b) and the Joseph form."""
    d = len(x)
    j = 3 + 2 * slot
    dx, dy = x[j] - x[0], x[j + 1] - x[1]
    q = dx * dx + dy * dy
    r = np.sqrt(q)
    h = np.array([r, wrap_angle(np.arctan2(dy, dx) - x[2])])
    a, b = -dx / r, -dy / r
    dd, e = dy / q, -dx / q
    H = np.zeros((2, d))
    H[:, :3] = [[a, b, 0.0], [dd, e, -1.0]]
    H[:, j : j + 2] = [[-a, -b], [-dd, -e]]
    S = H @ P @ H.T + R
    K = P @ H.T @ np.linalg.inv(S)
    nu = z - h
    nu[1] = wrap_angle(nu[1])
    x_new = x + K @ nu
    x_new[2] = wrap_angle(x_new[2])
    I_KH = np.eye(d) - K @ H
    return x_new, I_KH @ P @ I_KH.T + K @ R @ K.T


# -- tests ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("delta_cov", [None, np.diag([0.02, 0.01, 0.005]) ** 2])
def test_prediction_equals_dense_ekf(rng, delta_cov):
    state = random_state(rng)
    motion = OdometryMotionModel(NOISE)
    delta = np.array([0.4, 0.05, 0.1])
    sigma_u = motion.covariance(delta) if delta_cov is None else delta_cov
    x_ref, P_ref = dense_predict(state.mean.copy(), state.cov.copy(), delta, sigma_u)
    state.predict(motion, delta, delta_cov)
    np.testing.assert_allclose(state.mean, x_ref, rtol=0, atol=ORACLE_ATOL)
    np.testing.assert_allclose(state.cov, P_ref, rtol=0, atol=ORACLE_ATOL)
    assert np.array_equal(state.cov, state.cov.T)


@pytest.mark.parametrize("heading", [0.4, np.pi - 0.005])
def test_sparse_update_equals_dense_joseph_ekf(rng, heading):
    """Near pi the first update turns the heading past pi: the state must wrap it too."""
    state = random_state(rng, heading=heading)
    R = np.diag([0.05, 0.01]) ** 2
    x, P = state.mean.copy(), state.cov.copy()
    headings = []
    for slot in (3, 0, 4):  # several sequential updates, each against the oracle's
        lm = state.mean[3 + 2 * slot : 5 + 2 * slot]
        rel = lm - state.mean[:2]
        z = np.array([np.hypot(*rel) + 0.1, np.arctan2(rel[1], rel[0]) - state.mean[2] - 0.05])
        x, P = dense_update(x, P, slot, z, R)
        state.update(slot, z, R)
        np.testing.assert_allclose(state.mean, x, rtol=0, atol=ORACLE_ATOL)
        np.testing.assert_allclose(state.cov, P, rtol=0, atol=ORACLE_ATOL)
        assert np.array_equal(state.cov, state.cov.T)  # stored as one triangle
        headings.append(x[2])
    assert (np.min(headings) < 0) == (heading > 3)  # the case near pi did cross it


@pytest.mark.parametrize("heading", [0.4, np.pi - 0.005])
def test_a_batch_of_one_sighting_is_the_sequential_update(heading):
    """``update_batch`` of one sighting is ``update`` exactly, the heading wrapped alike."""
    a, b = (random_state(np.random.default_rng(3), heading=heading) for _ in range(2))
    R = np.diag([0.05, 0.01]) ** 2
    rel = a.mean[9:11] - a.mean[:2]  # slot 3
    z = np.array([np.hypot(*rel) + 0.1, np.arctan2(rel[1], rel[0]) - a.mean[2] - 0.05])
    a.update_batch(np.array([3]), z[None], R[None])
    b.update(3, z, R)
    np.testing.assert_allclose(a.mean, b.mean, rtol=0, atol=ORACLE_ATOL)
    np.testing.assert_allclose(a.cov, b.cov, rtol=0, atol=ORACLE_ATOL)
    assert -np.pi <= a.mean[2] < np.pi


def test_mahalanobis_of_all_landmarks_equals_dense_innovation(rng):
    state = random_state(rng)
    R = np.diag([0.05, 0.01]) ** 2
    z = np.array([3.0, 0.2])
    d2, nu = state.mahalanobis_all(z, R, np.arange(N_LANDMARKS))
    for slot in range(N_LANDMARKS):
        nu_i, Hs, idx = state.innovation(slot, z)
        S = state.innovation_covariance(Hs, idx, R)
        np.testing.assert_allclose(nu[slot], nu_i, atol=1e-12)
        np.testing.assert_allclose(d2[slot], nu_i @ np.linalg.solve(S, nu_i), rtol=1e-10)


def test_augmentation_equals_numerical_jacobian_propagation(rng):
    """P_aug = J blockdiag(P, R) J^T with J the numerical Jacobian of (X, z) -> [X; g(x_r, z)]."""
    state = random_state(rng, n=3)
    x, P = state.mean.copy(), state.cov.copy()
    z = np.array([4.0, 0.7])
    R = np.diag([0.1, 0.02]) ** 2
    d = len(x)

    def augmented(xz: np.ndarray) -> np.ndarray:
        pose, (r, b) = xz[:3], xz[d:]
        point = pose[:2] + r * np.array([np.cos(pose[2] + b), np.sin(pose[2] + b)])
        return np.concatenate([xz[:d], point])

    J = numerical_jacobian(augmented, np.concatenate([x, z]))
    joint = np.zeros((d + 2, d + 2))
    joint[:d, :d], joint[d:, d:] = P, R
    slot = state.augment(z, R)
    assert slot == 3
    np.testing.assert_allclose(state.mean, augmented(np.concatenate([x, z])), atol=1e-12)
    np.testing.assert_allclose(state.cov, J @ joint @ J.T, rtol=0, atol=JACOBIAN_ATOL)
    # the core Jacobians J_xr, J_z used by the augmentation, against numerical ones
    _, J_xr, J_z = state.model.inverse(x[:3], z)
    np.testing.assert_allclose(J_xr, J[d:, :3], atol=JACOBIAN_ATOL)
    np.testing.assert_allclose(J_z, J[d:, d:], atol=JACOBIAN_ATOL)


@pytest.mark.slow
def test_covariance_stays_symmetric_psd_over_10000_steps():
    scenario = make_scenario(seed=7, steps=10_000)
    ekf = EKFSLAM(EKFSLAMConfig(motion_noise=NOISE))
    worst = 0.0
    for k, frame in enumerate(scenario.frames):
        ekf.step(frame)
        if k % 50 == 0 or k == len(scenario.frames) - 1:
            P = ekf.state.cov
            assert np.array_equal(P, P.T), f"P not symmetric at step {k}"
            eig = np.linalg.eigvalsh(P)
            worst = min(worst, eig[0] / eig[-1])
    assert ekf.state.n_landmarks == len(scenario.landmarks_w)
    assert worst >= -1e-12, f"P lost positive semi-definiteness: min/max eigenvalue {worst}"


def test_block_and_columns_read_the_stored_triangle_as_the_whole_matrix(rng):
    state = random_state(rng)
    P = state.cov
    assert np.array_equal(P, P.T)
    idx = np.array([7, 0, 4, 12, 2])  # any order, below and above each other
    assert np.array_equal(state.block(idx), P[np.ix_(idx, idx)])
    assert np.array_equal(state.columns(idx), P[:, idx])
    assert np.array_equal(state.pose_cov, P[:3, :3])
    slots = np.array([4, 1])
    expected = np.stack([P[3 + 2 * s : 5 + 2 * s, 3 + 2 * s : 5 + 2 * s] for s in slots])
    assert np.array_equal(state.landmark_covariances(slots), expected)


def test_a_gated_update_tests_its_own_innovation_and_leaves_a_rejected_sighting_out(rng):
    state = random_state(rng)
    R = np.diag([0.05, 0.01]) ** 2
    lm = state.mean[3 + 2 * 2 : 5 + 2 * 2]
    rel = lm - state.mean[:2]
    z = np.array([np.hypot(*rel) + 0.05, np.arctan2(rel[1], rel[0]) - state.mean[2]])
    d2, _ = state.mahalanobis_all(z, R, np.array([2]))
    x, P = state.mean.copy(), state.cov
    assert state.update(2, z, R, gate=0.999 * d2[0]) is None  # just beyond the gate
    assert np.array_equal(state.mean, x) and np.array_equal(state.cov, P)
    gated = state.update(2, z, R, gate=1.001 * d2[0])  # just inside it: the plain update
    plain = random_state(np.random.default_rng(0))
    plain.mean[:] = x
    plain.cov = P
    expected = plain.update(2, z, R)
    assert gated is not None and expected is not None
    np.testing.assert_array_equal(state.mean, plain.mean)
    np.testing.assert_array_equal(state.cov, plain.cov)
