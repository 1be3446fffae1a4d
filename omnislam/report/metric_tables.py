"""The report's tables of numbers: per dataset and estimator over seeds, the verdicts, the headline.

Every number is a mean over seeds with its standard deviation (``mean_number``: the text the
tables show and the numbers the CSV writes); each dataset's table puts every estimator column
beside the dead-reckoning baseline (``DETAIL_COLUMNS``), its association counts come from each
run's ``estimator_info.json`` (``ASSOCIATION_COUNTS``), and the verdict of each dataset
(``metrics.verdict``) is one row of the verdict table.
"""

from __future__ import annotations

import json
from collections.abc import Sequence

import numpy as np

from omnislam.errors import DataError
from omnislam.harness.layout import ESTIMATOR_INFO
from omnislam.metrics.verdict import Verdict, verdict
from omnislam.report.results import (
    BASELINE,
    Metric,
    ReportCell,
    ate_rmse,
    columns,
    gt_label,
    values,
)
from omnislam.report.tables import Cell, Num, Table, make_table, slug


def mean_text(values: Sequence[float], digits: int = 3) -> str:
    """Mean of the values, "± std" after it when they spread (one seed: none; none: "–")."""
    if not values:
        return "–"
    mean = float(np.mean(values))
    text = f"{mean:.{digits}g}"
    spread = float(np.std(values, ddof=1)) if len(values) > 1 else 0.0
    if spread > 0:
        text += f" ± {spread:.2g}"
    return text


def mean_number(values: Sequence[float], digits: int = 3) -> Num:
    """``_fmt`` of the values, keeping their mean and standard deviation for the CSV."""
    if not values:
        return Num("–")
    std = float(np.std(values, ddof=1)) if len(values) > 1 else None
    return Num(mean_text(values, digits), float(np.mean(values)), std)


#: the columns of a dataset's table: header and the metric it averages over seeds (None: the
#: ratio to dead reckoning, matched / estimated landmarks and the number of runs)
DETAIL_COLUMNS: tuple[tuple[str, Metric | None], ...] = (
    ("ATE RMSE [m]", ate_rmse),
    ("ATE / dead reckoning", None),
    ("ATE max [m]", lambda m: m.ate.max_m),
    ("drift: ATE origin-aligned RMSE [m]", lambda m: m.ate.origin_rmse_m),
    ("RPE trans RMSE [m]", lambda m: m.rpe.trans_rmse_m),
    ("RPE rot RMSE [deg]", lambda m: m.rpe.rot_rmse_deg),
    ("landmark RMSE [m]", lambda m: m.landmarks.rmse_m),
    ("landmarks matched / estimated", None),
    ("pose NEES (dof 3)", lambda m: m.nees.pose_mean),
    ("step median [ms]", lambda m: m.timing.step_median_ms),
    ("step p95 [ms]", lambda m: m.timing.step_p95_ms),
    ("total [s]", lambda m: m.timing.total_s),
    ("peak RSS [MB]", lambda m: m.timing.peak_rss_mb),
    ("runs", None),
)


def detail_rows(cells: Sequence[ReportCell]) -> tuple[list[str], list[list[Cell]]]:
    """(header, one row per estimator column) of a dataset's table (``DETAIL_COLUMNS``)."""
    header = ["estimator", *(name for name, _ in DETAIL_COLUMNS)]
    by_column = {col: [c for c in cells if c.column == col] for col in columns(cells)}
    baseline = values([c for c in cells if c.column == BASELINE and c.ok], ate_rmse)
    rows = []
    for column, group in by_column.items():
        ok = [c for c in group if c.ok]
        row: list[Cell] = [column]
        for name, metric in DETAIL_COLUMNS:
            if metric is not None:
                row.append(mean_number(values(ok, metric)))
            elif name.startswith("ATE /"):
                ate_values = values(ok, ate_rmse)
                if ate_values and baseline and np.mean(baseline) > 0:
                    ratio = float(np.mean(ate_values) / np.mean(baseline))
                    row.append(Num(f"{ratio:.2f}x", ratio))
                else:
                    row.append(Num("–"))
            elif name.startswith("landmarks"):
                matched = values(ok, lambda m: m.landmarks.matched)
                estimated = values(ok, lambda m: m.landmarks.estimated)
                shown = f"{mean_text(matched)} / {mean_text(estimated)}"
                row.append(shown if any(estimated) else "–")
            else:
                failed = len(group) - len(ok)
                row.append(
                    Num(f"{len(ok)} ({failed} failed)") if failed else Num(f"{len(ok)}", len(ok))
                )
        rows.append(row)
    return header, rows


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
    """The verdict of each dataset (``metrics.verdict``), in the order of the cells."""
    out = []
    for dataset in dict.fromkeys(c.dataset for c in cells):
        group = [c for c in cells if c.dataset == dataset]
        out.append(
            verdict(
                dataset,
                gt_label(group),
                columns(group),
                lambda col, g=group: values([c for c in g if c.column == col and c.ok], ate_rmse),
                lambda col, g=group: _is_baseline(g, col),
            )
        )
    return out


def _range_text(low: float, high: float, seeds: int) -> str:
    return f"{low:.3g}–{high:.3g}" if seeds > 1 else f"{low:.3g} (1 seed)"


def verdict_table(verdicts: Sequence[Verdict]) -> Table:
    """One row per dataset: the best estimator, the runner-up, the margin and whether it is
    within the seed spread (the CSV: every number at full precision, ranges as two columns)."""
    header = (
        "dataset",
        "best",
        "ATE RMSE median [m]",
        "min–max [m]",
        "seeds",
        "runner-up",
        "runner-up median [m]",
        "runner-up min–max [m]",
        "margin [m]",
        "margin [%]",
        "within seed spread",
    )
    csv_header = (
        "dataset",
        "ground truth",
        "best",
        "best median [m]",
        "best min [m]",
        "best max [m]",
        "best seeds",
        "runner-up",
        "runner-up median [m]",
        "runner-up min [m]",
        "runner-up max [m]",
        "runner-up seeds",
        "margin [m]",
        "margin [%]",
        "within seed spread",
        "dead reckoning median [m]",
    )
    rows: list[list[Cell]] = []
    csv_rows: list[list[object]] = []
    for v in verdicts:
        best, runner = v.best, v.runner_up
        spread = {None: "unknown (1 seed)", True: "yes", False: "no"}[v.within_spread]
        if runner is None:
            spread = "–"
        frac = v.margin_fraction
        rows.append(
            [
                v.dataset,
                best.column if best else "–",
                Num(f"{best.median:.3g}", best.median) if best else Num("–"),
                _range_text(best.low, best.high, best.seeds) if best else "–",
                Num(str(best.seeds), best.seeds) if best else Num("0", 0),
                runner.column if runner else "–",
                Num(f"{runner.median:.3g}", runner.median) if runner else Num("–"),
                _range_text(runner.low, runner.high, runner.seeds) if runner else "–",
                Num(f"{v.margin_m:.3g}", v.margin_m) if v.margin_m is not None else Num("–"),
                Num(f"{100 * frac:.0f}", 100 * frac) if frac is not None else Num("–"),
                spread,
            ]
        )
        csv_rows.append(
            [
                v.dataset,
                v.ground_truth,
                best.column if best else None,
                best.median if best else None,
                best.low if best else None,
                best.high if best else None,
                best.seeds if best else 0,
                runner.column if runner else None,
                runner.median if runner else None,
                runner.low if runner else None,
                runner.high if runner else None,
                runner.seeds if runner else None,
                v.margin_m,
                100 * frac if frac is not None else None,
                None if runner is None else spread,
                v.baseline.median if v.baseline else None,
            ]
        )
    return make_table(
        "verdict",
        "Best estimator per dataset by ATE RMSE (median over seeds; dead reckoning excluded) "
        "and its margin over the runner-up",
        header,
        rows,
        csv_header,
        csv_rows,
    )


def headline_table(cells: Sequence[ReportCell]) -> Table:
    """ATE RMSE per dataset (rows, with their ground truth) and estimator column, mean ± std over
    seeds; "(failed)" where every run of a column failed."""
    labels = columns(cells)
    rows = []
    for dataset in dict.fromkeys(c.dataset for c in cells):
        group = [c for c in cells if c.dataset == dataset]
        row: list[Cell] = [dataset, gt_label(group)]
        for column in labels:
            ok = [c for c in group if c.column == column and c.ok]
            failed = [c for c in group if c.column == column and not c.ok]
            value = mean_number(values(ok, ate_rmse))
            if failed and not ok:
                value = Num(value.text + " (failed)")
            row.append(value)
        rows.append(row)
    return make_table(
        "ate-rmse",
        "ATE RMSE [m] per dataset and estimator (mean ± std over seeds)",
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
        f"{dataset}: metrics per estimator, mean ± std over seeds ({gt_label(cells)})",
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
