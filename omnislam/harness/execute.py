"""Run one estimator on one dataset: the library function behind ``omnislam run`` and the grid.

``execute_run(spec)`` reads like the run: split the options (``parse_run_options``), load the
dataset (with a prior map from an earlier run, ``harness.prior``), its reference solution when
it has one instead of ground truth (``harness.reference``), the shared front end's log when the
dataset has images or scans (``spec.log``, or the cached log ``frontend_log_for`` computes), the
frames the estimator is fed (``harness.frames``), the true points of the log's tracks when its
landmarks are the tracks (``harness.track_truth``), then the estimator through the registry,
every frame fed and each step timed, and a RunRecord. The RUN_DIR itself is written by
``write_run_dir``, atomically; what ``execute_run`` may write is cache: the front-end log of an
image dataset run without ``--log`` (``cache_dir()/logs``) and the true points of a log's tracks
next to the log (``LOG.truth.npz``). The same function runs in the CLI's process and in the
grid runner's workers, so a cell of a grid and ``omnislam run`` with the same arguments give
the same numbers.

Peak memory is measured per run: on Linux the process's resident-set high-water mark is reset
before the run (``/proc/self/clear_refs``), so a worker process that runs several cells reports
each cell's own peak; elsewhere it is the process's peak so far (an upper bound).
"""

from __future__ import annotations

import enum
import hashlib
import json
import sys
import time
from collections.abc import Callable, Collection, Mapping
from dataclasses import asdict, dataclass, field, is_dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from omnislam._files import safe_name
from omnislam.core.modality import Modality
from omnislam.core.types import Estimate, Exporting, Introspectable
from omnislam.datasets.sequence import GroundTruth
from omnislam.errors import ConfigError
from omnislam.frontend.timing import cpu_with_children_s
from omnislam.harness.cache import cache_dir
from omnislam.harness.frames import FedFrames, fed_frames
from omnislam.harness.layout import ATTACHMENTS, CONFIG, ESTIMATOR_INFO, LOGS
from omnislam.harness.perturb import (
    CLUTTER_OPTION,
    WRONG_ID_OPTION,
    parse_clutter_rate,
    parse_fraction,
)
from omnislam.harness.prior import PRIOR_MAP_OPTION, prior_map_from_run_dir
from omnislam.harness.reference import reference_for
from omnislam.harness.rundir import RunConfig, RunRecord
from omnislam.harness.track_truth import with_track_truth

_STATUS = Path("/proc/self/status")
_CLEAR_REFS = Path("/proc/self/clear_refs")


@dataclass(frozen=True, slots=True)
class RunSpec:
    """What to run: the arguments of ``omnislam run``.

    Attributes:
        dataset: registered name or path.
        estimator: estimator name (a key of ``omnislam.estimators.ESTIMATORS``), or
            ``external`` in a grid cell that reads another system's results from files
            (``Cell.external``, ``harness.external``) instead of running anything.
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


@dataclass(frozen=True, slots=True)
class RunOptions:
    """A run's ``--set`` options split by who takes them (``parse_run_options``).

    Attributes:
        dataset: the loader's options (the keys its dataset format accepts).
        estimator: the estimator's options (every other key, checked against its configuration
            dataclass by the registry).
        wrong_id_fraction: the harness re-labels this fraction of the sightings with wrong ids
            (``harness.perturb``; default 0: the sightings as given).
        clutter_per_frame: the harness adds this many false range-bearing detections per frame
            on average (``harness.perturb``; default 0: none).
        prior_map: the RUN_DIR whose landmarks are the prior map (``harness.prior``); default
            None: the dataset's own prior map, if any.
    """

    dataset: dict[str, str]
    estimator: dict[str, str]
    wrong_id_fraction: float = 0.0
    clutter_per_frame: float = 0.0
    prior_map: str | None = None


def parse_run_options(options: Mapping[str, str], loader_keys: Collection[str]) -> RunOptions:
    """Split a run's options: the harness's own (parsed), the loader's and the estimator's.

    Args:
        options: ``RunSpec.options``.
        loader_keys: the option names the dataset's loader accepts.

    Raises:
        ConfigError: a harness option whose value does not parse.
    """
    rest = dict(options)
    wrong_id_fraction = parse_fraction(rest.pop(WRONG_ID_OPTION, "0"))
    clutter_per_frame = parse_clutter_rate(rest.pop(CLUTTER_OPTION, "0"))
    prior_map = rest.pop(PRIOR_MAP_OPTION, None)
    return RunOptions(
        dataset={k: v for k, v in rest.items() if k in loader_keys},
        estimator={k: v for k, v in rest.items() if k not in loader_keys},
        wrong_id_fraction=wrong_id_fraction,
        clutter_per_frame=clutter_per_frame,
        prior_map=prior_map,
    )


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

    check_estimator(spec.estimator)
    if rendered:
        resolved = resolve(spec.dataset)
        fmt, fixed, loader_keys = resolved.format, resolved.options, resolved.option_names()
    else:
        fmt, fixed = DatasetFormat.SYNTHETIC, {}
        loader_keys = frozenset(FORMATS[fmt].options)
    options = parse_run_options(spec.options, loader_keys)
    if options.prior_map is not None and not (Path(options.prior_map) / CONFIG).is_file():
        raise ConfigError(f"{PRIOR_MAP_OPTION}={options.prior_map}: not a RUN_DIR folder")
    parse_options(fmt, {**fixed, **options.dataset})
    check_estimator_options(spec.estimator, options.estimator)


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
    from omnislam.datasets.registry import resolve
    from omnislam.estimators import make_estimator, resolve_estimator_modality

    say = RunStages(on_step if on_step is not None else _silent)
    reset_peak_rss()
    check_estimator(spec.estimator)
    say("loading", 0, 0)
    resolved = resolve(spec.dataset)
    options = parse_run_options(spec.options, resolved.option_names())
    sequence = _load_sequence(resolved, options)
    ground_truth, reference = reference_for(resolved.format, resolved.path, sequence)
    log = _frontend_log(spec, sequence, say, progress)
    if reference or log is not None:  # computing them (when not cached) is not the run's memory
        reset_peak_rss()
    fed = fed_frames(
        sequence,
        spec.estimator,
        log,
        wrong_id_fraction=options.wrong_id_fraction,
        clutter_per_frame=options.clutter_per_frame,
        seed=spec.seed,
    )
    modality = resolve_estimator_modality(spec.estimator, fed.info, options.estimator)
    ground_truth, track_truth = _track_landmarks(
        ground_truth, sequence, fed, modality, say, progress
    )
    rng = np.random.default_rng(spec.seed)
    estimator = make_estimator(spec.estimator, fed.info, options.estimator, rng)
    estimate, step_s, final_s = _step_through(estimator, fed.frames, len(sequence), say)
    attachments = {**_attachments(estimator), **_estimator_info(estimator)}
    config = _run_config(
        spec,
        resolved,
        sequence,
        options,
        fed,
        truth=(ground_truth, reference, track_truth),
        modality=modality,
        total_s=float(step_s.sum() + final_s),
        stages=say.finish(),
    )
    return RunRecord(config, estimate, step_s, ground_truth, attachments)


def _load_sequence(resolved: Any, options: RunOptions) -> Any:
    """The dataset with its loader options, and the prior map of ``prior_map=RUN_DIR``."""
    from omnislam.datasets.registry import load_dataset

    sequence = load_dataset(resolved, options.dataset)
    if options.prior_map is not None:
        sequence = replace(sequence, prior_map=prior_map_from_run_dir(options.prior_map))
    return sequence


def _frontend_log(
    spec: RunSpec, sequence: Any, say: StepCallback, progress: bool
) -> str | None:
    """The front-end log the run replays: ``spec.log``, else the shared front end's log of a
    dataset with images or laser scans (computed once into the cache; None: its own sightings).
    Dead reckoning sees nothing, so it needs none."""
    from omnislam.estimators import ESTIMATORS

    if spec.log is not None or not ESTIMATORS[spec.estimator].modalities:
        return spec.log
    say("front end", 0, 0)
    computed = frontend_log_for(sequence, spec.dataset, cache_dir() / LOGS, progress)
    return None if computed is None else str(computed)


def _track_landmarks(
    ground_truth: GroundTruth,
    sequence: Any,
    fed: FedFrames,
    modality: Modality | None,
    say: StepCallback,
    progress: bool,
) -> tuple[GroundTruth, bool]:
    """(ground truth, whether its landmarks are the log's tracks): an estimator whose landmarks
    are the front end's tracks (bearings-3d from a log) is scored against the tracks' true
    points (``harness.track_truth``); any other against ``ground_truth``."""
    if fed.replay is None or fed.log is None or modality is not Modality.BEARINGS_3D:
        return ground_truth, False
    say("true points of the tracks", 0, 0)
    return with_track_truth(sequence, fed.replay, Path(fed.log), progress)


def _step_through(
    estimator: Any, frames: list[Any], n_frames: int, say: StepCallback
) -> tuple[Estimate, np.ndarray, float]:
    """Feed the estimator every frame, timing each step, then ask for its final estimate.

    Returns:
        (the estimate, (n_frames,) wall time of each step by frame index [s], wall time of the
        final estimate [s]).
    """
    step_s = np.zeros(n_frames)
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
    return estimate, step_s, clock() - start


def _run_config(
    spec: RunSpec,
    resolved: Any,
    sequence: Any,
    options: RunOptions,
    fed: FedFrames,
    *,
    truth: tuple[GroundTruth, str, bool],
    modality: Modality | None,
    total_s: float,
    stages: tuple[dict[str, float], dict[str, float]],
) -> RunConfig:
    """The run's ``config.yaml`` (``RunConfig``), its peak memory read now.

    Args:
        truth: (the ground truth it is scored against, the name of its reference solution or
            "", whether its landmarks are the true points of the log's tracks).
        total_s: wall time of every step and the final estimate [s].
        stages: (wall, CPU) seconds per stage (``RunStages.finish``).
    """
    from omnislam._version import __version__

    ground_truth, reference, track_truth = truth
    range_bearing_ids = fed.info.known_association and modality is Modality.RANGE_BEARING_2D
    return RunConfig(
        dataset=spec.dataset,
        dataset_path=str(resolved.path),
        estimator=spec.estimator,
        omnislam_version=__version__,
        frames=len(sequence),
        images=len(sequence.image_frames),
        total_s=total_s,
        peak_rss_mb=round(peak_rss_mb(), 1),
        ground_truth_kind=ground_truth.kind.value,
        ground_truth_note=ground_truth.note,
        ground_truth_reference=reference or None,
        source=sequence.source,
        seed=spec.seed,
        dataset_options=options.dataset,
        estimator_options=options.estimator,
        landmark_ids_from_truth=range_bearing_ids or track_truth,
        frontend_log=fed.log,
        frontend_config_hash=None if fed.log is None else _log_config_hash(fed.log),
        wrong_id_fraction=options.wrong_id_fraction,
        sightings_reassigned=fed.reassigned,
        clutter_per_frame=options.clutter_per_frame,
        clutter_added=fed.clutter_added,
        modality=None if modality is None else modality.value,
        prior_map=options.prior_map,
        stages_wall_s=stages[0],
        stages_cpu_s=stages[1],
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



def _log_config_hash(log: str | Path) -> str:
    from omnislam.frontend.observation_log import read_log_key

    return read_log_key(Path(log))[1]



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

