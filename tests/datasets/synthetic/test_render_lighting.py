"""Lamps at the light panels: inverse-square falloff, Lambert's cosine, ambient far away."""

from __future__ import annotations

import math

import numpy as np
import pytest

from omnislam.camera.pinhole import PinholeCamera
from omnislam.camera.rig import CameraRig
from omnislam.datasets.synthetic.lighting import LightingConfig, lamp_irradiance, lamp_positions
from omnislam.datasets.synthetic.render import Renderer
from omnislam.datasets.synthetic.textures import TextureKind
from omnislam.datasets.synthetic.world import SurfaceKind, WorldBuilder
from omnislam.errors import ConfigError

#: relative agreement of the rendered lamp term with the reference (uint8 rounding of
#: pixels of at least MIN_LEVEL)
RENDER_RTOL = 0.03
MIN_LEVEL = 60


def _room(lamp_xy: tuple[float, float] = (3.0, 2.0)):
    """A 12 x 4 m room, one light panel over ``lamp_xy`` (no other lamps)."""
    b = WorldBuilder("lamp-room", 0, np.random.default_rng(1))
    b.walls_polygon([(0.0, 0.0), (12.0, 0.0), (12.0, 4.0), (0.0, 4.0)])
    b.floor_and_ceiling(0.0, 0.0, 12.0, 4.0, lights_every_m=None)
    light = b.texture(TextureKind.LIGHT, (0.6, 0.6))
    x, y = lamp_xy
    b.quad(SurfaceKind.LIGHT, (x - 0.3, y + 0.3, 2.595), (0.6, 0, 0), (0, -0.6, 0), light)
    return b.build()


def _rig() -> CameraRig:
    """A pinhole camera 1 m above the floor looking along the robot's x."""
    rTc = np.eye(4)
    rTc[:3, :3] = [[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]
    rTc[2, 3] = 1.0
    camera = PinholeCamera(fx=80.0, fy=80.0, cu=79.5, cv=59.5, width=160, height=120)
    return CameraRig(camera, rTc)


def test_the_reference_term_falls_with_the_square_and_the_cosine():
    config = LightingConfig(lamp_power_m2=2.0)
    lamp = np.array([[0.0, 0.0, 2.0]])
    up = np.array([0.0, 0.0, 1.0])
    points = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    e = lamp_irradiance(points, np.tile(up, (3, 1)), np.array([5.0, 5.0, 1.5]), lamp, config)
    assert e[0] == pytest.approx(2.0)  # P / d^2 at 1 m, facing the lamp
    assert e[1] == pytest.approx(2.0 / 4.0)  # twice as far: a quarter
    assert e[2] == pytest.approx(2.0 / 8.0 * math.cos(math.pi / 4))  # sqrt(8) m, 45 deg
    seen_from_below = lamp_irradiance(points, np.tile(up, (3, 1)), np.array([5.0, 5.0, -1.0]),
                                      lamp, config)
    np.testing.assert_array_equal(seen_from_below, 0.0)  # the lamp is on the other side


def test_lamps_sit_under_the_light_panels():
    world = _room((3.0, 2.0))
    lamps = lamp_positions(world, LightingConfig(lamp_drop_m=0.05))
    np.testing.assert_allclose(lamps, [[3.0, 2.0, 2.545]])


@pytest.mark.parametrize("field", ["ambient", "lamp_power_m2", "lamp_drop_m", "min_distance_m"])
def test_bad_lighting_is_refused(field):
    with pytest.raises(ConfigError, match=field):
        LightingConfig(**{field: -1.0})


def test_a_wall_is_brighter_nearer_the_lamp_and_ambient_far_from_it():
    world = _room((11.0, 3.6))  # near one end of the far wall, seen from (1, 2) facing +x
    config = LightingConfig(lamp_power_m2=1.0, ambient=0.4)
    pose = np.array([1.0, 2.0, 0.0])
    dark = Renderer(world, _rig(), "numpy", lighting=LightingConfig(lamp_power_m2=0.0,
                                                                    ambient=0.4)).render(pose)
    lit = Renderer(world, _rig(), "numpy", lighting=config).render(pose)
    np.testing.assert_array_equal(lit.surface_ids, dark.surface_ids)
    quads = world.arrays()
    ids = lit.surface_ids
    unshaded = np.array([q.kind is SurfaceKind.LIGHT for q in world.quads] + [True])
    seen = ~unshaded[ids] & (dark.image.min(axis=2) >= MIN_LEVEL)
    points = lit.points_w[seen].astype(float)
    normals = quads.normals_w[ids[seen]]
    lamps = lamp_positions(world, config)
    expected = lamp_irradiance(points, normals, np.array([1.0, 2.0, 1.0]), lamps, config)
    ratio = lit.image[seen].astype(float) / dark.image[seen]
    measured = (ratio.mean(axis=1) - 1.0) * config.ambient  # image = texture (ambient + E) fog
    unclipped = lit.image[seen].max(axis=1) < 250
    error = np.abs(measured - expected)[unclipped]
    assert np.all(error <= RENDER_RTOL * (1.0 + expected[unclipped]))
    assert expected[unclipped].max() > 0.5  # some pixels are well lit
    # the same wall: its points near the lamp are brighter than those far from it
    wall = seen & (ids == _far_wall(world))
    y, z = lit.points_w[..., 1], lit.points_w[..., 2]
    near, far = wall & (y > 3.0) & (z > 1.8), wall & (y < 0.5) & (z < 0.5)
    assert near.any() and far.any()
    excess = lit.image.astype(float).mean(axis=2) / np.maximum(dark.image.mean(axis=2), 1) - 1
    assert excess[near].min() > 1.0  # under 1.2 m from the lamp: over twice the ambient
    assert excess[far].max() < 0.05  # over 4 m away: the ambient term alone, nearly


def _far_wall(world) -> int:
    """Surface id of the wall at x = 12."""
    for i, q in enumerate(world.quads):
        if q.kind is SurfaceKind.WALL and q.origin_w[0] == 12.0 and q.edge_u_w[0] == 0.0:
            return i
    raise AssertionError("no wall at x = 12")


def test_one_wall_point_under_a_lamp_twice_as_far_gets_a_quarter_of_its_light():
    config = LightingConfig(lamp_power_m2=1.0, ambient=0.4)
    pose = np.array([1.0, 2.0, 0.0])
    rig = _rig()
    dark = Renderer(_room((11.0, 2.0)), rig, "numpy",
                    lighting=LightingConfig(lamp_power_m2=0.0, ambient=0.4)).render(pose)
    excess = []
    for lamp_x in (11.0, 10.0):  # 1 m and 2 m in front of the wall at x = 12
        world = _room((lamp_x, 2.0))
        lit = Renderer(world, rig, "numpy", lighting=config).render(pose)
        lamp = lamp_positions(world, config)[0]
        # the pixel of the wall point straight in front of the lamp (normal incidence)
        _, pixel = _pixel_of(lit, np.array([12.0, 2.0, lamp[2]]))
        ratio = lit.image[pixel].astype(float) / dark.image[pixel]
        excess.append((ratio.mean() - 1.0) * config.ambient)
    assert excess[0] == pytest.approx(1.0, rel=RENDER_RTOL)  # P / d^2 at 1 m
    assert excess[1] == pytest.approx(0.25, rel=4 * RENDER_RTOL)  # a quarter at 2 m


def _pixel_of(frame, point_w: np.ndarray) -> tuple[float, tuple[int, int]]:
    """Distance [m] and (row, col) of the pixel whose ground-truth point is nearest
    ``point_w``."""
    distance = np.linalg.norm(np.nan_to_num(frame.points_w, nan=1e9) - point_w, axis=2)
    row, col = np.unravel_index(np.argmin(distance), distance.shape)
    return float(distance[row, col]), (int(row), int(col))
