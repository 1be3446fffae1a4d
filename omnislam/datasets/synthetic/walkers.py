"""People walking through a world: moving vertical cylinders cast together with the static quads.

A walker is a vertical cylinder of a person's size (radius ~0.2 m, height ~1.7 m, no caps:
a camera below its top sees only its side) dressed in a ``CLOTH`` texture, pacing back and
forth along a straight segment of one floor rectangle at a constant speed:

    s = (phase + v t) mod 2L,   xy(t) = A + min(s, 2L - s) / L (B - A)      (L = |B - A|)

Walkers are drawn per render from a seed (``draw_walkers``); they walk through furniture (no
collision) and do not cast shadows or appear in the laser. A ray ``o + t d`` meets a walker
centred at ``c`` where ``|o_xy - c + t d_xy| = r``: ``t = (-b - sqrt(b^2 - a k)) / a`` with
``a = |d_xy|^2``, ``b = (o_xy - c) . d_xy``, ``k = |o_xy - c|^2 - r^2``, if ``0 <= z <= h``
there (from inside a walker nothing of it is seen). Only rays whose azimuth points at a walker
are tested (its half-width ``asin(r / D)`` seen from distance ``D``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from omnislam.datasets.synthetic.hit_distances import MIN_DISTANCE_M
from omnislam.datasets.synthetic.textures import TextureKind, TextureSpec
from omnislam.datasets.synthetic.world import SurfaceKind, World
from omnislam.errors import ConfigError, DataError

#: a walker's path keeps this far from its floor rectangle's edges (beyond its radius) [m]
WALL_CLEARANCE_M = 0.3


@dataclass(frozen=True, slots=True)
class Walkers:
    """How many people walk through the world, and how.

    Attributes:
        count: walkers per render. Default 3: a lab or corridor with a few people about,
            enough that some frames have a person close to the robot.
        speed_mps: walking speed [m/s]. Default 1.0: a relaxed indoor pace (1.2-1.4 m/s
            outdoors), five times the lab robot's top speed.
        radius_range_m: (min, max) of a walker's radius, drawn uniformly [m]. Default
            (0.18, 0.25): half a person's shoulder width.
        height_range_m: (min, max) of a walker's height, drawn uniformly [m]. Default
            (1.55, 1.90): adult heights.
        min_leg_m: shortest path segment [m]. Default 2.0: a walker crosses the view rather
            than standing still (shorter when no floor rectangle is long enough).
    """

    count: int = 3
    speed_mps: float = 1.0
    radius_range_m: tuple[float, float] = (0.18, 0.25)
    height_range_m: tuple[float, float] = (1.55, 1.90)
    min_leg_m: float = 2.0

    def __post_init__(self) -> None:
        if self.count < 0:
            raise ConfigError(f"walkers.count must be >= 0, got {self.count}")
        if not (math.isfinite(self.speed_mps) and self.speed_mps >= 0.0):
            raise ConfigError(f"walkers.speed_mps must be >= 0, got {self.speed_mps}")
        for name in ("radius_range_m", "height_range_m"):
            low, high = getattr(self, name)
            if not (math.isfinite(low) and math.isfinite(high) and 0.0 < low <= high):
                raise ConfigError(f"walkers.{name} must be 0 < min <= max, got {(low, high)}")
        if not (math.isfinite(self.min_leg_m) and self.min_leg_m >= 0.0):
            raise ConfigError(f"walkers.min_leg_m must be >= 0, got {self.min_leg_m}")


@dataclass(frozen=True, slots=True)
class WalkerPath:
    """One walker: its body and its path (the render's truth).

    Attributes:
        start_w, end_w: (x, y) ends of the segment it paces [m].
        speed_mps: its speed [m/s].
        phase_m: distance along the out-and-back loop at t = 0 [m].
        radius_m, height_m: the cylinder [m].
        texture: its clothes.
    """

    start_w: tuple[float, float]
    end_w: tuple[float, float]
    speed_mps: float
    phase_m: float
    radius_m: float
    height_m: float
    texture: TextureSpec

    def positions_w(self, stamps_s: np.ndarray) -> np.ndarray:
        """(N, 2) centre on the floor at times ``stamps_s`` (N,) [s] (module docstring)."""
        stamps_s = np.asarray(stamps_s, dtype=float).reshape(-1)
        start, end = np.asarray(self.start_w), np.asarray(self.end_w)
        length = float(np.linalg.norm(end - start))
        if length == 0.0:
            return np.tile(start, (stamps_s.size, 1))
        s = np.mod(self.phase_m + self.speed_mps * stamps_s, 2.0 * length)
        along = np.minimum(s, 2.0 * length - s) / length
        return start + along[:, None] * (end - start)

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python form for a render's truth file (``from_dict`` reads it)."""
        return {"start_w": list(self.start_w), "end_w": list(self.end_w),
                "speed_mps": self.speed_mps, "phase_m": self.phase_m,
                "radius_m": self.radius_m, "height_m": self.height_m,
                "texture": self.texture.to_dict()}

    @classmethod
    def from_dict(cls, doc: Any) -> WalkerPath:
        """Inverse of ``to_dict``; DataError on a malformed entry."""
        try:
            start = (float(doc["start_w"][0]), float(doc["start_w"][1]))
            end = (float(doc["end_w"][0]), float(doc["end_w"][1]))
            return cls(start, end, float(doc["speed_mps"]), float(doc["phase_m"]),
                       float(doc["radius_m"]), float(doc["height_m"]),
                       TextureSpec.from_dict(doc["texture"]))
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise DataError(f"malformed walker: {exc!r}") from exc


def walker_positions_w(walkers: tuple[WalkerPath, ...], stamps_s: np.ndarray) -> np.ndarray:
    """(N, W, 2) every walker's centre at times ``stamps_s`` (N,) [s]: the positions a writer
    records per frame."""
    stamps_s = np.asarray(stamps_s, dtype=float).reshape(-1)
    out = np.zeros((stamps_s.size, len(walkers), 2))
    for k, walker in enumerate(walkers):
        out[:, k] = walker.positions_w(stamps_s)
    return out


def draw_walkers(world: World, config: Walkers, rng: np.random.Generator) -> tuple[
        WalkerPath, ...]:
    """``config.count`` walkers on the world's floor rectangles (picked in proportion to their
    area), each pacing a segment between two uniform points of its rectangle (the longest of
    20 tries, or the first at least ``min_leg_m`` long). No floor: no walkers."""
    floors = [q for q in world.quads if q.kind is SurfaceKind.FLOOR]
    if not floors or config.count == 0:
        return ()
    areas = np.array([np.linalg.norm(np.cross(q.edge_u_w, q.edge_v_w)) for q in floors])
    walkers = []
    for _ in range(config.count):
        floor = floors[int(rng.choice(len(floors), p=areas / areas.sum()))]
        radius = float(rng.uniform(*config.radius_range_m))
        height = float(rng.uniform(*config.height_range_m))
        start, end = _segment(floor.origin_w, floor.edge_u_w, floor.edge_v_w,
                              radius + WALL_CLEARANCE_M, config.min_leg_m, rng)
        length = math.dist(start, end)
        texture = TextureSpec.make(TextureKind.CLOTH, int(rng.integers(0, 2**31 - 1)),
                                   (2.0 * math.pi * radius, height))
        walkers.append(WalkerPath(start, end, config.speed_mps,
                                  float(rng.uniform(0.0, 2.0 * length)), radius, height, texture))
    return tuple(walkers)


def _segment(origin: tuple[float, ...], edge_u: tuple[float, ...], edge_v: tuple[float, ...],
             margin_m: float, min_leg_m: float, rng: np.random.Generator,
             ) -> tuple[tuple[float, float], tuple[float, float]]:
    """Two points of a floor parallelogram, ``margin_m`` inside its edges where it is wide
    enough (its middle otherwise)."""
    o, eu, ev = (np.asarray(x, dtype=float)[:2] for x in (origin, edge_u, edge_v))
    lu, lv = float(np.linalg.norm(eu)), float(np.linalg.norm(ev))
    inset_u = min(margin_m / lu, 0.5) if lu > 0 else 0.5
    inset_v = min(margin_m / lv, 0.5) if lv > 0 else 0.5
    best: tuple[np.ndarray, np.ndarray] | None = None
    for _ in range(20):
        a, b = rng.uniform([inset_u, inset_v], [1.0 - inset_u, 1.0 - inset_v], size=(2, 2))
        p, q = o + a[0] * eu + a[1] * ev, o + b[0] * eu + b[1] * ev
        if best is None or np.linalg.norm(q - p) > np.linalg.norm(best[1] - best[0]):
            best = (p, q)
        if np.linalg.norm(q - p) >= min_leg_m:
            break
    assert best is not None
    return (float(best[0][0]), float(best[0][1])), (float(best[1][0]), float(best[1][1]))


def walker_hits(
    centres_w: np.ndarray,
    radii_m: np.ndarray,
    heights_m: np.ndarray,
    origins_w: np.ndarray,
    directions_w: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """First hits of rays on walker cylinders (module docstring), every ray against every one.

    Args:
        centres_w: (W, 2) centres on the floor [m].
        radii_m, heights_m: (W,) [m].
        origins_w: (3, N) ray origins [m].
        directions_w: (3, N) unit directions.

    Returns:
        ``(distances_m, walker)``: (N,) distance to the nearest hit (inf none) and (N,) the
        walker hit (-1 none).
    """
    n = directions_w.shape[1]
    best_t = np.full(n, np.inf)
    best = np.full(n, -1, dtype=np.intp)
    a = directions_w[0] ** 2 + directions_w[1] ** 2
    for k, (centre, radius, height) in enumerate(zip(centres_w, radii_m, heights_m,
                                                     strict=True)):
        px, py = origins_w[0] - centre[0], origins_w[1] - centre[1]
        b = px * directions_w[0] + py * directions_w[1]
        c = px**2 + py**2 - radius**2
        with np.errstate(invalid="ignore", divide="ignore"):
            t = (-b - np.sqrt(b**2 - a * c)) / a
            z = origins_w[2] + t * directions_w[2]
            closer = (t > MIN_DISTANCE_M) & (z >= 0.0) & (z <= height) & (t < best_t)
        best_t[closer] = t[closer]
        best[closer] = k
    return best_t, best
