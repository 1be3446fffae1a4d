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

What the paper does not do and we add (``AssociationConfig.gate_probability``, default 0.999;
``largest_set_first``, default on). The paper's step 4 uses the predicted pose only for the
expected projections, never its uncertainty: the windows allow any common shift and up to
24 px of spread. A line near a candidate's projection in the same frame twice (a poster edge
at the end of a corridor, the next door frame after a turn) then passes step 5, and wrong pairs
reach the update on corridor21 (docs/results/ukf.md). With the UKF's predicted covariance P:

* the pre-gate: the sigma points of (x, P) give each candidate's predicted bearing and the
  (C, C) covariance of all of them (``filter.PoseUKF.predict_bearings``, the Pzz of the
  update); a pair enters step 4 only if (b_i - b_hat_j)^2 / (sigma_i^2 + Pzz_jj) passes the
  1-dof chi-square gate. This also runs before the photometric stage, which then only scores
  the pre-gated pairs (the speed of step 4 in large maps).
* the joint gate: each window's matching is cut to its largest subset (greedily) that is
  consistent with one pose: its innovation vector passes the n-dof gate with S = Pzz + R,
  and each pair passes the 1-dof gate given the others. The pairs of one frame share one
  pose error: a common shift that P explains (a heading error) is allowed, shifts that no
  pose explains are not, which the windows' spread cannot tell apart.
* the choice: sets are compared by their number of pairs first and by Sc_k among sets of
  the same size. Eq. 1's |mean| d_max / 7 term makes a large correct set with the common
  shift of a heading error lose to a two-pair set of small shift (after a turn on
  corridor21: 4.6 deg, 34 px); with the joint gate such a shift is no evidence against a
  set. With ``largest_set_first=False`` Sc_k alone decides, as printed.
* a set of a single pair is kept only when neither its projection nor its landmark has another
  pair that passed the gates (``unambiguous_single``): a lone pair is the nearest candidate,
  not evidence for it.
* the nearest line (``nearest_line``): each window's set, once cut to its consistent subset,
  keeps a pair only when its line is, of all the frame's extracted lines whatever their colour,
  the nearest to its landmark's bearing as the set's other pairs predict it
  (``PoseConsistency.nearest_lines``). The photometric stage may reject lines, but not choose
  a farther line over a nearer one. On corridor21's dense render (an image every ~9 cm) every
  wrong validated pair (12 over d_it 10-37.5 cm) was an unmapped line 4-22 px beside a door
  frame's landmark: mostly the frame's inner edge, 8 cm away, which passes the photometric gate
  (diff_banda 16-24) where the landmark's own line close to the camera fails it (54-72 against
  the MC surveyed as a mean over ranges). Near the camera the pose's along-corridor
  uncertainty (2-5 cm) spreads the landmark's predicted bearing over 4-7 px, and the far
  landmarks of the set fix the heading but not that, so the wrong pair passed the joint gate
  (given the others, squared distance 0.5-9.4 against 10.8) in two consecutive frames: the
  same unmapped line beside the same landmark, so step 5 validated it. In 10 of the 12 the
  landmark's own line (or another one) lay nearer to that prediction; of the 1340 right
  validated pairs of the same runs, 10 did not (measured offline on that render).

Measured on corridor21 with ``benchmarks/ukf_corridor21.py`` (docs/results/ukf.md).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from omnislam.core.gating import chi_square_gate
from omnislam.core.se import wrap_angle
from omnislam.ukf.config import AssociationConfig
from omnislam.ukf.filter import BearingPrediction

#: weight that makes the number of pairs dominate C'_ij in the window matchings
_CARDINALITY = 1000.0
#: weight of the u_shift closeness that breaks ties of C'_ij in the window matchings
_TIE_BREAK = 1e-3


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


def _largest_matching(
    lines: np.ndarray, cands: np.ndarray, scores: np.ndarray, shift: np.ndarray
) -> np.ndarray:
    """Indices (into the window) of a maximum matching of largest total score; among those
    (e.g. without colour, every C'_ij = 0) the one whose u_shifts lie closest to the window's
    median (ours: the paper leaves the choice open; this is its least-variance criterion)."""
    n = lines.size
    if len(set(lines.tolist())) == n and len(set(cands.tolist())) == n:
        return np.arange(n)
    from scipy.optimize import linear_sum_assignment

    rows, row_of = np.unique(lines, return_inverse=True)
    cols, col_of = np.unique(cands, return_inverse=True)
    median = 0.5 * (shift[(n - 1) // 2] + shift[n // 2])  # a window's shifts are sorted
    deviation = np.abs(shift - median)
    closeness = _TIE_BREAK * (1.0 - deviation / max(float(deviation.max()), 1e-12))
    weight = np.zeros((rows.size, cols.size))
    weight[row_of, col_of] = _CARDINALITY + scores + closeness
    best = np.full((rows.size, cols.size), -1, dtype=np.int64)
    best[row_of, col_of] = np.arange(lines.size)  # a (line, candidate) pair occurs once
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


@dataclass(frozen=True, slots=True)
class PoseConsistency:
    """What the predicted pose and its covariance say about pairs (ours, on top of sec. 3.2).

    Attributes:
        innovations_rad: (K, C) wrapped bearing of projection i minus predicted bearing of
            candidate j.
        line_variance: (K,) variance of each extracted bearing [rad^2].
        prediction: the unscented prediction of the C candidates' bearings (its covariance
            couples them: they share the pose error).
        probability: of the chi-square gates.
    """

    innovations_rad: np.ndarray
    line_variance: np.ndarray
    prediction: BearingPrediction
    probability: float

    def pair_distances(self) -> np.ndarray:
        """(K, C) squared Mahalanobis distance of each pair's innovation alone."""
        s = self.line_variance[:, None] + self.prediction.variance[None, :]
        return self.innovations_rad**2 / s

    def pregate(self) -> np.ndarray:
        """(K, C) True where a pair's innovation lies inside the 1-dof gate."""
        return self.pair_distances() <= chi_square_gate(self.probability, 1)

    def joint_distance(self, lines: np.ndarray, candidates: np.ndarray) -> float:
        """Squared Mahalanobis distance of a set's innovation vector, y^T S^-1 y."""
        y = self.innovations_rad[lines, candidates]
        S = self.prediction.covariance(candidates) + np.diag(self.line_variance[lines])
        return float(y @ np.linalg.solve(S, y))

    def consistent_subset(self, lines: np.ndarray, candidates: np.ndarray) -> np.ndarray:
        """Indices of the largest subset, found greedily, that is consistent with the predicted
        pose: its innovation vector passes the n-dof joint gate and each pair passes the 1-dof
        gate given the others (with a = S^-1 y, a_k^2 / (S^-1)_kk is pair k's squared distance
        from what the other pairs predict for it, and removing k lowers y^T S^-1 y by just
        that). While the set fails, the pair of largest such distance is dropped."""
        keep = np.arange(lines.size)
        one = _gate(self.probability, 1)
        while keep.size:
            y = self.innovations_rad[lines[keep], candidates[keep]]
            S = self.prediction.covariance(candidates[keep]) + np.diag(
                self.line_variance[lines[keep]]
            )
            S_inv = np.linalg.inv(S)
            a = S_inv @ y
            given_others = a * a / np.diag(S_inv)
            worst = int(np.argmax(given_others))
            if float(y @ a) <= _gate(self.probability, keep.size) and given_others[worst] <= one:
                return keep
            keep = np.delete(keep, worst)
        return keep

    def nearest_lines(self, lines: np.ndarray, candidates: np.ndarray) -> np.ndarray:
        """(n,) True where pair k's line is, of all the frame's extracted lines (whatever their
        colour), the one nearest to its landmark's bearing as the set's other pairs predict it
        (ours, on step 4 of sec. 3.2; ``AssociationConfig.nearest_line``).

        With S = Pzz + R, a = S^-1 y and h = diag(S^-1), the innovation of pair k given the
        others has mean mu_k = y_k - a_k / h_k and variance 1 / h_k; without line k's own
        noise, 1 / h_k - R_k is the variance of landmark k's predicted bearing given the
        others. Line l's squared distance from it is (y_lk - mu_k)^2 / (1 / h_k - R_k + R_l),
        y_lk the innovation of line l against landmark k. A set of one pair: the prediction.
        """
        y = self.innovations_rad[lines, candidates]
        S = self.prediction.covariance(candidates) + np.diag(self.line_variance[lines])
        S_inv = np.linalg.inv(S)
        h = np.diag(S_inv)
        mu = y - (S_inv @ y) / h
        variance = np.maximum(1.0 / h - self.line_variance[lines], 0.0)
        offset = wrap_angle(self.innovations_rad[:, candidates] - mu[None, :])  # (K, n)
        d2 = offset**2 / (variance[None, :] + self.line_variance[:, None])
        return d2[lines, np.arange(lines.size)] <= d2.min(axis=0)


@lru_cache(maxsize=256)
def _gate(probability: float, dof: int) -> float:
    return chi_square_gate(probability, dof)


def associate_landmarks(
    u_lines_px: np.ndarray,
    u_candidates_px: np.ndarray,
    scores: np.ndarray,
    config: AssociationConfig,
    consistency: PoseConsistency | None = None,
) -> LandmarkAssociation:
    """Step 4: the set of (projection, candidate) pairs of largest Sc_k.

    Args:
        u_lines_px: (K,) extracted projections on the 1-D image [px].
        u_candidates_px: (C,) expected projections of the candidates [px].
        scores: (K, C) C'_ij, NaN where the photometric gate (or the pre-gate) rejects the
            pair.
        consistency: when given, each window's set is cut to its largest subset consistent
            with the predicted pose (``PoseConsistency.consistent_subset``), then, with
            ``config.nearest_line``, to the pairs whose line is the nearest to its landmark
            given the others (``PoseConsistency.nearest_lines``), before it is scored.

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
    cut: dict[tuple[int, ...], np.ndarray] = {}
    best = (-1, -math.inf, math.inf)  # (n_k or n_k >= min_set_pairs, Sc_k, |mean u_shift|)
    best_set = np.zeros(0, dtype=np.int64)
    for spread in config.windows_px:
        ends = np.searchsorted(shift, shift + spread, side="right")
        for start, end in zip(range(shift.size), ends.tolist(), strict=True):
            if (start, end) in seen:
                continue
            seen.add((start, end))
            window = slice(start, end)
            pick = start + _largest_matching(li[window], ci[window], c[window], shift[window])
            if consistency is not None:
                key_pick = tuple(pick.tolist())
                if key_pick in cut:
                    continue  # the same matching from another window: already scored
                pick = pick[consistency.consistent_subset(li[pick], ci[pick])]
                if config.nearest_line and pick.size:
                    pick = pick[consistency.nearest_lines(li[pick], ci[pick])]
                cut[key_pick] = pick
                if not pick.size:
                    continue
            sc, _ = set_score(shift[pick], u_lines_px[li[pick]], c[pick], config)
            size = pick.size if config.largest_set_first else int(pick.size >= config.min_set_pairs)
            key = (size, sc, abs(float(shift[pick].mean())))
            if key[:2] > best[:2] or (key[:2] == best[:2] and key[2] < best[2]):
                best, best_set = key, pick
    if config.unambiguous_single and best_set.size == 1:
        line, cand = int(li[best_set[0]]), int(ci[best_set[0]])
        if ok[line].sum() > 1 or ok[:, cand].sum() > 1:
            return dataclasses.replace(empty, sets=len(seen))
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
