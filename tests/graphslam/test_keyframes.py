"""Pose variables only at key frames, omni key-frame spacing and the per-image landmark budget."""

from __future__ import annotations

import numpy as np
import pytest
from graphslam_scenarios import (
    ISAM_VS_BATCH_TOL_M,
    MOTION_NOISE,
    SENSOR_HEIGHT_M,
    configured,
    run,
    simulate_omni,
)

from omnislam.core.modality import Modality
from omnislam.core.se import se2_compose
from omnislam.core.types import FrameInput
from omnislam.graphslam import BatchGraphSLAM, GraphSLAM, GraphSLAMConfig
from omnislam.graphslam import factors as fx
from omnislam.graphslam.bearings_3d import TrackBudget
from omnislam.graphslam.config import PoseVariables

gtsam = pytest.importorskip("gtsam")

#: the ``poses`` section's fields of a pose variable per frame
EVERY_FRAME = {"pose_variables": PoseVariables.FRAMES}
RB, OMNI = Modality.RANGE_BEARING_2D, Modality.BEARINGS_3D
#: key poses of the composed graph against those of the every-frame graph [m]: the composed
#: between-factor is the every-frame chain marginalised to first order
COMPOSED_VS_CHAIN_TOL_M = 0.01


def _config(**changes) -> GraphSLAMConfig:
    """The test's motion noise, with ``changes`` (``graphslam_scenarios.configured``)."""
    return configured(GraphSLAMConfig(motion_noise=MOTION_NOISE), **changes)


def _every_fifth(frames: list[FrameInput]) -> list[FrameInput]:
    """Sightings only in frames 0, 5, 10, ... (the others keep their odometry)."""
    return [f if f.index % 5 == 0 else FrameInput(f.index, f.odometry) for f in frames]


def test_composed_odometry_graph_matches_the_every_frame_chain(planar):
    frames = _every_fifth(planar.frames)
    keyed = GraphSLAM(RB, _config(), planar.poses_true[0])
    chain = GraphSLAM(RB, _config(poses=EVERY_FRAME), planar.poses_true[0])
    a, b = run(keyed, frames), run(chain, frames)
    assert keyed.info().key_frames == len(frames) // 5 and chain.info().key_frames == len(frames)
    assert len(a.trajectory) == len(b.trajectory) == len(frames)
    keys = np.arange(0, len(frames), 5)
    np.testing.assert_allclose(
        a.trajectory.se2[keys], b.trajectory.se2[keys], atol=COMPOSED_VS_CHAIN_TOL_M
    )
    np.testing.assert_allclose(a.landmarks_w, b.landmarks_w, atol=COMPOSED_VS_CHAIN_TOL_M)
    # a frame between key frames is the odometry smoothed between them: as the chain has it,
    # closer than the odometry composed forward from its key frame
    np.testing.assert_allclose(a.trajectory.se2, b.trajectory.se2, atol=COMPOSED_VS_CHAIN_TOL_M)
    forward = []
    for j in range(len(frames)):
        pose = a.trajectory.se2[j - j % 5]
        for step in range(j - j % 5 + 1, j + 1):
            pose = se2_compose(pose, frames[step].odometry.delta)
        forward.append(pose)
    forward = np.asarray(forward)
    between = np.setdiff1d(np.arange(len(frames) - 5), keys)
    smoothed_off = np.abs(a.trajectory.se2[between, :2] - b.trajectory.se2[between, :2]).mean()
    forward_off = np.abs(forward[between, :2] - b.trajectory.se2[between, :2]).mean()
    assert smoothed_off < 0.5 * forward_off
    # after the newest key frame there is nothing to smooth towards: the odometry forward
    last = keys[-1]
    np.testing.assert_allclose(a.trajectory.se2[last:], forward[last:], atol=1e-9)
    # the graph holds one between-factor per pair of consecutive key frames
    graph = keyed.factor_graph()
    between = [graph.at(i) for i in range(graph.size())]
    between = [tuple(f.keys()) for f in between if isinstance(f, gtsam.BetweenFactorPose2)]
    assert between == [(fx.pose_key(i), fx.pose_key(i + 5)) for i in keys[:-1]]


def test_isam2_equals_batch_lm_with_composed_odometry(planar):
    frames = _every_fifth(planar.frames)
    cfg, tol_m = _config(), ISAM_VS_BATCH_TOL_M
    incremental = run(GraphSLAM(RB, cfg, planar.poses_true[0]), frames)
    batch_estimator = BatchGraphSLAM(RB, cfg, planar.poses_true[0])
    batch = run(batch_estimator, frames)
    np.testing.assert_allclose(incremental.trajectory.se2, batch.trajectory.se2, atol=tol_m)
    np.testing.assert_allclose(incremental.landmarks_w, batch.landmarks_w, atol=tol_m)
    assert batch_estimator.optimize().iterations <= 5


def test_poses_after_the_last_sighting_get_the_propagated_covariance(planar):
    """After the last sighting both graphs are dead reckoning from the last key frame: the
    covariance propagated through the composition equals the chain's iSAM2 marginals."""
    frames = planar.frames[:60] + [FrameInput(f.index, f.odometry) for f in planar.frames[60:80]]
    cfg = _config(compute_covariances=True)
    keyed = run(GraphSLAM(RB, cfg, planar.poses_true[0]), frames)
    chain = run(
        GraphSLAM(RB, configured(cfg, poses=EVERY_FRAME), planar.poses_true[0]),
        frames,
    )
    tail = slice(61, 80)
    scale = np.abs(chain.pose_covariances[tail]).max()
    assert np.abs(keyed.pose_covariances[tail] - chain.pose_covariances[tail]).max() < (
        0.05 * scale
    )
    assert np.all(np.linalg.eigvalsh(keyed.pose_covariances[1:]) > 0)


def test_omni_key_frame_spacing_skips_close_images_and_counts_their_bearings(rng):
    scenario = simulate_omni(rng)  # ~0.5 m between frames
    cfg = _config(
        poses={"sensor_height_m": SENSOR_HEIGHT_M, "keyframe_spacing_m": 1.2},
        landmarks={"per_image": 0},
    )
    estimator = GraphSLAM(OMNI, cfg, scenario.poses_true[0])
    estimate = run(estimator, scenario.frames)
    info = estimator.info()
    keys = estimator._poses.key_frames
    assert len(keys) == info.key_frames < len(scenario.frames) / 2
    gaps = np.diff([scenario.dead_reckoning[k, :2] for k in keys], axis=0)
    assert np.all(np.hypot(*gaps.T) >= 1.2 * 0.9)  # spacing measured on the odometry guess
    skipped = set(range(len(scenario.frames))) - set(keys)
    assert info.sightings_between_key_frames == sum(
        len(scenario.frames[k].bearings) for k in skipped
    )
    assert len(estimate.trajectory) == len(scenario.frames)
    assert scenario.ate(estimate.trajectory.se2) < 0.5 * scenario.ate(scenario.dead_reckoning)


def _ring(n: int, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    azimuth = np.linspace(-np.pi, np.pi, n, endpoint=False) + 1e-3
    rays = np.column_stack([np.cos(azimuth), np.sin(azimuth), np.zeros(n)])
    return ids, rays


def test_track_budget_admits_up_to_the_budget_spread_over_azimuth():
    budget = TrackBudget(16, sectors=8)
    ids, rays = _ring(96, np.arange(96))
    admitted = budget.admit(ids, rays)
    assert admitted.sum() == 16
    azimuth = np.arctan2(rays[admitted, 1], rays[admitted, 0])
    sectors = np.floor((azimuth + np.pi) / (2 * np.pi) * 8).astype(int)
    assert np.bincount(sectors, minlength=8).tolist() == [2] * 8
    # the same view again: nothing new is admitted, the admitted tracks stay
    np.testing.assert_array_equal(budget.admit(ids, rays), admitted)
    # a view with 4 admitted tracks takes 12 more, preferring the 20 seen before (twice now)
    # over the 40 new ones, interleaved around the robot
    before = ids[~admitted][:20]
    pattern = [[int(b), 1000 + 2 * i, 1001 + 2 * i] for i, b in enumerate(before.tolist())]
    shown = np.array(ids[admitted][:4].tolist() + [t for group in pattern for t in group])
    again = budget.admit(*_ring(len(shown), shown))
    assert again.sum() == 16
    newly = set(shown[again].tolist()) - set(ids[admitted].tolist())
    assert len(newly) == 12 and newly <= set(before.tolist())


def test_track_budget_grace_frees_the_places_of_tracks_never_used():
    """Budget 4: four tracks admitted that the back end never uses (far: no triangulation)
    hold the budget for good without a grace; with a grace of 3 images they stop counting after
    it and the next image admits four more. Tracks in use keep counting."""
    ids, rays = _ring(8, np.arange(8))
    unused = np.zeros(8, bool)
    plain, graced = TrackBudget(4, sectors=4), TrackBudget(4, sectors=4, grace_images=3)
    first = graced.admit(ids, rays, unused)
    np.testing.assert_array_equal(first, plain.admit(ids, rays, unused))
    assert first.sum() == 4
    for _ in range(2):  # within the grace: nothing new
        np.testing.assert_array_equal(graced.admit(ids, rays, unused), first)
    np.testing.assert_array_equal(plain.admit(ids, rays, unused), first)
    assert graced.admit(ids, rays, unused).all()  # image 4: the first four no longer count
    assert plain.admit(ids, rays, unused).sum() == 4
    # tracks in use count however old
    used = TrackBudget(4, sectors=4, grace_images=1)
    admitted = used.admit(ids, rays, np.zeros(8, bool))
    for _ in range(3):
        np.testing.assert_array_equal(used.admit(ids, rays, admitted.copy()), admitted)
    with pytest.raises(ValueError, match="grace_images"):
        TrackBudget(4, grace_images=0)


def test_track_budget_counts_the_sectors_of_tracks_admitted_before():
    """Budget 2 over 4 sectors: track 0 (sector 0) admitted in the first image; the second
    image has room for one and takes the new track in the empty sector 2, not the one in
    sector 0 beside track 0 (the admitted tracks load their sectors). A ray at azimuth pi
    exactly lies in sector 0 (the wrap of (pi + pi) / 2pi * sectors) and is admitted."""
    az = np.array([-3 * np.pi / 4, -3 * np.pi / 4 + 0.1, np.pi / 4])
    rays = np.column_stack([np.cos(az), np.sin(az), np.zeros(3)])
    budget = TrackBudget(2, sectors=4)
    assert budget.admit(np.array([0]), rays[:1]).tolist() == [True]
    assert budget.admit(np.arange(3), rays).tolist() == [True, False, True]
    back = TrackBudget(1, sectors=4)
    assert back.admit(np.array([7]), np.array([[-1.0, 0.0, 0.0]])).tolist() == [True]
    # a track seen twice in one image takes one place of the budget
    twice = TrackBudget(2, sectors=4)
    assert twice.admit(np.array([5, 5, 6]), np.tile(rays[:1], (3, 1))).all()


def test_budget_keeps_the_graph_to_admitted_tracks_with_all_their_sightings(rng):
    scenario = simulate_omni(rng)
    base = {"sensor_height_m": SENSOR_HEIGHT_M, "keyframe_spacing_m": 0.0}
    limited = GraphSLAM(
        OMNI, _config(poses=base, landmarks={"per_image": 8}), scenario.poses_true[0]
    )
    estimate = run(limited, scenario.frames)
    info = limited.info()
    total = sum(len(f.bearings) for f in scenario.frames)
    graph = limited.factor_graph()
    bearing_factors = [
        graph.at(i) for i in range(graph.size()) if isinstance(graph.at(i), gtsam.BearingFactor3D)
    ]
    landmarks = {gtsam.Symbol(f.keys()[1]).index() for f in bearing_factors}
    assert landmarks == set(estimate.landmark_ids.tolist())
    # every sighting is used, held back, gated or over the budget
    used = len(bearing_factors) + info.sightings_pending + info.sightings_gated
    assert used + info.sightings_over_budget == total
    assert info.sightings_over_budget > 0
    # a mapped landmark carries every sighting of its track, including those before admission
    sightings = {}
    for frame in scenario.frames:
        for lid in frame.bearings.landmark_ids.tolist():
            sightings[lid] = sightings.get(lid, 0) + 1
    per_landmark = {}
    for factor in bearing_factors:
        lid = gtsam.Symbol(factor.keys()[1]).index()
        per_landmark[lid] = per_landmark.get(lid, 0) + 1
    if info.sightings_gated == 0:
        assert per_landmark == {lid: sightings[lid] for lid in per_landmark}
    full = run(
        GraphSLAM(OMNI, _config(poses=base, landmarks={"per_image": 0}), scenario.poses_true[0]),
        scenario.frames,
    )
    assert len(estimate.landmark_ids) < len(full.landmark_ids)
    assert scenario.ate(estimate.trajectory.se2) < 0.5 * scenario.ate(scenario.dead_reckoning)
