"""Photometric features and the photometric gate of Barra & Costa (sec. 2.2 and 3.2).

* PMC (perfil medio de cor): per projection, 3 bands x (2n + 1) mean colours across the line.
* MC (media de cores): per band, the mean colour left and right of the line
  (R_esq, R_dir, G_esq, G_dir, B_esq, B_dir); landmarks store MCs, projections' PMCs are
  turned into MCs by dropping the central value and averaging each side (sec. 3.2).
* For projection i and landmark j (sec. 3.2):

      M       = (R_dir + R_esq + G_dir + G_esq + B_dir + B_esq) / 6
      X_diff  = X_dir - X_esq                                 (X = R, G, B)
      diff_media = |M_i - M_j|
      diff_banda = (|R_diff_i - R_diff_j| + |G_diff_i - G_diff_j| + |B_diff_i - B_diff_j|) / 3
      reject if (30 - diff_banda) < 0 or (100 - diff_media) < 0, else
      C'_ij = (0.7 (30 - diff_banda) + 0.3 (100 - diff_media)) / (0.7 * 30 + 0.3 * 100).

Profiles run from the robot's left to its right (``VerticalLines`` convention): "esq" (left) is
the first n columns, "dir" (right) the last n.
"""

from __future__ import annotations

import numpy as np

from omnislam.ukf.config import PhotometricConfig


def mc_from_pmc(profiles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """MC of projections from their PMC (sec. 3.2: drop the centre, average each side).

    Args:
        profiles: (K, 3, 2n + 1) PMC, bands R, G, B, columns left to right.

    Returns:
        (means_left (K, 3), means_right (K, 3)).
    """
    profiles = np.asarray(profiles, dtype=float)
    n = profiles.shape[2] // 2
    return profiles[:, :, :n].mean(axis=2), profiles[:, :, n + 1 :].mean(axis=2)


def colour_differences(
    left_i: np.ndarray, right_i: np.ndarray, left_j: np.ndarray, right_j: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """diff_banda and diff_media of every (projection i, landmark j), sec. 3.2.

    Args:
        left_i: (K, 3) MC of the projections' left sides.
        right_i: (K, 3) MC of the projections' right sides.
        left_j: (M, 3) MC of the landmarks' left sides (NaN rows: unknown).
        right_j: (M, 3) MC of the landmarks' right sides (NaN rows: unknown).

    Returns:
        (diff_band (K, M), diff_mean (K, M)) in grey levels; NaN where a landmark's MC is NaN.
    """
    mean_i = (left_i.sum(axis=1) + right_i.sum(axis=1)) / 6.0
    mean_j = (left_j.sum(axis=1) + right_j.sum(axis=1)) / 6.0
    band_i = right_i - left_i
    band_j = right_j - left_j
    diff_mean = np.abs(mean_i[:, None] - mean_j[None, :])
    diff_band = np.abs(band_i[:, None, :] - band_j[None, :, :]).sum(axis=2) / 3.0
    return diff_band, diff_mean


def photometric_scores(
    diff_band: np.ndarray, diff_mean: np.ndarray, config: PhotometricConfig
) -> np.ndarray:
    """C'_ij of sec. 3.2; NaN where the gate rejects the pair.

    Pairs whose landmark has no MC (NaN differences) pass with C'_ij = 0: no colour evidence.
    """
    a, b = config.max_diff_band, config.max_diff_mean
    w = config.weight_band
    score = (w * (a - diff_band) + (1.0 - w) * (b - diff_mean)) / (w * a + (1.0 - w) * b)
    unknown = np.isnan(diff_band) | np.isnan(diff_mean)
    with np.errstate(invalid="ignore"):
        rejected = ((a - diff_band) < 0) | ((b - diff_mean) < 0)
    return np.where(unknown, 0.0, np.where(rejected, np.nan, score))


def profile_distance(profiles_a: np.ndarray, profiles_b: np.ndarray) -> np.ndarray:
    """Mean absolute difference of two sets of PMCs [grey levels], (K_a, K_b).

    Step 3's similarity of projections of consecutive frames (ours; the paper defers to Barra &
    Costa 2005). Profiles of different widths are compared on their common central columns.
    """
    wa, wb = profiles_a.shape[2], profiles_b.shape[2]
    w = min(wa, wb)
    a = profiles_a[:, :, (wa - w) // 2 : (wa - w) // 2 + w]
    b = profiles_b[:, :, (wb - w) // 2 : (wb - w) // 2 + w]
    return np.abs(a[:, None] - b[None, :]).mean(axis=(2, 3))
