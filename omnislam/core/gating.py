"""Chi-square validation gates on innovations, and the likelihood truncated at the gate.

For a consistent filter the squared Mahalanobis distance y^T S^-1 y of a k-dimensional
innovation is chi-square distributed with k degrees of freedom, so ``y^T S^-1 y <= gate`` with
gate the chi-square quantile of a probability keeps that fraction of the valid measurements
(Bar-Shalom's validation region; SLAM for Dummies' nu^T S^-1 nu <= lambda). A measurement
outside the gate is an outlier: an estimator skips its update, and a robust weight uses the
Gaussian likelihood truncated at the gate, so that one bad measurement cannot decide between
hypotheses.
"""

from __future__ import annotations

import math

import numpy as np

#: the chi-square probability of the outlier gate every Gaussian back end applies by default to
#: a sighting of a known landmark (an id, or a pairing the association chose): an innovation
#: whose squared Mahalanobis distance under the back end's own innovation covariance exceeds
#: the 0.999 quantile (13.8 for range-bearing) is dropped. MR.CLAM dataset 6 (robots 1-5)
#: has misread barcodes 3-3.4 m or ~3 rad away from the landmark they name: hundreds of sigmas.
OUTLIER_GATE_PROBABILITY = 0.999
#: a landmark with fewer than ``OUTLIER_GATE_MIN_SIGHTINGS`` sightings in the back end is gated
#: at ``YOUNG_GATE_FACTOR`` times the outlier gate's squared distance: its linearised estimate
#: is not trusted near the gate, and a sighting hundreds of sigmas off is still rejected. With
#: the plain gate a young landmark's correct re-sightings were rejected one after another, each
#: leaving it worse placed (victoria_park.txt with ids: graphslam 101 m from the LM optimum,
#: EKF-SLAM 105 m against 6.6 m with no gate)
OUTLIER_GATE_MIN_SIGHTINGS = 20
YOUNG_GATE_FACTOR = 10.0


def chi_square_gate(probability: float, dof: int) -> float:
    """The validation gate of a k-dimensional innovation: y^T S^-1 y <= gate holds with
    probability ``probability`` for a consistent filter (chi-square quantile).

    Args:
        probability: in (0, 1]; 1.0 gives an infinite gate (nothing rejected).
        dof: the innovation's dimension k.

    Returns:
        the gate on the squared Mahalanobis distance.
    """
    if probability >= 1.0:
        return math.inf
    from scipy.stats import chi2

    return float(chi2.ppf(probability, dof))


def gate_truncated_log_likelihood(
    log_likelihood: np.ndarray, mahalanobis: np.ndarray, gate: float
) -> np.ndarray:
    """The Gaussian log-likelihood with its Mahalanobis term capped at the gate.

    log N evaluated at min(y^T S^-1 y, gate) instead of y^T S^-1 y: unchanged inside the gate,
    the likelihood at the gate's boundary outside it.

    Args:
        log_likelihood: [...] log N(y; 0, S).
        mahalanobis: [...] y^T S^-1 y of the same innovations.
        gate: the gate (``chi_square_gate``).
    """
    truncated = np.minimum(mahalanobis, gate)
    return log_likelihood - 0.5 * (truncated - mahalanobis)
