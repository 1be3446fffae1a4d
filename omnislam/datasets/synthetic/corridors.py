"""Corridor networks: walls around axis-parallel centre lines, poles along them.

A network is a set of axis-parallel centre-line segments and one corridor width. Its free space
is the union of the rectangles the segments sweep, each padded by half the width at both ends
so that corners and junctions are open; the boundary of that union, found exactly on the grid
of every rectangle edge (coordinate compression), becomes the walls, floor to ceiling. Poles
stand along the centre lines at a fixed distance from one wall (side drawn from the world's
generator), never inside a junction or a corner and never on a segment marked blind.

Used by the presets of the thesis's two simulated routes (Guizilini 2008, sec. 5.1.2, Figs. 5.4
and 5.7), which need corridor circuits of several corridors rather than one rectangular ring.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from omnislam.datasets.synthetic.world import World, WorldBuilder
from omnislam.errors import ConfigError

Point = tuple[float, float]
Segment = tuple[Point, Point]


@dataclass(frozen=True, slots=True)
class PoleRow:
    """How poles line a network's corridors.

    Attributes:
        spacing_m: mean distance between consecutive poles along a centre line [m].
        jitter: each pole moves along its corridor by up to this fraction of ``spacing_m``
            either way (irregular rows: a regular one makes every pole look like its
            neighbour to an association by position).
        radius_m: pole radius [m].
        wall_gap_m: free space between a pole's surface and the nearer wall [m].
        junction_clearance_m: no pole within this distance of a crossing corridor's side [m]
            (the path follower cuts corners).
        sides: faces of each pole's prism (``WorldBuilder.pole``).
    """

    spacing_m: float
    jitter: float = 0.25
    radius_m: float = 0.06
    wall_gap_m: float = 0.35
    junction_clearance_m: float = 1.0
    sides: int = 16

    def __post_init__(self) -> None:
        if min(self.spacing_m, self.radius_m, self.wall_gap_m) <= 0 or not 0 <= self.jitter < 0.5:
            raise ConfigError(f"invalid pole row {self}")


@dataclass(frozen=True, slots=True)
class CorridorNetwork:
    """Axis-parallel corridors of one width.

    Attributes:
        segments_w: centre lines, each ((x0, y0), (x1, y1)) horizontal or vertical [m].
        width_m: corridor width, wall to wall [m].
        blind: indices into ``segments_w`` of corridors without poles.
    """

    segments_w: tuple[Segment, ...]
    width_m: float
    blind: frozenset[int] = frozenset()

    def __post_init__(self) -> None:
        if self.width_m <= 0 or not self.segments_w:
            raise ConfigError("a corridor network needs segments and a positive width")
        for (x0, y0), (x1, y1) in self.segments_w:
            if (x0 != x1) == (y0 != y1):
                raise ConfigError(f"segment {((x0, y0), (x1, y1))} is not axis-parallel")

    def rectangles(self) -> np.ndarray:
        """(K, 4) free rectangles [x_min, y_min, x_max, y_max] swept by the segments [m]."""
        h = self.width_m / 2
        segments = np.array(self.segments_w, dtype=float).reshape(-1, 4)
        lo = np.minimum(segments[:, :2], segments[:, 2:]) - h
        hi = np.maximum(segments[:, :2], segments[:, 2:]) + h
        return np.hstack([lo, hi])

    def walls(self) -> list[Segment]:
        """The boundary of the free space as maximal straight wall segments [m]."""
        rects = self.rectangles()
        xs = np.unique(rects[:, [0, 2]])
        ys = np.unique(rects[:, [1, 3]])
        cx, cy = (xs[:-1] + xs[1:]) / 2, (ys[:-1] + ys[1:]) / 2
        free = np.zeros((len(cx) + 2, len(cy) + 2), dtype=bool)  # a blocked border all round
        for x0, y0, x1, y1 in rects:
            inside_x = (cx > x0) & (cx < x1)
            inside_y = (cy > y0) & (cy < y1)
            free[1:-1, 1:-1] |= inside_x[:, None] & inside_y[None, :]
        # a wall runs along x = xs[i] between cells (i, j) and (i + 1, j) of the padded grid
        vertical = free[:-1, 1:-1] != free[1:, 1:-1]  # (len(xs), len(cy))
        horizontal = free[1:-1, :-1] != free[1:-1, 1:]  # (len(cx), len(ys))
        out = [((float(xs[i]), float(ys[a])), (float(xs[i]), float(ys[b])))
               for i, a, b in _runs(vertical)]
        out += [((float(xs[a]), float(ys[j])), (float(xs[b]), float(ys[j])))
                for j, a, b in _runs(horizontal.T)]
        return out

    def pole_sites(self, row: PoleRow, rng: np.random.Generator) -> list[Point]:
        """Pole centres along every corridor that is not blind [m] (see the module docstring)."""
        h = self.width_m / 2
        offset = h - row.wall_gap_m - row.radius_m
        if offset <= 0:
            raise ConfigError(f"poles of radius {row.radius_m} m do not fit a {self.width_m} m "
                              "corridor")
        sites: list[Point] = []
        for k, (p0, p1) in enumerate(self.segments_w):
            if k in self.blind:
                continue
            length = math.dist(p0, p1)
            along = ((p1[0] - p0[0]) / length, (p1[1] - p0[1]) / length)
            normal = (-along[1], along[0])
            for s in np.arange(row.spacing_m / 2, length, row.spacing_m):
                s = float(s + row.jitter * row.spacing_m * rng.uniform(-1.0, 1.0))
                side = 1.0 if rng.random() < 0.5 else -1.0
                x = p0[0] + s * along[0] + side * offset * normal[0]
                y = p0[1] + s * along[1] + side * offset * normal[1]
                if 0 < s < length and self._clear_of_junctions(k, (x, y), h + row.radius_m
                                                               + row.junction_clearance_m):
                    sites.append((x, y))
        return sites

    def _clear_of_junctions(self, own: int, point: Point, clearance_m: float) -> bool:
        """True when ``point`` is at least ``clearance_m`` from every other centre line."""
        for k, (p0, p1) in enumerate(self.segments_w):
            if k != own and _distance_to_segment(point, p0, p1) < clearance_m:
                return False
        return True

    def build(self, name: str, rng: np.random.Generator, poles: PoleRow) -> World:
        """The world: plain walls floor to ceiling on the boundary, poles along the corridors
        (no floor, ceiling or textures worth rendering: for laser-only presets)."""
        b = WorldBuilder(name, 0, rng)
        for p0, p1 in self.walls():
            b.wall(p0, p1, plain=True)
        for x, y in self.pole_sites(poles, rng):
            b.pole(x, y, radius=poles.radius_m, sides=poles.sides)
        return b.build()


def _runs(boundary: np.ndarray) -> list[tuple[int, int, int]]:
    """Maximal runs of True along axis 1 of ``boundary`` (I, J): (i, j_start, j_end + 1)."""
    out = []
    for i, line in enumerate(boundary):
        edges = np.flatnonzero(np.diff(np.concatenate([[0], line.astype(np.int8), [0]])))
        out += [(i, int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]
    return out


def _distance_to_segment(point: Point, p0: Point, p1: Point) -> float:
    """Euclidean distance from ``point`` to the segment p0-p1 [m]."""
    d = np.subtract(p1, p0)
    t = float(np.clip(np.dot(np.subtract(point, p0), d) / max(float(np.dot(d, d)), 1e-12), 0, 1))
    return math.dist(point, (p0[0] + t * d[0], p0[1] + t * d[1]))


def polygon_segments(vertices_w: tuple[Point, ...]) -> tuple[Segment, ...]:
    """The closed chain of centre lines through ``vertices_w`` (last back to first)."""
    return tuple(zip(vertices_w, vertices_w[1:] + vertices_w[:1], strict=True))
