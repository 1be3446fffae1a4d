"""The odometry's translation scale in the omni graph: online from the floor, final at the end.

Bearings carry no scale (``floor_scale.py``): a graph of omni bearings takes the odometry's.
``OdometryScaling`` gives it the floor's metric scale (``FloorConfig``):

* **online** (``scaled``): every frame's odometry translation, and its stated covariance, is
  multiplied by the floor's current scale (``floor_scale.FloorScale``, the frame's own bearings
  included), or by a known scale (``floor_scale.KnownScale``, ``known_odometry_scale``), before
  the pose chain composes it: the online estimate takes the scale known at each frame;
* **final** (``finish``; ``scale_final``, with the fixed-lag session whose final LM it can
  re-solve on other factors): every odometry translation of the final estimate is taken at the
  run's final scale -- the between-factors rebuilt with their translations times
  ``final / scale at the time``, the frames between key frames likewise
  (``PoseChain.rescale``). With ``landmarks`` and at least ``MIN_FLOOR_LANDMARKS`` floor tracks,
  the floor tracks join the final graph (``floor_points.py``) and the final scale is the one at
  which its solution agrees with its odometry (``_joint_floor_scale``). Otherwise, with
  ``scale_refine``, the final scale is re-estimated from the floor pairs over the graph's own
  trajectory (``FloorScale.refined``) and the final estimate re-solved at it, up to
  ``FINAL_SCALE_ROUNDS`` times until the correction is within ``FINAL_SCALE_TOLERANCE``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from omnislam._optional import require
from omnislam.core.types import UNKNOWN_ID, Bearings, FrameInput
from omnislam.graphslam import factors as fx
from omnislam.graphslam.config import FloorConfig
from omnislam.graphslam.floor_points import (
    FloorLandmarks,
    Sightings,
    floor_landmarks,
    odometry_ratio,
)
from omnislam.graphslam.floor_scale import MAX_SCALE, MIN_PAIRS, FloorScale, KnownScale
from omnislam.graphslam.poses import ViewpointPoses
from omnislam.graphslam.session import FixedLagSession, ISAM2Session

gtsam = require("gtsam")

#: ``scale_refine``: re-solves of the final estimate at most, and the correction below which the
#: final floor scale is kept (lab40: the first correction is ~0.5 %, the second <0.01 %)
FINAL_SCALE_ROUNDS = 3
FINAL_SCALE_TOLERANCE = 1e-4
#: ``landmarks``: floor tracks the joint solve needs (fewer: ``scale_refine``), and its solves
#: at most (lab40: the secant meets the tolerance at the third)
MIN_FLOOR_LANDMARKS = MIN_PAIRS
FLOOR_SCALE_ROUNDS = 5


class OdometryScaling:
    """The odometry's scale, online and in the final estimate (module docstring).

    Args:
        config: the floor's section.
        estimator: the online scale: from the floor points, or known.
        poses: the viewpoint chain (odometry factors' inputs, rescaling, trajectories).
        session: the graph's session; the final estimate is rescaled only with the fixed-lag
            session's.
        landmark_ids: ``landmark_ids()`` the ids of the landmarks in the graph (the graph
            builder's).
        planar_sigma_m: the planar prior's std of z [m] (``PoseConfig``), for the
            rebuilt odometry factors and the new viewpoints of the floor tracks.
        planar_sigma_rad: the planar prior's std of roll and pitch [rad] (``PoseConfig``), likewise.
    """

    def __init__(
        self,
        config: FloorConfig,
        estimator: FloorScale | KnownScale,
        poses: ViewpointPoses,
        session: ISAM2Session | FixedLagSession,
        landmark_ids: Callable[[], np.ndarray],
        planar_sigma_m: float,
        planar_sigma_rad: float,
    ) -> None:
        self._config = config
        self._floor = estimator
        self._poses = poses
        self._session = session
        self._landmark_ids = landmark_ids
        self._planar_sigmas = (planar_sigma_m, planar_sigma_rad)
        self._frame_scale: list[float] = []  # floor scale each frame's odometry was added at
        self._final_scale: tuple[int, float] | None = None  # (frames, the final estimate's scale)
        self._odometry_factors: dict[int, int] = {}  # key-frame row -> its between-factor's index
        self._sightings: dict[int, Sightings] = {}  # per image, for the floor landmarks
        self._floor_graph: FloorLandmarks | None = None  # the final graph's floor landmarks

    @classmethod
    def create(
        cls,
        config: FloorConfig,
        poses: ViewpointPoses,
        session: ISAM2Session | FixedLagSession,
        landmark_ids: Callable[[], np.ndarray],
        planar_sigma_m: float,
        planar_sigma_rad: float,
    ) -> OdometryScaling | None:
        """The scaling ``config`` asks for: a known scale, else the floor's when the camera
        height is known; None (the odometry as it is) otherwise."""
        if config.known_odometry_scale is not None:
            estimator: FloorScale | KnownScale = KnownScale(config.known_odometry_scale)
        elif config.scale and poses.sensor_height_m > 0:
            estimator = FloorScale(poses.sensor_height_m)
        else:
            return None
        return cls(config, estimator, poses, session, landmark_ids, planar_sigma_m,
                   planar_sigma_rad)

    # ------------------------------------------------------------------ online

    def scaled(self, k: int, frame: FrameInput) -> FrameInput:
        """``frame`` with its odometry translation (and stated covariance) multiplied by the
        current scale, estimated with the frame's own bearings included (the first frame's
        odometry is not used). Call once per frame, in order."""
        self._poses.rescale(None)  # the final estimate's ratios (finish) are per frame so far
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

    def keep_sightings(self, k: int, bearings: Bearings) -> None:
        """Keep frame k's bearings of tracks for the floor landmarks of the final graph."""
        if self._joins_floor:
            known = bearings.landmark_ids != UNKNOWN_ID
            self._sightings[k] = Sightings(
                bearings.landmark_ids[known],
                bearings.unit_vectors_r[known],
                bearings.sigmas_rad[known],
            )

    def key_frame_added(self, k: int) -> None:
        """Key frame k's between-factor is the next factor the session receives (remembered,
        to be rebuilt at the final scale)."""
        if k > 0 and self._rescales_final:  # the between-factor is the key frame's first
            self._odometry_factors[len(self._poses.key_frames) - 1] = self._session.factor_count

    # ------------------------------------------------------------------ final

    @property
    def _frames(self) -> int:
        """Frames consumed (``scaled`` sees every one)."""
        return len(self._frame_scale)

    @property
    def _rescales_final(self) -> bool:
        """Whether the final estimate takes the odometry at the final scale (``scale_final``;
        needs the whole-graph LM of the fixed-lag session, whose factors it can replace)."""
        return self._config.scale_final and isinstance(self._session, FixedLagSession)

    @property
    def _joins_floor(self) -> bool:
        """Whether the final estimate may solve for the floor tracks jointly (``landmarks``)."""
        return (self._rescales_final and self._config.landmarks
                and isinstance(self._floor, FloorScale))

    def finish(self) -> None:
        """Give the final estimate every odometry translation at the run's final scale (module
        docstring); cached per number of frames."""
        if not self._rescales_final or self._frames == 0:
            return
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
        if self._config.scale_refine and isinstance(self._floor, FloorScale):
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
            for lid in self._landmark_ids().tolist()
        }
        floor = floor_landmarks(
            tracks, self._sightings, planar, self._poses.key_frames, mapped_w,
            self._poses.sensor_height_m, fx.planar_prior_noise(*self._planar_sigmas),
            self._config.viewpoints,
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
            keyed = self._poses.key_poses(self.graph_values(self._session.estimate()))
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
        """The final graph's odometry at scale ``final`` (``finish``), with the floor
        landmarks when there are (``_floor_graph``)."""
        assert isinstance(self._session, FixedLagSession)
        ratios = final / np.asarray(self._frame_scale)
        floor = self._floor_graph
        if np.all(ratios == 1.0) and floor is None:
            self._poses.rescale(None)
            self._session.replace_final({}, final)
            return
        self._poses.rescale(ratios)
        replacements = {
            index: fx.between_pose3(*self._poses.odometry_factor_inputs(row),
                                    *self._planar_sigmas)
            for row, index in self._odometry_factors.items()
        }
        if floor is None:
            self._session.replace_final(replacements, (final, self._frames))
            return
        extra = gtsam.NonlinearFactorGraph(floor.factors)
        for frame in floor.frames:  # the new viewpoints' odometry, at this scale
            key_frame, delta, cov = self._poses.offset_factor_inputs(frame)
            extra.add(fx.between_pose3(key_frame, frame, delta, cov, *self._planar_sigmas))
        self._session.replace_final(replacements, (final, self._frames, "floor"), extra,
                                    floor.values)

    # ------------------------------------------------------------------ reads

    def graph_values(self, values: Any) -> Any:
        """``values`` without the floor landmarks' new variables (``_floor_graph``)."""
        if self._floor_graph is None:
            return values
        graph_values = gtsam.Values(values)
        for key in self._floor_graph.keys:
            if graph_values.exists(key):
                graph_values.erase(key)
        return graph_values

    @property
    def scale(self) -> float:
        """The factor the odometry's translations are multiplied by: the final estimate's once
        it has been read for every frame so far, else the online one."""
        if self._final_scale is not None and self._final_scale[0] == self._frames:
            return self._final_scale[1]
        return self._floor.scale

    @property
    def floor_pairs(self) -> int:
        """Floor-point pairs supporting the online scale (0: the scale is 1, or known)."""
        return self._floor.inliers

    @property
    def floor_landmarks(self) -> int:
        """Floor tracks in the final estimate's joint solve (0: not used)."""
        return 0 if self._floor_graph is None else len(self._floor_graph.tracks)
