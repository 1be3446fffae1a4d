"""Planar laser scans and pole sightings: the thesis's simulation stand-in (ch. 5.1.1).

The thesis could not simulate its mirror in Gazebo and used a second laser instead: 360 deg,
4 m range, 0.5 m above a 180 deg / 3 m laser; poles were detected as local range minima and
used as landmarks. Here the same sensors are ray cast against the world's quads:

* ``scan``: ranges of ``beams`` horizontal rays at ``height_m`` plus Gaussian range noise;
  beams without a return within ``max_range_m`` read ``max_range_m`` (``LaserScans``
  convention).
* ``pole_sightings``: every pole whose centre is within range and whose line of sight (at
  sensor height) first hits that pole, as a ``RangeBearing`` with the true landmark id; range
  (to the pole's centre) and bearing get Gaussian noise.
* ``scanned_poles``: the thesis's own detection (Fig. 5.2): the poles are the scan's local
  minima. Each pole the scan's beams hit is reported at the beam of least (noisy) range among
  those that hit it: range and bearing of the *nearest surface point* the laser saw, the range
  lengthened by a radius guess (``PoleScanner.radius_guess_m``). Where the guess falls short of
  a pole's radius, the pole is reported short of its centre along whichever side is seen --
  seen from opposite sides, twice the shortfall apart -- as the thesis says of its thicker poles
  ("uma maior imprecisao quanto a sua posicao ao ser detectada em diferentes angulos", sec.
  5.1.2). Which beams belong to which pole comes from the ray caster (the thesis placed its
  poles to be detectable and reports no false detections); where the pole is comes from the
  ranges alone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from omnislam.core.se import wrap_angle
from omnislam.core.types import RangeBearing
from omnislam.datasets.synthetic.raycast import RayCaster
from omnislam.datasets.synthetic.world import SurfaceKind, World
from omnislam.errors import ConfigError


@dataclass(frozen=True, slots=True)
class LaserConfig:
    """A planar laser on the robot.

    Attributes:
        fov_deg: field of view centred on the heading [deg] (180 or 360).
        beams: number of beams.
        max_range_m: maximum range [m].
        sigma_range_m: range noise std [m].
        height_m: height of the scan plane above the floor [m].
        sigma_bearing_rad: bearing noise std of pole sightings [rad].
    """

    fov_deg: float = 360.0
    beams: int = 360
    max_range_m: float = 4.0
    sigma_range_m: float = 0.01
    height_m: float = 0.8
    sigma_bearing_rad: float = math.radians(1.0)

    def __post_init__(self) -> None:
        if not 0 < self.fov_deg <= 360 or self.beams < 1 or self.max_range_m <= 0:
            raise ConfigError(f"invalid laser configuration {self}")
        if self.sigma_range_m <= 0 or self.sigma_bearing_rad <= 0:
            raise ConfigError("laser noise stds must be positive")

    def angles_rad(self) -> np.ndarray:
        """(B,) beam angles in the robot frame, counter-clockwise from the heading."""
        half = math.radians(self.fov_deg) / 2.0
        if self.fov_deg >= 360.0:
            return -math.pi + np.arange(self.beams) * 2 * math.pi / self.beams
        return np.linspace(-half, half, self.beams)


def scan(
    caster: RayCaster, config: LaserConfig, wTr: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """Noisy ranges (B,) [m] of one scan from planar pose ``wTr`` (3,)."""
    angles = config.angles_rad() + wTr[2]
    directions = np.column_stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)])
    origin = np.array([wTr[0], wTr[1], config.height_m])
    distances, _ = caster.cast(origin, directions)
    noisy = distances + config.sigma_range_m * rng.standard_normal(distances.shape)
    return np.where(np.isfinite(distances) & (distances < config.max_range_m),
                    np.clip(noisy, 0.0, config.max_range_m), config.max_range_m)


@dataclass(frozen=True, slots=True)
class PoleScanner:
    """A laser whose scan's local minima are the pole sightings (thesis sec. 5.1.1).

    Attributes:
        laser: the scanning laser (the thesis's upper one: 360 deg, 4 m, 0.5 m above the
            lower). Its ``sigma_range_m`` is the noise of every beam and the stated range sigma
            of a sighting; its ``sigma_bearing_rad`` is only stated (a sighting's bearing is its
            beam's angle, exact but quantised to the beam spacing: state the spacing).
        radius_guess_m: added to the range of the nearest surface point (0: the bare local
            minimum, as the thesis detects it).
    """

    laser: LaserConfig
    radius_guess_m: float = 0.0

    def __post_init__(self) -> None:
        if not self.radius_guess_m >= 0:
            raise ConfigError(f"radius_guess_m must be >= 0, got {self.radius_guess_m}")


def pole_table(world: World) -> np.ndarray:
    """(P, 4) [landmark_id, x, y, radius] of the world's poles (compute once per world)."""
    return np.array([[p.landmark_id, p.x_m, p.y_m, p.radius_m] for p in world.poles],
                    dtype=float).reshape(-1, 4)


def pole_sightings(
    caster: RayCaster,
    pole_surfaces: np.ndarray,
    poles: np.ndarray,
    config: LaserConfig,
    wTr: np.ndarray,
    rng: np.random.Generator,
) -> RangeBearing:
    """Noisy range-bearing sightings of the visible poles from planar pose ``wTr`` (3,).

    Args:
        caster: ray caster of ``world`` (occlusion test).
        pole_surfaces: (M,) bool, surface id is a pole face (``World.surface_kinds()``).
        poles: ``pole_table(world)``.
        config: the laser that detects the poles.
        wTr: (3,) true robot pose.
        rng: noise generator.
    """
    delta = poles[:, 1:3] - wTr[:2]
    distance = np.hypot(delta[:, 0], delta[:, 1])
    bearing = wrap_angle(np.arctan2(delta[:, 1], delta[:, 0]) - wTr[2])
    candidate = (distance <= config.max_range_m) & (distance > poles[:, 3])
    candidate &= np.abs(bearing) <= math.radians(config.fov_deg) / 2.0 + 1e-12
    index = np.flatnonzero(candidate)
    visible = np.zeros(0, dtype=np.int64)
    if index.size:
        origin = np.array([wTr[0], wTr[1], config.height_m])
        directions = np.column_stack([delta[index] / distance[index, None],
                                      np.zeros(index.size)])
        distances, hit = caster.cast(origin, directions)
        # the first hit must be a pole face no farther than this pole's far side
        own = (hit >= 0) & pole_surfaces[np.maximum(hit, 0)]
        own &= np.abs(distances - distance[index]) <= 1.5 * poles[index, 3] + 1e-6
        visible = index[own]
    k = visible.size
    ranges = distance[visible] + config.sigma_range_m * rng.standard_normal(k)
    bearings = wrap_angle(bearing[visible] + config.sigma_bearing_rad * rng.standard_normal(k))
    return RangeBearing(
        landmark_ids=poles[visible, 0].astype(np.int64),
        ranges_m=np.maximum(ranges, 0.0),
        bearings_rad=bearings,
        sigma_range_m=np.full(k, config.sigma_range_m),
        sigma_bearing_rad=np.full(k, config.sigma_bearing_rad),
    )


def pole_of_surface(world: World, poles: np.ndarray) -> np.ndarray:
    """(M,) row of ``poles`` (``pole_table``) each surface belongs to, -1 for non-pole faces.

    A pole face belongs to the pole whose centre is nearest to the face's middle (its prism is
    built round that centre, ``WorldBuilder.pole``).
    """
    out = np.full(len(world.quads), -1, dtype=np.int64)
    if not len(poles):
        return out
    for q, quad in enumerate(world.quads):
        if quad.kind is SurfaceKind.POLE:
            middle = np.add(quad.origin_w[:2], np.multiply(quad.edge_u_w[:2], 0.5))
            out[q] = int(np.argmin(np.hypot(*(poles[:, 1:3] - middle).T)))
    return out


def scanned_poles(
    caster: RayCaster,
    surface_pole: np.ndarray,
    poles: np.ndarray,
    scanner: PoleScanner,
    wTr: np.ndarray,
    rng: np.random.Generator,
) -> RangeBearing:
    """Pole sightings as the scan's local minima, one per pole hit (module docstring).

    Args:
        caster: ray caster of the world.
        surface_pole: ``pole_of_surface(world, poles)``.
        poles: ``pole_table(world)``.
        scanner: the scanning laser.
        wTr: (3,) true robot pose.
        rng: noise generator (one range draw per beam).

    Returns:
        Sightings in increasing landmark id, with the true ids (a loader may hide them).
    """
    config = scanner.laser
    angles = config.angles_rad()
    heading = angles + wTr[2]
    directions = np.column_stack([np.cos(heading), np.sin(heading), np.zeros_like(heading)])
    distances, hit = caster.cast(np.array([wTr[0], wTr[1], config.height_m]), directions)
    noisy = distances + config.sigma_range_m * rng.standard_normal(distances.shape)
    seen = np.isfinite(distances) & (distances < config.max_range_m) & (hit >= 0)
    pole = np.where(seen, surface_pole[np.maximum(hit, 0)], -1)
    rows = np.unique(pole[pole >= 0])
    beams = np.array([np.flatnonzero(pole == row)[np.argmin(noisy[pole == row])] for row in rows],
                     dtype=np.int64)
    k = rows.size
    return RangeBearing(
        landmark_ids=poles[rows, 0].astype(np.int64),
        ranges_m=np.maximum(noisy[beams], 0.0) + scanner.radius_guess_m,
        bearings_rad=wrap_angle(angles[beams]),
        sigma_range_m=np.full(k, config.sigma_range_m),
        sigma_bearing_rad=np.full(k, config.sigma_bearing_rad),
    )
