"""The synthetic world: textured planar quads, poles and vertical-line landmarks, saved as JSON.

A world is a flat list of parallelogram quads (walls, floors, ceilings, posters, box faces,
doors, door frames, pillars, poles, light panels). Each quad is one *surface*: its id is its
index in ``World.quads`` and is what the renderer writes into the surface-id map. Texture
coordinates of a quad are metres along its two edges, ``u`` along ``edge_u_w`` and ``v`` along
``edge_v_w`` (the texture's rows follow ``v``). Quads are two-sided.

Landmarks with known ground truth are kept next to the geometry: poles (the thesis's
simulation stand-in, ch. 5.1.1: laser-detected poles, given as 2-D centres) and vertical lines
(Barra & Costa: door-frame edges as 2-D points, with the main walls for occlusion).

World frame: x, y on the floor (z = 0), z up, metres.
"""

from __future__ import annotations

import enum
import itertools
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from omnislam.datasets.synthetic.textures import TextureKind, TextureSpec
from omnislam.errors import DataError

#: version of world.json; bump when the layout changes
WORLD_FORMAT_VERSION = 1
#: a door frame stands this far in front of its wall [m]
FRAME_OFFSET_M = 0.02
#: plausible |coordinate| of a point of a world or of its ground truth [m] (quad corners and
#: edges, poles, vertical lines, 2-D walls, landmarks.csv, groundtruth.tum): the presets' worlds
#: lie within 150 m of their origin (campus1500: 150 m, its landmarks 149.98 m, its route
#: 148.7 m; demo: 6 m), so 1e4 m leaves a margin of 66x; a corrupt 1e308 is not a position
MAX_COORDINATE_M = 1.0e4


class SurfaceKind(enum.Enum):
    """What a quad is; decides what a keypoint on it may be used for."""

    WALL = "wall"
    FLOOR = "floor"
    CEILING = "ceiling"
    LIGHT = "light"
    POSTER = "poster"
    BOX = "box"
    DOOR = "door"
    DOOR_FRAME = "door_frame"
    PILLAR = "pillar"
    POLE = "pole"

    @property
    def is_landmark(self) -> bool:
        """True for textured objects a front end should recognise (not walls, floor, ceiling)."""
        return self in _LANDMARK_KINDS


_LANDMARK_KINDS = frozenset(
    {SurfaceKind.POSTER, SurfaceKind.BOX, SurfaceKind.DOOR, SurfaceKind.DOOR_FRAME,
     SurfaceKind.PILLAR, SurfaceKind.POLE}
)


def _vec3(value: object) -> tuple[float, float, float]:
    x, y, z = (float(c) for c in value)  # type: ignore[union-attr]
    return (x, y, z)


@dataclass(frozen=True, slots=True)
class Quad:
    """A textured parallelogram ``origin + a * edge_u + b * edge_v``, a, b in [0, 1].

    Attributes:
        kind: what the surface is.
        origin_w: (3,) one corner in the world [m].
        edge_u_w: (3,) edge along the texture's u (columns) [m].
        edge_v_w: (3,) edge along the texture's v (rows) [m].
        texture: index into ``World.textures``.
        object_id: id of the object the quad belongs to (a box's six faces share one), -1 none.
    """

    kind: SurfaceKind
    origin_w: tuple[float, float, float]
    edge_u_w: tuple[float, float, float]
    edge_v_w: tuple[float, float, float]
    texture: int
    object_id: int = -1

    def __post_init__(self) -> None:
        object.__setattr__(self, "origin_w", _vec3(self.origin_w))
        object.__setattr__(self, "edge_u_w", _vec3(self.edge_u_w))
        object.__setattr__(self, "edge_v_w", _vec3(self.edge_v_w))
        if np.linalg.norm(np.cross(self.edge_u_w, self.edge_v_w)) < 1e-9:
            raise DataError(f"degenerate quad {self}")


@dataclass(frozen=True, slots=True)
class Pole:
    """A vertical pole (thesis ch. 5.1.1): a landmark seen by the laser and by the camera.

    Attributes:
        landmark_id: ground-truth id (shared with ``landmarks.csv`` and the sightings).
        x_m, y_m: centre on the floor [m].
        radius_m: radius [m].
        height_m: height [m].
    """

    landmark_id: int
    x_m: float
    y_m: float
    radius_m: float
    height_m: float


@dataclass(frozen=True, slots=True)
class VerticalLine:
    """A vertical-line landmark (Barra & Costa sec. 2.1): a door-frame edge as a 2-D point."""

    landmark_id: int
    x_m: float
    y_m: float


@dataclass(frozen=True, slots=True)
class Wall2D:
    """A main wall of the 2-D map (Barra & Costa use them to decide occlusion) [m]."""

    x0_m: float
    y0_m: float
    x1_m: float
    y1_m: float


@dataclass(frozen=True, slots=True)
class QuadArrays:
    """The quads of a world as arrays, for the ray casters and the texture sampler.

    Attributes:
        origins_w, edges_u_w, edges_v_w: (M, 3) [m].
        normals_w: (M, 3) unit normals (edge_u x edge_v).
        dual_u_w, dual_v_w: (M, 3) dual basis: ``a = (p - origin) . dual_u`` is the fraction of
            edge_u at point p of the quad's plane (exact for any parallelogram).
        length_u_m, length_v_m: (M,) edge lengths [m].
        textures: (M,) texture index; kinds: (M,) SurfaceKind values (str).
    """

    origins_w: np.ndarray
    edges_u_w: np.ndarray
    edges_v_w: np.ndarray
    normals_w: np.ndarray
    dual_u_w: np.ndarray
    dual_v_w: np.ndarray
    length_u_m: np.ndarray
    length_v_m: np.ndarray
    textures: np.ndarray

    def __len__(self) -> int:
        return int(self.origins_w.shape[0])

    def triangles(self) -> tuple[np.ndarray, np.ndarray]:
        """(4M, 3) vertices and (2M, 3) triangle indices; triangle k belongs to quad k // 2."""
        o, eu, ev = self.origins_w, self.edges_u_w, self.edges_v_w
        vertices = np.stack([o, o + eu, o + eu + ev, o + ev], axis=1).reshape(-1, 3)
        base = 4 * np.arange(len(self))[:, None]
        corners = np.array([[0, 1, 2], [0, 2, 3]])
        tris = (base[:, None, :] + corners[None]).reshape(-1, 3)
        return vertices, tris


@dataclass(frozen=True, slots=True)
class World:
    """Everything the renderer, the laser and the ground-truth files need.

    Attributes:
        name: preset name.
        seed: the seed it was built from.
        quads: the surfaces; surface id = index.
        textures: texture specifications (regenerated deterministically from their seeds).
        poles: pole landmarks.
        vertical_lines: vertical-line landmarks.
        walls_2d: main walls of the 2-D map.
    """

    name: str
    seed: int
    quads: tuple[Quad, ...]
    textures: tuple[TextureSpec, ...]
    poles: tuple[Pole, ...] = ()
    vertical_lines: tuple[VerticalLine, ...] = ()
    walls_2d: tuple[Wall2D, ...] = ()

    def __post_init__(self) -> None:
        for i, quad in enumerate(self.quads):
            if not 0 <= quad.texture < len(self.textures):
                raise DataError(f"world {self.name}: quad {i} has no texture {quad.texture}")

    def arrays(self) -> QuadArrays:
        """The quads as arrays (computed on each call; keep the result)."""
        o = np.array([q.origin_w for q in self.quads], dtype=float).reshape(-1, 3)
        eu = np.array([q.edge_u_w for q in self.quads], dtype=float).reshape(-1, 3)
        ev = np.array([q.edge_v_w for q in self.quads], dtype=float).reshape(-1, 3)
        n = np.cross(eu, ev)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        cu = np.cross(ev, n)
        cv = np.cross(n, eu)
        dual_u = cu / np.sum(eu * cu, axis=1, keepdims=True)
        dual_v = cv / np.sum(ev * cv, axis=1, keepdims=True)
        return QuadArrays(
            origins_w=o,
            edges_u_w=eu,
            edges_v_w=ev,
            normals_w=n,
            dual_u_w=dual_u,
            dual_v_w=dual_v,
            length_u_m=np.linalg.norm(eu, axis=1),
            length_v_m=np.linalg.norm(ev, axis=1),
            textures=np.array([q.texture for q in self.quads], dtype=np.int64),
        )

    def surface_kinds(self) -> np.ndarray:
        """(M,) SurfaceKind per surface id (object array)."""
        return np.array([q.kind for q in self.quads], dtype=object)

    def landmark_surface_mask(self) -> np.ndarray:
        """(M,) bool: surface id belongs to a textured landmark (SurfaceKind.is_landmark)."""
        return np.array([q.kind.is_landmark for q in self.quads], dtype=bool)

    def landmarks(self) -> tuple[np.ndarray, np.ndarray]:
        """Ground-truth landmark ids (K,) and positions (K, 3) [m] of poles and vertical lines.

        Both are 2-D landmarks: z = 0.
        """
        rows = [(p.landmark_id, p.x_m, p.y_m) for p in self.poles]
        rows += [(v.landmark_id, v.x_m, v.y_m) for v in self.vertical_lines]
        ids = np.array([r[0] for r in rows], dtype=np.int64)
        xyz = np.zeros((len(rows), 3))
        if rows:
            xyz[:, :2] = [(r[1], r[2]) for r in rows]
        return ids, xyz

    # --- JSON ---------------------------------------------------------------------------
    def to_json(self) -> str:
        """Deterministic JSON text (sorted keys, shortest float repr)."""
        doc = {
            "format_version": WORLD_FORMAT_VERSION,
            "name": self.name,
            "seed": self.seed,
            "textures": [t.to_dict() for t in self.textures],
            "quads": [
                {
                    "kind": q.kind.value,
                    "origin_w": list(q.origin_w),
                    "edge_u_w": list(q.edge_u_w),
                    "edge_v_w": list(q.edge_v_w),
                    "texture": q.texture,
                    "object_id": q.object_id,
                }
                for q in self.quads
            ],
            "poles": [
                [p.landmark_id, p.x_m, p.y_m, p.radius_m, p.height_m] for p in self.poles
            ],
            "vertical_lines": [[v.landmark_id, v.x_m, v.y_m] for v in self.vertical_lines],
            "walls_2d": [[w.x0_m, w.y0_m, w.x1_m, w.y1_m] for w in self.walls_2d],
        }
        return json.dumps(doc, sort_keys=True, separators=(",", ":"))

    @classmethod
    def from_json(cls, text: str, path: Path | None = None) -> World:
        """Parse ``to_json`` output; raises DataError naming ``path`` on malformed input.

        Besides the layout, the geometry is checked (naming the entry): every number finite
        and every coordinate within ``MAX_COORDINATE_M``, no degenerate quad, poles of positive
        radius and height, 2-D walls of positive length.
        """
        try:
            doc = json.loads(text)
            if not isinstance(doc, dict):
                raise DataError("malformed world description: not a JSON object", path)
            if doc.get("format_version") != WORLD_FORMAT_VERSION:
                raise DataError(f"unsupported world format {doc.get('format_version')}", path)
            quads = []
            for i, q in enumerate(doc["quads"]):
                for key in ("origin_w", "edge_u_w", "edge_v_w"):
                    _check_coordinates(f"quads[{i}].{key}", q[key], path)
                try:
                    quads.append(
                        Quad(
                            kind=SurfaceKind(q["kind"]),
                            origin_w=q["origin_w"],
                            edge_u_w=q["edge_u_w"],
                            edge_v_w=q["edge_v_w"],
                            texture=int(q["texture"]),
                            object_id=int(q["object_id"]),
                        )
                    )
                except DataError:
                    raise DataError(f"quads[{i}]: degenerate quad (its edges are parallel)",
                                    path) from None
            poles = []
            for i, p in enumerate(doc["poles"]):
                pole = Pole(int(p[0]), *map(float, p[1:]))
                _check_coordinates(f"poles[{i}]", (pole.x_m, pole.y_m), path)
                if not (0 < pole.radius_m <= MAX_COORDINATE_M and 0 < pole.height_m
                        <= MAX_COORDINATE_M):
                    raise DataError(
                        f"poles[{i}]: radius {pole.radius_m!r} m and height {pole.height_m!r} m "
                        f"must be positive (and at most {MAX_COORDINATE_M:g} m)", path)
                poles.append(pole)
            lines = []
            for i, v in enumerate(doc["vertical_lines"]):
                line = VerticalLine(int(v[0]), float(v[1]), float(v[2]))
                _check_coordinates(f"vertical_lines[{i}]", (line.x_m, line.y_m), path)
                lines.append(line)
            walls = []
            for i, w in enumerate(doc["walls_2d"]):
                wall = Wall2D(*map(float, w))
                _check_coordinates(f"walls_2d[{i}]", w, path)
                if wall.x0_m == wall.x1_m and wall.y0_m == wall.y1_m:
                    raise DataError(f"walls_2d[{i}]: a wall of zero length", path)
                walls.append(wall)
            return cls(
                name=str(doc["name"]),
                seed=int(doc["seed"]),
                textures=tuple(TextureSpec.from_dict(t) for t in doc["textures"]),
                quads=tuple(quads),
                poles=tuple(poles),
                vertical_lines=tuple(lines),
                walls_2d=tuple(walls),
            )
        except DataError as exc:
            if exc.path is None:  # a check of the records (a quad's texture): name the file
                raise DataError(str(exc), path) from None
            raise
        except (KeyError, TypeError, ValueError, IndexError, OverflowError) as exc:
            raise DataError(f"malformed world description: {exc!r}", path) from exc


def _check_coordinates(key: str, values: object, path: Path | None) -> None:
    """Raise DataError naming ``key`` when a coordinate of a world.json entry is NaN, infinite
    or beyond ``MAX_COORDINATE_M``."""
    coordinates = np.asarray([float(c) for c in values], dtype=float)  # type: ignore[union-attr]
    if not np.all(np.abs(coordinates) <= MAX_COORDINATE_M):  # False for NaN
        raise DataError(
            f"{key}: coordinates {coordinates.tolist()} must be finite and within "
            f"{MAX_COORDINATE_M:g} m",
            path,
        )


# --- building -----------------------------------------------------------------------------
@dataclass
class WorldBuilder:
    """Mutable helper that places rooms, corridors and objects; ``build()`` freezes the world.

    All randomness (texture seeds, colours, sizes) comes from the injected ``rng``.

    Attributes:
        name: world name.
        seed: seed recorded in the world.
        rng: the generator every random choice is drawn from.
        ceiling_m: ceiling height [m].
    """

    name: str
    seed: int
    rng: np.random.Generator
    ceiling_m: float = 2.6
    quads: list[Quad] = field(default_factory=list)
    textures: list[TextureSpec] = field(default_factory=list)
    poles: list[Pole] = field(default_factory=list)
    vertical_lines: list[VerticalLine] = field(default_factory=list)
    walls_2d: list[Wall2D] = field(default_factory=list)
    _next_object: int = 0
    _next_landmark: int = 0
    _shared: dict[str, int] = field(default_factory=dict)

    def build(self) -> World:
        return World(
            name=self.name,
            seed=self.seed,
            quads=tuple(self.quads),
            textures=tuple(self.textures),
            poles=tuple(self.poles),
            vertical_lines=tuple(self.vertical_lines),
            walls_2d=tuple(self.walls_2d),
        )

    # textures ------------------------------------------------------------------------
    def texture(
        self,
        kind: TextureKind,
        extent_m: tuple[float, float],
        *,
        shared: str | None = None,
        size_px: tuple[int, int] | None = None,
    ) -> int:
        """Add a texture (or reuse the one registered under ``shared``); returns its index."""
        if shared is not None and shared in self._shared:
            return self._shared[shared]
        spec = TextureSpec.make(kind, int(self.rng.integers(0, 2**31 - 1)), extent_m, size_px)
        self.textures.append(spec)
        index = len(self.textures) - 1
        if shared is not None:
            self._shared[shared] = index
        return index

    def new_object(self) -> int:
        self._next_object += 1
        return self._next_object - 1

    def new_landmark_id(self) -> int:
        self._next_landmark += 1
        return self._next_landmark - 1

    def quad(
        self,
        kind: SurfaceKind,
        origin_w: np.ndarray | tuple[float, ...],
        edge_u_w: np.ndarray | tuple[float, ...],
        edge_v_w: np.ndarray | tuple[float, ...],
        texture: int,
        object_id: int = -1,
    ) -> int:
        self.quads.append(Quad(kind, origin_w, edge_u_w, edge_v_w, texture, object_id))
        return len(self.quads) - 1

    # structure -----------------------------------------------------------------------
    def wall(
        self,
        p0: tuple[float, float],
        p1: tuple[float, float],
        *,
        plain: bool = False,
        main: bool = True,
        z0: float = 0.0,
        z1: float | None = None,
    ) -> None:
        """A vertical wall from p0 to p1 (floor to ceiling unless z0/z1 given)."""
        z1 = self.ceiling_m if z1 is None else z1
        length = math.dist(p0, p1)
        kind = TextureKind.PLAIN if plain else TextureKind.PAINT
        tex = self.texture(kind, (2.0, 2.0), shared=f"wall-{kind.value}")
        self.quad(
            SurfaceKind.WALL,
            (p1[0], p1[1], z1),
            (p0[0] - p1[0], p0[1] - p1[1], 0.0),
            (0.0, 0.0, z0 - z1),
            tex,
        )
        if main and length > 0:
            self.walls_2d.append(Wall2D(*(float(c) for c in (*p0, *p1))))

    def walls_polygon(self, corners: list[tuple[float, float]], *, plain: bool = False) -> None:
        """Closed chain of walls through ``corners``."""
        for a, b in zip(corners, corners[1:] + corners[:1], strict=True):
            self.wall(a, b, plain=plain)

    def floor_and_ceiling(
        self, x0: float, y0: float, x1: float, y1: float, *, plain: bool = False,
        lights_every_m: float | None = 3.0,
    ) -> None:
        """Tiled floor, panelled ceiling and light panels over the rectangle [x0,x1]x[y0,y1]."""
        if plain:
            tex_f = self.texture(TextureKind.PLAIN, (2.0, 2.0), shared="floor-plain")
            tex_c = self.texture(TextureKind.PLAIN, (2.0, 2.0), shared="ceiling-plain")
        else:
            tex_f = self.texture(TextureKind.TILES, (1.2, 1.2), shared="floor-tiles")
            tex_c = self.texture(TextureKind.CEILING, (1.2, 1.2), shared="ceiling")
        self.quad(SurfaceKind.FLOOR, (x0, y0, 0.0), (x1 - x0, 0, 0), (0, y1 - y0, 0), tex_f)
        h = self.ceiling_m
        self.quad(SurfaceKind.CEILING, (x0, y1, h), (x1 - x0, 0, 0), (0, y0 - y1, 0), tex_c)
        if lights_every_m and not plain:
            tex_l = self.texture(TextureKind.LIGHT, (1.2, 0.6), shared="light")
            nx = max(1, int((x1 - x0) // lights_every_m))
            ny = max(1, int((y1 - y0) // lights_every_m))
            for i in range(nx):
                for j in range(ny):
                    cx = x0 + (i + 0.5) * (x1 - x0) / nx
                    cy = y0 + (j + 0.5) * (y1 - y0) / ny
                    w, d = (1.2, 0.6) if (x1 - x0) >= (y1 - y0) else (0.6, 1.2)
                    self.quad(
                        SurfaceKind.LIGHT,
                        (cx - w / 2, cy + d / 2, h - 0.005),
                        (w, 0, 0),
                        (0, -d, 0),
                        tex_l,
                    )

    # objects -------------------------------------------------------------------------
    def _facing(self, x: float, y: float, yaw: float, width: float) -> tuple[np.ndarray, ...]:
        """Centre and horizontal edge of a panel at (x, y) whose normal points along ``yaw``."""
        normal = np.array([math.cos(yaw), math.sin(yaw), 0.0])
        right = np.array([math.sin(yaw), -math.cos(yaw), 0.0])  # u runs left->right seen from front
        return np.array([x, y, 0.0]), normal, right * width

    def poster(
        self, x: float, y: float, yaw: float, *, width: float = 0.8, height: float = 1.0,
        z_centre: float = 1.4,
    ) -> None:
        """A random high-contrast poster on a wall at (x, y), facing direction ``yaw``."""
        centre, normal, edge_u = self._facing(x, y, yaw, width)
        centre = centre + 0.01 * normal + np.array([0.0, 0.0, z_centre])
        tex = self.texture(TextureKind.POSTER, (width, height))
        origin = centre - edge_u / 2 + np.array([0.0, 0.0, height / 2])
        self.quad(SurfaceKind.POSTER, origin, edge_u, (0, 0, -height), tex, self.new_object())

    def box(
        self, x: float, y: float, yaw: float, size: tuple[float, float, float],
        *, kind: SurfaceKind = SurfaceKind.BOX, texture_kind: TextureKind = TextureKind.CARDBOARD,
    ) -> None:
        """An axis-vertical box (cardboard box, pillar) centred at (x, y) on the floor."""
        sx, sy, sz = size
        ax = np.array([math.cos(yaw), math.sin(yaw), 0.0])
        ay = np.array([-math.sin(yaw), math.cos(yaw), 0.0])
        c = np.array([x, y, 0.0])
        obj = self.new_object()
        faces = [(ax, ay, sx, sy), (ay, -ax, sy, sx), (-ax, -ay, sx, sy), (-ay, ax, sy, sx)]
        for normal, along, half_n, width in faces:
            tex = self.texture(texture_kind, (width, sz))
            origin = c + normal * half_n / 2 - along * width / 2 + np.array([0.0, 0.0, sz])
            self.quad(kind, origin, along * width, (0, 0, -sz), tex, obj)
        tex = self.texture(texture_kind, (sx, sy))
        top = c - ax * sx / 2 + ay * sy / 2 + np.array([0.0, 0.0, sz])
        self.quad(kind, top, ax * sx, -ay * sy, tex, obj)

    def pole(self, x: float, y: float, radius: float = 0.06, sides: int = 8) -> int:
        """A floor-to-ceiling striped pole (prism) with a ground-truth landmark id."""
        tex = self.texture(TextureKind.STRIPES, (2 * math.pi * radius / sides, self.ceiling_m),
                           shared=f"pole-{radius:.3f}")
        obj = self.new_object()
        angles = np.arange(sides + 1) * 2 * math.pi / sides
        r_out = radius / math.cos(math.pi / sides)  # the prism circumscribes the circle
        pts = np.stack([x + r_out * np.cos(angles), y + r_out * np.sin(angles)], axis=1)
        for a, b in itertools.pairwise(pts):
            h = self.ceiling_m
            self.quad(SurfaceKind.POLE, (b[0], b[1], h), (a[0] - b[0], a[1] - b[1], 0),
                      (0, 0, -h), tex, obj)
        landmark = self.new_landmark_id()
        self.poles.append(Pole(landmark, x, y, radius, self.ceiling_m))
        return landmark

    def door(self, x: float, y: float, yaw: float, *, width: float = 0.9,
             height: float = 2.05) -> None:
        """A wooden door with a dark frame on a wall; the frame's outer edges are vertical lines.

        (x, y) is the door's centre on the wall line; ``yaw`` the direction it faces. The frame
        stands ``FRAME_OFFSET_M`` in front of the wall, and so do its vertical-line landmarks:
        the edge the camera sees is the frame's, not the wall's (on the wall line they projected
        up to 5 px aside of the rendered edge in corridor21's pinhole images).
        """
        centre, normal, edge_u = self._facing(x, y, yaw, width)
        unit_u = edge_u / width
        tex_door = self.texture(TextureKind.WOOD, (width, height))
        obj = self.new_object()
        origin = centre + 0.01 * normal - edge_u / 2 + np.array([0.0, 0.0, height])
        self.quad(SurfaceKind.DOOR, origin, edge_u, (0, 0, -height), tex_door, obj)
        frame = 0.08
        tex_frame = self.texture(TextureKind.FRAME, (frame, height + frame), shared="door-frame")
        for side in (-1, 1):
            left = centre + FRAME_OFFSET_M * normal + unit_u * (
                side * (width / 2 + frame / 2) - frame / 2
            )
            up = np.array([0.0, 0.0, height + frame])
            self.quad(SurfaceKind.DOOR_FRAME, left + up, unit_u * frame, -up, tex_frame, obj)
            outer = centre + FRAME_OFFSET_M * normal + unit_u * side * (width / 2 + frame)
            self.vertical_lines.append(
                VerticalLine(self.new_landmark_id(), float(outer[0]), float(outer[1]))
            )
        top = centre + FRAME_OFFSET_M * normal - unit_u * (width / 2)
        top = top + np.array([0.0, 0.0, height + frame])
        self.quad(SurfaceKind.DOOR_FRAME, top, unit_u * width, (0, 0, -frame), tex_frame, obj)
