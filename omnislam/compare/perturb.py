"""Wrong data association on purpose: the robustness experiments of the harness.

``reassign_ids`` re-labels a fraction of the sightings of an ObservationLog (or of a dataset's
own sightings) with the id of *another landmark seen in the same frame*, as a front end that
confuses two features of one image would (a frame that saw a single landmark borrows a wrong
id from the whole input). A sighting re-labelled this way is a gross outlier for its new
landmark: robust kernels and consistency gates must cope with it.

``execute_run`` applies it when a run is given the harness option ``wrong_id_fraction``
(``omnislam run ... --set wrong_id_fraction=0.2``); the draw uses its own random stream
derived from the run's seed, so the estimator's stream is the same with and without it.
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
