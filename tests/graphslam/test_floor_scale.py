"""The odometry's scale from floor points (``floor_scale.py``) and the fixed-lag session.

Scenario: a robot drives a 2 m circle whose wheel odometry over-states every translation by
3%; around the path lie points on the floor (z = 0) and points on low objects (z 0.15-0.6 m)
that the omni camera at ``SENSOR_HEIGHT_M`` sees within 1.2 m, with angular noise.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from graphslam_scenarios import SENSOR_HEIGHT_M

from omnislam.core.measurement import unit_vectors_from_azimuth_elevation
from omnislam.core.modality import Modality
from omnislam.core.se import se2_between, wrap_angle
from omnislam.core.types import UNKNOWN_ID, Bearings, FrameInput, Odometry
from omnislam.errors import ConfigError
from omnislam.graphslam import GraphSLAM, GraphSLAMConfig, isam
from omnislam.graphslam.config import FloorConfig, PoseConfig, SolverConfig
from omnislam.graphslam.floor_scale import MIN_PAIRS, FloorScale, KnownScale
from omnislam.graphslam.session import FixedLagSession

WHEEL_SCALE = 1.03  # the odometry says 3% more than was driven
SIGMA_RAD = 0.003


def _scenario(rng, floor_points=400, raised_points=200, n=200, raised_z_m=(0.15, 0.6)):
    """(frames, true poses (n, 3), points (M, 3)) of the module docstring's circle."""
    angle = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    poses = np.column_stack(
        [2 * np.sin(angle), 2 - 2 * np.cos(angle), wrap_angle(angle)]
    )  # starts at the origin heading +x, counter-clockwise

    def near_path(count):
        anchor = poses[rng.integers(0, n, count), :2]
        offset = rng.uniform(0.3, 1.0, count)
        direction = rng.uniform(-np.pi, np.pi, count)
        return anchor + offset[:, None] * np.column_stack([np.cos(direction), np.sin(direction)])

    points = np.vstack(
        [
            np.column_stack([near_path(floor_points), np.zeros(floor_points)]),
            np.column_stack([near_path(raised_points), rng.uniform(*raised_z_m, raised_points)]),
        ]
    )
    frames = []
    for k in range(n):
        delta = np.zeros(3) if k == 0 else se2_between(poses[k - 1], poses[k])
        delta[:2] *= WHEEL_SCALE
        x, y, theta = poses[k]
        to = points[:, :2] - (x, y)
        seen = np.flatnonzero(np.hypot(*to.T) < 1.2)
        azimuth = np.arctan2(to[seen, 1], to[seen, 0]) - theta
        elevation = np.arctan2(points[seen, 2] - SENSOR_HEIGHT_M, np.hypot(*to[seen].T))
        noisy = np.column_stack([azimuth, elevation])
        noisy += SIGMA_RAD * rng.standard_normal(noisy.shape)
        frames.append(
            FrameInput(
                index=k,
                odometry=Odometry(delta, float(k)),
                bearings=Bearings(
                    seen,
                    unit_vectors_from_azimuth_elevation(noisy[:, 0], noisy[:, 1]),
                    np.full(len(seen), SIGMA_RAD),
                ),
            )
        )
    return frames, poses, points


def _observe_all(frames) -> FloorScale:
    floor = FloorScale(SENSOR_HEIGHT_M)
    for frame in frames:
        floor.observe(frame.odometry.delta, frame.bearings)
    return floor


def test_floor_points_give_the_wheel_scale_despite_raised_points():
    frames, _, _ = _scenario(np.random.default_rng(0))
    floor = _observe_all(frames)
    # the raised points (a third of the pairs) look like scales of 1.2-3.4 and are not the mode
    assert floor.scale == pytest.approx(1 / WHEEL_SCALE, rel=3e-3)
    assert floor.inliers >= 50


def test_the_floor_is_the_lowest_mode_even_below_more_points_just_above_it():
    """Points 3-4 cm above the floor (skirting boards, the feet of boxes) look like a scale
    ~4 % larger and may be the majority (lab40's log): the floor is the lowest mode."""
    frames, _, _ = _scenario(
        np.random.default_rng(4), floor_points=150, raised_points=400, raised_z_m=(0.03, 0.04)
    )
    floor = _observe_all(frames)
    assert floor.scale == pytest.approx(1 / WHEEL_SCALE, rel=5e-3)


def test_without_floor_points_the_scale_stays_one():
    frames, _, _ = _scenario(np.random.default_rng(1), floor_points=0)
    floor = _observe_all(frames)
    assert floor.pairs > 50  # the raised points do form pairs
    assert floor.scale == 1.0 and floor.inliers == 0


def test_points_fixed_in_the_robot_frame_are_no_floor():
    """Features that move with the robot (its own body in the mirror) give s = 0, not 1."""
    frames, _, _ = _scenario(np.random.default_rng(2), floor_points=0, raised_points=0)
    body = unit_vectors_from_azimuth_elevation(np.array([0.5, 2.0]), np.array([-0.9, -1.0]))
    frames = [
        replace(f, bearings=Bearings(np.array([7, 8]), body, np.full(2, SIGMA_RAD))) for f in frames
    ]
    assert _observe_all(frames).scale == 1.0


def _straight(xs, lateral=(0.3, 0.4, 0.5, 0.6), unknown=False):
    """Frames of a robot driving along x through ``xs`` (odometry exact) past floor points
    every 5 cm along the path at the given lateral offsets, seen exactly while 35 deg or
    more below the horizon; with ``unknown`` each frame also sees one floor point of its own
    with UNKNOWN_ID, all on one line along the path (as one track they would pair)."""
    grid = np.array([(x, y) for x in np.arange(-1.0, xs[-1] + 1.0, 0.05) for y in lateral])
    frames, previous = [], xs[0]
    for k, x in enumerate(xs):
        to = grid - (x, 0.0)
        rays = np.column_stack([to, np.full(len(to), -SENSOR_HEIGHT_M)])
        rays /= np.linalg.norm(rays, axis=1, keepdims=True)
        seen = np.flatnonzero(rays[:, 2] <= -np.sin(np.radians(35.0)))
        ids, rays = seen, rays[seen]
        if unknown:
            extra = np.array([[0.4 - 0.5 * x, -0.35, -SENSOR_HEIGHT_M]])  # at (0.4 + x / 2, -0.35)
            ids = np.append(ids, UNKNOWN_ID)
            rays = np.vstack([rays, extra / np.linalg.norm(extra)])
        delta = np.array([x - previous, 0.0, 0.0])
        previous = x
        bearings = Bearings(ids, rays, np.full(len(ids), SIGMA_RAD))
        frames.append(FrameInput(index=k, odometry=Odometry(delta, float(k)), bearings=bearings))
    return frames


def test_pairs_need_a_baseline_a_landmark_id_and_the_frames_own_poses():
    """Exact floor bearings on a straight drive with growing steps (x_k = 0.004 k^2):
    pairs over less than MIN_BASELINE_M (5 cm) are not used; sightings without an id never
    pair; refined over the true poses the scale is 1 (frame i's pose, not a neighbour's: with
    growing steps a pair's baseline would be off by (i + j) / (i + j - 2))."""
    assert _observe_all(_straight(0.002 * np.arange(20))).pairs == 0  # 3.8 cm in all
    xs = 0.004 * np.arange(30) ** 2
    floor = _observe_all(_straight(xs))
    assert floor.inliers >= MIN_PAIRS and floor.scale == pytest.approx(1.0, abs=1e-6)
    with_unknown = _observe_all(_straight(xs, unknown=True))
    assert with_unknown.pairs == floor.pairs and with_unknown.scale == floor.scale
    poses = np.column_stack([xs, np.zeros((len(xs), 2))])
    refined = floor.refined(poses)
    assert refined.scale == pytest.approx(1.0, abs=1e-6) and refined.inliers == floor.inliers


def _ate_scale(estimate, poses):
    """Least-squares scale of the estimated positions about the first pose vs the truth."""
    est = estimate.trajectory.se2[:, :2] - estimate.trajectory.se2[0, :2]
    true = poses[:, :2] - poses[0, :2]
    return float(np.sum(est * true) / np.sum(true * true))


@pytest.mark.slow
def test_graphslam_takes_the_floors_scale():
    frames, poses, _ = _scenario(np.random.default_rng(3))
    config = GraphSLAMConfig(poses=PoseConfig(sensor_height_m=SENSOR_HEIGHT_M))
    metric = GraphSLAM(Modality.BEARINGS_3D, config)
    wheel = GraphSLAM(Modality.BEARINGS_3D, replace(config, floor=FloorConfig(scale=False)))
    for frame in frames:
        metric.step(frame)
        wheel.step(frame)
    assert metric.info().odometry_scale == pytest.approx(1 / WHEEL_SCALE, rel=5e-3)
    assert wheel.info().odometry_scale == 1.0 and wheel.info().floor_pairs == 0
    # bearings alone keep the odometry's 3% (the graph cannot see scale) ...
    assert _ate_scale(wheel.estimate(), poses) == pytest.approx(WHEEL_SCALE, rel=5e-3)
    # ... the floor points remove it, in the final estimate from the first frame on (online,
    # the first ~20 images had the wheel's scale: 0.006 before floor.scale_final)
    assert abs(_ate_scale(metric.estimate(), poses) - 1) < 0.003


@pytest.mark.slow
@pytest.mark.parametrize("seed", [3, 5])
def test_the_final_estimate_takes_the_runs_final_floor_scale(seed):
    """Floor points only in the second half: the first half's odometry enters the online graph
    at the wheel's scale (the floor's not known yet). The final estimate takes every odometry
    translation at the final floor scale, so the whole trajectory, its first half included, has
    the floor's scale; without that, the first half keeps much of the wheel's 3%."""
    frames, poses, _ = _scenario(np.random.default_rng(seed))
    half = len(frames) // 2
    late = []
    for frame in frames:
        if frame.index < half:  # only the raised points (ids >= 400) are seen
            b = frame.bearings
            keep = b.landmark_ids >= 400
            frame = replace(frame, bearings=Bearings(b.landmark_ids[keep], b.unit_vectors_r[keep],
                                                     b.sigmas_rad[keep]))
        late.append(frame)
    config = GraphSLAMConfig(poses=PoseConfig(sensor_height_m=SENSOR_HEIGHT_M))
    final = GraphSLAM(Modality.BEARINGS_3D, config)
    online = GraphSLAM(Modality.BEARINGS_3D, replace(config, floor=FloorConfig(scale_final=False)))
    for frame in late:
        final.step(frame)
        online.step(frame)
        # the online estimate is the same: only the final one is rescaled
        np.testing.assert_array_equal(final.newest_pose(), online.newest_pose())
    scale = final.info().odometry_scale
    assert scale == pytest.approx(1 / WHEEL_SCALE, rel=3e-3)
    first = slice(0, half)
    truth = poses[first, :2] - poses[0, :2]

    def first_half_scale(estimate):
        est = estimate.trajectory.se2[first, :2] - estimate.trajectory.se2[0, :2]
        return float(np.sum(est * truth) / np.sum(truth * truth))

    assert first_half_scale(final.estimate()) == pytest.approx(scale * WHEEL_SCALE, abs=2e-3)
    assert first_half_scale(online.estimate()) - scale * WHEEL_SCALE > 0.01
    # estimate() can be called again, and stepping on after it works
    assert first_half_scale(final.estimate()) == pytest.approx(scale * WHEEL_SCALE, abs=2e-3)


def _noisy_odometry(frames, rng, sigma=0.15):
    """``frames`` with each step's translation multiplied by 1 + N(0, ``sigma``^2) (the wheels'
    per-step noise, large: the floor pairs' scales spread as on lab40)."""
    noisy = []
    for frame in frames:
        delta = frame.odometry.delta.copy()
        delta[:2] *= 1 + sigma * rng.standard_normal()
        noisy.append(replace(frame, odometry=Odometry(delta, frame.odometry.stamp_s)))
    return noisy


@pytest.mark.slow
def test_refined_pairs_measure_the_trajectorys_own_scale():
    """Over a trajectory that is the truth scaled by k, the floor pairs say 1 / k, whatever the
    raw odometry's noise (which spreads the raw pairs)."""
    rng = np.random.default_rng(6)
    frames, poses, _ = _scenario(rng)
    floor = _observe_all(_noisy_odometry(frames, rng))
    for k in (1.0, 1.02, 0.97):
        scaled = poses.copy()
        scaled[:, :2] *= k
        refined = floor.refined(scaled)
        assert refined.scale == pytest.approx(1 / k, rel=1e-3)
        assert refined.inliers >= 50
    with pytest.raises(ValueError, match="poses must be"):
        floor.refined(poses[:-1])


@pytest.mark.slow
@pytest.mark.parametrize("seed", [2, 3])
def test_the_final_floor_scale_is_refined_over_the_graphs_trajectory(seed):
    """Per-step odometry noise of 15 % leaves the raw pairs' scale 1-1.7 % off on these seeds;
    re-estimated over the graph's trajectory (held by the bearings), the final estimate's scale
    is within 0.2 % of the truth (the pairs' path: without ``floor.landmarks``)."""
    rng = np.random.default_rng(seed)
    frames, poses, _ = _scenario(rng)
    frames = _noisy_odometry(frames, rng)
    config = GraphSLAMConfig(
        poses=PoseConfig(sensor_height_m=SENSOR_HEIGHT_M), floor=FloorConfig(landmarks=False)
    )
    raw = GraphSLAM(
        Modality.BEARINGS_3D,
        replace(config, floor=FloorConfig(landmarks=False, scale_refine=False)),
    )
    refined = GraphSLAM(Modality.BEARINGS_3D, config)
    for frame in frames:
        raw.step(frame)
        refined.step(frame)
    assert abs(_ate_scale(raw.estimate(), poses) - 1) > 0.008
    assert abs(_ate_scale(refined.estimate(), poses) - 1) < 0.002
    # the info reports the refined scale, and reading again changes nothing
    assert refined.info().odometry_scale != raw.info().odometry_scale
    first = refined.estimate().trajectory.se2
    np.testing.assert_array_equal(refined.estimate().trajectory.se2, first)


@pytest.mark.slow
def test_fixed_lag_final_estimate_is_the_whole_graph_optimum():
    """The smoother's window is bounded; ``estimate()`` smooths every factor, as iSAM2 does
    (with the odometry at the scales it was added at, as iSAM2 has it)."""
    frames, _, _ = _scenario(np.random.default_rng(4))
    config = GraphSLAMConfig(
        poses=PoseConfig(sensor_height_m=SENSOR_HEIGHT_M),
        solver=SolverConfig(online_lag_key_frames=5),
        floor=FloorConfig(scale_final=False),
    )
    lagged = GraphSLAM(Modality.BEARINGS_3D, config)
    whole = GraphSLAM(
        Modality.BEARINGS_3D, replace(config, solver=SolverConfig(online_lag_key_frames=None))
    )
    window = []
    for frame in frames:
        lagged.step(frame)
        whole.step(frame)
        window.append(len(lagged.session._alive))
    assert isinstance(lagged.session, FixedLagSession)
    assert lagged.info().factors == whole.info().factors
    assert max(window[-50:]) < 0.5 * (lagged.info().landmarks + lagged.info().key_frames)
    a, b = lagged.estimate(), whole.estimate()
    np.testing.assert_array_equal(a.landmark_ids, b.landmark_ids)
    np.testing.assert_allclose(a.trajectory.se2, b.trajectory.se2, atol=2e-3)
    np.testing.assert_allclose(a.landmarks_w, b.landmarks_w, atol=5e-3)


class _FailingOnce(FixedLagSession):
    """A session whose smoother fails once, as GTSAM 4.3.0's does on loop150."""

    fail_at = 12

    def __init__(self, *args):
        super().__init__(*args)
        real = self._smoother

        class Smoother:
            def __init__(self, outer):
                self._outer = outer

            def update(self, *args):
                if self._outer._updates == self._outer.fail_at:
                    raise ValueError("Asking to remove variables from the variable index")
                return real.update(*args)

            def __getattr__(self, name):
                return getattr(real, name)

        self._smoother = Smoother(self)


@pytest.mark.slow
def test_fixed_lag_restarts_on_the_window_after_a_failed_update(monkeypatch):
    frames, _, _ = _scenario(np.random.default_rng(5))
    config = GraphSLAMConfig(
        poses=PoseConfig(sensor_height_m=SENSOR_HEIGHT_M),
        solver=SolverConfig(online_lag_key_frames=5),
    )
    plain = GraphSLAM(Modality.BEARINGS_3D, config)
    monkeypatch.setattr(isam, "FixedLagSession", _FailingOnce)
    restarted = GraphSLAM(Modality.BEARINGS_3D, config)
    assert isinstance(restarted.session, _FailingOnce)
    for frame in frames:
        restarted.step(frame)
        plain.step(frame)
    assert restarted.info().online_restarts == 1 and plain.info().online_restarts == 0
    a, b = restarted.estimate(), plain.estimate()
    np.testing.assert_allclose(a.trajectory.se2, b.trajectory.se2, atol=5e-3)


def test_a_known_odometry_scale_replaces_the_floor_points():
    """``known_odometry_scale`` multiplies every translation from the first frame; the floor
    points are not used (the module's circle, whose wheel odometry says 3% too much)."""
    frames, poses, _ = _scenario(np.random.default_rng(3))
    config = GraphSLAMConfig(
        poses=PoseConfig(sensor_height_m=SENSOR_HEIGHT_M),
        floor=FloorConfig(known_odometry_scale=1 / WHEEL_SCALE),
    )
    known = GraphSLAM(Modality.BEARINGS_3D, config)
    for frame in frames:
        known.step(frame)
    assert known.info().odometry_scale == 1 / WHEEL_SCALE and known.info().floor_pairs == 0
    assert known.info().floor_landmarks == 0  # no floor tracks join its final estimate either
    assert KnownScale(1.0).floor_tracks().shape == (0,)
    assert _ate_scale(known.estimate(), poses) == pytest.approx(1.0, abs=2e-3)
    with pytest.raises(ConfigError, match="known_odometry_scale"):
        FloorConfig(known_odometry_scale=0.0)
