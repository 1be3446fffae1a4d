"""FastSLAM 1.0 / 2.0 end to end on simulated loops built from the core models."""

from __future__ import annotations

import numpy as np
import pytest
from fastslam_scenario import (
    BEARING_SCENARIO_NOISE,
    SCENARIO_NOISE,
    SENSOR_HEIGHT_M,
    ate_rmse,
    make_bearing_scenario,
    make_scenario,
)
from fastslam_tolerances import (
    ATE_FRACTION_OF_DEAD_RECKONING,
    ATE_FRACTION_OF_DEAD_RECKONING_3D,
    LANDMARK_RMSE_M,
    OUTLIER_FRACTION,
    STORE_ATOL,
)

from omnislam.core.modality import Modality
from omnislam.core.types import UNKNOWN_ID, Estimator, FrameInput, Odometry, RangeBearing
from omnislam.errors import ConfigError
from omnislam.fastslam import (
    AssociationConfig,
    BearingsConfig,
    BearingUpdate,
    ExistenceIndexConfig,
    ExperimentalConfig,
    FastSLAMConfig,
    LandmarkStatus,
    ParticlesConfig,
    ProposalConfig,
    ResamplingConfig,
    StoreKind,
    TrajectoryMode,
    Variant,
    make_fastslam,
)

SEEDS = range(8)
RANGE_BEARING = Modality.RANGE_BEARING_2D
BEARINGS = Modality.BEARINGS_3D


def _slam(config, seed, modality=RANGE_BEARING):
    return make_fastslam(config, modality, np.random.default_rng(seed))


def _run(scenario, config, seed, modality=RANGE_BEARING):
    slam = _slam(config, seed, modality)
    for frame in scenario.frames:
        slam.step(frame)
    return slam, slam.estimate()


def _ate(estimate, scenario):
    return ate_rmse(estimate.trajectory.positions_w[:, :2], scenario.true_poses[1:, :2])


def _landmark_rmse(estimate, scenario):
    order = np.argsort(estimate.landmark_ids)
    truth = scenario.landmarks_w[estimate.landmark_ids[order]]
    d = truth.shape[1]
    return float(np.sqrt(np.mean(np.sum((estimate.landmarks_w[order, :d] - truth) ** 2, axis=1))))


def _config(variant, n, *, store=StoreKind.TREE, **changes):
    """The scenario's noise, ``n`` particles in a ``store``, and section ``changes``."""
    return FastSLAMConfig(
        variant=variant,
        motion_noise=SCENARIO_NOISE,
        particles=ParticlesConfig(n_particles=n, store=store),
        **changes,
    )


def _experimental(variant, n, **switches):
    """``_config`` with experimental ``switches`` on."""
    return _config(variant, n, experimental=ExperimentalConfig(**switches))


def test_is_an_estimator_named_after_its_variant():
    for variant in Variant:
        slam = _slam(FastSLAMConfig(variant=variant), 0)
        assert isinstance(slam, Estimator)
        assert slam.name == variant.value


def test_rejects_a_bad_initial_pose():
    with pytest.raises(ConfigError):
        make_fastslam(FastSLAMConfig(), RANGE_BEARING, np.random.default_rng(0), np.zeros(2))


@pytest.mark.parametrize("variant", list(Variant))
def test_beats_dead_reckoning_and_maps_the_landmarks(variant):
    ates, dead_reckoning, errors = [], [], []
    for seed in (0, 1, 2):
        scenario = make_scenario(seed)
        _, estimate = _run(scenario, _config(variant, 50), seed + 100)
        assert sorted(estimate.landmark_ids) == list(range(len(scenario.landmarks_w)))
        ates.append(_ate(estimate, scenario))
        dead_reckoning.append(
            ate_rmse(scenario.dead_reckoning[1:, :2], scenario.true_poses[1:, :2])
        )
        errors.append(_landmark_rmse(estimate, scenario))
    assert np.mean(ates) < ATE_FRACTION_OF_DEAD_RECKONING * np.mean(dead_reckoning)
    assert max(errors) < LANDMARK_RMSE_M


@pytest.mark.slow
def test_fastslam2_with_10_particles_at_least_as_good_as_fastslam1():
    """Paired over 8 seeds (same world, odometry and sightings): the 2.0 proposal gives a
    lower mean ATE with 10 particles and keeps its particles diverse (fewer resamplings)."""
    ate1, ate2, resamplings1, resamplings2 = [], [], [], []
    for seed in SEEDS:
        scenario = make_scenario(seed)
        slam1, estimate1 = _run(scenario, _config(Variant.FASTSLAM1, 10), seed + 100)
        slam2, estimate2 = _run(scenario, _config(Variant.FASTSLAM2, 10), seed + 100)
        ate1.append(_ate(estimate1, scenario))
        ate2.append(_ate(estimate2, scenario))
        resamplings1.append(slam1.resample_count)
        resamplings2.append(slam2.resample_count)
    assert np.mean(ate2) <= np.mean(ate1)
    assert np.mean(resamplings2) < 0.6 * np.mean(resamplings1)


@pytest.mark.parametrize("variant", list(Variant))
def test_tree_and_dense_store_give_identical_estimates(variant):
    scenario = make_scenario(4, steps=60)
    estimates = [
        _run(scenario, _config(variant, 20, store=store), 7)[1]
        for store in (StoreKind.TREE, StoreKind.DENSE, StoreKind.LEAF_TREE)
    ]
    for other in estimates[1:]:
        np.testing.assert_array_equal(other.landmark_ids, estimates[0].landmark_ids)
        np.testing.assert_allclose(other.landmarks_w, estimates[0].landmarks_w, atol=STORE_ATOL)
        np.testing.assert_allclose(
            other.landmark_covariances, estimates[0].landmark_covariances, atol=STORE_ATOL
        )
        np.testing.assert_allclose(
            other.trajectory.poses_w, estimates[0].trajectory.poses_w, atol=STORE_ATOL
        )


#: FastSLAM 1.0 samples poses from the odometry alone, so with a sensor far more precise than
#: the odometry its innovations are large: it needs a permissive p0 and the existence index
#: (thesis 5.1.2) to prune the duplicates; 2.0 associates with the refined proposal's
#: uncertainty and is fine with the default.
UNKNOWN_ASSOCIATION_SETTINGS = {
    Variant.FASTSLAM1: {
        "association": AssociationConfig(new_landmark_log_likelihood=-25.0),
        "existence": ExistenceIndexConfig(max_range_m=7.0),
    },
    Variant.FASTSLAM2: {},
}


@pytest.mark.slow
@pytest.mark.parametrize("variant", list(Variant))
def test_unknown_association(variant):
    """Per-particle maximum-likelihood association finds each well-separated landmark once."""
    ates, dead_reckoning = [], []
    for seed in (0, 1, 2):
        scenario = make_scenario(seed, unknown_ids=True)
        truth = make_scenario(seed)
        config = _config(variant, 30, **UNKNOWN_ASSOCIATION_SETTINGS[variant])
        _, estimate = _run(scenario, config, seed + 100)
        ates.append(_ate(estimate, scenario))
        dead_reckoning.append(
            ate_rmse(scenario.dead_reckoning[1:, :2], scenario.true_poses[1:, :2])
        )
        # (nearly) every true landmark has an estimate nearest to it, and few extras remain
        # (a map off by a global drift of ~1-2 m can swap one nearest neighbour)
        distance = np.linalg.norm(
            estimate.landmarks_w[:, None, :2] - truth.landmarks_w[None], axis=2
        )
        nearest = np.argmin(distance, axis=1)
        assert len(estimate.landmark_ids) <= len(truth.landmarks_w) + 2
        assert np.unique(nearest).size >= len(truth.landmarks_w) - 1
    assert np.mean(ates) < ATE_FRACTION_OF_DEAD_RECKONING * np.mean(dead_reckoning)


def test_exclusive_association_gives_a_landmark_at_most_one_sighting_of_a_frame():
    """Mutual exclusion (``experimental.association_exclusive``): a first frame maps one tree;
    the next frame sees it and a second tree 0.3 m beside it. Without exclusion both sightings
    fit the one landmark (its range-bearing noise is wide) and no landmark is added; with it,
    the likelier sighting takes the landmark and the other starts a new one, in every
    particle."""
    first = RangeBearing(np.array([UNKNOWN_ID]), np.array([5.0]), np.array([0.0]), 0.5, 0.05)
    second = RangeBearing(
        np.array([UNKNOWN_ID, UNKNOWN_ID]), np.array([5.0, 5.3]), np.array([0.0, 0.0]), 0.5, 0.05
    )
    counts = {}
    for exclusive in (False, True):
        for variant in Variant:
            config = _experimental(variant, 10, association_exclusive=exclusive)
            slam = _slam(config, 0)
            slam.step(FrameInput(0, Odometry(np.zeros(3), 0.0), range_bearing=first))
            slam.step(FrameInput(1, Odometry(np.zeros(3), 0.1), range_bearing=second))
            counts[exclusive, variant] = slam.info().landmarks
    assert all(counts[False, v] == 1 for v in Variant)
    assert all(counts[True, v] == 2 for v in Variant)


def test_exclusive_choice_is_a_greedy_assignment():
    """Per particle: the best pair first, then the best pair among what is left; a sighting
    whose remaining pairs are all below log p0 becomes a new landmark."""
    from omnislam.fastslam.association import NEW_LANDMARK, _exclusive_choice

    ll = np.array(
        [
            [[-1.0, -2.0], [-1.5, -9.0], [-0.5, -20.0]],  # sighting 2 takes 0, 0 takes 1, 1 new
            [[-1.0, -2.0], [-3.0, -1.5], [-20.0, -20.0]],  # 0 -> 0, 1 -> 1, 2 new
        ]
    )
    choice, chosen = _exclusive_choice(ll, log_p0=-6.0)
    np.testing.assert_array_equal(choice, [[1, NEW_LANDMARK, 0], [0, 1, NEW_LANDMARK]])
    np.testing.assert_array_equal(chosen, [[-2.0, -6.0, -0.5], [-1.0, -1.5, -6.0]])


def _one_tree_frames(seen_in_second: bool):
    """Three frames 0.5 m apart seeing one tree (unknown id) 5 m ahead; the second frame's
    sighting left out when not ``seen_in_second``."""
    frames = []
    for k in range(3):
        ranges = np.array([5.0 - 0.5 * k])
        sighting = RangeBearing(np.array([UNKNOWN_ID]), ranges, np.array([0.02]), 0.1, 0.01)
        seen = k != 1 or seen_in_second
        delta = np.array([0.5 if k else 0.0, 0.0, 0.0])
        frames.append(
            FrameInput(k, Odometry(delta, float(k)), range_bearing=sighting if seen else None)
        )
    return frames


@pytest.mark.parametrize("confirm", [1, 2])
def test_a_tentative_landmark_neither_weighs_nor_refines_the_proposal(confirm):
    """``experimental.confirm_sightings=2``: the first re-sighting of a landmark without id
    updates it but leaves FastSLAM 1.0's particles equally weighted (every particle gets p0),
    and FastSLAM 2.0 draws from the motion model as in a frame without sightings; the next
    re-sighting weighs. With 1 (the default) the first re-sighting already weighs and refines."""
    one = _experimental(Variant.FASTSLAM1, 20, confirm_sightings=confirm)
    slam = _slam(one, 5)
    frames = _one_tree_frames(seen_in_second=True)
    spread = []
    for frame in frames:
        slam.step(frame)
        spread.append(np.ptp(slam.particles.log_weights) if slam.resample_count == 0 else None)
        assert slam.estimate().landmark_ids.size == 1  # always the same landmark
    assert spread[0] == 0.0  # a new landmark: p0 in every particle
    assert (spread[1] == 0.0) == (confirm == 2)
    assert spread[2] is None or spread[2] > 0.0
    two = _experimental(Variant.FASTSLAM2, 20, confirm_sightings=confirm)
    seen, blind = _slam(two, 5), _slam(two, 5)
    blind_frames = _one_tree_frames(seen_in_second=False)
    for frame_seen, frame_blind in zip(frames[:2], blind_frames[:2], strict=True):
        seen.step(frame_seen)
        blind.step(frame_blind)
    same = np.array_equal(seen.particles.poses, blind.particles.poses)
    assert same == (confirm == 2)


def test_confirm_sightings_must_be_positive():
    with pytest.raises(ConfigError):
        ExperimentalConfig(confirm_sightings=0)


def test_a_frame_may_mix_known_and_unknown_ids():
    """Known ids map to their slots, an unknown sighting gets a new landmark: both mapped."""
    frame = FrameInput(
        0,
        Odometry(np.zeros(3), 0.0),
        range_bearing=RangeBearing(
            np.array([7, UNKNOWN_ID]), np.array([2.0, 3.0]), np.array([0.3, -0.5]), 0.1, 0.01
        ),
    )
    for variant in Variant:
        slam = _slam(_config(variant, 5), 0)
        slam.step(frame)
        ids = slam.estimate().landmark_ids
        assert len(ids) == 2 and 7 in ids


def test_frames_without_sightings_only_predict():
    """Asynchronous front end (thesis 4.5): weights and maps untouched, poses move."""
    scenario = make_scenario(0, steps=30)
    slam = _slam(_config(Variant.FASTSLAM1, 20), 0)
    for frame in scenario.frames[:20]:
        slam.step(frame)
    weights = slam.particles.log_weights.copy()
    landmarks = slam.estimate().landmarks_w
    poses = slam.particles.poses.copy()
    blind = FrameInput(index=99, odometry=Odometry(np.array([0.5, 0.0, 0.0]), stamp_s=100.0))
    slam.step(blind)
    np.testing.assert_array_equal(slam.particles.log_weights, weights)
    np.testing.assert_array_equal(slam.estimate().landmarks_w, landmarks)
    assert np.all(np.abs(slam.particles.poses - poses)[:, :2].sum(axis=1) > 0.3)
    assert len(slam.estimate().trajectory) == 21


def test_best_ancestry_trajectory_is_a_particle_path():
    scenario = make_scenario(1, steps=80)
    config = _experimental(Variant.FASTSLAM2, 10, trajectory=TrajectoryMode.BEST_ANCESTRY)
    slam, estimate = _run(scenario, config, 3)
    assert len(estimate.trajectory) == 80
    np.testing.assert_allclose(
        estimate.trajectory.se2[-1], slam.particles.poses[slam.particles.best()], atol=1e-9
    )
    assert _ate(estimate, scenario) < 1.0


def test_best_ancestry_covariance_is_the_particles_spread_about_the_reported_pose():
    """The reported pose's covariance is the weighted second moment of the particles about it,
    which contains the weighted covariance about the mean: never tighter than the mean's
    read-out. Checked at the last step against the particle set itself, which is the recorded
    one when the filter never resamples."""
    scenario = make_scenario(1, steps=80)
    kept = _config(
        Variant.FASTSLAM2,
        10,
        experimental=ExperimentalConfig(trajectory=TrajectoryMode.BEST_ANCESTRY),
        resampling=ResamplingConfig(ess_fraction=0.0),
    )
    slam, estimate = _run(scenario, kept, 3)
    particles = slam.particles
    d = particles.poses - estimate.trajectory.se2[-1]
    d[:, 2] = (d[:, 2] + np.pi) % (2 * np.pi) - np.pi
    covs = estimate.pose_covariances
    assert covs.shape == (80, 3, 3)
    np.testing.assert_allclose(covs[-1], (d * particles.weights[:, None]).T @ d, rtol=1e-5)
    # with resampling: the mean read-out's covariances plus the offsets' outer products
    ancestry = _experimental(Variant.FASTSLAM2, 10, trajectory=TrajectoryMode.BEST_ANCESTRY)
    _, estimate = _run(scenario, ancestry, 3)
    _, mean_estimate = _run(
        scenario, _experimental(Variant.FASTSLAM2, 10, trajectory=TrajectoryMode.WEIGHTED_MEAN), 3
    )
    extra = estimate.pose_covariances - mean_estimate.pose_covariances
    assert np.all(np.linalg.eigvalsh(extra) > -1e-12)  # offset's outer product, PSD
    assert np.any(np.trace(extra, axis1=1, axis2=2) > 0)  # the path leaves the mean somewhere


def test_existence_index_deletes_a_phantom_landmark():
    """Thesis 5.1.2: a landmark seen once, then in view but never again, is deleted."""
    scenario = make_scenario(0, steps=40)
    phantom = RangeBearing(np.array([999]), np.array([2.0]), np.array([0.0]), 0.05, 0.01)
    frames = list(scenario.frames)
    first = frames[0]
    merged = RangeBearing(
        np.r_[first.range_bearing.landmark_ids, 999],
        np.r_[first.range_bearing.ranges_m, phantom.ranges_m],
        np.r_[first.range_bearing.bearings_rad, phantom.bearings_rad],
        np.r_[first.range_bearing.sigma_range_m, 0.05],
        np.r_[first.range_bearing.sigma_bearing_rad, 0.01],
    )
    frames[0] = FrameInput(first.index, first.odometry, range_bearing=merged)
    existence = ExistenceIndexConfig(max_range_m=7.0)
    config = _config(Variant.FASTSLAM1, 10, existence=existence)
    slam = _slam(config, 0)
    slam.step(frames[0])
    assert 999 in slam.estimate().landmark_ids
    for frame in frames[1:]:
        slam.step(frame)
    ids = slam.estimate().landmark_ids
    assert 999 not in ids
    assert set(range(len(scenario.landmarks_w))) & set(ids.tolist())  # real ones survive


def test_predicted_visible_is_the_sensor_field_from_each_pose():
    """Thesis 5.1.2's field: range [min, max] inclusive, |bearing| <= half fov in the pose's
    frame, and for 3-D landmarks the elevation above the viewpoint's height within the band."""
    from omnislam.fastslam.existence import predicted_visible

    field = ExistenceIndexConfig(max_range_m=4.0, min_range_m=1.0, half_fov_rad=np.pi / 2)
    # heading pi/2: a landmark 2 m along +y is ahead, one 2 m along -y behind
    poses = np.tile([1.0, 1.0, np.pi / 2], (6, 1))
    landmarks = np.array([[1.0, 3.0], [1.0, -1.0], [1.0, 5.0], [1.0, 5.01], [1.0, 1.5], [3.0, 1.0]])
    # ahead, behind, at 4 m, past 4 m, at 0.5 m, to the side (bearing -pi/2)
    expected = [True, False, True, False, False, True]
    np.testing.assert_array_equal(predicted_visible(field, poses, landmarks), expected)
    band = ExistenceIndexConfig(
        max_range_m=10.0, min_elevation_rad=-0.1, max_elevation_rad=np.pi / 4
    )
    # viewpoint 1 m high, 2 m away: heights 2.9 m (43.5 deg), 3.1 m (46.4 deg), 0.85 m (-4.3 deg)
    # and 0.5 m (-14 deg) about it; from the floor the 2.9 m one would be at 55 deg
    high = np.array([[2.0, 0.0, 2.9], [2.0, 0.0, 3.1], [2.0, 0.0, 0.85], [2.0, 0.0, 0.5]])
    poses = np.zeros((4, 3))
    np.testing.assert_array_equal(
        predicted_visible(band, poses, high, sensor_height_m=1.0), [True, False, True, False]
    )


def test_existence_index_decrements_only_estimated_landmarks_in_view_and_unseen():
    """One apply: an unseen estimated landmark in view loses one (1 -> 0 stays; 0 -> -1 is
    deleted: status ABSENT, zeroed), a sighted one, a ray-only one and one out of range keep
    theirs; candidates lie within max range + margin of the weighted mean pose."""
    from omnislam.fastslam.dense_store import DenseLandmarkStore
    from omnislam.fastslam.existence import ExistenceIndex
    from omnislam.fastslam.landmark_store import ABSENT, ESTIMATED, RAY, LandmarkBlock
    from omnislam.fastslam.sightings import Pairs
    from omnislam.fastslam.slot_registry import SlotRegistry

    store = DenseLandmarkStore(1, 2)
    registry = SlotRegistry(store)
    # slots: 0 index 1, 1 index 0, 2 sighted (index 0), 3 ray-only (index 0), 4 at 6 m
    positions = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0], [6.0, 0.0]])
    slots = registry.add(np.arange(5), 5)
    registry.record_positions(slots, positions)
    block = LandmarkBlock.empty(5, 2, 0)
    block.mean[:] = positions
    block.cov[:] = np.eye(2)
    block.status[:] = LandmarkStatus.ESTIMATED
    block.status[3] = LandmarkStatus.RAY
    block.existence[:] = [1, 0, 0, 0, 0]
    store.scatter(np.zeros(5, np.int64), slots, block)
    index = ExistenceIndex(ExistenceIndexConfig(max_range_m=4.0), 3.0, 0.0)
    seen = Pairs(np.array([0]), np.array([2]), np.array([0]), np.array([False]))
    index.apply(store, registry, np.zeros((1, 3)), np.ones(1), seen)
    after = store.particle_map(0)
    np.testing.assert_array_equal(after.existence[:5], [0, 0, 0, 0, 0])
    np.testing.assert_array_equal(after.status[:5], [ESTIMATED, ABSENT, ESTIMATED, RAY, ESTIMATED])
    assert np.all(after.mean[1] == 0) and np.all(after.cov[1] == 0)
    np.testing.assert_array_equal(after.mean[[0, 2, 3, 4]], positions[[0, 2, 3, 4]])
    assert index.pruned == 1
    # two particles, nearly all weight on the second at (0, 0): the first, 30 m away, has its
    # landmark there too, but only slots within 7 m of the weighted mean (0.03, 0) are examined
    store = DenseLandmarkStore(2, 2)
    registry = SlotRegistry(store)
    slots = registry.add(np.arange(2), 2)
    registry.record_positions(slots, np.array([[1.0, 0.0], [31.0, 0.0]]))
    block = LandmarkBlock.empty(4, 2, 0)
    block.mean[:] = [[1.0, 0.0], [31.0, 0.0], [1.0, 0.0], [31.0, 0.0]]
    block.status[:] = LandmarkStatus.ESTIMATED
    block.existence[:] = 5
    store.scatter(np.array([0, 0, 1, 1]), np.array([0, 1, 0, 1]), block)
    poses = np.array([[30.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    none = Pairs(*(np.zeros(0, np.int64) for _ in range(3)), np.zeros(0, bool))
    index.apply(store, registry, poses, np.array([1e-3, 1 - 1e-3]), none)
    # slot 0 is examined: the second particle (landmark 1 m away) loses one, the first (29 m)
    # not; slot 1 (31 m from the mean) is not examined although 1 m from the first particle
    got = store.gather(np.array([0, 0, 1, 1]), np.array([0, 1, 0, 1])).existence
    np.testing.assert_array_equal(got, [5, 5, 4, 5])


@pytest.mark.parametrize("update", list(BearingUpdate))
def test_bearing_only_3d_mode(update):
    """Omni bearings: first sighting stores a ray, the next triangulates, later ones update."""
    config = FastSLAMConfig(
        variant=Variant.FASTSLAM2,
        particles=ParticlesConfig(n_particles=30),
        motion_noise=BEARING_SCENARIO_NOISE,
        sensor_height_m=SENSOR_HEIGHT_M,
        bearings=BearingsConfig(update=update),
    )
    ates, dead_reckoning = [], []
    for seed in (1, 2, 3):
        scenario = make_bearing_scenario(seed)
        slam = _slam(config, seed, BEARINGS)
        slam.step(scenario.frames[0])
        assert slam.modality is BEARINGS
        assert len(slam.estimate().landmark_ids) == 0  # rays only (thesis eq. 4.24)
        first = slam.store.particle_map(0)
        assert np.all(first.status[: len(scenario.frames[0].bearings)] == LandmarkStatus.RAY)
        for frame in scenario.frames[1:]:
            slam.step(frame)
        estimate = slam.estimate()
        assert len(estimate.landmark_ids) == len(scenario.landmarks_w)
        ates.append(_ate(estimate, scenario))
        dead_reckoning.append(
            ate_rmse(scenario.dead_reckoning[1:, :2], scenario.true_poses[1:, :2])
        )
        assert _landmark_rmse(estimate, scenario) < LANDMARK_RMSE_M
    assert np.mean(ates) < 0.5 * np.mean(dead_reckoning)


def _bearing_ates(config, outlier_fraction):
    ates, dead_reckoning = [], []
    for seed in (1, 2, 3):
        scenario = make_bearing_scenario(seed, outlier_fraction=outlier_fraction)
        _, estimate = _run(scenario, config, seed, BEARINGS)
        ates.append(_ate(estimate, scenario))
        dead_reckoning.append(
            ate_rmse(scenario.dead_reckoning[1:, :2], scenario.true_poses[1:, :2])
        )
    return np.mean(ates), np.mean(dead_reckoning)


def test_fastslam2_3d_survives_outlier_tracks():
    """5% of the bearings come from tracks that jumped to another point (as on lab40's SIFT
    log). Ungated, the 2.0 proposal follows them and the filter diverges far beyond dead
    reckoning; with the chi-square gate it stays well below dead reckoning."""
    config = FastSLAMConfig(
        variant=Variant.FASTSLAM2,
        particles=ParticlesConfig(n_particles=20),
        motion_noise=BEARING_SCENARIO_NOISE,
        sensor_height_m=SENSOR_HEIGHT_M,
    )
    gated, dead_reckoning = _bearing_ates(config, OUTLIER_FRACTION)
    ungated_config = config.with_(bearings=BearingsConfig(gate_probability=1.0))
    ungated, _ = _bearing_ates(ungated_config, OUTLIER_FRACTION)
    assert gated < ATE_FRACTION_OF_DEAD_RECKONING_3D * dead_reckoning
    assert ungated > dead_reckoning


@pytest.mark.parametrize(
    "option", [{"max_sightings": 4}, {"max_landmark_std_m": 1.0}]
)
def test_fastslam2_3d_with_a_restricted_proposal(option):
    """Fewer or only converged landmarks in the proposal: still well below dead reckoning."""
    config = FastSLAMConfig(
        variant=Variant.FASTSLAM2,
        particles=ParticlesConfig(n_particles=20),
        motion_noise=BEARING_SCENARIO_NOISE,
        sensor_height_m=SENSOR_HEIGHT_M,
        proposal=ProposalConfig(**option),
    )
    ate, dead_reckoning = _bearing_ates(config, OUTLIER_FRACTION)
    assert ate < ATE_FRACTION_OF_DEAD_RECKONING_3D * dead_reckoning


@pytest.mark.parametrize("n", [3, 10, 100])
def test_resample_fraction_one_resamples_every_step_and_zero_never(n):
    """A first sighting leaves the weights equal, and their ESS is P only up to rounding
    (3.0, 10.000000000000005, 100.00000000000011): fraction 1.0 must still resample."""
    first = FrameInput(
        0,
        Odometry(np.zeros(3), 0.0),
        range_bearing=RangeBearing(np.array([1]), np.array([2.0]), np.array([0.3]), 0.1, 0.01),
    )
    for fraction, expected in ((1.0, 1), (0.0, 0)):
        config = _config(Variant.FASTSLAM1, n, resampling=ResamplingConfig(ess_fraction=fraction))
        slam = _slam(config, 0)
        slam.step(first)
        assert slam.resample_count == expected


def test_a_tempered_likelihood_scales_fastslam1_log_weights():
    """``experimental.likelihood_temper`` t: FastSLAM 1.0 weighs by p(z | x)^t; the same
    draws, the same map."""
    frames = make_scenario(2, steps=5).frames
    runs = []
    for temper in (1.0, 0.25):
        config = _config(
            Variant.FASTSLAM1,
            30,
            resampling=ResamplingConfig(ess_fraction=0.0),
            experimental=ExperimentalConfig(likelihood_temper=temper),
        )
        slam = _slam(config, 4)
        for frame in frames:
            slam.step(frame)
        runs.append(slam)
    plain, tempered = runs
    np.testing.assert_array_equal(plain.particles.poses, tempered.particles.poses)
    log_plain = plain.particles.log_weights - plain.particles.log_weights[0]
    log_tempered = tempered.particles.log_weights - tempered.particles.log_weights[0]
    assert np.ptp(log_plain) > 1.0  # the sightings do separate the particles
    np.testing.assert_allclose(log_tempered, 0.25 * log_plain, rtol=1e-9, atol=1e-9)
    assert tempered.particles.effective_sample_size() > plain.particles.effective_sample_size()


@pytest.mark.parametrize("temper", [0.0, -0.5, 1.5])
def test_likelihood_temper_outside_0_1_is_refused(temper):
    with pytest.raises(ConfigError, match="likelihood_temper"):
        ExperimentalConfig(likelihood_temper=temper)


def test_islands_keep_one_lineage_each_and_beat_dead_reckoning():
    """``experimental.islands=5``: five independent filters of 10 particles, each island's
    weights summing to 1/5; resampling within islands leaves at least five distinct ancestors
    at every step."""
    scenario = make_scenario(1, steps=80)
    slam, estimate = _run(scenario, _experimental(Variant.FASTSLAM1, 50, islands=5), 3)
    w = slam.particles.weights.reshape(5, 10).sum(axis=1)
    np.testing.assert_allclose(w, 0.2)
    assert slam.resample_count > 0
    assert slam.info().distinct_ancestors_min >= 5
    dead_reckoning = ate_rmse(scenario.dead_reckoning[1:, :2], scenario.true_poses[1:, :2])
    assert _ate(estimate, scenario) < ATE_FRACTION_OF_DEAD_RECKONING * dead_reckoning
    with pytest.raises(ConfigError):
        _experimental(Variant.FASTSLAM1, 4, islands=5)
