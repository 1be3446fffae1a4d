"""The verdict on its own: families ranked by their best column, variants beside their method's
best, margins separated by the seed spread or not, ties, the dead-reckoning baseline; and the one
statistic over seeds (the low median, so the median is one run's value)."""

from __future__ import annotations

import pytest

from omnislam.metrics.seeds import SeedSummary, median_index, summarise_seeds
from omnislam.metrics.verdict import TIE_M, ColumnSummary, Verdict, rank_families, separated

GRAPH, PARTICLES = "factor graph", "particle filter"


def column(name: str, family: str, method: str, *values: float, det: bool = False):
    return ColumnSummary(name, family, method, summarise_seeds(values, det))


def test_the_median_over_seeds_is_one_runs_value_and_the_lower_middle_for_an_even_count():
    assert summarise_seeds([0.3, 0.1, 0.2]).median == 0.2
    even = summarise_seeds([0.4, 0.1, 0.3, 0.2])
    assert even.median == 0.2 and (even.low, even.high) == (0.1, 0.4)
    assert even.text() == "0.2 [0.1–0.4]"
    assert median_index([0.4, 0.1, 0.3, 0.2]) == 3  # the run whose value is the median
    assert summarise_seeds([float("nan"), None]) is None


def test_a_deterministic_estimator_shows_no_spread():
    det = SeedSummary((0.128, 0.128, 0.128), deterministic=True)
    assert not det.has_spread and det.text() == "0.128" and det.spread_text() == "deterministic"
    assert SeedSummary((0.128,)).spread_text() == "1 seed"


def test_variants_of_one_method_are_shown_beside_its_best_not_ranked_against_it():
    families = rank_families(
        [
            column("graphslam", GRAPH, "graph", 0.0183, det=True),
            column("graphslam-batch", GRAPH, "graph", 0.0183 + 1e-9, det=True),
            column("fastslam2", PARTICLES, "fs2", 0.05, 0.06, 0.07),
            column("fastslam1", PARTICLES, "fs1", 0.09, 0.1, 0.2),
        ]
    )
    assert [f.best.column for f in families] == ["graphslam", "fastslam2"]
    assert [c.column for c in families[0].variants] == ["graphslam-batch"]
    assert families[1].variants == ()  # fastslam1 is another method of the family
    verdict = Verdict("demo", "bearings-3d", "exact", families, SeedSummary((0.0396,)))
    assert verdict.margin_m == pytest.approx(0.06 - 0.0183)
    assert verdict.behind_fraction(families[1]) == pytest.approx((0.06 - 0.0183) / 0.06)
    assert separated(families[0].best, families[1].best) is True
    notes = verdict.notes()
    assert any("graphslam-batch gives graphslam's result" in n for n in notes)
    assert not any("dead reckoning" in n for n in notes)


def test_overlapping_ranges_unknown_spreads_ties_and_the_baseline_get_a_note():
    a = column("ekfslam", "Kalman filter", "ekf", 0.10, det=True)
    b = column("fastslam2", PARTICLES, "fs2", 0.09, 0.12, 0.2)
    assert separated(a, b) is False  # 0.10 lies inside fastslam2's range
    assert separated(a, column("fs", PARTICLES, "fs", 0.3)) is None  # one seed: unknown
    verdict = Verdict("r1", "range-bearing-2d", "gt", rank_families([a, b]), SeedSummary((0.05,)))
    notes = " ".join(verdict.notes())
    assert "do not separate" in notes and "no estimator beats dead reckoning" in notes
    tie = Verdict(
        "r1",
        "x",
        "gt",
        rank_families([a, column("g", GRAPH, "g", 0.10 + TIE_M / 2, det=True)]),
    )
    assert tie.tied and "tie" in tie.notes()[0]
