"""Landmark tracks: stable ids across images, re-recognition against the map, pruning.

Per processed image (thesis 4.2, Fig. 4.1):

1. **Frame to frame.** The new image's grouped features are matched (brute force + ratio
   test) against the tracks seen in the last ``window_images`` processed images, validated
   per object (a group's matches count only if enough of the group matched) and verified by
   RANSAC on bearing vectors, seeded by the odometry since the image the tracks were seen in.
   Inliers whose rays could only meet below the floor are refused (``beyond_the_floor``: a
   floor texture repeating along the direction of travel fits the epipolar geometry one
   period on); the others inherit track ids.
2. **Re-recognition (loop closing).** Features still unassigned, or on young tracks (started
   in the last ``young_images`` images), are matched against the descriptors of every older
   landmark of the map (FLANN kd-tree, the thesis's BBF search), with the ratio test taken
   against the nearest landmark of *another* object. Candidates are verified geometrically
   against the earlier image that saw most of them, using the stored bearings of that image;
   the (possibly drifted) dead-reckoning motion is one RANSAC hypothesis and guards the
   rotation. A young track re-recognised as an old landmark is merged into it
   (``canonical_ids``).
3. **Pruning.** A feature of an object recognised in this image that fails to match
   ``prune_after_failures`` times in a row without ever becoming a track is removed from the
   map; an object reduced below the group size absorbs the new features of the image group it
   was recognised in, or is deleted (thesis 4.2, last paragraph).
4. **New tracks.** Unassigned features start tracks; they join the object of the matched
   features of their image group, or found a new object.
"""

from __future__ import annotations

import collections
import dataclasses
import itertools
from dataclasses import dataclass

import numpy as np

from omnislam.core.se import se2_between
from omnislam.frontend.config import FrontendConfig
from omnislam.frontend.groups import NO_GROUP
from omnislam.frontend.matching import (
    MapIndex,
    Matches,
    match_brute_force,
    unique_train,
    validate_objects,
)
from omnislam.frontend.timing import StageClock
from omnislam.frontend.verification import (
    ModelKind,
    RelativePose,
    beyond_the_floor,
    verify_matches,
)

#: ``beyond_the_floor``'s tolerance on the parallax, in inlier thresholds of the verification
FLOOR_SLACK_THRESHOLDS = 3.0


@dataclass(frozen=True, slots=True)
class TrackedFrame:
    """The outcome of tracking one image.

    Attributes:
        feature_index: (K,) indices of the image's features that received a track.
        track_ids: (K,) their track ids.
        from_previous: number of features tracked from the previous image (verified).
        from_map: number of features re-recognised against the map (verified).
        new: number of new tracks started.
        candidates_previous: ratio-test matches to the previous image before verification.
    """

    feature_index: np.ndarray
    track_ids: np.ndarray
    from_previous: int
    from_map: int
    new: int
    candidates_previous: int


def _most_common(values: np.ndarray) -> int:
    """The most frequent value; among equally frequent ones the first to occur (as
    ``collections.Counter(values).most_common(1)``)."""
    unique, first, counts = np.unique(values, return_index=True, return_counts=True)
    return int(unique[np.lexsort((first, -counts))[0]])


class _Growable:
    """A column array that grows by doubling (track attributes)."""

    def __init__(self, dtype: type, width: int | None = None, fill: object = 0) -> None:
        shape = (64,) if width is None else (64, width)
        self.data = np.full(shape, fill, dtype=dtype)
        self.fill = fill

    def ensure(self, size: int) -> None:
        if size > self.data.shape[0]:
            new_shape = (max(size, 2 * self.data.shape[0]), *self.data.shape[1:])
            grown = np.full(new_shape, self.fill, dtype=self.data.dtype)
            grown[: self.data.shape[0]] = self.data
            self.data = grown


class LandmarkTracker:
    """Stateful tracker: feed it the processed images in order (see module docstring).

    Args:
        viewpoint_r: (3,) camera viewpoint in the robot frame [m] (for the odometry prior).
        config: the front-end configuration (matching, verification, tracks, groups).
        rng: random generator for RANSAC.
        clock: accumulates the time spent matching frame to frame (``match``) and against
            the map (``match_map``), verifying (``verify``) and indexing the map (``map``).
    """

    def __init__(
        self, viewpoint_r: np.ndarray, config: FrontendConfig, rng: np.random.Generator,
        clock: StageClock | None = None,
    ) -> None:
        self.clock = clock if clock is not None else StageClock()
        self.viewpoint_r = np.asarray(viewpoint_r, dtype=float)
        self.config = config
        self.rng = rng
        self.n_tracks = 0
        self.n_objects = 0
        self._descriptor = _Growable(np.float32, 128)
        self._object = _Growable(np.int64, fill=-1)
        self._seen = _Growable(np.int64)
        self._last = _Growable(np.int64, fill=-1)
        self._first = _Growable(np.int64, fill=-1)
        self._merged_into: dict[int, int] = {}
        self._failures = _Growable(np.int64)
        self._alive = _Growable(bool, fill=False)
        self._track_frames: list[list[int]] = []
        # per processed image: sorted track ids, their rays, dead-reckoning pose
        self._frame_ids: list[np.ndarray] = []
        self._frame_rays: list[np.ndarray] = []
        self._frame_pose: list[np.ndarray] = []
        self._map: MapIndex | None = None
        # the floor check needs the viewpoint's height above the floor
        self._floor_check = config.verification.below_floor_check and self.viewpoint_r[2] > 0
        #: frame-to-frame inliers refused because they meet below the floor
        self.beyond_floor = 0

    # -- public ---------------------------------------------------------------------------
    @property
    def sightings(self) -> np.ndarray:
        """(T,) number of sightings of every track so far (merged tracks count for the
        landmark they joined)."""
        return self._seen.data[: self.n_tracks].copy()

    @property
    def alive(self) -> np.ndarray:
        """(T,) False for tracks pruned from the map."""
        return self._alive.data[: self.n_tracks].copy()

    @property
    def objects(self) -> np.ndarray:
        """(T,) object (feature group) id of every track."""
        return self._object.data[: self.n_tracks].copy()

    def process(
        self,
        descriptors: np.ndarray,
        groups: np.ndarray,
        rays_r: np.ndarray,
        pose_dr: np.ndarray,
    ) -> TrackedFrame:
        """Track one processed image.

        Args:
            descriptors: (N, 128) float32 descriptors of the image's features.
            groups: (N,) feature-group labels (``NO_GROUP``: not used).
            rays_r: (N, 3) unit bearings of the features in the robot frame (NaN: none).
            pose_dr: (3,) dead-reckoning pose of the robot at this image [m, m, rad] (only
                differences between images are used, as odometry priors).

        Returns:
            The features that received track ids.
        """
        cfg = self.config
        usable = (groups != NO_GROUP) & np.all(np.isfinite(rays_r), axis=1)
        cand = np.flatnonzero(usable)
        desc, rays, grp = descriptors[cand], rays_r[cand], groups[cand]
        assigned = np.full(cand.shape[0], -1, dtype=np.int64)
        frame = len(self._frame_ids)

        # 1. against the tracks of the last few images (frame to frame, bridging short gaps)
        n_candidates = 0
        if frame > 0:
            window = np.flatnonzero(
                self._alive.data[: self.n_tracks]
                & (self._last.data[: self.n_tracks] >= frame - cfg.tracks.window_images)
            )
            with self.clock("match"):
                m = match_brute_force(desc, self._descriptor.data[window], cfg.matching)
            m = Matches(m.query, window[m.train], m.distance)
            m = m.subset(validate_objects(self._object.data[m.train], self._live_members(),
                                          cfg.matching))
            n_candidates = len(m)
            self._verify(m, rays, assigned, pose_dr, guided=True)
        n_previous = int(np.sum(assigned >= 0))

        # 2. re-recognition against the map
        if cfg.tracks.relocalise and self._map is not None and len(self._map):
            self._relocalise(desc, rays, assigned, pose_dr, frame)
        n_map = int(np.sum(assigned >= 0)) - n_previous

        # 3. update the matched tracks and prune (thesis 4.2)
        matched = assigned >= 0
        ids = assigned[matched]
        self._seen.data[ids] += 1
        self._last.data[ids] = frame
        self._failures.data[ids] = 0
        self._descriptor.data[ids] = desc[matched]
        for t in ids:
            self._track_frames[t].append(frame)
        recognised = np.unique(self._object.data[ids])
        self._prune(recognised, ids)

        # 4. new tracks, joining the object their image group was recognised as
        free = np.flatnonzero(~matched)
        new_ids = self._start_tracks(free, grp, assigned, desc, frame)
        assigned[free] = new_ids
        self._absorb_or_delete(recognised)

        order = np.argsort(assigned)
        self._frame_ids.append(assigned[order])
        self._frame_rays.append(rays[order])
        self._frame_pose.append(np.asarray(pose_dr, dtype=float).copy())
        if frame % cfg.tracks.map_rebuild_every == 0:
            with self.clock("map"):
                self._rebuild_map()
        return TrackedFrame(
            feature_index=cand,
            track_ids=assigned.copy(),
            from_previous=n_previous,
            from_map=n_map,
            new=int(free.shape[0]),
            candidates_previous=n_candidates,
        )

    # -- internals ------------------------------------------------------------------------
    def _live_members(self) -> np.ndarray:
        """(n_objects,) number of live tracks per object."""
        alive = self._alive.data[: self.n_tracks]
        return np.bincount(self._object.data[: self.n_tracks][alive],
                           minlength=max(self.n_objects, 1))

    def _relocalise(
        self, desc: np.ndarray, rays: np.ndarray, assigned: np.ndarray, pose_dr: np.ndarray,
        frame: int,
    ) -> None:
        """Re-recognise features against the map landmarks older than the window.

        Queried: the unassigned features and those on **young** tracks (started within the
        last ``young_images`` images). A verified match of a young track to an old landmark
        merges the two: the young track's sightings take the old id (this is how a loop closes
        even when the returning landmark was first picked up as new a few images before).
        """
        cfg = self.config
        assert self._map is not None
        n = self.n_tracks
        window_start = frame - cfg.tracks.window_images
        young = (assigned >= 0) & (
            self._first.data[np.maximum(assigned, 0)] >= frame - cfg.tracks.young_images)
        queried = np.flatnonzero((assigned < 0) | young)
        with self.clock("match_map"):
            q, labels, dist = self._map.query(desc[queried])
        if q.shape[0] == 0:
            return
        m = Matches(queried[q], labels, dist)
        taken = np.zeros(n, dtype=bool)
        taken[assigned[(assigned >= 0) & ~young]] = True
        recent = self._last.data[:n] >= window_start
        m = m.subset(~taken[m.train] & ~recent[m.train] & self._alive.data[m.train])
        m = unique_train(m)
        before = assigned.copy()
        self._verify(m, rays, assigned, pose_dr, guided=False)
        # object-level validation on the verified re-recognitions: an old object counts as
        # recognised only if enough of its features came back (thesis 4.2)
        changed = np.flatnonzero(before != assigned)
        keep = validate_objects(self._object.data[assigned[changed]], self._live_members(),
                                cfg.matching)
        assigned[changed[~keep]] = before[changed[~keep]]
        for k in changed[keep]:
            if before[k] >= 0:
                self._merge(int(before[k]), int(assigned[k]))

    def _merge(self, young: int, old: int) -> None:
        """Give young track ``young``'s sightings to the re-recognised landmark ``old``."""
        self._merged_into[young] = old
        self._alive.data[young] = False
        self._seen.data[old] += self._seen.data[young]
        self._seen.data[young] = 0
        self._last.data[old] = max(self._last.data[old], self._last.data[young])
        for f in self._track_frames[young]:
            ids = self._frame_ids[f]
            ids[ids == young] = old
            order = np.argsort(ids)
            self._frame_ids[f] = ids[order]
            self._frame_rays[f] = self._frame_rays[f][order]
        self._track_frames[old] = sorted(self._track_frames[old] + self._track_frames[young])
        self._track_frames[young] = []

    def canonical_ids(self, ids: np.ndarray) -> np.ndarray:
        """Track ids after merges (a merged young track maps to the landmark it joined)."""
        canon = np.arange(self.n_tracks, dtype=np.int64)
        for young, old in self._merged_into.items():
            canon[young] = old
        while True:  # follow chains of merges
            nxt = canon[canon]
            if np.array_equal(nxt, canon):
                break
            canon = nxt
        return canon[np.asarray(ids, dtype=np.int64)]

    def _verify(
        self, m: Matches, rays: np.ndarray, assigned: np.ndarray, pose_dr: np.ndarray,
        *, guided: bool,
    ) -> None:
        """Verify candidate (feature, track) matches geometrically; assign the inliers.

        Candidates are verified against the earlier image that saw most of them, with the
        stored bearings of that image; features already assigned in this image whose tracks
        that image also saw join the RANSAC as support. Repeated for up to
        ``max_reference_images`` images.
        """
        cfg = self.config
        verification = cfg.verification
        if not guided:  # re-recognition: wider viewpoint changes, keypoints move more
            verification = dataclasses.replace(
                verification,
                threshold_rad=verification.threshold_rad * cfg.tracks.relocalise_threshold_scale)
        # the images that saw each candidate's track, flattened once (candidate by candidate)
        frames_of = [self._track_frames[t] for t in m.train.tolist()]
        seen_in = np.fromiter(itertools.chain.from_iterable(frames_of), dtype=np.int64)
        owner = np.repeat(np.arange(len(m)), [len(f) for f in frames_of])
        for _ in range(cfg.tracks.max_reference_images):
            if len(m) == 0:
                return
            reference = _most_common(seen_in)
            ref_ids = self._frame_ids[reference]
            done = np.flatnonzero(assigned >= 0)
            query = np.concatenate([m.query, done])
            train = np.concatenate([m.train, assigned[done]])
            pos = np.minimum(np.searchsorted(ref_ids, train), ref_ids.shape[0] - 1)
            seen = ref_ids[pos] == train
            is_candidate = np.arange(query.shape[0]) < len(m)
            if np.sum(seen & is_candidate) < cfg.matching.min_object_matches:
                return  # too few left to be worth another RANSAC
            if np.sum(seen) >= cfg.verification.min_inliers:
                delta = se2_between(self._frame_pose[reference], pose_dr)
                prior = RelativePose.from_planar_motion(delta, self.viewpoint_r)
                with self.clock("verify"):
                    result = verify_matches(
                        self._frame_rays[reference][pos[seen]], rays[query[seen]], prior,
                        verification, self.rng, guided=guided,
                    )
                rows = np.flatnonzero(seen)[result.inliers]
                # frame to frame only: re-recognition's baseline is dead reckoning over an
                # unknown stretch (checking its recent references too cost lab40 2.6 % of
                # its true sighting pairs; docs/results/frontend.md, "The below-floor check")
                if guided and self._floor_check and result.kind is ModelKind.ESSENTIAL:
                    assert result.pose is not None
                    below = beyond_the_floor(
                        self._frame_rays[reference][pos[rows]], rays[query[rows]],
                        result.pose.R, prior.t, float(self.viewpoint_r[2]),
                        FLOOR_SLACK_THRESHOLDS * verification.threshold_rad,
                    )
                    self.beyond_floor += int(below.sum())
                    rows = rows[~below]
                ok = np.zeros(query.shape[0], dtype=bool)
                ok[rows] = True
                accept = ok & is_candidate
                assigned[query[accept]] = train[accept]
            left = ~seen[: len(m)]
            m = m.subset(left)
            kept = left[owner]
            seen_in = seen_in[kept]
            owner = (np.cumsum(left) - 1)[owner[kept]]

    def _prune(self, recognised: np.ndarray, matched_ids: np.ndarray) -> None:
        """Remove features that keep failing while their object is recognised (thesis 4.2).

        Every recognition of an object counts one failure for each of its live features that
        did not match. A feature is removed once it has failed ``prune_after_failures``
        recognitions since it was last seen **and** never became a track (fewer than
        ``min_track_length`` sightings): it is not repeatable. Established tracks stay in the
        map however long they are out of view, so that they can close loops.
        """
        if recognised.shape[0] == 0:
            return
        n = self.n_tracks
        members = np.isin(self._object.data[:n], recognised) & self._alive.data[:n]
        members[matched_ids] = False
        self._failures.data[:n][members] += 1
        cfg = self.config.tracks
        spurious = (self._failures.data[:n] >= cfg.prune_after_failures) & (
            self._seen.data[:n] < cfg.min_track_length)
        self._alive.data[:n][members & spurious] = False

    def _start_tracks(
        self, free: np.ndarray, groups: np.ndarray, assigned: np.ndarray, desc: np.ndarray,
        frame: int,
    ) -> np.ndarray:
        """New tracks for features ``free``; returns their ids."""
        count = free.shape[0]
        start = self.n_tracks
        new_ids = np.arange(start, start + count, dtype=np.int64)
        size = start + count
        for column in (self._descriptor, self._object, self._seen, self._last, self._first,
                       self._failures, self._alive):
            column.ensure(size)
        self._descriptor.data[start:size] = desc[free]
        self._seen.data[start:size] = 1
        self._last.data[start:size] = frame
        self._first.data[start:size] = frame
        self._failures.data[start:size] = 0
        self._alive.data[start:size] = True
        self._track_frames.extend([frame] for _ in range(count))
        # object of each image group: the majority object of its matched features, else new
        matched = assigned >= 0
        group_object: dict[int, int] = {}
        if np.any(matched):
            pairs = collections.Counter(
                zip(groups[matched].tolist(), self._object.data[assigned[matched]].tolist(),
                    strict=True)
            )
            for (g, o), _ in sorted(pairs.items(), key=lambda item: -item[1]):
                group_object.setdefault(g, o)
        objects = np.empty(count, dtype=np.int64)
        for k, g in enumerate(groups[free].tolist()):
            if g not in group_object:
                group_object[g] = self.n_objects
                self.n_objects += 1
            objects[k] = group_object[g]
        self._object.data[start:size] = objects
        self.n_tracks = size
        return new_ids

    def _absorb_or_delete(self, recognised: np.ndarray) -> None:
        """Delete recognised objects that fell below the group size (thesis 4.2)."""
        if recognised.shape[0] == 0:
            return
        live = self._live_members()
        small = recognised[live[recognised] < self.config.groups.min_size]
        if small.shape[0]:
            n = self.n_tracks
            self._alive.data[:n][np.isin(self._object.data[:n], small)] = False

    def _rebuild_map(self) -> None:
        n = self.n_tracks
        keep = self._alive.data[:n] & (self._seen.data[:n] >= self.config.tracks.map_min_sightings)
        ids = np.flatnonzero(keep)
        self._map = MapIndex(self._descriptor.data[ids], ids, self._object.data[ids],
                             self.config.matching)
