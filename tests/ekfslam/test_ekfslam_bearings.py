"""EKF-SLAM on omni bearings: 3-D landmarks by delayed triangulation.

The 3-D state's Jacobians against numerical ones, the batch update against a dense Joseph EKF,
the delayed initialisation's triangulation, and a simulated bearing-only run with ground truth:
the filter beats dead reckoning and its landmarks land within their covariances.
"""

from __future__ import annotations

import numpy as np
import pytest
from ekfslam_scenario import JACOBIAN_ATOL, ORACLE_ATOL, pose_error
from scipy.stats import chi2

from omnislam.core.jacobian import angle_difference, numerical_jacobian
from omnislam.core.measurement import (
    BearingElevation3D,
    RangeAzimuthElevation3D,
    unit_vectors_from_azimuth_elevation,
)
from omnislam.core.modality import Modality
from omnislam.core.motion import MotionNoise, OdometryMotionModel
from omnislam.core.se import se2_compose, se2_rotate_vectors, wrap_angle
from omnislam.core.sequence_info import SequenceInfo
from omnislam.core.types import Bearings, FrameInput, Odometry
from omnislam.ekfslam import BearingEKFSLAM, BearingsConfig, EKFSLAMConfig, SlamGaussian
from omnislam.ekfslam.bearings import PendingTracks, triangulated_sighting
from omnislam.estimators import make_estimator

HEIGHT_M = 0.8
SIGMA_RAD = np.radians(0.2)
NOISE = MotionNoise(a_vv=0.03, a_vw=0.01, a_wv=0.01, a_ww=0.03)
#: a landmark's error is inside this chi-square quantile (3 dof) of its covariance ...
LANDMARK_PROBABILITY = 0.999
#: ... for at least this fraction of the map (a filter's mean is not exactly its truth's)
LANDMARK_FRACTION = 0.9


def random_state_3d(rng: np.random.Generator, n: int = 4) -> SlamGaussian:
    """A 3-D-landmark state (capacity < n, so it grew) with a random SPD covariance."""
    model = BearingElevation3D(HEIGHT_M)
    state = SlamGaussian(np.array([0.3, -0.2, 0.4]), np.eye(3) * 0.01, capacity=2, model=model)
    init = RangeAzimuthElevation3D(HEIGHT_M)
    for _ in range(n):
        z = np.array([rng.uniform(2, 6), rng.uniform(-np.pi, np.pi), rng.uniform(-0.3, 0.3)])
        state.augment(z, np.eye(3) * 0.01, init)
    d = state.dim
    M = rng.standard_normal((d, d)) * 0.1
    state.cov = M @ M.T + 0.01 * np.eye(d)
    return state


def h_all(x: np.ndarray, slots: np.ndarray) -> np.ndarray:
    """The stacked (azimuth, elevation) of landmarks ``slots`` seen from the state's pose."""
    lm = x[3:].reshape(-1, 3)[slots]
    z, _, _ = BearingElevation3D(HEIGHT_M).predict(np.broadcast_to(x[:3], (len(slots), 3)), lm)
    return z.ravel()


def test_bearing_innovation_jacobian_equals_numerical(rng):
    state = random_state_3d(rng)
    x = state.mean.copy()
    for slot in range(state.n_landmarks):
        _, Hs, idx = state.innovation(slot, np.zeros(2))
        H = np.zeros((2, state.dim))
        H[:, idx] = Hs
        J = numerical_jacobian(
            lambda xx, s=slot: h_all(xx, np.array([s])), x, difference=angle_difference((True,) * 2)
        )
        np.testing.assert_allclose(H, J, atol=JACOBIAN_ATOL)


def test_augmentation_from_triangulated_range_equals_numerical_propagation(rng):
    """P_aug = J blockdiag(P, Q) J^T with J the numerical Jacobian of (X, z3) -> [X; g(x_r, z3)]
    for the (d, azimuth, elevation) pseudo-measurement of the delayed initialisation."""
    state = random_state_3d(rng, n=2)
    init = RangeAzimuthElevation3D(HEIGHT_M)
    x, P = state.mean.copy(), state.cov.copy()
    d = len(x)
    z = np.array([3.5, 0.6, 0.2])
    Q = np.diag([0.3, 0.01, 0.012]) ** 2

    def augmented(xz: np.ndarray) -> np.ndarray:
        pose, (r, az, el) = xz[:3], xz[d:]
        ray = unit_vectors_from_azimuth_elevation(pose[2] + az, el)
        point = np.array([pose[0], pose[1], HEIGHT_M]) + r * ray
        return np.concatenate([xz[:d], point])

    J = numerical_jacobian(augmented, np.concatenate([x, z]))
    joint = np.zeros((d + 3, d + 3))
    joint[:d, :d], joint[d:, d:] = P, Q
    slot = state.augment(z, Q, init)
    assert slot == 2 and state.landmark_dim == 3
    np.testing.assert_allclose(state.mean, augmented(np.concatenate([x, z])), atol=1e-12)
    np.testing.assert_allclose(state.cov, J @ joint @ J.T, rtol=0, atol=JACOBIAN_ATOL)


def test_batch_update_equals_dense_joseph_ekf(rng):
    """``update_batch`` against X' = X + K nu, P' = (I-KH) P (I-KH)^T + K R K^T with the
    dense stacked H of the numerical Jacobian."""
    state = random_state_3d(rng, n=5)
    x, P = state.mean.copy(), state.cov.copy()
    slots = np.array([4, 1, 2])
    z = h_all(x, slots).reshape(-1, 2) + rng.normal(0, 0.01, (3, 2))
    R = np.stack([np.eye(2) * s**2 for s in (0.01, 0.02, 0.005)])
    H = numerical_jacobian(lambda xx: h_all(xx, slots), x, difference=angle_difference((True,) * 6))
    Rb = np.zeros((6, 6))
    for i in range(3):
        Rb[2 * i : 2 * i + 2, 2 * i : 2 * i + 2] = R[i]
    nu = wrap_angle(z.ravel() - h_all(x, slots))
    S = H @ P @ H.T + Rb
    K = P @ H.T @ np.linalg.inv(S)
    IKH = np.eye(len(x)) - K @ H
    x_ref, P_ref = x + K @ nu, IKH @ P @ IKH.T + K @ Rb @ K.T
    state.update_batch(slots, z, R)
    np.testing.assert_allclose(state.mean, x_ref, atol=1e-8)
    np.testing.assert_allclose(state.cov, P_ref, atol=1e-8)
    # one sighting: the batch is the sequential update exactly
    a, b = random_state_3d(np.random.default_rng(5)), random_state_3d(np.random.default_rng(5))
    zz = np.array([0.4, 0.1])
    a.update_batch(np.array([2]), zz[None], R[:1])
    b.update(2, zz, R[0])
    np.testing.assert_allclose(a.mean, b.mean, atol=ORACLE_ATOL)
    np.testing.assert_allclose(a.cov, b.cov, atol=ORACLE_ATOL)


def rays_to(point: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """Unit bearings in the robot frame from each pose's viewpoint to ``point``."""
    origins = np.column_stack([poses[:, :2], np.full(len(poses), HEIGHT_M)])
    w = point - origins
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    back = poses.copy()
    back[:, 2] = -poses[:, 2]
    return se2_rotate_vectors(back, w)


def test_pending_track_triangulates_after_enough_parallax():
    point = np.array([3.0, 1.0, 1.5])
    tracks = PendingTracks(HEIGHT_M, min_sightings=3, min_parallax_rad=np.radians(3.0))
    poses = np.array([[0.0, 0.0, 0.1], [0.05, 0.0, 0.1], [0.1, 0.0, 0.12], [0.8, 0.2, 0.2]])
    rays = rays_to(point, poses)
    for k in range(3):  # three sightings 10 cm apart subtend < 3 deg at 3.2 m: held back
        tracks.hold(7, poses[k], rays[k], SIGMA_RAD, 0.0)
        assert tracks.try_triangulate(7, poses[k], poses[k]) is None
    tracks.hold(7, poses[3], rays[3], SIGMA_RAD, 0.0)
    result = tracks.try_triangulate(7, poses[3], poses[3])
    assert result is not None and 7 not in tracks
    np.testing.assert_allclose(result.point_w, point, atol=1e-9)
    assert result.parallax_rad >= np.radians(3.0)
    # a track with a sighting of another point is inconsistent: rejected, kept pending
    tracks.hold(8, poses[0], rays_to(point, poses[:1])[0], SIGMA_RAD, 0.0)
    tracks.hold(8, poses[2], rays_to(point, poses[2:3])[0], SIGMA_RAD, 0.0)
    tracks.hold(8, poses[3], rays_to(point + np.array([0, 0.5, 0]), poses[3:])[0], SIGMA_RAD, 0.0)
    assert (
        tracks.try_triangulate(8, poses[3], poses[3]) is None
        and 8 in tracks
        and tracks.rejected == 1
    )


def test_triangulated_depth_std_grows_as_parallax_shrinks():
    model = RangeAzimuthElevation3D(HEIGHT_M)
    pose = np.zeros(3)
    point = np.array([4.0, 0.0, HEIGHT_M])
    _, Q_wide = triangulated_sighting(model, pose, point, SIGMA_RAD, np.radians(20))
    z, Q_narrow = triangulated_sighting(model, pose, point, SIGMA_RAD, np.radians(3))
    np.testing.assert_allclose(z, [4.0, 0.0, 0.0], atol=1e-12)
    assert Q_narrow[0, 0] > 40 * Q_wide[0, 0]
    np.testing.assert_allclose(
        np.sqrt(Q_narrow[0, 0]), np.sqrt(2) * 4 * SIGMA_RAD / np.sin(np.radians(3))
    )
    _, Q_drift = triangulated_sighting(model, pose, point, SIGMA_RAD, np.radians(3), 1e-4)
    assert Q_drift[0, 0] > Q_narrow[0, 0] and Q_drift[1, 1] == Q_narrow[1, 1]


# -- a simulated bearing-only world -------------------------------------------------------------


def omni_world(rng: np.random.Generator) -> np.ndarray:
    """40 points on the walls of a 10 x 10 m room around the loop, 0.3-2.0 m high."""
    t = rng.uniform(0, 4, 40)
    side = np.floor(t).astype(int)
    u = (t - side) * 10 - 5
    xy = np.select(
        [side[:, None] == 0, side[:, None] == 1, side[:, None] == 2],
        [
            np.column_stack([u, np.full(40, -5.0)]),
            np.column_stack([np.full(40, 5.0), u]),
            np.column_stack([u, np.full(40, 5.0)]),
        ],
        np.column_stack([np.full(40, -5.0), u]),
    )
    return np.column_stack([xy, rng.uniform(0.3, 2.0, 40)])


def omni_scenario(seed: int, steps: int) -> tuple[np.ndarray, np.ndarray, list[FrameInput]]:
    """A robot circling (radius 3 m) in the room, seeing every point with bearing noise."""
    rng = np.random.default_rng(seed)
    points = omni_world(np.random.default_rng(100))
    motion = OdometryMotionModel(NOISE)
    radius, step = 3.0, 0.1
    dtheta = step / radius
    chord = 2 * radius * np.sin(dtheta / 2)
    true_delta = np.array([chord * np.cos(dtheta / 2), chord * np.sin(dtheta / 2), dtheta])
    poses = [np.array([0.0, -3.0, 0.0])]
    frames = []
    for t in range(steps):
        if t > 0:
            poses.append(se2_compose(poses[-1], true_delta))
            measured = motion.sample_delta(true_delta, rng)
        else:
            measured = np.zeros(3)
        pose = np.broadcast_to(poses[-1], (len(points), 3))
        z, _, _ = BearingElevation3D(HEIGHT_M).predict(pose, points)
        z = z + SIGMA_RAD * rng.standard_normal(z.shape)
        rays = unit_vectors_from_azimuth_elevation(z[:, 0], z[:, 1])
        frames.append(
            FrameInput(
                index=t,
                odometry=Odometry(measured, stamp_s=0.1 * (t + 1)),
                bearings=Bearings(np.arange(len(points)), rays, np.full(len(points), SIGMA_RAD)),
            )
        )
    return np.array(poses), points, frames


def omni_filter() -> BearingEKFSLAM:
    config = EKFSLAMConfig(
        motion_noise=NOISE,
        bearings=BearingsConfig(sensor_height_m=HEIGHT_M, landmarks_per_image=0),
    )
    return BearingEKFSLAM(config, initial_pose_w=np.array([0.0, -3.0, 0.0]))


def dead_reckoning(frames: list[FrameInput], start: np.ndarray) -> np.ndarray:
    poses = [start]
    for frame in frames[1:]:
        poses.append(se2_compose(poses[-1], frame.odometry.delta))
    return np.array(poses)


@pytest.mark.slow
def test_bearing_only_run_beats_dead_reckoning_and_maps_within_covariances():
    true_poses, points, frames = omni_scenario(seed=1, steps=400)  # ~2 loops
    ekf = omni_filter()
    for frame in frames:
        ekf.step(frame)
    est = ekf.estimate()
    dr = dead_reckoning(frames, true_poses[0])
    err_ekf = np.linalg.norm(pose_error(est.trajectory.se2, true_poses)[:, :2], axis=1)
    err_dr = np.linalg.norm(pose_error(dr, true_poses)[:, :2], axis=1)
    assert np.sqrt(np.mean(err_ekf**2)) < 0.5 * np.sqrt(np.mean(err_dr**2))
    info = ekf.info()
    assert info.landmarks == len(points) and info.tracks_pending == 0
    assert info.gated <= 0.01 * info.sightings  # consistent bearings are not gated out
    assert info.associated >= 0.9 * info.sightings  # all but the held-back ones update
    ids = est.landmark_ids
    diff = est.landmarks_w - points[ids]
    d2 = np.einsum("ni,nij,nj->n", diff, np.linalg.inv(est.landmark_covariances), diff)
    inside = np.mean(d2 <= chi2.ppf(LANDMARK_PROBABILITY, 3))
    assert inside >= LANDMARK_FRACTION, f"{inside:.2f} of the landmarks inside their covariance"
    assert np.sqrt(np.mean(np.sum(diff**2, axis=1))) < 0.15
    P = ekf.state.cov
    np.testing.assert_allclose(P, P.T, atol=1e-12)
    assert np.linalg.eigvalsh(P).min() > -1e-9


def test_registry_builds_the_omni_filter_with_the_rig_height(rng):
    info = SequenceInfo(
        name="omni", frames=0, modalities=frozenset({Modality.BEARINGS_3D}), sensor_height_m=0.6
    )
    ekf = make_estimator("ekfslam", info, {}, rng)
    assert isinstance(ekf, BearingEKFSLAM) and ekf.config.bearings.sensor_height_m == 0.6
    ekf = make_estimator("ekfslam", info, {"bearings.sensor_height_m": "0.9"}, rng)
    assert ekf.config.bearings.sensor_height_m == 0.9
