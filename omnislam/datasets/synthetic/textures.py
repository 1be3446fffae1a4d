"""Procedural textures made with numpy, and their bilinear, mip-mapped lookup.

A texture is described by a small ``TextureSpec`` (kind, seed, size, metres covered); the pixels
are regenerated from it deterministically, so ``world.json`` stays small and byte-stable.
Posters and box labels are dense random high-contrast patterns (distinctive SIFT keypoints);
walls, floor tiles and ceiling panels are smooth or periodic (few or repeated keypoints), as in
real corridors; ``PLAIN`` is nearly textureless (the thesis's "corridor with no landmarks").

Texture coordinates: ``u`` (columns) and ``v`` (rows) in metres from the quad's origin corner;
texel (0, 0) is centred at (0.5, 0.5) texels.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

import numpy as np

from omnislam.errors import DataError


class TextureKind(enum.Enum):
    """Procedural texture families."""

    POSTER = "poster"
    CARDBOARD = "cardboard"
    WOOD = "wood"
    FRAME = "frame"
    TILES = "tiles"
    CEILING = "ceiling"
    LIGHT = "light"
    PAINT = "paint"
    PLAIN = "plain"
    STRIPES = "stripes"

    @property
    def repeats(self) -> bool:
        """Periodic textures tile their quad; the others cover it exactly once."""
        return self in _REPEATING


_REPEATING = frozenset(
    {TextureKind.TILES, TextureKind.CEILING, TextureKind.PAINT, TextureKind.PLAIN,
     TextureKind.STRIPES, TextureKind.FRAME}
)

#: texels per metre per kind (before the size cap)
_DENSITY_PX_PER_M: dict[TextureKind, float] = {
    TextureKind.POSTER: 320.0,
    TextureKind.CARDBOARD: 256.0,
    TextureKind.WOOD: 160.0,
    TextureKind.FRAME: 64.0,
    TextureKind.TILES: 160.0,
    TextureKind.CEILING: 128.0,
    TextureKind.LIGHT: 64.0,
    TextureKind.PAINT: 32.0,
    TextureKind.PLAIN: 8.0,
    TextureKind.STRIPES: 64.0,
}
_MAX_SIZE_PX = 512
_MIN_SIZE_PX = 8


@dataclass(frozen=True, slots=True)
class TextureSpec:
    """How to regenerate one texture.

    Attributes:
        kind: family.
        seed: seed of its generator.
        size_px: (width, height) in texels.
        extent_m: (u, v) metres covered by one copy of the texture.
    """

    kind: TextureKind
    seed: int
    size_px: tuple[int, int]
    extent_m: tuple[float, float]

    @classmethod
    def make(
        cls,
        kind: TextureKind,
        seed: int,
        extent_m: tuple[float, float],
        size_px: tuple[int, int] | None = None,
    ) -> TextureSpec:
        """A spec with the kind's default texel density, sizes rounded to multiples of 8."""
        if size_px is None:
            density = _DENSITY_PX_PER_M[kind]

            def side(metres: float) -> int:
                px = round(metres * density / 8.0) * 8
                return min(_MAX_SIZE_PX, max(_MIN_SIZE_PX, px))

            size_px = (side(extent_m[0]), side(extent_m[1]))
        return cls(kind, int(seed), (int(size_px[0]), int(size_px[1])),
                   (float(extent_m[0]), float(extent_m[1])))

    def to_dict(self) -> dict[str, object]:
        return {"kind": self.kind.value, "seed": self.seed, "size_px": list(self.size_px),
                "extent_m": list(self.extent_m)}

    @classmethod
    def from_dict(cls, doc: dict[str, object]) -> TextureSpec:
        size = doc["size_px"]
        extent = doc["extent_m"]
        return cls(TextureKind(doc["kind"]), int(doc["seed"]),  # type: ignore[call-overload]
                   (int(size[0]), int(size[1])),  # type: ignore[index]
                   (float(extent[0]), float(extent[1])))  # type: ignore[index]

    def texel_m(self) -> float:
        """Size of one texel [m] (the larger of the two axes)."""
        return max(self.extent_m[0] / self.size_px[0], self.extent_m[1] / self.size_px[1])


# --- generators ---------------------------------------------------------------------------
def _value_noise(rng: np.random.Generator, h: int, w: int, cells: int) -> np.ndarray:
    """Smooth noise in [0, 1], (h, w): a random (cells+1)^2 grid, bilinearly interpolated."""
    grid = rng.random((cells + 1, cells + 1))
    ys = np.linspace(0, cells, h, endpoint=False) + 0.5 * cells / h
    xs = np.linspace(0, cells, w, endpoint=False) + 0.5 * cells / w
    y0 = np.minimum(ys.astype(int), cells - 1)
    x0 = np.minimum(xs.astype(int), cells - 1)
    fy = (ys - y0)[:, None]
    fx = (xs - x0)[None, :]
    g00 = grid[y0][:, x0]
    g01 = grid[y0][:, x0 + 1]
    g10 = grid[y0 + 1][:, x0]
    g11 = grid[y0 + 1][:, x0 + 1]
    return (g00 * (1 - fx) + g01 * fx) * (1 - fy) + (g10 * (1 - fx) + g11 * fx) * fy


def _grid(h: int, w: int) -> tuple[np.ndarray, np.ndarray]:
    """Texel centre coordinates normalised to [0, 1): (ys (h,1), xs (1,w))."""
    return (np.arange(h)[:, None] + 0.5) / h, (np.arange(w)[None, :] + 0.5) / w


def _saturated_colour(rng: np.random.Generator) -> np.ndarray:
    """A random high-contrast colour (one channel high, one low)."""
    c = rng.random(3)
    c[rng.integers(3)] = rng.uniform(0.0, 0.2)
    c[rng.integers(3)] = rng.uniform(0.8, 1.0)
    return c * 255.0


def _random_shapes(rng: np.random.Generator, img: np.ndarray, count: int, scale: float) -> None:
    """Paint ``count`` random discs, rectangles, rotated bars, rings and triangles in place."""
    h, w = img.shape[:2]
    ys, xs = _grid(h, w)
    ys = ys * (h / max(h, w))
    xs = xs * (w / max(h, w))
    for _ in range(count):
        colour = _saturated_colour(rng) if rng.random() < 0.8 else rng.choice([0.0, 255.0]) * (
            np.ones(3))
        cx, cy = rng.uniform(0, w / max(h, w)), rng.uniform(0, h / max(h, w))
        r = scale * rng.uniform(0.03, 0.18)
        shape = rng.integers(5)
        if shape == 0:
            mask = (xs - cx) ** 2 + (ys - cy) ** 2 < r**2
        elif shape == 1:
            mask = (np.abs(xs - cx) < r) & (np.abs(ys - cy) < r * rng.uniform(0.3, 1.5))
        elif shape == 2:
            a = rng.uniform(0, math.pi)
            along = (xs - cx) * math.cos(a) + (ys - cy) * math.sin(a)
            across = -(xs - cx) * math.sin(a) + (ys - cy) * math.cos(a)
            mask = (np.abs(along) < 1.5 * r) & (np.abs(across) < r * rng.uniform(0.1, 0.4))
        elif shape == 3:
            d2 = (xs - cx) ** 2 + (ys - cy) ** 2
            mask = (d2 < r**2) & (d2 > (r * rng.uniform(0.4, 0.8)) ** 2)
        else:
            pts = np.array([cx, cy]) + rng.uniform(-1.5 * r, 1.5 * r, size=(3, 2))
            signs = []
            for k in range(3):
                (x0, y0), (x1, y1) = pts[k], pts[(k + 1) % 3]
                signs.append((x1 - x0) * (ys - y0) - (y1 - y0) * (xs - x0) > 0)
            mask = (signs[0] == signs[1]) & (signs[1] == signs[2])
        img[mask] = colour


def _poster(rng: np.random.Generator, h: int, w: int) -> np.ndarray:
    img = np.empty((h, w, 3))
    img[:] = _saturated_colour(rng) * 0.5 + 100
    img += (_value_noise(rng, h, w, 6)[..., None] - 0.5) * 120
    _random_shapes(rng, img, 70, 1.0)
    _random_shapes(rng, img, 40, 0.35)
    border = max(2, min(h, w) // 40)
    img[:border], img[-border:], img[:, :border], img[:, -border:] = 245, 245, 245, 245
    return img


def _cardboard(rng: np.random.Generator, h: int, w: int) -> np.ndarray:
    base = np.array([176.0, 134.0, 88.0]) * rng.uniform(0.85, 1.1)
    noise = _value_noise(rng, h, w, 10) - 0.5 + 0.3 * (rng.random((h, w)) - 0.5)
    img = base + noise[..., None] * 40
    ys = _grid(h, w)[0]
    tape = np.abs(ys - rng.uniform(0.3, 0.7)) < 0.05
    img[np.broadcast_to(tape, (h, w))] = np.array([200.0, 170.0, 120.0])
    for _ in range(int(rng.integers(2, 5))):  # printed labels: ink shapes on white patches
        lw, lh = int(w * rng.uniform(0.2, 0.4)), int(h * rng.uniform(0.15, 0.3))
        x0, y0 = int(rng.integers(0, w - lw)), int(rng.integers(0, h - lh))
        label = np.full((lh, lw, 3), 235.0)
        _random_shapes(rng, label, 25, 0.6)
        stripes = rng.random(lw) < 0.4  # a barcode
        label[int(lh * 0.75):, stripes] = 20.0
        img[y0:y0 + lh, x0:x0 + lw] = label
    return img


def _wood(rng: np.random.Generator, h: int, w: int) -> np.ndarray:
    ys, xs = _grid(h, w)
    warp = _value_noise(rng, h, w, 8) * 0.15
    grain = np.sin(2 * math.pi * (xs * rng.uniform(14, 22) + warp * 12 + 0.5 * ys))
    base = np.array([150.0, 96.0, 52.0]) * rng.uniform(0.8, 1.15)
    img = base * (1.0 + 0.12 * grain[..., None])
    handle = (np.abs(xs - 0.88) < 0.03) & (np.abs(ys - 0.5) < 0.012)
    img[np.broadcast_to(handle, (h, w))] = [200, 200, 205]
    panel = (np.abs(np.abs(xs - 0.5) - 0.32) < 0.01) | (np.abs(np.abs(ys - 0.5) - 0.42) < 0.005)
    img[np.broadcast_to(panel, (h, w))] *= 0.6
    return img


def _tiles(rng: np.random.Generator, h: int, w: int, n: int, grout: float) -> np.ndarray:
    ys, xs = _grid(h, w)
    ty, tx = np.floor(ys * n).astype(int), np.floor(xs * n).astype(int)
    shade = rng.uniform(0.9, 1.05, size=(n, n))[ty, tx]
    img = np.array([205.0, 200.0, 190.0]) * shade[..., None]
    img += (rng.random((h, w, 1)) - 0.5) * 14
    line = (np.abs(ys * n - np.round(ys * n)) < grout) | (np.abs(xs * n - np.round(xs * n)) < grout)
    img[line] *= 0.55
    return img


def generate_texture(spec: TextureSpec) -> np.ndarray:
    """The texels of ``spec``: (height, width, 3) uint8, identical for identical specs."""
    rng = np.random.default_rng(spec.seed)
    w, h = spec.size_px
    kind = spec.kind
    if kind is TextureKind.POSTER:
        img = _poster(rng, h, w)
    elif kind is TextureKind.CARDBOARD:
        img = _cardboard(rng, h, w)
    elif kind is TextureKind.WOOD:
        img = _wood(rng, h, w)
    elif kind is TextureKind.FRAME:
        img = np.array([70.0, 55.0, 45.0]) + (rng.random((h, w, 1)) - 0.5) * 6
    elif kind is TextureKind.TILES:
        img = _tiles(rng, h, w, 4, 0.04)
    elif kind is TextureKind.CEILING:
        img = _tiles(rng, h, w, 2, 0.015) * 1.12
    elif kind is TextureKind.LIGHT:
        ys, xs = _grid(h, w)
        edge = (np.minimum(np.minimum(xs, 1 - xs), np.minimum(ys, 1 - ys)) < 0.05)
        img = np.where(edge[..., None], 150.0, 250.0) * np.ones(3)
    elif kind is TextureKind.PAINT:
        tint = np.array([225.0, 222.0, 210.0]) * rng.uniform(0.9, 1.0)
        img = tint * (1.0 + 0.04 * (_value_noise(rng, h, w, 4)[..., None] - 0.5))
    elif kind is TextureKind.PLAIN:
        img = np.full((h, w, 3), 190.0) + (rng.random((h, w, 1)) - 0.5) * 2
    elif kind is TextureKind.STRIPES:
        ys = _grid(h, w)[0]
        band = (np.floor(ys * spec.extent_m[1] / 0.25) % 2).astype(bool)
        colour = _saturated_colour(rng)
        img = np.where(band[..., None], colour, 235.0) * np.ones((1, w, 3))
    else:  # pragma: no cover - exhaustive enum
        raise DataError(f"unknown texture kind {kind}")
    return np.clip(np.round(img), 0, 255).astype(np.uint8)


# --- lookup -------------------------------------------------------------------------------
class TextureAtlas:
    """All textures of a world (with mip levels) packed into one flat texel array.

    ``sample(textures, u_m, v_m, footprint_m)`` does a bilinear lookup at the mip level whose
    texel matches the pixel's footprint on the surface (box-filtered pyramid, nearest level),
    which keeps distant posters from aliasing into salt-and-pepper noise.
    """

    def __init__(self, specs: tuple[TextureSpec, ...] | list[TextureSpec]) -> None:
        texels: list[np.ndarray] = []
        offsets, widths, heights = [], [], []
        first_level, n_levels, repeat, extent_u, extent_v, texel0 = [], [], [], [], [], []
        total = 0
        for spec in specs:
            level = generate_texture(spec).astype(np.float32)
            first_level.append(len(offsets))
            count = 0
            while True:
                h, w = level.shape[:2]
                texels.append(level.reshape(-1, 3))
                offsets.append(total)
                widths.append(w)
                heights.append(h)
                total += h * w
                count += 1
                if h % 2 or w % 2 or min(h, w) < _MIN_SIZE_PX:
                    break
                level = 0.25 * (level[0::2, 0::2] + level[1::2, 0::2] + level[0::2, 1::2]
                                + level[1::2, 1::2])
            n_levels.append(count)
            repeat.append(spec.kind.repeats)
            extent_u.append(spec.extent_m[0])
            extent_v.append(spec.extent_m[1])
            texel0.append(spec.texel_m())
        self.texels = np.concatenate(texels) if texels else np.zeros((0, 3), np.float32)
        self._offset = np.array(offsets, dtype=np.int64)
        self._width = np.array(widths, dtype=np.int64)
        self._height = np.array(heights, dtype=np.int64)
        self._first_level = np.array(first_level, dtype=np.int64)
        self._n_levels = np.array(n_levels, dtype=np.int64)
        self._repeat = np.array(repeat, dtype=bool)
        self._extent_u = np.array(extent_u)
        self._extent_v = np.array(extent_v)
        self._texel_m = np.array(texel0)

    def sample(
        self,
        textures: np.ndarray,
        u_m: np.ndarray,
        v_m: np.ndarray,
        footprint_m: np.ndarray | None = None,
    ) -> np.ndarray:
        """Bilinear colour lookup.

        Args:
            textures: (N,) texture indices.
            u_m, v_m: (N,) texture coordinates [m].
            footprint_m: (N,) size of the pixel on the surface [m] (selects the mip level);
                None samples the full-resolution level.

        Returns:
            (N, 3) float32 RGB in [0, 255].
        """
        textures = np.asarray(textures, dtype=np.int64)
        if footprint_m is None:
            level = np.zeros_like(textures)
        else:
            ratio = np.maximum(footprint_m / self._texel_m[textures], 1.0)
            level = np.minimum(np.round(np.log2(ratio)).astype(np.int64),
                               self._n_levels[textures] - 1)
        entry = self._first_level[textures] + level
        w, h = self._width[entry], self._height[entry]
        fx = u_m / self._extent_u[textures] * w - 0.5
        fy = v_m / self._extent_v[textures] * h - 0.5
        x0f, y0f = np.floor(fx), np.floor(fy)
        ax = (fx - x0f).astype(np.float32)[:, None]
        ay = (fy - y0f).astype(np.float32)[:, None]
        x0, y0 = x0f.astype(np.int64), y0f.astype(np.int64)
        rep = self._repeat[textures]
        x1, y1 = x0 + 1, y0 + 1
        x0 = np.where(rep, x0 % w, np.clip(x0, 0, w - 1))
        x1 = np.where(rep, x1 % w, np.clip(x1, 0, w - 1))
        y0 = np.where(rep, y0 % h, np.clip(y0, 0, h - 1))
        y1 = np.where(rep, y1 % h, np.clip(y1, 0, h - 1))
        base = self._offset[entry]
        t = self.texels
        top = t[base + y0 * w + x0] * (1 - ax) + t[base + y0 * w + x1] * ax
        bottom = t[base + y1 * w + x0] * (1 - ax) + t[base + y1 * w + x1] * ax
        return top * (1 - ay) + bottom * ay
