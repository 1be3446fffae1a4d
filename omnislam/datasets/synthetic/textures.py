"""Procedural textures made with numpy, and their bilinear, mip-mapped lookup.

A texture is described by a small ``TextureSpec`` (kind, seed, size, metres covered); the pixels
are regenerated from it deterministically, so ``world.json`` stays small and byte-stable.
Posters and box labels are dense random high-contrast patterns (distinctive SIFT keypoints);
walls, floor tiles and ceiling panels are smooth or periodic (few or repeated keypoints), as in
real corridors; ``PLAIN`` is nearly textureless (the thesis's "corridor with no landmarks").
``PHOTO`` textures are real photographs instead (``photos``: scikit-image's sample images).

Texture coordinates: ``u`` (columns) and ``v`` (rows) in metres from the quad's origin corner;
texel (0, 0) is centred at (0.5, 0.5) texels.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

import numpy as np

from omnislam.datasets.synthetic.photos import PHOTO_SOURCES, photo_texels
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
    PHOTO = "photo"  # a photograph (``TextureSpec.image``)
    CLOTH = "cloth"  # a walking person's clothes: shirt over trousers (``walkers``)

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
    TextureKind.PHOTO: 320.0,
    TextureKind.CLOTH: 64.0,
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
        image: the photograph of a ``PHOTO`` texture (a ``photos.PHOTO_SOURCES`` key); None
            for the procedural kinds.
    """

    kind: TextureKind
    seed: int
    size_px: tuple[int, int]
    extent_m: tuple[float, float]
    image: str | None = None

    def __post_init__(self) -> None:
        if (self.kind is TextureKind.PHOTO) != (self.image is not None):
            raise DataError(f"a texture has an image if and only if it is a photo: {self}")
        if self.image is not None and self.image not in PHOTO_SOURCES:
            raise DataError(f"texture of an unknown photograph {self.image!r}")

    @classmethod
    def make(
        cls,
        kind: TextureKind,
        seed: int,
        extent_m: tuple[float, float],
        size_px: tuple[int, int] | None = None,
        image: str | None = None,
    ) -> TextureSpec:
        """A spec with the kind's default texel density, sizes rounded to multiples of 8."""
        if size_px is None:
            density = _DENSITY_PX_PER_M[kind]

            def side(metres: float) -> int:
                px = round(metres * density / 8.0) * 8
                return min(_MAX_SIZE_PX, max(_MIN_SIZE_PX, px))

            size_px = (side(extent_m[0]), side(extent_m[1]))
        return cls(kind, int(seed), (int(size_px[0]), int(size_px[1])),
                   (float(extent_m[0]), float(extent_m[1])), image)

    def to_dict(self) -> dict[str, object]:
        """Plain-Python form (``image`` only for photos: other worlds' JSON is unchanged)."""
        doc: dict[str, object] = {"kind": self.kind.value, "seed": self.seed,
                                  "size_px": list(self.size_px), "extent_m": list(self.extent_m)}
        if self.image is not None:
            doc["image"] = self.image
        return doc

    @classmethod
    def from_dict(cls, doc: dict[str, object]) -> TextureSpec:
        size = doc["size_px"]
        extent = doc["extent_m"]
        return cls(TextureKind(doc["kind"]), int(doc["seed"]),  # type: ignore[call-overload]
                   (int(size[0]), int(size[1])),  # type: ignore[index]
                   (float(extent[0]), float(extent[1])),  # type: ignore[index]
                   None if doc.get("image") is None else str(doc["image"]))

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


def _cloth(rng: np.random.Generator, h: int, w: int) -> np.ndarray:
    """A person seen as a cylinder: hair, a face band, a shirt (plain or striped) and
    trousers, with a woven grain (rows run down from the head)."""
    ys, xs = _grid(h, w)
    shirt, trousers = _saturated_colour(rng) * 0.8, np.array([50.0, 55.0, 80.0]) * rng.uniform(
        0.6, 1.4)
    img = np.where((ys < 0.48)[..., None], shirt, trousers) * np.ones((1, w, 3))
    if rng.random() < 0.5:  # stripes across the shirt
        band = (np.floor(ys * rng.uniform(20, 40)) % 2).astype(bool) & (ys < 0.48)
        img[np.broadcast_to(band, (h, w))] *= 0.6
    skin = np.array([224.0, 172.0, 140.0]) * rng.uniform(0.5, 1.05)
    head = np.broadcast_to(ys < 0.13, (h, w))
    img[head] = skin
    img[np.broadcast_to((ys < 0.05) | ((ys < 0.13) & (np.abs(xs - 0.75) < 0.2)), (h, w))] = (
        np.array([40.0, 30.0, 25.0]) * rng.uniform(0.5, 2.5))  # hair, the back of the head
    img *= 1.0 + 0.08 * (rng.random((h, w, 1)) - 0.5)
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
    elif kind is TextureKind.PHOTO:
        assert spec.image is not None  # checked by TextureSpec
        img = photo_texels(spec.image, (w, h))
    elif kind is TextureKind.CLOTH:
        img = _cloth(rng, h, w)
    elif kind is TextureKind.STRIPES:
        ys = _grid(h, w)[0]
        band = (np.floor(ys * spec.extent_m[1] / 0.25) % 2).astype(bool)
        colour = _saturated_colour(rng)
        img = np.where(band[..., None], colour, 235.0) * np.ones((1, w, 3))
    else:  # pragma: no cover - exhaustive enum
        raise DataError(f"unknown texture kind {kind}")
    return np.clip(np.round(img), 0, 255).astype(np.uint8)


# --- lookup -------------------------------------------------------------------------------
#: columns of ``TextureAtlas.table``
TEX_WIDTH, TEX_HEIGHT, TEX_INV_TEXEL, TEX_MAX_LEVEL, TEX_REPEAT, TEX_LEVEL_ROW = range(6)
#: texels are stored as uint16 value * TEXEL_SCALE
TEXEL_SCALE = 256
#: a bound that never clips (used to switch clamping off for repeating textures)
_NO_CLAMP = np.float32(1e30)


class Workspace:
    """Named work arrays kept from call to call.

    A renderer's per-ray temporaries are tens of MB a frame; fresh arrays that large come
    from the kernel as new pages, and zeroing them cost ~14 ms a frame (20%). An array taken
    from a workspace is overwritten by the next ``get`` of the same name.
    """

    def __init__(self) -> None:
        self._arrays: dict[str, np.ndarray] = {}

    def get(self, name: str, shape: tuple[int, ...], dtype: type) -> np.ndarray:
        """The (uninitialised) array ``name`` of ``shape`` and ``dtype``."""
        array = self._arrays.get(name)
        if array is None or array.shape != shape or array.dtype != dtype:
            array = self._arrays[name] = np.empty(shape, dtype=dtype)
        return array


def _pad(level: np.ndarray, repeat: bool) -> np.ndarray:
    """(h+1, w+1) copy of ``level`` whose extra row / column wraps (repeat) or clamps."""
    h, w = level.shape[:2]
    out = np.empty((h + 1, w + 1, *level.shape[2:]), dtype=level.dtype)
    out[:h, :w] = level
    out[:h, w] = level[:, 0] if repeat else level[:, w - 1]
    out[h] = out[0] if repeat else out[h - 1]
    return out


class TextureAtlas:
    """All textures of a world (with mip levels) packed into one flat texel array.

    ``sample(textures, u_m, v_m, footprint_m)`` does a bilinear lookup at the mip level whose
    texel matches the pixel's footprint on the surface (box-filtered pyramid, nearest level),
    which keeps distant posters from aliasing into salt-and-pepper noise.

    Storage: each mip level gets one extra column and row (a copy of the first ones for
    repeating textures, of the last ones otherwise), so the right and lower neighbours of any
    texel exist and wrapping / clamping is done once, on the coordinate. A texel is one
    uint64: RGBA as uint16 fixed point (value * ``TEXEL_SCALE``), which holds the box-filtered
    mip levels exactly down to level 4 (uint8 would round them and change ~10% of the
    pixels), so a bilinear lookup is four one-element gathers.

    Attributes:
        table: (T, 6) float32 per texture: level-0 width and height [texels], 1 / texel size
            [1/m], highest mip level, repeat flag (0 / 1), first row of ``level_offsets``.
        level_offsets: (T * L,) int64 start of each (texture, level) in ``texels`` (row
            ``TEX_LEVEL_ROW + level``); L = ``levels_max``.
        texels: (K,) uint64 packed RGBA texels of all padded levels.
    """

    def __init__(self, specs: tuple[TextureSpec, ...] | list[TextureSpec]) -> None:
        chunks: list[np.ndarray] = []
        rows: list[tuple[float, ...]] = []
        offsets: list[list[int]] = []
        self._extent_m = np.array([s.extent_m for s in specs], dtype=float).reshape(-1, 2)
        total = 0
        for spec in specs:
            level = generate_texture(spec).astype(np.float32)
            starts = []
            while True:
                h, w = level.shape[:2]
                rgba = np.zeros((h, w, 4), dtype=np.uint16)
                rgba[..., :3] = np.rint(level * TEXEL_SCALE)
                padded = _pad(rgba.view(np.uint64)[..., 0], spec.kind.repeats)
                chunks.append(padded.reshape(-1))
                starts.append(total)
                total += padded.size
                if h % 2 or w % 2 or min(h, w) < _MIN_SIZE_PX:
                    break
                level = 0.25 * (level[0::2, 0::2] + level[1::2, 0::2] + level[0::2, 1::2]
                                + level[1::2, 1::2])
            offsets.append(starts)
            w0, h0 = spec.size_px
            rows.append((w0, h0, 1.0 / spec.texel_m(), len(starts) - 1,
                         float(spec.kind.repeats), 0.0))
        self.levels_max = max((len(o) for o in offsets), default=1)
        self.level_offsets = np.zeros(len(offsets) * self.levels_max, dtype=np.int64)
        for t, starts in enumerate(offsets):
            self.level_offsets[t * self.levels_max:t * self.levels_max + len(starts)] = starts
        self.table = np.array(rows, dtype=np.float32).reshape(-1, 6)
        self.table[:, TEX_LEVEL_ROW] = np.arange(len(rows)) * self.levels_max
        self.texels = np.concatenate(chunks) if chunks else np.zeros(1, np.uint64)

    def level_of(self, texture: np.ndarray, footprint_m: np.ndarray) -> np.ndarray:
        """(N,) float32 mip level (integer valued): the nearest to log2(footprint / texel),
        clipped to the texture's pyramid.

        Args:
            texture: (6, N) float32 ``table`` columns of the textures seen.
            footprint_m: (N,) float32 size of the pixels on the surfaces [m] (overwritten).
        """
        ratio = np.multiply(footprint_m, texture[TEX_INV_TEXEL], out=footprint_m)
        np.maximum(ratio, 1.0, out=ratio)
        level = np.log2(ratio, out=ratio)
        np.rint(level, out=level)
        return np.minimum(level, texture[TEX_MAX_LEVEL], out=level)

    def bilinear(
        self,
        texture: np.ndarray,
        texel0: np.ndarray,
        level: np.ndarray,
        work: Workspace | None = None,
    ) -> np.ndarray:
        """Bilinear lookup in mip level ``level`` at level-0 texel coordinates.

        Args:
            texture: (6, N) float32 ``table`` columns of the textures.
            texel0: (2, N) float32 (x, y) position in level-0 texels (texel (0, 0) spans
                [0, 1) x [0, 1)); overwritten.
            level: (N,) float32 integer-valued mip level (``level_of``); overwritten.
            work: arrays to reuse (the result is then one of them); None allocates.

        Returns:
            (3, N) float32 RGB channels in [0, 255].
        """
        work = Workspace() if work is None else work
        n = texel0.shape[1]
        scale = np.negative(level, out=work.get("tex.scale", (n,), np.float32))
        np.exp2(scale, out=scale)
        size = np.multiply(texture[TEX_WIDTH:TEX_HEIGHT + 1], scale,  # (2, N) level size
                           out=work.get("tex.size", (2, n), np.float32))
        f = np.multiply(texel0, scale, out=texel0)
        f -= 0.5
        # clamp to the outer texel centres, except for repeating textures (infinite bounds)
        low = np.multiply(texture[TEX_REPEAT], -_NO_CLAMP, out=scale)
        np.maximum(f, low, out=f)
        high = np.subtract(size, 1.0, out=work.get("tex.high", (2, n), np.float32))
        high -= low
        np.minimum(f, high, out=f)
        first = np.floor(f, out=work.get("tex.first", (2, n), np.float32))
        weight = np.subtract(f, first, out=f)
        wraps = np.divide(first, size, out=high)
        np.floor(wraps, out=wraps)
        wraps *= size
        first -= wraps  # wrap into [0, size) (identity once clamped)
        corner = work.get("tex.corner", (2, n), np.int64)
        corner[...] = first
        stride = work.get("tex.stride", (n,), np.int64)
        stride[...] = size[0]
        stride += 1
        row = work.get("tex.row", (n,), np.int64)
        row[...] = np.add(texture[TEX_LEVEL_ROW], level, out=level)
        index = np.take(self.level_offsets, row, out=work.get("tex.index", (n,), np.int64))
        corner[1] *= stride
        index += corner[1]
        index += corner[0]
        texels = work.get("tex.texels", (4, n), np.uint64)
        for corner_texels, step in zip(texels, (0, 1, None, 1), strict=True):
            if step is None:  # next row, left
                index += stride
                index -= 1
            else:
                index += step
            np.take(self.texels, index, out=corner_texels)
        channels = work.get("tex.channels", (4, 3, n), np.float32)
        channels[:] = texels.view(np.uint16).reshape(4, n, 4)[..., :3].transpose(0, 2, 1)
        top, top_right, bottom, bottom_right = channels
        ax, ay = weight
        top_right -= top
        top_right *= ax
        top += top_right
        bottom_right -= bottom
        bottom_right *= ax
        bottom += bottom_right
        bottom -= top
        bottom *= ay
        top += bottom
        top *= np.float32(1.0 / TEXEL_SCALE)
        return top

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
            u_m: (N,) texture coordinate along u [m].
            v_m: (N,) texture coordinate along v [m].
            footprint_m: (N,) size of the pixel on the surface [m] (selects the mip level);
                None samples the full-resolution level.

        Returns:
            (N, 3) float32 RGB in [0, 255].
        """
        textures = np.asarray(textures, dtype=np.int64)
        texture = np.ascontiguousarray(self.table[textures].T)
        if footprint_m is None:
            level = np.zeros(textures.shape, dtype=np.float32)
        else:
            level = self.level_of(texture, np.array(footprint_m, dtype=np.float32))
        extent = self._extent_m[textures]
        texel0 = np.array([u_m / extent[:, 0] * texture[TEX_WIDTH],
                           v_m / extent[:, 1] * texture[TEX_HEIGHT]], dtype=np.float32)
        return np.ascontiguousarray(self.bilinear(texture, texel0, level).T)
