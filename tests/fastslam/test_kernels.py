"""The compiled kernels against the numpy path, their reference and test oracle.

Each kernel is compared with the numpy function it replaces on random inputs; whole filters
(FastSLAM 1.0 and 2.0, known and unknown association, 2-D and 3-D) are run on both paths from
the same seed and must give the same trajectory, resamplings and map.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from fastslam_scenario import (
    BEARING_SCENARIO_NOISE,
    SCENARIO_NOISE,
    SENSOR_HEIGHT_M,
    make_bearing_scenario,
    make_scenario,
)

from omnislam.core.gaussian import log_likelihood_from_mahalanobis
from omnislam.core.kalman import ekf_update
from omnislam.core.measurement import (
    BearingElevation3D,
    RangeAzimuthElevation3D,
    RangeBearing2D,
    unit_vectors_from_azimuth_elevation,
)
from omnislam.core.modality import Modality
from omnislam.core.motion import MotionNoise, OdometryMotionModel
from omnislam.core.se import wrap_angle
from omnislam.errors import MissingExtraError
from omnislam.fastslam import FastSLAMConfig, Kernels, ParticlesConfig, Variant, make_fastslam
from omnislam.fastslam import kernels as kernel_module
from omnislam.fastslam.association import (
    NEW_LANDMARK,
    association_log_likelihood,
    maximum_likelihood_association,
)
from omnislam.fastslam.bearing_landmarks import triangulate, world_rays
from omnislam.fastslam.bearing_mapper import BearingMapper
from omnislam.fastslam.config import BearingsConfig, BearingUpdate, TriangulationMethod
from omnislam.fastslam.landmark_store import ESTIMATED, RAY, LandmarkBlock, LandmarkStatus
from omnislam.fastslam.landmark_tree import LandmarkTree, TreeLayout
from omnislam.fastslam.particles import ParticleSet
from omnislam.fastslam.proposal import _JITTER, refine_proposal, sample_poses
from omnislam.fastslam.sightings import Sightings

pytest.importorskip("numba")

#: kernels vs numpy, per call: both evaluate the same expressions in the same order; only the
#: last bits of atan2 / sqrt / cos / sin may differ (C library vs numpy's SIMD loops)
KERNEL_RTOL = 1e-12
#: whole runs: those last bits, carried through a few hundred filter steps
RUN_ATOL = 1e-9


@pytest.fixture(scope="module")
def k():
    return kernel_module.compiled()


def _random_landmarks(rng, n):
    mean = rng.uniform(-5, 5, (n, 2))
    a = rng.normal(0, 0.2, (n, 2, 2))
    cov = a @ np.swapaxes(a, 1, 2) + 0.01 * np.eye(2)
    return mean, cov


def _range_bearing(rng, n):
    z = np.column_stack([rng.uniform(0.5, 6, n), rng.uniform(-np.pi, np.pi, n)])
    R = np.zeros((n, 2, 2))
    R[:, 0, 0], R[:, 1, 1] = 0.05**2, 0.02**2
    return z, R


def test_ekf_kernel_matches_core_ekf_update(k):
    rng = np.random.default_rng(0)
    n = 300
    wTr = np.column_stack([rng.uniform(-3, 3, (n, 2)), rng.uniform(-np.pi, np.pi, n)])
    mean, cov = _random_landmarks(rng, n)
    z, R = _range_bearing(rng, n)
    reference = ekf_update(wTr, mean, cov, z, R, RangeBearing2D())
    out_mean, out_cov = np.empty_like(mean), np.empty_like(cov)
    mahalanobis, det = np.empty(n), np.empty(n)
    k.ekf_range_bearing(wTr, mean, cov, z, R, out_mean, out_cov, mahalanobis, det)
    np.testing.assert_allclose(out_mean, reference.mean, rtol=KERNEL_RTOL, atol=1e-14)
    np.testing.assert_allclose(out_cov, reference.cov, rtol=KERNEL_RTOL, atol=1e-16)
    np.testing.assert_allclose(mahalanobis, reference.mahalanobis, rtol=KERNEL_RTOL)
    assert np.array_equal(out_cov, np.swapaxes(out_cov, 1, 2))  # symmetrised
    # updated in place (the mapper's use) gives the same
    k.ekf_range_bearing(wTr, mean, cov, z, R, mean, cov, mahalanobis, det)
    np.testing.assert_array_equal(mean, out_mean)


def test_sequential_proposal_kernel_matches_refine_proposal(k):
    rng = np.random.default_rng(1)
    p, per = 40, 5
    mean0 = np.column_stack([rng.uniform(-2, 2, (p, 2)), rng.uniform(-np.pi, np.pi, p)])
    a = rng.normal(0, 0.05, (p, 3, 3))
    cov0 = a @ np.swapaxes(a, 1, 2) + 1e-6 * np.eye(3)
    n = p * per
    who = np.tile(np.arange(p), per)  # sighting-major, as the reference loops
    lm_mean, lm_cov = _random_landmarks(rng, n)
    z, R = _range_bearing(rng, n)
    mean, cov = mean0.copy(), cov0.copy()
    expected_ll = np.zeros(p)
    model = RangeBearing2D()
    for j in range(per):
        rows = np.arange(j * p, (j + 1) * p)
        update = refine_proposal(
            mean[who[rows]], cov[who[rows]], z[rows], R[rows], lm_mean[rows], lm_cov[rows], model
        )
        mean[who[rows]], cov[who[rows]] = update.mean, update.cov
        expected_ll[who[rows]] += update.log_likelihood
    got_mean, got_cov = mean0.copy(), cov0.copy()
    mahalanobis, det = np.empty(n), np.empty(n)
    k.refine_range_bearing(got_mean, got_cov, who, z, R, lm_mean, lm_cov, mahalanobis, det)
    ll = -0.5 * (mahalanobis + np.log(det) + 2 * math.log(2 * math.pi))
    np.testing.assert_allclose(got_mean, mean, rtol=KERNEL_RTOL, atol=1e-13)
    np.testing.assert_allclose(got_cov, cov, rtol=1e-10, atol=1e-16)
    np.testing.assert_allclose(np.bincount(who, weights=ll), expected_ll, rtol=KERNEL_RTOL)


def test_draw_kernel_matches_sample_poses(k):
    rng = np.random.default_rng(2)
    n = 200
    mean = np.column_stack([rng.normal(0, 3, (n, 2)), rng.uniform(-np.pi, np.pi, n)])
    a = rng.normal(0, 0.1, (n, 3, 3))
    cov = a @ np.swapaxes(a, 1, 2)
    cov[:5] = 0.0  # a proposal collapsed to a point: the jitter keeps it factorisable
    reference = sample_poses(mean, cov, np.random.default_rng(7))
    normals = np.random.default_rng(7).standard_normal(mean.shape)
    out = np.empty_like(mean)
    k.cholesky_draws(mean, cov, normals, _JITTER, out)
    np.testing.assert_allclose(out, reference, rtol=KERNEL_RTOL, atol=1e-13)


def test_odometry_prediction_kernel_matches_the_motion_model(k):
    rng = np.random.default_rng(3)
    model = OdometryMotionModel(MotionNoise(a_vv=0.1, a_vw=0.05, a_wv=0.02, a_ww=0.1))
    wTr = np.column_stack([rng.normal(0, 3, (50, 2)), rng.uniform(-np.pi, np.pi, 50)])
    for delta in ([0.3, 0.02, 0.1], [-0.2, 0.0, -0.4], [0.0, 0.0, 0.5]):
        mean, cov = model.predict(wTr, None, np.array(delta))
        rot1, trans, rot2 = model.decompose(np.array(delta))
        variances = model.component_sigmas(np.array([rot1, trans, rot2])) ** 2
        out_mean, out_cov = np.empty((50, 3)), np.empty((50, 3, 3))
        k.odometry_prediction(wTr, rot1, trans, rot2, variances, out_mean, out_cov)
        np.testing.assert_allclose(out_mean, mean, rtol=KERNEL_RTOL, atol=1e-14)
        np.testing.assert_allclose(out_cov, cov, rtol=KERNEL_RTOL, atol=1e-20)


def test_weighted_moments_kernel_matches_the_particle_set(k):
    rng = np.random.default_rng(4)
    particles = ParticleSet(
        np.column_stack([rng.normal(0, 1, (64, 2)), rng.normal(3.1, 0.2, 64)])  # near +-pi
    )
    particles.reweight(rng.normal(0, 2, 64))
    mean, cov = np.empty(3), np.empty((3, 3))
    k.weighted_moments(particles.weights, particles.poses, mean, cov)
    expected = particles.mean_pose()
    np.testing.assert_allclose(mean, expected, rtol=KERNEL_RTOL)
    np.testing.assert_allclose(cov, particles.pose_covariance(expected), rtol=1e-10)


def _association_inputs(rng, p, k_sightings, c, R_kinds):
    """Random poses, candidates (some not valid) and sightings for the association tests;
    ``R_kinds`` distinct sighting noises, repeated over the sightings."""
    poses = np.column_stack([rng.uniform(-3, 3, (p, 2)), rng.uniform(-np.pi, np.pi, p)])
    mean, cov = _random_landmarks(rng, p * c)
    valid = rng.random((p, c)) > 0.2
    z, R = _range_bearing(rng, k_sightings)
    z[: k_sightings // 2, 1] += rng.choice([-2 * np.pi, 2 * np.pi], k_sightings // 2)  # unwrapped
    R *= rng.uniform(0.5, 2.0, (R_kinds, 1, 1))[np.arange(k_sightings) % R_kinds]
    return poses, mean.reshape(p, c, 2), cov.reshape(p, c, 2, 2), valid, z, R


@pytest.mark.parametrize("R_kinds", [1, 3])
@pytest.mark.parametrize("pose_cov_kind", [None, "per particle", "per candidate"])
def test_association_kernels_equal_the_numpy_path_bit_for_bit(k, R_kinds, pose_cov_kind):
    """FastSLAM's per-(particle, sighting, candidate) association likelihoods, compiled and
    numpy: exactly equal (the kernels repeat the numpy path's operations in its order), with
    one noise for all sightings or several, with and without a pose covariance."""
    rng = np.random.default_rng(8)
    p, k_sightings, c = 30, 7, 40
    poses, mean, cov, valid, z, R = _association_inputs(rng, p, k_sightings, c, R_kinds)
    pose_cov = None
    if pose_cov_kind is not None:
        shape = (p, 3, 3) if pose_cov_kind == "per particle" else (p, c, 3, 3)
        a = rng.normal(0, 0.05, shape)
        pose_cov = a @ np.swapaxes(a, -1, -2)
    model = RangeBearing2D()
    expected = association_log_likelihood(poses, pose_cov, mean, cov, valid, z, R, model)
    got = association_log_likelihood(poses, pose_cov, mean, cov, valid, z, R, model, k)
    for a, b in zip(expected, got, strict=True):
        np.testing.assert_array_equal(a, b)
    assert np.isneginf(got[0].transpose(0, 2, 1)[~valid]).all()  # not candidates: -inf


@pytest.mark.parametrize("exclusive", [False, True])
@pytest.mark.parametrize("gate", [None, 9.21])
def test_association_choices_equal_on_both_paths(k, exclusive, gate):
    rng = np.random.default_rng(9)
    poses, mean, cov, valid, z, R = _association_inputs(rng, 20, 6, 25, 1)
    # sightings of candidates of particle 0, so that some are matched and some are new
    z[:3] = RangeBearing2D().predict(poses[0], mean[0, :3])[0] + rng.normal(0, 0.02, (3, 2))
    args = (poses, None, mean, cov, valid, z, R, RangeBearing2D(), -6.0, exclusive, gate)
    expected = maximum_likelihood_association(*args)
    got = maximum_likelihood_association(*args, k)
    for a, b in zip(expected, got, strict=True):
        np.testing.assert_array_equal(a, b)
    assert (expected[0] == NEW_LANDMARK).any() and (expected[0] != NEW_LANDMARK).any()


def test_wrap_near_is_the_modulo_wrap_bit_for_bit():
    """``_wrap_near`` (exact turn corrections) against ``_wrap`` (floored modulo), in plain
    Python as numba runs them: random angles, the interval ends and their neighbours."""
    rng = np.random.default_rng(10)
    ends = np.array([-3 * np.pi, -np.pi, 0.0, -0.0, np.pi, 3 * np.pi, 5 * np.pi, 1e6, -1e6])
    near = np.concatenate([ends, np.nextafter(ends, np.inf), np.nextafter(ends, -np.inf)])
    angles = np.concatenate([near, rng.uniform(-12, 12, 20000), [np.inf, -np.inf, np.nan]])
    for angle in angles.tolist():
        a, b = kernel_module._wrap(angle), kernel_module._wrap_near(angle)
        assert (a == b and math.copysign(1, a) == math.copysign(1, b)) or (a != a and b != b)


@pytest.mark.parametrize("layout", list(TreeLayout))
def test_tree_kernels_give_the_same_maps_and_counts(k, layout):
    """Random writes, reads and resamplings on two trees, one walking with the kernels: the
    same maps after every operation and the same node counts."""
    rng = np.random.default_rng(5)
    p = 12
    trees = [
        LandmarkTree(p, 2, 0, initial_capacity=4, layout=layout),
        LandmarkTree(p, 2, 0, initial_capacity=4, layout=layout, kernels=k),
    ]
    for step in range(60):
        if step % 7 == 0:
            count = int(rng.integers(1, 6))
            for tree in trees:
                tree.add_landmarks(count)
        m = trees[0].n_landmarks
        n = int(rng.integers(1, p * min(m, 4) + 1))
        keys = rng.choice(p * m, size=n, replace=False)
        who, slots = keys // m, keys % m
        block = LandmarkBlock.empty(n, 2, 0)
        block.mean[:] = rng.normal(size=(n, 2))
        block.cov[:] = rng.normal(size=(n, 2, 2))
        block.status[:] = LandmarkStatus.ESTIMATED
        block.existence[:] = rng.integers(0, 9, n)
        for tree in trees:
            tree.scatter(who, slots, block)
        if step % 3 == 0:
            ancestors = np.sort(rng.integers(0, p, p))
            for tree in trees:
                tree.resample(ancestors)
        probe_who, probe_slots = rng.integers(0, p, 30), rng.integers(0, m, 30)
        a, b = (tree.gather(probe_who, probe_slots) for tree in trees)
        for name in ("mean", "cov", "status", "existence"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    for particle in range(p):
        a, b = (tree.particle_map(particle) for tree in trees)
        np.testing.assert_array_equal(a.mean, b.mean)
        np.testing.assert_array_equal(a.status, b.status)
    assert trees[0].nodes_allocated == trees[1].nodes_allocated
    assert trees[0].node_visits == trees[1].node_visits
    assert trees[0].live_nodes() == trees[1].live_nodes()


# -- omni bearings: exact equality with the numpy path ------------------------------------------


def _bearing_views(rng, n):
    """N (pose, landmark, stored ray, new ray) cases around a robot: most rays meet near the
    landmark, some are parallel or diverge, some stored rays are from the same viewpoint."""
    poses = np.column_stack([rng.uniform(-1, 1, (n, 2)), rng.uniform(-np.pi, np.pi, n)])
    landmarks = np.column_stack(
        [poses[:, :2] + rng.uniform(-6, 6, (n, 2)), rng.uniform(-0.5, 3.0, n)]
    )
    earlier = poses + rng.normal(0, [0.3, 0.3, 0.2], (n, 3))
    earlier[: n // 10] = poses[: n // 10]  # no baseline: parallel rays
    model = BearingElevation3D(SENSOR_HEIGHT_M)

    def rays(wTr, noise):
        z, _, _ = model.predict(wTr, landmarks)
        z = z + rng.normal(0, noise, z.shape)
        return world_rays(
            wTr, unit_vectors_from_azimuth_elevation(z[:, 0], z[:, 1]), SENSOR_HEIGHT_M
        )

    stored, new = rays(earlier, 0.01), rays(poses, 0.01)
    new[-n // 10 :, 3:] *= -1.0  # pointing away: negative depths
    return poses, landmarks, stored, new


def test_world_rays_kernel_equals_world_rays(k, rng):
    poses, _, _, new = _bearing_views(rng, 2000)
    unit_vectors_r = new[rng.permutation(2000), 3:]
    obs = rng.integers(0, 2000, 2000)
    rays = np.empty((2000, 6))
    cos_theta, sin_theta = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    k.world_rays(poses, cos_theta, sin_theta, unit_vectors_r, obs, SENSOR_HEIGHT_M, rays)
    np.testing.assert_array_equal(rays, world_rays(poses, unit_vectors_r[obs], SENSOR_HEIGHT_M))


def test_midpoint_triangulation_kernel_equals_triangulate(k, rng):
    _, _, stored, new = _bearing_views(rng, 2000)
    points, valid, parallax = triangulate(TriangulationMethod.MIDPOINT, stored, new)
    got_points, cosine = np.empty((2000, 3)), np.empty(2000)
    got_valid = np.empty(2000, dtype=bool)
    k.midpoint_triangulation(stored, new, np.arange(2000), got_points, cosine, got_valid)
    assert 0 < valid.sum() < valid.size
    np.testing.assert_array_equal(got_points, points)
    np.testing.assert_array_equal(got_valid, valid)
    np.testing.assert_array_equal(np.arccos(cosine), parallax)


def test_azimuth_elevation_arguments_give_the_models_angles(k, rng):
    poses, landmarks, _, _ = _bearing_views(rng, 2000)
    landmarks[:5, :2] = poses[:5, :2]  # straight above: rho floored
    arguments = np.empty((4, 2000))
    k.azimuth_elevation_arguments(poses, landmarks, SENSOR_HEIGHT_M, arguments)
    azimuth = wrap_angle(np.arctan2(arguments[0], arguments[1]) - poses[:, 2])
    elevation = np.arctan2(arguments[2], arguments[3])
    z_bearing, _, _ = BearingElevation3D(SENSOR_HEIGHT_M).predict(poses, landmarks)
    z_range, _, _ = RangeAzimuthElevation3D(SENSOR_HEIGHT_M).predict(poses, landmarks)
    for z in (z_bearing, z_range[:, 1:]):
        np.testing.assert_array_equal(azimuth, z[:, 0])
        np.testing.assert_array_equal(elevation, z[:, 1])


def _bearing_block(rng, n):
    """A gathered block of N pairs (a tenth absent, a fifth rays, the rest estimated), their
    poses and one sighting each (a twentieth of them jumped far off: gated)."""
    poses, landmarks, stored, new = _bearing_views(rng, n)
    block = LandmarkBlock.empty(n, 3, 6)
    status = rng.choice([0, int(RAY), int(ESTIMATED)], n, p=[0.1, 0.2, 0.7]).astype(np.int8)
    block.status[:] = status
    block.existence[:] = rng.integers(0, 5, n)
    block.ray[status > 0] = stored[status > 0]
    block.mean[status == ESTIMATED] = (landmarks + rng.normal(0, 0.1, (n, 3)))[status == ESTIMATED]
    a = rng.normal(0, 0.1, (n, 3, 3))
    block.cov[status == ESTIMATED] = (a @ np.swapaxes(a, 1, 2) + 1e-4 * np.eye(3))[
        status == ESTIMATED
    ]
    unit_vectors_r = new[:, 3:].copy()
    c, s = np.cos(-poses[:, 2]), np.sin(-poses[:, 2])  # back into the robot frame
    unit_vectors_r[:, 0], unit_vectors_r[:, 1] = (
        c * new[:, 3] - s * new[:, 4],
        s * new[:, 3] + c * new[:, 4],
    )
    unit_vectors_r[: n // 20] = unit_vectors_r[rng.permutation(n // 20)][::-1]
    sigmas = rng.choice([0.002, 0.004], n)
    z = np.column_stack(
        [
            np.arctan2(unit_vectors_r[:, 1], unit_vectors_r[:, 0]),
            np.arctan2(unit_vectors_r[:, 2], np.hypot(unit_vectors_r[:, 0], unit_vectors_r[:, 1])),
        ]
    )
    R = np.zeros((n, 2, 2))
    R[:, 0, 0] = R[:, 1, 1] = sigmas**2
    sightings = Sightings(np.arange(n), z, R, unit_vectors_r, sigmas)
    return block, poses, sightings


@pytest.mark.parametrize("bearing_update", list(BearingUpdate))
@pytest.mark.parametrize("triangulation", list(TriangulationMethod))
@pytest.mark.parametrize("gate_probability", [0.999, 1.0])
def test_bearing_mapper_updates_equal_the_numpy_path_bit_for_bit(
    k, rng, bearing_update, triangulation, gate_probability
):
    n = 3000
    block, poses, sightings = _bearing_block(rng, n)
    obs = rng.permutation(n)
    config = BearingsConfig(
        update=bearing_update, triangulation=triangulation, gate_probability=gate_probability
    )
    mappers = [
        BearingMapper(config, SENSOR_HEIGHT_M),
        BearingMapper(config, SENSOR_HEIGHT_M, k),
    ]
    blocks = [block.take(slice(None)), block.take(np.arange(n))]
    likelihoods = [m.update(b, poses, sightings, obs) for m, b in zip(mappers, blocks, strict=True)]
    np.testing.assert_array_equal(likelihoods[1], likelihoods[0])
    for name in ("mean", "cov", "status", "existence", "ray"):
        np.testing.assert_array_equal(getattr(blocks[1], name), getattr(blocks[0], name))
    assert mappers[1].sightings_gated == mappers[0].sightings_gated
    assert mappers[1].triangulation_fallbacks == mappers[0].triangulation_fallbacks
    if gate_probability < 1.0:
        assert mappers[0].sightings_gated > 0
    if bearing_update is BearingUpdate.TRIANGULATED:
        assert 0 < mappers[0].triangulation_fallbacks < np.count_nonzero(block.status == ESTIMATED)


@pytest.mark.parametrize("gate", [math.inf, 2.0])
def test_bearing_proposal_kernel_equals_refine_proposal_bit_for_bit(k, rng, gate):
    n = 500
    poses, landmarks, _, _ = _bearing_views(rng, n)
    model = BearingElevation3D(SENSOR_HEIGHT_M)
    a = rng.normal(0, 0.05, (n, 3, 3))
    pose_cov = a @ np.swapaxes(a, 1, 2) + 1e-6 * np.eye(3)
    b = rng.normal(0, 0.1, (n, 3, 3))
    landmark_cov = b @ np.swapaxes(b, 1, 2) + 1e-4 * np.eye(3)
    z = model.predict(poses[0], landmarks[0])[0] + np.array([0.01, -0.02])
    R = np.diag([0.004**2, 0.003**2])
    expected = refine_proposal(
        poses,
        pose_cov,
        np.broadcast_to(z, (n, 2)),
        np.broadcast_to(R, (n, 2, 2)),
        landmarks,
        landmark_cov,
        model,
        gate,
    )
    arguments, angles = np.empty((4, n)), np.empty((2, n))
    k.azimuth_elevation_arguments(poses, landmarks, SENSOR_HEIGHT_M, arguments)
    angles[0], angles[1] = np.arctan2(arguments[0], arguments[1]), np.arctan2(*arguments[2:])
    mean, cov = poses.copy(), pose_cov.copy()
    mahalanobis, det = np.empty(n), np.empty(n)
    who = rng.permutation(n)  # any order of distinct particles
    k.refine_bearing_elevation(
        mean,
        cov,
        who,
        z,
        R,
        landmarks[who],
        landmark_cov[who],
        angles[:, who],
        SENSOR_HEIGHT_M,
        gate,
        mahalanobis,
        det,
    )
    np.testing.assert_array_equal(mean, expected.mean)
    np.testing.assert_array_equal(cov, expected.cov)
    np.testing.assert_array_equal(mahalanobis <= gate, expected.accepted[who])
    log_likelihood = log_likelihood_from_mahalanobis(np.minimum(mahalanobis, gate), np.log(det), 2)
    np.testing.assert_array_equal(log_likelihood, expected.log_likelihood[who])
    if math.isfinite(gate):
        assert 0 < expected.accepted.sum() < n


def test_payload_row_kernels_equal_take_and_put(k, rng):
    table = LandmarkBlock.empty(50, 3, 6)
    names = ("mean", "cov", "status", "existence", "ray")
    for name in names:
        field = getattr(table, name)
        field[:] = rng.integers(-100, 100, field.shape)
    rows = rng.permutation(50)[:20]
    taken = table.take(rows)
    for name in names:
        field, out = getattr(table, name), getattr(taken, name)
        got = np.zeros_like(out)
        k.take_rows(field.reshape(50, -1), rows, got.reshape(20, -1))
        np.testing.assert_array_equal(got, out)
        written = out[::-1].copy()
        expected = field.copy()
        expected[rows] = written
        k.put_rows(field.reshape(50, -1), rows, written.reshape(20, -1))
        np.testing.assert_array_equal(field, expected)


def _run(config, frames, modality, initial_pose=None):
    slam = make_fastslam(config, modality, np.random.default_rng(11), initial_pose)
    for frame in frames:
        slam.step(frame)
    return slam


def _assert_same_run(numpy_run, kernel_run, atol):
    assert numpy_run.resample_count == kernel_run.resample_count
    np.testing.assert_array_equal(numpy_run.diversity.distinct, kernel_run.diversity.distinct)
    a, b = numpy_run.estimate(), kernel_run.estimate()
    np.testing.assert_allclose(a.trajectory.se2, b.trajectory.se2, rtol=0, atol=atol)
    np.testing.assert_array_equal(a.landmark_ids, b.landmark_ids)
    np.testing.assert_allclose(a.landmarks_w, b.landmarks_w, rtol=0, atol=atol)
    np.testing.assert_allclose(a.pose_covariances, b.pose_covariances, rtol=1e-6, atol=1e-18)


@pytest.mark.parametrize("variant", list(Variant))
@pytest.mark.parametrize("unknown_ids", [False, True])
def test_range_bearing_runs_agree_on_both_paths(variant, unknown_ids):
    frames = make_scenario(3, steps=120, unknown_ids=unknown_ids).frames
    config = FastSLAMConfig(
        variant=variant,
        particles=ParticlesConfig(n_particles=30),
        motion_noise=SCENARIO_NOISE,
    )
    runs = [
        _run(config.with_(kernels=kernels), frames, Modality.RANGE_BEARING_2D)
        for kernels in (Kernels.NUMPY, Kernels.NUMBA)
    ]
    _assert_same_run(*runs, RUN_ATOL)


@pytest.mark.parametrize("variant", list(Variant))
def test_bearing_runs_agree_on_both_paths(variant):
    """3-D: the tree, the draws, the motion prediction, the triangulations, the landmark EKFs
    and the gated sequential proposal run compiled."""
    frames = make_bearing_scenario(2, steps=60).frames
    config = FastSLAMConfig(
        variant=variant,
        particles=ParticlesConfig(n_particles=10),
        motion_noise=BEARING_SCENARIO_NOISE,
        sensor_height_m=SENSOR_HEIGHT_M,
    )
    runs = [
        _run(config.with_(kernels=kernels), frames, Modality.BEARINGS_3D)
        for kernels in (Kernels.NUMPY, Kernels.NUMBA)
    ]
    _assert_same_run(*runs, RUN_ATOL)


def test_numba_choice_without_numba_names_the_extra(monkeypatch):
    monkeypatch.setattr(kernel_module, "_COMPILED", None)
    monkeypatch.setattr(kernel_module, "available", lambda: False)
    import builtins

    real_import = builtins.__import__

    def no_numba(name, *args, **kwargs):
        if name == "numba" or name.startswith("numba."):
            raise ImportError("no numba here")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_numba)
    assert kernel_module.resolve(Kernels.AUTO) is None  # AUTO falls back to numpy
    assert kernel_module.resolve(Kernels.NUMPY) is None
    with pytest.raises(MissingExtraError, match=r"'fast' extra"):
        kernel_module.resolve(Kernels.NUMBA)
