"""Reference solutions that stand in for ground truth where a dataset has none.

gtsam's ``victoria_park.txt`` (``victoria-park-gtsam``, format ``gtsam-graph``) carries odometry
and landmark sightings with ids but no ground truth. Its runs are scored against the
**warm-started LM optimum** (``REFERENCE_LM_OPTIMUM`` = "lm-optimum"):

1. the file's graph with its own landmark ids (known association, whatever the run used) through
   omnislam's iSAM2 (``GraphSLAM``, preset ``victoria-park-gtsam`` with the file's stated
   odometry covariances);
2. Levenberg-Marquardt on every factor, started from the iSAM2 solution
   (``graphslam.batch.warm_started_lm``). DESIGN.md: LM from dead reckoning stops in a local
   minimum 19 m RMS off, from the iSAM2 solution it reaches the optimum in 2-3 iterations.

It is the maximum-likelihood estimate of the same data, **not independent ground truth**: an
estimator run on the known-association graph is scored on how close it gets to the optimum,
one with unknown association on what its association costs. Metrics label it with
``GroundTruthKind.REFERENCE`` and ``reference = "lm-optimum"``.

Computing it takes ~35 s on the full file, so ``lm_reference`` caches the result (a small
``.npz``, ~0.2 MB) in ``cache_dir()`` under the SHA-256 of the data file and of ``RECIPE``; a
changed file or recipe never reuses a stale reference.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from omnislam.core.types import Trajectory
from omnislam.datasets.registry import DatasetFormat
from omnislam.datasets.sequence import GroundTruth, GroundTruthKind, Sequence
from omnislam.errors import DataError

#: the label of the warm-started LM optimum in metrics.json (``reference``)
REFERENCE_LM_OPTIMUM = "lm-optimum"
#: environment variable naming the cache folder (default ``$XDG_CACHE_HOME/omnislam`` or
#: ``~/.cache/omnislam``)
CACHE_ENV = "OMNISLAM_CACHE"
#: what the cached numbers are a function of, besides the data file (bump on any change)
RECIPE = "lm-optimum v1: iSAM2 preset victoria-park-gtsam, file covariances; LM 100 its, 1e-10"

LM_OPTIMUM_NOTE = (
    "reference = lm-optimum: Levenberg-Marquardt optimum of the file's known-association graph, "
    "warm-started from omnislam's iSAM2 solution (not independent ground truth)"
)


@dataclass(frozen=True, slots=True)
class ReferenceSolution:
    """A reference trajectory and map.

    Attributes:
        stamps_s: (N,) frame stamps of the sequence [s].
        poses_w: (N, 3) poses [x, y, theta] in the world (frame 0 at the origin) [m, m, rad].
        landmark_ids: (M,) the data's landmark ids.
        landmarks_w: (M, 2) landmark positions [m].
        iterations: LM iterations taken.
        initial_error: graph error at the iSAM2 solution (0.5 * sum of whitened squares).
        final_error: graph error at the optimum.
    """

    stamps_s: np.ndarray
    poses_w: np.ndarray
    landmark_ids: np.ndarray
    landmarks_w: np.ndarray
    iterations: int
    initial_error: float
    final_error: float

    def ground_truth(self) -> GroundTruth:
        """As the GroundTruth record runs are scored against (kind REFERENCE)."""
        return GroundTruth(
            kind=GroundTruthKind.REFERENCE,
            trajectory=Trajectory.from_se2(self.stamps_s, self.poses_w),
            landmark_ids=self.landmark_ids,
            landmarks_w=np.column_stack([self.landmarks_w, np.zeros(len(self.landmarks_w))]),
            note=LM_OPTIMUM_NOTE,
        )


def cache_dir() -> Path:
    """The folder of cached reference solutions (``$OMNISLAM_CACHE`` or the user cache)."""
    override = os.environ.get(CACHE_ENV)
    if override:
        return Path(override).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "omnislam"


def cache_key(path: Path) -> str:
    """SHA-256 of the data file's bytes and of ``RECIPE`` (hex)."""
    digest = hashlib.sha256(RECIPE.encode())
    try:
        with open(path, "rb") as stream:
            for block in iter(lambda: stream.read(1 << 20), b""):
                digest.update(block)
    except OSError as exc:
        raise DataError(f"cannot read ({exc.strerror})", Path(path)) from exc
    return digest.hexdigest()


def compute_lm_reference(sequence: Sequence) -> ReferenceSolution:
    """The warm-started LM optimum of a range-bearing sequence with known ids (no cache).

    Args:
        sequence: frames with odometry (and its stated covariances) and range-bearing sightings
            carrying landmark ids.

    Returns:
        The ReferenceSolution (frame 0 at the origin, as the estimators start).

    Raises:
        DataError: a sighting without an id (the reference needs the known association).
    """
    from omnislam.core.modality import Modality
    from omnislam.core.types import UNKNOWN_ID
    from omnislam.graphslam.batch import BatchGraphSLAM
    from omnislam.graphslam.config import PRESETS

    if any(
        rb is not None and np.any(rb.landmark_ids == UNKNOWN_ID)
        for rb in sequence.range_bearing or ()
    ):
        raise DataError(f"{sequence.name}: the LM reference needs the sightings' landmark ids")
    # the file's own odometry covariances (on victoria_park.txt equal to the preset's sigmas)
    estimator = BatchGraphSLAM(
        Modality.RANGE_BEARING_2D,
        dataclasses.replace(PRESETS["victoria-park-gtsam"], odometry_sigmas=None),
    )
    for frame in sequence.frame_inputs():
        estimator.step(frame)
    result = estimator.optimize()  # graphslam.batch.warm_started_lm
    estimate = estimator.estimate()  # the same LM solution as an Estimate
    return ReferenceSolution(
        stamps_s=np.asarray(sequence.stamps_s),
        poses_w=estimate.trajectory.se2,
        landmark_ids=np.asarray(estimate.landmark_ids, dtype=np.int64),
        landmarks_w=np.asarray(estimate.landmarks_w[:, :2]),
        iterations=result.iterations,
        initial_error=result.initial_error,
        final_error=result.final_error,
    )


def lm_reference(path: Path, cache: Path | None = None) -> ReferenceSolution:
    """The warm-started LM optimum of a gtsam graph file, from the cache when it is there.

    Args:
        path: a file in gtsam's 2-D graph format (e.g. gtsam's ``victoria_park.txt``).
        cache: cache folder (default ``cache_dir()``); the file ``lm-optimum-<key>.npz`` is
            keyed by ``cache_key(path)``. An unreadable cache entry is recomputed.

    Returns:
        The ReferenceSolution.

    Raises:
        DataError: the data file is missing or malformed.
    """
    from omnislam.datasets.gtsam_victoria import load_gtsam_victoria

    path = Path(path)
    folder = cache_dir() if cache is None else Path(cache)
    entry = folder / f"{REFERENCE_LM_OPTIMUM}-{cache_key(path)}.npz"
    try:
        with np.load(entry, allow_pickle=False) as data:
            return ReferenceSolution(
                stamps_s=data["stamps_s"],
                poses_w=data["poses_w"],
                landmark_ids=data["landmark_ids"],
                landmarks_w=data["landmarks_w"],
                iterations=int(data["iterations"]),
                initial_error=float(data["initial_error"]),
                final_error=float(data["final_error"]),
            )
    except (OSError, KeyError, ValueError):
        pass
    solution = compute_lm_reference(load_gtsam_victoria(path))
    _store(entry, solution)
    return solution


def _store(entry: Path, solution: ReferenceSolution) -> None:
    """Write a cache entry atomically; a cache that cannot be written is skipped silently."""
    try:
        entry.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=entry.parent, prefix=f".{entry.name}.", suffix=".tmp")
    except OSError:
        return
    try:
        with os.fdopen(fd, "wb") as stream:
            np.savez_compressed(stream, **dataclasses.asdict(solution))
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes it private; the cache may be shared
        os.replace(tmp, entry)
    except OSError:
        Path(tmp).unlink(missing_ok=True)


def reference_for(fmt: DatasetFormat, path: Path, sequence: Sequence) -> tuple[GroundTruth, str]:
    """The ground truth a run is scored against, and the name of the reference (or "").

    A sequence with ground truth of its own keeps it (reference ""). A gtsam graph file without
    one gets the warm-started LM optimum (``REFERENCE_LM_OPTIMUM``) when gtsam is installed.

    Args:
        fmt: the dataset's format.
        path: the dataset's file.
        sequence: the loaded sequence (its own ground truth).
    """
    own = sequence.ground_truth
    if own.kind is not GroundTruthKind.NONE or fmt is not DatasetFormat.GTSAM_GRAPH:
        return own, ""
    try:
        import gtsam  # noqa: F401
    except ImportError:
        return own, ""
    return lm_reference(path).ground_truth(), REFERENCE_LM_OPTIMUM
