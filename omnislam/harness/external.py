"""Results of other systems as grid cells: ``estimator: external`` reads them from files.

A grid cell ``{estimator: external, label: mysys, files: "results/{dataset}/{seed}.tum"}``
(``harness.grid`` validates the keys) is a run that was not made here: its trajectory (TUM, or
KITTI with one pose per frame of the dataset, whose frame stamps it takes) and optionally its
landmark map (``id,x,y,z`` CSV, the RUN_DIR's own ``landmarks.csv`` format) are read from the
files named for its dataset and seed. ``external_record`` makes of them the RunRecord a run
would have made: the dataset's ground truth (its reference solution where it has one,
``harness.reference``), the estimate, and a ``RunConfig`` whose ``external`` field says where
the results came from, with each file's SHA-256. From there on the cell is a cell like any
other: written as a RUN_DIR, evaluated, tabled, drawn and ranked beside the built-in estimators,
and its provenance says it was not run here. It has no step times (its timing metrics are
missing, not zero).
"""

from __future__ import annotations

import enum
import hashlib
import string
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from omnislam.core.types import Estimate, Trajectory
from omnislam.errors import ConfigError, DataError
from omnislam.harness.execute import RunSpec, parse_run_options
from omnislam.harness.reference import reference_for
from omnislam.harness.rundir import RunConfig, RunRecord, read_landmarks_csv

#: the estimator name of a cell whose results are read from files
EXTERNAL = "external"
#: the placeholders a file pattern may hold
PLACEHOLDERS = frozenset({"dataset", "seed"})


class TrajectoryFormat(enum.Enum):
    """How an external trajectory file is written."""

    AUTO = "auto"  # detected from the number of values on a line (8: TUM, 12: KITTI)
    TUM = "tum"
    KITTI = "kitti"


@dataclass(frozen=True, slots=True)
class ExternalResult:
    """The files of one external cell (its dataset and seed filled in).

    Attributes:
        trajectory: the trajectory file (absolute path).
        format: its format.
        landmarks: the landmark map, ``id,x,y,z`` CSV, or None (the system gives no map).
        true_landmark_ids: the map's ids are the dataset's landmark ids (it associates by
            them, as omnislam's estimators do when the sightings carry true ids); False: the
            map is matched to the true landmarks by optimal assignment within the gate.
    """

    trajectory: str
    format: TrajectoryFormat = TrajectoryFormat.AUTO
    landmarks: str | None = None
    true_landmark_ids: bool = False


def pattern_fields(pattern: str) -> set[str]:
    """The placeholders ``{NAME}`` of a file pattern.

    Raises:
        ConfigError: a malformed pattern (an unmatched brace, a format spec).
    """
    try:
        parsed = list(string.Formatter().parse(pattern))
    except ValueError as exc:
        raise ConfigError(f"malformed pattern {pattern!r} ({exc})") from None
    names = {name for _, name, spec, conversion in parsed if name is not None}
    if any(spec or conversion for _, name, spec, conversion in parsed if name is not None):
        raise ConfigError(f"pattern {pattern!r}: placeholders take no format spec")
    return names


def fill_pattern(pattern: str, base: Path, dataset: str, seed: int) -> Path:
    """The file a pattern names for one dataset label and seed (relative to ``base``)."""
    path = Path(pattern.format(dataset=dataset, seed=seed)).expanduser()
    return (path if path.is_absolute() else base / path).absolute()


def file_digest(path: Path) -> str:
    """SHA-256 of a file, hex."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def read_external_trajectory(external: ExternalResult, frame_stamps_s: np.ndarray) -> Trajectory:
    """The external trajectory; a KITTI file (no stamps) takes the dataset's frame stamps.

    Raises:
        DataError: a malformed file (naming it and the line), or a KITTI file whose pose count
            is not the dataset's frame count.
    """
    from omnislam.datasets.trajectory_io import detect_trajectory_format, read_kitti, read_tum

    path = Path(external.trajectory)
    fmt = external.format
    if fmt is TrajectoryFormat.AUTO:
        fmt = TrajectoryFormat(detect_trajectory_format(path))
    if fmt is TrajectoryFormat.TUM:
        return read_tum(path)
    poses = read_kitti(path)
    if len(poses) != len(frame_stamps_s):
        raise DataError(
            f"{len(poses)} KITTI poses but the dataset has {len(frame_stamps_s)} frames (a "
            "KITTI file has no stamps: one pose per frame; or write TUM with stamps)",
            path,
        )
    return Trajectory(np.asarray(frame_stamps_s, dtype=float), poses.poses_w)


def _estimate(external: ExternalResult, trajectory: Trajectory) -> Estimate:
    """The estimate the files hold (no covariances: the files carry none)."""
    if external.landmarks is None:
        return Estimate(trajectory=trajectory)
    ids, points_w = read_landmarks_csv(Path(external.landmarks))
    return Estimate(trajectory=trajectory, landmark_ids=ids, landmarks_w=points_w)


def provenance(external: ExternalResult) -> str:
    """What the RUN_DIR's ``config.yaml`` says of results that were not run here."""
    files = [external.trajectory] + ([external.landmarks] if external.landmarks else [])
    listed = "; ".join(f"{f} (sha256 {file_digest(Path(f))})" for f in files)
    return f"not run here: results of another system read from {listed}"


def external_record(spec: RunSpec, external: ExternalResult) -> RunRecord:
    """The RunRecord of an external cell: its files as the estimate, the dataset's ground truth.

    Args:
        spec: the cell's run (dataset, seed and loader options; ``spec.estimator`` is
            ``EXTERNAL``).
        external: its files.

    Raises:
        DataError: a dataset, trajectory or landmark file that is missing or malformed.
        ConfigError: options other than the loader's.
    """
    from omnislam._version import __version__
    from omnislam.datasets.registry import load_dataset, resolve

    resolved = resolve(spec.dataset)
    options = parse_run_options(spec.options, resolved.option_names())
    if options.estimator:
        raise ConfigError(
            f"an external cell takes loader options only, got {', '.join(options.estimator)}"
        )
    sequence = load_dataset(resolved, options.dataset)
    ground_truth, reference = reference_for(resolved.format, resolved.path, sequence)
    trajectory = read_external_trajectory(external, sequence.stamps_s)
    estimate = _estimate(external, trajectory)
    config = RunConfig(
        dataset=spec.dataset,
        dataset_path=str(resolved.path),
        estimator=EXTERNAL,
        omnislam_version=__version__,
        frames=len(trajectory),
        total_s=0.0,
        peak_rss_mb=0.0,
        ground_truth_kind=ground_truth.kind.value,
        ground_truth_note=ground_truth.note,
        ground_truth_reference=reference or None,
        source=sequence.source,
        seed=spec.seed,
        dataset_options=options.dataset,
        landmark_ids_from_truth=external.true_landmark_ids,
        external=provenance(external),
    )
    return RunRecord(config, estimate, np.zeros(len(trajectory)), ground_truth)
