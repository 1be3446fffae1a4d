"""Floor tracks (``frontend.floor_tracks``): a tiled floor's corners, all alike, told apart by
the floor plane and the odometry; and the pipeline's option that adds them to the log."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from omnislam.errors import ConfigError
from omnislam.frontend import evaluation
from omnislam.frontend.config import FloorTrackConfig, FrontendConfig, LaserLandmarkConfig
from omnislam.frontend.floor_tracks import FloorTracker

HEIGHT_M = 0.85
VIEWPOINT = np.array([0.0, 0.0, HEIGHT_M])
TILE_M = 0.3


def _floor_grid() -> np.ndarray:
    x, y = np.meshgrid(np.arange(-3.0, 8.0, TILE_M), np.arange(-3.0, 3.0, TILE_M))
    return np.column_stack([x.ravel(), y.ravel()])


def _rays_to(points_w: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """Exact bearings (robot frame) from the viewpoint to floor points."""
    c, s = np.cos(pose[2]), np.sin(pose[2])
    rel = (points_w - pose[:2]) @ np.array([[c, -s], [s, c]])
    rays = np.column_stack([rel, np.full(len(rel), -HEIGHT_M)])
    return rays / np.linalg.norm(rays, axis=1, keepdims=True)


def _drive(steps: int = 12, step_m: float = 0.17, turn: float = 0.05):
    """True poses of a robot driving a gentle arc, and its dead reckoning with a 1 % scale
    error and a little heading noise."""
    rng = np.random.default_rng(3)
    true, dr = [np.zeros(3)], [np.zeros(3)]
    for _ in range(steps):
        for poses, scale, noise in ((true, 1.0, 0.0), (dr, 0.99, 0.002)):
            x, y, th = poses[-1]
            th2 = th + turn + noise * rng.standard_normal()
            d = scale * step_m
            poses.append(np.array([x + d * np.cos(th), y + d * np.sin(th), th2]))
    return np.array(true), np.array(dr)


def _tracked(descriptors_alike: bool, body: bool = False):
    """Runs the tracker over the drive; returns (track id -> set of true points, tracker)."""
    grid = _floor_grid()
    rng = np.random.default_rng(0)
    own = rng.normal(size=(len(grid), 128)).astype(np.float32)
    own *= 512 / np.linalg.norm(own, axis=1, keepdims=True)
    alike = np.tile(own[:1], (len(grid), 1))
    descriptors = alike if descriptors_alike else own
    tracker = FloorTracker(VIEWPOINT, FloorTrackConfig(enabled=True))
    members: dict[int, set[int]] = {}
    body_ids: list[np.ndarray] = []
    seen_in: dict[int, list[int]] = {}  # corner -> the images it is visible in
    true, dr = _drive()
    for image, (pose, pose_dr) in enumerate(zip(true, dr, strict=True)):
        rays = _rays_to(grid, pose)
        depression = np.degrees(np.arcsin(-rays[:, 2]))
        visible = np.flatnonzero((depression >= 35) & (depression <= 60))
        for corner in visible.tolist():
            seen_in.setdefault(corner, []).append(image)
        rays_v, desc_v = rays[visible], descriptors[visible]
        if body:  # two points fixed to the robot, seen below the horizon in every image
            fixed = np.array([[0.3, 0.0, -HEIGHT_M], [-0.2, 0.3, -HEIGHT_M]])
            rays_v = np.vstack([rays_v, fixed / np.linalg.norm(fixed, axis=1, keepdims=True)])
            desc_v = np.vstack([desc_v, own[:2]])
        seen = tracker.process(rays_v, desc_v, pose_dr)
        for track, row in zip(seen.track_ids.tolist(), seen.feature_index.tolist(), strict=True):
            if row >= len(visible):
                body_ids.append(track)
            else:
                members.setdefault(track, set()).add(int(visible[row]))
    return members, tracker, body_ids, seen_in


@pytest.mark.parametrize("descriptors_alike", [False, True])
def test_every_floor_track_holds_one_corner(descriptors_alike):
    # with every corner's descriptor the same (a tiled floor), only the geometry tells them apart
    members, tracker, _, seen_in = _tracked(descriptors_alike)
    long = {t: m for t, m in members.items() if tracker.sightings[t] >= 3}
    assert len(long) > 50
    assert all(len(m) == 1 for m in long.values())
    # a corner in view in consecutive images is one track (one seen again after leaving the
    # band for longer than the window starts another)
    tracks_of: dict[int, int] = {}
    for m in members.values():
        corner = next(iter(m))
        tracks_of[corner] = tracks_of.get(corner, 0) + 1
    unbroken = [c for c, im in seen_in.items() if im == list(range(im[0], im[-1] + 1))]
    assert len(unbroken) > 50
    assert all(tracks_of[c] == 1 for c in unbroken)


def test_points_fixed_to_the_robot_never_form_a_track():
    _, tracker, body_ids, _ = _tracked(descriptors_alike=False, body=True)
    assert len(body_ids) == 2 * 13  # two per image, each a new track
    assert np.all(tracker.sightings[np.array(body_ids)] == 1)


def test_a_track_is_continued_by_one_keypoint_only():
    tracker = FloorTracker(VIEWPOINT, FloorTrackConfig(enabled=True, gate_m=0.05))
    desc = np.full((1, 128), 512 / np.sqrt(128), dtype=np.float32)
    first = tracker.process(_rays_to(np.array([[1.0, 0.0]]), np.zeros(3)), desc, np.zeros(3))
    # two keypoints 1 and 3 cm from the track's floor point: the nearer continues it
    rays = _rays_to(np.array([[1.03, 0.0], [1.01, 0.0]]), np.zeros(3))
    second = tracker.process(rays, np.vstack([desc, desc]), np.zeros(3))
    assert first.track_ids.tolist() == [0]
    assert second.track_ids.tolist() == [1, 0]
    assert tracker.sightings.tolist() == [2, 1]


def test_a_different_descriptor_starts_a_new_track():
    tracker = FloorTracker(VIEWPOINT, FloorTrackConfig(enabled=True))
    a = np.zeros((1, 128), dtype=np.float32)
    a[0, 0] = 512
    b = np.zeros((1, 128), dtype=np.float32)
    b[0, 1] = 512  # 724 apart, beyond the default 300
    rays = _rays_to(np.array([[1.0, 0.0]]), np.zeros(3))
    tracker.process(rays, a, np.zeros(3))
    assert tracker.process(rays, b, np.zeros(3)).track_ids.tolist() == [1]


def test_keypoints_above_the_band_are_not_floor_candidates():
    tracker = FloorTracker(VIEWPOINT, FloorTrackConfig(enabled=True))
    far = _rays_to(np.array([[3.0, 0.0]]), np.zeros(3))  # 16 deg down: a wall's foot, maybe
    up = np.array([[1.0, 0.0, 0.2]])
    seen = tracker.process(np.vstack([far, up]), np.zeros((2, 128), np.float32), np.zeros(3))
    assert seen.track_ids.size == 0


def test_a_track_waits_window_images_and_no_longer():
    """``window_images`` 3: a floor point seen in image 0 is continued in image 3 (three images
    later), in image 4 it starts a new track; keypoints that are no candidates are skipped."""
    desc = np.full((1, 128), 512 / np.sqrt(128), dtype=np.float32)
    ray = _rays_to(np.array([[1.0, 0.0]]), np.zeros(3))
    nothing = np.zeros((0, 3))
    for later, expected in ((3, [0]), (4, [1])):
        tracker = FloorTracker(VIEWPOINT, FloorTrackConfig(enabled=True, window_images=3))
        tracker.process(ray, desc, np.zeros(3))
        for _ in range(later - 1):
            tracker.process(nothing, desc[:0], np.zeros(3))
        assert tracker.process(ray, desc, np.zeros(3)).track_ids.tolist() == expected
    skipped = tracker.process(ray, desc, np.zeros(3), candidates=np.array([False]))
    assert skipped.track_ids.size == 0


def test_the_viewpoints_offset_turns_with_the_robot():
    """A viewpoint 0.2 m ahead of the robot's origin: one floor point seen from (0, 0, 0) and
    from (0.5, 0, pi/2) is one track (without the offset the two floor points would be
    0.2 sqrt(2) = 0.28 m apart, beyond the 4 cm gate)."""
    viewpoint = np.array([0.2, 0.0, HEIGHT_M])
    tracker = FloorTracker(viewpoint, FloorTrackConfig(enabled=True))
    desc = np.full((1, 128), 512 / np.sqrt(128), dtype=np.float32)
    point = np.array([1.0, 0.6])
    ids = []
    for pose in (np.zeros(3), np.array([0.5, 0.0, np.pi / 2])):
        c, s = np.cos(pose[2]), np.sin(pose[2])
        rel = (point - pose[:2]) @ np.array([[c, -s], [s, c]]) - viewpoint[:2]
        ray = np.array([[rel[0], rel[1], -HEIGHT_M]])
        ids += tracker.process(ray, desc, pose).track_ids.tolist()
    assert ids == [0, 0]


@pytest.mark.parametrize(
    "kwargs",
    [
        {"min_depression_deg": 0.0},
        {"gate_m": 0.0},
        {"max_descriptor_distance": -1.0},
        {"window_images": 0},
    ],
)
def test_bad_settings_are_refused(kwargs):
    with pytest.raises(ConfigError):
        FloorTrackConfig(**kwargs)


def test_a_viewpoint_on_the_floor_is_refused():
    with pytest.raises(ValueError, match="viewpoint above the floor"):
        FloorTracker(np.zeros(3), FloorTrackConfig())


@pytest.fixture(scope="module")
def demo_logs(demo_sequence):
    """The demo's first images through the front end without and with the floor tracks."""
    from omnislam.frontend.pipeline import run_frontend

    images_only = FrontendConfig(laser=LaserLandmarkConfig(enabled=False))
    assert images_only.floor.enabled  # the default
    plain = run_frontend(
        demo_sequence, dataclasses.replace(images_only, floor=FloorTrackConfig(enabled=False))
    )
    floor = run_frontend(demo_sequence, images_only)
    return plain, floor


@pytest.mark.slow
def test_the_pipeline_adds_floor_tracks_on_the_floor_and_leaves_the_rest(demo_logs, demo_truth):
    plain, floor = demo_logs
    landmark_ids = set()
    for a, b in zip(plain.frames, floor.frames, strict=True):
        if a.bearings is None:
            assert b.bearings is None
            continue
        k = len(a.bearings)  # the landmark tracks come first, unchanged
        np.testing.assert_array_equal(b.bearings.landmark_ids[:k], a.bearings.landmark_ids)
        np.testing.assert_array_equal(b.bearings.unit_vectors_r[:k], a.bearings.unit_vectors_r)
        landmark_ids |= set(a.bearings.landmark_ids.tolist())
    # the floor tracks' ids come after every landmark track's, and the log says where
    assert plain.floor_ids_from is None and floor.floor_ids_from is not None
    assert max(landmark_ids) < floor.floor_ids_from
    floor_ids = {
        int(i) for f in floor.frames if f.bearings is not None
        for i in f.bearings.landmark_ids if i not in landmark_ids
    }
    assert floor_ids and min(floor_ids) >= floor.floor_ids_from
    # every track the log keeps, floor tracks included, has its minimum length
    assert evaluation.track_lengths(floor).min() >= floor.config["tracks"]["min_track_length"]
    ids, points = evaluation.track_truth(evaluation.true_sightings(floor, demo_truth))
    on_floor = np.array([i not in landmark_ids for i in ids.tolist()])
    assert floor.stats["floor_tracks_kept"] >= 30
    assert on_floor.sum() >= 0.95 * floor.stats["floor_tracks_kept"]  # consistent true points
    # ... on the floor, but for a few points a little above it (51 tracks on these images, 3
    # of them 7.5-9.6 cm up: their floor points move 10 % more than the robot, inside the gate;
    # the floor scale's lowest mode leaves them out)
    heights = points[on_floor, 2]
    assert np.mean(np.abs(heights) < 0.01) >= 0.9
    assert np.all(np.abs(heights) < 0.15)


def test_only_the_estimators_that_model_the_floor_are_fed_its_tracks(
    demo_logs, demo_folder, tmp_path
):
    """``omnislam run --log``: the graph takes the floor tracks, FastSLAM 2.0 and EKF-SLAM the
    landmark tracks alone (``EstimatorEntry.floor_tracks``)."""
    from omnislam.frontend.observation_log import save_observation_log
    from omnislam.harness.execute import RunSpec, execute_run

    floor = demo_logs[1]
    path = tmp_path / "floor.npz"
    save_observation_log(floor, path)
    first = floor.floor_ids_from
    for estimator, fed in (("graphslam", True), ("fastslam2", False), ("ekfslam", False)):
        record = execute_run(RunSpec(str(demo_folder), estimator, seed=0, log=str(path)))
        ids = record.estimate.landmark_ids
        assert len(ids) and np.any(ids < first), estimator
        assert np.any(ids >= first) == fed, estimator
