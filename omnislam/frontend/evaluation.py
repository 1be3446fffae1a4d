"""Quality of an ObservationLog against per-pixel ground truth (synthetic renders).

The renderer knows the world point every pixel sees, so every sighting of the log has a true
3-D point. A track is correct when all its sightings see the same point: **track precision**
is the fraction of sighting pairs within one track whose true points lie within ``tol_m`` of
each other. **Re-association after a return**: a sighting whose true point was last seen
``min_gap_s`` or more before, and first seen ``min_age_s`` or more before, is a landmark
"visible again"; it is re-associated when its track id is one of the ids that point had.
**Bearing noise**: the angle between each logged bearing of a consistent track and the
direction, from the true viewpoint, to the track's true point, against the bearing's sigma.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from omnislam.frontend.observation_log import ObservationLog

#: two sightings of one world point see true points closer than this [m]
SAME_POINT_M = 0.05


@dataclass(frozen=True, slots=True)
class Sightings:
    """Every sighting of a log, flattened.

    Attributes:
        frame: (S,) frame index; stamp_s: (S,) time [s]; track: (S,) track id;
        points_w: (S, 3) true world point [m] (NaN: the pixel sees nothing).
    """

    frame: np.ndarray
    stamp_s: np.ndarray
    track: np.ndarray
    points_w: np.ndarray


#: ``sample(rows, cols)``: the (K, 3) world points [m] of K integer pixel centres of one image
#: (NaN where none): a whole map indexed, or ``Sequence.pixel_points_loader`` at that frame
PixelSampler = Callable[[np.ndarray, np.ndarray], np.ndarray]


def point_at_pixels(points_w: np.ndarray, pixels: np.ndarray) -> np.ndarray:
    """True world points at sub-pixel keypoint positions.

    Bilinear interpolation of the per-pixel map between the four surrounding pixel centres
    when they see one surface patch (all within ``SAME_POINT_M`` of each other); the nearest
    pixel's point across depth discontinuities.

    Args:
        points_w: (H, W, 3) world point of every pixel centre [m], NaN where none.
        pixels: (K, 2) ``[u, v]`` [px].

    Returns:
        (K, 3) world points [m] (NaN where unknown).
    """
    return sampled_point_at_pixels(
        lambda rows, cols: points_w[rows, cols], points_w.shape[:2], pixels
    )


def sampled_point_at_pixels(
    sample: PixelSampler, shape: tuple[int, int], pixels: np.ndarray
) -> np.ndarray:
    """``point_at_pixels`` reading only the pixel centres it needs (four around each keypoint
    and the nearest), in one ``sample`` call.

    Args:
        sample: the world points of pixel centres of the image (``PixelSampler``).
        shape: (H, W) of the image's map.
        pixels: (K, 2) ``[u, v]`` [px].

    Returns:
        (K, 3) world points [m] (NaN where unknown).
    """
    h, w = shape
    k = pixels.shape[0]
    u = np.clip(pixels[:, 0], 0, w - 1)
    v = np.clip(pixels[:, 1], 0, h - 1)
    u0 = np.clip(np.floor(u).astype(int), 0, w - 2)
    v0 = np.clip(np.floor(v).astype(int), 0, h - 2)
    rows = np.concatenate([v0, v0, v0 + 1, v0 + 1, np.round(v).astype(int)])
    cols = np.concatenate([u0, u0 + 1, u0, u0 + 1, np.round(u).astype(int)])
    flat, inverse = np.unique(rows * w + cols, return_inverse=True)
    values = sample(flat // w, flat % w)[inverse.reshape(-1)]
    c00, c10, c01, c11, at_nearest = (values[j * k:(j + 1) * k] for j in range(5))
    a, b = (u - u0)[:, None], (v - v0)[:, None]
    corners = np.stack([c00, c10, c01, c11], axis=1).astype(float)
    bilinear = (1 - a) * (1 - b) * c00 + a * (1 - b) * c10 + (1 - a) * b * c01 + a * b * c11
    spread = np.max(np.linalg.norm(corners - corners.mean(axis=1, keepdims=True), axis=2), axis=1)
    smooth = np.all(np.isfinite(corners), axis=(1, 2)) & (spread < SAME_POINT_M)
    nearest = at_nearest.astype(float)
    return np.where(smooth[:, None], bilinear, nearest)


def true_sightings(log: ObservationLog, points_w_of: Callable[[int], np.ndarray]) -> Sightings:
    """Look up the true world point of every sighting.

    Args:
        log: the log (its ``pixels`` locate the keypoints).
        points_w_of: ``points_w_of(frame)`` -> (H, W, 3) world point of each pixel, NaN none.
    """
    return _true_sightings(log, lambda frame, px: point_at_pixels(points_w_of(frame), px))


def sampled_true_sightings(
    log: ObservationLog,
    pixel_points_of: Callable[[int, np.ndarray, np.ndarray], np.ndarray],
    shape: tuple[int, int],
) -> Sightings:
    """``true_sightings`` reading each image's true points at its keypoints' pixels only.

    Args:
        log: the log.
        pixel_points_of: ``pixel_points_of(frame, rows, cols)`` -> (K, 3) world points of
            those pixel centres (``Sequence.pixel_points_loader``).
        shape: (H, W) of the images' maps.
    """
    return _true_sightings(
        log,
        lambda frame, px: sampled_point_at_pixels(
            lambda rows, cols: pixel_points_of(frame, rows, cols), shape, px
        ),
    )


def _true_sightings(
    log: ObservationLog, points_at: Callable[[int, np.ndarray], np.ndarray]
) -> Sightings:
    """The sightings of ``log`` with ``points_at(frame, pixels)`` as their true points."""
    frames, stamps, tracks, points = [], [], [], []
    for frame, px in zip(log.frames, log.pixels, strict=True):
        if frame.bearings is None or px is None or len(frame.bearings) == 0:
            continue
        k = len(frame.bearings)
        frames.append(np.full(k, frame.index))
        stamps.append(np.full(k, frame.stamp_s))
        tracks.append(frame.bearings.landmark_ids)
        points.append(points_at(frame.index, px))
    if not frames:
        return Sightings(np.zeros(0, int), np.zeros(0), np.zeros(0, int), np.zeros((0, 3)))
    return Sightings(
        np.concatenate(frames),
        np.concatenate(stamps),
        np.concatenate(tracks),
        np.concatenate(points),
    )


def track_precision(s: Sightings, tol_m: float = SAME_POINT_M) -> tuple[float, int]:
    """Fraction of same-track sighting pairs whose true points are within ``tol_m``.

    Returns:
        ``(precision, pairs)``; pairs with an unknown true point are not counted.
    """
    good = total = 0
    known = np.all(np.isfinite(s.points_w), axis=1)
    order = np.argsort(s.track[known], kind="stable")
    tracks = s.track[known][order]
    points = s.points_w[known][order]
    bounds = np.flatnonzero(np.diff(tracks)) + 1
    for p in np.split(points, bounds):
        if p.shape[0] < 2:
            continue
        d = np.linalg.norm(p[:, None, :] - p[None, :, :], axis=2)
        iu = np.triu_indices(p.shape[0], 1)
        good += int(np.sum(d[iu] <= tol_m))
        total += iu[0].shape[0]
    return (good / total if total else 1.0), total


def track_truth(s: Sightings, tol_m: float = SAME_POINT_M) -> tuple[np.ndarray, np.ndarray]:
    """The true 3-D point of every consistent track: ground truth for landmark error.

    A track's point is the median of its sightings' true points; a track is kept only when every
    sighting with a known point lies within ``tol_m`` of that median (a track that wandered
    between surfaces has no single true position and is left out of the evaluation).

    Returns:
        (ids (T,), points_w (T, 3) [m]).
    """
    known = np.all(np.isfinite(s.points_w), axis=1)
    order = np.argsort(s.track[known], kind="stable")
    tracks = s.track[known][order]
    points = s.points_w[known][order]
    bounds = np.flatnonzero(np.diff(tracks)) + 1
    ids, centres = [], []
    for t, p in zip(np.split(tracks, bounds), np.split(points, bounds), strict=True):
        if not t.size:
            continue
        centre = np.median(p, axis=0)
        if np.all(np.linalg.norm(p - centre, axis=1) <= tol_m):
            ids.append(int(t[0]))
            centres.append(centre)
    if not ids:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 3))
    return np.array(ids, dtype=np.int64), np.array(centres)


def track_lengths(log: ObservationLog) -> np.ndarray:
    """(T,) number of sightings of every track id in the log."""
    ids = [f.bearings.landmark_ids for f in log.frames if f.bearings is not None]
    if not ids:
        return np.zeros(0, dtype=np.int64)
    _, counts = np.unique(np.concatenate(ids), return_counts=True)
    return counts


def sightings_per_image(log: ObservationLog) -> np.ndarray:
    """(M,) number of bearings on every processed image."""
    return np.array([len(f.bearings) for f in log.frames if f.bearings is not None])


def reassociation_rate(
    s: Sightings, min_age_s: float = 60.0, min_gap_s: float = 20.0, tol_m: float = SAME_POINT_M
) -> tuple[float, int]:
    """Fraction of landmarks visible again after a return that keep their original track id.

    A sighting counts as a return when its true point (within ``tol_m``) was first seen at
    least ``min_age_s`` before and not seen during the last ``min_gap_s``; it is
    re-associated when its track id is one the point had before.

    Returns:
        ``(rate, returns)``.
    """
    known = np.all(np.isfinite(s.points_w), axis=1)
    idx = np.flatnonzero(known)
    if idx.shape[0] == 0:
        return 0.0, 0
    tree = cKDTree(s.points_w[idx])
    neighbours = tree.query_ball_point(s.points_w[idx], tol_m)
    good = returns = 0
    for a, near in enumerate(neighbours):
        near = idx[np.asarray(near, dtype=np.int64)]
        i = idx[a]
        earlier = near[s.stamp_s[near] < s.stamp_s[i]]
        if earlier.shape[0] == 0:
            continue
        if s.stamp_s[i] - s.stamp_s[earlier].min() < min_age_s:
            continue
        if s.stamp_s[i] - s.stamp_s[earlier].max() < min_gap_s:
            continue
        returns += 1
        good += int(s.track[i] in set(s.track[earlier].tolist()))
    return (good / returns if returns else 0.0), returns


def visible_lines(
    lines_w: np.ndarray,
    wTr: np.ndarray,
    rig: object,
    points_w: np.ndarray,
    tol_m: float = 0.12,
) -> tuple[np.ndarray, np.ndarray]:
    """The vertical-line landmarks visible in one image and their true robot-frame bearings.

    A line (x, y) is visible when its point at the camera's height projects into the usable
    image and the renderer's world point at that pixel (or up to 3 px aside) lies within
    ``tol_m`` of the line (it is not hidden behind something).

    Args:
        lines_w: (L, 2) line positions on the floor [m].
        wTr: (4, 4) true robot pose.
        rig: the camera rig.
        points_w: (H, W, 3) the renderer's world point of every pixel.

    Returns:
        (indices into ``lines_w`` (V,), bearings (V,) [rad]).
    """
    R, t = wTr[:3, :3], wTr[:3, 3]
    viewpoint_r = rig.viewpoint_r  # type: ignore[attr-defined]
    index, out = [], []
    for k, (x, y) in enumerate(np.asarray(lines_w, dtype=float).reshape(-1, 2)):
        p_w = np.array([x, y, (R @ viewpoint_r + t)[2]])
        p_r = (p_w - t) @ R
        pixels, valid = rig.project_r(p_r[None])  # type: ignore[attr-defined]
        if not valid[0] or not rig.camera.in_mask(pixels)[0]:  # type: ignore[attr-defined]
            continue
        u, v = np.round(pixels[0]).astype(int)
        cols = np.clip(u + np.arange(-3, 4), 0, points_w.shape[1] - 1)
        seen = points_w[min(max(v, 0), points_w.shape[0] - 1), cols]
        near = np.hypot(seen[:, 0] - x, seen[:, 1] - y) < tol_m
        if np.any(near):
            d_r = p_r - viewpoint_r
            index.append(k)
            out.append(np.arctan2(d_r[1], d_r[0]))
    return np.array(index, dtype=np.int64), np.array(out)


def visible_line_bearings(
    lines_w: np.ndarray,
    wTr: np.ndarray,
    rig: object,
    points_w: np.ndarray,
    tol_m: float = 0.12,
) -> np.ndarray:
    """True robot-frame bearings of the vertical-line landmarks visible in one image
    (``visible_lines`` without the indices)."""
    return visible_lines(lines_w, wTr, rig, points_w, tol_m)[1]


def bearing_errors(detected_rad: np.ndarray, true_rad: np.ndarray) -> np.ndarray:
    """(T,) angular distance from each true bearing to the nearest detected one [rad]."""
    if np.asarray(detected_rad).size == 0:
        return np.full(np.asarray(true_rad).shape, np.inf)
    d = np.asarray(detected_rad)[None, :] - np.asarray(true_rad)[:, None]
    return np.abs((d + np.pi) % (2 * np.pi) - np.pi).min(axis=1)


@dataclass(frozen=True, slots=True)
class BearingResiduals:
    """Logged bearings of consistent tracks against their tracks' true points.

    Attributes:
        angle_rad: (K,) angle between the logged bearing and the true direction [rad].
        sigma_rad: (K,) the bearing's logged angular std [rad].
        dof: (K,) ``n / (n - 1)`` for a track of n sightings: the true point is the mean of
            the track's own sightings, which shrinks their residuals by ``(n - 1) / n`` on
            average; multiplying squared residuals by this undoes it.
        track: (K,) track id.
    """

    angle_rad: np.ndarray
    sigma_rad: np.ndarray
    dof: np.ndarray
    track: np.ndarray


def bearing_residuals(
    log: ObservationLog, s: Sightings, wTr: np.ndarray, viewpoint_r: np.ndarray,
    tol_m: float = SAME_POINT_M,
) -> BearingResiduals:
    """Residuals of the bearings of consistent tracks (``track_truth``) [rad].

    A track's true point is the mean of its sightings' true points (every one within
    ``tol_m`` of their median); a bearing's residual is its angle to the direction from the
    true viewpoint to that point.

    Args:
        log: the log whose sightings ``s`` are (``true_sightings(log, ...)``, same order).
        s: its sightings with true points.
        wTr: (N, 4, 4) true robot poses of every frame.
        viewpoint_r: (3,) the camera's viewpoint in the robot frame [m].
    """
    rays, sigmas = [], []
    for frame, px in zip(log.frames, log.pixels, strict=True):
        if frame.bearings is None or px is None or len(frame.bearings) == 0:
            continue
        rays.append(frame.bearings.unit_vectors_r)
        sigmas.append(frame.bearings.sigmas_rad)
    if not rays:
        empty = np.zeros(0)
        return BearingResiduals(empty, empty, empty, np.zeros(0, dtype=np.int64))
    rays_r, sigma = np.concatenate(rays), np.concatenate(sigmas)
    known = np.flatnonzero(np.all(np.isfinite(s.points_w), axis=1))
    order = known[np.argsort(s.track[known], kind="stable")]
    bounds = np.flatnonzero(np.diff(s.track[order])) + 1
    keep, centres, dof = [], [], []
    for rows in np.split(order, bounds):
        if rows.size < 2:
            continue
        p = s.points_w[rows]
        if np.any(np.linalg.norm(p - np.median(p, axis=0), axis=1) > tol_m):
            continue  # the track wandered between surfaces: no single true point
        keep.append(rows)
        centres.append(np.repeat(p.mean(axis=0)[None], rows.size, axis=0))
        dof.append(np.full(rows.size, rows.size / (rows.size - 1.0)))
    if not keep:
        empty = np.zeros(0)
        return BearingResiduals(empty, empty, empty, np.zeros(0, dtype=np.int64))
    rows, centre, dof_k = np.concatenate(keep), np.concatenate(centres), np.concatenate(dof)
    pose = np.asarray(wTr)[s.frame[rows]]
    R, t = pose[:, :3, :3], pose[:, :3, 3]
    origin_w = np.einsum("nij,j->ni", R, np.asarray(viewpoint_r, dtype=float)) + t
    to_point_r = np.einsum("nji,nj->ni", R, centre - origin_w)
    to_point_r /= np.linalg.norm(to_point_r, axis=1, keepdims=True)
    cos = np.clip(np.sum(to_point_r * rays_r[rows], axis=1), -1.0, 1.0)
    return BearingResiduals(np.arccos(cos), sigma[rows], dof_k, s.track[rows])


#: a bearing error is 2-D (on the tangent plane): E[(angle / sigma)^2] = 2 when calibrated
_TANGENT_DOF = 2.0


def noise_ratio(res: BearingResiduals, trim: float = 0.01) -> float:
    """Per-axis RMS of the residuals in units of their logged sigma (1: calibrated).

    ``sqrt(mean(dof * (angle / sigma)^2) / 2)`` over all but the ``trim`` largest normalised
    residuals (gross errors, left to the estimators' gates and robust kernels), corrected for
    the trimming as if the residuals were Gaussian (the mean of the chi-square(2) below its
    ``1 - trim`` quantile). Below 1 the logged sigmas are too large, above 1 too small.
    """
    if res.angle_rad.size == 0:
        return float("nan")
    z2 = np.sort(res.dof * (res.angle_rad / res.sigma_rad) ** 2)
    z2 = z2[: max(1, int(np.ceil((1.0 - trim) * z2.size)))]
    quantile = -_TANGENT_DOF * np.log(trim) if trim > 0 else np.inf
    kept_mean = _TANGENT_DOF - (quantile * trim / (1.0 - trim) if trim > 0 else 0.0)
    return float(np.sqrt(np.mean(z2) / kept_mean))


def noise_ratio_median(res: BearingResiduals) -> float:
    """The same from the median: ``median(angle / sigma) / sqrt(2 ln 2)`` (1: calibrated)."""
    if res.angle_rad.size == 0:
        return float("nan")
    z = np.sqrt(res.dof) * res.angle_rad / res.sigma_rad
    return float(np.median(z) / np.sqrt(2.0 * np.log(2.0)))


@dataclass(frozen=True, slots=True)
class TriangulationErrors:
    """Landmark error the front end alone allows: its tracks triangulated from the true poses.

    Attributes:
        track: (T,) ids of the consistent tracks with at least ``min_sightings`` sightings.
        error_m: (T,) distance of the least-squares intersection of a track's rays (from the
            true viewpoints) to its true point [m].
        parallax_rad: (T,) the largest angle between two of its rays [rad].
    """

    track: np.ndarray
    error_m: np.ndarray
    parallax_rad: np.ndarray


def triangulation_errors(
    log: ObservationLog, s: Sightings, wTr: np.ndarray, viewpoint_r: np.ndarray,
    min_sightings: int = 3, tol_m: float = SAME_POINT_M,
) -> TriangulationErrors:
    """Triangulate every consistent track from the true poses (``core.triangulation``'s least
    squares, vectorised over tracks) and compare with its true point (``track_truth``).

    No back end can place a landmark much better than this from the same sightings, so it
    measures what the front end's bearings allow, independently of the estimators.
    """
    rays = [f.bearings.unit_vectors_r for f, px in zip(log.frames, log.pixels, strict=True)
            if f.bearings is not None and px is not None and len(f.bearings)]
    ids, truth = track_truth(s, tol_m)
    if not rays or ids.size == 0:
        empty = np.zeros(0)
        return TriangulationErrors(np.zeros(0, dtype=np.int64), empty, empty)
    rays_r = np.concatenate(rays)
    pos = np.minimum(np.searchsorted(ids, s.track), ids.size - 1)
    rows = np.flatnonzero(ids[pos] == s.track)
    slot = pos[rows]
    pose = np.asarray(wTr)[s.frame[rows]]
    R, t = pose[:, :3, :3], pose[:, :3, 3]
    origin = np.einsum("nij,j->ni", R, np.asarray(viewpoint_r, dtype=float)) + t
    d = np.einsum("nij,nj->ni", R, rays_r[rows])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    projector = np.eye(3)[None] - d[:, :, None] * d[:, None, :]
    A = np.zeros((ids.size, 3, 3))
    b = np.zeros((ids.size, 3))
    np.add.at(A, slot, projector)
    np.add.at(b, slot, np.einsum("nij,nj->ni", projector, origin))
    count = np.bincount(slot, minlength=ids.size)
    # parallax: the largest angle from the track's mean direction, twice (close to the
    # largest pairwise angle for the small spreads of a track)
    mean = np.zeros((ids.size, 3))
    np.add.at(mean, slot, d)
    mean /= np.maximum(np.linalg.norm(mean, axis=1, keepdims=True), 1e-12)
    spread = np.zeros(ids.size)
    np.maximum.at(spread, slot, np.arccos(np.clip(np.sum(d * mean[slot], axis=1), -1, 1)))
    keep = (count >= min_sightings) & (np.linalg.cond(A) < 1e12)
    point = np.linalg.solve(A[keep], b[keep][..., None])[..., 0]
    return TriangulationErrors(ids[keep], np.linalg.norm(point - truth[keep], axis=1),
                               2.0 * spread[keep])
