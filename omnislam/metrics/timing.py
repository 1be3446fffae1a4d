"""Step timing: statistics of the wall time of each estimator step."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, slots=True)
class TimingStats:
    """Per-step wall time statistics [ms] (NaN when there are no steps)."""

    median_ms: float
    p95_ms: float
    mean_ms: float
    max_ms: float
    steps_total_s: float


def timing_stats(step_s: np.ndarray) -> TimingStats:
    """Statistics of (N,) per-step wall times [s]."""
    ms = 1e3 * np.asarray(step_s, dtype=float)
    if not ms.size:
        return TimingStats(math.nan, math.nan, math.nan, math.nan, 0.0)
    return TimingStats(
        median_ms=float(np.median(ms)),
        p95_ms=float(np.percentile(ms, 95)),
        mean_ms=float(np.mean(ms)),
        max_ms=float(np.max(ms)),
        steps_total_s=float(ms.sum() / 1e3),
    )
