"""Steps 4 and 5 of Barra & Costa (sec. 3 and 3.2): projections to landmarks, then validation.

Step 4. All pairs (i, j) of a projection i and a candidate landmark j that pass the photometric
gate (``photometric.photometric_scores``; every pair when the gate is off) get

    u_shift_ij = u_i - u_hat_j        (extracted minus expected position on the 1-D image [px]).

The pairs are sorted by u_shift and a window slides over them, once per maximum spread
(3, 6, 12, 24 px): at each step the window starts at the next pair and ends at the last pair
whose u_shift is within the spread of the first. From each window the largest set of pairs
without a repeated projection or landmark is taken (a maximum-cardinality matching; among
maxima, the one of largest total C'_ij). Each set k is scored (eq. 1 and the following one):

    F_shift_k = sqrt(n_k) / (Var(u_shift_k) + |mean(u_shift_k)| d_max / 7)
    Sc_k      = mean(C'_ij over k) + 100 F_shift_k

with d_max the largest spacing between the set's projections, read as the largest gap between
neighbouring projections ("o espacamento maximo entre as projecoes"): the reading under which a
denser set of the same shift scores better (with max u - min u instead, a two-pair subset of a
correct five-pair set with a 2 px common shift beats it; see the tests). The set of
largest Sc_k is the answer; sets of fewer than ``min_set_pairs`` (2) pairs compete only when no
window gives that many (ours: as printed, eq. 1 makes a one-pair set, Var = d_max = 0,
infinitely good). Two more details the paper leaves open, ours: the mean enters by its
magnitude (the paper speaks of its size; a negative shift would otherwise reward itself), and
the denominator has a floor (``variance_floor_px2``; a one-pair set has Var = d_max = 0). Ties
go to the set of smaller |mean(u_shift)|.

Step 5. A pair (i, j) is used only if the previous processed frame associated the same landmark
j with the projection that step 3 (``tracking``) matched to i: the same physical line, twice.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from omnislam.ukf.config import AssociationConfig

#: weight that makes the number of pairs dominate C'_ij in the window matchings
_CARDINALITY = 1000.0


@dataclass(frozen=True, slots=True)
class LandmarkAssociation:
    """The best set of step 4.

    Attributes:
        lines: (n,) projection indices.
        candidates: (n,) candidate indices (``Candidates`` rows), paired with ``lines``.
        score: Sc_k of the set (-inf when no pair passed the gate).
        sets: number of distinct sets scored.
    """

    lines: np.ndarray
    candidates: np.ndarray
    score: float
    sets: int

    def __len__(self) -> int:
        return int(self.lines.shape[0])


def _largest_matching(lines: np.ndarray, cands: np.ndarray, scores: np.ndarray) -> np.ndarray:
    """Indices (into the window) of a maximum matching of largest total score."""
    if np.unique(lines).size == lines.size and np.unique(cands).size == cands.size:
        return np.arange(lines.size)
    from scipy.optimize import linear_sum_assignment

    rows, row_of = np.unique(lines, return_inverse=True)
    cols, col_of = np.unique(cands, return_inverse=True)
    weight = np.zeros((rows.size, cols.size))
    best = np.full((rows.size, cols.size), -1, dtype=np.int64)
    for k in np.argsort(scores):  # increasing: the last write is the largest score
        weight[row_of[k], col_of[k]] = _CARDINALITY + scores[k]
        best[row_of[k], col_of[k]] = k
    r, c = linear_sum_assignment(weight, maximize=True)
    chosen = best[r, c]
    return np.sort(chosen[chosen >= 0])


def set_score(
    u_shift_px: np.ndarray, u_lines_px: np.ndarray, scores: np.ndarray, config: AssociationConfig
) -> tuple[float, float]:
    """(Sc_k, F_shift_k) of one set (eq. 1 and the Sc_k equation of sec. 3.2)."""
    n = u_shift_px.size
    variance = float(np.var(u_shift_px))
    d_max = float(np.diff(np.sort(u_lines_px)).max()) if n > 1 else 0.0
    denominator = variance + abs(float(u_shift_px.mean())) * d_max / config.spread_divisor
    f_shift = math.sqrt(n) / max(denominator, config.variance_floor_px2)
    return float(scores.mean()) + config.shift_weight * f_shift, f_shift


def associate_landmarks(
    u_lines_px: np.ndarray,
    u_candidates_px: np.ndarray,
    scores: np.ndarray,
    config: AssociationConfig,
) -> LandmarkAssociation:
    """Step 4: the set of (projection, candidate) pairs of largest Sc_k.

    Args:
        u_lines_px: (K,) extracted projections on the 1-D image [px].
        u_candidates_px: (C,) expected projections of the candidates [px].
        scores: (K, C) C'_ij, NaN where the photometric gate rejects the pair.

    Returns:
        The chosen set (empty when no pair passes).
    """
    u_lines_px = np.asarray(u_lines_px, dtype=float)
    u_candidates_px = np.asarray(u_candidates_px, dtype=float)
    ok = np.isfinite(scores) & np.isfinite(u_lines_px)[:, None]
    ok &= np.isfinite(u_candidates_px)[None, :]
    li, ci = np.nonzero(ok)
    empty = LandmarkAssociation(np.zeros(0, np.int64), np.zeros(0, np.int64), -math.inf, 0)
    if not li.size:
        return empty
    shift = u_lines_px[li] - u_candidates_px[ci]
    order = np.argsort(shift, kind="stable")
    li, ci, shift, c = li[order], ci[order], shift[order], scores[li[order], ci[order]]
    seen: set[tuple[int, int]] = set()
    best = (-1, -math.inf, math.inf)  # (n_k >= min_set_pairs, Sc_k, |mean u_shift|)
    best_set = np.zeros(0, dtype=np.int64)
    for spread in config.windows_px:
        ends = np.searchsorted(shift, shift + spread, side="right")
        for start, end in zip(range(shift.size), ends.tolist(), strict=True):
            if (start, end) in seen:
                continue
            seen.add((start, end))
            window = slice(start, end)
            pick = start + _largest_matching(li[window], ci[window], c[window])
            sc, _ = set_score(shift[pick], u_lines_px[li[pick]], c[pick], config)
            key = (int(pick.size >= config.min_set_pairs), sc, abs(float(shift[pick].mean())))
            if key[:2] > best[:2] or (key[:2] == best[:2] and key[2] < best[2]):
                best, best_set = key, pick
    return LandmarkAssociation(li[best_set], ci[best_set], best[1], len(seen))


def validate(
    pairs: Mapping[int, int], tracked_from: np.ndarray, previous_pairs: Mapping[int, int]
) -> dict[int, int]:
    """Step 5: the pairs of this frame whose landmark the previous frame gave the same line.

    Args:
        pairs: projection index -> landmark id, step 4 of this frame.
        tracked_from: (K,) step 3: previous projection index of each projection, or -1.
        previous_pairs: projection index -> landmark id, step 4 of the previous frame.

    Returns:
        The validated subset of ``pairs``.
    """
    out = {}
    for line, landmark in pairs.items():
        before = int(tracked_from[line])
        if before >= 0 and previous_pairs.get(before) == landmark:
            out[line] = landmark
    return out
