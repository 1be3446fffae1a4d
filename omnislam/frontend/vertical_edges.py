"""Vertical lines with their colour profiles (Barra & Costa, sec. 2).

- **Perspective camera** with a horizontal optical axis (camera rows level): a vertical world
  line projects to an image column. Pixels with a strong, mostly horizontal gradient vote for
  their column; columns supported over ``min_support`` of the image height are lines; the
  column (sub-pixel: vote-weighted mean around the peak) gives a ray, hence a bearing.
- **Omnidirectional camera** with a vertical mirror axis: a vertical world line projects to a
  **radial** segment, so the image azimuth about the image of the axis gives the bearing.
  Pixels whose gradient is mostly tangential vote for their azimuth bin; peaks with enough
  radial support are lines; their azimuth is turned into a robot-frame bearing through the
  camera model (this handles mirrored images).

Each line carries the PMC (mean colour profile: 3 bands x (2n + 1) samples across the line,
ordered from the robot's left to its right, i.e. by decreasing bearing) and the MC (mean colour
of the n samples on each side).
"""

from __future__ import annotations

import warnings

import numpy as np

from omnislam._optional import require
from omnislam.core.types import UNKNOWN_ID, VerticalLines
from omnislam.errors import DataError
from omnislam.frontend.config import VerticalEdgeConfig

#: peaks closer than this many bins/columns are one line (non-maximum suppression)
NMS_RADIUS = 3
#: omni: pixels with |g|^2 >= this times min_gradient^2 are tested exactly (float32 rounding)
STRONG_SLACK = 0.999


def _gradients(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """float32 Sobel gradients / 4 of the grey image (the integer sums scaled by a power of
    two inside the filter: the same values as converting to float32 and dividing after)."""
    cv2 = require("cv2")
    grey = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY) if image.ndim == 3 else image
    gx = cv2.Sobel(grey, cv2.CV_32F, 1, 0, ksize=3, scale=0.25)
    gy = cv2.Sobel(grey, cv2.CV_32F, 0, 1, ksize=3, scale=0.25)
    return gx, gy


def _peaks(score: np.ndarray, minimum: float, circular: bool) -> np.ndarray:
    """Indices of local maxima of ``score`` (within NMS_RADIUS) at least ``minimum``."""
    n = score.shape[0]
    padded = np.concatenate([score[-NMS_RADIUS:], score, score[:NMS_RADIUS]]) if circular \
        else np.pad(score, NMS_RADIUS, constant_values=-np.inf)
    windows = np.lib.stride_tricks.sliding_window_view(padded, 2 * NMS_RADIUS + 1)[:n]
    is_max = (score >= windows.max(axis=1)) & (score >= minimum)
    # keep the first of equal neighbours
    shifted = np.roll(score, 1) == score
    return np.flatnonzero(is_max & ~(shifted & np.roll(is_max, 1)))


def _parabola_peak(strength: np.ndarray, peak: int) -> float:
    """Sub-pixel position of a maximum: vertex of the parabola through three samples."""
    if peak == 0 or peak == strength.shape[0] - 1:
        return float(peak)
    left, mid, right = strength[peak - 1], strength[peak], strength[peak + 1]
    curvature = left - 2.0 * mid + right
    if curvature >= 0:
        return float(peak)
    return float(peak + 0.5 * (left - right) / curvature)


def _sample_colours(image: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(..., 3) nearest-pixel colours (out-of-image samples are NaN)."""
    h, w = image.shape[:2]
    ui = np.round(u).astype(int)
    vi = np.round(v).astype(int)
    inside = (ui >= 0) & (ui < w) & (vi >= 0) & (vi < h)
    out = np.full((*u.shape, 3), np.nan)
    out[inside] = image[vi[inside], ui[inside], :3]
    return out


def _nanmean(values: np.ndarray, axis: int) -> np.ndarray:
    """Mean ignoring NaN (NaN where every sample is NaN, without a warning)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.nanmean(values, axis=axis)


def _lines(bearings: np.ndarray, profiles: np.ndarray, config: VerticalEdgeConfig,
           ) -> VerticalLines:
    n = config.profile_half_width
    profiles = np.nan_to_num(profiles, nan=0.0)
    return VerticalLines(
        bearings_rad=bearings,
        sigma_bearing_rad=np.full(bearings.shape[0], config.sigma_bearing_rad),
        profiles=profiles,
        means_left=profiles[:, :, :n].mean(axis=2) if bearings.size else np.zeros((0, 3)),
        means_right=profiles[:, :, n + 1:].mean(axis=2) if bearings.size else np.zeros((0, 3)),
        landmark_ids=np.full(bearings.shape[0], UNKNOWN_ID, dtype=np.int64),
    )


class VerticalLineExtractor:
    """Extracts vertical lines from the images of one camera rig (see the module docstring).

    What depends only on the camera (the usable ring's pixels, their radius and azimuth about
    the image of the mirror axis, their azimuth bin) is computed once here.

    Args:
        rig: the ``omnislam.camera.CameraRig``; a pinhole camera is treated as perspective,
            any other model as omnidirectional with a vertical axis.
        config: thresholds and profile size.

    Raises:
        DataError: an omnidirectional rig that images neither end of the vertical through
            its viewpoint (no image of the mirror axis to measure azimuths about).
    """

    def __init__(self, rig: object, config: VerticalEdgeConfig) -> None:
        from omnislam.camera.pinhole import PinholeCamera

        self.rig = rig
        self.config = config
        camera = rig.camera  # type: ignore[attr-defined]
        self.perspective = isinstance(camera, PinholeCamera)
        if self.perspective:
            return
        viewpoint = rig.viewpoint_r  # type: ignore[attr-defined]
        # the image of the mirror axis: where the vertical below the viewpoint projects, or the
        # vertical above it for a camera that looks up at its mirror (which cannot image below)
        ends = viewpoint[None, :] + [[0.0, 0.0, -1.0], [0.0, 0.0, 1.0]]
        centre, _ = rig.project_r(ends)  # type: ignore[attr-defined]
        imaged = np.all(np.isfinite(centre), axis=1)
        if not imaged.any():
            raise DataError(
                "the camera rig images neither end of the vertical through its viewpoint: "
                "vertical lines need the mirror axis vertical (check the rig's rTc)"
            )
        self.cu, self.cv = (float(x) for x in centre[int(np.argmax(imaged))])
        self.mask = camera.mask()
        rows, cols = np.nonzero(self.mask)
        self.flat = rows * self.mask.shape[1] + cols  # ring pixels, row-major
        self.ring_u8 = self.mask.astype(np.uint8) * 255
        # index among the ring pixels of every image pixel (-1 outside the ring)
        self.ring_index = np.full(self.mask.size, -1, dtype=np.int64)
        self.ring_index[self.flat] = np.arange(self.flat.shape[0])
        du, dv = cols - self.cu, rows - self.cv
        radius = np.hypot(du, dv)
        safe = np.maximum(radius, 1e-9)
        # radial unit vector of each pixel (float32 like the gradients)
        self.unit_u, self.unit_v = (du / safe).astype(np.float32), (dv / safe).astype(np.float32)
        self.azimuth = np.arctan2(dv, du)
        bins = config.azimuth_bins
        self.bin = np.floor((self.azimuth + np.pi) / (2 * np.pi) * bins).astype(int) % bins
        self.r_in, self.r_out = float(radius.min()), float(radius.max())
        self.r_index = np.round(radius - self.r_in).astype(int)
        self.n_radii = int(self.r_index.max()) + 1

    def extract(self, image: np.ndarray) -> VerticalLines:
        """Vertical lines of one image, with bearings in the robot frame and colour profiles.

        Args:
            image: (H, W, 3) RGB uint8.
        """
        if self.perspective:
            return _perspective(image, self.rig, self.config)
        return self._omni(image)

    def _omni(self, image: np.ndarray) -> VerticalLines:
        config, rig = self.config, self.rig
        cv2 = require("cv2")
        gx, gy = _gradients(image)
        # the ring's pixels with a strong gradient (a few percent of them): |g|^2 over the whole
        # image, with a margin for float32 rounding below the exact test that follows
        magnitude2 = gx * gx
        magnitude2 += gy * gy
        strong = cv2.bitwise_and(cv2.compare(magnitude2, STRONG_SLACK * config.min_gradient**2,
                                             cv2.CMP_GE), self.ring_u8)
        points = cv2.findNonZero(strong)  # (x, y), row-major like the ring's pixels
        points = np.zeros((0, 2), np.int64) if points is None else points.reshape(-1, 2)
        flat = points[:, 1].astype(np.int64) * gx.shape[1] + points[:, 0]
        ring = self.ring_index[flat]
        g_u, g_v = gx.ravel()[flat], gy.ravel()[flat]
        unit_u, unit_v = self.unit_u[ring], self.unit_v[ring]
        radial2 = np.square(g_u * unit_u + g_v * unit_v)
        tangential2 = np.square(g_v * unit_u - g_u * unit_v)
        # |g| >= min_gradient and |g_radial| <= tan(max error) |g_tangential|, squared
        ok = np.flatnonzero((radial2 + tangential2 >= config.min_gradient**2) & (
            radial2 <= np.tan(config.max_direction_error_rad) ** 2 * tangential2))
        edge = ring[ok]  # indices among the ring's pixels, increasing
        magnitude = np.sqrt(radial2[ok] + tangential2[ok]).astype(float)  # of each edge pixel
        bins = config.azimuth_bins
        # support: fraction of the ring's integer radii holding an edge pixel within +-1 bin
        occupied = np.zeros((bins, self.n_radii), dtype=bool)
        edge_bin = self.bin[edge]
        occupied[edge_bin, self.r_index[edge]] = True
        spread = occupied | np.roll(occupied, 1, axis=0) | np.roll(occupied, -1, axis=0)
        score = spread.sum(axis=1) / self.n_radii
        peaks = _peaks(score, config.min_support, circular=True)
        if peaks.size == 0:
            return _lines(np.zeros(0), np.zeros((0, 3, 2 * config.profile_half_width + 1)),
                          config)
        # azimuth: gradient-weighted mean of the edge pixels within +-1.5 bins of the peak
        # (all in the peak's bin or the two on either side)
        width = 2 * np.pi / bins
        order = np.argsort(edge_bin, kind="stable")
        starts = np.searchsorted(edge_bin[order], np.arange(bins + 1))
        phi = np.empty(peaks.shape[0])
        for n, peak in enumerate(peaks.tolist()):
            which = np.concatenate([order[starts[b % bins]: starts[b % bins + 1]]
                                    for b in range(peak - 2, peak + 3)])
            near = edge[which]
            centre = (peak + 0.5) * width - np.pi
            offset = (self.azimuth[near] - centre + np.pi) % (2 * np.pi) - np.pi
            w = np.where(np.abs(offset) <= 1.5 * width, magnitude[which], 0.0)
            phi[n] = centre + float(np.sum(w * offset)) / max(float(np.sum(w)), 1e-12)
        cu, cv, r_in, r_out = self.cu, self.cv, self.r_in, self.r_out
        r_mid = 0.5 * (r_in + r_out)
        pixels = np.column_stack([cu + r_mid * np.cos(phi), cv + r_mid * np.sin(phi)])
        bearings = _bearing(rig.rays_r(pixels))  # type: ignore[attr-defined]
        # profile samples at azimuths phi + k step, over the supported radii
        n = config.profile_half_width
        k = np.arange(-n, n + 1)
        probe = rig.rays_r(np.column_stack([cu + r_mid * np.cos(phi + 1e-3),  # type: ignore[attr-defined]
                                            cv + r_mid * np.sin(phi + 1e-3)]))
        turn = np.sign(np.sin(_bearing(probe) - bearings))  # +1: image azimuth grows leftwards
        radii = np.linspace(r_in, r_out, 24)
        ang = phi[:, None] - turn[:, None] * k[None, :] * config.profile_step_rad  # left -> right
        u = cu + radii[None, None, :] * np.cos(ang)[:, :, None]
        v = cv + radii[None, None, :] * np.sin(ang)[:, :, None]
        colours = _sample_colours(image, u, v)
        mask = self.mask
        inside = mask[np.clip(np.round(v).astype(int), 0, mask.shape[0] - 1),
                      np.clip(np.round(u).astype(int), 0, mask.shape[1] - 1)]
        colours[~inside] = np.nan
        profiles = _nanmean(colours, axis=2).transpose(0, 2, 1)
        return _lines(bearings, profiles, config)


def extract_vertical_lines(image: np.ndarray, rig: object, config: VerticalEdgeConfig,
                           ) -> VerticalLines:
    """Vertical lines of one image (builds a ``VerticalLineExtractor`` for it; build one
    extractor for many images of the same rig).

    Args:
        image: (H, W, 3) RGB uint8.
        rig: the ``omnislam.camera.CameraRig``; a pinhole camera is treated as perspective,
            any other model as omnidirectional with a vertical axis.
        config: thresholds and profile size.

    Raises:
        DataError: an omnidirectional rig that images neither end of the vertical through
            its viewpoint (no image of the mirror axis to measure azimuths about).
    """
    return VerticalLineExtractor(rig, config).extract(image)


def _bearing(rays_r: np.ndarray) -> np.ndarray:
    return np.arctan2(rays_r[:, 1], rays_r[:, 0])


def _perspective(image: np.ndarray, rig: object, config: VerticalEdgeConfig) -> VerticalLines:
    gx, gy = _gradients(image)
    abs_gx = np.abs(gx)
    direction_ok = np.abs(gy) <= np.tan(config.max_direction_error_rad) * abs_gx
    # |g| >= min as |g|^2 >= min^2: the same pixels (gradients are quarter integers, their
    # squares exact in float32), without a square root per pixel
    edge = (gx * gx + gy * gy >= np.float32(config.min_gradient) ** 2) & direction_ok
    votes = edge.sum(axis=0).astype(float)
    strength = (abs_gx * edge).sum(axis=0, dtype=float)
    height = gx.shape[0]
    score = votes / height
    peaks = _peaks(score, config.min_support, circular=False)
    columns = np.array([_parabola_peak(strength, p) for p in peaks])
    cv_mid = (height - 1) / 2.0
    if columns.size == 0:
        return _lines(np.zeros(0), np.zeros((0, 3, 2 * config.profile_half_width + 1)), config)
    rays = rig.rays_r(np.column_stack([columns, np.full(columns.shape, cv_mid)]))  # type: ignore[attr-defined]
    bearings = _bearing(rays)
    # profile: columns u - n .. u + n (left to right in the image = decreasing bearing); a
    # line's samples are whole image columns (nearest pixel), so the profile is the mean
    # colour of those columns (NaN outside the image)
    n = config.profile_half_width
    k = np.arange(-n, n + 1)
    cols = np.round(columns[:, None] + k[None, :]).astype(int)  # (L, W)
    inside = (cols >= 0) & (cols < image.shape[1])
    used = np.unique(cols[inside])
    column_means = np.zeros((image.shape[1], 3))
    column_means[used] = image[:, used, :3].mean(axis=0, dtype=float)
    colours = np.full((*cols.shape, 3), np.nan)
    colours[inside] = column_means[cols[inside]]
    profiles = colours.transpose(0, 2, 1)  # (L, 3, W)
    return _lines(bearings, profiles, config)
