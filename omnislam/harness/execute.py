"""Run one estimator on one dataset: the library function behind ``omnislam run`` and the grid.

``execute_run(spec)`` loads the dataset (and, for data without ground truth that has a reference
solution, that reference: ``harness.reference``), replays the shared front end's log when the
dataset has images (``spec.log``, or the cached log ``frontend_log_for`` computes), builds the
estimator through the registry, feeds it every frame, times each step, and returns a RunRecord.
The RUN_DIR itself is written by ``write_run_dir``, atomically; what ``execute_run`` may write is
cache: the front-end log of an image dataset run without ``--log`` (``cache_dir()/logs``) and
the true points of a log's tracks next to the log (``LOG.truth.npz``). The same function runs in
the CLI's process and in the grid runner's workers, so a cell of a grid and ``omnislam run``
with the same arguments give the same numbers.

Peak memory is measured per run: on Linux the process's resident-set high-water mark is reset
before the run (``/proc/self/clear_refs``), so a worker process that runs several cells reports
each cell's own peak; elsewhere it is the process's peak so far (an upper bound).
"""

from __future__ import annotations

import enum
import hashlib
import json
import os
import sys
import tempfile
import time
from collections.abc import Callable, Mapping
from contextlib import nullcontext
from dataclasses import asdict, dataclass, field, is_dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from omnislam._files import NPZ_ERRORS, make_public, safe_name
from omnislam.core.modality import Modality, modalities_of
from omnislam.core.sequence_info import SequenceInfo
from omnislam.core.types import UNKNOWN_ID, Bearings, Exporting, Introspectable, OdometrySource
from omnislam.datasets.sequence import GroundTruth
from omnislam.errors import ConfigError, DataError
from omnislam.frontend.timing import cpu_with_children_s
from omnislam.harness.cache import cache_dir
from omnislam.harness.layout import ATTACHMENTS, ESTIMATOR_INFO, LOGS
from omnislam.harness.perturb import (
    CLUTTER_OPTION,
    WRONG_ID_OPTION,
    add_clutter,
    clutter_stream,
    parse_clutter_rate,
    parse_fraction,
    reassign_ids,
)
from omnislam.harness.prior import PRIOR_MAP_OPTION, prior_map_from_run_dir
from omnislam.harness.reference import reference_for
from omnislam.harness.rundir import RunConfig, RunRecord

_STATUS = Path("/proc/self/status")
_CLEAR_REFS = Path("/proc/self/clear_refs")


@dataclass(frozen=True, slots=True)
class RunSpec:
    """What to run: the arguments of ``omnislam run``.

    Attributes:
        dataset: registered name or path.
        estimator: estimator name (a key of ``omnislam.estimators.ESTIMATORS``).
        seed: random seed (None: fresh entropy).
        options: ``--set`` options; keys the dataset's loader accepts go to the loader,
            ``wrong_id_fraction`` to the harness (``harness.perturb``: re-label that fraction
            of the sightings with wrong ids), so is ``clutter_per_frame`` (add that many false
            range-bearing detections per frame, on average), the others to the estimator.
        log: a front-end ObservationLog to replay instead of the dataset's own sightings
            (the hook of the shared front end). None: a dataset with images replays the
            cached log of ``frontend_log_for``; one without keeps its own sightings.
    """

    dataset: str
    estimator: str
    seed: int | None = None
    options: Mapping[str, str] = field(default_factory=dict)
    log: str | None = None


def reset_peak_rss() -> bool:
    """Reset this process's resident-set high-water mark (Linux >= 4.0); True on success."""
    try:
        _CLEAR_REFS.write_text("5")
    except OSError:
        return False
    return True


def peak_rss_mb() -> float:
    """Peak resident set size of this process since the last reset [MB] (0 when unknown)."""
    try:
        for line in _STATUS.read_text().splitlines():
            if line.startswith("VmHWM:"):
                return float(line.split()[1]) / 1024.0
    except (OSError, ValueError, IndexError):
        pass
    try:
        import resource
    except ImportError:  # pragma: no cover - Windows
        return 0.0
    kilobytes = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return kilobytes / (1024.0 * 1024.0) if sys.platform == "darwin" else kilobytes / 1024.0


def check_estimator(name: str) -> None:
    """Raise ConfigError unless ``name`` is a registered and available estimator."""
    from omnislam.estimators import estimator_factory

    estimator_factory(name)


def check_spec(spec: RunSpec, *, rendered: bool = True) -> None:
    """Validate a run without doing it: estimator, dataset, every option (loader, harness and
    estimator, the latter against its configuration dataclass), nothing loaded or computed.

    A grid calls it for every cell before any work starts, so a bad value fails the grid up
    front instead of when its cell's turn comes (after the front end, with a results folder).

    Args:
        spec: the run.
        rendered: False for a synthetic render the grid runner has yet to make
            (``harness.renders``): ``spec.dataset`` need not exist, its options are checked
            against the synthetic format.

    Raises:
        ConfigError: unknown estimator or option, a value that does not parse, a prior map
            that is not a RUN_DIR.
        DataError: a dataset that cannot be resolved.
    """
    from omnislam.datasets.registry import FORMATS, DatasetFormat, parse_options, resolve
    from omnislam.estimators import check_estimator_options
    from omnislam.harness.layout import CONFIG

    check_estimator(spec.estimator)
    if rendered:
        resolved = resolve(spec.dataset)
        fmt, fixed, loader_keys = resolved.format, resolved.options, resolved.option_names()
    else:
        fmt, fixed = DatasetFormat.SYNTHETIC, {}
        loader_keys = frozenset(FORMATS[fmt].options)
    options = dict(spec.options)
    parse_fraction(options.pop(WRONG_ID_OPTION, "0"))
    parse_clutter_rate(options.pop(CLUTTER_OPTION, "0"))
    prior_run = options.pop(PRIOR_MAP_OPTION, None)
    if prior_run is not None and not (Path(prior_run) / CONFIG).is_file():
        raise ConfigError(f"{PRIOR_MAP_OPTION}={prior_run}: not a RUN_DIR folder")
    parse_options(fmt, {**fixed, **{k: v for k, v in options.items() if k in loader_keys}})
    check_estimator_options(
        spec.estimator, {k: v for k, v in options.items() if k not in loader_keys}
    )


#: ``on_step(stage, done, total)``: what a run is doing ("loading", "front end", "running",
#: "final estimate") and how many of its ``total`` frames it has stepped (0 of 0: not counted)
StepCallback = Callable[[str, int, int], None]


def execute_run(
    spec: RunSpec, *, progress: bool = False, on_step: StepCallback | None = None
) -> RunRecord:
    """Run ``spec.estimator`` on ``spec.dataset`` and return what a RUN_DIR holds.

    Args:
        spec: the run.
        progress: say on stderr what takes time (running the front end, with a progress line).
        on_step: called at every stage and after every frame (``StepCallback``; the callee
            throttles what it shows).

    Returns:
        RunRecord with the final estimate, per-step wall times [s] and the sequence's ground
        truth.

    Raises:
        ConfigError: unknown estimator or option, a log that is not available, no modality the
            estimator can use on the data.
        DataError: missing or malformed data.
    """
    import omnislam
    from omnislam.datasets.registry import load_dataset, resolve
    from omnislam.estimators import ESTIMATORS, make_estimator, resolve_estimator_modality

    say = RunStages(on_step if on_step is not None else _silent)
    reset_peak_rss()
    check_estimator(spec.estimator)
    say("loading", 0, 0)
    resolved = resolve(spec.dataset)
    loader_keys = resolved.option_names()
    options = dict(spec.options)
    wrong_fraction = parse_fraction(options.pop(WRONG_ID_OPTION, "0"))
    clutter_rate = parse_clutter_rate(options.pop(CLUTTER_OPTION, "0"))
    prior_run = options.pop(PRIOR_MAP_OPTION, None)
    dataset_options = {k: v for k, v in options.items() if k in loader_keys}
    estimator_options = {k: v for k, v in options.items() if k not in loader_keys}
    sequence = load_dataset(resolved, dataset_options)
    if prior_run is not None:
        sequence = replace(sequence, prior_map=prior_map_from_run_dir(prior_run))
    ground_truth, reference = reference_for(resolved.format, resolved.path, sequence)
    log = spec.log
    if log is None and ESTIMATORS[spec.estimator].modalities:  # dead reckoning sees nothing
        say("front end", 0, 0)
        computed = frontend_log_for(sequence, spec.dataset, cache_dir() / LOGS, progress)
        log = None if computed is None else str(computed)
    if reference or log is not None:  # computing them (when not cached) is not the run's memory
        reset_peak_rss()
    replay = None
    laser = False
    if log is None:
        frames = list(sequence.frame_inputs())
    else:
        replay = _load_log(sequence, log)
        # a log's laser odometry replaces the wheel odometry for the SLAM estimators; dead
        # reckoning stays the wheel odometry, the baseline they are compared with
        laser = (
            replay.odometry_source is OdometrySource.LASER
            and not ESTIMATORS[spec.estimator].wheel_odometry
        )
        frames = _own_sighting_ids(
            sequence, list(sequence.frame_inputs(replay.frames, odometry=laser)), log
        )
        frames = frames_for_estimator(spec.estimator, frames, replay.floor_ids_from)
    reassigned = 0
    if wrong_fraction > 0:
        # its own stream, so the estimator draws the same numbers with and without it
        perturb_rng = np.random.default_rng(np.random.SeedSequence(spec.seed).spawn(1)[0])
        perturbed, reassigned = reassign_ids(iter(frames), wrong_fraction, perturb_rng)
        frames = list(perturbed)
    # what the data is (ids, sigmas) is told before the clutter, which is a fault injected
    info = sequence_info(
        sequence, frames, OdometrySource.LASER if laser else OdometrySource.WHEEL
    )
    clutter_added = 0
    if clutter_rate > 0:
        frames, clutter_added = add_clutter(frames, clutter_rate, clutter_stream(spec.seed))
    known = info.known_association
    modality = resolve_estimator_modality(spec.estimator, info, estimator_options)
    track_truth = False
    if replay is not None and modality is Modality.BEARINGS_3D:
        # the landmarks are the front end's tracks: score them against the tracks' true points
        say("true points of the tracks", 0, 0)
        ground_truth, track_truth = _with_track_truth(sequence, replay, Path(log), progress)
    rng = np.random.default_rng(spec.seed)
    estimator = make_estimator(spec.estimator, info, estimator_options, rng)

    step_s = np.zeros(len(sequence))
    clock = time.perf_counter
    total = len(frames)
    say("running", 0, total)
    for done, frame in enumerate(frames, start=1):
        start = clock()
        estimator.step(frame)
        step_s[frame.index] = clock() - start
        say("running", done, total)
    say("final estimate", total, total)
    start = clock()
    estimate = estimator.estimate()
    final_s = clock() - start
    attachments = {**_attachments(estimator), **_estimator_info(estimator)}
    stages_wall_s, stages_cpu_s = say.finish()

    config = RunConfig(
        dataset=spec.dataset,
        dataset_path=str(resolved.path),
        estimator=spec.estimator,
        omnislam_version=omnislam.__version__,
        frames=len(sequence),
        images=len(sequence.image_frames),
        total_s=float(step_s.sum() + final_s),
        peak_rss_mb=round(peak_rss_mb(), 1),
        ground_truth_kind=ground_truth.kind.value,
        ground_truth_note=ground_truth.note,
        ground_truth_reference=reference or None,
        source=sequence.source,
        seed=spec.seed,
        dataset_options=dataset_options,
        estimator_options=estimator_options,
        landmark_ids_from_truth=(known and modality is Modality.RANGE_BEARING_2D) or track_truth,
        frontend_log=None if log is None else str(log),
        frontend_config_hash=None if log is None else _log_config_hash(log),
        wrong_id_fraction=wrong_fraction,
        sightings_reassigned=reassigned,
        clutter_per_frame=clutter_rate,
        clutter_added=clutter_added,
        modality=None if modality is None else modality.value,
        prior_map=prior_run,
        stages_wall_s=stages_wall_s,
        stages_cpu_s=stages_cpu_s,
    )
    return RunRecord(config, estimate, step_s, ground_truth, attachments)


def sequence_info(
    sequence: Any, frames: list[Any], odometry_source: OdometrySource = OdometrySource.WHEEL
) -> SequenceInfo:
    """What the estimators are told about a run (``core.sequence_info.SequenceInfo``), from the
    frames as fed: their modalities, whether every range-bearing sighting carries a true id, the
    sightings' first sigmas, the rig, the prior map.

    Args:
        sequence: the loaded Sequence.
        frames: the FrameInputs the estimator will step through (a front-end log's, with the
            loader's own sighting ids: ``_own_sighting_ids``).
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
        sensor_height_m=_sensor_height_m(sequence.calibration),
        prior_map=sequence.prior_map,
        calibration=sequence.calibration,
        facts=sequence.info,
        odometry_source=odometry_source,
    )


class RunStages:
    """An ``on_step`` callback that also times the stages it is told about.

    Wall-clock and CPU seconds from each stage's first call to the next stage's (the last
    stage ends at ``finish``). CPU counts this process and the child processes that ended
    within the stage (the front end's workers: their whole CPU once they have exited).

    Args:
        say: the callback to pass every call on to.
    """

    def __init__(self, say: StepCallback) -> None:
        self._say = say
        self._stage: str | None = None
        self._start = (0.0, 0.0)
        self.wall_s: dict[str, float] = {}
        self.cpu_s: dict[str, float] = {}

    def __call__(self, stage: str, done: int, total: int) -> None:
        if stage != self._stage:
            self._switch(stage)
        self._say(stage, done, total)

    def _switch(self, stage: str | None) -> None:
        now = (time.perf_counter(), cpu_with_children_s())
        if self._stage is not None:
            key = self._stage
            self.wall_s[key] = self.wall_s.get(key, 0.0) + now[0] - self._start[0]
            self.cpu_s[key] = self.cpu_s.get(key, 0.0) + now[1] - self._start[1]
        self._stage, self._start = stage, now

    def finish(self) -> tuple[dict[str, float], dict[str, float]]:
        """End the current stage; (wall, CPU) seconds per stage, rounded to the millisecond."""
        self._switch(None)
        return (
            {k: round(v, 3) for k, v in self.wall_s.items()},
            {k: round(v, 3) for k, v in self.cpu_s.items()},
        )


def _silent(stage: str, done: int, total: int) -> None:
    """The ``on_step`` of a run nobody watches."""


def log_file_name(dataset: str) -> str:
    """File name of a dataset's front-end log: its last path component plus a short hash of the
    full argument (two folders of the same name never share a log)."""
    digest = hashlib.sha1(dataset.encode()).hexdigest()[:10]
    return f"{safe_name(Path(dataset).name)}-{digest}.npz"


def frontend_log_for(
    sequence: Any,
    dataset: str,
    folder: Path,
    progress: bool = False,
    on_image: Callable[[int, int], None] | None = None,
) -> Path | None:
    """The shared front end's log of a dataset with images or laser scans, computed once.

    ``frontend.pipeline.cached_frontend`` writes (or reuses, when the dataset and the front
    end's configuration are unchanged) ``folder/<log_file_name(dataset)>``: bearings and
    vertical lines from the images, landmarks from the laser scans (merged with the loader's own
    range-bearing sightings). The grid runner calls it once per dataset so that every cell
    replays the same observations; ``omnislam run`` without ``--log`` calls it too, so a run and
    a grid cell measure the same experiment. ``on_image`` is called with (images done, images
    to do) while the front end runs (``frontend.pipeline.run_frontend``).

    Returns:
        The log's path, or None for a dataset with neither (its own sightings are used).
    """
    images = sequence.image_loader is not None and len(sequence.image_frames) > 0
    if not images and sequence.laser is None:
        return None
    from omnislam.frontend.pipeline import cached_frontend

    path = folder / log_file_name(dataset)
    path.parent.mkdir(parents=True, exist_ok=True)
    cached_frontend(sequence, path, progress=progress, pipelined=True, on_image=on_image)
    if progress:  # after it: bad input found on the way (an image) stays the one stderr line
        what = f"{len(sequence.image_frames)} images" if images else "laser scans"
        print(
            f"omnislam: shared front end on {dataset} ({what}; cached in {path})",
            file=sys.stderr,
            flush=True,
        )
    return path


def _sensor_height_m(calibration: object) -> float | None:
    """Height of a camera rig's single viewpoint above the robot frame (None without a rig)."""
    viewpoint = getattr(calibration, "viewpoint_r", None)
    return None if viewpoint is None else float(np.asarray(viewpoint)[2])


def _log_config_hash(log: str | Path) -> str:
    from omnislam.frontend.observation_log import read_log_key

    return read_log_key(Path(log))[1]


def _load_log(sequence: object, log: str) -> Any:
    """The front-end ObservationLog to replay (RunSpec.log), built from this very sequence."""
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


def _own_sighting_ids(sequence: Any, frames: list[Any], log: str | Path) -> list[Any]:
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


def cache_track_truth(
    sequence: Any,
    log: str | Path,
    progress: bool = False,
    on_image: Callable[[int, int], None] | None = None,
) -> None:
    """Compute the true points of a log's tracks into the cache next to it, once.

    The grid runner calls it in its own process before the cells start, so that workers running
    cells of the same log read the cache instead of each computing it (``_with_track_truth``;
    ``on_image`` is called with (images done, images to do)). Nothing to do for a sequence
    without per-pixel ground truth.
    """
    if sequence.point_map_loader is None:
        return
    from omnislam.frontend.observation_log import dataset_fingerprint, load_observation_log

    replay = load_observation_log(Path(log), dataset_id=dataset_fingerprint(sequence))
    _with_track_truth(sequence, replay, Path(log), progress=progress, on_image=on_image)


def _with_track_truth(
    sequence: Any,
    replay: Any,
    log: Path,
    progress: bool = False,
    on_image: Callable[[int, int], None] | None = None,
) -> tuple[GroundTruth, bool]:
    """Ground truth whose landmarks are the true points of the front end's tracks.

    With per-pixel ground truth (``Sequence.point_map_loader``: synthetic renders) every track
    of the log has a true 3-D position (``frontend.evaluation.track_truth``); the estimators'
    landmarks carry the track ids, so landmark error associates by id. The true points are
    read at the keypoints' pixels only when the sequence can (``pixel_points_loader``: the
    same bits as whole maps, for ~1 % of the pixels), and cached next to the log
    (``LOG.truth.npz``, keyed by the log's dataset and configuration).

    Returns:
        (ground truth, True) with the track landmarks, or (the sequence's, False) without
        per-pixel ground truth.
    """
    if sequence.point_map_loader is None:
        return sequence.ground_truth, False
    cache = log.with_name(log.name + ".truth.npz")
    key = f"{replay.dataset_id}:{replay.config_hash}"
    ids = points = None
    try:
        with np.load(cache, allow_pickle=False) as data:
            if str(data["key"]) == key:
                ids, points = data["ids"], data["points_w"]
    except NPZ_ERRORS:  # no cache entry, or a truncated one: recompute
        pass
    if ids is None:
        from omnislam._progress import Progress
        from omnislam.frontend.evaluation import (
            sampled_true_sightings,
            track_truth,
            true_sightings,
        )

        images = sum(
            f.bearings is not None and px is not None and len(f.bearings) > 0
            for f, px in zip(replay.frames, replay.pixels, strict=True)
        )
        label = f"true points of the tracks of {log.name}"
        done = 0

        def advance() -> None:
            nonlocal done
            done += 1
            if bar is not None:
                bar.advance()
            if on_image is not None:
                on_image(done, images)

        with Progress(label, images, "img") if progress else nullcontext() as bar:
            camera = getattr(sequence.calibration, "camera", None)
            if sequence.pixel_points_loader is not None and camera is not None:
                # the keypoints' pixels only: bit-identical to whole maps, ~50x less work

                def pixel_points_of(index: int, rows: np.ndarray, cols: np.ndarray
                                    ) -> np.ndarray:
                    points = sequence.pixel_points_loader(index, rows, cols)
                    advance()
                    return points

                shape = (int(camera.height), int(camera.width))
                sightings = sampled_true_sightings(replay, pixel_points_of, shape)
            else:

                def points_w_of(index: int) -> np.ndarray:
                    points = sequence.point_map_loader(index)
                    advance()
                    return points

                sightings = true_sightings(replay, points_w_of)
            ids, points = track_truth(sightings)
        with tempfile.NamedTemporaryFile(dir=log.parent, suffix=".npz", delete=False) as tmp:
            np.savez_compressed(tmp, key=np.array(key), ids=ids, points_w=points)
        make_public(tmp.name)
        os.replace(tmp.name, cache)
    truth = replace(
        sequence.ground_truth,
        landmark_ids=ids,
        landmarks_w=points,
        note=sequence.ground_truth.note
        + "; landmarks: true 3-D points of the front end's tracks (per-pixel ground truth)",
    )
    return truth, True


def _attachments(estimator: object) -> dict[str, bytes]:
    """The files an ``Exporting`` estimator exports (``graph.g2o``), by RUN_DIR file name."""
    if not isinstance(estimator, Exporting):
        return {}
    files = dict(estimator.attachments())
    unknown = sorted(set(files) - set(ATTACHMENTS))
    if unknown:
        raise ConfigError(f"estimator attachments not known to the RUN_DIR: {unknown}")
    return files


def _estimator_info(estimator: object) -> dict[str, bytes]:
    """An ``Introspectable`` estimator's ``info()`` record (a dataclass of counts) as JSON."""
    if not isinstance(estimator, Introspectable):
        return {}
    record = estimator.info()
    if not is_dataclass(record) or isinstance(record, type):
        return {}
    fields = {
        key: value.value if isinstance(value, enum.Enum) else value
        for key, value in asdict(record).items()
    }
    return {ESTIMATOR_INFO: (json.dumps(fields, indent=1, sort_keys=True) + "\n").encode()}
