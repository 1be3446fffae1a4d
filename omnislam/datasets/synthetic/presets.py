"""Named synthetic scenarios: a world, a route, the sensors (README lists them from here).

| preset | description |
|---|---|
| ``demo`` | ~60 omni frames driving a loop in a small furnished room (the embedded default) |
| ``lab40`` | thesis Magellan Pro run: ~40 m, <= 0.2 m/s, ~540 frames, loops round boxes |
| ``loop150`` | the thesis's first simulated route: a ~140 m closed corridor circuit with poles |
| ``campus1500`` | thesis route 2: ~1.5 km, thick poles, a 70 m corridor with no landmarks |
| ``corridor21`` | Barra & Costa: 21 m U corridor, door frames, pinhole camera, line map |

Every random choice of a world (poster patterns, box sizes, colours) comes from the seed; the
layout (walls, routes) is fixed per preset so results stay comparable across seeds.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from omnislam.camera.hyperbolic import HyperbolicCamera
from omnislam.camera.pinhole import PinholeCamera
from omnislam.camera.rig import CameraRig
from omnislam.core.motion import MotionNoise
from omnislam.datasets.synthetic.laser import LaserConfig
from omnislam.datasets.synthetic.routes import DriveLimits, OdometryBias
from omnislam.datasets.synthetic.textures import TextureKind
from omnislam.datasets.synthetic.world import SurfaceKind, World, WorldBuilder

THESIS = "Guizilini 2008, SLAM com auxilio visual omnidirecional, ch. 5"
BARRA_COSTA = "Barra & Costa, Localizacao de robos moveis usando visao monocular e retas verticais"


class CameraKind(enum.Enum):
    """The camera a preset renders with."""

    OMNI = "omni"  # the thesis's hyperbolic-mirror catadioptric camera (HyperbolicCamera)
    PERSPECTIVE = "perspective"  # a forward-looking pinhole (Barra & Costa)
    NONE = "none"  # laser / pole sightings only


@dataclass(frozen=True, slots=True)
class Preset:
    """A synthetic scenario.

    Attributes:
        name: preset name (``omnislam dataset synth NAME``).
        description: one line for ``dataset list`` and the README.
        source: where the scenario comes from.
        build_world: ``build_world(rng) -> World`` (layout fixed, details random).
        waypoints_w: route through the world [m].
        drive: speed / turn-rate limits and the odometry rate.
        image_every_k: one image every k odometry steps.
        camera: which camera renders.
        camera_height_m: height of the camera's viewpoint above the floor [m].
        laser: the laser (and pole sightings).
        motion_noise: alpha coefficients of the odometry noise (thesis eq. 4.40).
        odometry_bias: systematic odometry errors (wheel scale, turn scale, curvature); the
            same robot in every preset, dead reckoning drifting 1-3 % of the distance.
    """

    name: str
    description: str
    source: str
    build_world: Callable[[np.random.Generator], World]
    waypoints_w: tuple[tuple[float, float], ...]
    drive: DriveLimits
    image_every_k: int
    camera: CameraKind = CameraKind.OMNI
    camera_height_m: float = 0.85
    laser: LaserConfig = field(default_factory=LaserConfig)
    motion_noise: MotionNoise = field(default_factory=MotionNoise)
    odometry_bias: OdometryBias = field(default_factory=OdometryBias)

    def rig(self) -> CameraRig | None:
        """The camera rig of the preset, or None without a camera."""
        rTc = np.eye(4)
        rTc[2, 3] = self.camera_height_m
        if self.camera is CameraKind.OMNI:
            return CameraRig(HyperbolicCamera(), rTc)
        if self.camera is CameraKind.PERSPECTIVE:
            # camera z forward (robot x), camera x right (robot -y), camera y down (robot -z)
            rTc[:3, :3] = [[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]
            camera = PinholeCamera(fx=400.0, fy=400.0, cu=319.5, cv=239.5, width=640, height=480)
            return CameraRig(camera, rTc)
        return None


# --- worlds -------------------------------------------------------------------------------
def _posters_along(
    b: WorldBuilder, p0: tuple[float, float], p1: tuple[float, float], spacing_m: float,
    facing_left: bool = True, start_m: float | None = None,
) -> None:
    """Posters every ``spacing_m`` on the wall p0->p1, facing its left side (seen from p0)."""
    length = math.dist(p0, p1)
    yaw = math.atan2(p1[1] - p0[1], p1[0] - p0[0]) + (math.pi / 2 if facing_left else -math.pi / 2)
    s = spacing_m / 2 if start_m is None else start_m
    while s < length - 0.5:
        a = s / length
        x, y = p0[0] + a * (p1[0] - p0[0]), p0[1] + a * (p1[1] - p0[1])
        b.poster(x, y, yaw, width=float(b.rng.uniform(0.6, 1.0)),
                 height=float(b.rng.uniform(0.6, 1.0)), z_centre=float(b.rng.uniform(1.1, 1.5)))
        s += spacing_m * float(b.rng.uniform(0.8, 1.2))


def _box_island(b: WorldBuilder, x0: float, y0: float, x1: float, y1: float) -> None:
    """A cluster of cardboard boxes filling [x0, x1] x [y0, y1]."""
    nx = max(1, round((x1 - x0) / 0.6))
    ny = max(1, round((y1 - y0) / 0.6))
    dx, dy = (x1 - x0) / nx, (y1 - y0) / ny
    for i in range(nx):
        for j in range(ny):
            if 0 < i < nx - 1 and 0 < j < ny - 1:
                continue  # hidden inside the cluster
            h = float(b.rng.uniform(0.35, 1.0))
            b.box(x0 + (i + 0.5) * dx, y0 + (j + 0.5) * dy, float(b.rng.uniform(-0.08, 0.08)),
                  (dx * 0.92, dy * 0.92, h))


def demo_world(rng: np.random.Generator) -> World:
    """A 6 m x 5 m room: posters, a door, boxes, a pole, a pillar, tiles and lights."""
    b = WorldBuilder("demo", 0, rng)
    b.walls_polygon([(0, 0), (6, 0), (6, 5), (0, 5)])
    b.floor_and_ceiling(0, 0, 6, 5)
    _posters_along(b, (0, 0), (6, 0), 1.3)
    _posters_along(b, (6, 5), (0, 5), 1.3)
    _posters_along(b, (6, 0), (6, 5), 1.6)
    b.door(0, 1.5, 0.0)
    b.poster(0, 3.6, 0.0)
    b.box(3.0, 2.5, 0.2, (0.6, 0.45, 0.5))
    b.box(3.4, 2.3, -0.3, (0.4, 0.4, 0.35))
    b.box(5.5, 4.4, 0.1, (0.5, 0.5, 0.8), kind=SurfaceKind.PILLAR,
          texture_kind=TextureKind.CARDBOARD)
    b.pole(0.8, 4.2)
    b.pole(5.2, 0.7)
    return b.build()


def lab_world(rng: np.random.Generator) -> World:
    """The Magellan test track (thesis Fig. 5.19): a 9 x 7 m lab, two box islands."""
    b = WorldBuilder("lab40", 0, rng)
    b.walls_polygon([(0.5, 0.5), (9.5, 0.5), (9.5, 7.5), (0.5, 7.5)])
    b.floor_and_ceiling(0.5, 0.5, 9.5, 7.5)
    _posters_along(b, (0.5, 0.5), (9.5, 0.5), 1.4)
    _posters_along(b, (9.5, 7.5), (0.5, 7.5), 1.4)
    _posters_along(b, (9.5, 0.5), (9.5, 7.5), 1.5)
    _posters_along(b, (0.5, 7.5), (0.5, 4.5), 1.5)
    b.door(0.5, 2.5, 0.0)
    b.door(9.5, 5.8, math.pi)
    _box_island(b, 2.8, 3.0, 4.2, 5.0)
    _box_island(b, 5.8, 3.0, 7.2, 5.0)
    b.box(1.2, 1.2, 0.0, (0.4, 0.4, 1.6), kind=SurfaceKind.PILLAR)
    b.box(8.8, 6.8, 0.0, (0.4, 0.4, 1.6), kind=SurfaceKind.PILLAR)
    for x, y in ((5.0, 1.0), (5.0, 7.0), (1.0, 4.0), (9.0, 4.0)):
        b.pole(x, y)
    return b.build()


def _ring_world(
    rng: np.random.Generator, name: str, width: float, height: float, corridor: float,
    pole_radius: float, pole_spacing: float, blind_x: tuple[float, float] | None,
) -> World:
    """A closed rectangular corridor ring; optionally a top stretch with nothing to see."""
    b = WorldBuilder(name, 0, rng)
    c = corridor
    outer = [(0.0, 0.0), (width, 0.0), (width, height), (0.0, height)]
    inner = [(c, c), (c, height - c), (width - c, height - c), (width - c, c)]
    b.floor_and_ceiling(0, 0, width, height, lights_every_m=6.0)
    for ring, facing_left in ((outer, True), (inner, True)):
        for p0, p1 in zip(ring, ring[1:] + ring[:1], strict=True):
            top = abs(p0[1] - p1[1]) < 1e-9 and p0[1] > height / 2
            if blind_x is not None and top:
                lo, hi = blind_x
                xs = sorted([p0[0], p1[0]])
                pieces = [(xs[0], lo, False), (lo, hi, True), (hi, xs[1], False)]
                for a, e, plain in pieces:
                    q0, q1 = ((a, p0[1]), (e, p0[1])) if p0[0] < p1[0] else ((e, p0[1]),
                                                                                (a, p0[1]))
                    b.wall(q0, q1, plain=plain)
                    if not plain:
                        _posters_along(b, q0, q1, 3.0, facing_left)
                continue
            b.wall(p0, p1)
            _posters_along(b, p0, p1, 3.0, facing_left)
            length = math.dist(p0, p1)
            for s in np.arange(5.0, length - 2.0, 11.0):
                a = s / length
                yaw = math.atan2(p1[1] - p0[1], p1[0] - p0[0]) + math.pi / 2
                b.door(p0[0] + a * (p1[0] - p0[0]), p0[1] + a * (p1[1] - p0[1]), yaw)
    if blind_x is not None:  # plain floor under the blind stretch
        tex = b.texture(TextureKind.PLAIN, (2.0, 2.0), shared="floor-plain")
        lo, hi = blind_x
        b.quad(SurfaceKind.FLOOR, (lo, height - c, 0.002), (hi - lo, 0, 0), (0, c, 0), tex)
    # poles near the walls, every ~pole_spacing along the centre line
    centre = [(c / 2, c / 2), (width - c / 2, c / 2), (width - c / 2, height - c / 2),
              (c / 2, height - c / 2)]
    for p0, p1 in zip(centre, centre[1:] + centre[:1], strict=True):
        length = math.dist(p0, p1)
        for s in np.arange(pole_spacing / 2, length, pole_spacing):
            a = s / length
            x, y = p0[0] + a * (p1[0] - p0[0]), p0[1] + a * (p1[1] - p0[1])
            if blind_x is not None and y > height / 2 and blind_x[0] - 4 < x < blind_x[1] + 4:
                continue
            side = 1.0 if rng.random() < 0.5 else -1.0
            nx, ny = -(p1[1] - p0[1]) / length, (p1[0] - p0[0]) / length
            off = side * (c / 2 - 0.35 - pole_radius)
            b.pole(x + off * nx, y + off * ny, radius=pole_radius)
    return b.build()


def loop_world(rng: np.random.Generator) -> World:
    """Route 1 of the thesis (Fig. 5.4): a 45 x 30 m corridor ring, 2.5 m wide, with poles."""
    return _ring_world(rng, "loop150", 45.0, 30.0, 2.5, 0.06, 4.0, None)


def campus_world(rng: np.random.Generator) -> World:
    """Route 2 of the thesis (Fig. 5.7): a 150 x 70 m ring, thick poles, a 70 m blind stretch."""
    return _ring_world(rng, "campus1500", 150.0, 70.0, 3.0, 0.15, 5.0, (40.0, 110.0))


def corridor_world(rng: np.random.Generator) -> World:
    """Barra & Costa's U-shaped corridor: 2 m wide, door frames on both sides and at the three
    ends the route faces (the paper's camera saw 8 landmarks per processed frame; facing blank
    end walls ours saw none, and no vision can localise there)."""
    b = WorldBuilder("corridor21", 0, rng)
    b.walls_polygon([(0, 0), (10, 0), (10, 7), (0, 7), (0, 5), (8, 5), (8, 2), (0, 2)])
    b.floor_and_ceiling(0, 0, 10, 7)
    for x in np.arange(1.5, 8.0, 2.2):
        b.door(float(x), 0.0, math.pi / 2)
        b.door(float(x) + 1.1, 2.0, -math.pi / 2)
        b.door(float(x), 7.0, -math.pi / 2)
        b.door(float(x) + 1.1, 5.0, math.pi / 2)
    b.door(10.0, 3.5, math.pi)
    b.door(8.0, 3.5, 0.0)
    b.door(10.0, 1.0, math.pi)  # the end of the first leg
    b.door(9.0, 7.0, -math.pi / 2)  # the end of the second
    b.door(0.0, 6.0, 0.0)  # the end of the third
    for y in (2.3, 5.3):  # posters between the doors of the wall x = 10
        b.poster(10.0, y, math.pi, width=float(b.rng.uniform(0.6, 0.9)),
                 height=float(b.rng.uniform(0.6, 1.0)), z_centre=float(b.rng.uniform(1.1, 1.5)))
    return b.build()


# --- route helpers ------------------------------------------------------------------------
def _ring_route(width: float, height: float, corridor: float, laps: float) -> tuple[
        tuple[float, float], ...]:
    """Counter-clockwise laps along the ring's centre line, starting bottom-left."""
    c = corridor / 2
    corners = [(c, c), (width - c, c), (width - c, height - c), (c, height - c)]
    full = int(laps)
    points = [corners[0]]
    for _ in range(full):
        points += [*corners[1:], corners[0]]
    frac = laps - full
    perimeter = 2 * (width + height - 4 * c)
    rest = frac * perimeter
    for p0, p1 in zip(corners, corners[1:] + corners[:1], strict=True):
        seg = math.dist(p0, p1)
        if rest <= 0:
            break
        a = min(1.0, rest / seg)
        points.append((p0[0] + a * (p1[0] - p0[0]), p0[1] + a * (p1[1] - p0[1])))
        rest -= seg
    return tuple(points)


PRESETS: dict[str, Preset] = {
    p.name: p
    for p in (
        Preset(
            name="demo",
            description="~60 omni frames on a loop in a small furnished room (embedded default)",
            source="omnislam; camera and motion model of " + THESIS,
            build_world=demo_world,
            waypoints_w=((1.6, 1.3), (4.4, 1.3), (4.4, 3.8), (1.6, 3.8), (1.6, 1.3)),
            drive=DriveLimits(max_speed_mps=0.3, max_turn_rate_radps=0.6),
            image_every_k=6,
        ),
        Preset(
            name="lab40",
            description="thesis Magellan run: ~40 m at <= 0.2 m/s, ~540 frames, loops round boxes",
            source=THESIS + " sec. 5.3, Fig. 5.19-5.20",
            build_world=lab_world,
            waypoints_w=((2.0, 2.0), (8.0, 2.0), (8.0, 6.0), (2.0, 6.0), (2.0, 2.0), (5.0, 2.0),
                         (5.0, 6.0), (2.0, 6.0), (2.0, 2.0), (5.0, 2.0), (5.0, 4.5)),
            drive=DriveLimits(max_speed_mps=0.2, max_turn_rate_radps=0.12, max_accel_mps2=0.1),
            image_every_k=5,
        ),
        Preset(
            name="loop150",
            description="thesis route 1: ~140 m closed corridor circuit with poles (laser)",
            source=THESIS + " sec. 5.1.2, Fig. 5.4-5.6",
            build_world=loop_world,
            waypoints_w=_ring_route(45.0, 30.0, 2.5, 1.0),
            drive=DriveLimits(max_speed_mps=0.5, max_turn_rate_radps=0.6, lookahead_m=0.8),
            image_every_k=10,
        ),
        Preset(
            name="campus1500",
            description="thesis route 2: ~1.5 km, thick poles, a 70 m corridor with no landmarks",
            source=THESIS + " sec. 5.1.2, Fig. 5.7-5.8",
            build_world=campus_world,
            waypoints_w=_ring_route(150.0, 70.0, 3.0, 3.5),
            drive=DriveLimits(max_speed_mps=0.6, max_turn_rate_radps=0.6, lookahead_m=1.0),
            image_every_k=10,
        ),
        Preset(
            name="corridor21",
            description="Barra & Costa: 21 m U corridor, door frames, pinhole camera, line map",
            source=BARRA_COSTA + ", sec. 5",
            build_world=corridor_world,
            waypoints_w=((1.0, 1.0), (9.0, 1.0), (9.0, 6.0), (1.0, 6.0)),
            drive=DriveLimits(max_speed_mps=0.3, max_turn_rate_radps=0.5),
            image_every_k=12,
            camera=CameraKind.PERSPECTIVE,
            camera_height_m=1.0,
            laser=LaserConfig(fov_deg=180.0, beams=361, max_range_m=8.0),
        ),
    )
}
