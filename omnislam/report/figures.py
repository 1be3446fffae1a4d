"""The figures of one dataset (``FIGURES``), each answering one question, drawn by ``plots``.

``dataset_figures`` draws them from the median seed of every estimator column -- the run whose
ATE RMSE is the median over seeds (``metrics.seeds``: with an even count, the lower of the two
middle ones), so a panel's ATE is the number the tables print -- and from every run for the
figures over seeds: ATE over seeds, accuracy against run time,
each trajectory coloured by its position error over the ground truth, error over distance,
landmark maps, step-time percentiles and -- where the data has laser scans (CARMEN, synthetic,
a folder's ``laser.csv``) -- occupancy grids built from the scans on every estimated trajectory
(``occupancy``; the beams start at the scanner, ``LaserScans.scanner_poses_w``). Every
estimate is drawn SE(2)-aligned to the ground truth as its ATE aligns it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from omnislam.datasets.registry import DatasetFormat
from omnislam.datasets.sequence import GroundTruthKind
from omnislam.errors import DataError, OmnislamError
from omnislam.harness.rundir import RunRecord, read_run_dir
from omnislam.metrics.seeds import median_index
from omnislam.metrics.trajectory import Alignment, AteResult, ate
from omnislam.report.model import Figure
from omnislam.report.options import ReportOptions
from omnislam.report.results import ReportCell, columns, gt_label

#: dataset formats whose Sequence can carry raw laser scans (occupancy grids)
LASER_FORMATS = (DatasetFormat.CARMEN, DatasetFormat.SYNTHETIC, DatasetFormat.FOLDER)

#: (file stem, caption) of each figure of a dataset, in report order; each answers one question
FIGURES: tuple[tuple[str, str], ...] = (
    (
        "trajectories",
        "Where along the path does each estimator go wrong? Each estimator's "
        "path (its median seed: the run whose ATE RMSE is the median over seeds, the lower of "
        "the two middle ones for an even count), SE(2)-aligned to the {gt} (dashed) and "
        "coloured by its position "
        "error on one logarithmic scale for all panels; the dot marks the start.",
    ),
    (
        "ate-seeds",
        "How accurate is each estimator over seeds? ATE RMSE of every seed (dots) "
        "and its median over seeds (bar; the lower middle value for an even count) against "
        "the {gt}.",
    ),
    (
        "accuracy-vs-time",
        "What does accuracy cost? ATE RMSE against the total run time of "
        "every run (log-log; ringed: the median over seeds). Wall-clock times of the machine in "
        "the provenance block.",
    ),
    (
        "error-over-distance",
        "How does the error grow with the distance travelled? RPE RMSE "
        "against segment length of ground-truth travel, translation and rotation (log-log; "
        "median seed).",
    ),
    (
        "landmarks",
        "Where does each estimator put the landmarks? Each map (median seed) "
        "aligned with its trajectory, over the true landmarks where the data has them; "
        "{sigma:g}-sigma covariance ellipses on maps of at most {most} landmarks (more overlap "
        "into a solid mass).",
    ),
    (
        "step-time",
        "How long does one step take, typically and at worst? Percentiles of the "
        "wall time of each estimator step (median seed; the line spans the 5th percentile to the "
        "maximum).",
    ),
    (
        "occupancy",
        "What map do the laser scans make on each trajectory? Occupancy grids "
        "({resolution:g} m cells) built from the scans on the ground truth and on the poses of "
        "every estimator with one pose per scan (any other is named under Notes).",
    ),
)


#: draws one figure: its file stem (``DATASET-KIND``) -> the SVG document
Draw = Callable[[str], str]
#: estimator column -> (gtTest (4, 4): its SE(2) alignment to the ground truth, its run)
Aligned = Mapping[str, tuple[np.ndarray, RunRecord]]


def dataset_figures(
    dataset: str,
    cells: Sequence[ReportCell],
    colours: Mapping[str, str],
    options: ReportOptions,
    notes: list[str],
) -> list[Figure]:
    """One dataset's figures, in ``FIGURES`` order (those its runs have data for).

    Args:
        dataset: the dataset's label.
        cells: its runs.
        colours: estimator column -> colour (``palette``).
        options: the report's options (occupancy grids and their resolution).
        notes: what could not be drawn is appended here (the report's Notes).
    """
    runs = _median_runs(cells)
    if not runs:
        return []
    label = gt_label(cells)
    aligned, results = _aligned_runs(runs)
    drawings: dict[str, Draw | None] = {
        **_over_seeds(dataset, cells, colours),
        "trajectories": _trajectories(dataset, label, runs, aligned, results, colours),
        "error-over-distance": _error_over_distance(dataset, runs, colours),
        "landmarks": _landmark_maps(dataset, runs[0][1], aligned, colours),
        "step-time": _step_times(dataset, runs, colours),
        "occupancy": (
            _occupancy(dataset, runs[0][1], aligned, label, options, notes, colours)
            if options.occupancy
            else None
        ),
    }
    stem = "".join(ch if ch.isalnum() or ch in "-_" else "-" for ch in dataset)
    drawn = [
        Figure(f"{stem}-{kind}.svg", caption(kind, label, options), draw(f"{stem}-{kind}"))
        for kind, draw in drawings.items()
        if draw is not None
    ]
    order = [kind for kind, _ in FIGURES]
    return sorted(drawn, key=lambda f: order.index(f.name[len(stem) + 1 : -len(".svg")]))


def caption(kind: str, gt_label: str, options: ReportOptions) -> str:
    """The caption of a figure of ``kind`` (a key of ``FIGURES``)."""
    from omnislam.report import plots

    text = dict(FIGURES)[kind]
    return text.format(
        gt=gt_label,
        sigma=plots.ELLIPSE_SIGMA,
        most=plots.ELLIPSE_MAX_LANDMARKS,
        resolution=options.occupancy_resolution_m,
    )


def _median_runs(cells: Sequence[ReportCell]) -> list[tuple[ReportCell, RunRecord]]:
    """The median seed of each column (``metrics.seeds.median_index`` of its ATE RMSE; the
    lowest seed when no run has an ATE), read from disk."""
    out = []
    for column in columns(cells):
        group = sorted(
            (c for c in cells if c.column == column and c.ok),
            key=lambda c: (c.seed is None, c.seed or 0),
        )
        if not group:
            continue
        scored = [c for c in group if c.metrics is not None and c.metrics.ate.rmse_m is not None]
        if scored:
            chosen = scored[median_index([c.metrics.ate.rmse_m for c in scored])]  # type: ignore[union-attr,misc]
        else:
            chosen = group[0]
        out.append((chosen, read_run_dir(chosen.run_dir)))  # type: ignore[arg-type]
    return out


def _aligned_runs(
    runs: Sequence[tuple[ReportCell, RunRecord]],
) -> tuple[dict[str, tuple[np.ndarray, RunRecord]], dict[str, AteResult | None]]:
    """(column -> (its alignment, its run), column -> its ATE or None): identity without one."""
    aligned, results = {}, {}
    for cell, record in runs:
        result = _ate_of(record)
        aligned[cell.column] = (result.gtTest if result is not None else np.eye(4), record)
        results[cell.column] = result
    return aligned, results


def _over_seeds(
    dataset: str, cells: Sequence[ReportCell], colours: Mapping[str, str]
) -> dict[str, Draw]:
    """ATE RMSE of every run by column ("ate-seeds") and against its run time
    ("accuracy-vs-time", when some run's total time is known)."""
    from omnislam.report import plots

    over_seeds = []
    for column in columns(cells):
        ok = [c for c in cells if c.column == column and c.ok and c.metrics is not None]
        pairs = [
            (c.metrics.ate.rmse_m, c.metrics.timing.total_s)  # type: ignore[union-attr]
            for c in ok
            if c.metrics.ate.rmse_m is not None  # type: ignore[union-attr]
        ]
        if pairs:
            ate_m = np.array([a for a, _ in pairs], dtype=float)
            total = np.array([t if t is not None else np.nan for _, t in pairs], dtype=float)
            over_seeds.append(plots.RunPoints(column, ate_m, total))
    if not over_seeds:
        return {}
    drawings = {"ate-seeds": lambda n: plots.ate_over_seeds(n, dataset, over_seeds, colours)}
    if any(np.isfinite(p.total_s).any() for p in over_seeds):
        drawings["accuracy-vs-time"] = lambda n: plots.accuracy_vs_time(
            n, dataset, over_seeds, colours
        )
    return drawings


def _trajectories(
    dataset: str,
    label: str,
    runs: Sequence[tuple[ReportCell, RunRecord]],
    aligned: Aligned,
    results: Mapping[str, AteResult | None],
    colours: Mapping[str, str],
) -> Draw:
    """Each estimator's path over the ground truth, coloured by its position error."""
    from omnislam.report import plots

    truth = runs[0][1].ground_truth
    truth_xy = truth.trajectory.positions_w[:, :2] if truth.trajectory is not None else None
    paths = []
    for cell, record in runs:
        T, result = aligned[cell.column][0], results[cell.column]
        paths.append(
            plots.TrajectorySeries(
                cell.column,
                _aligned_se2(record, T)[:, :2],
                _pose_errors(record, result) if result is not None else None,
                result.rmse_m if result is not None else None,
            )
        )
    return lambda n: plots.trajectories(n, dataset, label, truth_xy, paths, colours)


def _error_over_distance(
    dataset: str, runs: Sequence[tuple[ReportCell, RunRecord]], colours: Mapping[str, str]
) -> Draw | None:
    """RPE RMSE against segment length, translation and rotation (None: no curve)."""
    from omnislam.report import plots

    translation, rotation = [], []
    for cell, _ in runs:
        curve = (cell.metrics.rpe.by_distance if cell.metrics is not None else None) or ()
        if curve:
            lengths = np.array([p.length_m for p in curve], dtype=float)
            trans = np.array([p.trans_rmse_m for p in curve], dtype=float)
            translation.append(plots.Series(cell.column, np.column_stack([lengths, trans])))
            rot = [p.rot_rmse_deg for p in curve]
            if all(r is not None for r in rot):
                rotation.append(
                    plots.Series(cell.column, np.column_stack([lengths, np.array(rot, float)]))
                )
    if not translation:
        return None
    return lambda n: plots.error_over_distance(n, dataset, translation, rotation, colours)


def _landmark_maps(
    dataset: str, reference: RunRecord, aligned: Aligned, colours: Mapping[str, str]
) -> Draw | None:
    """Each estimated map aligned with its trajectory, over the true landmarks (None: no map)."""
    from omnislam.report import plots

    truth = reference.ground_truth
    truth_lm = truth.landmarks_w[:, :2] if len(truth.landmark_ids) else None
    maps = []
    for column, (T, record) in aligned.items():
        estimate = record.estimate
        if not len(estimate.landmark_ids):
            continue
        xy = estimate.landmarks_w[:, :2] @ T[:2, :2].T + T[:2, 3]
        cov = None
        if estimate.landmark_covariances is not None:
            R = T[:2, :2]
            cov = R @ estimate.landmark_covariances[:, :2, :2] @ R.T
        maps.append(plots.LandmarkSeries(column, xy, cov))
    if not maps:
        return None
    return lambda n: plots.landmark_maps(n, dataset, truth_lm, maps, colours)


def _step_times(
    dataset: str, runs: Sequence[tuple[ReportCell, RunRecord]], colours: Mapping[str, str]
) -> Draw | None:
    """Percentiles of the wall time of each estimator step [ms] (None: no steps)."""
    from omnislam.report import plots

    steps = [
        plots.Series(
            cell.column,
            np.column_stack([np.arange(len(record.step_s)), 1e3 * np.asarray(record.step_s)]),
        )
        for cell, record in runs
        if len(record.step_s)
    ]
    if not steps:
        return None
    return lambda n: plots.step_times(n, dataset, steps, colours)


def _occupancy(
    dataset: str,
    reference: RunRecord,
    aligned: Aligned,
    label: str,
    options: ReportOptions,
    notes: list[str],
    colours: Mapping[str, str],
) -> Draw | None:
    """Occupancy grids on the ground truth and every estimated trajectory (None: no scans)."""
    from omnislam.report import plots

    grids = _occupancy_grids(reference, aligned, label, options, notes)
    if not grids:
        return None
    return lambda n: plots.occupancy(n, dataset, grids, colours)


def _ate_of(record: RunRecord) -> AteResult | None:
    """The SE(2) ATE the metrics use, with its per-pose errors (None without ground truth)."""
    truth = record.ground_truth.trajectory
    if truth is None:
        return None
    oriented = record.ground_truth.kind is not GroundTruthKind.GPS_PARTIAL
    try:
        return ate(record.estimate.trajectory, truth, Alignment.SE2, truth_has_orientation=oriented)
    except DataError:  # too few poses with ground truth: drawn unaligned
        return None


def _aligned_se2(record: RunRecord, T: np.ndarray) -> np.ndarray:
    xyt = record.estimate.trajectory.se2
    xy = xyt[:, :2] @ T[:2, :2].T + T[:2, 3]
    return np.column_stack([xy, xyt[:, 2] + math.atan2(T[1, 0], T[0, 0])])


def _pose_errors(record: RunRecord, result: AteResult) -> np.ndarray:
    """The position error at every estimate pose [m]: the ATE's errors where a pose has ground
    truth, linearly interpolated over time in between (GPS gaps)."""
    stamps = record.estimate.trajectory.stamps_s
    if len(result.stamps_s) == len(stamps):
        return result.errors_m
    return np.interp(stamps, result.stamps_s, result.errors_m)


def _occupancy_grids(
    reference: RunRecord,
    aligned: Mapping[str, tuple[np.ndarray, RunRecord]],
    gt_label: str,
    options: ReportOptions,
    notes: list[str],
) -> list[tuple[str, object]]:
    """Occupancy grids on the ground truth and on each estimator's poses (laser data only)."""
    from omnislam.datasets.registry import load_dataset, resolve
    from omnislam.report.occupancy import occupancy_grid

    config = reference.config
    try:
        resolved = resolve(config.dataset)
        if resolved.format not in LASER_FORMATS:
            return []  # no raw scans in this format: do not load the data for nothing
        sequence = load_dataset(resolved, dict(config.dataset_options))
    except OmnislamError as exc:
        notes.append(f"{config.dataset}: no occupancy grid, the data could not be read ({exc})")
        return []
    laser = sequence.laser
    if laser is None:
        return []
    grids: list[tuple[str, object]] = []

    def build(poses: np.ndarray) -> object:
        return occupancy_grid(
            laser.scanner_poses_w(poses),  # the beams start at the scanner, not the robot
            laser.angles_rad,
            laser.ranges_m,
            laser.max_range_m,
            resolution_m=options.occupancy_resolution_m,
        )

    truth = sequence.ground_truth.trajectory
    if truth is not None and len(truth) == len(sequence):
        grids.append((gt_label.split(" (")[0], build(truth.se2)))
    for column, (T, record) in aligned.items():
        if len(record.estimate.trajectory) != len(sequence):
            notes.append(f"{config.dataset}: {column} has no pose per scan; no occupancy grid")
            continue
        grids.append((column, build(_aligned_se2(record, T))))
    return grids
