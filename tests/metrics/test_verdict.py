"""The verdict's wording on its own: a margin, a tie, the dead-reckoning baseline."""

from __future__ import annotations

from omnislam.metrics.verdict import TIE_M, ColumnSummary, Verdict

GT = "exact ground truth (synthetic)"


def _verdict(best: float, runner: float) -> Verdict:
    return Verdict(
        "demo",
        GT,
        (ColumnSummary("graphslam", (best,)), ColumnSummary("graphslam-batch", (runner,))),
        ColumnSummary("deadreckoning", (0.0396,)),
    )


def test_medians_closer_than_a_micrometre_are_a_tie():
    verdict = _verdict(0.0183, 0.0183 + 1.43e-9)  # the demo's graph and its batch pass
    assert verdict.tied
    sentence = verdict.sentence()
    assert sentence.startswith(
        "demo: graphslam and graphslam-batch tie for the lowest ATE RMSE, median 0.0183 m"
    )
    assert "1e-09 m, less than 1 µm" in sentence and "below" not in sentence
    assert "Dead reckoning: median 0.0396 m" in sentence


def test_a_margin_of_a_micrometre_or_more_is_stated():
    verdict = _verdict(0.0183, 0.0183 + TIE_M)
    assert not verdict.tied
    sentence = verdict.sentence()
    assert sentence.startswith("demo: graphslam has the lowest ATE RMSE")
    assert "1e-06 m (0%) below graphslam-batch" in sentence
