"""The incremental GTSAM back end: one iSAM2 update per key frame (estimator ``graphslam``).

``GraphSLAM`` is built for one ``Modality`` (resolved once by the registry, ``core.modality``)
and reads only that stream of each frame; sightings of the other streams are counted as
ignored. A frame is a *key frame* -- it gets a pose variable -- when it has sightings of that
stream (``PoseConfig.pose_variables``), for omni bearings only once the robot has moved
``keyframe_spacing_m`` since the newest key frame; any other frame only folds its odometry into
the next key frame's between-factor (``poses.py``) and costs no update. Each key frame's
``step``:

1. adds the frame's pose with the initial guess ``wTr_key (+) delta`` and its odometry
   factor from the previous key frame (``poses.py``: ``Pose2`` robot poses, or for omni
   bearings ``Pose3`` sensor viewpoints with the planar prior);
2. turns the frame's sightings into factors and new landmarks (the modality's graph builder:
   ``bearings_3d.py``, ``range_bearing.py``, ``vertical_lines.py``);
3. runs one iSAM2 update (``session.py``; Cholesky, rebuilt with QR if it fails) and reads back
   **only the newest pose**; the full estimate is computed only in ``estimate()`` (docs/design.md:
   reading everything every step cost as much as the update). Omni bearings, by default: the
   update goes to a fixed-lag smoother over the last ``SolverConfig.online_lag_key_frames`` key
   frames, and ``estimate()`` is LM over the whole graph (``session.FixedLagSession``): iSAM2
   over the whole graph re-eliminates a block that grows with the run where a room is seen
   from everywhere.

Omni bearings with a camera height: the odometry takes the floor's metric scale, online and in
the final estimate (``odometry_scale.py``, ``FloorConfig``).

Landmark ids in the estimate are the sightings' ids (track ids, dataset ids); landmarks created
by the association get ids from ``range_bearing.CREATED_ID_BASE`` upwards.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from omnislam._optional import require
from omnislam.core.modality import Modality
from omnislam.core.motion import OdometryMotionModel
from omnislam.core.types import Estimate, FrameInput, Trajectory
from omnislam.errors import ConfigError, EstimationError
from omnislam.graphslam import factors as fx
from omnislam.graphslam.bearings_3d import Bearings3DGraph
from omnislam.graphslam.builder import GraphBuilder
from omnislam.graphslam.config import GraphSLAMConfig, PoseVariables
from omnislam.graphslam.export import G2O_ATTACHMENT, format_g2o
from omnislam.graphslam.odometry_scale import OdometryScaling
from omnislam.graphslam.poses import PlanarPoses, PoseChain, ViewpointPoses
from omnislam.graphslam.range_bearing import CREATED_ID_BASE, RangeBearingGraph
from omnislam.graphslam.session import FixedLagSession, ISAM2Session
from omnislam.graphslam.vertical_lines import VerticalLinesGraph

gtsam = require("gtsam")

__all__ = ["CREATED_ID_BASE", "GraphSLAM", "GraphSLAMInfo"]


@dataclass(frozen=True, slots=True)
class GraphSLAMInfo:
    """What the back end has done so far (counts, for reports and tests).

    Attributes:
        modality: the observation stream the graph is built from.
        frames: frames consumed.
        landmarks: landmarks in the graph.
        factors: factors in the graph.
        tracks_inserted: bearing-only tracks triangulated and inserted (or range-bearing
            landmarks through consistent insertion).
        tracks_pending: bearing-only tracks held back so far (never qualified).
        sightings_pending: held-back sightings of those tracks.
        triangulations_rejected: insertion attempts rejected (point behind a ray, parallel rays).
        landmarks_created: landmarks started by the association of unlabelled sightings.
        sightings_associated: unlabelled sightings matched to a mapped landmark.
        sightings_ambiguous: unlabelled sightings dropped between the two gates.
        sightings_ignored: sightings the graph cannot use (bearings without a track id) and
            every sighting of the other modalities.
        sightings_gated: bearings of mapped landmarks pointing away from them (outliers of
            the front end's association), not added to the graph.
        sightings_readmitted: range-bearing sightings with ids the outlier gate rejected
            that entered the graph once enough re-sightings of their landmark agreed with them
            (a loop closed under an overconfident pose; ``core.gating.GatedResightings``).
        sightings_between_key_frames: sightings of frames that got no pose variable (omni
            images closer than ``keyframe_spacing_m`` to the newest key frame).
        key_frames: frames with a pose variable (``PoseConfig.pose_variables``).
        sightings_over_budget: bearings of tracks left out by the per-image landmark budget
            (``LandmarkConfig.per_image``).
        factorization_fallbacks: Cholesky failures recovered by rebuilding with QR (AUTO).
        batch_reorders: updates in which iSAM2 re-ordered and re-eliminated the whole Bayes
            tree (when most variables were affected, or by ``adaptive_reorder_threshold``).
        tree_nonzeros: non-zeros of the Bayes tree's conditionals after the latest update
            (its fill-in).
        tentative_committed: landmarks started by the association that were re-observed and
            entered the graph (``AssociationConfig.tentative_min_sightings`` > 1).
        tentative_dropped: such landmarks not re-observed in time, dropped with their
            sightings (clutter).
        tentative_sightings_dropped: sightings dropped with them.
        tentative_pending: such landmarks still waiting.
        odometry_scale: the factor the odometry's translations are multiplied by (omni
            bearings with ``FloorConfig.scale``: from the floor points -- the final
            estimate's scale once it has been read, else the online one; else 1).
        floor_pairs: floor-point pairs supporting the online floor scale (0: the scale is 1).
        floor_landmarks: floor tracks in the final estimate's joint solve
            (``FloorConfig.landmarks``; 0: not used).
        online_factors_skipped: omni with ``SolverConfig.online_lag_key_frames``: factors on
            variables the fixed-lag smoother had marginalised (in the full graph only).
        online_restarts: restarts of the fixed-lag smoother after a failed marginalisation.
        online_landmarks_held_out: landmarks a restart of the fixed-lag smoother left out of
            its window, held there by fewer than two bearings (``session.FixedLagSession``);
            they are in the final estimate.
        landmarks_merged: landmarks started by the association found to duplicate an older one
            and merged into it (``loop_closure.py``; not counted in ``landmarks``).
        loop_closures: loop closures accepted (each merged one or more landmarks).
        sightings_reassociated: batch mode with ``ExperimentalConfig.batch_reassociation_rounds``:
            sightings the final re-association gave to another landmark (``reassociation.py``).
    """

    modality: Modality
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
    sightings_readmitted: int = 0
    sightings_between_key_frames: int = 0
    key_frames: int = 0
    sightings_over_budget: int = 0
    factorization_fallbacks: int = 0
    batch_reorders: int = 0
    tree_nonzeros: int = 0
    tentative_committed: int = 0
    tentative_dropped: int = 0
    tentative_sightings_dropped: int = 0
    tentative_pending: int = 0
    odometry_scale: float = 1.0
    floor_pairs: int = 0
    floor_landmarks: int = 0
    online_factors_skipped: int = 0
    online_restarts: int = 0
    online_landmarks_held_out: int = 0
    landmarks_merged: int = 0
    loop_closures: int = 0
    sightings_reassociated: int = 0


class GraphSLAM:
    """iSAM2 SLAM over Pose2/Pose3 variables with built-in GTSAM factors.

    Args:
        modality: the observation stream the graph is built from (``BEARINGS_3D``: Pose3
            viewpoints and ``BearingFactor3D``; ``RANGE_BEARING_2D``: Pose2 and
            ``BearingRangeFactor2D``; ``VERTICAL_LINES``: Pose2 and ``BearingFactor2D``).
        config: settings (``GraphSLAMConfig``); None uses the defaults.
        initial_pose: (3,) pose [x, y, theta] of the first frame in the world [m, m, rad].
        motion: the odometry motion model (thesis eqs. 4.38-4.44) whose covariance weighs the
            odometry factors; by default one built from ``config.motion_noise``.

    Conforms to ``omnislam.core.types.Estimator``, ``Introspectable`` (``info``) and
    ``Exporting`` (``attachments``: the factor graph as ``graph.g2o``).

    Raises:
        ConfigError: ``modality`` is not a ``Modality``.
    """

    name = "graphslam"

    def __init__(
        self,
        modality: Modality,
        config: GraphSLAMConfig | None = None,
        initial_pose: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
        motion: OdometryMotionModel | None = None,
    ) -> None:
        if not isinstance(modality, Modality):
            raise ConfigError(f"modality must be a Modality, got {modality!r}")
        self.config = config = config if config is not None else GraphSLAMConfig()
        self._modality = modality
        initial = np.asarray(initial_pose, dtype=float).reshape(3)
        self._session = _session(modality, config)
        self._motion = OdometryMotionModel(config.motion_noise) if motion is None else motion
        self._poses, self._graph = _pose_chain_and_builder(
            modality, config, initial, self._session, self._motion
        )
        self._scaling: OdometryScaling | None = None  # omni bearings: see FloorConfig
        if isinstance(self._poses, ViewpointPoses):
            self._scaling = OdometryScaling.create(
                config.floor,
                self._poses,
                self._session,
                self._graph.landmark_ids,
                config.poses.planar_sigma_m,
                config.poses.planar_sigma_rad,
            )
        self._stamps: list[float] = []
        self._frames = 0
        self._other_streams_ignored = 0
        self._between_keys = 0  # sightings of frames that got no pose variable

    # ------------------------------------------------------------------ protocol

    def step(self, frame: FrameInput) -> None:
        """Add one frame: its pose and odometry factor, its sightings, one iSAM2 update."""
        k = self._frames
        if self._scaling is not None:
            frame = self._scaling.scaled(k, frame)
        used = self._modality.stream(frame)
        for other in (frame.bearings, frame.range_bearing, frame.vertical_lines):
            if other is not None and other is not used:
                self._other_streams_ignored += len(other)
        seen = used is not None and len(used) > 0
        guess_w = self._poses.fold(k, frame)
        key = (
            k == 0
            or self.config.poses.pose_variables is PoseVariables.FRAMES
            or (seen and self._far_enough())
        )
        self._stamps.append(frame.stamp_s)
        self._frames += 1
        if seen and self._scaling is not None:
            self._scaling.keep_sightings(k, used)
        if not key:  # its odometry waits for the next key frame's between-factor
            self._poses.add(k, None, None, key=False)
            if seen:
                self._between_keys += len(used)
            return
        graph = gtsam.NonlinearFactorGraph()
        values = gtsam.Values()
        self._poses.add(k, graph, values, key=True)
        if self._scaling is not None:
            self._scaling.key_frame_added(k)
        if seen:
            self._graph.add(k, used, guess_w, graph, values)
        self._session.update(graph, values, frame.index)
        self._poses.read_newest(k)

    def _far_enough(self) -> bool:
        """Omni bearings: a frame with sightings becomes a key frame once the robot has moved
        ``keyframe_spacing_m`` since the newest one (``PoseConfig``); other streams: always."""
        spacing = self.config.poses.keyframe_spacing_m
        if self._modality is not Modality.BEARINGS_3D or spacing <= 0:
            return True
        return bool(np.hypot(*self._poses.since_key[:2]) >= spacing)

    def finish(self) -> None:
        """Decide the sightings the graph builder still holds back (the association window of
        ``window_association.py``) and run one iSAM2 update with them; then give the final
        estimate the odometry at the run's final scale (``odometry_scale.py``).

        Called by every read of the whole estimate; ``step`` may continue afterwards.
        """
        finish = getattr(self._graph, "finish", None)
        if finish is not None and self._frames > 0:
            graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
            if finish(graph, values):
                self._session.update(graph, values, self._frames - 1)
        if self._scaling is not None:
            self._scaling.finish()

    def estimate(self) -> Estimate:
        """The current iSAM2 estimate: all poses, all landmarks, covariances if configured."""
        if self._frames == 0:
            return _empty_estimate()
        self.finish()
        covariance = self._session.marginal_covariance if self.config.compute_covariances else None
        return self._estimate_from(self._session.estimate(), covariance)

    # ------------------------------------------------------------------ inspection

    @property
    def modality(self) -> Modality:
        """The observation stream the graph is built from."""
        return self._modality

    @property
    def session(self) -> ISAM2Session | FixedLagSession:
        """The iSAM2 session, or the fixed-lag one (for inspection: marginals, linearisation
        point)."""
        return self._session

    def info(self) -> GraphSLAMInfo:
        """Counts of what the back end did (see ``GraphSLAMInfo``)."""
        counts = self._graph.counts()
        insertion, tentative = counts.insertion, counts.tentative
        scaling = self._scaling
        return GraphSLAMInfo(
            modality=self._modality,
            frames=self._frames,
            landmarks=counts.landmarks,
            factors=self._session.factor_count,
            tracks_inserted=insertion.tracks_inserted,
            tracks_pending=insertion.tracks_pending,
            sightings_pending=insertion.sightings_pending,
            triangulations_rejected=insertion.triangulations_rejected,
            landmarks_created=counts.landmarks_created,
            sightings_associated=counts.sightings_associated,
            sightings_ambiguous=counts.sightings_ambiguous,
            sightings_ignored=counts.sightings_ignored + self._other_streams_ignored,
            sightings_between_key_frames=self._between_keys,
            key_frames=len(self._poses.key_frames),
            sightings_over_budget=counts.sightings_over_budget,
            sightings_gated=counts.sightings_gated,
            sightings_readmitted=counts.sightings_readmitted,
            factorization_fallbacks=self._session.fallbacks,
            batch_reorders=self._session.batch_reorders,
            tree_nonzeros=self._session.tree_nonzeros,
            tentative_committed=tentative.committed,
            tentative_dropped=tentative.dropped,
            tentative_sightings_dropped=tentative.sightings_dropped,
            tentative_pending=tentative.pending,
            odometry_scale=1.0 if scaling is None else scaling.scale,
            floor_pairs=0 if scaling is None else scaling.floor_pairs,
            floor_landmarks=0 if scaling is None else scaling.floor_landmarks,
            online_factors_skipped=getattr(self._session, "online_factors_skipped", 0),
            online_restarts=getattr(self._session, "online_restarts", 0),
            online_landmarks_held_out=getattr(self._session, "online_landmarks_held_out", 0),
            landmarks_merged=counts.landmarks_merged,
            loop_closures=counts.loop_closures,
        )

    def factor_graph(self) -> Any:
        """The ``gtsam.NonlinearFactorGraph`` of every factor added so far (iSAM2's own copy)."""
        self.finish()
        return self._session.factors()

    def values(self) -> Any:
        """The current iSAM2 estimate as ``gtsam.Values`` (a full back-substitution)."""
        self.finish()
        return self._session.estimate()

    def newest_pose(self) -> np.ndarray:
        """(3,) newest pose estimate [x, y, theta] of the robot frame: the newest key frame's
        iSAM2 estimate composed with the odometry since (read every step)."""
        return self._poses.guess_w.copy()

    def attachments(self) -> Mapping[str, bytes]:
        """``{"graph.g2o": ...}``: the factor graph at ``values()`` in g2o text (``export.py``)."""
        return {G2O_ATTACHMENT: format_g2o(self.factor_graph(), self.values()).text.encode()}

    # ------------------------------------------------------------------ estimate

    def _estimate_from(
        self, values: Any, marginal_covariance: Callable[[int], np.ndarray] | None
    ) -> Estimate:
        """Estimate record from ``values``; covariances from ``marginal_covariance(key)``."""
        n = self._frames
        if self._scaling is not None:
            values = self._scaling.graph_values(values)
        planar, poses_w = self._poses.trajectory(values, n)
        landmarks_w = self._graph.landmarks(values)
        ids = self._graph.landmark_ids()  # the key order of values
        if len(ids) != len(landmarks_w):
            raise EstimationError("estimate does not hold one value per pose and landmark")
        pose_covs = landmark_covs = None
        if marginal_covariance is not None:
            keys = self._poses.key_frames
            key_covs = np.array(
                [
                    self._poses.world_covariance(marginal_covariance(fx.pose_key(i)), planar[i, 2])
                    for i in keys
                ]
            ).reshape(len(keys), 3, 3)
            pose_covs = self._poses.frame_covariances(key_covs, planar)
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


def _empty_estimate() -> Estimate:
    """The estimate before the first frame: no poses, no landmarks."""
    return Estimate(Trajectory.from_se2(np.zeros(0), np.zeros((0, 3))))


def _session(modality: Modality, config: GraphSLAMConfig) -> ISAM2Session | FixedLagSession:
    """The session of a run: the fixed-lag one for omni bearings with a lag, else iSAM2 over
    the whole graph (``SolverConfig.online_lag_key_frames``)."""
    if modality is Modality.BEARINGS_3D and config.solver.online_lag_key_frames is not None:
        return FixedLagSession(config.solver, config.batch, config.poses.planar_sigma_m)
    return ISAM2Session(config.solver)


def _pose_chain_and_builder(
    modality: Modality,
    config: GraphSLAMConfig,
    initial_pose: np.ndarray,
    session: ISAM2Session | FixedLagSession,
    motion: OdometryMotionModel,
) -> tuple[PoseChain, GraphBuilder]:
    """The pose chain and the graph builder of ``modality``, each given its sections."""
    noise = fx.NoiseModels(*config.solver.landmark_kernel(modality))
    if modality is Modality.BEARINGS_3D:
        viewpoints = ViewpointPoses(config.poses, initial_pose, session, motion)
        return viewpoints, Bearings3DGraph(
            config.landmarks, noise, viewpoints, config.experimental.budget_grace_images
        )
    planar = PlanarPoses(config.poses, initial_pose, session, motion)
    if modality is Modality.RANGE_BEARING_2D:
        return planar, RangeBearingGraph(
            config.landmarks,
            config.association,
            noise,
            planar,
            session,
            config.experimental.loop_closure,
            config.experimental.association_landmark_marginals,
        )
    return planar, VerticalLinesGraph(config.landmarks, noise, planar)
