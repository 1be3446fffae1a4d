import numpy as np
import pytest
from tolerances import JACOBIAN_RTOL

from omnislam.core.jacobian import angle_difference, numerical_jacobian, se2_retract
from omnislam.core.measurement import (
    Bearing2D,
    BearingElevation3D,
    RangeAzimuthElevation3D,
    RangeBearing2D,
    azimuth_elevation_from_unit_vectors,
    unit_vectors_from_azimuth_elevation,
)
from omnislam.core.se import se2_inverse, se2_transform_points, wrap_angle

MODELS = [
    RangeBearing2D(),
    Bearing2D(),
    BearingElevation3D(sensor_height_m=0.45),
    RangeAzimuthElevation3D(sensor_height_m=0.45),
]


def _scene(rng, model, n=25):
    poses = np.column_stack([rng.uniform(-4, 4, (n, 2)), rng.uniform(-np.pi, np.pi, n)])
    offsets = rng.uniform(0.5, 6.0, n)[:, None] * unit_vectors_from_azimuth_elevation(
        rng.uniform(-np.pi, np.pi, n), rng.uniform(-1.2, 1.2, n)
    )
    landmarks = poses[:, :2] if model.dim_landmark == 2 else np.c_[poses[:, :2], np.zeros(n)]
    landmarks = landmarks + offsets[:, : model.dim_landmark]
    if model.dim_landmark == 3:
        landmarks[:, 2] += getattr(model, "sensor_height_m", 0.0)
    return poses, landmarks


@pytest.mark.parametrize("model", MODELS, ids=lambda m: type(m).__name__)
def test_analytic_jacobians_match_numerical(rng, model):
    poses, landmarks = _scene(rng, model)
    diff = angle_difference(model.angular)
    for pose, landmark in zip(poses, landmarks, strict=True):
        _, H_p, H_l = model.predict(pose, landmark)
        num_p = numerical_jacobian(
            lambda x, lm=landmark: model.predict(x, lm)[0],
            pose,
            retract=se2_retract,
            tangent_dim=3,
            difference=diff,
        )
        num_l = numerical_jacobian(
            lambda lm, x=pose: model.predict(x, lm)[0], landmark, difference=diff
        )
        for analytic, numeric in ((H_p, num_p), (H_l, num_l)):
            err = np.linalg.norm(analytic - numeric) / np.linalg.norm(numeric)
            assert err <= JACOBIAN_RTOL, f"{type(model).__name__}: {err:.2e}"


@pytest.mark.parametrize("model", MODELS, ids=lambda m: type(m).__name__)
def test_predict_is_vectorised(rng, model):
    poses, landmarks = _scene(rng, model, n=40)
    z, H_p, H_l = model.predict(poses, landmarks)
    assert z.shape == (40, model.dim_z)
    assert H_p.shape == (40, model.dim_z, 3)
    assert H_l.shape == (40, model.dim_z, model.dim_landmark)
    for i in (0, 17, 39):
        z_i, Hp_i, Hl_i = model.predict(poses[i], landmarks[i])
        np.testing.assert_allclose(z[i], z_i)
        np.testing.assert_allclose(H_p[i], Hp_i)
        np.testing.assert_allclose(H_l[i], Hl_i)


def test_range_bearing_matches_robot_frame_geometry(rng):
    poses, landmarks = _scene(rng, RangeBearing2D(), n=100)
    z, _, _ = RangeBearing2D().predict(poses, landmarks)
    in_robot = se2_transform_points(se2_inverse(poses), landmarks)
    np.testing.assert_allclose(z[:, 0], np.linalg.norm(in_robot, axis=1))
    np.testing.assert_allclose(z[:, 1], np.arctan2(in_robot[:, 1], in_robot[:, 0]), atol=1e-12)


def test_range_bearing_inverse_round_trip_and_jacobians(rng):
    model = RangeBearing2D()
    poses, landmarks = _scene(rng, model, n=20)
    z, _, _ = model.predict(poses, landmarks)
    back, J_p, J_z = model.inverse(poses, z)
    np.testing.assert_allclose(back, landmarks, atol=1e-10)
    for pose, zi, Jp, Jz in zip(poses, z, J_p, J_z, strict=True):
        num_p = numerical_jacobian(lambda x, zi=zi: model.inverse(x, zi)[0], pose)
        num_z = numerical_jacobian(lambda zz, x=pose: model.inverse(x, zz)[0], zi)
        assert np.linalg.norm(Jp - num_p) <= JACOBIAN_RTOL * np.linalg.norm(num_p)
        assert np.linalg.norm(Jz - num_z) <= JACOBIAN_RTOL * np.linalg.norm(num_z)


def test_range_azimuth_elevation_inverse_round_trip_and_eq_4_26(rng):
    model = RangeAzimuthElevation3D(sensor_height_m=0.45)
    poses, landmarks = _scene(rng, model, n=20)
    z, _, _ = model.predict(poses, landmarks)
    back, J_p, J_z = model.inverse(poses, z)
    np.testing.assert_allclose(back, landmarks, atol=1e-10)
    for pose, zi, Jp, Jz in zip(poses, z, J_p, J_z, strict=True):
        num_p = numerical_jacobian(lambda x, zi=zi: model.inverse(x, zi)[0], pose)
        num_z = numerical_jacobian(lambda zz, x=pose: model.inverse(x, zz)[0], zi)
        assert np.linalg.norm(Jp - num_p) <= JACOBIAN_RTOL * np.linalg.norm(num_p)
        assert np.linalg.norm(Jz - num_z) <= JACOBIAN_RTOL * np.linalg.norm(num_z)
    # the inverse Jacobian (4.26) inverts the measurement Jacobian (4.32) w.r.t. the landmark
    _, _, H_l = model.predict(poses, landmarks)
    np.testing.assert_allclose(H_l @ J_z, np.broadcast_to(np.eye(3), H_l.shape), atol=1e-9)


def test_bearing_models_inverse(rng):
    poses, landmarks = _scene(rng, BearingElevation3D(0.45), n=30)
    model = BearingElevation3D(sensor_height_m=0.45)
    z, _, _ = model.predict(poses, landmarks)
    ranges = np.linalg.norm(landmarks - np.c_[poses[:, :2], np.full(30, 0.45)], axis=1)
    np.testing.assert_allclose(model.inverse(poses, z, ranges), landmarks, atol=1e-10)
    flat = landmarks[:, :2]
    zb, _, _ = Bearing2D().predict(poses, flat)
    rb = np.linalg.norm(flat - poses[:, :2], axis=1)
    np.testing.assert_allclose(Bearing2D().inverse(poses, zb, rb), flat, atol=1e-10)


def test_unit_vector_conversions(rng):
    az = rng.uniform(-np.pi, np.pi, 1000)
    el = rng.uniform(-1.5, 1.5, 1000)
    v = unit_vectors_from_azimuth_elevation(az, el)
    np.testing.assert_allclose(np.linalg.norm(v, axis=1), 1.0)
    back = azimuth_elevation_from_unit_vectors(3.0 * v)
    np.testing.assert_allclose(wrap_angle(back[:, 0] - az), 0.0, atol=1e-12)
    np.testing.assert_allclose(back[:, 1], el, atol=1e-12)


def test_residual_wraps_angles_only():
    model = RangeBearing2D()
    r = model.residual(np.array([5.0, np.pi - 0.01]), np.array([1.0, -np.pi + 0.01]))
    np.testing.assert_allclose(r, [4.0, -0.02], atol=1e-12)


@pytest.mark.parametrize("model", MODELS, ids=lambda m: type(m).__name__)
def test_predicted_azimuth_is_the_robot_frame_angle_wrapped(rng, model):
    """Every model's azimuth is atan2 of the landmark in the robot frame, in [-pi, pi): the
    headings span [-pi, pi), so atan2(dy, dx) - theta spans (-2 pi, 2 pi) unwrapped (the
    Jacobians and inverses, periodic in the angle, cannot tell)."""
    poses, landmarks = _scene(rng, model, n=200)
    z, _, _ = model.predict(poses, landmarks)
    in_robot = se2_transform_points(se2_inverse(poses), landmarks[:, :2])
    azimuth = z[:, model.angular.index(True)]
    assert np.all((azimuth >= -np.pi) & (azimuth < np.pi))
    np.testing.assert_allclose(azimuth, np.arctan2(in_robot[:, 1], in_robot[:, 0]), atol=1e-12)
    assert np.any(
        np.abs(
            np.arctan2(landmarks[:, 1] - poses[:, 1], landmarks[:, 0] - poses[:, 0]) - poses[:, 2]
        )
        > np.pi
    )  # some need the wrap


def test_residual_wraps_a_measurement_without_its_component_axis():
    """A bearing-only residual of shape (n,) (or a scalar) has no component axis: the mask
    (True,) broadcasts and every entry is wrapped."""
    model = Bearing2D()
    np.testing.assert_allclose(model.residual(np.pi - 0.01, -np.pi + 0.01), -0.02, atol=1e-12)
    r = model.residual(np.array([np.pi - 0.01, 0.3, -np.pi]), np.array([-np.pi + 0.01, 0.1, 3.0]))
    np.testing.assert_allclose(r, [-0.02, 0.2, np.pi - 3.0], atol=1e-12)
