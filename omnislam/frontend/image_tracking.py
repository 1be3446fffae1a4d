"""The front end's per-image stages: a prepared image grouped and tracked.

``pipeline`` hands ``ImageTracking.add`` every scheduled image in order, prepared (loaded, SIFT,
vertical edges: ``preparation``; in worker processes when pipelined). Here its features are
grouped (``groups``), their rays and bearing sigmas computed (``CameraRig.rays_r``,
``bearing_sigmas``), and they are tracked into landmark tracks (``tracks``) and, when
``FrontendConfig.floor`` asks, floor tracks (``floor_tracks``). ``finish`` gives every image's
sightings under the tracks' final ids: the landmark tracks' (merges followed), then the floor
tracks', whose ids follow the landmark tracks'.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from omnislam.core.types import Bearings
from omnislam.frontend.bearing_noise import bearing_sigmas
from omnislam.frontend.config import FrontendConfig
from omnislam.frontend.floor_tracks import FloorTracker
from omnislam.frontend.groups import group_features
from omnislam.frontend.preparation import PreparedImage
from omnislam.frontend.timing import StageClock
from omnislam.frontend.tracks import LandmarkTracker


@dataclass(frozen=True, slots=True)
class ImageSightings:
    """The tracked keypoints of one image, before the log drops the short tracks.

    Attributes:
        track_ids: (K,) the track of each keypoint.
        rays_r: (K, 3) their rays from the camera's viewpoint, robot frame (not normalised).
        pixels: (K, 2) their image positions [px].
        sigmas_rad: (K,) their bearings' angular sigmas [rad] (not finite or 0: unusable).
    """

    track_ids: np.ndarray
    rays_r: np.ndarray
    pixels: np.ndarray
    sigmas_rad: np.ndarray

    def subset(self, rows: np.ndarray) -> ImageSightings:
        """The sightings at ``rows`` (indices or a mask)."""
        return ImageSightings(self.track_ids[rows], self.rays_r[rows], self.pixels[rows],
                              self.sigmas_rad[rows])

    def followed_by(self, other: ImageSightings, id_offset: int) -> ImageSightings:
        """These sightings, then ``other``'s with their track ids shifted by ``id_offset``."""
        return ImageSightings(
            np.concatenate([self.track_ids, other.track_ids + id_offset]),
            np.vstack([self.rays_r, other.rays_r]),
            np.vstack([self.pixels, other.pixels]),
            np.concatenate([self.sigmas_rad, other.sigmas_rad]),
        )

    def bearings(self, keep_track: np.ndarray) -> tuple[Bearings, np.ndarray]:
        """The bearings of the usable sightings of kept tracks, and their (K, 2) pixels.

        Args:
            keep_track: (T,) True for the tracks the log keeps, by track id.
        """
        ok = keep_track[self.track_ids] & np.isfinite(self.sigmas_rad) & (self.sigmas_rad > 0)
        rays = self.rays_r[ok] / np.linalg.norm(self.rays_r[ok], axis=1, keepdims=True)
        return Bearings(self.track_ids[ok], rays, self.sigmas_rad[ok]), self.pixels[ok]


@dataclass(frozen=True, slots=True)
class _FloorImage:
    """The floor keypoints of one image that were tracked.

    Attributes:
        sightings: their sightings, by the floor tracker's own ids.
        feature_rows: (F,) the rows of the image's features they are.
        landmark_rows: (K,) the rows of the image's features the landmark tracks hold, aligned
            with the image's landmark sightings.
    """

    sightings: ImageSightings
    feature_rows: np.ndarray
    landmark_rows: np.ndarray


@dataclass(frozen=True, slots=True)
class TrackedImages:
    """What the per-image stages give the log.

    Attributes:
        sightings: per processed frame, its tracked keypoints under the tracks' final ids.
        lines: per processed frame whose vertical lines were extracted, its lines.
        track_sightings: (T,) images each track was seen in, by track id (the log keeps the
            tracks seen in at least ``TrackConfig.min_track_length``): the landmark tracks',
            then the floor tracks'.
        floor_ids_from: the floor tracks' first id; None without floor tracks.
        beyond_floor: frame-to-frame matches refused by the floor check.
        prepared_in_workers: images prepared in worker processes.
        prepared_cpu_s: the workers' CPU in their stages [s] (a lower bound of their total).
    """

    sightings: dict[int, ImageSightings]
    lines: dict[int, Any]
    track_sightings: np.ndarray
    floor_ids_from: int | None = None
    beyond_floor: int = 0
    prepared_in_workers: int = 0
    prepared_cpu_s: float = 0.0

    @classmethod
    def none(cls) -> TrackedImages:
        """No image processed."""
        return cls({}, {}, np.zeros(0, dtype=np.int64))


class ImageTracking:
    """Tracks the scheduled images one by one (``add``) and gives their sightings (``finish``).

    Args:
        rig: the camera rig.
        poses_dr: (N, 3) dead-reckoned pose of every frame (the trackers' motion prior).
        config: the front-end configuration.
        rng: RANSAC's generator.
        clock: receives the images' preparation stages (as measured where they ran) and
            ``group``.
        track_clock: receives the tracking's stages (the landmark tracker's own, ``track``
            for the rest of its time, and ``floor``).
    """

    def __init__(self, rig: Any, poses_dr: np.ndarray, config: FrontendConfig,
                 rng: np.random.Generator, clock: StageClock, track_clock: StageClock) -> None:
        self.rig, self.poses_dr, self.config = rig, poses_dr, config
        self.clock, self.track_clock = clock, track_clock
        self.tracker = LandmarkTracker(rig.viewpoint_r, config, rng, track_clock)
        self.floor = FloorTracker(rig.viewpoint_r, config.floor) if config.floor.enabled else None
        self.sightings: dict[int, ImageSightings] = {}
        self.lines: dict[int, Any] = {}
        self.prepared_in_workers = 0
        self.prepared_cpu_s = 0.0
        self._floor_images: dict[int, _FloorImage] = {}

    def add(self, i: int, image: PreparedImage) -> None:
        """Track the prepared image of frame ``i`` (frames in increasing order)."""
        for stage, seconds in image.seconds.items():
            self.clock.add(stage, seconds, image.cpu_seconds[stage])
        if image.in_worker:
            self.prepared_cpu_s += sum(image.cpu_seconds.values())
            self.prepared_in_workers += 1
        features = image.features
        with self.clock("group"):  # here: the groups need scipy, which the workers do not load
            groups = group_features(features.pixels, features.sizes_px, features.contrast,
                                    self.config.groups)
            rays_r = self.rig.rays_r(features.pixels)
            sigmas = bearing_sigmas(self.rig.camera, features, self.config.tracks)
        track_ids, rows = self._track(features.descriptors, groups, rays_r, self.poses_dr[i])
        self.sightings[i] = ImageSightings(track_ids, rays_r[rows], features.pixels[rows],
                                           sigmas[rows])
        if self.floor is not None:
            with self.track_clock("floor"):
                self._floor_images[i] = self._track_floor(features, rays_r, sigmas,
                                                          self.poses_dr[i], rows)
        if image.lines is not None:
            self.lines[i] = image.lines

    def _track(self, descriptors: np.ndarray, groups: np.ndarray, rays_r: np.ndarray,
               pose_dr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The landmark tracker's (track ids, feature rows) of one image; its time outside its
        own stages (match, verify, map, ...) goes to the ``track`` stage."""
        clock = self.track_clock
        before = sum(clock.seconds.values()), sum(clock.cpu_seconds.values())
        start, cpu = time.perf_counter(), time.process_time()
        tracked = self.tracker.process(descriptors, groups, rays_r, pose_dr)
        inner = (sum(clock.seconds.values()) - before[0],
                 sum(clock.cpu_seconds.values()) - before[1])
        clock.add("track", time.perf_counter() - start - inner[0],
                  time.process_time() - cpu - inner[1])
        return tracked.track_ids, tracked.feature_index

    def _track_floor(self, features: Any, rays_r: np.ndarray, sigmas: np.ndarray,
                     pose_dr: np.ndarray, landmark_rows: np.ndarray) -> _FloorImage:
        """The floor tracker's sightings of one image (of its features with usable sigmas)."""
        assert self.floor is not None
        usable = np.isfinite(sigmas) & (sigmas > 0)
        seen = self.floor.process(rays_r, features.descriptors, pose_dr, usable)
        rows = seen.feature_index
        return _FloorImage(
            ImageSightings(seen.track_ids, rays_r[rows], features.pixels[rows], sigmas[rows]),
            rows, landmark_rows,
        )

    def finish(self) -> TrackedImages:
        """Every image's sightings under the landmark tracks' final ids (merged tracks map to
        the landmark they joined), then its floor tracks' (``floor_ids_from`` on)."""
        track_sightings = self.tracker.sightings
        sightings = {i: replace(seen, track_ids=self.tracker.canonical_ids(seen.track_ids))
                     for i, seen in self.sightings.items()}
        floor_ids_from = None
        if self.floor is not None:  # floor tracks take the ids after the landmark tracks'
            kept = track_sightings >= self.config.tracks.min_track_length
            floor_ids_from = int(track_sightings.shape[0])
            floor_seen = np.zeros(self.floor.sightings.shape[0], dtype=np.int64)
            for i, seen in self._floor_images.items():
                # a keypoint that a kept landmark track holds stays that track's alone
                held = seen.landmark_rows[kept[sightings[i].track_ids]]
                mine = seen.sightings.subset(~np.isin(seen.feature_rows, held))
                np.add.at(floor_seen, mine.track_ids, 1)
                sightings[i] = sightings[i].followed_by(mine, floor_ids_from)
            # what the log keeps of the floor tracks: the sightings no landmark track holds
            track_sightings = np.concatenate([track_sightings, floor_seen])
        return TrackedImages(sightings, self.lines, track_sightings, floor_ids_from,
                             self.tracker.beyond_floor, self.prepared_in_workers,
                             self.prepared_cpu_s)
