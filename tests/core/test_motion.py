import numpy as np
import pytest
from tolerances import JACOBIAN_RTOL, MOMENT_RTOL

from omnislam.core.jacobian import numerical_jacobian
from omnislam.core.motion import (
    MotionNoise,
    OdometryMotionModel,
    StatedOdometryMotion,
    compose_odometry,
)
from omnislam.core.se import se2_between, se2_compose, wrap_angle

MODEL = OdometryMotionModel(MotionNoise(a_vv=0.08, a_vw=0.02, a_wv=0.01, a_ww=0.06))


@pytest.mark.parametrize(
    "delta",
    [[0.30, 0.05, 0.20], [0.5, -0.1, -0.4], [-0.25, 0.02, 0.1], [0.0, 0.0, 0.5], [1e-12, 0, 0]],
)
def test_decompose_recompose_round_trip(delta):
    delta = np.asarray(delta)
    np.testing.assert_allclose(MODEL.recompose(MODEL.decompose(delta)), delta, atol=1e-12)
    # eq. 4.44 from a non-trivial pose agrees with composing the delta in SE(2)
    pose = np.array([1.0, -2.0, 2.5])
    moved = MODEL.apply(pose, MODEL.decompose(delta))
    np.testing.assert_allclose(se2_between(pose, moved), delta, atol=1e-12)


def test_component_sigmas_follow_eq_4_41():
    rot1, trans, rot2 = 0.2, 0.5, -0.3
    sigma = MODEL.component_sigmas(np.array([rot1, trans, rot2]))
    n = MODEL.noise
    expected = [
        n.a_ww * abs(rot1) + n.a_vw * trans,
        n.a_wv * (abs(rot1) + abs(rot2)) + n.a_vv * trans,
        n.a_ww * abs(rot2) + n.a_vw * trans,
    ]
    np.testing.assert_allclose(sigma, expected)
    assert np.all(MODEL.component_sigmas(np.zeros(3)) > 0), "standing still keeps a floor"


@pytest.mark.parametrize("delta", [[0.30, 0.05, 0.20], [0.8, -0.2, -0.6], [-0.3, 0.05, 0.1]])
def test_sampled_moments_match_linearised_moments(rng, delta):
    delta = np.asarray(delta)
    pose = np.array([2.0, 1.0, 0.7])
    draws = MODEL.sample(np.tile(pose, (100_000, 1)), delta, rng)
    mean, cov = MODEL.predict(pose, np.zeros((3, 3)), delta)
    residuals = draws - mean
    residuals[:, 2] = wrap_angle(residuals[:, 2])
    sample_mean = mean + residuals.mean(axis=0)
    sample_cov = np.cov(residuals.T)
    assert np.linalg.norm(sample_mean - mean) <= MOMENT_RTOL * np.linalg.norm(mean)
    assert np.linalg.norm(sample_cov - cov) <= MOMENT_RTOL * np.linalg.norm(cov)
    np.testing.assert_allclose(
        np.sqrt(np.diag(sample_cov)), np.sqrt(np.diag(cov)), rtol=MOMENT_RTOL
    )


def test_sample_delta_covariance_matches_covariance(rng):
    delta = np.array([0.4, 0.1, 0.3])
    draws = MODEL.sample_delta(delta, rng, size=100_000)
    assert draws.shape == (100_000, 3)
    cov = MODEL.covariance(delta)
    sample_cov = np.cov((draws - delta).T)
    assert np.linalg.norm(sample_cov - cov) <= MOMENT_RTOL * np.linalg.norm(cov)
    assert np.all(np.linalg.eigvalsh(cov) > 0)
    assert MODEL.sample_delta(delta, rng).shape == (3,)


def test_covariance_is_positive_definite_when_standing_still():
    for delta in ([0.0, 0.0, 0.0], [0.0, 0.0, 0.3], [1e-15, 0.0, 0.0]):
        assert np.all(np.linalg.eigvalsh(MODEL.covariance(np.asarray(delta))) > 0)


def test_sampling_is_reproducible_with_the_injected_generator():
    poses = np.zeros((50, 3))
    a = MODEL.sample(poses, np.array([0.2, 0, 0.1]), np.random.default_rng(3))
    b = MODEL.sample(poses, np.array([0.2, 0, 0.1]), np.random.default_rng(3))
    np.testing.assert_array_equal(a, b)
    assert np.ptp(a[:, 0]) > 0, "particles get independent noise"


def test_apply_jacobians(rng):
    for _ in range(10):
        pose = np.r_[rng.uniform(-3, 3, 2), rng.uniform(-np.pi, np.pi)]
        comps = np.r_[rng.uniform(-0.5, 0.5), rng.uniform(0.05, 1.0), rng.uniform(-0.5, 0.5)]
        G, V = MODEL.apply_jacobians(pose, comps)
        num_G = numerical_jacobian(lambda x, c=comps: MODEL.apply(x, c), pose)
        num_V = numerical_jacobian(lambda c, x=pose: MODEL.apply(x, c), comps)
        assert np.linalg.norm(G - num_G) <= JACOBIAN_RTOL * np.linalg.norm(num_G)
        assert np.linalg.norm(V - num_V) <= JACOBIAN_RTOL * np.linalg.norm(num_V)


def test_predict_with_zero_noise_equals_composition():
    model = OdometryMotionModel(MotionNoise(0, 0, 0, 0, min_sigma=(0, 0, 0)))
    pose, delta = np.array([1.0, 2.0, -0.5]), np.array([0.3, -0.1, 0.25])
    mean, cov = model.predict(pose, np.zeros((3, 3)), delta)
    np.testing.assert_allclose(mean, se2_compose(pose, delta), atol=1e-12)
    np.testing.assert_allclose(cov, 0.0, atol=1e-15)


def test_predict_is_vectorised_over_poses(rng):
    """Stacks of poses and covariances give the per-pose results; None is a known pose."""
    poses = np.column_stack([rng.uniform(-3, 3, (6, 2)), rng.uniform(-np.pi, np.pi, 6)])
    A = rng.normal(size=(6, 3, 3)) * 0.1
    P = A @ np.swapaxes(A, 1, 2)
    delta = np.array([0.4, 0.05, 0.2])
    means, covs = MODEL.predict(poses, P, delta)
    noise_means, noise = MODEL.predict(poses, None, delta)
    for i in range(6):
        mean, cov = MODEL.predict(poses[i], P[i], delta)
        np.testing.assert_allclose(means[i], mean, rtol=1e-15)
        np.testing.assert_allclose(covs[i], cov, rtol=1e-12)
        _, noise_i = MODEL.predict(poses[i], np.zeros((3, 3)), delta)
        np.testing.assert_allclose(noise[i], noise_i, rtol=1e-15)
    np.testing.assert_array_equal(noise_means, means)


def test_known_pose_prediction_moments_match_sampling(rng):
    """The Gaussian the FastSLAM 2.0 proposal starts from agrees with the sampler's moments."""
    motion = OdometryMotionModel(MotionNoise(a_vv=0.1, a_vw=0.05, a_wv=0.02, a_ww=0.1))
    pose = np.array([[1.0, 2.0, 0.3]])
    delta = np.array([0.4, 0.02, 0.1])
    mean, cov = motion.predict(pose, None, delta)
    samples = motion.sample(np.repeat(pose, 100_000, axis=0), delta, rng)
    np.testing.assert_allclose(samples.mean(axis=0), mean[0], atol=2e-3)
    np.testing.assert_allclose(np.cov(samples.T), cov[0], rtol=0.05, atol=1e-6)


def test_negative_coefficients_rejected():
    with pytest.raises(ValueError):
        MotionNoise(a_vv=-0.1)
    with pytest.raises(ValueError):
        MotionNoise(reference_step_m=0.0)


STEP_INVARIANT = OdometryMotionModel(
    MotionNoise(a_vv=0.08, a_vw=0.02, a_wv=0.01, a_ww=0.06, reference_step_m=0.03)
)


@pytest.mark.parametrize("components", [[0.2, 0.03, -0.1], [0.1, 0.01, 0.0], [0.5, 0.0, 0.3]])
def test_steps_up_to_the_reference_keep_eq_4_41(components):
    c = np.array(components)
    np.testing.assert_array_equal(STEP_INVARIANT.component_sigmas(c), MODEL.component_sigmas(c))


@pytest.mark.parametrize("pieces", [2, 5, 20])
def test_beyond_the_reference_a_motion_gets_the_same_variance_however_it_is_cut(pieces):
    """n pieces of a 1.2 m motion (each >= d0) sum to one step's variance; eq. 4.41 alone sums
    them to 1/n of it."""
    whole = np.array([0.3, 1.2, -0.1])
    piece = whole / pieces
    invariant = [STEP_INVARIANT.component_sigmas(c) ** 2 for c in (whole, piece)]
    np.testing.assert_allclose(pieces * invariant[1], invariant[0], rtol=1e-12)
    thesis = [MODEL.component_sigmas(c) ** 2 for c in (whole, piece)]
    np.testing.assert_allclose(pieces * thesis[1], thesis[0] / pieces, rtol=1e-12)
    # the whole step: eq. 4.41 times d0 / |trans| in variance
    np.testing.assert_allclose(invariant[0], thesis[0] * 0.03 / 1.2, rtol=1e-12)


def test_step_invariant_sigmas_agree_on_the_scalar_and_vector_paths(rng):
    components = rng.normal(size=(50, 3)) * [0.3, 0.5, 0.3]
    vector = STEP_INVARIANT.component_sigmas(components)
    scalar = np.array([STEP_INVARIANT.component_sigmas(c) for c in components])
    np.testing.assert_allclose(vector, scalar, rtol=1e-14)
    assert np.all(STEP_INVARIANT.component_sigmas(np.zeros(3)) > 0), "standing still: the floor"


def test_composed_odometry_covariance_matches_sampled_composition(rng):
    """Five noisy steps drawn from the motion model and composed: the chain of
    ``compose_odometry`` gives their mean and covariance (first order, small noise)."""
    steps = np.array(
        [
            [0.05, 0.0, 0.02],
            [0.06, 0.005, 0.1],
            [0.04, -0.002, 0.15],
            [0.05, 0.0, 0.08],
            [0.07, 0.01, -0.05],
        ]
    )
    delta, cov = steps[0], MODEL.covariance(steps[0])
    for step in steps[1:]:
        delta, cov = compose_odometry(delta, cov, step, MODEL.covariance(step))
    draws = MODEL.sample_delta(steps[0], rng, size=100_000)
    for step in steps[1:]:
        draws = se2_compose(draws, MODEL.sample_delta(step, rng, size=100_000))
    exact = steps[0]
    for step in steps[1:]:
        exact = se2_compose(exact, step)
    np.testing.assert_allclose(delta, exact, atol=1e-12)
    errors = draws - delta
    errors[:, 2] = wrap_angle(errors[:, 2])
    sample_cov = np.cov(errors.T)
    assert np.linalg.norm(sample_cov - cov) <= 2 * MOMENT_RTOL * np.linalg.norm(cov)
    np.testing.assert_allclose(cov, cov.T)
    # composing with an exactly known first delta only moves the second's covariance
    _, moved = compose_odometry(steps[0], np.zeros((3, 3)), steps[1], MODEL.covariance(steps[1]))
    c, s = np.cos(steps[0, 2]), np.sin(steps[0, 2])
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    np.testing.assert_allclose(moved, R @ MODEL.covariance(steps[1]) @ R.T, atol=1e-15)


def test_stated_odometry_motion_samples_and_predicts_the_stated_covariance():
    """``StatedOdometryMotion``: draws from a rotated pose spread as J_b C J_b^T, the
    prediction's covariance, around x (+) delta."""
    delta = np.array([0.4, 0.05, 0.2])
    C = np.array([[4e-4, 1e-4, 0.0], [1e-4, 9e-4, 2e-4], [0.0, 2e-4, 1e-3]])
    model = StatedOdometryMotion(delta, C)
    start = np.array([1.0, -2.0, 2.0])
    mean, cov = model.predict(start, None, delta)
    np.testing.assert_allclose(mean, se2_compose(start, delta))
    c, s = np.cos(2.0), np.sin(2.0)
    J = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    np.testing.assert_allclose(cov, J @ C @ J.T, atol=1e-15)
    draws = model.sample(np.tile(start, (20000, 1)), delta, np.random.default_rng(0))
    np.testing.assert_allclose(draws.mean(axis=0), mean, atol=1e-3)
    # 20000 draws: each covariance entry within ~1 % of the diagonal's scale (1 sigma)
    np.testing.assert_allclose(np.cov(draws.T), cov, atol=0.05 * np.max(np.diag(cov)))
    P = np.array([[0.01, 0.002, 0.001], [0.002, 0.02, -0.003], [0.001, -0.003, 0.03]])
    _, cov_p = model.predict(start, P, delta)
    # the prior's uncertainty is carried through the composition's numerical pose Jacobian
    J_a = numerical_jacobian(lambda x: se2_compose(x, delta), start)
    np.testing.assert_allclose(cov_p, J_a @ P @ J_a.T + cov, rtol=JACOBIAN_RTOL, atol=1e-15)


def test_reversing_is_decomposed_as_a_short_turn_and_a_negative_translation():
    """dx < 0: rot1 = atan2(-dy, -dx), trans = -|d| (module docstring), on the scalar and the
    vector paths, so a motion reversed costs the noise of the same motion driven forwards
    (not a rot1 near pi)."""
    reverse = np.array([[-0.3, 0.05, 0.1], [-0.6, -0.2, -0.4]])
    forward = reverse * [-1.0, -1.0, 1.0]
    rot1 = np.arctan2(-reverse[:, 1], -reverse[:, 0])
    expected = np.column_stack(
        [rot1, -np.hypot(reverse[:, 0], reverse[:, 1]), wrap_angle(reverse[:, 2] - rot1)]
    )
    for k in range(2):
        np.testing.assert_allclose(MODEL.decompose(reverse[k]), expected[k], atol=1e-15)
        np.testing.assert_allclose(
            MODEL.component_sigmas(MODEL.decompose(reverse[k])),
            MODEL.component_sigmas(MODEL.decompose(forward[k])),
            rtol=1e-12,
        )
    np.testing.assert_allclose(MODEL.decompose(reverse), expected, atol=1e-15)
