"""SIFT keypoint detection on a first octave at the image's own resolution (thesis 4.1.1-4.1.2).

Lowe (2004, sec. 3.3) doubles the image before building the first octave so that the DoG is
sampled finely enough at its smallest scales; the thesis keeps this optional ("durante a
construção da primeira oitava pode-se ainda dobrar as dimensões da imagem", sec. 4.1.1).
OpenCV always doubles, which puts ~3/4 of its work into the doubled octave: 70-85 ms of CPU per
640 x 640 omni image here, ~90 % of it detection. Sampling the *same* scales (sigma / 2 ..
sigma, i.e. 0.8 .. 1.6 px) at the image's own pixels keeps the fine keypoints, which make the
best-localised landmarks, on a quarter of the pixels; dropping them (Lowe's octave 0 first)
loses most tracks (docs/results/frontend.md, what was tried).

The detector follows Lowe and OpenCV's ``SIFT`` step for step, vectorised over candidates:

1. Gaussian pyramid: octaves of ``N + 3`` images, ``k = 2^(1/N)``; each octave's base is the
   ``N``-th image of the previous one sampled at every second pixel (thesis 4.1.1).
2. DoG extrema against the 26 neighbours in space and scale, above half the contrast threshold.
3. Sub-pixel and sub-scale refinement by the Taylor expansion of D (thesis eqs. 4.6-4.8), at
   most 5 Newton steps; rejection of low contrast |D(x^)| < C (eq. 4.9) and of edges by the
   principal-curvature ratio tr(H)^2 / det(H) >= (R + 1)^2 / R (eqs. 4.10-4.15).
4. Orientation: 36-bin histogram of gradient directions in a window of radius 4.5 sigma,
   Gaussian-weighted with 1.5 sigma, smoothed; every peak >= 80 % of the highest makes a
   keypoint (parabolic interpolation of the peak).

Detections convert to ``cv2.KeyPoint`` with OpenCV's octave packing (octave, layer, sub-scale),
so that OpenCV's own descriptor (``SIFT.compute``, which then builds its pyramid without
doubling) describes them (``sift.SiftExtractor``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from omnislam._optional import require

#: keypoints closer than this to an octave's border are not detected (OpenCV's SIFT_IMG_BORDER)
IMAGE_BORDER = 5
#: Newton steps of the sub-pixel refinement before a candidate is given up
MAX_INTERP_STEPS = 5
#: blur assumed in the input image [px] (Lowe 2004 sec. 3.3)
INPUT_SIGMA = 0.5
#: orientation histogram: bins, window radius and Gaussian weight in units of the scale
ORI_BINS = 36
ORI_RADIUS = 4.5
ORI_SIGMA = 1.5
#: secondary orientation peaks at least this fraction of the highest make keypoints
ORI_PEAK_RATIO = 0.8


@dataclass(frozen=True, slots=True)
class Octave:
    """One octave of the Gaussian and DoG pyramids (``[0, 1]`` grey levels).

    Attributes:
        gaussian: (S + 3, H_o, W_o) float32 blurred images, blur ``sigma_px * k^i``.
        dog: (S + 2, H_o, W_o) float32 differences of consecutive ones; extrema are sought
            in layers 1..S.
        step_px: the octave's pixel spacing in image pixels (1, 2, 4...).
        sigma_px: blur of its base image in its own pixels.
        index: Lowe's octave number of its base (-1: the scales of the doubled first octave).
    """

    gaussian: np.ndarray
    dog: np.ndarray
    step_px: int
    sigma_px: float
    index: int

    @property
    def extrema_layers(self) -> int:
        return int(self.dog.shape[0] - 2)


def n_octaves(height: int, width: int) -> int:
    """OpenCV's octave count for a first octave at the image's own size."""
    return max(1, round(math.log2(min(height, width)) - 2))


def _octave(base: np.ndarray, sigma: float, layers: int, span: int, step_px: int, index: int
            ) -> Octave:
    """``span + 3`` Gaussian images from a base of blur ``sigma`` (k = 2^(1/layers)) and
    their differences."""
    cv2 = require("cv2")
    k = 2.0 ** (1.0 / layers)
    gaussian = np.empty((span + 3, *base.shape), dtype=np.float32)
    gaussian[0] = base
    for i in range(1, span + 3):
        # sigma_total(i)^2 = sigma_total(i - 1)^2 + step^2
        step = sigma * k ** (i - 1) * math.sqrt(k * k - 1.0)
        cv2.GaussianBlur(gaussian[i - 1], (0, 0), step, dst=gaussian[i], sigmaY=step)
    dog = np.empty((span + 2, *base.shape), dtype=np.float32)
    np.subtract(gaussian[1:], gaussian[:-1], out=dog)
    return Octave(gaussian, dog, step_px, sigma, index)


def build_scale_space(grey: np.ndarray, sigma: float, layers: int, *, fine: bool,
                      halved: bool = False) -> tuple[Octave, ...]:
    """Lowe's Gaussian/DoG pyramid with the doubled first octave replaced (thesis 4.1.1).

    Without ``fine`` these are Lowe's octaves 0, 1, ... (OpenCV's, VLFeat's first_octave 0):
    base blur ``sigma`` on the image, each next base the N-th image of the previous octave at
    every second pixel. With ``fine`` the scales ``sigma / 2 .. sigma`` of Lowe's doubled
    octave -1 are sampled at the image's own pixels: octaves -1 and 0 become one octave of
    2N + 3 images at the image's resolution (blur ``sigma / 2 * k^i``; its images N..2N + 2
    are octave 0's), and octave 1 starts from its image 2N. With ``halved`` too, octave -1 keeps
    its own N + 3 images at the image's resolution and octaves 0, 1... follow at 2, 4...
    pixels, each from the previous one's image N (blur ``sigma / 2`` in its own pixels, half
    Lowe's sampling density: the pyramid of a SIFT of sigma / 2 on the undoubled image).

    Args:
        grey: (H, W) uint8 grey image.
        sigma: Lowe's sigma (1.6): the base blur of octave 0 [px].
        layers: N, scales per octave (k = 2^(1/N)).
        fine: sample octave -1 at the image's resolution.
        halved: with ``fine``, sample octave 0 on at half the previous octave's pixels.
    """
    cv2 = require("cv2")
    image = grey.astype(np.float32) * np.float32(1.0 / 255.0)
    first = sigma / 2 if fine else sigma
    blur = math.sqrt(max(first**2 - INPUT_SIGMA**2, 0.01))
    base = cv2.GaussianBlur(image, (0, 0), blur, sigmaY=blur)
    halved = fine and halved
    octaves = [_octave(base, first, layers, 2 * layers if fine and not halved else layers, 1,
                       -1 if fine else 0)]
    # halved: octaves 0, 1... follow at 2, 4... pixels, each with base blur sigma / 2 in its
    # own pixels (Lowe's sigma at the previous octave's spacing)
    sigma_o = first if halved else sigma
    for o in range(1, n_octaves(*grey.shape) + int(halved)):
        previous = octaves[-1].gaussian[-3]  # blur 2 sigma in the previous octave's pixels
        # every second pixel, floor(W / 2) of them (OpenCV's INTER_NEAREST halving)
        base = previous[::2, ::2][: previous.shape[0] // 2, : previous.shape[1] // 2]
        if min(base.shape) <= 2 * IMAGE_BORDER + 2:
            break
        octaves.append(_octave(np.ascontiguousarray(base), sigma_o, layers, layers, 1 << o,
                               o - int(halved)))
    return tuple(octaves)


def _kernels() -> Any:
    """The compiled ``kernels`` (``kernels_compiled``) when numba is installed or they were
    compiled ahead of time (and ``use_kernels`` allows), else None: the numpy and OpenCV path
    below, their reference."""
    if not _USE_KERNELS:
        return None
    from omnislam.frontend import kernels_compiled

    return kernels_compiled.COMPILED


#: the compiled kernels are used when available (``use_kernels``)
_USE_KERNELS = True


def use_kernels(enabled: bool) -> bool:
    """Use the compiled kernels when numba is installed (the default) or never (the reference
    path, for tests and benchmarks); returns the previous setting."""
    global _USE_KERNELS
    previous, _USE_KERNELS = _USE_KERNELS, bool(enabled)
    return previous


#: offsets (scale, row, col) of a 3 x 3 x 3 neighbourhood, index 13 is the centre
_CUBE = np.stack(np.meshgrid([-1, 0, 1], [-1, 0, 1], [-1, 0, 1], indexing="ij"), -1).reshape(-1, 3)
#: the 18 neighbours in the layers above and below
_ADJACENT = _CUBE[_CUBE[:, 0] != 0]


def _candidates(dog: np.ndarray, span: int, threshold: float, mask: np.ndarray | None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(layers, rows, cols) of the DoG extrema over their 26 neighbours with |D| > threshold.

    The 8 neighbours in the same layer are tested on the whole image (a 3 x 3 dilation or
    erosion), the 18 in the layers above and below only at the few pixels that pass.

    Args:
        dog: (S + 2, H, W) one octave's DoG stack; extrema are sought in layers 1..S.
        span: S.
        threshold: minimum |D|.
        mask: (H, W) uint8, non-zero where to detect (None: everywhere).
    """
    cv2 = require("cv2")
    kernel = np.ones((3, 3), np.uint8)
    _, height, width = dog.shape
    b = IMAGE_BORDER
    inner = np.zeros((height, width), dtype=np.uint8)
    inner[b:-b, b:-b] = 255
    if mask is not None:
        inner = cv2.bitwise_and(inner, mask)
    compiled = _kernels()
    if compiled is not None:  # the same candidates in the same order, one pass (``kernels``)
        found = compiled.extrema(dog, span, np.float32(threshold), inner)
        return found[:, 0].copy(), found[:, 1].copy(), found[:, 2].copy()
    found_s, found_r, found_c = [], [], []
    flat = dog.reshape(-1)
    strides = np.array([height * width, width, 1])
    for layer in range(1, span + 1):
        centre = dog[layer]
        peak = cv2.bitwise_and(cv2.compare(centre, threshold, cv2.CMP_GT),
                               cv2.compare(centre, cv2.dilate(centre, kernel), cv2.CMP_GE))
        pit = cv2.bitwise_and(cv2.compare(centre, -threshold, cv2.CMP_LT),
                              cv2.compare(centre, cv2.erode(centre, kernel), cv2.CMP_LE))
        points = cv2.findNonZero(cv2.bitwise_and(cv2.bitwise_or(peak, pit), inner))
        if points is None:
            continue
        points = points.reshape(-1, 2).astype(np.int64)  # (x, y)
        c, r = points[:, 0], points[:, 1]
        v = centre[r, c]
        index = (layer * strides[0] + r * strides[1] + c)[:, None] + _ADJACENT @ strides
        others = flat[index]
        keep = np.where(v > 0, v >= others.max(axis=1), v <= others.min(axis=1))
        found_s.append(np.full(int(keep.sum()), layer, dtype=np.int64))
        found_r.append(r[keep])
        found_c.append(c[keep])
    if not found_s:
        empty = np.zeros(0, dtype=np.int64)
        return empty, empty, empty
    return np.concatenate(found_s), np.concatenate(found_r), np.concatenate(found_c)


def _derivatives(dog: np.ndarray, s: np.ndarray, r: np.ndarray, c: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """D, its gradient (M, 3) and Hessian (M, 3, 3) in (x, y, scale) by central differences."""
    _, height, width = dog.shape
    strides = np.array([height * width, width, 1])
    flat = (s * strides[0] + r * strides[1] + c)[:, None] + _CUBE @ strides
    n = dog.reshape(-1)[flat].astype(np.float64).reshape(-1, 3, 3, 3)  # [scale, row, col]
    v = n[:, 1, 1, 1]
    dx = 0.5 * (n[:, 1, 1, 2] - n[:, 1, 1, 0])
    dy = 0.5 * (n[:, 1, 2, 1] - n[:, 1, 0, 1])
    ds = 0.5 * (n[:, 2, 1, 1] - n[:, 0, 1, 1])
    dxx = n[:, 1, 1, 2] + n[:, 1, 1, 0] - 2 * v
    dyy = n[:, 1, 2, 1] + n[:, 1, 0, 1] - 2 * v
    dss = n[:, 2, 1, 1] + n[:, 0, 1, 1] - 2 * v
    dxy = 0.25 * (n[:, 1, 2, 2] - n[:, 1, 2, 0] - n[:, 1, 0, 2] + n[:, 1, 0, 0])
    dxs = 0.25 * (n[:, 2, 1, 2] - n[:, 2, 1, 0] - n[:, 0, 1, 2] + n[:, 0, 1, 0])
    dys = 0.25 * (n[:, 2, 2, 1] - n[:, 2, 0, 1] - n[:, 0, 2, 1] + n[:, 0, 0, 1])
    gradient = np.stack([dx, dy, ds], axis=1)
    hessian = np.stack([dxx, dxy, dxs, dxy, dyy, dys, dxs, dys, dss], axis=1).reshape(-1, 3, 3)
    return v, gradient, hessian


def _solve3(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Solve (M, 3, 3) symmetric systems ``a x = b`` by the adjugate; (x, solvable)."""
    c00 = a[:, 1, 1] * a[:, 2, 2] - a[:, 1, 2] * a[:, 2, 1]
    c01 = a[:, 1, 2] * a[:, 2, 0] - a[:, 1, 0] * a[:, 2, 2]
    c02 = a[:, 1, 0] * a[:, 2, 1] - a[:, 1, 1] * a[:, 2, 0]
    c11 = a[:, 0, 0] * a[:, 2, 2] - a[:, 0, 2] * a[:, 2, 0]
    c12 = a[:, 0, 1] * a[:, 2, 0] - a[:, 0, 0] * a[:, 2, 1]
    c22 = a[:, 0, 0] * a[:, 1, 1] - a[:, 0, 1] * a[:, 1, 0]
    det = a[:, 0, 0] * c00 + a[:, 0, 1] * c01 + a[:, 0, 2] * c02
    solvable = np.abs(det) > 1e-30
    inverse_det = np.where(solvable, 1.0 / np.where(solvable, det, 1.0), 0.0)
    adjugate = np.stack([c00, c01, c02, c01, c11, c12, c02, c12, c22], axis=1).reshape(-1, 3, 3)
    x = np.einsum("mij,mj->mi", adjugate, b) * inverse_det[:, None]
    return x, solvable


@dataclass(frozen=True, slots=True)
class _Refined:
    layer: np.ndarray  # (M,) int
    row: np.ndarray  # (M,) int
    col: np.ndarray  # (M,) int
    offset: np.ndarray  # (M, 3) sub-pixel (x, y) and sub-scale offsets
    contrast: np.ndarray  # (M,) |D(x^)|


def _refine(dog: np.ndarray, span: int, s: np.ndarray, r: np.ndarray, c: np.ndarray,
            contrast_threshold: float, edge_threshold: float) -> _Refined:
    """Taylor refinement and the contrast and edge tests (thesis eqs. 4.6-4.15)."""
    compiled = _kernels()
    if compiled is not None:  # the same bits, one loop per candidate (``kernels``)
        index, values = compiled.refine(dog, span, IMAGE_BORDER, s, r, c, contrast_threshold,
                                        edge_threshold)
        return _Refined(s[index], r[index], c[index], values[:, :3], values[:, 3])
    height, width = dog.shape[1:]
    b = IMAGE_BORDER
    alive = np.arange(s.shape[0])
    done = np.zeros(s.shape[0], dtype=bool)
    offset = np.zeros((s.shape[0], 3))
    for _ in range(MAX_INTERP_STEPS):
        if alive.size == 0:
            break
        _, g, h = _derivatives(dog, s[alive], r[alive], c[alive])
        x, solvable = _solve3(h, -g)
        converged = solvable & np.all(np.abs(x) < 0.5, axis=1)
        offset[alive[converged]] = x[converged]
        done[alive[converged]] = True
        moving = solvable & ~converged & np.all(np.abs(x) < 1e6, axis=1)
        idx = alive[moving]
        step = np.rint(x[moving]).astype(np.int64)
        c[idx] += step[:, 0]
        r[idx] += step[:, 1]
        s[idx] += step[:, 2]
        inside = ((s[idx] >= 1) & (s[idx] <= span) & (c[idx] >= b) & (c[idx] < width - b)
                  & (r[idx] >= b) & (r[idx] < height - b))
        alive = idx[inside]
    keep = np.flatnonzero(done)
    s, r, c, x = s[keep], r[keep], c[keep], offset[keep]
    v, g, h = _derivatives(dog, s, r, c)
    contrast = np.abs(v + 0.5 * np.sum(g * x, axis=1))
    trace = h[:, 0, 0] + h[:, 1, 1]
    det = h[:, 0, 0] * h[:, 1, 1] - h[:, 0, 1] ** 2
    ok = ((contrast >= contrast_threshold) & (det > 0)
          & (trace**2 * edge_threshold < (edge_threshold + 1) ** 2 * det))
    return _Refined(s[ok], r[ok], c[ok], x[ok], contrast[ok])


def _orientations(gaussian: np.ndarray, layer: np.ndarray, rows: np.ndarray,
                  cols: np.ndarray, scales: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Dominant gradient orientations (Lowe 2004 sec. 5): one or more per keypoint.

    Args:
        gaussian: (N + 3, H, W) the octave's Gaussian images.
        layer, rows, cols: (M,) integer keypoint layers and positions in the octave.
        scales: (M,) keypoint scales in the octave's pixels.

    Returns:
        ``(which, angles_deg)``: for every orientation found, the keypoint index and OpenCV's
        angle (degrees, 360 - the image-frame angle with y up).
    """
    cv2 = require("cv2")
    m = rows.shape[0]
    _, height, width = gaussian.shape
    radius = np.rint(ORI_RADIUS * scales).astype(np.int64)
    reach = int(radius.max())
    span = np.arange(-reach, reach + 1)
    compiled = _kernels()
    if compiled is not None:  # the same gather, one pass (``kernels``)
        dx, dy, valid = compiled.window_gradients(gaussian, layer, rows, cols, radius, reach)
        valid = valid.reshape(m, span.size, span.size)
    else:
        yy = rows[:, None, None] + span[None, :, None]
        xx = cols[:, None, None] + span[None, None, :]
        valid = ((np.abs(span)[None, :, None] <= radius[:, None, None])
                 & (np.abs(span)[None, None, :] <= radius[:, None, None])
                 & (yy > 0) & (yy < height - 1) & (xx > 0) & (xx < width - 1))
        flat = gaussian.reshape(-1)
        at = (layer[:, None, None] * (height * width) + np.clip(yy, 1, height - 2) * width
              + np.clip(xx, 1, width - 2))
        dx = (flat[at + 1] - flat[at - 1]).ravel()
        dy = (flat[at - width] - flat[at + width]).ravel()
    magnitude, angle = cv2.cartToPolar(dx, dy, angleInDegrees=True)
    sigma_w = (ORI_SIGMA * scales).astype(np.float32)
    dist2 = (span[None, :, None] ** 2 + span[None, None, :] ** 2).astype(np.float32)
    weight = np.exp(-dist2 / (2.0 * sigma_w[:, None, None] ** 2)) * valid
    if compiled is not None:  # the same sums in the same order
        hist = compiled.orientation_histograms(angle.ravel(), weight.ravel(), magnitude.ravel(),
                                               m, ORI_BINS)
    else:
        bins = np.rint(angle.ravel() * (ORI_BINS / 360.0)).astype(np.int64) % ORI_BINS
        index = (np.arange(m)[:, None] * ORI_BINS + bins.reshape(m, -1)).ravel()
        hist = np.bincount(index, weights=weight.ravel() * magnitude.ravel(),
                           minlength=m * ORI_BINS).reshape(m, ORI_BINS)
    # smoothing [1 4 6 4 1] / 16 (circular)
    wrap = np.concatenate([hist[:, -2:], hist, hist[:, :2]], axis=1)
    hist = ((wrap[:, :-4] + wrap[:, 4:]) * (1.0 / 16.0) + (wrap[:, 1:-3] + wrap[:, 3:-1])
            * (4.0 / 16.0) + wrap[:, 2:-2] * (6.0 / 16.0))
    wrap = np.concatenate([hist[:, -1:], hist, hist[:, :1]], axis=1)
    left, right = wrap[:, :-2], wrap[:, 2:]
    peak = ((hist > left) & (hist > right)
            & (hist >= ORI_PEAK_RATIO * hist.max(axis=1, keepdims=True)))
    which, j = np.nonzero(peak)
    lv, cv_, rv = left[which, j], hist[which, j], right[which, j]
    b = j + 0.5 * (lv - rv) / (lv - 2.0 * cv_ + rv)
    b = np.where(b < 0, b + ORI_BINS, np.where(b >= ORI_BINS, b - ORI_BINS, b))
    angles = 360.0 - (360.0 / ORI_BINS) * b
    angles[np.abs(angles - 360.0) < 1e-6] = 0.0
    return which, angles


@dataclass(frozen=True, slots=True)
class Detections:
    """Keypoints before description (image pixels, pixel centres at integers).

    Attributes:
        x, y: (K,) position [px].
        sigma: (K,) scale [px] (OpenCV's ``size`` is 2 sigma).
        angle_deg: (K,) OpenCV's orientation convention (360 - the angle with y up) [deg].
        response: (K,) |D(x^)| (thesis eq. 4.9).
        octave: (K,) Lowe's octave (-1: the fine octave).
        layer: (K,) layer within it (1..N).
        sub_scale: (K,) refined offset of the scale within the layer (-0.5..0.5).
    """

    x: np.ndarray
    y: np.ndarray
    sigma: np.ndarray
    angle_deg: np.ndarray
    response: np.ndarray
    octave: np.ndarray
    layer: np.ndarray
    sub_scale: np.ndarray

    def __len__(self) -> int:
        return int(self.x.shape[0])

    def subset(self, index: np.ndarray) -> Detections:
        return Detections(*(getattr(self, f)[index] for f in self.__slots__))

    def keypoints(self, octave_offset: int = 0) -> list:
        """``cv2.KeyPoint`` list, octaves packed as OpenCV does (shifted by ``octave_offset``:
        +1 describes the fine octave with a ``SIFT`` of sigma / 2, whose octave 0 it is)."""
        cv2 = require("cv2")
        octave = (self.octave + octave_offset) & 255
        packed = (octave + (self.layer << 8)
                  + (np.rint((self.sub_scale + 0.5) * 255).astype(np.int64) << 16))
        return [
            cv2.KeyPoint(x, y, size, a, r, p)
            for x, y, size, a, r, p in zip(self.x.tolist(), self.y.tolist(),
                                           (2.0 * self.sigma).tolist(), self.angle_deg.tolist(),
                                           self.response.tolist(), packed.tolist(), strict=True)
        ]


def detect_keypoints(
    grey: np.ndarray,
    mask: np.ndarray | None,
    *,
    sigma: float,
    layers: int,
    contrast_threshold: float,
    edge_threshold: float,
    fine: bool = True,
    halved: bool = False,
    max_keypoints: int = 0,
    buckets: np.ndarray | None = None,
) -> Detections:
    """SIFT keypoints of an image without doubling it (see the module docstring).

    Args:
        grey: (H, W) uint8 grey image.
        mask: (H, W) uint8 detection mask (non-zero = detect) or None.
        sigma: Lowe's sigma, the base blur of octave 0 [px].
        layers: N, scales per octave.
        contrast_threshold: C on |D(x^)| for images in [0, 1] (thesis eq. 4.9).
        edge_threshold: R, the principal-curvature ratio (thesis eq. 4.15).
        fine: detect at the scales sigma / 2 .. sigma too, on the image's own pixels.
        halved: with ``fine``, octave 0 on at half the previous octave's pixels
            (``build_scale_space``).
        max_keypoints: keep only this many of the strongest detections (by ``response``;
            0 = all). The budget is applied before the orientations are computed: only the
            strongest located keypoints get an orientation histogram, and the strongest
            detections among their orientations are kept, which are exactly the detections
            that computing every orientation and keeping the strongest would give, in the
            same order (an orientation shares its keypoint's response, so no keypoint beyond
            the ``max_keypoints`` strongest can hold one of the strongest detections).
        buckets: (H, W) integer map of each pixel's bucket (``budget_buckets``); with it the
            budget is shared out over the buckets (``strongest_per_bucket``) instead of going
            to the strongest detections of the whole image. Orientations are computed for the
            located keypoints that are the strongest of their bucket or of the whole image,
            a superset of the keypoints whose detections the rule keeps, so the result is
            again exactly that of computing every orientation first.

    Returns:
        The detections, one per orientation (thesis 4.1.2: peaks >= 80 % make keypoints), in
        the order octave, layer, candidate, orientation.
    """
    located = _located(grey, mask, sigma=sigma, layers=layers,
                       contrast_threshold=contrast_threshold, edge_threshold=edge_threshold,
                       fine=fine, halved=halved)
    if max_keypoints:
        located = _strongest_located(located, max_keypoints, buckets)
    parts = [_oriented(octave, ref, layers) for octave, ref in located if ref.layer.size]
    if not parts:
        empty = np.zeros(0)
        ints = np.zeros(0, dtype=np.int64)
        return Detections(empty, empty, empty, empty, empty, ints, ints, empty)
    found = Detections(*(np.concatenate([getattr(p, f) for p in parts])
                         for f in Detections.__slots__))
    if max_keypoints and len(found) > max_keypoints:  # orientations beyond the budget
        found = _within_budget(found, max_keypoints, buckets)
    return found


def _located(grey: np.ndarray, mask: np.ndarray | None, *, sigma: float, layers: int,
             contrast_threshold: float, edge_threshold: float, fine: bool, halved: bool
             ) -> list[tuple[Octave, _Refined]]:
    """The refined DoG extrema of each octave (thesis eqs. 4.6-4.15) whose refined position
    falls inside ``mask``, layer by layer; octaves without any are left out (arguments as
    ``detect_keypoints``'s)."""
    cv2 = require("cv2")
    full_mask = None if mask is None else (mask > 0).astype(np.uint8) * 255
    octave_mask = full_mask
    threshold = 0.5 * contrast_threshold  # candidates: half the final contrast threshold
    located: list[tuple[Octave, _Refined]] = []
    for octave in build_scale_space(grey, sigma, layers, fine=fine, halved=halved):
        if full_mask is not None and octave.step_px > 1:
            # a pixel of the octave stands for step^2 image pixels: detect where any may
            octave_mask = cv2.dilate(octave_mask, np.ones((3, 3), np.uint8))[::2, ::2]
            octave_mask = np.ascontiguousarray(octave_mask[: octave.dog.shape[1],
                                                           : octave.dog.shape[2]])
        span = octave.extrema_layers
        s, r, c = _candidates(octave.dog, span, threshold, octave_mask)
        if s.size == 0:
            continue
        ref = _refine(octave.dog, span, s, r, c, contrast_threshold, edge_threshold)
        # layer by layer (the orientations are computed per layer, in this order)
        ref = _subset_refined(ref, np.argsort(ref.layer, kind="stable"))
        if mask is not None:  # the refined position must fall inside the mask
            step = float(octave.step_px)
            u = np.clip(np.rint((ref.col + ref.offset[:, 0]) * step).astype(np.int64), 0,
                        mask.shape[1] - 1)
            v = np.clip(np.rint((ref.row + ref.offset[:, 1]) * step).astype(np.int64), 0,
                        mask.shape[0] - 1)
            ref = _subset_refined(ref, mask[v, u] > 0)
        if ref.layer.size:
            located.append((octave, ref))
    return located


def _strongest_located(located: list[tuple[Octave, _Refined]], max_keypoints: int,
                       buckets: np.ndarray | None) -> list[tuple[Octave, _Refined]]:
    """The located keypoints that may hold one of the ``max_keypoints`` detections kept: the
    strongest of the whole image and, with ``buckets``, of each bucket (the superset
    ``detect_keypoints`` describes); all of them when they are within the budget."""
    if sum(ref.layer.size for _, ref in located) <= max_keypoints:
        return located
    response = np.concatenate([ref.contrast for _, ref in located])
    keep = np.zeros(response.shape[0], dtype=bool)
    keep[np.argsort(-response, kind="stable")[:max_keypoints]] = True
    if buckets is not None:  # and the strongest of each bucket (the docstring's superset)
        bucket = np.concatenate([_bucket_of(buckets, octave, ref) for octave, ref in located])
        keep |= strongest_per_bucket(response, bucket, int(buckets.max()) + 1, max_keypoints,
                                     spill=False)
    sizes = np.cumsum([0] + [ref.layer.size for _, ref in located])
    return [(octave, _subset_refined(ref, keep[a:b]))
            for (octave, ref), a, b in zip(located, sizes[:-1], sizes[1:], strict=True)]


def _oriented(octave: Octave, ref: _Refined, layers: int) -> Detections:
    """The detections of an octave's located keypoints, one per dominant orientation
    (``_orientations``), in image pixels and Lowe's octave and layer."""
    scale = octave.sigma_px * 2.0 ** ((ref.layer + ref.offset[:, 2]) / layers)
    # one call per layer: the window radius grows with the scale
    k, angles = [], []
    for layer in np.unique(ref.layer):
        sel = np.flatnonzero(ref.layer == layer)
        which, found = _orientations(octave.gaussian, ref.layer[sel], ref.row[sel],
                                     ref.col[sel], scale[sel])
        k.append(sel[which])
        angles.append(found)
    k, angles = np.concatenate(k), np.concatenate(angles)
    step = float(octave.step_px)
    # Lowe's octave and layer (the fine octave spans octaves -1 and 0)
    above = (ref.layer[k] - 1) // layers
    return Detections(
        x=(ref.col[k] + ref.offset[k, 0]) * step,
        y=(ref.row[k] + ref.offset[k, 1]) * step,
        sigma=scale[k] * step,
        angle_deg=angles,
        response=ref.contrast[k],
        octave=octave.index + above,
        layer=ref.layer[k] - layers * above,
        sub_scale=ref.offset[k, 2],
    )


def _within_budget(found: Detections, max_keypoints: int, buckets: np.ndarray | None
                   ) -> Detections:
    """The ``max_keypoints`` strongest detections, in their order, or with ``buckets`` the
    budget shared out over the buckets (``strongest_per_bucket``)."""
    if buckets is None:
        strongest = np.argsort(-found.response, kind="stable")[:max_keypoints]
        return found.subset(np.sort(strongest))
    return found.subset(strongest_per_bucket(
        found.response, bucket_at(buckets, np.column_stack([found.x, found.y])),
        int(buckets.max()) + 1, max_keypoints))


def budget_buckets(region: np.ndarray, bands: int, sectors: int) -> np.ndarray:
    """Buckets of equal area for a keypoint budget: rings about the region's centroid times
    angular sectors.

    The ``bands`` rings split the region's pixels into equal counts by their distance from the
    centroid, the sectors into equal angles. On a catadioptric image the rings are bands of
    elevation (on lab40 the floor, seen 35 deg and more below the horizon, is the innermost
    ring) and the sectors bands of azimuth, so a budget shared out over them keeps features
    at every elevation and azimuth, where the strongest of the whole image crowd onto a few
    high-contrast objects (the usual bucketing of visual odometry front ends).

    Args:
        region: (H, W) detection mask (non-zero = detect).
        bands: number of rings (>= 1).
        sectors: number of angular sectors (>= 1).

    Returns:
        (H, W) int32 map: the bucket ``ring * sectors + sector`` of every pixel (computed for
        pixels outside the region too, by the same rule).
    """
    if bands < 1 or sectors < 1:
        raise ValueError(f"bands and sectors must be >= 1, got {bands}, {sectors}")
    rows, cols = np.nonzero(region)
    if rows.size == 0:
        raise ValueError("the detection region is empty")
    cy, cx = rows.mean(), cols.mean()
    edges = np.quantile(np.hypot(cols - cx, rows - cy), np.linspace(0.0, 1.0, bands + 1)[1:-1])
    yy, xx = np.mgrid[: region.shape[0], : region.shape[1]]
    ring = np.searchsorted(edges, np.hypot(xx - cx, yy - cy), side="right")
    angle = (np.arctan2(yy - cy, xx - cx) + np.pi) / (2.0 * np.pi)
    sector = np.minimum((angle * sectors).astype(np.int64), sectors - 1)
    return (ring * sectors + sector).astype(np.int32)


def bucket_at(buckets: np.ndarray, pixels: np.ndarray) -> np.ndarray:
    """The bucket of each ``[u, v]`` pixel position (rounded, clipped to the image)."""
    u = np.clip(np.rint(pixels[:, 0]).astype(np.int64), 0, buckets.shape[1] - 1)
    v = np.clip(np.rint(pixels[:, 1]).astype(np.int64), 0, buckets.shape[0] - 1)
    return buckets[v, u]


def strongest_per_bucket(
    response: np.ndarray, bucket: np.ndarray, n_buckets: int, budget: int, *, spill: bool = True
) -> np.ndarray:
    """Which detections a budget shared out over equal-area buckets keeps (a boolean mask).

    Each of the ``n_buckets`` buckets keeps its ``budget // n_buckets`` strongest; with
    ``spill`` the budget that sparse buckets leave goes to the strongest of the rest, so
    ``min(budget, len(response))`` are kept. Stable: ties keep their order.
    """
    response, bucket = np.asarray(response), np.asarray(bucket, dtype=np.int64)
    keep = np.zeros(response.shape[0], dtype=bool)
    if response.shape[0] == 0 or budget <= 0:
        return keep
    quota = budget // n_buckets
    order = np.lexsort((-response, bucket))  # by bucket, strongest first, stable
    sorted_bucket = bucket[order]
    rank = np.arange(order.size) - np.searchsorted(sorted_bucket, sorted_bucket, side="left")
    keep[order[rank < quota]] = True
    left = budget - int(keep.sum())
    if spill and left > 0:
        rest = np.flatnonzero(~keep)
        keep[rest[np.argsort(-response[rest], kind="stable")[:left]]] = True
    return keep


def _bucket_of(buckets: np.ndarray, octave: Octave, ref: _Refined) -> np.ndarray:
    step = float(octave.step_px)
    return bucket_at(buckets, np.column_stack([(ref.col + ref.offset[:, 0]) * step,
                                               (ref.row + ref.offset[:, 1]) * step]))


def _subset_refined(ref: _Refined, index: np.ndarray) -> _Refined:
    return _Refined(ref.layer[index], ref.row[index], ref.col[index], ref.offset[index],
                    ref.contrast[index])
