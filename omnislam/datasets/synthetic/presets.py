"""Named synthetic scenarios: a world, a route, the sensors (README lists them from here).

| preset | description |
|---|---|
| ``demo`` | ~60 omni frames driving a loop in a small furnished room (the embedded default) |
| ``lab40`` | thesis Magellan Pro run: ~40 m, <= 0.2 m/s, ~540 frames, loops round boxes |
| ``loop150`` | the thesis's first simulated route: a ~140 m closed corridor circuit with poles |
| ``campus1500`` | thesis route 2: ~1.5 km, thick poles, a 70 m corridor with no landmarks |
| ``thesis-route1`` | thesis route 1 as simulated there: ~150 m circuit, poles without ids |
| ``thesis-route2`` | thesis route 2 as simulated there: ~1.5 km grid, thick poles, blind corridor |
| ``corridor21`` | Barra & Costa: 21 m U corridor, door frames, pinhole camera, line map |

Every random choice of a world (poster patterns, box sizes, colours) comes from the seed; the
layout (walls, routes) is fixed per preset so results stay comparable across seeds.

``loop150`` and ``campus1500`` are omnislam's own harder versions of the thesis's routes
(systematically biased odometry, omnidirectional images). ``thesis-route1`` and
``thesis-route2`` are the two simulated experiments under the thesis's own conditions (sec. 5.1),
laser and poles only, so they render in seconds:

* **Sensors** (sec. 5.1.1): data at 10 Hz; "um sensor laser que varre uma area de 180 graus a
  sua frente, com um alcance de 3 metros", used only for the metric map ("nao influencia de
  forma alguma no SLAM"): its scans are ``laser.npz`` with ``LaserRole.OCCUPANCY`` (the
  reports' occupancy grid; the front end leaves them alone); and "um segundo sensor laser que
  varre uma area de 360 graus ao redor do robo com um alcance de 4 metros, posicionado a uma
  altura de 0.5 metros acima do primeiro", on which poles are "detectados ... como minimos
  locais" (``laser.scanned_poles``: the nearest surface point of each pole the scan hits, plus
  a 6 cm radius guess; 1 cm range noise per beam, bearings quantised to its 1 deg beams).
  The poles' positions are "nao conhecidas pelo robo": the folder's ``meta.json`` makes the
  loader hide the sightings' ids (``--set association=known`` shows them).
* **Route 1** (Fig. 5.4): "um percurso fechado ... composto por diversos corredores", the robot
  starting "no ponto indicado", moving "inicialmente para a direita" and back to its start after
  "aproximadamente 150 metros": six corridors 2.5 m wide round an L-shaped block (151 m driven),
  starting 8 m into the bottom corridor; the last stretch comes down the left corridor and
  along the bottom one into the poles seen at the start, where the thesis's robot,
  "desalinhado" in the lower-left corridor, realigned "tao logo reconheceu um marco". 31 thin
  poles (6 cm radius) about every 4 m (seed 0).
* **Route 2** (Fig. 5.7): "aproximadamente dez vezes maior (1.5 km) e com significativamente
  mais marcos", poles of larger diameter, "gerando uma maior imprecisao quanto a sua posicao ao
  ser detectada em diferentes angulos" (15 cm radius: the 6 cm radius guess leaves each
  sighting 9 cm short of the centre, along whichever side is seen), and "um corredor (extremo
  superior, com entrada pelo lado esquerdo) onde nao ha nenhum marco": a building of corridors
  3 m wide (four columns, four rows), 1479 m driven through every corridor, most twice; ~280
  poles about every 3 m; the top-left corridor (72 m) has none and is entered from the left
  column after 1.05 km, and leads into corridors mapped before.
* **Odometry** (eqs. 4.38-4.44): the thesis's zero-mean alpha model only (no ``OdometryBias``).
  The thesis gives no coefficients (its errors were "modelados, tendo como base um robo real",
  without values); ``THESIS_MOTION_NOISE`` is chosen so that, as in Fig. 5.5a, dead reckoning
  cannot return to the start of route 1. Measured over seeds 0-9 (the final position's distance
  from the true one): route 1 2.1-10.3 m, median 4.7 m (3.1 % of 151 m); route 2 5.1-66 m,
  median 34 m (2.3 % of 1479 m).
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
from omnislam.datasets._common import Association
from omnislam.datasets.sequence import LaserRole
from omnislam.datasets.synthetic.corridors import CorridorNetwork, PoleRow, polygon_segments
from omnislam.datasets.synthetic.laser import LaserConfig, PoleScanner
from omnislam.datasets.synthetic.routes import NO_BIAS, DriveLimits, OdometryBias
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
        laser: the laser whose scans the folder holds (and that sights the poles when there
            is no ``pole_scanner``).
        motion_noise: alpha coefficients of the odometry noise (thesis eq. 4.40).
        odometry_bias: systematic odometry errors (wheel scale, turn scale, curvature); the
            same robot in every preset, dead reckoning drifting 1-3 % of the distance.
        pole_scanner: the laser whose scan's local minima are the pole sightings (thesis sec.
            5.1.1); None: ``laser`` reports each visible pole's centre with Gaussian noise.
        association: whether the loader hands the sightings' ids to the estimators by default
            (``omnislam run ... --set association=...`` overrides it).
        laser_role: what ``laser``'s scans are for: SENSOR (the front end may use them) or
            OCCUPANCY (the occupancy grid of reports only).
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
    pole_scanner: PoleScanner | None = None
    association: Association = Association.KNOWN
    laser_role: LaserRole = LaserRole.SENSOR

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


# --- the thesis's simulated routes (sec. 5.1.2) ------------------------------------------
#: Route 1 (Fig. 5.4): the centre lines of a closed circuit of six corridors, 2.5 m wide [m]
ROUTE1_CIRCUIT = ((0.0, 0.0), (44.0, 0.0), (44.0, 20.0), (26.0, 20.0), (26.0, 32.0), (0.0, 32.0))
#: where route 1 starts and ends: 8 m into the bottom corridor, heading right [m]
ROUTE1_START = (8.0, 0.0)
#: Route 2 (Fig. 5.7): a grid of corridors 3 m wide; columns and rows of its centre lines [m]
ROUTE2_COLUMNS = (0.0, 72.0, 117.0, 162.0)
ROUTE2_ROWS = (0.0, 35.0, 70.0, 105.0)


def route1_network() -> CorridorNetwork:
    """Route 1's circuit: six corridors round an L-shaped block (about 152 m of centre line)."""
    return CorridorNetwork(polygon_segments(ROUTE1_CIRCUIT), width_m=2.5)


def route2_network() -> CorridorNetwork:
    """Route 2's building: three full-width rows, a top row whose left part (72 m, entered from
    the left column) has no pole, and four columns (the third stops at the third row)."""
    (x0, x1, x2, x3), (y0, y1, y2, y3) = ROUTE2_COLUMNS, ROUTE2_ROWS
    segments = (
        ((x0, y3), (x1, y3)),  # the blind corridor: upper end, entered from the left
        ((x1, y3), (x3, y3)),
        *(((x0, y), (x3, y)) for y in (y0, y1, y2)),
        ((x0, y0), (x0, y3)),
        ((x1, y0), (x1, y3)),
        ((x2, y0), (x2, y2)),
        ((x3, y0), (x3, y3)),
    )
    return CorridorNetwork(segments, width_m=3.0, blind=frozenset({0}))


#: Route 1's poles: thin (6 cm radius), one every ~4 m
ROUTE1_POLES = PoleRow(spacing_m=4.0, radius_m=0.06)
#: Route 2's poles: "significantly more" and thicker (15 cm radius), one every ~3 m
ROUTE2_POLES = PoleRow(spacing_m=3.0, radius_m=0.15)


def thesis_route1_world(rng: np.random.Generator) -> World:
    """Route 1 of the thesis (Fig. 5.4): a ~150 m circuit of corridors with thin poles."""
    return route1_network().build("thesis-route1", rng, ROUTE1_POLES)


def thesis_route2_world(rng: np.random.Generator) -> World:
    """Route 2 of the thesis (Fig. 5.7): a corridor grid with thick poles and a blind corridor."""
    return route2_network().build("thesis-route2", rng, ROUTE2_POLES)


def route1_waypoints() -> tuple[tuple[float, float], ...]:
    """From the start, right along the bottom corridor, round the circuit counter-clockwise and
    back along the lower-left corridors (mapped at the start) to the start."""
    return (ROUTE1_START, *ROUTE1_CIRCUIT[1:], ROUTE1_CIRCUIT[0], ROUTE1_START)


def route2_waypoints() -> tuple[tuple[float, float], ...]:
    """~1.5 km through route 2's building: the three rows, the top-right corridor, down the
    second column, up the third, back along the third row, up the left column, **through the
    blind corridor** (from the left), and home along corridors mapped before it."""
    (x0, x1, x2, x3), (y0, y1, y2, y3) = ROUTE2_COLUMNS, ROUTE2_ROWS
    return (
        (x0, y0), (x3, y0), (x3, y1), (x0, y1), (x0, y2), (x3, y2), (x3, y3), (x1, y3),
        (x1, y0), (x2, y0), (x2, y2), (x0, y2), (x0, y3), (x1, y3), (x3, y3), (x3, y0), (x0, y0),
    )


#: The thesis's lower laser (sec. 5.1.1): 180 deg in front, 3 m, for the occupancy grid only
THESIS_LOWER_LASER = LaserConfig(fov_deg=180.0, beams=181, max_range_m=3.0, height_m=0.3)
#: The thesis's upper laser, 0.5 m above the lower one: 360 deg, 4 m, 1 deg beams; poles are
#: its scan's local minima. Bearing stated as one beam spacing.
THESIS_UPPER_LASER = LaserConfig(fov_deg=360.0, beams=360, max_range_m=4.0, height_m=0.8,
                                 sigma_bearing_rad=math.radians(1.0))
#: The thesis's pole detector: the upper laser's local minima, each moved 6 cm further along
#: its beam (the nearest surface point plus the radius of route 1's poles). Route 1's poles are
#: then seen at their centres from every side; route 2's, 15 cm thick, 9 cm short of them, and
#: where depends on the side seen from (thesis sec. 5.1.2: "uma maior imprecisao quanto a sua
#: posicao ao ser detectada em diferentes angulos").
THESIS_POLE_SCANNER = PoleScanner(THESIS_UPPER_LASER, radius_guess_m=0.06)
#: The odometry noise of the thesis's simulated robot (zero-mean alpha model, eqs. 4.40-4.41,
#: at 10 Hz): chosen so that dead reckoning misses route 1's start by metres on every seed, as
#: in Fig. 5.5a (the thesis gives no coefficients; the module docstring has the measurements).
THESIS_MOTION_NOISE = MotionNoise(a_vv=0.05, a_vw=0.04, a_wv=0.02, a_ww=0.15)
#: the thesis robot's drive: the thesis gives no speed for its simulation; ``loop150``'s
THESIS_DRIVE = DriveLimits(max_speed_mps=0.5, max_turn_rate_radps=0.6, lookahead_m=0.8)


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
            name="thesis-route1",
            description="thesis route 1 as simulated there: ~150 m corridor circuit, thin "
            "poles seen by a 360 deg laser without ids, zero-mean odometry noise",
            source=THESIS + " sec. 5.1, Fig. 5.4-5.6",
            build_world=thesis_route1_world,
            waypoints_w=route1_waypoints(),
            drive=THESIS_DRIVE,
            image_every_k=10,
            camera=CameraKind.NONE,
            laser=THESIS_LOWER_LASER,
            motion_noise=THESIS_MOTION_NOISE,
            odometry_bias=NO_BIAS,
            pole_scanner=THESIS_POLE_SCANNER,
            association=Association.UNKNOWN,
            laser_role=LaserRole.OCCUPANCY,
        ),
        Preset(
            name="thesis-route2",
            description="thesis route 2 as simulated there: ~1.5 km corridor grid, more and "
            "thicker poles, a 72 m corridor without poles, no ids, zero-mean odometry noise",
            source=THESIS + " sec. 5.1, Fig. 5.7-5.8",
            build_world=thesis_route2_world,
            waypoints_w=route2_waypoints(),
            drive=THESIS_DRIVE,
            image_every_k=10,
            camera=CameraKind.NONE,
            laser=THESIS_LOWER_LASER,
            motion_noise=THESIS_MOTION_NOISE,
            odometry_bias=NO_BIAS,
            pole_scanner=THESIS_POLE_SCANNER,
            association=Association.UNKNOWN,
            laser_role=LaserRole.OCCUPANCY,
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
