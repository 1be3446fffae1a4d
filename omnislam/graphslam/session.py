"""One iSAM2 session: its parameters, the update (with the Cholesky -> QR fallback) and reads.

``ISAM2Session`` owns the ``gtsam.ISAM2`` object of a run and everything that is about iSAM2
rather than about the graph's content:

* the parameters (``SolverConfig``: relinearisation threshold and skip, factorisation,
  adaptive re-ordering; docs/design.md "iSAM2 settings");
* ``update``: one ``ISAM2.update`` per frame. With ``Factorization.AUTO`` a Cholesky failure
  ("Indeterminate linear system") re-adds every factor so far, linearised at iSAM2's current
  linearisation point (the new variables at their initial guesses), to a fresh QR-factorising
  iSAM2 that the rest of the run keeps using. For that rebuild the session keeps its own copy
  of every factor added;
* ``reeliminate_next``: variables the next update re-eliminates besides the new factors' (the
  association's candidate landmarks, moved to the top of the Bayes tree where their marginals
  are cheap to read);
* the bookkeeping of what iSAM2 did (fallbacks, whole-tree re-orderings, Bayes-tree fill-in);
* reads of the estimate: one variable (the newest pose each step; docs/design.md: reading everything
  every step cost as much as the update), the full estimate, marginal covariances.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from omnislam._optional import require
from omnislam.errors import EstimationError
from omnislam.graphslam.config import BatchConfig, Factorization, SolverConfig
from omnislam.graphslam.levenberg_marquardt import optimize_batch

gtsam = require("gtsam")


class ISAM2Session:
    """The iSAM2 optimiser of one run, started empty.

    Args:
        solver: the iSAM2 settings (``relinearize_threshold``, ``relinearize_skip``,
            ``factorization``, ``adaptive_reorder_threshold``).
    """

    def __init__(self, solver: SolverConfig) -> None:
        self._solver = solver
        self._factorization = Factorization.CHOLESKY
        self._isam = self._new_isam(solver.factorization)
        self._all_factors = gtsam.NonlinearFactorGraph()  # every factor so far (for a rebuild)
        self._fallbacks = 0
        self._reorders = 0
        self._pose3_cache: dict[int, Any] = {}  # Pose3 estimates read since the last update
        self._reeliminate: set[int] = set()  # keys the next update re-eliminates (re-orders)

    def _new_isam(self, factorization: Factorization) -> Any:
        """A fresh ``gtsam.ISAM2`` factorising with ``factorization`` (AUTO starts Cholesky)."""
        config = self._solver
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
            if self._reeliminate:
                params = gtsam.ISAM2UpdateParams()
                extra = gtsam.KeyList()
                for key in self._reeliminate:
                    extra.push_back(key)
                params.extraReelimKeys = extra
                self._reeliminate.clear()
                result = self._isam.update(graph, values, params)
            else:
                result = self._isam.update(graph, values)
        except RuntimeError as exc:
            if not (
                self._solver.factorization is Factorization.AUTO
                and self._factorization is Factorization.CHOLESKY
            ):
                raise EstimationError(f"iSAM2 update at frame {frame_index} failed: {exc}") from exc
            self._rebuild_with_qr(graph, values, frame_index)
            return
        self._reorders += bool(result.getBatchReorderTriggered())
        self._all_factors.push_back(graph)

    def reeliminate_next(self, keys: Any) -> None:
        """Have the next ``update`` re-eliminate ``keys`` (variables in the graph) with the new
        factors' variables: iSAM2 re-orders them into the top of the Bayes tree, so marginals
        that involve them are read near the root afterwards (``window_association.py``)."""
        self._reeliminate.update(int(k) for k in keys)

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


#: a landmark enters the fixed-lag smoother only with at least this many measurement factors
#: (bearings) there; its weak prior does not count (``FixedLagSession``)
MIN_ONLINE_MEASUREMENTS = 2


def _is_landmark(key: int) -> bool:
    """Omni sessions: poses are ``x`` symbols (Pose3), everything else a landmark (Point3)."""
    return gtsam.Symbol(key).chr() != ord("x")


def _underdetermined_landmarks(factors: list[Any], candidates: set[int]) -> set[int]:
    """The landmarks of ``candidates`` that ``factors`` hold by fewer than
    ``MIN_ONLINE_MEASUREMENTS`` measurement factors (factors on more than one variable)."""
    counts = {key: 0 for key in candidates if _is_landmark(key)}
    for factor in factors:
        keys = [int(k) for k in factor.keys()]
        if len(keys) > 1:
            for key in keys:
                if key in counts:
                    counts[key] += 1
    return {key for key, count in counts.items() if count < MIN_ONLINE_MEASUREMENTS}


class FixedLagSession:
    """A fixed-lag smoother for the online estimate, the whole graph for the final one.

    ``SolverConfig.online_lag_key_frames`` = L (omni bearings): every update goes to a
    ``gtsam.IncrementalFixedLagSmoother`` whose variables are those touched within the last L
    key frames (a pose by its own key frame, a landmark by the newest factor on it); older
    ones are marginalised, so each update re-eliminates a window of bounded size instead of
    the Bayes tree of the whole run (in a room the camera sees from everywhere, iSAM2's update
    grew from 2 to 70 ms over lab40's 158 key frames; the smoother's stays at 2-6 ms). A new
    factor on a variable the smoother has marginalised (a landmark seen again after the lag)
    does not enter the smoother, only the full graph (counted, ``online_factors_skipped``).
    GTSAM 4.3.0's smoother sometimes fails to marginalise ("Asking to remove variables from the
    variable index that are not unused", loop150 at key frame 202 with a lag of 10; known
    fixed-lag bugs upstream, borglab/gtsam#1890, #2474): the session then restarts the
    smoother on the window -- its variables at their newest estimates, every factor among them,
    and a prior at its estimate on the window's oldest pose for the marginalised past --
    (counted, ``online_restarts``). The window is that of the failed update after its
    marginalisation: a restart that still held the variables leaving the lag marginalised them
    in its own first update and could fail the same way (campus1500 seed 1, frame 23330).

    A restart leaves out of the window every landmark that fewer than
    ``MIN_ONLINE_MEASUREMENTS`` measurement factors hold there (counted,
    ``online_landmarks_held_out``): a track inserted long after its first sightings, whose
    viewpoints the smoother has already marginalised, enters with one bearing and its weak
    prior, which leave its depth at 1/sigma^2 = 0.01 against ~1e6 across the ray -- GTSAM's
    Cholesky reports that as an indeterminate system (lab40 seed 1, frame 2195), and a restart
    that kept the landmark met it again. Like a factor on a marginalised variable, its factors
    stay in the full graph only, its value is the final estimate's starting point.

    Reads during the run (the newest pose, the viewpoints of held-back sightings) are the
    smoother's estimate, or for marginalised variables their estimate when they left it.
    ``estimate()`` is **Levenberg-Marquardt over every factor of the run** from those
    estimates (``levenberg_marquardt.optimize_batch``), cached until the next update: the final
    map is the full smoothing solution, as with iSAM2, not the window's.

    Args:
        solver: ``online_lag_key_frames``, ``relinearize_threshold``, ``relinearize_skip``.
        final: the stopping rules of the final LM (``BatchConfig``).
        anchor_sigma_m: std per axis of the prior a restart puts on the window's oldest pose
            for the marginalised past (the planar prior's, ``PoseConfig.planar_sigma_m``).
    """

    def __init__(self, solver: SolverConfig, final: BatchConfig, anchor_sigma_m: float) -> None:
        if solver.online_lag_key_frames is None:
            raise ValueError("FixedLagSession needs online_lag_key_frames")
        self._solver = solver
        self._final_lm = final
        self._anchor_sigma_m = anchor_sigma_m
        self._smoother = self._new_smoother()
        self._all_factors = gtsam.NonlinearFactorGraph()
        self._last = gtsam.Values()  # every variable's newest estimate (frozen once marginalised)
        self._alive: set[int] = set()
        self._stamp: dict[int, float] = {}  # every variable's newest time (key-frame count)
        self._updates = 0
        self._skipped = 0
        self._restarts = 0
        self._held_out = 0
        self._final: Any = None  # LM solution, until the next update
        self._replace: dict[int, Any] = {}  # factors the final graph has instead (replace_final)
        self._extra: Any = None  # factors only the final graph has (replace_final) ...
        self._extra_values: Any = None  # ... and the starting points of their new variables
        self._warm: Any = None  # the previous final estimate, the next one's start (extras)
        self._final_graph: Any = None  # the whole graph with them
        self._marginals: Any = None  # gtsam.Marginals at it

    @property
    def _lag(self) -> float:
        """The smoother's lag in stamps (key-frame counts): variables older than the newest
        stamp minus this are marginalised."""
        return float(self._solver.online_lag_key_frames) - 0.5

    def _new_smoother(self) -> Any:
        params = gtsam.ISAM2Params()
        params.setRelinearizeThreshold(self._solver.relinearize_threshold)
        params.relinearizeSkip = self._solver.relinearize_skip
        return gtsam.IncrementalFixedLagSmoother(self._lag, params)

    def update(self, graph: Any, values: Any, frame_index: int) -> None:
        """Add the frame's factors and variables (see ``ISAM2Session.update``)."""
        self._final = self._marginals = self._final_graph = None
        self._all_factors.push_back(graph)
        new_keys = {int(k) for k in values.keys()}
        online = gtsam.NonlinearFactorGraph()
        stamps = gtsam.FixedLagSmootherKeyTimestampMap()
        now = float(self._updates)
        touched = set(new_keys)
        alive = self._alive
        for i in range(graph.size()):
            factor = graph.at(i)
            keys = [int(k) for k in factor.keys()]
            if all(k in alive or k in new_keys for k in keys):
                online.push_back(factor)
                touched.update(keys)
            else:
                self._skipped += 1
        for key in touched:
            stamps.insert((key, now))
            self._stamp[key] = now
        try:
            self._smoother.update(online, values, stamps)
        except (RuntimeError, ValueError, IndexError):
            self._restart(values, alive | new_keys, frame_index)
        self._updates += 1
        window = self._smoother.calculateEstimate()
        self._last.insert_or_assign(window)
        self._alive = {int(k) for k in window.keys()}

    def replace_final(
        self,
        replacements: dict[int, Any],
        token: object,
        extra: Any = None,
        extra_values: Any = None,
    ) -> None:
        """The final estimate's graph: the run's factors with those at the given indices (in the
        order added) replaced, and the factors ``extra`` (``gtsam.NonlinearFactorGraph``)
        added, whose variables not in the run start at ``extra_values`` (``gtsam.Values``).
        ``token`` names the replacements and extras: the same token as the last call keeps the
        cached estimate. With extras, LM starts from the previous final estimate where it has
        one (a re-solve at another odometry scale moves little). The online smoother is not
        touched."""
        if token == getattr(self, "_replace_token", None) and self._final_graph is not None:
            return
        self._replace_token = token
        self._replace = dict(replacements)
        self._warm = self._final if extra is not None else None
        self._extra = extra
        self._extra_values = extra_values
        self._final = self._marginals = self._final_graph = None

    def final_factors(self) -> Any:
        """The whole graph the final estimate optimises (``replace_final``)."""
        if self._final_graph is None:
            if not self._replace and self._extra is None:
                self._final_graph = self._all_factors
            else:
                graph = gtsam.NonlinearFactorGraph(self._all_factors)
                for index, factor in self._replace.items():
                    graph.replace(index, factor)
                if self._extra is not None:
                    graph.push_back(self._extra)
                self._final_graph = graph
        return self._final_graph

    def _restart(self, values: Any, window: set[int], frame_index: int) -> None:
        """A fresh smoother on ``window`` (see the class docstring)."""
        self._restarts += 1
        self._smoother = self._new_smoother()
        # the variables this update would marginalise stay out: marginalising them in the
        # restart's own update can fail the same way (campus1500 seed 1, frame 23330)
        newest = max(self._stamp[key] for key in window)
        horizon = newest - self._lag
        window = {key for key in window if self._stamp[key] >= horizon}
        inside = [
            self._all_factors.at(i) for i in range(self._all_factors.size())
            if all(int(k) in window for k in self._all_factors.at(i).keys())
        ]
        held_out = _underdetermined_landmarks(inside, window)
        self._held_out += len(held_out)
        window = window - held_out
        for key in held_out:  # kept for the final estimate
            if not self._last.exists(key):
                self._last.insert(key, values.atPoint3(key))
        factors = gtsam.NonlinearFactorGraph()
        for factor in inside:
            if held_out.isdisjoint(int(k) for k in factor.keys()):
                factors.push_back(factor)
        initial = gtsam.Values()
        stamps = gtsam.FixedLagSmootherKeyTimestampMap()
        poses = []
        for key in window:
            source = values if values.exists(key) else self._last
            stamps.insert((key, self._stamp[key]))
            if gtsam.Symbol(key).chr() == ord("x"):  # omni: Pose3 viewpoints, Point3 landmarks
                initial.insert(key, source.atPose3(key))
                poses.append(key)
            else:
                initial.insert(key, source.atPoint3(key))
        oldest = min(poses, key=lambda key: (self._stamp[key], gtsam.Symbol(key).index()))
        anchor = gtsam.noiseModel.Isotropic.Sigma(6, self._anchor_sigma_m)
        factors.push_back(gtsam.PriorFactorPose3(oldest, initial.atPose3(oldest), anchor))
        try:
            self._smoother.update(factors, initial, stamps)
        except (RuntimeError, ValueError, IndexError) as exc:
            raise EstimationError(
                f"fixed-lag update at frame {frame_index} failed, also restarted: {exc}"
            ) from exc

    # ------------------------------------------------------------------ reads

    def pose2(self, key: int) -> Any:
        """The newest estimate of one Pose2 variable."""
        return self._last.atPose2(key)

    def pose3(self, key: int) -> Any:
        """The newest estimate of one Pose3 variable."""
        return self._last.atPose3(key)

    def point2(self, key: int) -> np.ndarray:
        """The newest estimate of one Point2 variable, (2,) [m]."""
        return self._last.atPoint2(key)

    def exists(self, key: int) -> bool:
        """True when the variable ``key`` is in the graph."""
        return bool(self._last.exists(key))

    def marginal_covariance(self, key: int) -> np.ndarray:
        """The marginal covariance of one variable in the full graph, at ``estimate()``."""
        if self._marginals is None:
            self._marginals = gtsam.Marginals(self.final_factors(), self.estimate())
        return self._marginals.marginalCovariance(key)

    def estimate(self) -> Any:
        """LM over every factor of the run, from the newest estimates (cached)."""
        if self._final is None:
            start = self._last
            if self._extra is not None:
                start = gtsam.Values(self._last)
                if self._extra_values is not None:
                    start.insert_or_assign(self._extra_values)
                if self._warm is not None:
                    start.update(self._warm)
                    self._warm = None
            self._final = optimize_batch(
                self.final_factors(),
                start,
                self._final_lm.max_iterations,
                self._final_lm.relative_error_tol,
            ).values
        return self._final

    def factors(self) -> Any:
        """Every factor of the run (the full graph the final estimate optimises)."""
        return self.final_factors()

    def linearization_point(self) -> Any:
        """The newest estimates (``gtsam.Values``)."""
        return self._last

    # ------------------------------------------------------------------ bookkeeping

    @property
    def factorization(self) -> Factorization:
        """Cholesky (the smoother's iSAM2)."""
        return Factorization.CHOLESKY

    @property
    def fallbacks(self) -> int:
        """Always 0 (no QR rebuild)."""
        return 0

    @property
    def batch_reorders(self) -> int:
        """Always 0 (not tracked for the smoother)."""
        return 0

    @property
    def factor_count(self) -> int:
        """Factors in the full graph."""
        return int(self._all_factors.size())

    @property
    def tree_nonzeros(self) -> int:
        """Non-zeros of the smoother's Bayes tree (the window's fill-in)."""
        return int(self._smoother.getISAM2().treeNnz())

    @property
    def online_restarts(self) -> int:
        """Smoother restarts after a failed marginalisation (class docstring)."""
        return self._restarts

    @property
    def online_landmarks_held_out(self) -> int:
        """Landmarks left out of the smoother, too weakly held there (class docstring)."""
        return self._held_out

    @property
    def online_factors_skipped(self) -> int:
        """Factors on marginalised variables, in the full graph but not in the smoother."""
        return self._skipped
