"""The report's verdict: per dataset and input, the best estimator of each method family and the
margins between families.

A verdict compares like with like. It ranks only estimators that consumed the same input (the
run's modality and source: the omni front end's tracks, range-bearing pole sightings, vertical
lines in a known map ...), so one verdict is made per (dataset, input). Within it, estimators
are grouped by method family (``estimators.Family``): each family is represented by its best
column, the families are ranked by that column's median ATE RMSE over seeds
(``metrics.seeds``), and the margin is that between families. Columns of one method (variants:
the same registered method, e.g. ``graphslam`` and ``graphslam-batch``, or one estimator with
other options) are shown beside the family's best as variants, never as rivals.

Dead reckoning is the baseline and is never ranked. A margin is *within the seed spread* when
the two min-max ranges over seeds overlap (a deterministic estimator's range is its one value);
it is unknown when either side is one seed of a seed-dependent estimator. Two medians closer
than ``TIE_M`` are a tie.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from omnislam.metrics.seeds import SeedSummary

#: medians of ATE RMSE closer than this are a tie [m] (1 um: far below what any trajectory in a
#: comparison resolves)
TIE_M = 1e-6


@dataclass(frozen=True, slots=True)
class ColumnSummary:
    """ATE RMSE of one estimator column over its seeds.

    Attributes:
        column: the column label.
        family: its method family (``estimators.Family`` value).
        method: the method it is a variant of (columns with one method are variants).
        ate: its ATE RMSE over seeds [m].
    """

    column: str
    family: str
    method: str
    ate: SeedSummary

    @property
    def median(self) -> float:
        return self.ate.median

    @property
    def spread_known(self) -> bool:
        """Its range over seeds is known: several seeds, or deterministic."""
        return self.ate.has_spread or self.ate.deterministic


@dataclass(frozen=True, slots=True)
class FamilyResult:
    """One method family in a verdict.

    Attributes:
        best: its column with the lowest median ATE RMSE.
        variants: the other columns of the best column's method, best first.
    """

    best: ColumnSummary
    variants: tuple[ColumnSummary, ...] = ()

    @property
    def family(self) -> str:
        return self.best.family


def separated(a: ColumnSummary, b: ColumnSummary) -> bool | None:
    """The min-max ranges over seeds of ``a`` and ``b`` do not overlap (None: a range is not
    known, one seed of a seed-dependent estimator)."""
    if not (a.spread_known and b.spread_known):
        return None
    lower, upper = (a, b) if a.median <= b.median else (b, a)
    return lower.ate.high < upper.ate.low


@dataclass(frozen=True, slots=True)
class Verdict:
    """The verdict of one dataset on one input.

    Attributes:
        dataset: dataset label.
        input: what the ranked estimators consumed (``report.results.input_label``).
        ground_truth: what the ATE is measured against.
        families: the families, best (lowest median of its best column) first.
        baseline: dead reckoning's summary, None when it was not run (or has no ATE).
    """

    dataset: str
    input: str
    ground_truth: str
    families: tuple[FamilyResult, ...]
    baseline: SeedSummary | None = None

    @property
    def best(self) -> ColumnSummary | None:
        return self.families[0].best if self.families else None

    @property
    def runner_up(self) -> ColumnSummary | None:
        """The best column of the second family."""
        return self.families[1].best if len(self.families) > 1 else None

    def behind_m(self, family: FamilyResult) -> float | None:
        """How far ``family``'s best median is above the best family's [m]."""
        return None if self.best is None else family.best.median - self.best.median

    def behind_fraction(self, family: FamilyResult) -> float | None:
        """``behind_m`` as a fraction of ``family``'s median (None: a zero median)."""
        behind = self.behind_m(family)
        if behind is None or family.best.median <= 0:
            return None
        return behind / family.best.median

    @property
    def margin_m(self) -> float | None:
        """The runner-up family's best median minus the best family's [m]."""
        return None if len(self.families) < 2 else self.behind_m(self.families[1])

    @property
    def tied(self) -> bool:
        """The two best families' medians differ by less than ``TIE_M``."""
        return self.margin_m is not None and self.margin_m < TIE_M

    @property
    def beats_baseline(self) -> bool | None:
        """The best median is below dead reckoning's (None: no baseline or no best)."""
        if self.best is None or self.baseline is None:
            return None
        return self.best.median < self.baseline.median

    def notes(self) -> list[str]:
        """Short notes on what a reader of the verdict's rows must know (empty: none)."""
        out = []
        best, runner = self.best, self.runner_up
        where = f"{self.dataset} ({self.input})"
        if best is None:
            return [f"{where}: no estimator besides dead reckoning has an ATE RMSE."]
        if runner is not None:
            split = separated(best, runner)
            if self.tied:
                out.append(
                    f"{where}: {best.column} and {runner.column} tie (medians < 1 µm apart)."
                )
            elif split is None:
                out.append(
                    f"{where}: one seed of a seed-dependent estimator; whether {best.column} "
                    f"and {runner.column} differ by more than the seed spread is unknown."
                )
            elif not split:
                out.append(
                    f"{where}: {best.column}'s and {runner.column}'s ranges over seeds overlap; "
                    "these runs do not separate the two families."
                )
        for family in self.families:
            for variant in family.variants:
                if abs(variant.median - family.best.median) < TIE_M:
                    out.append(
                        f"{where}: {variant.column} gives {family.best.column}'s result "
                        "(the same method reaching the same optimum)."
                    )
        if self.beats_baseline is False:
            out.append(f"{where}: no estimator beats dead reckoning.")
        return out


def rank_families(
    columns: Sequence[ColumnSummary],
) -> tuple[FamilyResult, ...]:
    """The families of ``columns`` ranked by their best column; each best's method's other
    columns as its variants.

    Args:
        columns: the summaries of the columns of one dataset and input (baseline excluded).
    """
    ordered = sorted(columns, key=lambda c: (c.median, c.ate.high, c.column))
    families: dict[str, FamilyResult] = {}
    for column in ordered:
        if column.family not in families:
            variants = tuple(
                c for c in ordered if c.method == column.method and c is not column
            )
            families[column.family] = FamilyResult(column, variants)
    return tuple(families.values())
