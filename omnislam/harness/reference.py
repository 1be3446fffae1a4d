"""Reference solutions that stand in for ground truth where a dataset has none.

gtsam's ``victoria_park.txt`` (``victoria-park-gtsam``, format ``gtsam-graph``) carries odometry
and landmark sightings with ids but no ground truth. Its runs are scored against the
**warm-started LM optimum** (``REFERENCE_LM_OPTIMUM`` = "lm-optimum"), computed from the data
with GTSAM's own classes and none of omnislam's estimators (a reference must not be one of the
contestants):

1. the graph of the file's odometry (its stated covariances) and sightings (their landmark ids,
   known association whatever the run used), built from gtsam factors one frame at a time
   (``graph_frames``), through a plain ``gtsam.ISAM2`` pass (``isam2_pass``: relinearisation
   threshold 0.1 checked every update, docs/design.md "iSAM2 settings"; the first pose held at the
   origin by a 1 mm / 1 mrad prior);
2. ``gtsam.LevenbergMarquardtOptimizer`` on every factor, started from the iSAM2 solution.
   docs/design.md: LM from dead reckoning stops in a local minimum 19 m RMS off, from the iSAM2
   solution it reaches the optimum in 2-3 iterations.

``benchmarks/graphslam_victoria.py`` times the same ``isam2_pass`` against omnislam's iSAM2.

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
import time
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from omnislam._files import NPZ_ERRORS
from omnislam.core.types import UNKNOWN_ID, FrameInput, Trajectory
from omnislam.datasets.registry import DatasetFormat
from omnislam.datasets.sequence import GroundTruth, GroundTruthKind, Sequence
from omnislam.errors import DataError, EstimationError
from omnislam.harness.cache import cache_dir

#: the label of the warm-started LM optimum in metrics.json (``reference``)
REFERENCE_LM_OPTIMUM = "lm-optimum"
#: what the cached numbers are a function of, besides the data file (bump on any change)
RECIPE = (
    "lm-optimum v2: gtsam factors of the file's odometry (its covariances) and sightings, prior "
    "1e-3 at the origin; plain gtsam.ISAM2 pass (threshold 0.1, skip 1); gtsam LM 100 its, 1e-10"
)
#: the anchoring prior's sigmas (x [m], y [m], theta [rad]) and the iSAM2 settings of the pass
PRIOR_SIGMAS = (1e-3, 1e-3, 1e-3)
RELINEARIZE_THRESHOLD = 0.1
RELINEARIZE_SKIP = 1
#: Levenberg-Marquardt stopping rules
LM_MAX_ITERATIONS = 100
LM_RELATIVE_ERROR_TOL = 1e-10

LM_OPTIMUM_NOTE = (
    "reference = lm-optimum: Levenberg-Marquardt optimum of the file's known-association graph, "
    "warm-started from a plain gtsam iSAM2 pass (not independent ground truth)"
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


@dataclass(frozen=True, slots=True)
class GraphFrame:
    """One frame as plain numbers for the bare GTSAM loop (built before any timing).

    Attributes:
        delta_r: (3,) odometry [dx, dy, dtheta] into the frame, robot frame [m, m, rad].
        covariance: (3, 3) its stated covariance, or None.
        sightings: (landmark id, range [m], bearing [rad], sigma_range [m], sigma_bearing [rad])
            of each range-bearing sighting.
    """

    delta_r: np.ndarray
    covariance: np.ndarray | None
    sightings: tuple[tuple[int, float, float, float, float], ...]


def graph_frames(frames: Iterable[FrameInput]) -> list[GraphFrame]:
    """The odometry and range-bearing sightings of ``frames`` as ``GraphFrame`` records."""
    out = []
    for frame in frames:
        rb = frame.range_bearing
        sightings: tuple[tuple[int, float, float, float, float], ...] = ()
        if rb is not None:
            sightings = tuple(
                zip(
                    rb.landmark_ids.tolist(),
                    rb.ranges_m.tolist(),
                    rb.bearings_rad.tolist(),
                    rb.sigma_range_m.tolist(),
                    rb.sigma_bearing_rad.tolist(),
                    strict=True,
                )
            )
        out.append(GraphFrame(frame.odometry.delta, frame.odometry.covariance, sightings))
    return out


@dataclass(frozen=True, slots=True)
class ISAM2Pass:
    """The outcome of ``isam2_pass``.

    Attributes:
        isam: the ``gtsam.ISAM2`` holding every factor (``getFactorsUnsafe``) and the estimate.
        step_s: (N,) wall time of each frame's work (factors, update, newest-pose read) [s].
    """

    isam: Any
    step_s: np.ndarray


def isam2_pass(
    frames: list[GraphFrame],
    odometry_sigmas: tuple[float, float, float] | None = None,
) -> ISAM2Pass:
    """One plain ``gtsam.ISAM2`` update per frame, written directly against GTSAM's Python API.

    Per frame: a ``Pose2`` at the newest estimate composed with the odometry, with a
    ``BetweenFactorPose2`` (or, for frame 0, a ``PriorFactorPose2`` at the origin with
    ``PRIOR_SIGMAS``); one ``BearingRangeFactor2D`` per sighting, a landmark entering at its
    first sighting's point; one ``ISAM2.update``; a read of the newest pose only.

    Args:
        frames: the frames (``graph_frames``).
        odometry_sigmas: fixed (sx [m], sy [m], stheta [rad]) of every odometry factor (one
            shared diagonal model); None uses each frame's stated covariance.

    Returns:
        The ISAM2Pass.

    Raises:
        DataError: a frame without a covariance when ``odometry_sigmas`` is None.
        EstimationError: an iSAM2 update failed.
    """
    from omnislam._optional import require

    gtsam = require("gtsam")
    from gtsam.symbol_shorthand import L, X

    params = gtsam.ISAM2Params()
    params.setRelinearizeThreshold(RELINEARIZE_THRESHOLD)
    params.relinearizeSkip = RELINEARIZE_SKIP
    isam = gtsam.ISAM2(params)
    fixed = None
    if odometry_sigmas is not None:
        fixed = gtsam.noiseModel.Diagonal.Sigmas(np.asarray(odometry_sigmas, dtype=float))
    prior_noise = gtsam.noiseModel.Diagonal.Sigmas(np.asarray(PRIOR_SIGMAS))
    sighting_noise: dict[tuple[float, float], Any] = {}
    seen: set[int] = set()
    latest = gtsam.Pose2()
    step_s = np.empty(len(frames))
    clock = time.perf_counter
    for k, frame in enumerate(frames):
        start = clock()
        graph = gtsam.NonlinearFactorGraph()
        values = gtsam.Values()
        if k == 0:
            guess = gtsam.Pose2()
            graph.add(gtsam.PriorFactorPose2(X(0), guess, prior_noise))
        else:
            delta = frame.delta_r
            odometry = gtsam.Pose2(delta[0], delta[1], delta[2])
            guess = latest.compose(odometry)
            noise = fixed
            if noise is None:
                if frame.covariance is None:
                    raise DataError(f"frame {k}: no odometry covariance for the reference")
                noise = gtsam.noiseModel.Gaussian.Covariance(frame.covariance)
            graph.add(gtsam.BetweenFactorPose2(X(k - 1), X(k), odometry, noise))
        values.insert(X(k), guess)
        for lid, r, b, s_r, s_b in frame.sightings:
            if lid not in seen:
                seen.add(lid)
                values.insert(
                    L(lid), guess.transformFrom(gtsam.Point2(r * np.cos(b), r * np.sin(b)))
                )
            noise = sighting_noise.get((s_b, s_r))
            if noise is None:
                noise = sighting_noise[(s_b, s_r)] = gtsam.noiseModel.Diagonal.Sigmas(
                    np.array([s_b, s_r])
                )
            graph.add(gtsam.BearingRangeFactor2D(X(k), L(lid), gtsam.Rot2(b), r, noise))
        try:
            isam.update(graph, values)
        except RuntimeError as exc:
            raise EstimationError(f"iSAM2 update at frame {k} failed: {exc}") from exc
        latest = isam.calculateEstimatePose2(X(k))
        step_s[k] = clock() - start
    return ISAM2Pass(isam, step_s)


def compute_lm_reference(sequence: Sequence) -> ReferenceSolution:
    """The warm-started LM optimum of a range-bearing sequence with known ids (no cache).

    Built from gtsam classes only (see the module docstring): ``isam2_pass`` over the frames
    with their stated odometry covariances, then ``gtsam.LevenbergMarquardtOptimizer`` on every
    factor from the iSAM2 estimate.

    Args:
        sequence: frames with odometry and its stated covariances, and range-bearing sightings
            carrying landmark ids.

    Returns:
        The ReferenceSolution (frame 0 at the origin, as the estimators start).

    Raises:
        DataError: a sighting without an id (the reference needs the known association), or
            odometry without a stated covariance.
    """
    from omnislam._optional import require

    gtsam = require("gtsam")
    frames = graph_frames(sequence.frame_inputs())
    if any(s[0] == UNKNOWN_ID for frame in frames for s in frame.sightings):
        raise DataError(f"{sequence.name}: the LM reference needs the sightings' landmark ids")
    warm = isam2_pass(frames).isam
    graph, initial = warm.getFactorsUnsafe(), warm.calculateEstimate()
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(LM_MAX_ITERATIONS)
    params.setRelativeErrorTol(LM_RELATIVE_ERROR_TOL)
    optimizer = gtsam.LevenbergMarquardtOptimizer(graph, initial, params)
    optimum = optimizer.optimize()
    ids = sorted({s[0] for frame in frames for s in frame.sightings})  # the key order of L(id)
    return ReferenceSolution(
        stamps_s=np.asarray(sequence.stamps_s),
        poses_w=gtsam.utilities.extractPose2(optimum).reshape(-1, 3),
        landmark_ids=np.asarray(ids, dtype=np.int64),
        landmarks_w=gtsam.utilities.extractPoint2(optimum).reshape(-1, 2),
        iterations=int(optimizer.iterations()),
        initial_error=float(graph.error(initial)),
        final_error=float(graph.error(optimum)),
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
    except NPZ_ERRORS:  # no cache entry, or a truncated one: recompute
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
