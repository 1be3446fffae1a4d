"""Step timing: statistics of the wall time of each estimator step, the warm-up apart.

The first steps of a run pay for what happens once: numba compiling the kernels a code path
reaches first, caches filling, the first frame's allocations (FastSLAM 2.0's first step took
0.76 s of a 4.5 s run). Counted among the steps they set the maximum and the tail, and they
belong to no step a long run repeats; so they are reported apart, as the *warm-up*:

    the warm-up is the first step, and every step up to the last step of the first
    ``WARMUP_WINDOW`` of the run (at least one step) that takes longer than
    ``WARMUP_FACTOR`` times the median step of the whole run.

The per-step statistics are over the steps after the warm-up (over all steps when the run has
only warm-up steps); the total includes the warm-up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: a step in the warm-up window slower than this many median steps ends the warm-up no earlier
#: than itself (a compiled step is 100-1000x a normal one; a slow ordinary step rarely 10x)
WARMUP_FACTOR = 10.0
#: the fraction of the steps, from the start, in which the warm-up may end
WARMUP_WINDOW = 0.1


@dataclass(frozen=True, slots=True)
class TimingStats:
    """Per-step wall time statistics [ms] (NaN when there are no steps).

    Attributes:
        median_ms, p95_ms, mean_ms, max_ms: over the steps after the warm-up [ms].
        steps_total_s: wall time of all steps, the warm-up included [s].
        warmup_s: wall time of the warm-up steps [s].
        warmup_steps: how many steps the warm-up is (0 when there are no steps).
    """

    median_ms: float
    p95_ms: float
    mean_ms: float
    max_ms: float
    steps_total_s: float
    warmup_s: float = 0.0
    warmup_steps: int = 0


def warmup_steps(step_s: np.ndarray) -> int:
    """How many leading steps of (N,) step times are the warm-up (module docstring)."""
    step_s = np.asarray(step_s, dtype=float)
    if not step_s.size:
        return 0
    window = max(1, math.ceil(WARMUP_WINDOW * step_s.size))
    slow = np.flatnonzero(step_s[:window] > WARMUP_FACTOR * float(np.median(step_s)))
    return max(1, int(slow[-1]) + 1 if slow.size else 1)


def timing_stats(step_s: np.ndarray) -> TimingStats:
    """Statistics of (N,) per-step wall times [s], the warm-up apart."""
    step_s = np.asarray(step_s, dtype=float)
    if not step_s.size:
        return TimingStats(math.nan, math.nan, math.nan, math.nan, 0.0)
    warm = warmup_steps(step_s)
    steady = step_s[warm:] if warm < step_s.size else step_s
    ms = 1e3 * steady
    return TimingStats(
        median_ms=float(np.median(ms)),
        p95_ms=float(np.percentile(ms, 95)),
        mean_ms=float(np.mean(ms)),
        max_ms=float(np.max(ms)),
        steps_total_s=float(step_s.sum()),
        warmup_s=float(step_s[:warm].sum()),
        warmup_steps=warm,
    )
