"""The chi-square validation gate of SLAM for Dummies' data association (nu^T S^-1 nu <= lambda).

Kept small and isolated on purpose: the same function (same name, same signature) is being moved
into ``omnislam.core.gating`` for every estimator; once it is there, this module becomes an
import of it.
"""

from __future__ import annotations

import math


def chi_square_gate(probability: float, dof: int) -> float:
    """The gate lambda on the squared Mahalanobis distance of a ``dof``-dimensional innovation.

    For a consistent filter nu^T S^-1 nu is chi-square distributed with ``dof`` degrees of
    freedom, so the gate keeps the fraction ``probability`` of correct pairings (SLAM for
    Dummies, "Associação de dados": the validation gate; Bar-Shalom's validation region).

    Args:
        probability: in (0, 1]; 1.0 gives an infinite gate (nothing rejected).
        dof: the innovation's dimension.

    Returns:
        lambda, the chi-square quantile of ``probability``.
    """
    if probability >= 1.0:
        return math.inf
    from scipy.stats import chi2

    return float(chi2.ppf(probability, dof))
