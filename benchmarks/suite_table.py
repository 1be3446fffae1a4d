"""The README's results table, generated from the suite's report (``reports/suite``)::

    .venv/bin/python benchmarks/suite_table.py [--report reports/suite] [--readme README.md]
        [--check]

``make suite`` runs it after ``omnislam compare benchmarks/grids/suite.yaml`` and ``omnislam
report``. It reads two tables the report writes -- ``tables/ate-rmse.csv`` (ATE RMSE per dataset
and estimator, the median over seeds with its min and max) and ``tables/verdict.csv`` (per
dataset and input one row per method family: its best estimator by median ATE over seeds, dead
reckoning excluded, how far behind the best family it is, whether the seed spread separates
them, dead reckoning's median) -- and rewrites the block of the README between
``<!-- suite-table:begin -->`` and ``<!-- suite-table:end -->``: no number in that block is
typed by hand. The last column names, per input, the best estimator with its median and the
next family's best with its distance behind, and says when dead reckoning's median is lower
still. ``--check``
rewrites nothing and exits 1 when the block is not what the report gives (for CI, after the
report changed).
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
BEGIN = "<!-- suite-table:begin -->"
END = "<!-- suite-table:end -->"
ATE_TABLE = Path("tables") / "ate-rmse.csv"
VERDICT_TABLE = Path("tables") / "verdict.csv"
#: columns of ate-rmse.csv before the estimators
LEADING = ("dataset", "ground truth")


class SuiteTableError(Exception):
    """The report lacks a table, a table is malformed, or the README has no marked block."""


@dataclass(frozen=True, slots=True)
class Verdict:
    """The first two rows of one dataset and input of verdict.csv, as far as the table shows it.

    Attributes:
        input: what the ranked estimators consumed.
        best: the best family's best estimator.
        runner_up: the next family's best estimator ("" when only one family ran).
        behind_percent: how far the runner-up is behind the best, in % of its own median.
        separated: "yes", "no" or "unknown (1 seed)" ("" without a runner-up).
        best_median, baseline_median: medians over seeds of the best and of dead reckoning.
    """

    input: str
    best: str
    runner_up: str
    behind_percent: float | None
    separated: str
    best_median: float | None = None
    baseline_median: float | None = None

    @property
    def behind_baseline(self) -> bool:
        """Dead reckoning's median is below the best estimator's: no estimator beats it."""
        return (
            self.best_median is not None
            and self.baseline_median is not None
            and self.best_median > self.baseline_median
        )


def _read_csv(path: Path) -> tuple[list[str], list[dict[str, str]]]:
    try:
        with path.open(newline="") as handle:
            reader = csv.DictReader(handle)
            rows = list(reader)
            return list(reader.fieldnames or []), rows
    except OSError as exc:
        raise SuiteTableError(f"{path}: cannot read ({exc.strerror or exc})") from None


def _number(text: str) -> float | None:
    try:
        value = float(text)
    except ValueError:
        return None
    return None if math.isnan(value) else value


def _format(median: str, low: str, high: str) -> str:
    """``0.113``, ``0.532 [0.49–0.61]``; the report's own text (``– (failed)``) when no number."""
    value = _number(median)
    if value is None:
        return median.strip() or "–"
    lo, hi = _number(low), _number(high)
    return f"{value:.3g}" if lo is None or hi is None else f"{value:.3g} [{lo:.3g}–{hi:.3g}]"


def read_verdicts(report: Path) -> dict[str, list[Verdict]]:
    """Dataset label -> its verdict per input (datasets without a ranked estimator are absent)."""
    _, rows = _read_csv(report / VERDICT_TABLE)
    first: dict[tuple[str, str], dict[str, str]] = {}
    second: dict[tuple[str, str], dict[str, str]] = {}
    try:
        for row in rows:
            key = (row["dataset"], row["input"])
            if row["best"] and row["rank"] == "1":
                first[key] = row
            elif row["best"] and row["rank"] == "2":
                second[key] = row
        out: dict[str, list[Verdict]] = {}
        for (dataset, kind), row in first.items():
            runner = second.get((dataset, kind))
            out.setdefault(dataset, []).append(
                Verdict(
                    kind,
                    row["best"],
                    runner["best"] if runner else "",
                    _number(runner["behind the best [%]"]) if runner else None,
                    runner["separated from the best"] if runner else "",
                    _number(row["median [m]"]),
                    _number(row["dead reckoning median [m]"]),
                )
            )
    except KeyError as exc:
        raise SuiteTableError(f"{report / VERDICT_TABLE}: no column {exc}") from None
    return out


def _verdict_text(verdict: Verdict) -> str:
    """``graphslam 0.0105 (fastslam2 +82 % behind)`` for one input."""
    text = f"{verdict.best}"
    if verdict.best_median is not None:
        text += f" {verdict.best_median:.3g}"
    if not verdict.runner_up:  # one family only
        text += " (one family ranked"
    else:
        behind = f"{verdict.behind_percent:.0f} %" if verdict.behind_percent is not None else "?"
        text += f" ({verdict.runner_up} {behind} behind"
        text += "; not separated by the seed spread" if verdict.separated == "no" else ""
    if verdict.behind_baseline:
        text += f"; dead reckoning's {verdict.baseline_median:.3g} is lower"
    return text + ")"


def suite_table(report: str | Path) -> str:
    """The Markdown table of ATE RMSE per dataset and estimator, with each row's verdict."""
    report = Path(report)
    header, rows = _read_csv(report / ATE_TABLE)
    if tuple(header[:2]) != LEADING:
        raise SuiteTableError(f"{report / ATE_TABLE}: expected columns {LEADING} first")
    if "input" not in _read_csv(report / VERDICT_TABLE)[0]:
        return suite_table_v1(report)  # a report of format 1
    estimators = [h for h in header[2:] if not h.endswith((" min", " max"))]
    verdicts = read_verdicts(report)
    lines = [
        "| dataset | ground truth | "
        + " | ".join(estimators)
        + " | best per input: median over seeds (the next family behind) |",
        "|---|---|" + "---|" * len(estimators) + "---|",
    ]
    for row in rows:
        found = verdicts.get(row["dataset"], [])
        winners = {v.best for v in found}
        cells = []
        for name in estimators:
            text = _format(row.get(name, ""), row.get(f"{name} min", ""),
                           row.get(f"{name} max", ""))
            cells.append(f"**{text}**" if name in winners else text)
        best = "; ".join(
            (f"{v.input}: " if len(found) > 1 else "") + _verdict_text(v) for v in found
        ) or "–"
        lines.append(
            f"| {row['dataset']} | {row['ground truth']} | " + " | ".join(cells) + f" | {best} |"
        )
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------------------------
# Reports of format 1: verdict.csv with one row per dataset (no ``input`` column), ate-rmse.csv
# with the mean and standard deviation over seeds. A committed table of that format stays
# checkable until ``make suite`` writes the report anew.
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class VerdictV1:
    """One row of a format-1 verdict.csv (one row per dataset), as far as the table shows it."""

    best: str
    runner_up: str
    margin_percent: float | None
    within_spread: str
    best_median: float | None = None
    baseline_median: float | None = None

    @property
    def behind_baseline(self) -> bool:
        """Dead reckoning's median is below the best estimator's: no estimator beats it."""
        return (
            self.best_median is not None
            and self.baseline_median is not None
            and self.best_median > self.baseline_median
        )


def _format_v1(mean: str, std: str) -> str:
    """``0.113``, ``0.532 ± 0.095``; the report's own text (``– (failed)``) when no number."""
    value = _number(mean)
    if value is None:
        return mean.strip() or "–"
    spread = _number(std)
    return f"{value:.3g}" if spread is None else f"{value:.3g} ± {spread:.2g}"


def read_verdicts_v1(report: Path) -> dict[str, VerdictV1]:
    """Dataset label -> its verdict (datasets without a ranked estimator are absent)."""
    _, rows = _read_csv(report / VERDICT_TABLE)
    out = {}
    for row in rows:
        try:
            if row["best"]:
                out[row["dataset"]] = VerdictV1(
                    row["best"],
                    row["runner-up"],
                    _number(row["margin [%]"]),
                    row["within seed spread"],
                    _number(row["best median [m]"]),
                    _number(row["dead reckoning median [m]"]),
                )
        except KeyError as exc:
            raise SuiteTableError(f"{report / VERDICT_TABLE}: no column {exc}") from None
    return out


def suite_table_v1(report: Path) -> str:
    """The table of a report of format 1, as that format's script wrote it (mean ± std per
    cell, one verdict per dataset)."""
    header, rows = _read_csv(report / ATE_TABLE)
    if tuple(header[:2]) != LEADING:
        raise SuiteTableError(f"{report / ATE_TABLE}: expected columns {LEADING} first")
    estimators = [h for h in header[2:] if not h.endswith(" std")]
    verdicts = read_verdicts_v1(report)
    lines = [
        "| dataset | ground truth | "
        + " | ".join(estimators)
        + " | best: median over seeds (margin over next) |",
        "|---|---|" + "---|" * len(estimators) + "---|",
    ]
    for row in rows:
        verdict = verdicts.get(row["dataset"])
        cells = []
        for name in estimators:
            text = _format_v1(row.get(name, ""), row.get(f"{name} std", ""))
            cells.append(f"**{text}**" if verdict is not None and verdict.best == name else text)
        if verdict is None:
            best = "–"
        else:
            best = verdict.best
            if verdict.best_median is not None:
                best += f" {verdict.best_median:.3g}"
            if not verdict.runner_up:  # the only estimator besides dead reckoning
                best += " (only one ranked"
            else:
                margin = (
                    f"{verdict.margin_percent:.0f} %" if verdict.margin_percent is not None else "?"
                )
                best += f" ({margin} over {verdict.runner_up}"
                best += "; within seed spread" if verdict.within_spread == "yes" else ""
            if verdict.behind_baseline:
                best += f"; dead reckoning's {verdict.baseline_median:.3g} is lower"
            best += ")"
        lines.append(
            f"| {row['dataset']} | {row['ground truth']} | " + " | ".join(cells) + f" | {best} |"
        )
    return "\n".join(lines) + "\n"


def rewrite_block(text: str, table: str) -> str:
    """``text`` with the block between the markers replaced by ``table``."""
    start, end = text.find(BEGIN), text.find(END)
    if start < 0 or end < start:
        raise SuiteTableError(f"no block between {BEGIN} and {END}")
    return text[: start + len(BEGIN)] + "\n" + table + text[end:]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--report", default=str(REPO / "reports" / "suite"))
    parser.add_argument("--readme", default=str(REPO / "README.md"))
    parser.add_argument("--check", action="store_true", help="exit 1 if the README is stale")
    args = parser.parse_args(argv)
    readme = Path(args.readme)
    try:
        text = readme.read_text()
        updated = rewrite_block(text, suite_table(args.report))
    except OSError as exc:
        print(f"suite_table: {readme}: cannot read ({exc.strerror or exc})", file=sys.stderr)
        return 2
    except SuiteTableError as exc:
        where = "" if str(exc).startswith(str(args.report)) else f"{readme}: "
        print(f"suite_table: {where}{exc}", file=sys.stderr)
        return 2
    if args.check:
        if updated != text:
            print(f"suite_table: {readme}'s table is not the one {args.report} gives")
            return 1
        return 0
    if updated != text:
        readme.write_text(updated)
    print(f"suite_table: {readme} table from {args.report}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
