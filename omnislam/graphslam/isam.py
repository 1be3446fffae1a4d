"""The incremental GTSAM back end: one iSAM2 update per frame (estimator ``graphslam``).

Each ``step``:

1. adds the new pose with the initial guess ``wTr_{k-1} (+) delta_k`` and an odometry
   between-factor whose covariance is the motion model's (``OdometryMotionModel.covariance``,
   thesis eq. 4.41) or fixed dataset sigmas; OMNI mode adds the planar prior (z, roll, pitch);
2. turns the frame's sightings into factors (``factors.py``): range-bearing landmarks enter on
   their first sighting; bearing-only tracks are held back until they can be triangulated
   (``landmark_init.py``) and enter with a weak prior at that point (see
   ``GraphSLAMConfig.landmark_prior_sigma_m``); unlabelled range-bearing sightings are
   associated first (``association.py``);
3. runs one ``ISAM2.update`` and reads back **only the newest pose**
   (``calculateEstimatePose2/3``); the full estimate is computed only in ``estimate()``
   (DESIGN.md: reading everything every step cost as much as the update).

Landmark ids in the estimate are the sightings' ids (track ids, dataset ids); landmarks created
by the association get ids from ``CREATED_ID_BASE`` upwards so they never collide with given
ids.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from omnislam._optional import require
from omnislam.core.measurement import RangeBearing2D
from omnislam.core.motion import OdometryMotionModel
from omnislam.core.se import se2_compose, se2_from_se3, se2_rotate_vectors, se3_from_se2
from omnislam.core.types import (
    UNKNOWN_ID,
    Bearings,
    Estimate,
    FrameInput,
    RangeBearing,
    Trajectory,
    VerticalLines,
)
from omnislam.errors import EstimationError
from omnislam.graphslam import factors as fx
from omnislam.graphslam.association import (
    AMBIGUOUS,
    NEW_LANDMARK,
    Gates,
    associate,
    mahalanobis2,
    sighting_points,
)
from omnislam.graphslam.config import Factorization, GraphSLAMConfig, Mode
from omnislam.graphslam.landmark_init import (
    ConsistentInsertion,
    DelayedInsertion,
    DelayedInsertionStats,
)
from omnislam.graphslam.tentative import TentativeLandmarks

gtsam = require("gtsam")

#: first id given to a landmark created by the association of unlabelled sightings
CREATED_ID_BASE = 1_000_000_000

_RANGE_BEARING = RangeBearing2D()

#: smallest angle between a measured bearing and its mapped landmark that counts as an outlier
_BEARING_GATE_RAD = np.radians(20.0)


@dataclass(frozen=True, slots=True)
class GraphSLAMInfo:
    """What the back end has done so far (counts, for reports and tests).

    Attributes:
        mode: the resolved mode (AUTO while no sightings have been seen).
        frames: frames consumed.
        landmarks: landmarks in the graph.
        factors: factors in the graph.
        tracks_inserted: bearing-only tracks triangulated and inserted.
        tracks_pending: bearing-only tracks held back so far (never qualified).
        sightings_pending: held-back sightings of those tracks.
        triangulations_rejected: insertion attempts rejected (point behind a ray, parallel rays).
        landmarks_created: landmarks started by the association of unlabelled sightings.
        sightings_associated: unlabelled sightings matched to a mapped landmark.
        sightings_ambiguous: unlabelled sightings dropped between the two gates.
        sightings_ignored: sightings the mode cannot use (unknown ids of bearing-only tracks,
            a modality other than the mode's).
        sightings_gated: bearings of mapped landmarks pointing away from them (outliers of
            the front end's association), not added to the graph.
        factorization_fallbacks: Cholesky failures recovered by rebuilding with QR (AUTO).
        batch_reorders: updates in which iSAM2 re-ordered and re-eliminated the whole Bayes
            tree (when most variables were affected, or by ``adaptive_reorder_threshold``).
        tree_nonzeros: non-zeros of the Bayes tree's conditionals after the latest update
            (its fill-in).
        tentative_committed: landmarks started by the association that were re-observed and
            entered the graph (``GraphSLAMConfig.association_min_sightings`` > 1).
        tentative_dropped: such landmarks not re-observed in time, dropped with their
            sightings (clutter).
        tentative_sightings_dropped: sightings dropped with them.
        tentative_pending: such landmarks still waiting.
    """

    mode: Mode
    frames: int
    landmarks: int
    factors: int
    tracks_inserted: int
    tracks_pending: int
    sightings_pending: int
    triangulations_rejected: int
    landmarks_created: int
    sightings_associated: int
    sightings_ambiguous: int
    sightings_ignored: int
    sightings_gated: int = 0
    factorization_fallbacks: int = 0
    batch_reorders: int = 0
    tree_nonzeros: int = 0
    tentative_committed: int = 0
    tentative_dropped: int = 0
    tentative_sightings_dropped: int = 0
    tentative_pending: int = 0


def resolve_mode(frame: FrameInput) -> Mode:
    """The mode a frame's content implies (AUTO when it has no sightings)."""
    if frame.bearings is not None and len(frame.bearings):
        return Mode.OMNI
    if frame.range_bearing is not None and len(frame.range_bearing):
        return Mode.RANGE_BEARING_2D
    if frame.vertical_lines is not None and len(frame.vertical_lines):
        return Mode.BEARING_2D
    return Mode.AUTO


class GraphSLAM:
    """iSAM2 SLAM over Pose2/Pose3 variables with built-in GTSAM factors.

    Args:
        config: settings (``GraphSLAMConfig``); None uses the defaults.
        initial_pose: (3,) pose [x, y, theta] of the first frame in the world [m, m, rad].

    Conforms to ``omnislam.core.types.Estimator``.
    """

    name = "graphslam"

    def __init__(
        self,
        config: GraphSLAMConfig | None = None,
        initial_pose: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
    ) -> None:
        self.config = config if config is not None else GraphSLAMConfig()
        self._initial_pose = np.asarray(initial_pose, dtype=float).reshape(3)
        self._mode = self.config.mode
        self._motion = OdometryMotionModel(self.config.motion_noise)
        self._noise = fx.NoiseModels(self.config.robust_kernel, self.config.kernel_threshold)
        self._delayed = DelayedInsertion(
            self.config.min_sightings, np.deg2rad(self.config.min_parallax_deg)
        )
        self._gates = Gates.from_probabilities(
            self.config.association_gate_probability, self.config.new_landmark_probability
        )
        self._consistent = ConsistentInsertion(
            self.config.min_consistent_sightings, self._gates.match
        )
        self._tentative = (
            TentativeLandmarks(
                self.config.association_min_sightings, self.config.association_window_frames
            )
            if self.config.association_min_sightings > 1
            else None
        )
        self._fixed_odometry_cov = (
            None
            if self.config.odometry_sigmas is None
            else fx.condition_odometry_covariance(
                np.diag(np.square(self.config.odometry_sigmas)), self.config.odometry_min_sigma_m
            )
        )
        self._isam: Any = None
        self._buffer: list[FrameInput] = []
        self._stamps: list[float] = []
        self._latest = self._initial_pose.copy()  # newest pose estimate [x, y, theta]
        self._latest_pose2 = fx.pose2(self._initial_pose)  # the same as a gtsam.Pose2
        self._guess = self._initial_pose.copy()  # initial guess of the frame being added
        self._odometry_noise = None
        if self._fixed_odometry_cov is not None:
            sigmas = np.sqrt(np.diag(self._fixed_odometry_cov))
            self._odometry_noise = gtsam.noiseModel.Diagonal.Sigmas(sigmas)
        self._frames = 0
        # landmarks in the graph: id -> row of the cached positions (used by the association)
        self._landmark_row: dict[int, int] = {}
        self._landmark_ids: list[int] = []
        self._landmarks_xy = np.zeros((64, 2))
        self._next_created_id = CREATED_ID_BASE
        self._created = self._associated = self._ambiguous = self._ignored = 0
        self._gated = 0  # bearings of mapped landmarks rejected by the outlier gate
        self._fallbacks = 0  # Cholesky failures recovered by rebuilding with QR
        self._reorders = 0  # updates that re-ordered the whole Bayes tree
        self._factorization = Factorization.CHOLESKY
        self._all_factors = gtsam.NonlinearFactorGraph()  # every factor so far (for a rebuild)
        self._landmark_point_w: dict[int, np.ndarray] = {}  # 3-D landmarks at insertion
        self._landmark_priors: dict[int, Any] = {}  # weak landmark prior models by dimension

    # ------------------------------------------------------------------ protocol

    def step(self, frame: FrameInput) -> None:
        """Add one frame: its odometry factor, its sightings, one iSAM2 update."""
        if self._isam is None:
            if self._mode is Mode.AUTO:
                self._mode = resolve_mode(frame)
                if self._mode is Mode.AUTO:
                    self._buffer.append(frame)
                    return
            self._start()
            buffered, self._buffer = self._buffer, []
            for old in buffered:
                self._add_frame(old)
        self._add_frame(frame)

    def estimate(self) -> Estimate:
        """The current iSAM2 estimate: all poses, all landmarks, covariances if configured."""
        if self._isam is None:
            return self._dead_reckoning()
        covariance = self._isam.marginalCovariance if self.config.compute_covariances else None
        return self._estimate_from(self._isam.calculateEstimate(), covariance)

    # ------------------------------------------------------------------ inspection

    @property
    def mode(self) -> Mode:
        """The resolved mode (AUTO until the first sightings when configured AUTO)."""
        return self._mode

    def info(self) -> GraphSLAMInfo:
        """Counts of what the back end did (see ``GraphSLAMInfo``)."""
        bearing, ranged = self._delayed.stats(), self._consistent.stats()
        tentative = self._tentative.stats() if self._tentative is not None else None
        delayed = DelayedInsertionStats(
            *(a + b for a, b in zip(_as_tuple(bearing), _as_tuple(ranged), strict=True))
        )
        return GraphSLAMInfo(
            mode=self._mode,
            frames=self._frames + len(self._buffer),
            landmarks=len(self._landmark_ids),
            factors=0 if self._isam is None else int(self._isam.getFactorsUnsafe().size()),
            tracks_inserted=delayed.tracks_inserted,
            tracks_pending=delayed.tracks_pending,
            sightings_pending=delayed.sightings_pending,
            triangulations_rejected=delayed.triangulations_rejected,
            landmarks_created=self._created,
            sightings_associated=self._associated,
            sightings_ambiguous=self._ambiguous,
            sightings_ignored=self._ignored,
            sightings_gated=self._gated,
            factorization_fallbacks=self._fallbacks,
            batch_reorders=self._reorders,
            tree_nonzeros=0 if self._isam is None else int(self._isam.treeNnz()),
            tentative_committed=tentative.committed if tentative else 0,
            tentative_dropped=tentative.dropped if tentative else 0,
            tentative_sightings_dropped=tentative.sightings_dropped if tentative else 0,
            tentative_pending=tentative.pending if tentative else 0,
        )

    def factor_graph(self) -> Any:
        """The ``gtsam.NonlinearFactorGraph`` of every factor added so far (iSAM2's own copy)."""
        self._require_started()
        return self._isam.getFactorsUnsafe()

    def values(self) -> Any:
        """The current iSAM2 estimate as ``gtsam.Values`` (a full back-substitution)."""
        self._require_started()
        return self._isam.calculateEstimate()

    def newest_pose(self) -> np.ndarray:
        """(3,) newest pose estimate [x, y, theta] of the robot frame (read every step)."""
        return self._latest.copy()

    # ------------------------------------------------------------------ graph building

    def _start(self, factorization: Factorization | None = None) -> None:
        params = gtsam.ISAM2Params()
        params.setRelinearizeThreshold(self.config.relinearize_threshold)
        params.relinearizeSkip = self.config.relinearize_skip
        if factorization is None:
            factorization = self.config.factorization
        self._factorization = (
            Factorization.CHOLESKY if factorization is Factorization.AUTO else factorization
        )
        params.setFactorization(self._factorization.name)
        if self.config.adaptive_reorder_threshold is not None:
            params.enableAdaptiveReorder = True
            params.adaptiveReorderThreshold = self.config.adaptive_reorder_threshold
        self._isam = gtsam.ISAM2(params)

    def _update(self, graph: Any, values: Any, frame_index: int) -> None:
        """One iSAM2 update; with AUTO factorisation, a Cholesky failure rebuilds with QR.

        The rebuild re-adds every factor so far, linearised at iSAM2's current linearisation
        point (the new variables at their initial guesses), to a fresh QR-factorising iSAM2,
        which the rest of the run keeps using.
        """
        try:
            result = self._isam.update(graph, values)
        except RuntimeError as exc:
            if not (
                self.config.factorization is Factorization.AUTO
                and self._factorization is Factorization.CHOLESKY
            ):
                raise EstimationError(f"iSAM2 update at frame {frame_index} failed: {exc}") from exc
            point = gtsam.Values(self._isam.getLinearizationPoint())
            for key in values.keys():
                if point.exists(key):
                    point.erase(key)
            point.insert(values)
            self._all_factors.push_back(graph)
            self._start(Factorization.QR)
            self._fallbacks += 1
            try:
                self._isam.update(self._all_factors, point)
            except RuntimeError as exc2:
                raise EstimationError(
                    f"iSAM2 update at frame {frame_index} failed, also with QR: {exc2}"
                ) from exc2
            return
        self._reorders += bool(result.getBatchReorderTriggered())
        self._all_factors.push_back(graph)

    def _require_started(self) -> None:
        if self._isam is None:
            raise EstimationError("the graph is empty: no frame with sightings yet")

    def _add_frame(self, frame: FrameInput) -> None:
        k = self._frames
        graph = gtsam.NonlinearFactorGraph()
        values = gtsam.Values()
        omni = self._mode is Mode.OMNI
        height = self.config.sensor_height_m
        if k == 0:
            self._guess = self._initial_pose.copy()
            guess2 = fx.pose2(self._guess)
            prior = gtsam.noiseModel.Diagonal.Sigmas(np.asarray(self.config.prior_sigmas))
            if omni:
                sigmas = np.array([*self.config.prior_sigmas, 0.0, 0.0, 0.0])
                sigmas[fx.POSE3_PLANAR_INDICES] = self.config.prior_sigmas
                sigmas[fx.POSE3_OFF_PLANE_INDICES] = [
                    self.config.planar_sigma_rad,
                    self.config.planar_sigma_rad,
                    self.config.planar_sigma_m,
                ]
                prior = gtsam.noiseModel.Diagonal.Sigmas(sigmas)
                graph.add(
                    gtsam.PriorFactorPose3(
                        fx.pose_key(0), fx.pose3_planar(self._guess, height), prior
                    )
                )
            else:
                graph.add(gtsam.PriorFactorPose2(fx.pose_key(0), guess2, prior))
        else:
            delta = frame.odometry.delta
            odometry = fx.pose2(delta)
            guess2 = self._latest_pose2.compose(odometry)
            self._guess = fx.planar_from_pose2(guess2)
            if self._fixed_odometry_cov is not None:
                cov = self._fixed_odometry_cov
            elif frame.odometry.covariance is not None:  # the data states its own noise
                cov = frame.odometry.covariance
            else:
                cov = self._motion.covariance(delta)
            # a factor far more precise than the poses' absolute uncertainty makes iSAM2's
            # Cholesky reject the clique (see GraphSLAMConfig.odometry_min_sigma_m)
            cov = fx.condition_odometry_covariance(cov, self.config.odometry_min_sigma_m)
            if omni:
                graph.add(
                    fx.between_pose3(
                        k - 1,
                        k,
                        delta,
                        cov,
                        self.config.planar_sigma_m,
                        self.config.planar_sigma_rad,
                    )
                )
                graph.add(
                    gtsam.PriorFactorPose3(
                        fx.pose_key(k),
                        fx.pose3_planar(self._guess, height),
                        fx.planar_prior_noise(
                            self.config.planar_sigma_m, self.config.planar_sigma_rad
                        ),
                    )
                )
            elif self._odometry_noise is not None:  # fixed sigmas: one shared noise model
                graph.add(
                    gtsam.BetweenFactorPose2(
                        fx.pose_key(k - 1), fx.pose_key(k), odometry, self._odometry_noise
                    )
                )
            else:
                graph.add(fx.between_pose2(k - 1, k, delta, cov))
        if omni:
            values.insert(fx.pose_key(k), fx.pose3_planar(self._guess, height))
        else:
            values.insert(fx.pose_key(k), guess2)

        self._add_sightings(k, frame, graph, values)
        self._update(graph, values, frame.index)
        if omni:
            self._latest = fx.planar_from_pose3(self._isam.calculateEstimatePose3(fx.pose_key(k)))
            self._latest_pose2 = fx.pose2(self._latest)
        else:
            self._latest_pose2 = self._isam.calculateEstimatePose2(fx.pose_key(k))
            self._latest = fx.planar_from_pose2(self._latest_pose2)
        self._stamps.append(frame.stamp_s)
        self._frames += 1

    def _add_sightings(self, k: int, frame: FrameInput, graph: Any, values: Any) -> None:
        mode = self._mode
        used = {
            Mode.OMNI: frame.bearings,
            Mode.RANGE_BEARING_2D: frame.range_bearing,
            Mode.BEARING_2D: frame.vertical_lines,
        }[mode]
        for other in (frame.bearings, frame.range_bearing, frame.vertical_lines):
            if other is not None and other is not used:
                self._ignored += len(other)
        if used is None or len(used) == 0:
            return
        if mode is Mode.OMNI:
            self._add_bearings_3d(k, used, graph, values)
        elif mode is Mode.RANGE_BEARING_2D:
            self._add_range_bearing(k, used, graph, values)
        else:
            self._add_bearings_2d(k, used, graph, values)

    def _register_landmark(self, landmark_id: int, xy: np.ndarray) -> None:
        row = len(self._landmark_ids)
        if row == len(self._landmarks_xy):
            grown = np.zeros((2 * row, 2))
            grown[:row] = self._landmarks_xy
            self._landmarks_xy = grown
        self._landmarks_xy[row] = xy[:2]
        self._landmark_row[landmark_id] = row
        self._landmark_ids.append(landmark_id)

    # ---- bearing-only modes (delayed insertion)

    def _add_bearings_3d(self, k: int, bearings: Bearings, graph: Any, values: Any) -> None:
        touched: list[int] = []
        for lid, ray, sigma in zip(
            bearings.landmark_ids.tolist(),
            bearings.unit_vectors_r,
            bearings.sigmas_rad.tolist(),
            strict=True,
        ):
            if lid == UNKNOWN_ID:
                self._ignored += 1
                continue
            factor = fx.bearing_3d(k, lid, ray, self._noise.isotropic(2, sigma))
            if lid in self._landmark_row:
                if self._bearing_outlier(lid, ray, sigma):
                    self._gated += 1
                    continue
                graph.add(factor)
            else:
                self._delayed.hold(lid, k, ray, factor, sigma)
                touched.append(lid)
        self._insert_ready(k, touched, graph, values, point3=True)

    def _bearing_outlier(self, lid: int, ray_r: np.ndarray, sigma_rad: float) -> bool:
        """True when a bearing of a mapped landmark points away from the landmark.

        The angle between the measured ray and the direction from the guessed viewpoint to the
        landmark (its position when it was inserted) is gated at max(5 sigma, 20 deg): a wrong
        front-end association can point anywhere, and a Unit3 bearing error near 180 deg has a
        degenerate Jacobian that makes iSAM2 throw "Indeterminate linear system".
        """
        point = self._landmark_point_w.get(lid)
        if point is None:
            return False
        ray_w = se2_rotate_vectors(self._guess, ray_r)
        to_point = point - np.array([self._guess[0], self._guess[1], self.config.sensor_height_m])
        cosine = ray_w @ to_point / max(np.linalg.norm(to_point), 1e-12)
        return bool(cosine < np.cos(max(5.0 * sigma_rad, _BEARING_GATE_RAD)))

    def _add_bearings_2d(self, k: int, lines: VerticalLines, graph: Any, values: Any) -> None:
        touched: list[int] = []
        for lid, bearing, sigma in zip(
            lines.landmark_ids.tolist(),
            lines.bearings_rad.tolist(),
            lines.sigma_bearing_rad.tolist(),
            strict=True,
        ):
            if lid == UNKNOWN_ID:
                self._ignored += 1
                continue
            factor = fx.bearing_2d(k, lid, bearing, self._noise.isotropic(1, sigma))
            if lid in self._landmark_row:
                graph.add(factor)
            else:
                ray = np.array([np.cos(bearing), np.sin(bearing), 0.0])
                self._delayed.hold(lid, k, ray, factor)
                touched.append(lid)
        self._insert_ready(k, touched, graph, values, point3=False)

    def _insert_ready(
        self, k: int, touched: list[int], graph: Any, values: Any, point3: bool
    ) -> None:
        for lid in dict.fromkeys(touched):
            insertion = self._delayed.try_insert(lid, self._viewpoint_callback(k))
            if insertion is None:
                continue
            key = fx.landmark_key(lid)
            sigma = self.config.landmark_prior_sigma_m
            if point3:
                point = gtsam.Point3(insertion.point_w)
                values.insert(key, point)
                self._landmark_point_w[lid] = np.asarray(insertion.point_w, dtype=float)
                if sigma is not None:  # see GraphSLAMConfig.landmark_prior_sigma_m
                    graph.add(gtsam.PriorFactorPoint3(key, point, self._landmark_prior(3)))
            else:
                point = gtsam.Point2(insertion.point_w[:2])
                values.insert(key, point)
                if sigma is not None:
                    graph.add(gtsam.PriorFactorPoint2(key, point, self._landmark_prior(2)))
            for factor in insertion.factors:
                graph.add(factor)
            self._register_landmark(lid, insertion.point_w)

    def _landmark_prior(self, dim: int) -> Any:
        """The weak prior's noise model (never robust: it is not a measurement)."""
        model = self._landmark_priors.get(dim)
        if model is None:
            sigma = float(self.config.landmark_prior_sigma_m or 0.0)
            model = self._landmark_priors[dim] = gtsam.noiseModel.Isotropic.Sigma(dim, sigma)
        return model

    def _viewpoint_callback(self, k: int) -> Callable[[int], tuple[np.ndarray, np.ndarray]]:
        """Sensor viewpoint (origin_w, wRs) of a frame: the guess for frame k, iSAM2 before."""
        height = self.config.sensor_height_m if self._mode is Mode.OMNI else 0.0

        def viewpoint(frame: int) -> tuple[np.ndarray, np.ndarray]:
            if frame == k:
                x, y, theta = self._guess
            elif self._mode is Mode.OMNI:
                wTs = self._isam.calculateEstimatePose3(fx.pose_key(frame))
                return np.asarray(wTs.translation()), wTs.rotation().matrix()
            else:
                x, y, theta = fx.planar_from_pose2(
                    self._isam.calculateEstimatePose2(fx.pose_key(frame))
                )
            c, s = np.cos(theta), np.sin(theta)
            return (
                np.array([x, y, height]),
                np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]),
            )

        return viewpoint

    # ---- range-bearing mode

    def _add_range_bearing(self, k: int, sightings: RangeBearing, graph: Any, values: Any) -> None:
        ids = sightings.landmark_ids.copy()
        unknown = ids == UNKNOWN_ID
        created: set[int] = set()
        points_w = covariances_w = np.zeros((0, 2))
        if unknown.any():
            ids[unknown], points_w, covariances_w = self._associate(
                np.flatnonzero(unknown), sightings
            )
            created = set(ids[unknown].tolist())
        unknown_row = np.cumsum(unknown) - 1  # row of each unlabelled sighting in points_w
        delay = self.config.min_consistent_sightings > 1
        for i, (lid, r, b, s_r, s_b) in enumerate(
            zip(
                ids.tolist(),
                sightings.ranges_m.tolist(),
                sightings.bearings_rad.tolist(),
                sightings.sigma_range_m.tolist(),
                sightings.sigma_bearing_rad.tolist(),
                strict=True,
            )
        ):
            if lid == UNKNOWN_ID:  # ambiguous
                continue
            factor = fx.bearing_range_2d(k, lid, b, r, self._noise.diagonal(s_b, s_r))
            if lid in self._landmark_row:
                graph.add(factor)
                continue
            if lid in created and self._tentative is not None:  # unlabelled: wait for more
                row = unknown_row[i]
                commitment = self._tentative.add(
                    lid, k, points_w[row], covariances_w[row], factor
                )
                if commitment is not None:
                    values.insert(fx.landmark_key(lid), gtsam.Point2(commitment.point_w))
                    self._register_landmark(lid, commitment.point_w)
                    for held in commitment.factors:
                        graph.add(held)
                continue
            if not delay or lid in created:
                xy = _RANGE_BEARING.inverse(self._guess, np.array([r, b]))[0]
                values.insert(fx.landmark_key(lid), gtsam.Point2(xy))
                self._register_landmark(lid, xy)
                graph.add(factor)
                continue
            points, covs = sighting_points(self._guess, *map(np.atleast_1d, (r, b, s_r, s_b)))
            self._consistent.hold(lid, points[0], covs[0], factor)
            insertion = self._consistent.try_insert(lid)
            if insertion is not None:
                values.insert(fx.landmark_key(lid), gtsam.Point2(insertion.point_w))
                self._register_landmark(lid, insertion.point_w)
                for held in insertion.factors:
                    graph.add(held)

    def _associate(
        self, rows: np.ndarray, sightings: RangeBearing
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Ids for the unlabelled sightings ``rows``: matched, new or UNKNOWN_ID (ambiguous).

        Candidates are the mapped landmarks near the robot and, with the tentative stage, the
        tentative landmarks. A new id is registered in the graph by the caller (at once, or
        through the tentative stage).

        Returns:
            (ids (K,), the sightings' world points (K, 2) and covariances (K, 2, 2)).
        """
        pose_cov = None
        if self.config.association_pose_covariance and self._frames > 0:
            # the newest estimated pose (frame k-1) is in the root clique: a cheap marginal
            previous = self._isam.marginalCovariance(fx.pose_key(self._frames - 1))
            pose_cov = _world_pose_covariance(previous, self._latest[2], omni=False)
        points, covs = sighting_points(
            self._guess,
            sightings.ranges_m[rows],
            sightings.bearings_rad[rows],
            sightings.sigma_range_m[rows],
            sightings.sigma_bearing_rad[rows],
            pose_cov,
        )
        m = len(self._landmark_ids)
        cached = self._landmarks_xy[:m]
        # candidates: landmarks that could fall inside the outer gate (conservative radius)
        spread = self.config.association_landmark_sigma_m + np.sqrt(
            np.linalg.eigvalsh(covs)[:, -1].max()
        )
        radius = sightings.ranges_m[rows].max() + 3.0 * np.sqrt(self._gates.new_landmark) * spread
        near = np.flatnonzero(np.hypot(*(cached - self._guess[:2]).T) <= radius)
        for row in near.tolist():  # refresh only these positions from iSAM2
            key = fx.landmark_key(self._landmark_ids[row])
            if self._isam.valueExists(key):
                cached[row] = self._isam.calculateEstimatePoint2(key)
        candidate_ids = [self._landmark_ids[row] for row in near.tolist()]
        candidates_xy = cached[near]
        candidate_covs = self._landmark_covariances(near, points, covs)
        if self._tentative is not None:
            self._tentative.expire(self._frames)
            if len(self._tentative):
                tentative_ids, tentative_xy, tentative_covs = self._tentative.candidates()
                candidate_ids += tentative_ids.tolist()
                candidates_xy = np.concatenate([candidates_xy, tentative_xy])
                candidate_covs = np.concatenate([candidate_covs, tentative_covs])
        indices, _ = associate(
            points,
            covs,
            candidates_xy,
            self.config.association_landmark_sigma_m,
            self._gates,
            candidate_covs,
        )
        out = np.full(len(rows), UNKNOWN_ID, dtype=np.int64)
        for i, index in enumerate(indices.tolist()):
            if index >= 0:
                out[i] = candidate_ids[index]
                self._associated += 1
            elif index == NEW_LANDMARK:
                out[i] = self._next_created_id
                self._next_created_id += 1
                self._created += 1
            elif index == AMBIGUOUS:
                self._ambiguous += 1
        return out, points, covs

    def _landmark_covariances(
        self, rows: np.ndarray, points_w: np.ndarray, point_covariances: np.ndarray
    ) -> np.ndarray:
        """Position covariances (M, 2, 2) of the mapped landmarks ``rows`` for the gate.

        ``sigma_l^2 I`` (``association_landmark_sigma_m``), or with
        ``association_landmark_marginals`` the iSAM2 marginal of each landmark whose distance
        with ``sigma_l`` is within 4x the new-landmark gate of some sighting (a marginal costs a
        back-substitution; the far ones could not match anyway unless their marginal were huge).
        """
        sigma2 = self.config.association_landmark_sigma_m**2
        covariances = np.tile(sigma2 * np.eye(2), (len(rows), 1, 1))
        if not self.config.association_landmark_marginals or not len(rows):
            return covariances
        d2 = mahalanobis2(points_w, point_covariances, self._landmarks_xy[rows], covariances)
        for j in np.flatnonzero(d2.min(axis=0) <= 4.0 * self._gates.new_landmark).tolist():
            key = fx.landmark_key(self._landmark_ids[int(rows[j])])
            if self._isam.valueExists(key):
                covariances[j] = self._isam.marginalCovariance(key)
        return covariances

    # ------------------------------------------------------------------ estimate

    def _dead_reckoning(self) -> Estimate:
        poses = [self._initial_pose]
        for frame in self._buffer[1:]:
            poses.append(se2_compose(poses[-1], frame.odometry.delta))
        poses = poses[: len(self._buffer)]
        stamps = [frame.stamp_s for frame in self._buffer]
        return Estimate(Trajectory.from_se2(np.asarray(stamps), np.asarray(poses).reshape(-1, 3)))

    def _estimate_from(
        self, values: Any, marginal_covariance: Callable[[int], np.ndarray] | None
    ) -> Estimate:
        """Estimate record from ``values``; covariances from ``marginal_covariance(key)``."""
        omni = self._mode is Mode.OMNI
        n = self._frames
        if omni:
            rows = gtsam.utilities.extractPose3(values)
            wTs = np.tile(np.eye(4), (n, 1, 1))
            wTs[:, :3, :3] = rows[:, :9].reshape(n, 3, 3)
            wTs[:, :3, 3] = rows[:, 9:]
            # the variables are the sensor viewpoints wTs; the robot frame is sTr = (I, -h e_z)
            sTr = np.eye(4)
            sTr[2, 3] = -self.config.sensor_height_m
            poses_w = wTs @ sTr
            planar = se2_from_se3(poses_w)
            landmarks_w = gtsam.utilities.extractPoint3(values).reshape(-1, 3)
        else:
            planar = gtsam.utilities.extractPose2(values).reshape(-1, 3)
            poses_w = se3_from_se2(planar)
            points = gtsam.utilities.extractPoint2(values).reshape(-1, 2)
            landmarks_w = np.column_stack([points, np.zeros(len(points))])
        ids = np.array(sorted(self._landmark_ids), dtype=np.int64)  # the key order of values
        if len(ids) != len(landmarks_w) or len(planar) != n:
            raise EstimationError("estimate does not hold one value per pose and landmark")
        pose_covs = landmark_covs = None
        if marginal_covariance is not None:
            pose_covs = np.array(
                [
                    _world_pose_covariance(marginal_covariance(fx.pose_key(i)), planar[i, 2], omni)
                    for i in range(n)
                ]
            ).reshape(n, 3, 3)
            landmark_covs = np.zeros((len(ids), 3, 3))
            for row, lid in enumerate(ids.tolist()):
                cov = marginal_covariance(fx.landmark_key(lid))
                landmark_covs[row, : len(cov), : len(cov)] = cov
        return Estimate(
            trajectory=Trajectory(np.asarray(self._stamps), poses_w),
            landmark_ids=ids,
            landmarks_w=landmarks_w,
            landmark_covariances=landmark_covs,
            pose_covariances=pose_covs,
        )


def _as_tuple(stats: DelayedInsertionStats) -> tuple[int, ...]:
    return (
        stats.tracks_inserted,
        stats.tracks_pending,
        stats.sightings_pending,
        stats.triangulations_rejected,
    )


def _world_pose_covariance(cov: np.ndarray, yaw: float, omni: bool) -> np.ndarray:
    """Marginal covariance in the pose's tangent space -> covariance of world [x, y, yaw].

    GTSAM's pose marginals are in the body frame ([x, y, theta] for Pose2, [rx, ry, rz, tx, ty,
    tz] for Pose3); to first order the world-frame position covariance is R(yaw) C R(yaw)^T.
    """
    if omni:
        cov = cov[np.ix_(fx.POSE3_PLANAR_INDICES, fx.POSE3_PLANAR_INDICES)]
    c, s = np.cos(yaw), np.sin(yaw)
    A = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return A @ cov @ A.T
