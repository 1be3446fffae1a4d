"""The frames an estimator is fed: the dataset's own, or a front-end log's, as the run alters them.

``fed_frames`` makes them in the order the harness applies its steps, each a function here:

1. the frames: the dataset's own sightings, or the replay of a front-end ``ObservationLog``
   (``load_log``) whose laser odometry replaces the wheels' for the SLAM estimators (dead
   reckoning keeps the wheels', the baseline they are compared with:
   ``EstimatorEntry.wheel_odometry``);
2. a log's range-bearing rows with the ids this loader gives its own sightings
   (``own_sighting_ids``: a loader option that hides the ids reaches the estimator);
3. without the floor tracks' bearings unless the estimator models the floor
   (``frames_for_estimator``);
4. a fraction of the sightings re-labelled with wrong ids (``perturb.reassign_ids``);
5. what the estimator is told about the data (``sequence_info``), from the frames so far:
   the clutter that follows is a fault injected, not a property of the data;
6. false range-bearing detections added (``perturb.add_clutter``).

Each fault draws from its own random stream of the run's seed, so the estimator draws the same
numbers with and without it.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from omnislam.core.modality import modalities_of
from omnislam.core.sequence_info import SequenceInfo
from omnislam.core.types import UNKNOWN_ID, Bearings, FrameInput, OdometrySource
from omnislam.errors import ConfigError, DataError
from omnislam.harness.perturb import add_clutter, clutter_stream, reassign_ids


@dataclass(frozen=True, slots=True)
class FedFrames:
    """What ``fed_frames`` made.

    Attributes:
        frames: one FrameInput per frame, in order, as the estimator steps through them.
        info: what the estimator is told about the data (``sequence_info``).
        replay: the front-end ObservationLog replayed (None: the dataset's own sightings).
        log: the path of that log (None: the dataset's own sightings).
        reassigned: sightings re-labelled with a wrong id (0 without ``wrong_id_fraction``).
        clutter_added: false detections added (0 without ``clutter_per_frame``).
    """

    frames: list[FrameInput]
    info: SequenceInfo
    replay: Any = None
    log: str | None = None
    reassigned: int = 0
    clutter_added: int = 0


def fed_frames(
    sequence: Any,
    estimator: str,
    log: str | None = None,
    *,
    wrong_id_fraction: float = 0.0,
    clutter_per_frame: float = 0.0,
    seed: int | None = None,
) -> FedFrames:
    """The frames estimator ``estimator`` steps through in a run (the steps: module docstring).

    Args:
        sequence: the loaded Sequence.
        estimator: the estimator's registered name.
        log: the front-end log to replay (None: the dataset's own sightings).
        wrong_id_fraction: fraction of the sightings to re-label with wrong ids (0: none).
        clutter_per_frame: false range-bearing detections to add per frame, on average (0: none).
        seed: the run's seed (the faults' random streams are spawned from it).

    Raises:
        ConfigError: a log given without the front end installed.
        DataError: a log that is not this sequence's (a stale log).
    """
    replay = None if log is None else load_log(sequence, log)
    laser = _replays_laser_odometry(replay, estimator)
    frames = replayed_frames(sequence, estimator, replay, log, laser)
    frames, reassigned = _with_wrong_ids(frames, wrong_id_fraction, seed)
    source = OdometrySource.LASER if laser else OdometrySource.WHEEL
    info = sequence_info(sequence, frames, source)
    frames, clutter_added = _with_clutter(frames, clutter_per_frame, seed)
    return FedFrames(
        frames, info, replay, None if log is None else str(log), reassigned, clutter_added
    )


def replayed_frames(
    sequence: Any, estimator: str, replay: Any, log: str | Path | None, laser: bool = False
) -> list[FrameInput]:
    """The frames before any fault: the dataset's own, or ``replay``'s with the loader's own
    sighting ids and, unless ``estimator`` models the floor, without the floor tracks.

    Args:
        sequence: the loaded Sequence.
        estimator: the estimator's registered name.
        replay: the front-end ObservationLog (None: the dataset's own sightings).
        log: the log's path (named in errors).
        laser: the frames carry the log's laser odometry instead of the wheels'.
    """
    if replay is None:
        return list(sequence.frame_inputs())
    frames = list(sequence.frame_inputs(replay.frames, odometry=laser))
    frames = own_sighting_ids(sequence, frames, log)
    return frames_for_estimator(estimator, frames, replay.floor_ids_from)


def _replays_laser_odometry(replay: Any, estimator: str) -> bool:
    """A log's laser odometry replaces the wheel odometry for the SLAM estimators; dead reckoning
    stays the wheel odometry, the baseline they are compared with."""
    from omnislam.estimators import ESTIMATORS

    return (
        replay is not None
        and replay.odometry_source is OdometrySource.LASER
        and not ESTIMATORS[estimator].wheel_odometry
    )


def _with_wrong_ids(
    frames: list[FrameInput], fraction: float, seed: int | None
) -> tuple[list[FrameInput], int]:
    """(frames, sightings re-labelled): ``fraction`` of the sightings given wrong ids, drawn
    from the seed's first spawned stream."""
    if fraction <= 0:
        return frames, 0
    rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(1)[0])
    perturbed, reassigned = reassign_ids(iter(frames), fraction, rng)
    return list(perturbed), reassigned


def _with_clutter(
    frames: list[FrameInput], rate: float, seed: int | None
) -> tuple[list[FrameInput], int]:
    """(frames, detections added): ``rate`` false detections per frame on average, drawn from
    the seed's clutter stream (``perturb.clutter_stream``)."""
    if rate <= 0:
        return frames, 0
    return add_clutter(frames, rate, clutter_stream(seed))


def sequence_info(
    sequence: Any, frames: list[Any], odometry_source: OdometrySource = OdometrySource.WHEEL
) -> SequenceInfo:
    """What the estimators are told about a run (``core.sequence_info.SequenceInfo``), from the
    frames as fed: their modalities, whether every range-bearing sighting carries a true id, the
    sightings' first sigmas, the rig (or the height of a bearing-only sensor), the prior map.

    Args:
        sequence: the loaded Sequence.
        frames: the FrameInputs the estimator will step through (a front-end log's, with the
            loader's own sighting ids: ``own_sighting_ids``).
        odometry_source: LASER when the frames carry the log's laser odometry.
    """
    # the range-bearing sightings as fed (a front-end log adds its laser landmarks, which have
    # no ids, to the loader's)
    sightings = [f.range_bearing for f in frames if f.range_bearing is not None]
    sightings = [rb for rb in sightings if len(rb)]
    known = bool(sightings) and all(np.all(rb.landmark_ids != UNKNOWN_ID) for rb in sightings)
    return SequenceInfo(
        name=sequence.name,
        frames=len(sequence),
        modalities=modalities_of(frames),
        known_association=known,
        sigma_range_m=float(sightings[0].sigma_range_m[0]) if sightings else None,
        sigma_bearing_rad=float(sightings[0].sigma_bearing_rad[0]) if sightings else None,
        sensor_height_m=sensor_height_m(sequence.calibration,
                                        getattr(sequence, "bearing_sightings", None)),
        prior_map=sequence.prior_map,
        calibration=sequence.calibration,
        facts=sequence.info,
        odometry_source=odometry_source,
    )


def sensor_height_m(calibration: object, bearing_sightings: Any = None) -> float | None:
    """Height of a camera rig's single viewpoint above the robot frame, else of the sensor of
    the loader's bearing-only sightings (``Sequence.bearing_sightings``); None without either."""
    viewpoint = getattr(calibration, "viewpoint_r", None)
    if viewpoint is not None:
        return float(np.asarray(viewpoint)[2])
    return None if bearing_sightings is None else bearing_sightings.sensor_height_m


def load_log(sequence: object, log: str | Path) -> Any:
    """The front-end ObservationLog to replay (``RunSpec.log``), built from this very sequence.

    Raises:
        ConfigError: the front end is not available.
        DataError: the log is not this sequence's, or has another number of frames.
    """
    try:
        from omnislam.frontend.observation_log import dataset_fingerprint, load_observation_log
    except ImportError as exc:
        raise ConfigError(f"--log needs the front end, which is not available ({exc})") from None
    replay = load_observation_log(Path(log), dataset_id=dataset_fingerprint(sequence))
    if len(replay.frames) != len(sequence):  # type: ignore[arg-type]
        raise DataError(
            f"the observation log has {len(replay.frames)} frames, the dataset {len(sequence)}",  # type: ignore[arg-type]
            Path(log),
        )
    return replay


def frames_for_estimator(name: str, frames: list[Any], floor_ids_from: int | None) -> list[Any]:
    """A log's frames as estimator ``name`` is fed them: without the floor tracks' bearings
    (ids ``floor_ids_from`` and above, ``ObservationLog.floor_ids_from``) unless it models the
    floor (``EstimatorEntry.floor_tracks``). The frames themselves when there are none."""
    from omnislam.estimators import ESTIMATORS

    if floor_ids_from is None or ESTIMATORS[name].floor_tracks:
        return frames
    out = []
    for frame in frames:
        seen = frame.bearings
        if seen is None or not np.any(seen.landmark_ids >= floor_ids_from):
            out.append(frame)
            continue
        keep = seen.landmark_ids < floor_ids_from
        out.append(replace(frame, bearings=Bearings(
            seen.landmark_ids[keep], seen.unit_vectors_r[keep], seen.sigmas_rad[keep])))
    return out


def own_sighting_ids(sequence: Any, frames: list[Any], log: str | Path | None) -> list[Any]:
    """The replayed frames with the ids this loader gives its own range-bearing sightings.

    A front-end log is shared by every cell of a dataset: each frame's range-bearing sightings
    in it are the loader's own as the front end saw them (default loader options) followed by
    the laser landmarks it extracted (``frontend.pipeline._merge_sightings``). A loader option
    that changes the ids -- ``association: unknown`` hides them -- must still reach the
    estimator, so the leading rows take the ids of this sequence's own sightings.

    Raises:
        DataError: a frame's leading rows are not this sequence's sightings (a stale log).
    """
    own = sequence.range_bearing
    if own is None:
        return frames
    out = []
    for frame in frames:
        given, fed = own[frame.index], frame.range_bearing
        if given is None or not len(given) or fed is None:
            out.append(frame)
            continue
        k = len(given)
        if len(fed) < k or not np.array_equal(fed.ranges_m[:k], given.ranges_m):
            raise DataError(
                f"frame {frame.index}: its range-bearing sightings are not the loader's "
                "(a stale log: delete it to recompute)",
                log,
            )
        if np.array_equal(fed.landmark_ids[:k], given.landmark_ids):
            out.append(frame)
            continue
        ids = np.concatenate([given.landmark_ids, fed.landmark_ids[k:]])
        out.append(replace(frame, range_bearing=replace(fed, landmark_ids=ids)))
    return out
