"""Floor tracks: keypoints on the floor, matched where the odometry moves them.

The landmark tracker (``tracks.py``) finds a keypoint again by its descriptor (Lowe's ratio test)
and keeps only keypoints of feature groups that are recognised as a whole (thesis 4.1.3, 4.2).
A tiled floor's corners lie apart, so they form no groups and are dropped (on the demo: with the
groups and the object rule relaxed to single keypoints, 33 low tracks appear, against 1;
docs/results/frontend.md); and every corner looks like the next, which leaves the ratio test no
distinct nearest neighbour. Yet the floor is what gives a bearing-only map its metric scale
(``graphslam.floor_scale``): a point on the floor seen at depression delta from the
viewpoint's height h lies ``h / tan(delta)`` away.

The same geometry finds the corners again. A bearing ``u`` (robot frame) at least
``min_depression_deg`` below the horizon meets the floor plane at

    p_r = v_xy + (h / -u_z) u_xy        (v: the viewpoint in the robot frame, h = v_z)

which the dead-reckoned pose places in the world. Between two images the odometry errs by
millimetres, while the tiles are tens of centimetres apart, so a floor track is continued by the
keypoint whose floor point lies within ``gate_m`` of the track's (and whose descriptor is
close enough); the pairs are assigned one to one, nearest first. A keypoint fixed to the robot
(its own body in the mirror) moves with it and starts a new track in every image; such tracks,
like every track seen fewer than ``tracks.min_track_length`` times, are dropped from the log.

The odometry only gates the matching; the bearings are the keypoints' own, so the scale the
floor gives (``floor_scale``) is measured, not copied: a gate of 4 cm is ~20x the odometry's
error over one image step on the synthetic worlds and far wider than any scale error.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from omnislam.core.se import se2_transform_points
from omnislam.core.triangulation import floor_points_r
from omnislam.frontend.config import FloorTrackConfig


@dataclass(frozen=True, slots=True)
class FloorSightings:
    """The floor keypoints of one image that were tracked.

    Attributes:
        track_ids: (K,) the floor tracker's own track ids (0, 1, ... in order of creation).
        feature_index: (K,) the rows of the image's features they are.
    """

    track_ids: np.ndarray
    feature_index: np.ndarray


class FloorTracker:
    """Tracks floor keypoints across images by the floor plane and the dead-reckoned poses.

    Args:
        viewpoint_r: (3,) the camera's single viewpoint in the robot frame; its z is the
            height above the floor [m] (> 0).
        config: the gate, the descriptor bound, the window.
    """

    def __init__(self, viewpoint_r: np.ndarray, config: FloorTrackConfig) -> None:
        viewpoint = np.asarray(viewpoint_r, dtype=float)
        if viewpoint.shape != (3,) or not viewpoint[2] > 0:
            raise ValueError(f"floor tracks need a viewpoint above the floor, got {viewpoint}")
        self._v = viewpoint
        self._config = config
        self._max_uz = -np.sin(np.radians(config.min_depression_deg))
        self._point = np.zeros((64, 2))  # per track: its latest floor point (world, dead reckoned)
        self._descriptor = np.zeros((64, 128), dtype=np.float32)
        self._last = np.zeros(64, dtype=np.int64)  # the image number of its latest sighting
        self._count = np.zeros(64, dtype=np.int64)
        self._tracks = 0
        self._image = -1

    @property
    def sightings(self) -> np.ndarray:
        """(T,) sightings of every floor track so far, by track id."""
        return self._count[: self._tracks].copy()

    def process(
        self,
        rays_r: np.ndarray,
        descriptors: np.ndarray,
        pose_dr: np.ndarray,
        candidates: np.ndarray | None = None,
    ) -> FloorSightings:
        """Track one image's floor keypoints.

        Args:
            rays_r: (N, 3) the keypoints' bearings in the robot frame (any norm; NaN rows are
                skipped).
            descriptors: (N, 128) their SIFT descriptors.
            pose_dr: (3,) the image's dead-reckoned pose (x, y, theta).
            candidates: (N,) bool, the keypoints that may be floor keypoints (default: all);
                the pipeline leaves out those the landmark tracker took.

        Returns:
            The floor keypoints of this image that continue or start a track.
        """
        self._image += 1
        rays = np.asarray(rays_r, dtype=float)
        norms = np.linalg.norm(rays, axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            u = rays / norms[:, None]
            low = np.isfinite(u).all(axis=1) & (u[:, 2] <= self._max_uz)
        if candidates is not None:
            low &= np.asarray(candidates, dtype=bool)
        rows = np.flatnonzero(low)
        if not rows.size:
            return FloorSightings(np.zeros(0, dtype=np.int64), rows)
        floor_r, _ = floor_points_r(u[rows], np.zeros(rows.size), self._v[2])
        floor_w = se2_transform_points(pose_dr, self._v[:2] + floor_r)
        desc = np.asarray(descriptors, dtype=np.float32)[rows]
        ids = self._continue(floor_w, desc)
        fresh = np.flatnonzero(ids < 0)
        if fresh.size:
            self._reserve(self._tracks + fresh.size)
            ids[fresh] = np.arange(self._tracks, self._tracks + fresh.size)
            self._tracks += fresh.size
        self._point[ids] = floor_w
        self._descriptor[ids] = desc
        self._last[ids] = self._image
        self._count[ids] += 1
        return FloorSightings(ids, rows)

    def _continue(self, floor_w: np.ndarray, desc: np.ndarray) -> np.ndarray:
        """(M,) the track each candidate continues, or -1: pairs within the gate and the
        descriptor bound, assigned one to one, nearest floor points first."""
        ids = np.full(floor_w.shape[0], -1, dtype=np.int64)
        live = np.flatnonzero(
            self._image - self._last[: self._tracks] <= self._config.window_images
        )
        if not live.size:
            return ids
        gap = np.linalg.norm(floor_w[:, None, :] - self._point[live][None, :, :], axis=2)
        m, t = np.nonzero(gap <= self._config.gate_m)
        if not m.size:
            return ids
        d_desc = np.linalg.norm(desc[m] - self._descriptor[live[t]], axis=1)
        ok = d_desc <= self._config.max_descriptor_distance
        m, t, dist = m[ok], t[ok], gap[m[ok], t[ok]]
        taken = np.zeros(live.size, dtype=bool)
        for k in np.argsort(dist, kind="stable"):
            if ids[m[k]] < 0 and not taken[t[k]]:
                ids[m[k]] = live[t[k]]
                taken[t[k]] = True
        return ids

    def _reserve(self, size: int) -> None:
        if size <= self._point.shape[0]:
            return
        new = max(size, 2 * self._point.shape[0])
        grow = new - self._point.shape[0]
        self._point = np.vstack([self._point, np.zeros((grow, 2))])
        self._descriptor = np.vstack([self._descriptor, np.zeros((grow, 128), np.float32)])
        self._last = np.concatenate([self._last, np.zeros(grow, dtype=np.int64)])
        self._count = np.concatenate([self._count, np.zeros(grow, dtype=np.int64)])
