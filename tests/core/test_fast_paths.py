"""The fast paths of ``omnislam.core`` against the reference formulas they replace."""

import numpy as np
import pytest

from omnislam.core.measurement import (
    Bearing2D,
    BearingElevation3D,
    RangeAzimuthElevation3D,
    RangeBearing2D,
)
from omnislam.core.motion import MIN_TRANSLATION_M, MotionNoise, OdometryMotionModel
from omnislam.core.se import wrap_angle, wrap_angle_inplace

PI = np.pi


def _reference_wrap(angle):
    return (np.asarray(angle, dtype=float) + np.pi) % (2.0 * np.pi) - np.pi


def _edge_angles():
    """Angles at and next to every boundary of the masked corrections."""
    centres = np.array([-5 * PI, -4 * PI, -3 * PI, -2 * PI, -PI, 0.0, PI, 2 * PI, 3 * PI, 4 * PI])
    near = [centres]
    for direction in (-np.inf, np.inf):
        step = centres
        for _ in range(3):
            step = np.nextafter(step, direction)
            near.append(step)
    return np.concatenate([*near, [0.0, -0.0, 1e-300, -1e-300, 1e-17, -1e-17]])


@pytest.mark.parametrize("size", [1, 10, 511, 512, 1000, 10_000])
@pytest.mark.parametrize("scale", [PI, 2 * PI, 3 * PI, 50.0, 1e6])
def test_wrap_angle_is_bitwise_the_reference(rng, size, scale):
    angles = np.concatenate([rng.uniform(-scale, scale, size), _edge_angles()])
    rng.shuffle(angles)
    for a in (angles, angles[:size], angles[::2]):
        expected = _reference_wrap(a)
        np.testing.assert_array_equal(wrap_angle(a), expected)
        copy = a.copy()
        assert wrap_angle_inplace(copy) is copy
        np.testing.assert_array_equal(copy, expected)
    assert np.all(wrap_angle(angles) >= -PI) and np.all(wrap_angle(angles) <= PI)


def test_wrap_angle_special_values_and_shapes():
    special = np.array([np.nan, np.inf, -np.inf, 1.0] * 100)
    with np.errstate(invalid="ignore"):
        np.testing.assert_array_equal(wrap_angle(special), _reference_wrap(special))
    grid = np.linspace(-10, 10, 600).reshape(20, 30)
    np.testing.assert_array_equal(wrap_angle(grid), _reference_wrap(grid))
    scalar = wrap_angle(7.0)
    assert isinstance(scalar, np.floating) and scalar == _reference_wrap(7.0)
    assert wrap_angle([4.0, -4.0]).tolist() == _reference_wrap([4.0, -4.0]).tolist()
    source = np.full(300, 5.0)
    wrap_angle(source)
    assert np.all(source == 5.0)  # wrap_angle never writes into its input


def _reference_range_bearing(wTr, landmarks_w):
    """RangeBearing2D.predict as the textbook expressions (the implementation before the
    in-place rewrite)."""
    wTr = np.asarray(wTr, dtype=float)
    landmarks_w = np.asarray(landmarks_w, dtype=float)
    dx = landmarks_w[..., 0] - wTr[..., 0]
    dy = landmarks_w[..., 1] - wTr[..., 1]
    q = np.maximum(dx * dx + dy * dy, 1e-12)
    r = np.sqrt(q)
    z = np.stack([r, _reference_wrap(np.arctan2(dy, dx) - wTr[..., 2])], axis=-1)
    H_l = np.empty((*z.shape[:-1], 2, 2))
    H_l[..., 0, 0], H_l[..., 0, 1] = dx / r, dy / r
    H_l[..., 1, 0], H_l[..., 1, 1] = -dy / q, dx / q
    H_p = np.zeros((*z.shape[:-1], 2, 3))
    H_p[..., :, :2] = -H_l
    H_p[..., 1, 2] = -1.0
    return z, H_p, H_l


def _random_poses(rng, shape, heading_scale=PI):
    xy = rng.uniform(-10, 10, (*shape, 2))
    return np.concatenate([xy, rng.uniform(-heading_scale, heading_scale, (*shape, 1))], axis=-1)


@pytest.mark.parametrize(
    ("pose_shape", "landmark_shape"),
    [((), ()), ((5,), (5,)), ((700,), (700,)), ((300, 1), (300, 8)), ((4, 1), (4, 3)), ((), (9,))],
)
@pytest.mark.parametrize("heading_scale", [PI, 3 * PI, 100.0])
def test_range_bearing_predict_is_bitwise_the_reference(
    rng, pose_shape, landmark_shape, heading_scale
):
    poses = _random_poses(rng, pose_shape, heading_scale)
    landmarks = rng.uniform(-10, 10, (*landmark_shape, 2))
    if landmarks.ndim > 1:
        landmarks[0] = poses.reshape(-1, 3)[0, :2]  # a landmark on the robot: the eps floor
    for lm in (landmarks, np.concatenate([landmarks, np.ones((*landmark_shape, 1))], axis=-1)):
        got = RangeBearing2D().predict(poses, lm)
        for a, b in zip(got, _reference_range_bearing(poses, lm), strict=True):
            assert a.shape == b.shape
            np.testing.assert_array_equal(a, b)
        z, H_p, H_l = RangeBearing2D().predict(poses, lm, jacobians=False)
        assert H_p is None and H_l is None
        np.testing.assert_array_equal(z, got[0])


@pytest.mark.parametrize(
    "model", [Bearing2D(), BearingElevation3D(0.3), RangeAzimuthElevation3D(0.3)]
)
def test_other_models_skip_jacobians_on_request(rng, model):
    poses = _random_poses(rng, (50,))
    landmarks = rng.uniform(-10, 10, (50, model.dim_landmark))
    z, _, _ = model.predict(poses, landmarks)
    z_only = model.predict(poses, landmarks, jacobians=False)
    assert z_only[1] is None and z_only[2] is None
    np.testing.assert_array_equal(z_only[0], z)


@pytest.mark.parametrize(
    "model", [RangeBearing2D(), Bearing2D(), BearingElevation3D(), RangeAzimuthElevation3D()]
)
@pytest.mark.parametrize("shape", [(), (7,), (600,), (20, 40)])
def test_residual_is_bitwise_the_reference(rng, model, shape):
    k = model.dim_z
    measured = rng.uniform(-4 * PI, 4 * PI, (*shape, k))
    predicted = rng.uniform(-PI, PI, (*shape, k))
    mask = np.asarray(model.angular)
    d = measured - predicted
    np.testing.assert_array_equal(
        model.residual(measured, predicted), np.where(mask, _reference_wrap(d), d)
    )
    # broadcasting measurements against predictions, as data association does
    z = measured.reshape(-1, k)[:3]
    z_hat = predicted.reshape(-1, k)[:5]
    d = z[None, :, None, :] - z_hat[:, None, None, :]
    np.testing.assert_array_equal(
        model.residual(z[None, :, None, :], z_hat[:, None, None, :]),
        np.where(mask, _reference_wrap(d), d),
    )


NOISE = MotionNoise(a_vv=0.05, a_vw=0.02, a_wv=0.01, a_ww=0.05)


def _reference_decompose(delta_r):
    delta_r = np.asarray(delta_r, dtype=float)
    dx, dy, dtheta = delta_r[..., 0], delta_r[..., 1], delta_r[..., 2]
    trans = np.hypot(dx, dy)
    sign = np.where(dx < 0, -1.0, 1.0)
    rot1 = np.where(trans > MIN_TRANSLATION_M, np.arctan2(sign * dy, sign * dx), 0.0)
    return np.stack([rot1, sign * trans, _reference_wrap(dtheta - rot1)], axis=-1)


def _reference_sigmas(noise, components):
    c = np.abs(np.asarray(components, dtype=float))
    rot1, trans, rot2 = c[..., 0], c[..., 1], c[..., 2]
    sigma = np.stack(
        [
            noise.a_ww * rot1 + noise.a_vw * trans,
            noise.a_wv * (rot1 + rot2) + noise.a_vv * trans,
            noise.a_ww * rot2 + noise.a_vw * trans,
        ],
        axis=-1,
    )
    return np.maximum(sigma, np.asarray(noise.min_sigma))


def _reference_apply(wTr, components):
    heading = wTr[..., 2] + components[..., 0]
    x = wTr[..., 0] + components[..., 1] * np.cos(heading)
    y = wTr[..., 1] + components[..., 1] * np.sin(heading)
    theta = _reference_wrap(wTr[..., 2] + components[..., 0] + components[..., 2])
    return np.stack(np.broadcast_arrays(x, y, theta), axis=-1)


def _odometry_deltas(rng, n):
    deltas = np.column_stack(
        [rng.normal(0, 0.5, n), rng.normal(0, 0.2, n), rng.uniform(-3 * PI, 3 * PI, n)]
    )
    special = [
        [0.0, 0.0, 0.1],
        [-0.0, 0.0, -PI],
        [1e-12, -1e-12, PI],
        [-0.3, 0.01, 0.0],
        [-0.3, -0.0, 2 * PI],
        [0.3, 0.0, -2 * PI],
        [0.0, 0.2, 0.0],
    ]
    return np.concatenate([deltas, special])


def test_decompose_and_sigmas_of_one_delta_are_bitwise_the_reference(rng):
    model = OdometryMotionModel(NOISE)
    zero_floor = OdometryMotionModel(MotionNoise(0.1, 0.0, 0.0, 0.1, min_sigma=(0.0, 0.0, 0.0)))
    for delta in _odometry_deltas(rng, 2000):
        components = model.decompose(delta)
        np.testing.assert_array_equal(components, _reference_decompose(delta))
        for m in (model, zero_floor):
            np.testing.assert_array_equal(
                m.component_sigmas(components), _reference_sigmas(m.noise, components)
            )
    many = _odometry_deltas(rng, 50)
    np.testing.assert_array_equal(model.decompose(many), _reference_decompose(many))


@pytest.mark.parametrize(
    ("pose_shape", "component_shape"), [((), ()), ((100,), (100,)), ((700,), ()), ((), (9,))]
)
def test_apply_is_bitwise_the_reference(rng, pose_shape, component_shape):
    poses = _random_poses(rng, pose_shape, 3 * PI)
    components = np.concatenate(
        [rng.normal(0, 1, (*component_shape, 2)), rng.uniform(-PI, PI, (*component_shape, 1))],
        axis=-1,
    )
    got = OdometryMotionModel.apply(poses, components)
    expected = _reference_apply(poses, components)
    assert got.shape == expected.shape
    np.testing.assert_array_equal(got, expected)


@pytest.mark.parametrize("n_poses", [1, 100, 1000])
def test_sample_draws_the_same_stream_and_numbers(rng, n_poses):
    model = OdometryMotionModel(NOISE)
    poses = _random_poses(rng, (n_poses,))
    for delta in _odometry_deltas(rng, 20):
        a, b = np.random.default_rng(11), np.random.default_rng(11)
        got = model.sample(poses, delta, a)
        components = _reference_decompose(delta)
        noisy = components + _reference_sigmas(NOISE, components) * b.standard_normal((n_poses, 3))
        np.testing.assert_array_equal(got, _reference_apply(poses, noisy))
        assert a.random() == b.random()  # the generators are in the same state afterwards
