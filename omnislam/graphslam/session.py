"""One iSAM2 session: its parameters, the update (with the Cholesky -> QR fallback) and reads.

``ISAM2Session`` owns the ``gtsam.ISAM2`` object of a run and everything that is about iSAM2
rather than about the graph's content:

* the parameters (``GraphSLAMConfig``: relinearisation threshold and skip, factorisation,
  adaptive re-ordering; DESIGN.md "iSAM2 settings");
* ``update``: one ``ISAM2.update`` per frame. With ``Factorization.AUTO`` a Cholesky failure
  ("Indeterminate linear system") re-adds every factor so far, linearised at iSAM2's current
  linearisation point (the new variables at their initial guesses), to a fresh QR-factorising
  iSAM2 that the rest of the run keeps using. For that rebuild the session keeps its own copy
  of every factor added;
* the bookkeeping of what iSAM2 did (fallbacks, whole-tree re-orderings, Bayes-tree fill-in);
* reads of the estimate: one variable (the newest pose each step; DESIGN.md: reading everything
  every step cost as much as the update), the full estimate, marginal covariances.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from omnislam._optional import require
from omnislam.errors import EstimationError
from omnislam.graphslam.config import Factorization, GraphSLAMConfig

gtsam = require("gtsam")


class ISAM2Session:
    """The iSAM2 optimiser of one run, started empty.

    Args:
        config: the iSAM2 settings are read from it (``relinearize_threshold``,
            ``relinearize_skip``, ``factorization``, ``adaptive_reorder_threshold``).
    """

    def __init__(self, config: GraphSLAMConfig) -> None:
        self._config = config
        self._factorization = Factorization.CHOLESKY
        self._isam = self._new_isam(config.factorization)
        self._all_factors = gtsam.NonlinearFactorGraph()  # every factor so far (for a rebuild)
        self._fallbacks = 0
        self._reorders = 0
        self._pose3_cache: dict[int, Any] = {}  # Pose3 estimates read since the last update

    def _new_isam(self, factorization: Factorization) -> Any:
        """A fresh ``gtsam.ISAM2`` factorising with ``factorization`` (AUTO starts Cholesky)."""
        config = self._config
        params = gtsam.ISAM2Params()
        params.setRelinearizeThreshold(config.relinearize_threshold)
        params.relinearizeSkip = config.relinearize_skip
        self._factorization = (
            Factorization.CHOLESKY if factorization is Factorization.AUTO else factorization
        )
        params.setFactorization(self._factorization.name)
        if config.adaptive_reorder_threshold is not None:
            params.enableAdaptiveReorder = True
            params.adaptiveReorderThreshold = config.adaptive_reorder_threshold
        return gtsam.ISAM2(params)

    # ------------------------------------------------------------------ update

    def update(self, graph: Any, values: Any, frame_index: int) -> None:
        """Add ``graph`` (new factors) and ``values`` (initial guesses of new variables).

        Args:
            graph: ``gtsam.NonlinearFactorGraph`` of the frame's new factors.
            values: ``gtsam.Values`` of the frame's new variables.
            frame_index: the frame's index, for the error message.

        Raises:
            EstimationError: iSAM2 failed (and, with AUTO factorisation, also the QR rebuild).
        """
        self._pose3_cache.clear()
        try:
            result = self._isam.update(graph, values)
        except RuntimeError as exc:
            if not (
                self._config.factorization is Factorization.AUTO
                and self._factorization is Factorization.CHOLESKY
            ):
                raise EstimationError(f"iSAM2 update at frame {frame_index} failed: {exc}") from exc
            self._rebuild_with_qr(graph, values, frame_index)
            return
        self._reorders += bool(result.getBatchReorderTriggered())
        self._all_factors.push_back(graph)

    def _rebuild_with_qr(self, graph: Any, values: Any, frame_index: int) -> None:
        """Every factor so far into a fresh QR iSAM2, at the current linearisation point."""
        point = gtsam.Values(self._isam.getLinearizationPoint())
        for key in values.keys():
            if point.exists(key):
                point.erase(key)
        point.insert(values)
        self._all_factors.push_back(graph)
        self._isam = self._new_isam(Factorization.QR)
        self._fallbacks += 1
        try:
            self._isam.update(self._all_factors, point)
        except RuntimeError as exc:
            raise EstimationError(
                f"iSAM2 update at frame {frame_index} failed, also with QR: {exc}"
            ) from exc

    # ------------------------------------------------------------------ reads

    def pose2(self, key: int) -> Any:
        """The current estimate of one Pose2 variable (a partial back-substitution)."""
        return self._isam.calculateEstimatePose2(key)

    def pose3(self, key: int) -> Any:
        """The current estimate of one Pose3 variable (read once per update: the delayed
        insertion asks for the viewpoints of every sighting of every pending track)."""
        pose = self._pose3_cache.get(key)
        if pose is None:
            pose = self._pose3_cache[key] = self._isam.calculateEstimatePose3(key)
        return pose

    def point2(self, key: int) -> np.ndarray:
        """The current estimate of one Point2 variable, (2,) [m]."""
        return self._isam.calculateEstimatePoint2(key)

    def exists(self, key: int) -> bool:
        """True when the variable ``key`` is in the graph."""
        return bool(self._isam.valueExists(key))

    def marginal_covariance(self, key: int) -> np.ndarray:
        """iSAM2's marginal covariance of one variable, in its tangent space."""
        return self._isam.marginalCovariance(key)

    def joint_marginal_covariance(self, keys: list[int]) -> np.ndarray:
        """iSAM2's joint marginal covariance of ``keys``, blocks in their order (tangent spaces).

        Computed from the Bayes tree for these variables only (``ISAM2.jointMarginalCovariance``),
        not from the whole map: the association's pose and candidate landmarks.
        """
        return self._isam.jointMarginalCovariance(list(keys)).fullMatrix()

    def estimate(self) -> Any:
        """The full current estimate as ``gtsam.Values`` (a full back-substitution)."""
        return self._isam.calculateEstimate()

    def factors(self) -> Any:
        """The ``gtsam.NonlinearFactorGraph`` of every factor so far (iSAM2's own copy)."""
        return self._isam.getFactorsUnsafe()

    def linearization_point(self) -> Any:
        """The ``gtsam.Values`` iSAM2 last linearised at."""
        return self._isam.getLinearizationPoint()

    # ------------------------------------------------------------------ bookkeeping

    @property
    def factorization(self) -> Factorization:
        """The factorisation in use (CHOLESKY or QR; QR after an AUTO fallback)."""
        return self._factorization

    @property
    def fallbacks(self) -> int:
        """Cholesky failures recovered by rebuilding with QR (AUTO factorisation)."""
        return self._fallbacks

    @property
    def batch_reorders(self) -> int:
        """Updates in which iSAM2 re-ordered and re-eliminated the whole Bayes tree."""
        return self._reorders

    @property
    def factor_count(self) -> int:
        """Factors in the graph."""
        return int(self._isam.getFactorsUnsafe().size())

    @property
    def tree_nonzeros(self) -> int:
        """Non-zeros of the Bayes tree's conditionals after the latest update (fill-in)."""
        return int(self._isam.treeNnz())
