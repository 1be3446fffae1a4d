"""People walking: moving cylinders that occlude the static world, with ids of their own."""

from __future__ import annotations

import numpy as np
import pytest

from omnislam.camera.pinhole import PinholeCamera
from omnislam.camera.rig import CameraRig
from omnislam.core.se import se3_from_se2
from omnislam.datasets.synthetic.lighting import LightingConfig
from omnislam.datasets.synthetic.photo_posters import PhotoTextures, with_photo_textures
from omnislam.datasets.synthetic.render import Renderer
from omnislam.datasets.synthetic.rig_error import RigPerturbation
from omnislam.datasets.synthetic.textures import TextureKind, TextureSpec
from omnislam.datasets.synthetic.walkers import (
    WALL_CLEARANCE_M,
    WalkerPath,
    Walkers,
    draw_walkers,
    walker_hits,
    walker_positions_w,
)
from omnislam.datasets.synthetic.world import SurfaceKind, WorldBuilder
from omnislam.errors import ConfigError, DataError

#: float32 ground-truth points on a walker's surface [m]
ON_SURFACE_M = 1e-5
CLOTH = TextureSpec.make(TextureKind.CLOTH, 5, (1.3, 1.7))


def _walker(start, end, speed=1.0, phase=0.0) -> WalkerPath:
    return WalkerPath(start, end, speed, phase, 0.2, 1.7, CLOTH)


def _room():
    b = WorldBuilder("hall", 0, np.random.default_rng(2))
    b.walls_polygon([(0.0, -3.0), (6.0, -3.0), (6.0, 3.0), (0.0, 3.0)])
    b.floor_and_ceiling(0.0, -3.0, 6.0, 3.0)
    return b.build()


def _rig() -> CameraRig:
    rTc = np.eye(4)
    rTc[:3, :3] = [[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]
    rTc[2, 3] = 1.0
    return CameraRig(PinholeCamera(fx=60.0, fy=60.0, cu=39.5, cv=29.5, width=80, height=60),
                     rTc)


def test_a_walker_paces_its_segment_at_its_speed():
    walker = _walker((0.0, 0.0), (4.0, 0.0), speed=2.0, phase=1.0)
    xy = walker.positions_w(np.array([0.0, 1.5, 3.5, 4.5]))
    np.testing.assert_allclose(xy, [[1.0, 0.0], [4.0, 0.0], [0.0, 0.0], [2.0, 0.0]], atol=1e-12)
    assert WalkerPath.from_dict(walker.to_dict()) == walker
    with pytest.raises(DataError):
        WalkerPath.from_dict({"start_w": [0.0]})
    both = walker_positions_w((walker, _walker((1.0, 1.0), (1.0, 1.0))), np.array([0.0, 9.0]))
    assert both.shape == (2, 2, 2) and np.all(both[:, 1] == 1.0)


def test_walkers_are_drawn_per_seed_inside_the_floor():
    world = _room()
    a = draw_walkers(world, Walkers(count=4), np.random.default_rng(3))
    assert a == draw_walkers(world, Walkers(count=4), np.random.default_rng(3))
    assert a != draw_walkers(world, Walkers(count=4), np.random.default_rng(4))
    assert len(a) == 4
    for walker in a:
        for x, y in (walker.start_w, walker.end_w):
            inset = walker.radius_m + WALL_CLEARANCE_M - 1e-9
            assert inset <= x <= 6.0 - inset and -3.0 + inset <= y <= 3.0 - inset
        assert 0.18 <= walker.radius_m <= 0.25 and 1.55 <= walker.height_m <= 1.90
    assert draw_walkers(world, Walkers(count=0), np.random.default_rng(3)) == ()
    with pytest.raises(ConfigError):
        Walkers(radius_range_m=(0.3, 0.2))


def test_a_walker_between_the_camera_and_a_wall_occludes_it():
    world = _room()
    m = len(world.quads)
    pose = np.array([1.0, 0.0, 0.0])  # facing the wall at x = 6
    walker = _walker((3.0, 0.0), (3.0, 0.0))
    empty = Renderer(world, _rig(), "numpy").render(pose)
    seen = Renderer(world, _rig(), "numpy", walkers=(walker,)).render(pose)
    centre = (29, 39)
    assert world.quads[empty.surface_ids[centre]].kind is SurfaceKind.WALL
    assert seen.surface_ids[centre] == m  # walker 0
    np.testing.assert_allclose(seen.points_w[centre], [2.8, 0.0, 1.0], atol=0.02)
    ids = seen.surface_ids
    on_walker = ids == m
    points = seen.points_w[on_walker].astype(float)
    radial = np.hypot(points[:, 0] - 3.0, points[:, 1])
    np.testing.assert_allclose(radial, 0.2, atol=ON_SURFACE_M)
    assert np.all((points[:, 2] >= 0.0) & (points[:, 2] <= 1.7 + 1e-6))
    # elsewhere the world is untouched
    np.testing.assert_array_equal(ids[~on_walker], empty.surface_ids[~on_walker])
    np.testing.assert_array_equal(seen.image[~on_walker], empty.image[~on_walker])


def test_a_walker_moves_between_frames_as_its_path_says():
    world = _room()
    m = len(world.quads)
    walker = _walker((3.0, -1.5), (3.0, 1.5), speed=1.0)
    renderer = Renderer(world, _rig(), "numpy", walkers=(walker,))
    pose = np.array([1.0, 0.0, 0.0])
    for stamp in (0.5, 1.5, 2.5):
        frame = renderer.render(pose, stamp)
        points = frame.points_w[frame.surface_ids == m].astype(float)
        assert points.shape[0] > 20
        centre = walker.positions_w(np.array([stamp]))[0]
        radial = np.hypot(points[:, 0] - centre[0], points[:, 1] - centre[1])
        np.testing.assert_allclose(radial, 0.2, atol=ON_SURFACE_M)
    assert renderer.render(pose, 0.5).surface_ids[29, 39] != m  # off to the side, then
    assert renderer.render(pose, 1.5).surface_ids[29, 39] == m  # in front of the camera


def test_the_omni_render_finds_every_walker_hit(demo_sim):
    """The azimuth culling misses nothing: the brute-force cast of every ray agrees."""
    walkers = draw_walkers(demo_sim.world, Walkers(count=4), np.random.default_rng(0))
    m = len(demo_sim.world.quads)
    renderer = Renderer(demo_sim.world, demo_sim.rig, None, walkers=walkers)
    index = demo_sim.image_frames[4]
    pose, stamp = demo_sim.poses_w[index], float(demo_sim.stamps_s[index])
    frame = renderer.render(pose, stamp)
    empty = Renderer(demo_sim.world, demo_sim.rig, None).render(pose)
    rows, cols = np.nonzero(demo_sim.rig.camera.mask())
    rays_r = demo_sim.rig.rays_r(np.column_stack([cols, rows]).astype(float))
    keep = np.all(np.isfinite(rays_r), axis=1)
    rows, cols, rays_r = rows[keep], cols[keep], rays_r[keep]
    wTr = se3_from_se2(pose)
    origin_w = wTr[:3, :3] @ demo_sim.rig.viewpoint_r + wTr[:3, 3]
    rays_w = rays_r @ wTr[:3, :3].T
    t, k = walker_hits(walker_positions_w(walkers, np.array([stamp]))[0],
                       np.array([w.radius_m for w in walkers]),
                       np.array([w.height_m for w in walkers]),
                       np.repeat(origin_w[:, None], len(rays_w), axis=1), rays_w.T)
    static_m = np.linalg.norm(empty.points_w[rows, cols] - origin_w, axis=1)
    expected = np.where(t < np.where(np.isnan(static_m), np.inf, static_m), m + k,
                        empty.surface_ids[rows, cols])
    assert np.sum(expected >= m) > 100
    np.testing.assert_array_equal(frame.surface_ids[rows, cols], expected)


@pytest.mark.slow
def test_every_option_together(demo_sim):
    world = with_photo_textures(demo_sim.world, PhotoTextures(), np.random.default_rng(1))
    walkers = draw_walkers(world, Walkers(), np.random.default_rng(1))
    renderer = Renderer(world, demo_sim.rig, None, supersample=2, lighting=LightingConfig(),
                        rig_error=RigPerturbation((0.001, 0.0, -0.001), (0.005, 0.0, 0.0)),
                        walkers=walkers)
    index = demo_sim.image_frames[3]
    frame = renderer.render(demo_sim.poses_w[index], float(demo_sim.stamps_s[index]))
    inside = demo_sim.rig.camera.mask()
    assert np.mean(frame.surface_ids[inside] >= 0) > 0.99
    hit = frame.surface_ids >= 0
    assert np.all(np.isfinite(frame.points_w[hit]))
    assert frame.image[inside].mean() > 40
