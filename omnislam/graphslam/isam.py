"""The incremental GTSAM back end: one iSAM2 update per key frame (estimator ``graphslam``).

``GraphSLAM`` is built for one ``Modality`` (resolved once by the registry, ``core.modality``)
and reads only that stream of each frame; sightings of the other streams are counted as
ignored. A frame is a *key frame* -- it gets a pose variable -- when it has sightings of that
stream (``GraphSLAMConfig.pose_variables``), for omni bearings only once the robot has moved
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
   update goes to a fixed-lag smoother over the last ``online_lag_key_frames`` key frames, and
   ``estimate()`` is LM over the whole graph (``session.FixedLagSession``): iSAM2 over the
   whole graph re-eliminates a block that grows with the run where a room is seen from
   everywhere.

Landmark ids in the estimate are the sightings' ids (track ids, dataset ids); landmarks created
by the association get ids from ``range_bearing.CREATED_ID_BASE`` upwards.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from omnislam._optional import require
from omnislam.core.modality import Modality
from omnislam.core.motion import OdometryMotionModel
from omnislam.core.types import UNKNOWN_ID, Estimate, FrameInput, Trajectory
from omnislam.errors import ConfigError, EstimationError
from omnislam.graphslam import factors as fx
from omnislam.graphslam.bearings_3d import Bearings3DGraph
from omnislam.graphslam.builder import GraphBuilder
from omnislam.graphslam.config import GraphSLAMConfig, PoseVariables
from omnislam.graphslam.export import G2O_ATTACHMENT, format_g2o
from omnislam.graphslam.floor_points import (
    FloorLandmarks,
    Sightings,
    floor_landmarks,
    odometry_ratio,
)
from omnislam.graphslam.floor_scale import MAX_SCALE, MIN_PAIRS, FloorScale, KnownScale
from omnislam.graphslam.poses import PlanarPoses, PoseChain, ViewpointPoses
from omnislam.graphslam.range_bearing import CREATED_ID_BASE, RangeBearingGraph
from omnislam.graphslam.session import FixedLagSession, ISAM2Session
from omnislam.graphslam.vertical_lines import VerticalLinesGraph

gtsam = require("gtsam")

#: ``floor_scale_refine``: re-solves of the final estimate at most, and the correction below
#: which the final floor scale is kept (lab40: the first correction is ~0.5 %, the second <0.01 %)
FINAL_SCALE_ROUNDS = 3
FINAL_SCALE_TOLERANCE = 1e-4
#: ``floor_landmarks``: floor tracks the joint solve needs (fewer: ``floor_scale_refine``), and
#: its solves at most (lab40: the secant meets the tolerance at the third)
MIN_FLOOR_LANDMARKS = MIN_PAIRS
FLOOR_SCALE_ROUNDS = 5

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
        key_frames: frames with a pose variable (``GraphSLAMConfig.pose_variables``).
        sightings_over_budget: bearings of tracks left out by the per-image landmark budget
            (``GraphSLAMConfig.landmarks_per_image``).
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
        odometry_scale: the factor the odometry's translations are multiplied by (omni
            bearings with ``GraphSLAMConfig.floor_scale``: from the floor points -- the final
            estimate's scale once it has been read, else the online one; else 1).
        floor_pairs: floor-point pairs supporting the online floor scale (0: the scale is 1).
        floor_landmarks: floor tracks in the final estimate's joint solve
            (``GraphSLAMConfig.floor_landmarks``; 0: not used).
        online_factors_skipped: omni with ``GraphSLAMConfig.online_lag_key_frames``: factors on
            variables the fixed-lag smoother had marginalised (in the full graph only).
        online_restarts: restarts of the fixed-lag smoother after a failed marginalisation.
        online_landmarks_held_out: landmarks a restart of the fixed-lag smoother left out of
            its window, held there by fewer than two bearings (``session.FixedLagSession``);
            they are in the final estimate.
        landmarks_merged: landmarks started by the association found to duplicate an older one
            and merged into it (``loop_closure.py``; not counted in ``landmarks``).
        loop_closures: loop closures accepted (each merged one or more landmarks).
        sightings_reassociated: batch mode with ``GraphSLAMConfig.batch_reassociation_rounds``:
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
        self.config = config if config is not None else GraphSLAMConfig()
        self._modality = modality
        initial = np.asarray(initial_pose, dtype=float).reshape(3)
        self._session: ISAM2Session | FixedLagSession = (
            FixedLagSession(self.config)
            if modality is Modality.BEARINGS_3D and self.config.online_lag_key_frames is not None
            else ISAM2Session(self.config)
        )
        self._motion = OdometryMotionModel(self.config.motion_noise) if motion is None else motion
        self._poses: PoseChain
        self._graph: GraphBuilder
        if modality is Modality.BEARINGS_3D:
            viewpoints = ViewpointPoses(self.config, initial, self._session, self._motion)
            self._poses, self._graph = viewpoints, Bearings3DGraph(self.config, viewpoints)
        else:
            planar = PlanarPoses(self.config, initial, self._session, self._motion)
            self._poses = planar
            self._graph = (
                RangeBearingGraph(self.config, planar, self._session)
                if modality is Modality.RANGE_BEARING_2D
                else VerticalLinesGraph(self.config, planar)
            )
        self._floor: FloorScale | KnownScale | None = None  # see GraphSLAMConfig.floor_scale
        if modality is Modality.BEARINGS_3D and self.config.known_odometry_scale is not None:
            self._floor = KnownScale(self.config.known_odometry_scale)
        elif (
            modality is Modality.BEARINGS_3D
            and self.config.floor_scale
            and self.config.sensor_height_m > 0
        ):
            self._floor = FloorScale(self.config.sensor_height_m)
        self._stamps: list[float] = []
        self._frame_scale: list[float] = []  # floor scale each frame's odometry was added at
        self._final_scale: tuple[int, float] | None = None  # (frames, the final estimate's scale)
        self._odometry_factors: dict[int, int] = {}  # key-frame row -> its between-factor's index
        self._sightings: dict[int, Sightings] = {}  # per image, for floor_landmarks
        self._floor_graph: FloorLandmarks | None = None  # the final graph's floor landmarks
        self._frames = 0
        self._other_streams_ignored = 0
        self._between_keys = 0  # sightings of frames that got no pose variable

    # ------------------------------------------------------------------ protocol

    def step(self, frame: FrameInput) -> None:
        """Add one frame: its pose and odometry factor, its sightings, one iSAM2 update."""
        k = self._frames
        self._poses.rescale(None)  # the final estimate's ratios (finish) are per frame so far
        if self._floor is not None:
            frame = self._scaled(k, frame)
        used = self._modality.stream(frame)
        for other in (frame.bearings, frame.range_bearing, frame.vertical_lines):
            if other is not None and other is not used:
                self._other_streams_ignored += len(other)
        seen = used is not None and len(used) > 0
        guess_w = self._poses.fold(k, frame)
        key = (
            k == 0
            or self.config.pose_variables is PoseVariables.FRAMES
            or (seen and self._far_enough())
        )
        self._stamps.append(frame.stamp_s)
        self._frames += 1
        if seen and self._joins_floor:
            known = used.landmark_ids != UNKNOWN_ID
            self._sightings[k] = Sightings(
                used.landmark_ids[known], used.unit_vectors_r[known], used.sigmas_rad[known]
            )
        if not key:  # its odometry waits for the next key frame's between-factor
            self._poses.add(k, None, None, key=False)
            if seen:
                self._between_keys += len(used)
            return
        graph = gtsam.NonlinearFactorGraph()
        values = gtsam.Values()
        self._poses.add(k, graph, values, key=True)
        if k > 0 and self._rescales_final:  # the between-factor is the key frame's first
            self._odometry_factors[len(self._poses.key_frames) - 1] = self._session.factor_count
        if seen:
            self._graph.add(k, used, guess_w, graph, values)
        self._session.update(graph, values, frame.index)
        self._poses.read_newest(k)

    def _scaled(self, k: int, frame: FrameInput) -> FrameInput:
        """``frame`` with its odometry translation (and stated covariance) multiplied by the
        floor's scale, estimated with the frame's own bearings included (``floor_scale.py``;
        the first frame's odometry is not used)."""
        assert self._floor is not None
        odometry = frame.odometry
        self._floor.observe(odometry.delta if k > 0 else np.zeros(3), frame.bearings)
        scale = self._floor.scale
        self._frame_scale.append(scale)  # (frame 0 has no odometry: any scale does)
        if scale == 1.0 or k == 0:
            return frame
        factors = np.array([scale, scale, 1.0])
        covariance = odometry.covariance
        if covariance is not None:
            covariance = covariance * np.outer(factors, factors)
        return replace(
            frame,
            odometry=replace(odometry, delta=odometry.delta * factors, covariance=covariance),
        )

    def _far_enough(self) -> bool:
        """Omni bearings: a frame with sightings becomes a key frame once the robot has moved
        ``keyframe_spacing_m`` since the newest one (``GraphSLAMConfig``); other streams:
        always."""
        spacing = self.config.keyframe_spacing_m
        if self._modality is not Modality.BEARINGS_3D or spacing <= 0:
            return True
        return bool(np.hypot(*self._poses.since_key[:2]) >= spacing)

    def finish(self) -> None:
        """Decide the sightings the graph builder still holds back (the association window of
        ``window_association.py``) and run one iSAM2 update with them.

        Called by every read of the whole estimate; ``step`` may continue afterwards.
        """
        finish = getattr(self._graph, "finish", None)
        if finish is not None and self._frames > 0:
            graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
            if finish(graph, values):
                self._session.update(graph, values, self._frames - 1)
        if self._rescales_final and self._frames > 0:
            self._rescale_final()

    @property
    def _rescales_final(self) -> bool:
        """Whether the final estimate takes the odometry at the final floor scale
        (``GraphSLAMConfig.floor_scale_final``; needs the whole-graph LM of the fixed-lag
        session, whose factors it can replace)."""
        return (self._floor is not None and self.config.floor_scale_final
                and isinstance(self._session, FixedLagSession))

    @property
    def _joins_floor(self) -> bool:
        """Whether the final estimate may solve for the floor tracks jointly
        (``GraphSLAMConfig.floor_landmarks``)."""
        return (self._rescales_final and self.config.floor_landmarks
                and isinstance(self._floor, FloorScale))

    def _rescale_final(self) -> None:
        """Give the final estimate every odometry translation at the run's final floor scale:
        the between-factors rebuilt with their translations times ``final / scale at the time``,
        the frames between key frames likewise (``PoseChain.rescale``).

        With ``floor_landmarks`` and at least ``MIN_FLOOR_LANDMARKS`` floor tracks, the floor
        tracks then join the final graph (``floor_points.py``) and the final scale is the one at
        which its solution agrees with its odometry (``_joint_floor_scale``). Otherwise, with
        ``floor_scale_refine``, the final scale is re-estimated from the floor pairs over the
        graph's own trajectory (``FloorScale.refined``) and the final estimate re-solved at it,
        up to ``FINAL_SCALE_ROUNDS`` times until the correction is within
        ``FINAL_SCALE_TOLERANCE``. Cached per number of frames."""
        assert self._floor is not None and isinstance(self._session, FixedLagSession)
        if self._final_scale is not None and self._final_scale[0] == self._frames:
            self._apply_final_scale(self._final_scale[1])
            return
        final = self._floor.scale
        self._floor_graph = None
        self._apply_final_scale(final)
        if self._joins_floor:
            self._floor_graph = self._floor_landmarks()
            if self._floor_graph is not None:
                self._final_scale = (self._frames, self._joint_floor_scale(final))
                return
        if self.config.floor_scale_refine and isinstance(self._floor, FloorScale):
            for _ in range(FINAL_SCALE_ROUNDS):
                planar, _ = self._poses.trajectory(self._session.estimate(), self._frames)
                correction = self._floor.refined(planar).scale
                if abs(correction - 1.0) <= FINAL_SCALE_TOLERANCE:
                    break
                final *= correction
                self._apply_final_scale(final)
        self._final_scale = (self._frames, final)

    def _floor_landmarks(self) -> FloorLandmarks | None:
        """The floor tracks for the final graph (``floor_points.py``), classified by the pairs
        over the final estimate's trajectory without them; None when fewer than
        ``MIN_FLOOR_LANDMARKS``."""
        assert isinstance(self._floor, FloorScale)
        start = self._session.estimate()
        planar, _ = self._poses.trajectory(start, self._frames)
        tracks = self._floor.refined(planar).floor_tracks()
        if len(tracks) < MIN_FLOOR_LANDMARKS:
            return None
        mapped_w = {
            lid: np.asarray(start.atPoint3(fx.landmark_key(lid)))
            for lid in self._graph.landmark_ids().tolist()
        }
        floor = floor_landmarks(
            tracks, self._sightings, planar, self._poses.key_frames, mapped_w,
            self.config.sensor_height_m,
            fx.planar_prior_noise(self.config.planar_sigma_m, self.config.planar_sigma_rad),
            self.config.floor_viewpoints,
        )
        return floor if len(floor.tracks) >= MIN_FLOOR_LANDMARKS else None

    def _joint_floor_scale(self, final: float) -> float:
        """The odometry scale at which the final estimate with the floor landmarks agrees with
        its own odometry (``floor_points.odometry_ratio`` = 1), where the odometry no longer
        pulls the map's scale and the floor tracks' height priors set it: the secant method
        on the log of the scale from the online floor scale, at most ``FLOOR_SCALE_ROUNDS``
        solves, until the ratio is within ``FINAL_SCALE_TOLERANCE`` of 1."""
        previous: tuple[float, float] | None = None
        for _ in range(FLOOR_SCALE_ROUNDS):
            self._apply_final_scale(final)
            keyed = self._poses.key_poses(self._graph_values(self._session.estimate()))
            poses_w = dict(zip(self._poses.key_frames, keyed, strict=True))
            odometry = [
                self._poses.odometry_factor_inputs(row)[:3] for row in self._odometry_factors
            ]
            log_ratio = float(np.log(odometry_ratio(poses_w, odometry)))
            if abs(log_ratio) <= FINAL_SCALE_TOLERANCE:
                break
            step = log_ratio
            if previous is not None and previous[1] != log_ratio:
                step = log_ratio * (np.log(final) - previous[0]) / (previous[1] - log_ratio)
            previous = (float(np.log(final)), log_ratio)
            # a secant through two nearly equal ratios must not throw the scale away
            final = float(final * np.exp(np.clip(step, -np.log(MAX_SCALE), np.log(MAX_SCALE))))
        return final

    def _apply_final_scale(self, final: float) -> None:
        """The final graph's odometry at scale ``final`` (``_rescale_final``), with the floor
        landmarks when there are (``_floor_graph``)."""
        assert isinstance(self._session, FixedLagSession)
        ratios = final / np.asarray(self._frame_scale)
        floor = self._floor_graph
        if np.all(ratios == 1.0) and floor is None:
            self._poses.rescale(None)
            self._session.replace_final({}, final)
            return
        self._poses.rescale(ratios)
        config = self.config
        replacements = {
            index: fx.between_pose3(*self._poses.odometry_factor_inputs(row),
                                    config.planar_sigma_m, config.planar_sigma_rad)
            for row, index in self._odometry_factors.items()
        }
        if floor is None:
            self._session.replace_final(replacements, (final, self._frames))
            return
        extra = gtsam.NonlinearFactorGraph(floor.factors)
        for frame in floor.frames:  # the new viewpoints' odometry, at this scale
            key_frame, delta, cov = self._poses.offset_factor_inputs(frame)
            extra.add(fx.between_pose3(key_frame, frame, delta, cov, config.planar_sigma_m,
                                       config.planar_sigma_rad))
        self._session.replace_final(replacements, (final, self._frames, "floor"), extra,
                                    floor.values)

    def _graph_values(self, values: Any) -> Any:
        """``values`` without the floor landmarks' new variables (``_floor_graph``)."""
        if self._floor_graph is None:
            return values
        graph_values = gtsam.Values(values)
        for key in self._floor_graph.keys:
            if graph_values.exists(key):
                graph_values.erase(key)
        return graph_values

    def _odometry_scale(self) -> float:
        """``GraphSLAMInfo.odometry_scale``."""
        if self._floor is None:
            return 1.0
        if self._final_scale is not None and self._final_scale[0] == self._frames:
            return self._final_scale[1]
        return self._floor.scale

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
            odometry_scale=self._odometry_scale(),
            floor_pairs=0 if self._floor is None else self._floor.inliers,
            floor_landmarks=0 if self._floor_graph is None else len(self._floor_graph.tracks),
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
        values = self._graph_values(values)
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
