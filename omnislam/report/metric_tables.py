"""The report's tables of numbers: per dataset and estimator over seeds, each seed, the verdicts,
the headline.

Every number summarising a cell over its seeds is its median with the min-max range
(``metrics.seeds``; ``seed_number``: the text the tables show and the numbers the CSV writes),
"deterministic" where the estimator repeats one run for every seed; the values of each run are
in a table of their own (``seeds_table``). Each dataset's table puts every estimator column
beside the dead-reckoning baseline (``DETAIL_COLUMNS``), its association counts come from each
run's ``estimator_info.json`` (``ASSOCIATION_COUNTS``), and the verdict of each dataset and
input (``metrics.verdict``) is one row per method family of the verdict table.
"""

from __future__ import annotations

import json
from collections.abc import Sequence

from omnislam.errors import DataError
from omnislam.harness.layout import ESTIMATOR_INFO
from omnislam.metrics.consistency import INCONSISTENT_FACTOR
from omnislam.metrics.seeds import STATISTIC, SeedSummary, summarise_seeds
from omnislam.metrics.verdict import ColumnSummary, Verdict, rank_families, separated
from omnislam.report.results import (
    BASELINE,
    Metric,
    ReportCell,
    ate_rmse,
    columns,
    deterministic,
    family_of,
    gt_label,
    input_label,
    method_of,
    values,
)
from omnislam.report.tables import Cell, Num, Table, make_table, slug


def seed_number(summary: SeedSummary | None, digits: int = 3) -> Num:
    """A cell's summary over seeds as a table shows it (median [min–max]) and the CSV writes it
    (median, min, max); "–" without values."""
    if summary is None:
        return Num("–")
    if summary.has_spread:
        return Num(summary.text(digits), summary.median, summary.low, summary.high)
    return Num(summary.text(digits), summary.median)


def column_summary(cells: Sequence[ReportCell], metric: Metric) -> SeedSummary | None:
    """``metric`` of the successful runs of one column over seeds."""
    ok = [c for c in cells if c.ok]
    return summarise_seeds(values(ok, metric), deterministic(ok))


def nees_text(cells: Sequence[ReportCell]) -> Num:
    """The median pose NEES of a column over seeds, "inconsistent" when it exceeds
    ``INCONSISTENT_FACTOR`` times its degrees of freedom (a value like 1e44 means nothing)."""
    summary = column_summary(cells, lambda m: m.nees.pose_median)
    dof = next((c.metrics.nees.pose_dof for c in cells if c.ok and c.metrics is not None
                and c.metrics.nees.pose_dof), None)
    if summary is None or dof is None:
        return Num("–")
    if summary.median > INCONSISTENT_FACTOR * dof:
        return Num("inconsistent", summary.median)
    return seed_number(summary)


#: the columns of a dataset's table: header and the metric it summarises over seeds (None: the
#: ratio to dead reckoning, matched / estimated landmarks, NEES, the seeds)
DETAIL_COLUMNS: tuple[tuple[str, Metric | None], ...] = (
    ("ATE RMSE [m]", ate_rmse),
    ("ATE / dead reckoning", None),
    ("ATE max [m]", lambda m: m.ate.max_m),
    ("drift: ATE origin-aligned RMSE [m]", lambda m: m.ate.origin_rmse_m),
    ("RPE trans RMSE [m]", lambda m: m.rpe.trans_rmse_m),
    ("RPE rot RMSE [deg]", lambda m: m.rpe.rot_rmse_deg),
    ("landmark RMSE [m]", lambda m: m.landmarks.rmse_m),
    ("landmarks matched / estimated", None),
    ("pose NEES median", None),
    ("poses in NEES 95 % band", lambda m: m.nees.pose_within_bounds),
    ("seeds", None),
)
#: the columns of a dataset's table of costs (a table of its own: one table of both would be
#: wider than the page)
COST_COLUMNS: tuple[tuple[str, Metric | None], ...] = (
    ("step median [ms]", lambda m: m.timing.step_median_ms),
    ("step p95 [ms]", lambda m: m.timing.step_p95_ms),
    ("step max [ms]", lambda m: m.timing.step_max_ms),
    ("warm-up [s]", lambda m: m.timing.warmup_s),
    ("total [s]", lambda m: m.timing.total_s),
    ("peak RSS [MB]", lambda m: m.timing.peak_rss_mb),
    ("seeds", None),
)


def _seeds_cell(group: Sequence[ReportCell]) -> Num:
    """How many runs a column has: "deterministic" for one run standing for every seed."""
    ok = [c for c in group if c.ok]
    failed = len(group) - len(ok)
    if failed:
        return Num(f"{len(ok)} ({failed} failed)")
    if deterministic(ok) and len(ok) == 1:
        return Num("deterministic", 1)
    return Num(f"{len(ok)}", len(ok))


def _ratio_cell(ok: Sequence[ReportCell], baseline: SeedSummary | None) -> Num:
    """The column's median ATE over dead reckoning's."""
    summary = column_summary(ok, ate_rmse)
    if summary is None or baseline is None or baseline.median <= 0:
        return Num("–")
    ratio = summary.median / baseline.median
    return Num(f"{ratio:.2f}x", ratio)


def _landmarks_cell(ok: Sequence[ReportCell]) -> Cell:
    matched = column_summary(ok, lambda m: m.landmarks.matched)
    estimated = column_summary(ok, lambda m: m.landmarks.estimated)
    if estimated is None or not any(estimated.values):
        return "–"
    return f"{seed_number(matched).text} / {seed_number(estimated).text}"


def detail_rows(
    cells: Sequence[ReportCell], spec: Sequence[tuple[str, Metric | None]] = DETAIL_COLUMNS
) -> tuple[list[str], list[list[Cell]]]:
    """(header, one row per estimator column) of a dataset's table (``DETAIL_COLUMNS`` or
    ``COST_COLUMNS``)."""
    header = ["estimator", *(name for name, _ in spec)]
    by_column = {col: [c for c in cells if c.column == col] for col in columns(cells)}
    baseline = column_summary([c for c in cells if c.column == BASELINE], ate_rmse)
    rows = []
    for column, group in by_column.items():
        ok = [c for c in group if c.ok]
        special = {
            "ATE / dead reckoning": _ratio_cell(ok, baseline),
            "landmarks matched / estimated": _landmarks_cell(ok),
            "pose NEES median": nees_text(ok),
            "seeds": _seeds_cell(group),
        }
        row: list[Cell] = [column]
        for name, metric in spec:
            row.append(seed_number(column_summary(ok, metric)) if metric else special[name])
        rows.append(row)
    return header, rows


#: the columns of a dataset's table of runs: header and the metric of each run
SEED_COLUMNS: tuple[tuple[str, Metric], ...] = (
    ("ATE RMSE [m]", ate_rmse),
    ("drift [m]", lambda m: m.ate.origin_rmse_m),
    ("RPE trans RMSE [m]", lambda m: m.rpe.trans_rmse_m),
    ("landmark RMSE [m]", lambda m: m.landmarks.rmse_m),
    ("pose NEES median", lambda m: m.nees.pose_median),
    ("total [s]", lambda m: m.timing.total_s),
)


def seeds_table(dataset: str, cells: Sequence[ReportCell]) -> Table:
    """One dataset's runs, one row per estimator column and seed (the values the other tables
    summarise)."""
    rows: list[list[Cell]] = []
    for column in columns(cells):
        for cell in sorted((c for c in cells if c.column == column),
                           key=lambda c: (c.seed is None, c.seed or 0)):
            row: list[Cell] = [column, "–" if cell.seed is None else str(cell.seed)]
            for _, metric in SEED_COLUMNS:
                value = metric(cell.metrics) if cell.metrics is not None else None
                row.append(Num("–") if value is None else Num(f"{value:.3g}", float(value)))
            if not cell.ok:
                row[2] = Num("failed")
            rows.append(row)
    return make_table(
        f"{slug(dataset)}-seeds",
        f"{dataset}: every run, one row per estimator and seed ({gt_label(cells)})",
        ["estimator", "seed", *(name for name, _ in SEED_COLUMNS)],
        rows,
    )


#: the association decisions an estimator's ``estimator_info.json`` may count, by the report's
#: column: the first of the keys that the record holds (graphslam, EKF-SLAM's range-bearing and
#: omni filters, FastSLAM name them differently)
ASSOCIATION_COUNTS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("landmarks", ("landmarks",)),
    ("created", ("landmarks_created", "created")),
    ("associated", ("sightings_associated", "associated")),
    ("ambiguous", ("sightings_ambiguous", "ambiguous")),
    ("gated (rejected)", ("sightings_gated", "gated")),
    ("tentative dropped", ("tentative_dropped",)),
    ("merged", ("landmarks_merged",)),
    ("loop closures", ("loop_closures",)),
)


def association_rows(cells: Sequence[ReportCell]) -> tuple[list[str], list[list[Cell]]]:
    """One row per run whose ``estimator_info.json`` counts association decisions (the
    ``ASSOCIATION_COUNTS`` besides ``landmarks``; none: no rows), in the cells' order."""
    header = ["estimator", "seed", *(name for name, _ in ASSOCIATION_COUNTS)]
    rows: list[list[Cell]] = []
    for cell in cells:
        if not cell.ok or cell.run_dir is None or not (cell.run_dir / ESTIMATOR_INFO).is_file():
            continue
        try:
            info = json.loads((cell.run_dir / ESTIMATOR_INFO).read_text())
        except (OSError, ValueError) as exc:
            raise DataError(f"{cell.run_dir / ESTIMATOR_INFO}: not readable JSON ({exc})") from exc
        counts = [next((info[k] for k in keys if isinstance(info.get(k), int)), None)
                  for _, keys in ASSOCIATION_COUNTS]
        if all(v is None for v in counts[1:]):
            continue
        rows.append([cell.column, "–" if cell.seed is None else str(cell.seed),
                     *(Num("–") if v is None else Num(str(v), v) for v in counts)])
    return header, rows


def _is_baseline(cells: Sequence[ReportCell], column: str) -> bool:
    return column == BASELINE or any(c.column == column and c.estimator == BASELINE for c in cells)


def dataset_verdicts(cells: Sequence[ReportCell]) -> list[Verdict]:
    """The verdict of each dataset and input (``metrics.verdict``), in the order of the cells:
    only runs that consumed the same input are ranked together. Results read from another
    system's files (``estimator: external``), whose input omnislam cannot know, are set beside
    each input's runs as a family of their own."""
    out = []
    for dataset in dict.fromkeys(c.dataset for c in cells):
        group = [c for c in cells if c.dataset == dataset]
        baseline = next(
            (s for col in columns(group) if _is_baseline(group, col)
             for s in [column_summary([c for c in group if c.column == col], ate_rmse)]
             if s is not None),
            None,
        )
        by_input: dict[str, list[ColumnSummary]] = {}
        elsewhere: list[ColumnSummary] = []  # another system's results: what it read is unknown
        for column in columns(group):
            if _is_baseline(group, column):
                continue
            runs = [c for c in group if c.column == column and c.ok]
            summary = column_summary(runs, ate_rmse)
            if summary is None:
                continue
            first = runs[0]
            ranked = ColumnSummary(column, family_of(first), method_of(first), summary)
            if first.config is not None and first.config.external is not None:
                elsewhere.append(ranked)
            else:
                by_input.setdefault(input_label(first), []).append(ranked)
        if elsewhere and not by_input:
            by_input["another system's input"] = []
        for summaries in by_input.values():
            summaries.extend(elsewhere)  # set beside every input's runs of the dataset
        label = gt_label(group)
        for kind, summaries in by_input.items():
            out.append(Verdict(dataset, kind, label, rank_families(summaries), baseline))
        if not by_input:
            out.append(Verdict(dataset, "–", label, (), baseline))
    return out


#: the verdict table's columns as shown
VERDICT_HEADER = (
    "dataset",
    "input",
    "family",
    "best of the family",
    "ATE RMSE [m]",
    "behind the best",
    "separated from the best",
    "variants",
    "/ dead reckoning",
)


def _verdict_row(v: Verdict, rank: int) -> tuple[list[Cell], list[object]]:
    """(the shown row, the CSV row) of the ``rank``-th family of verdict ``v``."""
    family = v.families[rank]
    best = family.best
    behind, fraction = v.behind_m(family), v.behind_fraction(family)
    split = None if rank == 0 or v.best is None else separated(v.best, best)
    split_text = "–" if rank == 0 else {None: "unknown (1 seed)", True: "yes", False: "no"}[split]
    variants = ", ".join(f"{c.column} {c.median:.3g}" for c in family.variants) or "–"
    ratio = best.median / v.baseline.median if v.baseline and v.baseline.median > 0 else None
    shown: list[Cell] = [
        v.dataset,
        v.input,
        best.family,
        best.column,
        seed_number(best.ate),
        Num("best") if rank == 0 else Num(
            f"+{behind:.3g} m ({100 * (fraction or 0):.0f} %)", behind
        ),
        split_text,
        variants,
        Num("–") if ratio is None else Num(f"{ratio:.2f}x", ratio),
    ]
    written: list[object] = [
        v.dataset, v.input, v.ground_truth, rank + 1, best.family, best.column,
        best.ate.median, best.ate.low, best.ate.high, best.ate.seeds, best.ate.deterministic,
        behind, None if fraction is None else 100 * fraction,
        None if rank == 0 else split_text, variants if family.variants else None,
        None if v.baseline is None else v.baseline.median,
    ]
    return shown, written


def verdict_table(verdicts: Sequence[Verdict]) -> Table:
    """One row per method family of each dataset and input: its best column, that column's
    median ATE RMSE [min–max] over seeds, how far behind the best family it is and whether the
    seed spread separates the two, the method's other variants and the ratio to dead reckoning
    (the CSV: every number at full precision, ranges as two columns)."""
    csv_header = (
        "dataset", "input", "ground truth", "rank", "family", "best", "median [m]", "min [m]",
        "max [m]", "seeds", "deterministic", "behind the best [m]", "behind the best [%]",
        "separated from the best", "variants", "dead reckoning median [m]",
    )
    rows: list[list[Cell]] = []
    csv_rows: list[list[object]] = []
    for v in verdicts:
        if not v.families:
            rows.append([v.dataset, v.input, "–", "–", Num("–"), Num("–"), "–", "–", Num("–")])
            csv_rows.append([v.dataset, v.input, v.ground_truth] + [None] * 13)
        for rank in range(len(v.families)):
            shown, written = _verdict_row(v, rank)
            rows.append(shown)
            csv_rows.append(written)
    return make_table(
        "verdict",
        "Best estimator of each method family per dataset and input by ATE RMSE "
        f"({STATISTIC}; dead reckoning excluded), and its distance behind the best family",
        VERDICT_HEADER,
        rows,
        csv_header,
        csv_rows,
    )


def headline_table(cells: Sequence[ReportCell]) -> Table:
    """ATE RMSE per dataset (rows, with their ground truth) and estimator column, the median
    [min–max] over seeds; "(failed)" where every run of a column failed."""
    labels = columns(cells)
    rows = []
    for dataset in dict.fromkeys(c.dataset for c in cells):
        group = [c for c in cells if c.dataset == dataset]
        row: list[Cell] = [dataset, gt_label(group)]
        for column in labels:
            runs = [c for c in group if c.column == column]
            value = seed_number(column_summary(runs, ate_rmse))
            if runs and not any(c.ok for c in runs):
                value = Num(value.text + " (failed)")
            row.append(value)
        rows.append(row)
    return make_table(
        "ate-rmse",
        f"ATE RMSE [m] per dataset and estimator ({STATISTIC})",
        ["dataset", "ground truth", *labels],
        rows,
    )


def metrics_table(dataset: str, cells: Sequence[ReportCell]) -> Table:
    """One dataset's metrics per estimator column (``DETAIL_COLUMNS``), its RPE columns named
    with the dataset's own segment length (a short run's is shorter: ``evaluation.segment_for``)."""
    header, rows = detail_rows(cells)
    lengths = [c.metrics.rpe.segment_m for c in cells if c.ok and c.metrics is not None]
    segment = next((length for length in lengths if length), None)
    if segment:
        header = [h.replace("RPE trans", f"RPE {segment:g} m trans") for h in header]
        header = [h.replace("RPE rot", f"RPE {segment:g} m rot") for h in header]
    return make_table(
        f"{slug(dataset)}-metrics",
        f"{dataset}: metrics per estimator, {STATISTIC} ({gt_label(cells)})",
        header,
        rows,
    )


def cost_table(dataset: str, cells: Sequence[ReportCell]) -> Table:
    """One dataset's costs per estimator column (``COST_COLUMNS``): step times after the
    warm-up (``metrics.timing``), the warm-up, the total and the memory."""
    header, rows = detail_rows(cells, COST_COLUMNS)
    return make_table(
        f"{slug(dataset)}-cost",
        f"{dataset}: cost per estimator, {STATISTIC}; step times exclude the warm-up",
        header,
        rows,
    )


def association_table(dataset: str, cells: Sequence[ReportCell]) -> Table | None:
    """One dataset's association decisions per run (``association_rows``); None when no run
    counts them."""
    header, rows = association_rows(cells)
    if not rows:
        return None
    return make_table(
        f"{slug(dataset)}-association",
        f"{dataset}: association decisions per run (estimator_info.json)",
        header,
        rows,
    )
