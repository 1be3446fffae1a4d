"""The one statistic of a metric over seeds: the median with its min-max range.

Every place of a report that summarises a cell (an estimator on a dataset) over its seeds --
the verdict, the tables, the text and the figures -- uses ``SeedSummary``. Its median is the
*low median*: with an even count, the lower of the two middle values, so the median is always
the value of one run (the *median seed*, ``median_index``), and the trajectory drawn for a cell
is the run whose ATE is the number printed for it. A deterministic estimator run once shows its
value with "deterministic" instead of a spread.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

#: what the tables and captions say the statistic is
STATISTIC = "median over seeds [min–max]"


@dataclass(frozen=True, slots=True)
class SeedSummary:
    """A metric of one cell over its seeds.

    Attributes:
        values: the value of each run that has one, ascending.
        deterministic: the cell is a deterministic estimator run once on data on disk (its
            seeds would repeat the same run), so it has no seed spread.
    """

    values: tuple[float, ...]
    deterministic: bool = False

    @property
    def seeds(self) -> int:
        """The number of runs summarised."""
        return len(self.values)

    @property
    def median(self) -> float:
        """The low median: the middle value, the lower of the two middle ones for an even count."""
        return self.values[(len(self.values) - 1) // 2]

    @property
    def low(self) -> float:
        return self.values[0]

    @property
    def high(self) -> float:
        return self.values[-1]

    @property
    def has_spread(self) -> bool:
        """More than one run of a seed-dependent estimator, so a min-max range over seeds is
        known (a deterministic estimator's runs repeat one value)."""
        return self.seeds > 1 and not self.deterministic

    def text(self, digits: int = 3) -> str:
        """``"0.128 [0.120–0.140]"``; one run: the value alone."""
        text = f"{self.median:.{digits}g}"
        if self.has_spread:
            text += f" [{self.low:.{digits}g}–{self.high:.{digits}g}]"
        return text

    def spread_text(self, digits: int = 3) -> str:
        """The spread alone: ``"0.120–0.140"``, ``"deterministic"`` or ``"1 seed"``."""
        if self.has_spread:
            return f"{self.low:.{digits}g}–{self.high:.{digits}g}"
        return "deterministic" if self.deterministic else "1 seed"


def summarise_seeds(values: Sequence[float | None], deterministic: bool = False) -> (
    SeedSummary | None
):
    """The summary of the finite values (None when there are none)."""
    finite = sorted(float(v) for v in values if v is not None and math.isfinite(v))
    return SeedSummary(tuple(finite), deterministic) if finite else None


def median_index(values: Sequence[float]) -> int:
    """The position in ``values`` of the median seed: the run whose value is the low median
    (ties broken by position)."""
    order = sorted(range(len(values)), key=lambda i: (values[i], i))
    return order[(len(order) - 1) // 2]
