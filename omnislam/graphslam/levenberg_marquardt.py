"""Levenberg-Marquardt on a whole factor graph: the final solve of the back end.

One GTSAM ``LevenbergMarquardtOptimizer`` run from given values, with its stopping rules
(``BatchConfig``): the fixed-lag session's ``estimate()`` (``session.py``), batch mode's solve
warm-started from iSAM2 (``batch.py``) and the re-solves of the re-association. It depends on
GTSAM only, so every module of the back end can import it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from omnislam._optional import require

gtsam = require("gtsam")


@dataclass(frozen=True, slots=True)
class BatchResult:
    """Outcome of one LM run.

    Attributes:
        values: the optimised ``gtsam.Values``.
        iterations: LM iterations taken.
        initial_error: graph error (0.5 * sum of squared whitened residuals) at the start.
        final_error: graph error at the end.
    """

    values: Any
    iterations: int
    initial_error: float
    final_error: float


def optimize_batch(
    graph: Any, initial: Any, max_iterations: int = 100, relative_error_tol: float = 1e-10
) -> BatchResult:
    """Levenberg-Marquardt on ``graph`` (``gtsam.NonlinearFactorGraph``) from ``initial``
    (``gtsam.Values``), stopping after ``max_iterations`` or once the error's relative
    decrease falls below ``relative_error_tol``."""
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(max_iterations)
    params.setRelativeErrorTol(relative_error_tol)
    optimizer = gtsam.LevenbergMarquardtOptimizer(graph, initial, params)
    values = optimizer.optimize()
    return BatchResult(
        values=values,
        iterations=int(optimizer.iterations()),
        initial_error=float(graph.error(initial)),
        final_error=float(graph.error(values)),
    )
