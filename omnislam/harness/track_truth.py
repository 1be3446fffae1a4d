"""The true points of a front-end log's tracks: the ground truth of landmarks that are tracks.

With per-pixel ground truth (``Sequence.point_map_loader``: synthetic renders) every track of a
front-end log has a true 3-D position (``frontend.evaluation.track_truth``); an estimator whose
landmarks are the log's tracks (it consumes bearings-3d) carries the track ids, so its landmark
error associates by id against these points. They are read at the keypoints' pixels only when
the sequence can (``pixel_points_loader``: the same bits as whole maps, for ~1 % of the pixels)
and cached next to the log (``LOG.truth.npz``, keyed by the log's dataset and configuration):
the grid runner computes them once per log (``cache_track_truth``) and every cell reads them.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from contextlib import nullcontext
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from omnislam._files import NPZ_ERRORS, make_public
from omnislam.datasets.sequence import GroundTruth

#: called with (images done, images to do) while the true points are computed
OnImage = Callable[[int, int], None]


def truth_cache_path(log: str | Path) -> Path:
    """Where the true points of ``log``'s tracks are cached: ``LOG.truth.npz`` next to it."""
    log = Path(log)
    return log.with_name(log.name + ".truth.npz")


def with_track_truth(
    sequence: Any,
    replay: Any,
    log: Path,
    progress: bool = False,
    on_image: OnImage | None = None,
) -> tuple[GroundTruth, bool]:
    """Ground truth whose landmarks are the true points of the front end's tracks.

    Args:
        sequence: the loaded Sequence.
        replay: its front-end ObservationLog, read from ``log``.
        log: the log's path (the cache is next to it).
        progress: show a progress line while the points are computed.
        on_image: called with (images done, images to do) while they are computed.

    Returns:
        (ground truth, True) with the track landmarks, or (the sequence's, False) without
        per-pixel ground truth.
    """
    if sequence.point_map_loader is None:
        return sequence.ground_truth, False
    cache = truth_cache_path(log)
    key = f"{replay.dataset_id}:{replay.config_hash}"
    cached = _read_cache(cache, key)
    if cached is None:
        cached = _true_track_points(sequence, replay, log.name, progress, on_image)
        _write_cache(cache, key, *cached)
    ids, points = cached
    truth = replace(
        sequence.ground_truth,
        landmark_ids=ids,
        landmarks_w=points,
        note=sequence.ground_truth.note
        + "; landmarks: true 3-D points of the front end's tracks (per-pixel ground truth)",
    )
    return truth, True


def cache_track_truth(
    sequence: Any,
    log: str | Path,
    progress: bool = False,
    on_image: OnImage | None = None,
) -> None:
    """Compute the true points of a log's tracks into the cache next to it, once.

    The grid runner calls it in its own process before the cells start, so that workers running
    cells of the same log read the cache instead of each computing it (``with_track_truth``;
    ``on_image`` is called with (images done, images to do)). Nothing to do for a sequence
    without per-pixel ground truth.
    """
    if sequence.point_map_loader is None:
        return
    from omnislam.frontend.observation_log import dataset_fingerprint, load_observation_log

    replay = load_observation_log(Path(log), dataset_id=dataset_fingerprint(sequence))
    with_track_truth(sequence, replay, Path(log), progress=progress, on_image=on_image)


def _read_cache(cache: Path, key: str) -> tuple[np.ndarray, np.ndarray] | None:
    """(track ids, true points) cached under ``key``; None when absent, stale or truncated."""
    try:
        with np.load(cache, allow_pickle=False) as data:
            if str(data["key"]) == key:
                return data["ids"], data["points_w"]
    except NPZ_ERRORS:  # no cache entry, or a truncated one: recompute
        pass
    return None


def _write_cache(cache: Path, key: str, ids: np.ndarray, points_w: np.ndarray) -> None:
    """Write the cache entry atomically (a temporary file next to it, then rename)."""
    with tempfile.NamedTemporaryFile(dir=cache.parent, suffix=".npz", delete=False) as tmp:
        np.savez_compressed(tmp, key=np.array(key), ids=ids, points_w=points_w)
    make_public(tmp.name)
    os.replace(tmp.name, cache)


def _true_track_points(
    sequence: Any, replay: Any, name: str, progress: bool, on_image: OnImage | None
) -> tuple[np.ndarray, np.ndarray]:
    """(track ids, true points in the world [m]) of every track of ``replay``, computed."""
    from omnislam._progress import Progress
    from omnislam.frontend.evaluation import sampled_true_sightings, track_truth, true_sightings

    images = sum(
        f.bearings is not None and px is not None and len(f.bearings) > 0
        for f, px in zip(replay.frames, replay.pixels, strict=True)
    )
    done = 0

    def counted(loader: Callable[..., np.ndarray]) -> Callable[..., np.ndarray]:
        """``loader``, counting each image it reads on the progress line and ``on_image``."""

        def load(*args: Any) -> np.ndarray:
            nonlocal done
            points = loader(*args)
            done += 1
            if bar is not None:
                bar.advance()
            if on_image is not None:
                on_image(done, images)
            return points

        return load

    label = f"true points of the tracks of {name}"
    with Progress(label, images, "img") if progress else nullcontext() as bar:
        camera = getattr(sequence.calibration, "camera", None)
        if sequence.pixel_points_loader is not None and camera is not None:
            # the keypoints' pixels only: bit-identical to whole maps, ~50x less work
            shape = (int(camera.height), int(camera.width))
            sightings = sampled_true_sightings(
                replay, counted(sequence.pixel_points_loader), shape
            )
        else:
            sightings = true_sightings(replay, counted(sequence.point_map_loader))
        return track_truth(sightings)
