"""World description, JSON round trip and texture lookup."""

from __future__ import annotations

import numpy as np
import pytest

from omnislam.datasets.synthetic.presets import PRESETS
from omnislam.datasets.synthetic.textures import (
    TextureAtlas,
    TextureKind,
    TextureSpec,
    generate_texture,
)
from omnislam.datasets.synthetic.world import World
from omnislam.errors import DataError


def test_world_json_round_trip_is_exact(demo_sim):
    text = demo_sim.world.to_json()
    again = World.from_json(text)
    assert again == demo_sim.world
    assert again.to_json() == text


def test_world_is_deterministic_per_seed():
    a = PRESETS["demo"].build_world(np.random.default_rng(1))
    b = PRESETS["demo"].build_world(np.random.default_rng(1))
    c = PRESETS["demo"].build_world(np.random.default_rng(2))
    assert a.to_json() == b.to_json()
    assert a.to_json() != c.to_json()


@pytest.mark.parametrize("text", ["{", '{"format_version": 99}', '{"format_version": 1}'])
def test_malformed_world_raises_data_error_naming_the_file(tmp_path, text):
    path = tmp_path / "world.json"
    with pytest.raises(DataError, match=r"world\.json"):
        World.from_json(text, path)


@pytest.mark.parametrize("kind", list(TextureKind))
def test_textures_are_deterministic(kind):
    if kind is TextureKind.PHOTO:
        pytest.importorskip("skimage")
    image = "coffee" if kind is TextureKind.PHOTO else None
    spec = TextureSpec.make(kind, 11, (0.8, 0.6), image=image)
    a, b = generate_texture(spec), generate_texture(spec)
    assert a.dtype == np.uint8 and a.shape == (spec.size_px[1], spec.size_px[0], 3)
    np.testing.assert_array_equal(a, b)


def test_bilinear_lookup_hits_texel_centres_and_interpolates():
    spec = TextureSpec.make(TextureKind.POSTER, 4, (1.0, 0.5), size_px=(64, 32))
    texels = generate_texture(spec).astype(np.float32)
    atlas = TextureAtlas([spec])
    col, row = np.array([3, 40]), np.array([5, 20])
    u = (col + 0.5) / 64 * 1.0
    v = (row + 0.5) / 32 * 0.5
    np.testing.assert_allclose(atlas.sample(np.zeros(2, int), u, v), texels[row, col], atol=1e-3)
    mid = atlas.sample(np.zeros(1, int), u[:1] + 0.5 / 64, v[:1])
    np.testing.assert_allclose(mid[0], 0.5 * (texels[5, 3] + texels[5, 4]), atol=1e-3)


def test_poster_textures_are_rich_and_plain_ones_are_not():
    pytest.importorskip("cv2")
    import cv2

    poster = generate_texture(TextureSpec.make(TextureKind.POSTER, 1, (1.0, 1.0)))
    plain = generate_texture(TextureSpec.make(TextureKind.PLAIN, 1, (2.0, 2.0), (256, 256)))
    sift = cv2.SIFT_create()
    assert len(sift.detect(cv2.cvtColor(poster, cv2.COLOR_RGB2GRAY), None)) > 100
    assert len(sift.detect(cv2.cvtColor(plain, cv2.COLOR_RGB2GRAY), None)) < 5
