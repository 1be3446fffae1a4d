"""The report's verdict: per dataset, the best estimator by ATE RMSE and its margin over the next.

Each estimator column is summarised over its seeds by the median ATE RMSE and the min-max
range. Dead reckoning is the baseline and is never the verdict's best. The difference between
the best and the runner-up is *within the seed spread* when their min-max ranges overlap;
with a single seed no spread is known and the verdict says so. Two medians closer than
``TIE_M`` are a tie (the same estimate reached two ways, e.g. graphslam's final batch pass and
graphslam-batch), and the verdict names both instead of a margin of nanometres.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

#: medians of ATE RMSE closer than this are a tie [m] (1 um: far below what any trajectory in a
#: comparison resolves)
TIE_M = 1e-6


@dataclass(frozen=True, slots=True)
class ColumnSummary:
    """ATE RMSE of one estimator column over its seeds.

    Attributes:
        column: the column label.
        values: ATE RMSE of each successful seed [m], ascending.
    """

    column: str
    values: tuple[float, ...]

    @property
    def seeds(self) -> int:
        return len(self.values)

    @property
    def median(self) -> float:
        return float(np.median(self.values))

    @property
    def low(self) -> float:
        return self.values[0]

    @property
    def high(self) -> float:
        return self.values[-1]

    def describe(self) -> str:
        text = f"median {self.median:.3g} m over {self.seeds} seed{'s' * (self.seeds != 1)}"
        if self.seeds > 1:
            text += f", range {self.low:.3g}–{self.high:.3g} m"
        return text


@dataclass(frozen=True, slots=True)
class Verdict:
    """The verdict of one dataset.

    Attributes:
        dataset: dataset label.
        ground_truth: what the ATE is measured against.
        ranked: the estimator columns (baseline excluded) with an ATE, best (lowest median) first.
        baseline: dead reckoning's summary, None when it was not run (or has no ATE).
    """

    dataset: str
    ground_truth: str
    ranked: tuple[ColumnSummary, ...]
    baseline: ColumnSummary | None = None

    @property
    def best(self) -> ColumnSummary | None:
        return self.ranked[0] if self.ranked else None

    @property
    def runner_up(self) -> ColumnSummary | None:
        return self.ranked[1] if len(self.ranked) > 1 else None

    @property
    def margin_m(self) -> float | None:
        """Runner-up median minus best median [m]."""
        if self.best is None or self.runner_up is None:
            return None
        return self.runner_up.median - self.best.median

    @property
    def margin_fraction(self) -> float | None:
        """The margin as a fraction of the runner-up's median."""
        if self.margin_m is None or self.runner_up is None or self.runner_up.median <= 0:
            return None
        return self.margin_m / self.runner_up.median

    @property
    def tied(self) -> bool:
        """The best and the runner-up medians differ by less than ``TIE_M``."""
        return self.margin_m is not None and self.margin_m < TIE_M

    @property
    def spread_known(self) -> bool:
        """Both the best and the runner-up have at least two seeds."""
        return (
            self.best is not None
            and self.runner_up is not None
            and min(self.best.seeds, self.runner_up.seeds) > 1
        )

    @property
    def within_spread(self) -> bool | None:
        """The min-max ranges over seeds of the best and the runner-up overlap (None: unknown)."""
        if not self.spread_known:
            return None
        assert self.best is not None and self.runner_up is not None
        return self.best.high >= self.runner_up.low

    def sentence(self) -> str:
        """The verdict in one sentence."""
        best, runner = self.best, self.runner_up
        if best is None:
            return (
                f"{self.dataset}: no verdict, no estimator besides dead reckoning has an ATE "
                f"RMSE against the {self.ground_truth}."
            )
        text = f"{self.dataset}: {best.column} has the lowest ATE RMSE, {best.describe()}"
        if runner is not None and self.tied:
            assert self.margin_m is not None
            text = (
                f"{self.dataset}: {best.column} and {runner.column} tie for the lowest ATE RMSE, "
                f"{best.describe()} (their medians differ by {self.margin_m:.1g} m, less than "
                f"{TIE_M * 1e6:.0f} µm)"
            )
        elif runner is None:
            text += ", and is the only estimator besides dead reckoning"
        else:
            assert self.margin_m is not None
            margin = f"{self.margin_m:.3g} m"
            if self.margin_fraction is not None:
                margin += f" ({100 * self.margin_fraction:.0f}%)"
            text += f"; {margin} below {runner.column} ({runner.describe()})"
            if self.within_spread is None:
                text += (
                    "; with only one seed no seed spread is known, so whether the difference "
                    "exceeds it cannot be said"
                )
            elif self.within_spread:
                text += (
                    "; the difference is within the seed spread (their ranges over seeds "
                    "overlap), so these runs do not separate the two"
                )
            else:
                text += (
                    "; the difference is larger than the seed spread (the ranges do not overlap)"
                )
        if self.baseline is not None and self.baseline.median > 0:
            text += (
                f". Dead reckoning: median {self.baseline.median:.3g} m "
                f"({best.median / self.baseline.median:.2f}× for {best.column})"
            )
            if best.median > self.baseline.median:
                text += "; no estimator beats dead reckoning here"
        return text + f" [{self.ground_truth}]."


def summarise(column: str, values: Sequence[float]) -> ColumnSummary | None:
    finite = sorted(float(v) for v in values if v is not None and np.isfinite(v))
    return ColumnSummary(column, tuple(finite)) if finite else None


def verdict(
    dataset: str,
    ground_truth: str,
    columns: Sequence[str],
    values_of: Callable[[str], Sequence[float]],
    is_baseline: Callable[[str], bool],
) -> Verdict:
    """The verdict of one dataset.

    Args:
        dataset: its label.
        ground_truth: label of its ground truth.
        columns: the estimator columns.
        values_of: column -> ATE RMSE of each successful seed.
        is_baseline: the column is dead reckoning.
    """
    ranked, baseline = [], None
    for column in columns:
        summary = summarise(column, values_of(column))
        if summary is None:
            continue
        if is_baseline(column):
            baseline = baseline or summary
        else:
            ranked.append(summary)
    ranked.sort(key=lambda s: (s.median, s.high, s.column))
    return Verdict(dataset, ground_truth, tuple(ranked), baseline)
