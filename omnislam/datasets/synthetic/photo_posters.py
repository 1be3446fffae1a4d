"""Hang real photographs in a world: a fraction of its posters become photographs.

A poster keeps its place, size and surface id; only its texture changes, from the procedural
pattern to a photograph (``photos``) cropped to its aspect ratio. Which posters and which
photographs is drawn from an injected generator, so one seed gives one world.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from omnislam.datasets.synthetic.photos import PHOTO_NAMES, photo_credit
from omnislam.datasets.synthetic.textures import TextureKind, TextureSpec
from omnislam.datasets.synthetic.world import SurfaceKind, World
from omnislam.errors import ConfigError


@dataclass(frozen=True, slots=True)
class PhotoTextures:
    """Which posters show photographs.

    Attributes:
        fraction: probability that a poster shows a photograph instead of its procedural
            pattern. Default 0.5: half the walls' pictures are real photographs (natural
            image statistics: smooth gradients, repeated texture, few saturated colours),
            half keep the dense synthetic patterns whose keypoints are easy to match.
        photos: the photographs drawn from (``photos.PHOTO_SOURCES`` keys), uniformly.
            Default: all of them (colour photographs, grey photographs, brick, gravel and
            grass samples as wall panels).
    """

    fraction: float = 0.5
    photos: tuple[str, ...] = PHOTO_NAMES

    def __post_init__(self) -> None:
        if not (math.isfinite(self.fraction) and 0.0 <= self.fraction <= 1.0):
            raise ConfigError(f"photo_textures.fraction must lie in [0, 1], got {self.fraction}")
        if not self.photos:
            raise ConfigError("photo_textures.photos must name at least one photograph")
        unknown = sorted(set(self.photos) - set(PHOTO_NAMES))
        if unknown:
            raise ConfigError(f"photo_textures.photos: unknown photograph(s) {unknown}; "
                              f"known: {', '.join(PHOTO_NAMES)}")


def with_photo_textures(world: World, config: PhotoTextures, rng: np.random.Generator) -> World:
    """``world`` with a fraction of its posters' textures replaced by photographs.

    Two draws per poster (whether, which), in surface-id order, whatever the fraction: the
    same generator state gives the same world.

    Args:
        world: the world (its posters each own their texture, as ``WorldBuilder.poster``
            makes them; a shared texture would change every quad that uses it).
        config: the fraction and the photographs.
        rng: the generator the choices are drawn from.
    """
    textures = list(world.textures)
    for quad in world.quads:
        if quad.kind is not SurfaceKind.POSTER:
            continue
        chosen = rng.random() < config.fraction
        name = config.photos[int(rng.integers(len(config.photos)))]
        if chosen:
            spec = textures[quad.texture]
            textures[quad.texture] = TextureSpec.make(TextureKind.PHOTO, 0, spec.extent_m,
                                                      spec.size_px, image=name)
    return dataclasses.replace(world, textures=tuple(textures))


def world_photo_credit(world: World) -> str | None:
    """The credit of the photographs ``world`` shows (``photos.photo_credit``), None when it
    shows none: the text a dataset's metadata can carry."""
    names = [t.image for t in world.textures if t.image is not None]
    return photo_credit(names) if names else None
