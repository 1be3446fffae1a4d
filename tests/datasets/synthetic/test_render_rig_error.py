"""An imperfect rig: non-central mirror rays, a tilt, and the ground truth of the rays cast."""

from __future__ import annotations

import math

import numpy as np
import pytest

from omnislam.camera.hyperbolic import HyperbolicCamera
from omnislam.camera.pinhole import PinholeCamera
from omnislam.camera.rig import CameraRig
from omnislam.core.se import se3_from_se2, se3_inverse, se3_transform_points
from omnislam.datasets.synthetic.raycast_numpy import NumpyRayCaster
from omnislam.datasets.synthetic.render import Renderer
from omnislam.datasets.synthetic.rig_error import (
    RigError,
    RigPerturbation,
    draw_rig_perturbation,
    mirror_rays_s,
    true_rays_r,
)
from omnislam.datasets.synthetic.world import WorldBuilder
from omnislam.errors import ConfigError, DataError

#: a rig at the bounds of the default RigError: 1 mm offsets, roll and pitch ~0.5 deg
PERTURBATION = RigPerturbation((0.001, -0.001, 0.001), (0.008, -0.007, 0.0))
#: distance of a float32 ground-truth point from its ray [m]
ON_RAY_M = 2e-5
#: reprojection through the true rig [px]
REPROJECTION_PX = 0.01


def _mask_pixels(camera, step: int) -> np.ndarray:
    rows, cols = np.nonzero(camera.mask())
    return np.column_stack([cols, rows]).astype(float)[::step]


def test_a_pinhole_at_the_focus_gives_the_central_rays():
    camera = HyperbolicCamera()
    pixels = _mask_pixels(camera, 97)
    points, rays = mirror_rays_s(camera, np.zeros(3), pixels)
    np.testing.assert_allclose(rays, camera.unproject(pixels), atol=1e-12)
    # the focal property: every reflected ray passes through F2 (the origin of S)
    np.testing.assert_allclose(np.cross(points, rays), 0.0, atol=1e-14)
    np.testing.assert_allclose(camera.mirror_point(rays), points, atol=1e-14)


def test_an_offset_pinhole_makes_the_rays_non_central():
    camera = HyperbolicCamera()
    pixels = _mask_pixels(camera, 97)
    points, rays = mirror_rays_s(camera, np.array([0.001, 0.0, 0.0]), pixels)
    miss_m = np.linalg.norm(np.cross(points, rays), axis=1)  # distance of each ray from F2
    assert 1e-4 < np.median(miss_m) < 1e-3  # a fraction of the millimetre offset
    turn_deg = np.degrees(np.arccos(np.clip(np.sum(rays * camera.unproject(pixels), 1), -1, 1)))
    assert 0.2 < np.median(turn_deg) < 0.8
    # the reflection law: incoming and outgoing rays make equal angles with the normal
    e, a2, b2 = camera.e_m, camera.a_m**2, camera.b_m**2
    normal = np.column_stack([-points[:, 0] / b2, -points[:, 1] / b2, (points[:, 2] + e) / a2])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    incoming = points - np.array([0.001, 0.0, -2.0 * e])
    incoming /= np.linalg.norm(incoming, axis=1, keepdims=True)
    np.testing.assert_allclose(np.sum(rays * normal, 1), -np.sum(incoming * normal, 1),
                               atol=1e-12)


def test_draws_are_bounded_seeded_and_round_trip():
    config = RigError()
    draws = [draw_rig_perturbation(config, np.random.default_rng(s)) for s in range(20)]
    assert draws[3] == draw_rig_perturbation(config, np.random.default_rng(3))
    for draw in draws:
        assert np.all(np.abs(draw.offset_s_m) <= config.max_offset_m)
        assert np.all(np.abs(draw.tilt_r_rad[:2]) <= config.max_tilt_rad)
        assert draw.tilt_r_rad[2] == 0.0
        assert RigPerturbation.from_dict(draw.to_dict()) == draw
    assert math.degrees(np.linalg.norm(draws[0].tilt_r_rad)) < 1.0
    with pytest.raises(DataError):
        RigPerturbation.from_dict({"offset_s_m": [0.0, 0.0], "tilt_r_rad": [0.0, 0.0, 0.0]})
    with pytest.raises(ConfigError):
        RigError(max_offset_m=-0.001)


def test_per_ray_origins_cast_like_one_origin():
    b = WorldBuilder("box", 0, np.random.default_rng(0))
    b.walls_polygon([(0.0, 0.0), (4.0, 0.0), (4.0, 3.0), (0.0, 3.0)])
    b.floor_and_ceiling(0.0, 0.0, 4.0, 3.0)
    caster = NumpyRayCaster(b.build().arrays())
    directions = np.random.default_rng(1).normal(size=(500, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    origin = np.array([1.0, 1.5, 1.0])
    np.testing.assert_array_equal(caster.first_hits(np.tile(origin, (500, 1)), directions),
                                  caster.first_hits(origin, directions))


def _true_pixels(rig, perturbation, points_r, pixels0):
    """Pixels whose true rays pass through ``points_r`` (Gauss-Newton from ``pixels0`` on the
    point's offset across the ray, numerical Jacobian)."""
    def across(pixels):
        origins, rays = true_rays_r(rig, perturbation, pixels)
        rel = points_r - origins
        return rel - np.sum(rel * rays, axis=1, keepdims=True) * rays

    pixels = pixels0.copy()
    for _ in range(8):
        r = across(pixels)
        J = np.stack([(across(pixels + h) - r) / 1e-4 for h in ([1e-4, 0], [0, 1e-4])], axis=2)
        step = np.linalg.lstsq(J[0], -r[0], rcond=None)[0] if len(pixels) == 1 else np.stack(
            [np.linalg.lstsq(Jk, -rk, rcond=None)[0] for Jk, rk in zip(J, r, strict=True)])
        pixels = pixels + step
    return pixels


def test_ground_truth_is_that_of_the_true_rays(demo_sim):
    rig = demo_sim.rig
    pose = demo_sim.poses_w[demo_sim.image_frames[2]]
    frame = Renderer(demo_sim.world, rig, None, rig_error=PERTURBATION).render(pose)
    rows, cols = np.nonzero(frame.surface_ids >= 0)
    pick = np.random.default_rng(0).choice(rows.size, 300, replace=False)
    pixels = np.column_stack([cols[pick], rows[pick]]).astype(float)
    points_r = se3_transform_points(se3_inverse(se3_from_se2(pose)),
                                    frame.points_w[rows[pick], cols[pick]].astype(float))
    origins, rays = true_rays_r(rig, PERTURBATION, pixels)
    rel = points_r - origins
    assert np.linalg.norm(np.cross(rel, rays), axis=1).max() < ON_RAY_M
    assert np.all(np.sum(rel * rays, axis=1) > 0)  # in front of the ray's origin
    nominal, valid = rig.project_r(points_r)
    assert valid.all()
    reprojected = _true_pixels(rig, PERTURBATION, points_r, nominal)
    assert np.abs(reprojected - pixels).max() < REPROJECTION_PX
    assert np.median(np.hypot(*(nominal - pixels).T)) > 1.0  # the nominal rig misses them


def test_an_offset_centre_shows_the_parallax_of_a_wall_at_one_metre():
    b = WorldBuilder("wall", 0, np.random.default_rng(0))
    b.walls_polygon([(0.0, -5.0), (3.0, -5.0), (3.0, 5.0), (0.0, 5.0)])
    b.floor_and_ceiling(0.0, -5.0, 3.0, 5.0)
    rTc = np.eye(4)
    rTc[:3, :3] = [[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]
    rTc[2, 3] = 1.0
    rig = CameraRig(PinholeCamera(fx=80.0, fy=80.0, cu=39.5, cv=29.5, width=80, height=60), rTc)
    offset = np.array([0.004, -0.003, 0.0])  # camera x right, y down: 4 mm right, 3 mm up
    pose = np.array([2.0, 0.0, 0.0])  # 1 m before the wall at x = 3
    frame = Renderer(b.build(), rig, "numpy", rig_error=RigPerturbation(tuple(offset))).render(
        pose)
    rows, cols = np.nonzero(frame.surface_ids >= 0)
    points_w = frame.points_w[rows, cols].astype(float)
    on_wall = np.abs(points_w[:, 0] - 3.0) < 1e-6
    points_r = se3_transform_points(se3_inverse(se3_from_se2(pose)), points_w[on_wall])
    nominal, _ = rig.project_r(points_r)
    shift = nominal - np.column_stack([cols, rows])[on_wall]
    # seen from the nominal centre the points move by f offset / depth (depth 1 m)
    np.testing.assert_allclose(shift, np.broadcast_to(80.0 * offset[:2] / 1.0, shift.shape),
                               atol=1e-3)
