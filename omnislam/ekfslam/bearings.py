"""EKF-SLAM on the omni camera's bearings: 3-D point landmarks by delayed initialisation.

Omni bearings through delayed initialisation with ``core``'s triangulation: a
bearing fixes no depth, so a feature track cannot enter the joint Gaussian on its first sighting
as SLAM for Dummies' range-bearing landmarks do ("Passo 3"). Its sightings are held back
(``PendingTracks``: the odometry pose of each frame and the ray in the robot frame) until it
has ``BearingsConfig.min_track_sightings`` sightings whose viewpoints subtend at least
``min_parallax_deg`` at their least-squares intersection
(``core.triangulation.triangulate_rays``, the same tests as graphslam's delayed insertion:
in front of every ray, not parallel, every ray within 4 sigma of the point). Then the point
enters the state by the standard augmentation with the *triangulated pseudo-measurement*
z = (d, azimuth, elevation) of the thesis (eq. 4.25) from the current pose:

    l = g(x_r, z),  P_ll = J_xr P_rr J_xr^T + J_z Q J_z^T,  P_lx = J_xr P_rx,

with g and its Jacobians from ``RangeAzimuthElevation3D.inverse`` (eq. 4.26) and Q =
diag(sigma_d^2, sigma^2, sigma^2) (eq. 4.23): sigma the bearing's angular std, sigma_d the
depth std of two-view triangulation, sqrt(2) d sigma' / sin(gamma) (``fastslam.bearing_landmarks``)
with gamma the parallax and sigma'^2 = sigma^2 + the heading variance the odometry added
between the track's first sighting and now (the held-back rays come from past poses that are
not in the state; their relative error, not the camera's 0.03 deg, dominates the depth).

The rays are triangulated in the frame of the *current* pose estimate, each past viewpoint
placed by the odometry composed since (dead-reckoned relative poses), not by the filter's
estimate at that frame: those estimates are stale (later updates moved the current pose but
not them), and a point triangulated from them is off by the corrections made since, an error
the augmentation's J_xr P_rr J_xr^T does not describe (measured: on the simulated room of
``tests/ekfslam/test_ekfslam_bearings.py`` the pose NEES reached 55 with the stale poses). The
held-back bearings are consumed by the initialisation (they fix the depth) and not applied as
updates: the correlation of the depth with the odometry is ignored, the usual approximation of
delayed initialisation (Davison 2003; Bailey 2003).

Later bearings of a mapped track update the state with z = (azimuth, elevation)
(``BearingElevation3D``, thesis eqs. 4.29-4.37), all bearings of an image in one batch
(``SlamGaussian.update_batch``), after a chi-square gate per sighting against the state before
the image (a front-end track that jumped to another point is skipped and counted).

Landmark dimension: the omni features are 3-D points -- the true points of the tracks of the
``demo`` render lie between 0.44 and 1.67 m above the floor (5-95 %), their bearings between
-20 and +18 deg of elevation -- so a landmark is (x, y, z), as in graphslam's Point3 and
FastSLAM's 3-D landmark EKFs, and evaluated against the tracks' true 3-D points. A planar
landmark would have to drop the elevation (bearing-only in azimuth) and merge points of one
vertical edge seen at different heights.

The per-image budget of ``core.track_budget`` (graphslam's 40) bounds the state: every landmark
adds three rows and columns to P and every sighting an O(n^2) correction. Sightings without a
track id are ignored (counted).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from omnislam.core.gating import chi_square_gate
from omnislam.core.measurement import (
    BearingElevation3D,
    RangeAzimuthElevation3D,
    azimuth_elevation_from_unit_vectors,
)
from omnislam.core.motion import OdometryMotionModel
from omnislam.core.se import se2_between, se2_compose, se2_rotate_vectors
from omnislam.core.track_budget import TrackBudget
from omnislam.core.triangulation import triangulate_rays
from omnislam.core.types import UNKNOWN_ID, Bearings, Estimate, FrameInput, Trajectory
from omnislam.ekfslam.config import EKFSLAMConfig
from omnislam.ekfslam.state import SlamGaussian

#: a triangulated point must lie within this many angular sigmas of every ray of its track
CONSISTENCY_SIGMAS = 4.0
#: relative floor of the smallest eigenvalue of sum(I - d d^T) (near-parallel rays rejected)
MIN_EIGENVALUE = 1e-6


@dataclass(slots=True)
class PendingTrack:
    """The held-back sightings of a track not in the state.

    Attributes:
        poses_o: (3,) odometry (dead-reckoned) pose of each sighting's frame.
        rays_r: (3,) unit bearing of each sighting in the robot frame.
        sigmas_rad: angular std of each sighting.
        heading_var0: the cumulative odometry heading variance at the first sighting.
    """

    poses_o: list[np.ndarray] = field(default_factory=list)
    rays_r: list[np.ndarray] = field(default_factory=list)
    sigmas_rad: list[float] = field(default_factory=list)
    heading_var0: float = 0.0
    travel_var0: float = 0.0


@dataclass(frozen=True, slots=True)
class Triangulated:
    """A pending track that qualified: its point, parallax, baseline [m] (the largest distance
    between its viewpoints), latest sighting's sigma, and the cumulative odometry variances
    (heading [rad^2], translation [m^2]) at its first sighting."""

    point_w: np.ndarray
    parallax_rad: float
    sigma_rad: float
    heading_var0: float
    baseline_m: float = 0.0
    travel_var0: float = 0.0


class PendingTracks:
    """Bearing-only tracks held back until they can be triangulated (module docstring).

    Args:
        sensor_height_m: the viewpoint's height above the ground plane [m].
        min_sightings: sightings needed (>= 2).
        min_parallax_rad: angle the viewpoints must subtend at the point [rad].
    """

    def __init__(
        self, sensor_height_m: float, min_sightings: int, min_parallax_rad: float
    ) -> None:
        self._height = float(sensor_height_m)
        self._min_sightings = int(min_sightings)
        self._min_parallax_rad = float(min_parallax_rad)
        self._pending: dict[int, PendingTrack] = {}
        self.rejected = 0

    def __len__(self) -> int:
        return len(self._pending)

    def __contains__(self, track_id: object) -> bool:
        return track_id in self._pending

    def hold(
        self,
        track_id: int,
        pose_o: np.ndarray,
        ray_r: np.ndarray,
        sigma_rad: float,
        heading_var: float,
        travel_var: float = 0.0,
    ) -> None:
        """Hold back one sighting: the odometry pose it was taken from, its robot-frame ray, and
        the cumulative odometry variances (heading, translation) at that frame."""
        track = self._pending.get(track_id)
        if track is None:
            track = self._pending[track_id] = PendingTrack(
                heading_var0=heading_var, travel_var0=travel_var
            )
        track.poses_o.append(np.asarray(pose_o, dtype=float).copy())
        track.rays_r.append(np.asarray(ray_r, dtype=float))
        track.sigmas_rad.append(float(sigma_rad))

    def sightings(self) -> int:
        """Held-back sightings of all pending tracks."""
        return sum(len(t.rays_r) for t in self._pending.values())

    def try_triangulate(
        self, track_id: int, pose_o: np.ndarray, pose_w: np.ndarray
    ) -> Triangulated | None:
        """Triangulate a pending track if it qualifies; it is forgotten when it does.

        Args:
            track_id: the track.
            pose_o: (3,) the current odometry pose.
            pose_w: (3,) the current pose estimate: each held-back viewpoint is placed at
                pose_w (+) (pose_o^-1 (+) its odometry pose).
        """
        track = self._pending.get(track_id)
        if track is None or len(track.rays_r) < self._min_sightings:
            return None
        relative = se2_between(
            np.broadcast_to(pose_o, (len(track.poses_o), 3)), np.asarray(track.poses_o)
        )
        poses = se2_compose(np.broadcast_to(pose_w, relative.shape), relative)
        origins = np.column_stack([poses[:, :2], np.full(len(poses), self._height)])
        rays_w = se2_rotate_vectors(poses, np.asarray(track.rays_r))
        result = triangulate_rays(origins, rays_w)
        # the angle the viewpoints subtend at the point (rays from one viewpoint -- a robot
        # turning on the spot -- may differ by degrees and still meet at zero depth)
        to_origins = origins - result.point_w
        norms = np.linalg.norm(to_origins, axis=1)
        if np.any(norms < 1e-9):
            return None
        unit = to_origins / norms[:, None]
        subtended = float(np.arccos(np.clip(unit @ unit.T, -1.0, 1.0)).max())
        parallax = min(result.parallax_rad, subtended)
        if parallax < self._min_parallax_rad:
            return None
        if not result.in_front or result.min_eigenvalue < MIN_EIGENVALUE * len(poses):
            self.rejected += 1
            return None
        to_point = -unit
        directions = rays_w / np.linalg.norm(rays_w, axis=1, keepdims=True)
        miss = np.arccos(np.clip(np.sum(to_point * directions, axis=1), -1.0, 1.0))
        if np.any(miss > CONSISTENCY_SIGMAS * np.asarray(track.sigmas_rad)):
            self.rejected += 1
            return None
        del self._pending[track_id]
        spread = origins[:, None, :2] - origins[None, :, :2]
        baseline = float(np.sqrt(np.max(np.sum(spread**2, axis=-1))))
        return Triangulated(
            result.point_w,
            parallax,
            track.sigmas_rad[-1],
            track.heading_var0,
            baseline,
            track.travel_var0,
        )


def triangulated_sighting(
    model: RangeAzimuthElevation3D,
    pose_w: np.ndarray,
    point_w: np.ndarray,
    sigma_rad: float,
    parallax_rad: float,
    extra_angle_var: float = 0.0,
    baseline_m: float = 0.0,
    baseline_var: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """The pseudo-measurement z = (d, azimuth, elevation) of a triangulated point from the
    current pose (thesis eq. 4.25) and its noise Q (eq. 4.23, depth std of the module
    docstring; ``extra_angle_var`` the relative heading variance of the triangulating poses,
    ``baseline_var`` the variance of their relative position, which scales the depth by
    sigma_b / b for a baseline b = ``baseline_m``).

    Returns:
        z (3,) and Q (3, 3).
    """
    z, _, _ = model.predict(pose_w, point_w, jacobians=False)
    d = float(z[0])
    angle_std = math.sqrt(sigma_rad**2 + max(extra_angle_var, 0.0))
    var_d = (math.sqrt(2.0) * d * angle_std / max(math.sin(parallax_rad), 1e-6)) ** 2
    if baseline_m > 0:
        var_d += d**2 * max(baseline_var, 0.0) / baseline_m**2
    return z, np.diag([var_d, sigma_rad**2, sigma_rad**2])


@dataclass(frozen=True, slots=True)
class BearingEKFSLAMInfo:
    """What the omni filter did so far (``estimator_info.json``).

    Attributes:
        landmarks: landmarks (triangulated tracks) in the state.
        sightings: bearings consumed.
        associated: bearings that updated the state.
        gated: bearings of mapped tracks outside the validation gate (skipped).
        unknown_ignored: bearings without a track id (ignored).
        over_budget: bearings of tracks not admitted (yet) by the per-image budget (held back).
        tracks_pending: tracks held back, not triangulated (yet).
        sightings_pending: their held-back bearings.
        triangulations_rejected: triangulations behind a ray, ill-conditioned or missing a ray.
        capacity: landmark slots allocated.
    """

    landmarks: int
    sightings: int
    associated: int
    gated: int
    unknown_ignored: int
    over_budget: int
    tracks_pending: int
    sightings_pending: int
    triangulations_rejected: int
    capacity: int


class BearingEKFSLAM:
    """EKF-SLAM over 3-D point landmarks seen by the omni camera's unit bearings.

    Args:
        config: the filter's configuration (its ``motion_noise``, ``state`` and ``bearings``).
        motion: the odometry motion model (by default the shared one with
            ``config.motion_noise``).
        initial_pose_w: (3,) pose of the first frame; the origin by default.
    """

    name = "ekfslam"

    def __init__(
        self,
        config: EKFSLAMConfig | None = None,
        motion: OdometryMotionModel | None = None,
        initial_pose_w: np.ndarray | None = None,
    ) -> None:
        self.config = EKFSLAMConfig() if config is None else config
        b, start_config = self.config.bearings, self.config.state
        self.motion = OdometryMotionModel(self.config.motion_noise) if motion is None else motion
        self.model = BearingElevation3D(b.sensor_height_m)
        self.init_model = RangeAzimuthElevation3D(b.sensor_height_m)
        start = np.zeros(3) if initial_pose_w is None else np.asarray(initial_pose_w, float)
        sigma = np.asarray(start_config.initial_pose_sigma, dtype=float)
        capacity = start_config.initial_landmark_capacity
        self.state = SlamGaussian(start, np.diag(sigma**2), capacity, self.model)
        self._gate = chi_square_gate(b.track_gate_probability, 2)
        self._pending = PendingTracks(
            b.sensor_height_m, b.min_track_sightings, math.radians(b.min_parallax_deg)
        )
        self._budget = TrackBudget(b.landmarks_per_image) if b.landmarks_per_image > 0 else None
        self._slot_of_id: dict[int, int] = {}
        self._slot_ids: list[int] = []
        self._heading_var = 0.0  # odometry heading variance added so far
        self._travel_var = 0.0  # odometry translation variance added so far
        self._pose_o = np.zeros(3)  # the odometry composed (dead reckoning)
        self._frames = 0
        self._stamps_s: list[float] = []
        self._poses: list[np.ndarray] = []
        self._pose_covs: list[np.ndarray] = []
        self._counts = dict.fromkeys(
            ("sightings", "associated", "gated", "unknown_ignored", "over_budget"), 0
        )

    # -- Estimator protocol ---------------------------------------------------------------------

    def step(self, frame: FrameInput) -> None:
        """Predict with the frame's odometry (not for the first frame), update with the bearings
        of mapped tracks, hold back the others and add those that can be triangulated."""
        if self._frames > 0:
            odometry = frame.odometry
            delta_cov = odometry.covariance
            sigma_u = self.motion.covariance(odometry.delta) if delta_cov is None else delta_cov
            sigma_u = np.asarray(sigma_u)
            self._heading_var += float(sigma_u[2, 2])
            self._travel_var += float(sigma_u[0, 0] + sigma_u[1, 1])
            self._pose_o = se2_compose(self._pose_o, odometry.delta)
            self.state.predict(self.motion, odometry.delta, delta_cov)
        bearings = frame.bearings
        if bearings is not None and len(bearings):
            self._observe(bearings)
        self._frames += 1
        self._stamps_s.append(frame.stamp_s)
        self._poses.append(self.state.pose)
        self._pose_covs.append(self.state.pose_cov)

    def estimate(self) -> Estimate:
        """The filtered pose of every frame with its covariance, and the 3-D map."""
        poses = np.asarray(self._poses).reshape(-1, 3)
        n = self.state.n_landmarks
        return Estimate(
            trajectory=Trajectory.from_se2(np.asarray(self._stamps_s), poses),
            landmark_ids=np.asarray(self._slot_ids, dtype=np.int64),
            landmarks_w=self.state.landmarks.reshape(n, 3),
            landmark_covariances=self.state.landmark_covariances().reshape(n, 3, 3),
            pose_covariances=np.asarray(self._pose_covs).reshape(-1, 3, 3),
        )

    def info(self) -> BearingEKFSLAMInfo:
        """The counts so far."""
        c = self._counts
        return BearingEKFSLAMInfo(
            landmarks=self.state.n_landmarks,
            sightings=c["sightings"],
            associated=c["associated"],
            gated=c["gated"],
            unknown_ignored=c["unknown_ignored"],
            over_budget=c["over_budget"],
            tracks_pending=len(self._pending),
            sightings_pending=self._pending.sightings(),
            triangulations_rejected=self._pending.rejected,
            capacity=self.state.capacity,
        )

    # -- one image's bearings -------------------------------------------------------------------

    def _observe(self, bearings: Bearings) -> None:
        state = self.state
        ids = np.asarray(bearings.landmark_ids)
        rays = np.asarray(bearings.unit_vectors_r, dtype=float)
        sigmas = np.asarray(bearings.sigmas_rad, dtype=float)
        self._counts["sightings"] += len(ids)
        known = ids != UNKNOWN_ID
        self._counts["unknown_ignored"] += int((~known).sum())
        rows = np.flatnonzero(known)
        # one sighting per track and image (the first)
        _, first = np.unique(ids[rows], return_index=True)
        rows = rows[np.sort(first)]
        if self._budget is not None:
            admitted = self._budget.admit(ids[rows], rays[rows])
        else:
            admitted = np.ones(rows.size, dtype=bool)
        z_all = azimuth_elevation_from_unit_vectors(rays)
        # updates of mapped tracks, each gated against the state before this image
        slots: list[int] = []
        update_rows: list[int] = []
        held: list[tuple[int, bool]] = []  # (row, admitted) of tracks not in the state
        for row, ok in zip(rows.tolist(), admitted.tolist(), strict=True):
            slot = self._slot_of_id.get(int(ids[row]))
            if slot is None:
                held.append((row, ok))
                self._counts["over_budget"] += int(not ok)
                continue
            R = np.eye(2) * sigmas[row] ** 2
            nu, Hs, idx = state.innovation(slot, z_all[row])
            S = state.innovation_covariance(Hs, idx, R)
            if float(nu @ np.linalg.solve(S, nu)) > self._gate:
                self._counts["gated"] += 1
                continue
            slots.append(slot)
            update_rows.append(row)
        if slots:
            R = np.zeros((len(slots), 2, 2))
            R[:, 0, 0] = R[:, 1, 1] = sigmas[update_rows] ** 2
            state.update_batch(np.asarray(slots), z_all[update_rows], R)  # P stays symmetric
            self._counts["associated"] += len(slots)
        # the others are held back from the corrected pose (also those the budget has not
        # admitted yet: their sightings count once they are); admitted ones that qualify enter
        pose = state.pose
        for row, ok in held:
            track_id = int(ids[row])
            self._pending.hold(
                track_id,
                self._pose_o,
                rays[row],
                float(sigmas[row]),
                self._heading_var,
                self._travel_var,
            )
            if not ok:
                continue
            triangulated = self._pending.try_triangulate(track_id, self._pose_o, pose)
            if triangulated is not None:
                self._add_landmark(track_id, triangulated)

    def _add_landmark(self, track_id: int, tri: Triangulated) -> None:
        z, Q = triangulated_sighting(
            self.init_model,
            self.state.pose,
            tri.point_w,
            tri.sigma_rad,
            tri.parallax_rad,
            self._heading_var - tri.heading_var0,
            tri.baseline_m,
            self._travel_var - tri.travel_var0,
        )
        slot = self.state.augment(z, Q, self.init_model)
        self._slot_of_id[track_id] = slot
        self._slot_ids.append(track_id)
