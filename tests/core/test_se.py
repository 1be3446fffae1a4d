import numpy as np
from tolerances import JACOBIAN_RTOL

from omnislam.core.jacobian import numerical_jacobian
from omnislam.core.se import (
    quat_wxyz_from_se3,
    se2_between,
    se2_compose,
    se2_compose_jacobians,
    se2_from_matrix,
    se2_from_se3,
    se2_inverse,
    se2_rotate_vectors,
    se2_to_matrix,
    se3_exp,
    se3_from_se2,
    se3_from_xyz_quat,
    se3_inverse,
    se3_log,
    wrap_angle,
)


def _random_se2(rng, n):
    return np.column_stack([rng.uniform(-5, 5, (n, 2)), rng.uniform(-np.pi, np.pi, n)])


def test_wrap_angle_range_and_identity(rng):
    angles = rng.uniform(-50, 50, 10_000)
    wrapped = wrap_angle(angles)
    assert np.all(wrapped >= -np.pi) and np.all(wrapped < np.pi)
    np.testing.assert_allclose(np.sin(wrapped), np.sin(angles), atol=1e-12)
    np.testing.assert_allclose(np.cos(wrapped), np.cos(angles), atol=1e-12)


def test_se2_compose_matches_matrix_product(rng):
    a, b = _random_se2(rng, 500), _random_se2(rng, 500)
    expected = se2_from_matrix(se2_to_matrix(a) @ se2_to_matrix(b))
    np.testing.assert_allclose(se2_compose(a, b), expected, atol=1e-12)


def test_se2_inverse_and_between(rng):
    a, b = _random_se2(rng, 200), _random_se2(rng, 200)
    np.testing.assert_allclose(se2_compose(a, se2_inverse(a)), np.zeros((200, 3)), atol=1e-12)
    np.testing.assert_allclose(se2_compose(a, se2_between(a, b)), b, atol=1e-12)


def test_se2_compose_jacobians(rng):
    for a, b in zip(_random_se2(rng, 20), _random_se2(rng, 20), strict=True):
        J_a, J_b = se2_compose_jacobians(a, b)
        num_a = numerical_jacobian(lambda x, b=b: se2_compose(x, b), a)
        num_b = numerical_jacobian(lambda x, a=a: se2_compose(a, x), b)
        for analytic, numeric in ((J_a, num_a), (J_b, num_b)):
            err = np.linalg.norm(analytic - numeric) / np.linalg.norm(numeric)
            assert err < JACOBIAN_RTOL


def test_se3_exp_log_round_trip(rng):
    xi = rng.normal(0, 0.8, (2000, 6))
    xi = xi[np.linalg.norm(xi[:, 3:], axis=1) < np.pi - 1e-3]
    np.testing.assert_allclose(se3_log(se3_exp(xi)), xi, atol=1e-9)
    tiny = rng.normal(0, 1e-10, (10, 6))
    np.testing.assert_allclose(se3_log(se3_exp(tiny)), tiny, atol=1e-15)


def test_se3_inverse_and_planar_embedding(rng):
    poses = _random_se2(rng, 100)
    T = se3_from_se2(poses, z=0.3)
    np.testing.assert_allclose(T @ se3_inverse(T), np.broadcast_to(np.eye(4), T.shape), atol=1e-12)
    np.testing.assert_allclose(se2_from_se3(T), poses, atol=1e-12)


def test_quaternion_round_trip(rng):
    T = se3_exp(rng.normal(0, 1.0, (500, 6)))
    q = quat_wxyz_from_se3(T)
    assert np.all(q[:, 0] >= 0)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(se3_from_xyz_quat(T[:, :3, 3], q), T, atol=1e-12)


def test_se2_rotate_vectors_is_the_rotation_of_the_planar_pose(rng):
    poses = rng.normal(size=(20, 3)) * [5.0, 5.0, 3.0]
    vectors = rng.normal(size=(20, 3))
    expected = np.einsum("nij,nj->ni", se3_from_se2(poses)[:, :3, :3], vectors)
    np.testing.assert_allclose(se2_rotate_vectors(poses, vectors), expected, atol=1e-12)
    np.testing.assert_allclose(se2_rotate_vectors(poses[3], vectors[3]), expected[3], atol=1e-12)


def test_se2_integrate_composes_steps_after_the_first_frame():
    from omnislam.core.se import se2_compose, se2_integrate

    rng = np.random.default_rng(3)
    deltas = rng.normal(scale=0.3, size=(6, 3))
    start = np.array([1.0, -2.0, 0.4])
    poses = se2_integrate(deltas, start)
    assert np.array_equal(poses[0], start)
    pose = start
    for k in range(1, 6):
        pose = se2_compose(pose, deltas[k])
        assert np.array_equal(poses[k], pose)  # bit-for-bit the incremental composition
    assert se2_integrate(np.zeros((0, 3))).shape == (0, 3)
