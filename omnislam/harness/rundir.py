"""RUN_DIR: what one ``omnislam run`` leaves on disk, as ``read_run_dir`` / ``write_run_dir``.

Files (docs/concepts.md and docs/design.md describe them; their names: ``harness.layout``):

* ``trajectory.tum``: one estimated pose per frame (TUM format; z = 0 for planar runs).
* ``landmarks.csv``: ``id,x,y,z`` of the estimated map (header only when there is none).
* ``timing.csv``: ``frame,stamp_s,step_s``, the wall time of each ``Estimator.step``.
* ``config.yaml``: dataset, estimator, seed, options, omnislam version, run totals.
* ``ground_truth.tum`` and ``ground_truth_landmarks.csv``: the sequence's ground truth copied at
  run time (when it has any), so ``omnislam evaluate`` needs neither the data nor the loader.
* ``pose_covariances.csv`` (``frame,c00,...,c22``: covariance of [x, y, yaw] per pose, row-major)
  and ``landmark_covariances.csv`` (``id,c00,...,c22``: position covariance [m^2]) when the
  estimator provides covariances.
* attachments an estimator exports (e.g. ``graph.g2o``), stored verbatim, and
  ``estimator_info.json``: the counts an estimator's ``info()`` reports at the end of the run
  (graphslam: landmarks inserted and pending, sightings gated, factorisation fallbacks, ...).
* ``metrics.json``: written by ``omnislam evaluate`` (``metrics.run_metrics``).

A RUN_DIR is written atomically: everything goes into a hidden temporary folder next to it,
which is renamed into place only when complete; a failure leaves no partial RUN_DIR.
"""

from __future__ import annotations

import glob
import math
import os
import shutil
import tempfile
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import yaml

from omnislam._files import check_output_location, make_public, output_error, read_yaml
from omnislam.core.types import Estimate
from omnislam.datasets.sequence import GroundTruth, GroundTruthKind
from omnislam.datasets.trajectory_io import read_tum, write_tum
from omnislam.errors import ConfigError, DataError
from omnislam.harness.layout import (
    ATTACHMENTS,
    CONFIG,
    GROUND_TRUTH,
    GROUND_TRUTH_LANDMARKS,
    LANDMARK_COVARIANCES,
    LANDMARKS,
    POSE_COVARIANCES,
    TIMING,
    TRAJECTORY,
)

_COV_COLUMNS = ",".join(f"c{r}{c}" for r in range(3) for c in range(3))
#: every kind of ground truth but NONE comes with poses (``ground_truth.tum``)
_KINDS_WITH_TRAJECTORY = frozenset(GroundTruthKind) - {GroundTruthKind.NONE}


@dataclass(frozen=True, slots=True)
class RunConfig:
    """The ``config.yaml`` of a run: enough to repeat it and to label its numbers.

    Attributes:
        dataset: the DATASET argument (registered name or path).
        dataset_path: where the data was read from.
        dataset_options: loader options used (``--set`` keys the loader took).
        estimator: estimator name.
        estimator_options: options passed to the estimator.
        seed: the ``--seed`` (None when not given).
        omnislam_version: package version that produced the run.
        frames: number of frames processed.
        images: how many of those frames carry a camera image (0: none; None: not recorded,
            as in a ``config.yaml`` without the field).
        total_s: wall time of all estimator steps [s].
        peak_rss_mb: peak resident memory of the process [MB].
        ground_truth_kind: ``GroundTruthKind`` value.
        ground_truth_note: the ground truth's note (printed with every number).
        ground_truth_reference: when the ground truth is a reference solution computed by
            omnislam (kind ``reference``), its name (e.g. "lm-optimum", see
            ``harness.reference``); None for recorded ground truth.
        source: the dataset's citation.
        landmark_ids_from_truth: the sightings carried the ground truth's landmark ids, so the
            estimate's ids name true landmarks (landmark error associates by id).
        frontend_log: the front-end ObservationLog replayed (None: the dataset's own sightings).
        frontend_config_hash: the configuration hash of that log (a changed front end never
            reuses a finished cell).
        wrong_id_fraction: the harness re-labelled this fraction of the sightings with another
            landmark's id before the run (``harness.perturb``; 0 = the sightings as given).
        sightings_reassigned: how many sightings that re-labelled.
        clutter_per_frame: the harness added this many false range-bearing detections per
            frame on average, without ids (``harness.perturb.add_clutter``; 0 = none).
        clutter_added: how many it added.
        modality: the observation stream the estimator consumed (``core.modality``), None for
            one that uses no sightings.
        prior_map: the RUN_DIR whose landmarks were the prior map (``--set prior_map=``), or
            None (the dataset's own prior map, if any).
        stages_wall_s: wall-clock seconds of each stage of the run ("loading", "front end",
            "true points of the tracks", "running", "final estimate"; ``execute.RunStages``).
        stages_cpu_s: CPU seconds of the same stages (the process and the front end's worker
            processes).
        external: for results of another system read from files by an ``estimator: external``
            grid cell (``harness.external``), where they came from (files and their SHA-256):
            the run was not made here and has no step times. None for a run made by omnislam.
    """

    dataset: str
    dataset_path: str
    estimator: str
    omnislam_version: str
    frames: int
    total_s: float
    peak_rss_mb: float
    ground_truth_kind: str = GroundTruthKind.NONE.value
    ground_truth_note: str = ""
    ground_truth_reference: str | None = None
    source: str = ""
    seed: int | None = None
    dataset_options: Mapping[str, str] = field(default_factory=dict)
    estimator_options: Mapping[str, str] = field(default_factory=dict)
    landmark_ids_from_truth: bool = False
    frontend_log: str | None = None
    frontend_config_hash: str | None = None
    wrong_id_fraction: float = 0.0
    sightings_reassigned: int = 0
    clutter_per_frame: float = 0.0
    clutter_added: int = 0
    modality: str | None = None
    prior_map: str | None = None
    images: int | None = None
    stages_wall_s: Mapping[str, float] = field(default_factory=dict)
    stages_cpu_s: Mapping[str, float] = field(default_factory=dict)
    external: str | None = None


@dataclass(frozen=True, slots=True)
class RunRecord:
    """Everything a RUN_DIR holds (before evaluation).

    Attributes:
        config: see RunConfig.
        estimate: the estimator's final estimate (one pose per frame).
        step_s: (N,) wall time of each step [s].
        ground_truth: the sequence's ground truth (kind NONE when there is none).
        attachments: file name (one of ATTACHMENTS) -> bytes exported by the estimator.
    """

    config: RunConfig
    estimate: Estimate
    step_s: np.ndarray
    ground_truth: GroundTruth = field(default_factory=GroundTruth)
    attachments: Mapping[str, bytes] = field(default_factory=dict)


def _write_landmarks(path: Path, ids: np.ndarray, points_w: np.ndarray) -> None:
    lines = ["id,x,y,z"]
    lines += [
        f"{int(i)},{p[0]:.17g},{p[1]:.17g},{p[2]:.17g}" for i, p in zip(ids, points_w, strict=True)
    ]
    path.write_text("\n".join(lines) + "\n")


def _write_covariances(path: Path, key: str, keys: np.ndarray, covariances: np.ndarray) -> None:
    lines = [f"{key},{_COV_COLUMNS}"]
    lines += [
        f"{int(k)}," + ",".join(f"{v:.17g}" for v in c.reshape(9))
        for k, c in zip(keys, covariances, strict=True)
    ]
    path.write_text("\n".join(lines) + "\n")


def _read_keyed_csv(path: Path, header: str) -> tuple[np.ndarray, np.ndarray]:
    """A CSV whose first column is an integer key and whose other columns are numbers.

    Returns:
        (keys (M,), values (M, columns - 1)).

    Raises:
        DataError: unreadable file, wrong header, column count, non-numeric or non-finite
            field, or a key listed twice (naming the line).
    """
    path = Path(path)
    columns = header.count(",") + 1
    text = _read_lines(path)
    if not text or text[0].strip() != header:
        raise DataError(f"line 1: expected the header '{header}'", path)
    keys, values = [], []
    first_line: dict[int, int] = {}
    for number, line in enumerate(text[1:], start=2):
        if not line.strip():
            continue
        fields = line.split(",")
        if len(fields) != columns:
            raise DataError(f"line {number}: expected {columns} columns, got {len(fields)}", path)
        try:
            key = int(fields[0])
            row = [float(v) for v in fields[1:]]
        except ValueError:
            raise DataError(f"line {number}: non-numeric field in {line!r}", path) from None
        if not all(math.isfinite(v) for v in row):
            raise DataError(f"line {number}: NaN or infinite value in {line!r}", path)
        if key in first_line:
            raise DataError(
                f"line {number}: {header.split(',')[0]} {key} listed twice (first on line "
                f"{first_line[key]})",
                path,
            )
        first_line[key] = number
        keys.append(key)
        values.append(row)
    return np.asarray(keys, dtype=np.int64), np.asarray(values, dtype=float).reshape(
        -1, columns - 1
    )


def read_covariances_csv(path: Path, key: str) -> tuple[np.ndarray, np.ndarray]:
    """``KEY,c00,...,c22`` CSV -> (keys (M,), covariances (M, 3, 3)).

    Raises:
        DataError: wrong header, column count or non-numeric field (naming the line).
    """
    keys, values = _read_keyed_csv(path, f"{key},{_COV_COLUMNS}")
    return keys, values.reshape(-1, 3, 3)


def read_landmarks_csv(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """``id,x,y,z`` CSV -> (ids (M,), points (M, 3)).

    Raises:
        DataError: wrong header, column count or non-numeric field (naming the line).
    """
    return _read_keyed_csv(path, "id,x,y,z")


def _read_lines(path: Path) -> list[str]:
    """The lines of a text file of a RUN_DIR.

    Raises:
        DataError: missing, unreadable or not text.
    """
    try:
        return path.read_text().splitlines()
    except OSError as exc:
        raise DataError(f"cannot read the file ({exc})", path) from exc
    except UnicodeDecodeError:
        raise DataError("cannot read the file (not a text file)", path) from None


def _read_timing(path: Path) -> np.ndarray:
    """``timing.csv`` -> (N,) step seconds.

    Raises:
        DataError: unreadable file, wrong header or column count, or a step time that is not a
            finite number >= 0 (naming the line).
    """
    lines = _read_lines(path)
    if not lines or lines[0].strip() != "frame,stamp_s,step_s":
        raise DataError("line 1: expected the header 'frame,stamp_s,step_s'", path)
    steps = []
    for number, line in enumerate(lines[1:], start=2):
        fields = line.split(",")
        if len(fields) != 3:
            raise DataError(f"line {number}: expected 3 columns, got {len(fields)}", path)
        try:
            step = float(fields[2])
        except ValueError:
            raise DataError(f"line {number}: step_s {fields[2]!r} is not a number", path) from None
        if not (math.isfinite(step) and step >= 0):
            raise DataError(f"line {number}: step_s {fields[2]!r} is not a time >= 0", path)
        steps.append(step)
    return np.asarray(steps, dtype=float)


def make_shareable(folder: Path) -> None:
    """Give a ``tempfile.mkdtemp`` folder (mode 0700) the permissions of a plain ``mkdir``."""
    make_public(folder)


def write_run_dir(path: Path, record: RunRecord) -> None:
    """Write a RUN_DIR atomically (temporary folder next to it, then rename).

    An existing RUN_DIR of an earlier run (it has ``config.yaml``) or an empty folder is
    replaced; any other existing non-empty folder is refused.

    Raises:
        ConfigError: ``path`` exists, is not empty and is not a RUN_DIR.
    """
    path = Path(path)
    if path.exists() and (
        not path.is_dir() or (any(path.iterdir()) and not (path / CONFIG).exists())
    ):
        raise ConfigError(f"{path}: exists and is not a RUN_DIR; refusing to overwrite it")
    check_output_location(path, "RUN_DIR")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        remove_stale_temporaries(path)
        staging = Path(
            tempfile.mkdtemp(prefix=f".{path.name}.{os.getpid()}.", suffix=".tmp", dir=path.parent)
        )
    except OSError as exc:
        raise output_error(exc, path, "RUN_DIR") from None
    try:
        make_shareable(staging)
        write_tum(staging / TRAJECTORY, record.estimate.trajectory)
        _write_landmarks(
            staging / LANDMARKS, record.estimate.landmark_ids, record.estimate.landmarks_w
        )
        stamps = record.estimate.trajectory.stamps_s
        timing = ["frame,stamp_s,step_s"]
        timing += [
            f"{k},{stamps[k] if k < len(stamps) else math.nan:.17g},{s:.9f}"
            for k, s in enumerate(record.step_s)
        ]
        (staging / TIMING).write_text("\n".join(timing) + "\n")
        config = asdict(record.config)
        config["dataset_options"] = dict(record.config.dataset_options)
        config["estimator_options"] = dict(record.config.estimator_options)
        config["stages_wall_s"] = dict(record.config.stages_wall_s)
        config["stages_cpu_s"] = dict(record.config.stages_cpu_s)
        (staging / CONFIG).write_text(yaml.safe_dump(config, sort_keys=False))
        estimate = record.estimate
        if estimate.pose_covariances is not None:
            _write_covariances(
                staging / POSE_COVARIANCES,
                "frame",
                np.arange(len(estimate.trajectory)),
                estimate.pose_covariances,
            )
        if estimate.landmark_covariances is not None:
            _write_covariances(
                staging / LANDMARK_COVARIANCES,
                "id",
                estimate.landmark_ids,
                estimate.landmark_covariances,
            )
        for name, payload in record.attachments.items():
            if name not in ATTACHMENTS:
                raise ConfigError(f"unknown RUN_DIR attachment {name!r}; known: {ATTACHMENTS}")
            (staging / name).write_bytes(payload)
        gt = record.ground_truth
        if gt.trajectory is not None:
            write_tum(staging / GROUND_TRUTH, gt.trajectory)
        if len(gt.landmark_ids):
            _write_landmarks(staging / GROUND_TRUTH_LANDMARKS, gt.landmark_ids, gt.landmarks_w)
        if path.exists():
            trash = path.with_name(f".{path.name}.old-{os.getpid()}")
            os.replace(path, trash)
            os.replace(staging, path)
            shutil.rmtree(trash, ignore_errors=True)
        else:
            os.replace(staging, path)
    except OSError as exc:
        shutil.rmtree(staging, ignore_errors=True)
        raise output_error(exc, path, "RUN_DIR", atomic=True) from None
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # alive, someone else's
        return True
    return True


def remove_stale_temporaries(path: Path) -> list[Path]:
    """Remove what a killed ``write_run_dir`` of ``path`` left next to it.

    The staging folder (``.NAME.PID.*.tmp``) and the replaced RUN_DIR (``.NAME.old-PID``) carry
    the writer's process id; those of a process that no longer runs are removed (a SIGKILL
    skips every ``finally``). Those of a live process are left alone.

    Returns:
        The paths removed.
    """
    path = Path(path)
    removed = []
    prefix = f".{path.name}."
    for candidate in path.parent.glob(f"{glob.escape(prefix)}*"):
        rest = candidate.name[len(prefix) :]
        if rest.startswith("old-"):
            pid_text = rest[4:]
        elif rest.endswith(".tmp"):
            pid_text = rest.split(".", 1)[0]
        else:
            continue
        if not pid_text.isdigit() or _pid_alive(int(pid_text)):
            continue
        shutil.rmtree(candidate, ignore_errors=True)
        removed.append(candidate)
    return removed



def read_run_config(path: Path) -> RunConfig:
    """Read ``RUN_DIR/config.yaml``.

    Raises:
        DataError: missing file, not YAML, or keys missing / unknown.
    """
    file = Path(path) / CONFIG
    if not file.is_file():
        raise DataError(f"not a RUN_DIR (no {CONFIG})", Path(path))
    raw = read_yaml(file)
    if not isinstance(raw, dict):
        raise DataError("expected a mapping", file)
    try:
        config = RunConfig(**raw)
    except TypeError as exc:
        raise DataError(f"unexpected contents ({exc})", file) from exc
    if isinstance(config.frames, bool) or not isinstance(config.frames, int) or config.frames < 1:
        raise DataError(f"frames must be a positive integer, got {config.frames!r}", file)
    if config.images is not None and (
        isinstance(config.images, bool)
        or not isinstance(config.images, int)
        or not 0 <= config.images <= config.frames
    ):
        raise DataError(
            f"images must be an integer between 0 and frames ({config.frames}), "
            f"got {config.images!r}",
            file,
        )
    return config


def read_run_dir(path: Path) -> RunRecord:
    """Read a RUN_DIR written by ``write_run_dir``.

    Raises:
        DataError: a missing or malformed file (naming it), ``ground_truth.tum`` included when
            ``config.yaml`` says the run has ground truth.
    """
    path = Path(path)
    config = read_run_config(path)
    trajectory = read_tum(path / TRAJECTORY)
    if len(trajectory) != config.frames:
        raise DataError(
            f"{len(trajectory)} poses but {CONFIG} says the run had {config.frames} frames "
            "(one pose per frame): the file is truncated or from another run",
            path / TRAJECTORY,
        )
    ids, points = read_landmarks_csv(path / LANDMARKS)
    step_s = _read_timing(path / TIMING)
    if len(step_s) != config.frames:
        raise DataError(
            f"{len(step_s)} rows but {CONFIG} says the run had {config.frames} frames",
            path / TIMING,
        )
    try:
        kind = GroundTruthKind(config.ground_truth_kind)
    except ValueError:
        raise DataError(
            f"ground_truth_kind {config.ground_truth_kind!r} is not one of "
            f"{', '.join(k.value for k in GroundTruthKind)}",
            path / CONFIG,
        ) from None
    gt_trajectory = read_tum(path / GROUND_TRUTH) if (path / GROUND_TRUTH).is_file() else None
    if gt_trajectory is None and kind in _KINDS_WITH_TRAJECTORY:
        raise DataError(
            f"missing, but {CONFIG} says the run has {kind.value} ground truth", path / GROUND_TRUTH
        )
    if (path / GROUND_TRUTH_LANDMARKS).is_file():
        gt_ids, gt_points = read_landmarks_csv(path / GROUND_TRUTH_LANDMARKS)
    else:
        gt_ids, gt_points = np.zeros(0, dtype=np.int64), np.zeros((0, 3))
    pose_cov = landmark_cov = None
    if (path / POSE_COVARIANCES).is_file():
        frames, pose_cov = read_covariances_csv(path / POSE_COVARIANCES, "frame")
        if not np.array_equal(frames, np.arange(len(trajectory))):
            raise DataError("expected one row per pose, frames 0..N-1", path / POSE_COVARIANCES)
    if (path / LANDMARK_COVARIANCES).is_file():
        cov_ids, landmark_cov = read_covariances_csv(path / LANDMARK_COVARIANCES, "id")
        if not np.array_equal(cov_ids, ids):
            raise DataError(f"ids differ from {LANDMARKS}", path / LANDMARK_COVARIANCES)
    try:
        estimate = Estimate(
            trajectory=trajectory,
            landmark_ids=ids,
            landmarks_w=points,
            landmark_covariances=landmark_cov,
            pose_covariances=pose_cov,
        )
    except DataError as exc:
        raise DataError(f"inconsistent RUN_DIR ({exc})", path) from exc
    attachments = {
        name: (path / name).read_bytes() for name in ATTACHMENTS if (path / name).is_file()
    }
    return RunRecord(
        config=config,
        attachments=attachments,
        estimate=estimate,
        step_s=step_s,
        ground_truth=GroundTruth(
            kind=kind,
            trajectory=gt_trajectory,
            landmark_ids=gt_ids,
            landmarks_w=gt_points,
            note=config.ground_truth_note,
        ),
    )
