"""Photographs on a fraction of the posters: deterministic per seed, credited, rendered."""

from __future__ import annotations

import numpy as np
import pytest

from omnislam.datasets.synthetic.photo_posters import (
    PhotoTextures,
    with_photo_textures,
    world_photo_credit,
)
from omnislam.datasets.synthetic.photos import PHOTO_SOURCES, photo_credit, photo_texels
from omnislam.datasets.synthetic.render import Renderer
from omnislam.datasets.synthetic.textures import TextureKind, TextureSpec, generate_texture
from omnislam.datasets.synthetic.world import SurfaceKind, World
from omnislam.errors import ConfigError, DataError

pytest.importorskip("skimage")


def _posters(world: World) -> list[TextureSpec]:
    return [world.textures[q.texture] for q in world.quads if q.kind is SurfaceKind.POSTER]


def test_the_same_seed_hangs_the_same_photographs(demo_sim):
    config = PhotoTextures(fraction=0.5)
    a = with_photo_textures(demo_sim.world, config, np.random.default_rng(7))
    b = with_photo_textures(demo_sim.world, config, np.random.default_rng(7))
    c = with_photo_textures(demo_sim.world, config, np.random.default_rng(8))
    assert a.to_json() == b.to_json()
    assert a.to_json() != c.to_json()
    photos = [t for t in _posters(a) if t.kind is TextureKind.PHOTO]
    assert 0 < len(photos) < len(_posters(a))
    assert World.from_json(a.to_json()) == a  # the photographs' names survive world.json
    assert a.quads == demo_sim.world.quads  # only textures change


def test_fractions_zero_and_one():
    from omnislam.datasets.synthetic.presets import PRESETS

    world = PRESETS["lab40"].build_world(np.random.default_rng(0))
    none = with_photo_textures(world, PhotoTextures(fraction=0.0), np.random.default_rng(1))
    assert none.to_json() == world.to_json()
    assert world_photo_credit(none) is None
    every = with_photo_textures(world, PhotoTextures(fraction=1.0), np.random.default_rng(1))
    assert all(t.kind is TextureKind.PHOTO for t in _posters(every))
    assert '"image"' not in world.to_json()  # procedural worlds' JSON is as it was


def test_the_credit_names_scikit_image_and_every_source(demo_sim):
    world = with_photo_textures(demo_sim.world, PhotoTextures(fraction=1.0),
                                np.random.default_rng(3))
    credit = world_photo_credit(world)
    assert credit is not None and "scikit-image" in credit and "BSD-3-Clause" in credit
    for name in {t.image for t in world.textures if t.image}:
        assert f"skimage.data.{name}: {PHOTO_SOURCES[name]}" in credit
    assert photo_credit().count("\n") == len(PHOTO_SOURCES)
    with pytest.raises(DataError):
        photo_credit(["lena"])


def test_a_photograph_is_cropped_to_the_quad_and_keeps_its_content():
    texels = photo_texels("astronaut", (64, 128))  # a tall poster from a square image
    assert texels.shape == (128, 64, 3)
    from skimage import data, transform

    middle = data.astronaut()[:, 128:384].astype(float)
    expected = transform.resize(middle, (128, 64), order=1, anti_aliasing=True,
                                preserve_range=True)
    np.testing.assert_allclose(texels, expected, atol=1e-9)
    grey = generate_texture(TextureSpec.make(TextureKind.PHOTO, 0, (1.0, 1.0), image="brick"))
    assert grey.dtype == np.uint8 and np.array_equal(grey[..., 0], grey[..., 2])


def test_bad_photo_settings_are_refused():
    with pytest.raises(ConfigError):
        PhotoTextures(fraction=1.5)
    with pytest.raises(ConfigError):
        PhotoTextures(photos=("lena",))
    with pytest.raises(DataError):
        TextureSpec.make(TextureKind.PHOTO, 0, (1.0, 1.0))  # a photo without its image


def test_a_rendered_photo_poster_shows_the_photograph(demo_sim):
    world = with_photo_textures(demo_sim.world, PhotoTextures(fraction=1.0, photos=("coffee",)),
                                np.random.default_rng(0))
    pose = demo_sim.poses_w[demo_sim.image_frames[0]]
    before = Renderer(demo_sim.world, demo_sim.rig, None).render(pose)
    after = Renderer(world, demo_sim.rig, None).render(pose)
    np.testing.assert_array_equal(after.surface_ids, before.surface_ids)
    posters = np.isin(after.surface_ids,
                      [i for i, q in enumerate(world.quads) if q.kind is SurfaceKind.POSTER])
    assert posters.sum() > 500
    assert np.array_equal(after.image[~posters], before.image[~posters])
    changed = np.any(after.image[posters] != before.image[posters], axis=1)
    assert changed.mean() > 0.9
