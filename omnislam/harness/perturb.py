"""Wrong data association on purpose: the robustness experiments of the harness.

``reassign_ids`` re-labels a fraction of the sightings of an ObservationLog (or of a dataset's
own sightings) with the id of *another landmark seen in the same frame*, as a front end that
confuses two features of one image would (a frame that saw a single landmark borrows a wrong
id from the whole input). A sighting re-labelled this way is a gross outlier for its new
landmark: robust kernels and consistency gates must cope with it.

``add_clutter`` adds false range-bearing detections without ids (clutter) to every frame whose
range-bearing sensor reported, a Poisson number per frame, uniform over the span of the data's
own sightings: the robustness of unknown association to detections that are no landmark.

``execute_run`` applies them when a run is given the harness options ``wrong_id_fraction``
(``omnislam run ... --set wrong_id_fraction=0.2``) and ``clutter_per_frame`` (``--set
clutter_per_frame=0.5``); each draw uses its own random stream derived from the run's seed, so
the estimator's stream is the same with and without them.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace

import numpy as np

from omnislam.core.types import UNKNOWN_ID, FrameInput
from omnislam.errors import ConfigError

#: the ``--set`` key that asks ``execute_run`` for re-assigned sightings
WRONG_ID_OPTION = "wrong_id_fraction"

_MODALITIES = ("bearings", "range_bearing", "vertical_lines")


def parse_fraction(text: str) -> float:
    """The value of ``wrong_id_fraction``: a number in [0, 1)."""
    try:
        value = float(text)
    except ValueError:
        raise ConfigError(f"{WRONG_ID_OPTION} must be a number, got {text!r}") from None
    if not 0.0 <= value < 1.0:
        raise ConfigError(f"{WRONG_ID_OPTION} must be in [0, 1), got {value}")
    return value


def reassign_ids(
    frames: Iterable[FrameInput], fraction: float, rng: np.random.Generator
) -> tuple[list[FrameInput], int]:
    """Re-label ``fraction`` of the labelled sightings with another id seen in the same frame.

    Every labelled sighting is picked independently with probability ``fraction``; a picked
    sighting takes an id drawn uniformly from the *other* distinct ids of its frame and
    modality (bearings, range-bearing, vertical lines); in a frame with a single distinct id,
    from the other ids of that modality in the whole input. Unlabelled sightings
    (``UNKNOWN_ID``) are never touched; measurements, sigmas and odometry are unchanged.

    Args:
        frames: the frames to perturb (not modified).
        fraction: probability that a labelled sighting is re-labelled, in [0, 1).
        rng: random generator of the draw.

    Returns:
        (new frames, number of sightings re-labelled).
    """
    if not 0.0 <= fraction < 1.0:
        raise ConfigError(f"{WRONG_ID_OPTION} must be in [0, 1), got {fraction}")
    frames = list(frames)
    everywhere = {name: _all_ids(frames, name) for name in _MODALITIES}
    out: list[FrameInput] = []
    wrong = 0
    for frame in frames:
        changes = {}
        for name in _MODALITIES:
            sightings = getattr(frame, name)
            if sightings is None or len(sightings) == 0:
                continue
            ids, count = _relabel(sightings.landmark_ids, everywhere[name], fraction, rng)
            if count:
                changes[name] = replace(sightings, landmark_ids=ids)
                wrong += count
        out.append(replace(frame, **changes) if changes else frame)
    return out, wrong


def _all_ids(frames: list[FrameInput], name: str) -> np.ndarray:
    """Sorted distinct labelled ids of one modality over all frames."""
    parts = [getattr(f, name).landmark_ids for f in frames if getattr(f, name) is not None]
    if not parts:
        return np.zeros(0, dtype=np.int64)
    ids = np.unique(np.concatenate(parts))
    return ids[ids != UNKNOWN_ID]


def _relabel(
    ids: np.ndarray, everywhere: np.ndarray, fraction: float, rng: np.random.Generator
) -> tuple[np.ndarray, int]:
    labelled = ids != UNKNOWN_ID
    distinct = np.unique(ids[labelled])
    if len(distinct) < 2:  # nothing to confuse in this frame: borrow from the whole input
        distinct = everywhere
    if len(distinct) < 2:
        return ids, 0
    picked = np.flatnonzero(labelled & (rng.random(len(ids)) < fraction))
    if len(picked) == 0:
        return ids, 0
    # an offset in 1..n-1 over the sorted distinct ids never lands on the sighting's own id
    own = np.searchsorted(distinct, ids[picked])
    offset = rng.integers(1, len(distinct), len(picked))
    new = ids.copy()
    new[picked] = distinct[(own + offset) % len(distinct)]
    return new, len(picked)


#: the ``--set`` key that asks ``execute_run`` for false detections added to the sightings
CLUTTER_OPTION = "clutter_per_frame"


def parse_clutter_rate(text: str) -> float:
    """The value of ``clutter_per_frame``: a finite number >= 0 (false detections per frame)."""
    try:
        value = float(text)
    except ValueError:
        raise ConfigError(f"{CLUTTER_OPTION} must be a number, got {text!r}") from None
    return _checked_rate(value)


def _checked_rate(value: float) -> float:
    if not (np.isfinite(value) and value >= 0.0):
        raise ConfigError(f"{CLUTTER_OPTION} must be a finite number >= 0, got {value}")
    return float(value)


def clutter_stream(seed: int) -> np.random.Generator:
    """The random stream of a run's false detections: its own, derived from the run's seed, so
    the estimator draws the same numbers with and without clutter."""
    return np.random.default_rng(np.random.SeedSequence(seed).spawn(2)[1])


def add_clutter(
    frames: Iterable[FrameInput], rate: float, rng: np.random.Generator
) -> tuple[list[FrameInput], int]:
    """Add false range-bearing detections (clutter) without ids to the frames that have
    range-bearing sightings: a detector firing on passing objects, each seen once.

    Every frame whose range-bearing sensor reported (``range_bearing`` not None, even with no
    sighting) gets a Poisson(``rate``) number of detections, uniform in range and bearing over
    the span the data's own sightings cover (the sensor's reach and field of view), with the
    median of the data's stated sigmas, and ``UNKNOWN_ID``: the estimators must tell them from
    landmarks by their association (a tentative stage, an existence index), not by an id.

    Args:
        frames: the frames to perturb (not modified).
        rate: mean false detections per frame, >= 0.
        rng: random generator of the draw.

    Returns:
        (new frames, number of false detections added).

    Raises:
        ConfigError: a positive rate on frames without any range-bearing sighting.
    """
    rate = _checked_rate(rate)
    frames = list(frames)
    if rate == 0.0:
        return frames, 0
    sensed = [f.range_bearing for f in frames if f.range_bearing is not None]
    seen = [rb for rb in sensed if len(rb)]
    if not seen:
        raise ConfigError(f"{CLUTTER_OPTION}: the data has no range-bearing sightings")
    ranges = np.concatenate([rb.ranges_m for rb in seen])
    bearings = np.concatenate([rb.bearings_rad for rb in seen])
    sigma_range = float(np.median(np.concatenate([rb.sigma_range_m for rb in seen])))
    sigma_bearing = float(np.median(np.concatenate([rb.sigma_bearing_rad for rb in seen])))
    low_r, high_r = float(ranges.min()), float(ranges.max())
    low_b, high_b = float(bearings.min()), float(bearings.max())
    out: list[FrameInput] = []
    added = 0
    for frame in frames:
        rb = frame.range_bearing
        n = 0 if rb is None else int(rng.poisson(rate))
        if n == 0:
            out.append(frame)
            continue
        added += n
        clutter = replace(
            rb,
            landmark_ids=np.concatenate([rb.landmark_ids, np.full(n, UNKNOWN_ID)]),
            ranges_m=np.concatenate([rb.ranges_m, rng.uniform(low_r, high_r, n)]),
            bearings_rad=np.concatenate([rb.bearings_rad, rng.uniform(low_b, high_b, n)]),
            sigma_range_m=np.concatenate([rb.sigma_range_m, np.full(n, sigma_range)]),
            sigma_bearing_rad=np.concatenate([rb.sigma_bearing_rad, np.full(n, sigma_bearing)]),
        )
        out.append(replace(frame, range_bearing=clutter))
    return out, added
