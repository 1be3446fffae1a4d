"""Local light sources of a rendered world: ceiling lamps as point lights.

With lighting on, the renderer's shading term of a surface point ``p`` with unit normal ``n`` is

    shade = AMBIENT + sum_k P_k max(0, s n . (L_k - p)) / max(|L_k - p|, d_min)^3

(Lambert's cosine ``cos theta_k = n . (L_k - p) / |L_k - p|`` times the inverse-square falloff
``1 / |L_k - p|^2`` of a point source: the illuminance law, E = I cos(theta) / d^2), where
``L_k`` are the lamps, ``P_k`` their power and ``s = sign(n . (o - p))`` the side of the surface
the camera (at ``o``) sees: a lamp lights only the side it is on, so a lamp behind a wall does
not light the wall's face seen from the front. No shadows: a lamp lights every point on its
side of a surface, whatever stands between.

On a planar quad ``n . (L_k - p) = n . (L_k - o_q)`` for every point ``p`` of it (``o_q`` a
corner), so the cosine's numerator and the side are constants per quad (and per frame): the
renderer tabulates them once and evaluates only the distance per ray.

The lamps are the world's light panels (``SurfaceKind.LIGHT``): one point light a little below
each panel's centre. Worlds without light panels (laser-only presets, plain corridors) get no
lamps, and their renders stay ambient only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from omnislam.datasets.synthetic.world import SurfaceKind, World
from omnislam.errors import ConfigError


@dataclass(frozen=True, slots=True)
class LightingConfig:
    """Point lights at the world's ceiling light panels (module docstring).

    Attributes:
        ambient: shading of a surface that no lamp lights (diffuse inter-reflection from the
            room) [fraction of the texture's colour]. Default 0.35: far from the lamps a wall
            is about a third as bright as under one, as in a lab lit by ceiling panels.
        lamp_power_m2: power ``P`` of each lamp in the shading's units (shade = P / d^2 under
            the lamp at distance d) [m^2]. Default 2.0: a floor 2.55 m below a panel gets
            +0.31 and a wall 1.5 m beside and 1 m below one +0.51, so the brightest surfaces
            of a lab stay below the texture's full colour (little clipping).
        lamp_drop_m: how far below its light panel a lamp sits [m]. Default 0.05: the panel's
            own plane must not contain the lamp (the ceiling would be lit edge-on at zero).
        min_distance_m: distances to a lamp below this count as this [m]. Default 0.3: keeps
            a poster right beside a lamp from an unbounded 1/d^2.
    """

    ambient: float = 0.35
    lamp_power_m2: float = 2.0
    lamp_drop_m: float = 0.05
    min_distance_m: float = 0.3

    def __post_init__(self) -> None:
        if not (np.isfinite(self.ambient) and self.ambient >= 0.0):
            raise ConfigError(f"lighting.ambient must be >= 0, got {self.ambient}")
        if not (np.isfinite(self.lamp_power_m2) and self.lamp_power_m2 >= 0.0):
            raise ConfigError(f"lighting.lamp_power_m2 must be >= 0, got {self.lamp_power_m2}")
        if not (np.isfinite(self.lamp_drop_m) and self.lamp_drop_m > 0.0):
            raise ConfigError(f"lighting.lamp_drop_m must be > 0, got {self.lamp_drop_m}")
        if not (np.isfinite(self.min_distance_m) and self.min_distance_m > 0.0):
            raise ConfigError(
                f"lighting.min_distance_m must be > 0, got {self.min_distance_m}")


def lamp_positions(world: World, config: LightingConfig) -> np.ndarray:
    """(K, 3) positions of the lamps [m]: ``lamp_drop_m`` below the centre of every light panel
    (along -z: panels hang under ceilings)."""
    centres = [
        np.add(q.origin_w, 0.5 * (np.add(q.edge_u_w, q.edge_v_w)))
        for q in world.quads
        if q.kind is SurfaceKind.LIGHT
    ]
    lamps = np.array(centres, dtype=float).reshape(-1, 3)
    lamps[:, 2] -= config.lamp_drop_m
    return lamps


def lamp_heights(normals_w: np.ndarray, origins_w: np.ndarray, lamps_w: np.ndarray) -> np.ndarray:
    """(K, M) signed height ``n_q . (L_k - o_q)`` of every lamp over every quad's plane [m].

    Args:
        normals_w: (M, 3) unit normals of the quads.
        origins_w: (M, 3) a corner of each quad [m].
        lamps_w: (K, 3) lamp positions [m].
    """
    return lamps_w @ normals_w.T - np.einsum("ij,ij->i", normals_w, origins_w)[None, :]


def lamp_irradiance(
    points_w: np.ndarray,
    normals_w: np.ndarray,
    viewer_w: np.ndarray,
    lamps_w: np.ndarray,
    config: LightingConfig,
) -> np.ndarray:
    """Lamp term of the shading (module docstring) at points: the reference implementation.

    Args:
        points_w: (N, 3) surface points [m].
        normals_w: (N, 3) unit normals of their surfaces (either sign).
        viewer_w: (3,) the camera's position [m] (decides the side of the surface seen).
        lamps_w: (K, 3) lamp positions [m].
        config: the lighting.

    Returns:
        (N,) ``sum_k P max(0, s n . (L_k - p)) / max(|L_k - p|, d_min)^3``.
    """
    to_lamps = lamps_w[None, :, :] - points_w[:, None, :]  # (N, K, 3)
    side = np.sign(np.einsum("ij,ij->i", normals_w, viewer_w - points_w))
    facing = np.maximum(0.0, side[:, None] * np.einsum("nkj,nj->nk", to_lamps, normals_w))
    distance = np.maximum(np.linalg.norm(to_lamps, axis=2), config.min_distance_m)
    return config.lamp_power_m2 * np.sum(facing / distance**3, axis=1)
