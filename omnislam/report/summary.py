"""The report's summary figures, drawn from the runs' metrics alone (no RUN_DIR is read, so
they are cheap and small enough for a committed report of many datasets).

* ``DATASET-ate-by-input``: per dataset, the ATE RMSE of every seed (dots) and the median over
  seeds (bar) of each estimator, the estimators grouped by the input they consumed;
* ``accuracy-vs-time``: over every dataset, each estimator's median ATE relative to dead
  reckoning's against its median run time;
* ``families``: the best of each method family per dataset and input, its median and min-max
  over seeds (the verdict's rows).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from omnislam.metrics.verdict import Verdict
from omnislam.report.model import Figure
from omnislam.report.results import BASELINE, ReportCell, ate_rmse, columns, input_label, values

#: captions of the summary figures
CAPTIONS = {
    "ate-by-input": (
        "How accurate is each estimator over seeds, among those fed the same input? ATE RMSE of "
        "every seed (dots) and the median over seeds (bar; the lower middle value for an even "
        "count), the estimators grouped by input (named in the title); a deterministic "
        "estimator ran once."
    ),
    "accuracy-vs-time": (
        "What does accuracy cost? Over every dataset, each estimator's median ATE RMSE divided "
        "by dead reckoning's on the same dataset, against its median total run time (log-log; "
        "below the dashed line it beats dead reckoning)."
    ),
    "families": (
        "Which method family wins where? The best estimator of each family per dataset and "
        "input (the verdict's rows): its median ATE RMSE over seeds (dot) and min–max (line)."
    ),
}


def summary_figures(
    cells: Sequence[ReportCell], verdicts: Sequence[Verdict], colours: Mapping[str, str]
) -> list[Figure]:
    """The summary figures (module docstring), those the runs have data for."""
    from omnislam.report import plots

    out = []
    for dataset in dict.fromkeys(c.dataset for c in cells):
        group = [c for c in cells if c.dataset == dataset]
        drawn = _ate_by_input(dataset, group, colours)
        if drawn is not None:
            out.append(drawn)
    cost = _cost_points(cells)
    if cost:
        svg = plots.accuracy_vs_time_summary("accuracy-vs-time", cost, colours)
        out.append(Figure("accuracy-vs-time.svg", CAPTIONS["accuracy-vs-time"], svg))
    points = [
        plots.FamilyPoint(
            f"{v.dataset} · {v.input}", f.family, f.best.column, f.best.median,
            f.best.ate.low, f.best.ate.high,
        )
        for v in verdicts
        for f in v.families
    ]
    if points:
        out.append(
            Figure("families.svg", CAPTIONS["families"], plots.family_summary("families", points))
        )
    return out


def _stem(dataset: str) -> str:
    return "".join(ch if ch.isalnum() or ch in "-_" else "-" for ch in dataset)


def _ate_by_input(
    dataset: str, cells: Sequence[ReportCell], colours: Mapping[str, str]
) -> Figure | None:
    """One dataset's strip plot of ATE over seeds, columns grouped by input (None: no ATE)."""
    from omnislam.report import plots

    by_input: dict[str, list[plots.RunPoints]] = {}
    for column in columns(cells):
        ok = [c for c in cells if c.column == column and c.ok]
        ate = np.array(values(ok, ate_rmse), dtype=float)
        if ok and ate.size:
            by_input.setdefault(input_label(ok[0]), []).append(
                plots.RunPoints(column, ate, np.full(ate.size, np.nan))
            )
    if not by_input:
        return None
    ordered = [p for group in by_input.values() for p in group]
    groups = "; ".join(f"{kind}: {len(group)}" for kind, group in by_input.items())
    name = f"{_stem(dataset)}-ate-by-input"
    svg = plots.ate_over_seeds(name, f"{dataset} (inputs, left to right: {groups})", ordered,
                               colours)
    return Figure(f"{name}.svg", CAPTIONS["ate-by-input"], svg)


def _cost_points(cells: Sequence[ReportCell]) -> list:
    """Every (dataset, column) with an ATE, a run time and a dead-reckoning median to divide by."""
    from omnislam.report import plots

    out = []
    for dataset in dict.fromkeys(c.dataset for c in cells):
        group = [c for c in cells if c.dataset == dataset and c.ok]
        baseline = sorted(values([c for c in group if c.column == BASELINE], ate_rmse))
        if not baseline or baseline[(len(baseline) - 1) // 2] <= 0:
            continue
        reference = baseline[(len(baseline) - 1) // 2]
        for column in columns(group):
            if column == BASELINE:
                continue
            mine = [c for c in group if c.column == column]
            ate = sorted(values(mine, ate_rmse))
            times = sorted(values(mine, lambda m: m.timing.total_s))
            if ate and times:
                out.append(
                    plots.CostPoint(
                        column,
                        ate[(len(ate) - 1) // 2] / reference,
                        times[(len(times) - 1) // 2],
                    )
                )
    return out
