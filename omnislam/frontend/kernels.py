"""Compiled kernels for the SIFT detector's per-pixel loops (numba, the optional extra ``fast``).

``scale_space`` finds the DoG extrema with whole-image OpenCV operations (a 3 x 3 dilation and
erosion per layer, then a gather of the 18 neighbours in the layers above and below for the ~18 %
of the pixels that pass the threshold), refines them and histograms their orientation windows
with vectorised numpy; on a 640 x 640 lab40 image that is ~20 + ~8 + ~4 ms of CPU, most of it
memory traffic and index arithmetic over whole arrays. These kernels do the same work in one
pass each:

* ``extrema``: the DoG extrema over their 26 neighbours above half the contrast threshold
  (``scale_space._candidates``), a branch-free pre-test on each row first;
* ``refine``: the Taylor refinement and the contrast and edge tests (thesis eqs. 4.6-4.15,
  ``scale_space._refine``);
* ``window_gradients`` and ``orientation_histograms``: the gradients of the orientation
  windows and their weighted direction histograms (Lowe 2004 sec. 5,
  ``scale_space._orientations``), with OpenCV's ``cartToPolar`` and numpy's ``exp`` still
  between them (their float32 results depend on the implementation, so they stay the same
  calls on the same arrays).

The numpy path stays the reference and the test oracle (``tests/frontend/test_sift_kernels.py``):
``extrema`` only compares float32 values and returns the same candidates in the same order;
``refine`` writes out the reference's float64 arithmetic in the reference's order (the central
differences, the adjugate solve, the same rounding of a Newton step); the gather computes the
same float32 differences, and the histograms add the same float32 products in the same order
as ``np.bincount``. So all give the same bits, and the front end's log does not depend on
whether numba is installed.

The functions are plain Python written in the subset numba compiles; this module only
defines them (it imports numpy alone). ``kernels_compiled`` compiles them (ahead of time,
``kernels_aot``, or with numba) and holds what the detector calls.
"""

from __future__ import annotations

import numpy as np

#: Newton steps of the sub-pixel refinement (``scale_space.MAX_INTERP_STEPS``)
_MAX_INTERP_STEPS = 5
#: the functions the kernels call, which numba must compile before them (it resolves a
#: kernel's globals when it compiles the kernel)
HELPERS = ("_derivatives", "_solve3")


def extrema(dog: np.ndarray, span: int, threshold: np.float32, inner: np.ndarray) -> np.ndarray:
    """(M, 3) int64 ``(layer, row, col)`` of the DoG extrema, layer by layer in row-major order.

    Each row is tested in two passes: a branch-free one (which the compiler vectorises) flags
    the pixels beyond the threshold that are not below (above) their four nearest neighbours
    in the layer, then the few flagged pixels are compared with the other 22.

    Args:
        dog: (S + 2, H, W) float32 DoG stack of one octave; extrema are sought in layers 1..S.
        span: S.
        threshold: float32 minimum |D| (``cv2.compare`` compares float32 images with the
            threshold as float32 too).
        inner: (H, W) uint8, non-zero where to detect (zero on the octave's border).
    """
    _, height, width = dog.shape
    found = np.empty((1024, 3), dtype=np.int64)
    n = 0
    flag = np.zeros(width, dtype=np.uint8)
    negative = -threshold
    for s in range(1, span + 1):
        below, layer, above = dog[s - 1], dog[s], dog[s + 1]
        for r in range(1, height - 1):
            row, up, down, allowed = layer[r], layer[r - 1], layer[r + 1], inner[r]
            for c in range(1, width - 1):
                v = row[c]
                peak = (
                    (v > threshold)
                    & (v >= row[c - 1])
                    & (v >= row[c + 1])
                    & (v >= up[c])
                    & (v >= down[c])
                )
                pit = (
                    (v < negative)
                    & (v <= row[c - 1])
                    & (v <= row[c + 1])
                    & (v <= up[c])
                    & (v <= down[c])
                )
                flag[c] = (peak | pit) & (allowed[c] != 0)
            for c in range(1, width - 1):
                if flag[c] == 0:
                    continue
                v = row[c]
                extremum = True
                if v > 0:  # a peak: no neighbour larger
                    for dr in (-1, 1):
                        for dc in (-1, 1):
                            if layer[r + dr, c + dc] > v:
                                extremum = False
                    if not extremum:
                        continue
                    for dr in range(-1, 2):
                        for dc in range(-1, 2):
                            if below[r + dr, c + dc] > v or above[r + dr, c + dc] > v:
                                extremum = False
                else:  # a pit: no neighbour smaller
                    for dr in (-1, 1):
                        for dc in (-1, 1):
                            if layer[r + dr, c + dc] < v:
                                extremum = False
                    if not extremum:
                        continue
                    for dr in range(-1, 2):
                        for dc in range(-1, 2):
                            if below[r + dr, c + dc] < v or above[r + dr, c + dc] < v:
                                extremum = False
                if not extremum:
                    continue
                if n == found.shape[0]:
                    bigger = np.empty((2 * n, 3), dtype=np.int64)
                    bigger[:n] = found
                    found = bigger
                found[n, 0] = s
                found[n, 1] = r
                found[n, 2] = c
                n += 1
    return found[:n]


def _derivatives(dog: np.ndarray, s: int, r: int, c: int, g: np.ndarray, h: np.ndarray) -> float:
    """D at (s, r, c); its gradient into ``g`` (3,) and Hessian into ``h`` (3, 3), in (x, y,
    scale), by central differences (``scale_space._derivatives``'s arithmetic)."""
    v = np.float64(dog[s, r, c])
    right = np.float64(dog[s, r, c + 1])
    left = np.float64(dog[s, r, c - 1])
    down = np.float64(dog[s, r + 1, c])
    up = np.float64(dog[s, r - 1, c])
    above = np.float64(dog[s + 1, r, c])
    below = np.float64(dog[s - 1, r, c])
    g[0] = 0.5 * (right - left)
    g[1] = 0.5 * (down - up)
    g[2] = 0.5 * (above - below)
    dxx = right + left - 2 * v
    dyy = down + up - 2 * v
    dss = above + below - 2 * v
    dxy = 0.25 * (
        np.float64(dog[s, r + 1, c + 1])
        - np.float64(dog[s, r + 1, c - 1])
        - np.float64(dog[s, r - 1, c + 1])
        + np.float64(dog[s, r - 1, c - 1])
    )
    dxs = 0.25 * (
        np.float64(dog[s + 1, r, c + 1])
        - np.float64(dog[s + 1, r, c - 1])
        - np.float64(dog[s - 1, r, c + 1])
        + np.float64(dog[s - 1, r, c - 1])
    )
    dys = 0.25 * (
        np.float64(dog[s + 1, r + 1, c])
        - np.float64(dog[s + 1, r - 1, c])
        - np.float64(dog[s - 1, r + 1, c])
        + np.float64(dog[s - 1, r - 1, c])
    )
    h[0, 0], h[0, 1], h[0, 2] = dxx, dxy, dxs
    h[1, 0], h[1, 1], h[1, 2] = dxy, dyy, dys
    h[2, 0], h[2, 1], h[2, 2] = dxs, dys, dss
    return v


def _solve3(a: np.ndarray, b: np.ndarray, x: np.ndarray) -> bool:
    """``a x = -b`` for a symmetric 3 x 3 ``a`` by the adjugate (``scale_space._solve3``'s
    arithmetic, with ``b`` negated as the reference's caller does); False when singular."""
    c00 = a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]
    c01 = a[1, 2] * a[2, 0] - a[1, 0] * a[2, 2]
    c02 = a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]
    c11 = a[0, 0] * a[2, 2] - a[0, 2] * a[2, 0]
    c12 = a[0, 1] * a[2, 0] - a[0, 0] * a[2, 1]
    c22 = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
    det = a[0, 0] * c00 + a[0, 1] * c01 + a[0, 2] * c02
    solvable = abs(det) > 1e-30
    inverse_det = 1.0 / det if solvable else 0.0
    b0, b1, b2 = -b[0], -b[1], -b[2]
    # numpy's einsum("mij,mj->mi") sums a row's three products as (first + last) + middle
    x[0] = ((c00 * b0 + c02 * b2) + c01 * b1) * inverse_det
    x[1] = ((c01 * b0 + c12 * b2) + c11 * b1) * inverse_det
    x[2] = ((c02 * b0 + c22 * b2) + c12 * b1) * inverse_det
    return solvable


def refine(
    dog: np.ndarray,
    span: int,
    border: int,
    s: np.ndarray,
    r: np.ndarray,
    c: np.ndarray,
    contrast_threshold: float,
    edge_threshold: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Taylor refinement and the contrast and edge tests (thesis eqs. 4.6-4.15).

    Args:
        dog: (S + 2, H, W) float32 DoG stack.
        span: S.
        border: candidates may not step closer than this to the octave's border.
        s: (M,) int64 candidate layers (moved in place by the Newton steps, as the reference
            does).
        r: (M,) int64 candidate rows (moved in place likewise).
        c: (M,) int64 candidate columns (moved in place likewise).
        contrast_threshold: C (eq. 4.9).
        edge_threshold: R (eq. 4.15).

    Returns:
        ``(index, values)``: the (K,) indices of the candidates kept, and (K, 4) their
        sub-pixel offsets (x, y, scale) and contrast |D(x^)|, in candidate order.
    """
    height, width = dog.shape[1], dog.shape[2]
    m = s.shape[0]
    index = np.empty(m, dtype=np.int64)
    values = np.empty((m, 4))
    g = np.empty(3)
    h = np.empty((3, 3))
    x = np.empty(3)
    k = 0
    for i in range(m):
        done = False
        for _ in range(_MAX_INTERP_STEPS):
            _derivatives(dog, s[i], r[i], c[i], g, h)
            solvable = _solve3(h, g, x)
            if solvable and abs(x[0]) < 0.5 and abs(x[1]) < 0.5 and abs(x[2]) < 0.5:
                done = True
                break
            if not (solvable and abs(x[0]) < 1e6 and abs(x[1]) < 1e6 and abs(x[2]) < 1e6):
                break
            c[i] += np.int64(np.rint(x[0]))
            r[i] += np.int64(np.rint(x[1]))
            s[i] += np.int64(np.rint(x[2]))
            if not (
                1 <= s[i] <= span
                and border <= c[i] < width - border
                and border <= r[i] < height - border
            ):
                break
        if not done:
            continue
        v = _derivatives(dog, s[i], r[i], c[i], g, h)
        contrast = abs(v + 0.5 * (g[0] * x[0] + g[1] * x[1] + g[2] * x[2]))
        trace = h[0, 0] + h[1, 1]
        det = h[0, 0] * h[1, 1] - h[0, 1] ** 2
        if (
            contrast >= contrast_threshold
            and det > 0
            and trace**2 * edge_threshold < (edge_threshold + 1) ** 2 * det
        ):
            index[k] = i
            values[k, 0], values[k, 1], values[k, 2], values[k, 3] = x[0], x[1], x[2], contrast
            k += 1
    return index[:k], values[:k]


def window_gradients(
    gaussian: np.ndarray,
    layer: np.ndarray,
    rows: np.ndarray,
    cols: np.ndarray,
    radius: np.ndarray,
    reach: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The orientation windows' gradients (``scale_space._orientations``'s gather).

    Args:
        gaussian: (N + 3, H, W) float32 Gaussian images of the octave.
        layer: (M,) int64 keypoint layers.
        rows: (M,) int64 keypoint rows.
        cols: (M,) int64 keypoint columns.
        radius: (M,) int64 window radius of each keypoint.
        reach: the largest radius: every window is (2 reach + 1)^2 samples, as the
            reference's.

    Returns:
        ``(dx, dy, valid)``: (M * (2 reach + 1)^2,) float32 central differences (x right, y
        up) at each sample (positions clipped into the image as the reference does), and
        whether the sample is inside the keypoint's own window and the image.
    """
    height, width = gaussian.shape[1], gaussian.shape[2]
    side = 2 * reach + 1
    m = rows.shape[0]
    dx = np.empty(m * side * side, dtype=np.float32)
    dy = np.empty(m * side * side, dtype=np.float32)
    valid = np.empty(m * side * side, dtype=np.bool_)
    i = 0
    for k in range(m):
        image = gaussian[layer[k]]
        for iy in range(side):
            y = rows[k] + iy - reach
            yc = min(max(y, 1), height - 2)
            inside_y = abs(iy - reach) <= radius[k] and 0 < y < height - 1
            for ix in range(side):
                x = cols[k] + ix - reach
                xc = min(max(x, 1), width - 2)
                dx[i] = image[yc, xc + 1] - image[yc, xc - 1]
                dy[i] = image[yc - 1, xc] - image[yc + 1, xc]
                valid[i] = inside_y and abs(ix - reach) <= radius[k] and 0 < x < width - 1
                i += 1
    return dx, dy, valid


def orientation_histograms(
    angle: np.ndarray, weight: np.ndarray, magnitude: np.ndarray, m: int, bins: int
) -> np.ndarray:
    """(M, bins) float64 histograms of the window samples' directions
    (``scale_space._orientations``'s ``np.bincount``: the float32 products summed in sample
    order).

    Args:
        angle: (M * S,) float32 sample directions [deg] (``cv2.cartToPolar``).
        weight: (M * S,) float32 Gaussian weights (0 outside a keypoint's window).
        magnitude: (M * S,) float32 gradient magnitudes.
        m: M keypoints, S samples each.
        bins: histogram bins over 360 deg.
    """
    hist = np.zeros((m, bins))
    per = angle.shape[0] // max(m, 1)
    scale = np.float32(bins / 360.0)
    for k in range(m):
        for j in range(per):
            i = k * per + j
            b = np.int64(np.rint(angle[i] * scale)) % bins
            hist[k, b] += np.float64(weight[i] * magnitude[i])
    return hist
