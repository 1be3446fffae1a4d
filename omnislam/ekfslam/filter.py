"""EKF-SLAM, the baseline of "SLAM for Dummies" (Riisgaard & Blas), as an omnislam Estimator.

Per frame (tutorial, "Perspetiva do processo"): (1) predict with the odometry; (2) update with
the sightings of landmarks already in the state; (3) add new landmarks to the state. Sightings
with ids are associated by id (a new id is augmented at once); sightings of unknown id
(``UNKNOWN_ID``) by the tutorial's nearest neighbour with validation gate and counter
(``association``). The Gaussian and the three steps are in ``state.SlamGaussian``.

Within a frame every update uses the state corrected by the previous ones (sequential updates);
new landmarks are added after all updates of the frame, from the corrected pose. Landmarks
created from sightings of unknown id get the smallest ids not used yet (a log should not mix
sightings with and without ids of the same landmarks).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from omnislam.core.compatibility import (
    Decision,
    JointAssociation,
    Pairings,
    decide_on_kept_support,
    innovation_widening,
)
from omnislam.core.gating import (
    YOUNG_GATE_FACTOR,
    GatedResightings,
    Resighting,
    chi_square_gate,
    lies_on_a_landmark,
)
from omnislam.core.measurement import RangeBearing2D
from omnislam.core.motion import OdometryMotionModel
from omnislam.core.types import UNKNOWN_ID, Estimate, FrameInput, RangeBearing, Trajectory
from omnislam.ekfslam.association import TentativeLandmarks, frame_pairings, nearest_gated
from omnislam.ekfslam.config import AssociationTest, EKFSLAMConfig
from omnislam.ekfslam.state import SlamGaussian


@dataclass(frozen=True, slots=True)
class EKFSLAMInfo:
    """What the filter did so far (``estimator_info.json``).

    Attributes:
        landmarks: landmarks in the state.
        tentative: landmarks of unknown id seen fewer than N times, waiting outside the state.
        sightings: sightings consumed.
        associated: sightings that updated the state (by id or through the gate).
        gated: sightings of unknown id outside every state landmark's gate (they went to the
            tentative landmarks), plus sightings with ids rejected by the outlier gate.
        readmitted: sightings with ids the outlier gate rejected that updated the state once
            enough re-sightings of their landmark agreed (``OutlierGateConfig.votes``).
        ambiguous: sightings of unknown id outside every validation gate but inside the wider
            new-landmark gate of a landmark: discarded.
        created: landmarks added to the state (augmentations).
        tentative_created: tentative landmarks started (sightings that matched nothing).
        tentative_dropped: tentative landmarks dropped, not re-observed within the window
            (``LandmarksConfig.tentative_window_m``).
        capacity: landmark slots allocated.
    """

    landmarks: int
    tentative: int
    sightings: int
    associated: int
    gated: int
    readmitted: int
    ambiguous: int
    created: int
    tentative_created: int
    tentative_dropped: int
    capacity: int


class EKFSLAM:
    """EKF-SLAM over 2-D point landmarks seen by range and bearing.

    Args:
        config: the filter's configuration.
        motion: the odometry motion model used for prediction (injected; by default the shared
            model with ``config.motion_noise``).
        initial_pose_w: (3,) pose of the first frame; the origin by default (evaluation aligns).
    """

    name = "ekfslam"

    def __init__(
        self,
        config: EKFSLAMConfig | None = None,
        motion: OdometryMotionModel | None = None,
        initial_pose_w: np.ndarray | None = None,
    ) -> None:
        self.config = EKFSLAMConfig() if config is None else config
        self.motion = OdometryMotionModel(self.config.motion_noise) if motion is None else motion
        self.model = RangeBearing2D()
        start = np.zeros(3) if initial_pose_w is None else np.asarray(initial_pose_w, float)
        start_config = self.config.state
        sigma = np.asarray(start_config.initial_pose_sigma, dtype=float)
        self.state = SlamGaussian(
            start, np.diag(sigma**2), start_config.initial_landmark_capacity, self.model
        )
        association, outlier_gate = self.config.association, self.config.outlier_gate
        self._gate = chi_square_gate(association.gate_probability, 2)
        self._new_gate = chi_square_gate(association.new_landmark_gate_probability, 2)
        self._known_gate = chi_square_gate(outlier_gate.probability, 2)
        self._resightings = GatedResightings(self._known_gate, outlier_gate.votes)
        self._slot_ids: list[int] = []  # landmark id of each state slot
        self._slot_of_id: dict[int, int] = {}
        self._sightings: dict[int, int] = {}  # per slot: its creation and updates by id
        self._next_id = 0
        self._tentative = TentativeLandmarks()
        self._odometer_m = 0.0  # path length of the odometry so far
        self._frames = 0
        self._stamps_s: list[float] = []
        self._poses: list[np.ndarray] = []
        self._pose_covs: list[np.ndarray] = []
        self._counts = dict.fromkeys(
            (
                "sightings",
                "associated",
                "gated",
                "readmitted",
                "ambiguous",
                "created",
                "tentative_created",
                "dropped",
            ),
            0,
        )

    # -- Estimator protocol ---------------------------------------------------------------------

    def step(self, frame: FrameInput) -> None:
        """Predict with the frame's odometry (not for the first frame, which sits at the initial
        pose), update with its range-bearing sightings, add new landmarks."""
        if self._frames > 0:
            odometry = frame.odometry
            self.state.predict(self.motion, odometry.delta, odometry.covariance)
            self._odometer_m += float(np.hypot(*odometry.delta[:2]))
        sightings = frame.range_bearing
        if sightings is not None and len(sightings):
            self._observe(sightings)
        self._counts["dropped"] += self._tentative.drop_stale(
            self._odometer_m, self.config.landmarks.tentative_window_m
        )
        self._frames += 1
        self._stamps_s.append(frame.stamp_s)
        self._poses.append(self.state.pose)
        self._pose_covs.append(self.state.pose_cov)

    def estimate(self) -> Estimate:
        """The filtered pose of every frame (the estimate at that frame, not smoothed) with its
        covariance, and the current map with the landmark covariances (z = 0)."""
        poses = np.asarray(self._poses).reshape(-1, 3)
        n = self.state.n_landmarks
        landmarks_w = np.zeros((n, 3))
        landmarks_w[:, :2] = self.state.landmarks
        covs = np.zeros((n, 3, 3))
        covs[:, :2, :2] = self.state.landmark_covariances()
        return Estimate(
            trajectory=Trajectory.from_se2(np.asarray(self._stamps_s), poses),
            landmark_ids=np.asarray(self._slot_ids, dtype=np.int64),
            landmarks_w=landmarks_w,
            landmark_covariances=covs,
            pose_covariances=np.asarray(self._pose_covs).reshape(-1, 3, 3),
        )

    def info(self) -> EKFSLAMInfo:
        """The counts so far."""
        c = self._counts
        return EKFSLAMInfo(
            landmarks=self.state.n_landmarks,
            tentative=len(self._tentative),
            sightings=c["sightings"],
            associated=c["associated"],
            gated=c["gated"],
            readmitted=c["readmitted"],
            ambiguous=c["ambiguous"],
            created=c["created"],
            tentative_created=c["tentative_created"],
            tentative_dropped=c["dropped"],
            capacity=self.state.capacity,
        )

    # -- one frame's sightings ------------------------------------------------------------------

    def _observe(self, sightings: RangeBearing) -> None:
        state = self.state
        z_all = np.column_stack([sightings.ranges_m, sightings.bearings_rad])
        R_all = np.zeros((len(sightings), 2, 2))
        R_all[:, 0, 0] = sightings.sigma_range_m**2
        R_all[:, 1, 1] = sightings.sigma_bearing_rad**2
        ids = sightings.landmark_ids
        if self.config.association.ignore_ids:
            ids = np.full_like(ids, UNKNOWN_ID)
        self._counts["sightings"] += len(sightings)
        new_known: list[tuple[int, int]] = []  # (row, id) of ids not in the state yet
        unmatched: list[int] = []  # rows of unknown-id sightings outside every gate
        used: set[int] = set()  # state slots updated in this frame (one sighting each)
        unknown_rows: list[int] = []  # sightings of unknown id for the joint test
        for row, landmark_id in enumerate(ids.tolist()):
            z, R = z_all[row], R_all[row]
            if landmark_id != UNKNOWN_ID:
                slot = self._slot_of_id.get(landmark_id)
                if slot is None:
                    if all(landmark_id != other for _, other in new_known):
                        new_known.append((row, landmark_id))
                    continue
                young = self._sightings[slot] < self.config.outlier_gate.mature_sightings
                gate = self._known_gate * (YOUNG_GATE_FACTOR if young else 1.0)
                if state.update(slot, z, R, gate=gate) is None and (
                    young or not self._readmit(slot, landmark_id, z, R)
                ):
                    self._counts["gated"] += 1
                    continue
                self._resightings.seen(landmark_id, self._frames)
                self._sightings[slot] += 1
                self._counts["associated"] += 1
                continue
            if self.config.association.test is AssociationTest.JOINT:
                unknown_rows.append(row)
                continue
            free = np.ones(state.n_landmarks, dtype=bool)
            free[list(used)] = False
            candidates = np.flatnonzero(free)
            d2, _ = state.mahalanobis_all(z, R, candidates)
            best = nearest_gated(d2, self._gate)
            if best is None:
                self._counts["gated"] += 1
                if d2.size and d2.min() <= self._new_gate:
                    self._counts["ambiguous"] += 1
                else:
                    unmatched.append(row)
                continue
            slot = int(candidates[best])
            used.add(slot)
            state.update(slot, z, R)
            self._counts["associated"] += 1
        if unknown_rows:
            unmatched += self._joint_step(unknown_rows, z_all, R_all, used)
        # Passo 3: new landmarks, from the pose corrected by this frame's updates
        for row, landmark_id in new_known:
            self._add_landmark(z_all[row], R_all[row], landmark_id)
        self._tentative_step(unmatched, z_all, R_all)

    def _readmit(self, slot: int, landmark_id: int, z: np.ndarray, R: np.ndarray) -> bool:
        """A sighting with an id the plain outlier gate rejected (its landmark past the young
        stage): held; when enough re-sightings of its landmark agree with it
        (``core.gating.GatedResightings``), the newest updates the state without the gate (the
        earlier ones' poses are gone from a filter's state). A sighting whose implied point
        lies on another landmark is a misread id: never used.

        Returns:
            True when this sighting updated the state.
        """
        point, _, J_z = self.model.inverse(self.state.pose[None], z[None])
        covariance = J_z[0] @ R @ J_z[0].T
        others = np.delete(self.state.landmarks, slot, axis=0)
        if lies_on_a_landmark(point[0], covariance, others, self._known_gate):
            return False
        resighting = Resighting(self._frames, point[0], covariance, None)
        if not self._resightings.offer(landmark_id, resighting):
            return False
        self.state.update(slot, z, R)
        self._counts["readmitted"] += 1
        return True

    def _joint_step(
        self, rows: list[int], z_all: np.ndarray, R_all: np.ndarray, used: set[int]
    ) -> list[int]:
        """The frame's sightings of unknown id by joint compatibility (``association``).

        Candidates: state landmarks not updated by an id this frame whose individual distance
        to some sighting is within 4x the new-landmark gate. PAIRED sightings update the state;
        NEW ones go to the tentative landmarks (returned); AMBIGUOUS and REJECTED are dropped.

        Returns:
            the rows that start or re-observe a tentative landmark.
        """
        state = self.state
        z, R = z_all[rows], R_all[rows]
        free = np.setdiff1d(np.arange(state.n_landmarks), list(used))
        if len(free):
            d2 = np.array([state.mahalanobis_all(z[i], R[i], free)[0] for i in range(len(rows))])
            free = free[d2.min(axis=0) <= 4.0 * self._new_gate]
        if not len(free):
            self._counts["gated"] += len(rows)
            return list(rows)
        cols = np.concatenate([np.arange(3), (3 + 2 * free[:, None] + np.arange(2)).ravel()])
        pairings = frame_pairings(
            state.pose, state.block(cols), state.landmarks[free], z, R, self.model
        )
        association = self.config.association
        result, decisions = decide_on_kept_support(
            pairings,
            association.gate_probability,
            self._gate,
            self._new_gate,
            association.ambiguity_margin,
            association.support_sigma_ratio,
        )
        self._unsupported_loops(decisions, result.assignment, pairings)
        self._displaced_wide(decisions, result, pairings)
        to_tentative: list[int] = []
        for i, row in enumerate(rows):
            if decisions[i] == Decision.PAIRED:
                state.update(int(free[result.assignment[i]]), z[i], R[i])
                self._counts["associated"] += 1
            elif decisions[i] == Decision.NEW:  # outside every gate: a tentative landmark
                self._counts["gated"] += 1
                to_tentative.append(row)
            elif decisions[i] == Decision.AMBIGUOUS:
                self._counts["ambiguous"] += 1
            else:
                self._counts["gated"] += 1
        return to_tentative

    def _unsupported_loops(
        self, decisions: np.ndarray, assignment: np.ndarray, pairings: Pairings
    ) -> None:
        """Mark AMBIGUOUS (in place) the pairings of a frame that would close a loop alone.

        A pairing whose innovation covariance S is wider than the sighting's noise R by more
        than ``experimental.loop_sigma_ratio`` (largest std of R^-1/2 S R^-1/2) pairs the robot
        with a landmark it is no longer tied to (seen long ago, the pose uncertain by metres): its
        gate then holds any landmark within metres, and a sighting or two cannot tell them
        apart. Such a pairing is kept only when the frame's joint hypothesis has at least
        ``experimental.loop_min_pairings`` pairings (1, the default: always).
        """
        experimental = self.config.experimental
        paired = np.flatnonzero(decisions == Decision.PAIRED)
        if len(paired) >= experimental.loop_min_pairings or not len(paired):
            return
        for i in paired:
            if innovation_widening(pairings, i, assignment[i]) > experimental.loop_sigma_ratio:
                decisions[i] = Decision.AMBIGUOUS

    def _displaced_wide(
        self, decisions: np.ndarray, result: JointAssociation, pairings: Pairings
    ) -> None:
        """Mark AMBIGUOUS (in place) the wide pairings that JCBB moved off their sighting's own
        best landmark, or whose landmark another sighting of the frame contests.

        JCBB (Neira & Tardos 2001) takes the hypothesis with the most pairings. With the pose
        uncertain by decimetres and degrees after a gap without sightings, the gates of every
        landmark within a metre or two overlap, and a hypothesis that pairs all of a frame's
        sightings with *another* group of landmarks outnumbers the right one, which pairs one
        sighting and leaves its neighbour new (MR.CLAM robot 2, frame 194: landmarks 19 and 20
        seen together, the map holding one landmark for both, individual D2 0.8 and 1.4; JCBB
        paired them with 17 and 16, D2 5.1 and 4.2, 1.7 m away). A pairing whose innovation is
        wider than its noise by more than ``association.displaced_sigma_ratio``
        (``innovation_widening``) is dropped when its sighting is individually closer (smaller
        D2) to a candidate that no sighting of the hypothesis takes.

        With ``association.contested_sigma_ratio`` the same holds from the landmark's side: a
        pairing wider than that is dropped when another sighting of the frame, left unpaired, is
        within ``association.ambiguity_margin`` of its D2 to the landmark -- the frame does not
        tell which of the two sightings the landmark is (MR.CLAM robot 1, frame 190: sightings of
        landmarks 17 and 18, 0.17 m apart, D2 8.9 and 12.1 to landmark 14, 2 m away; 17 was
        paired).
        """
        association = self.config.association
        displaced_ratio = association.displaced_sigma_ratio
        contested_ratio = association.contested_sigma_ratio
        if not (np.isfinite(displaced_ratio) or np.isfinite(contested_ratio)):
            return
        d2_all = result.individual_d2
        paired = np.flatnonzero(decisions == Decision.PAIRED)
        unpaired = np.flatnonzero(decisions != Decision.PAIRED)
        free = np.ones(pairings.candidates, dtype=bool)
        free[result.assignment[paired]] = False
        for i in paired:
            m = int(result.assignment[i])
            d2 = d2_all[i, m]
            displaced = bool(np.any(free & (d2_all[i] < d2)))
            contested = bool(np.any(d2_all[unpaired, m] < d2 + association.ambiguity_margin))
            if not (displaced or contested):
                continue
            widening = innovation_widening(pairings, i, m)
            if (displaced and widening > displaced_ratio) or (
                contested and widening > contested_ratio
            ):
                decisions[i] = Decision.AMBIGUOUS

    def _tentative_step(self, rows: list[int], z_all: np.ndarray, R_all: np.ndarray) -> None:
        """Match unmatched sightings to tentative landmarks (the tutorial's counter); promote a
        candidate into the state at its N-th sighting."""
        if not rows:
            return
        state = self.state
        pose, P_rr = state.pose, state.pose_cov
        taken: set[int] = set()
        promote: list[tuple[int, int]] = []  # (candidate index, row)
        for row in rows:
            z, R = z_all[row], R_all[row]
            point, J_xr, J_z = self.model.inverse(pose, z)
            cov = J_xr @ P_rr @ J_xr.T + J_z @ R @ J_z.T
            index = self._tentative.match(point, cov, self._gate, taken)
            if index is None:
                if self.config.landmarks.min_sightings <= 1:
                    self._add_landmark(z, R, None)
                    continue
                index = self._tentative.add(point, cov, self._odometer_m)
                self._counts["tentative_created"] += 1
                taken.add(index)
                continue
            taken.add(index)
            if (
                self._tentative.observe(index, point, cov, self._odometer_m)
                >= self.config.landmarks.min_sightings
            ):
                promote.append((index, row))
        for _, row in promote:
            self._add_landmark(z_all[row], R_all[row], None)
        self._tentative.remove([index for index, _ in promote])

    def _add_landmark(self, z: np.ndarray, R: np.ndarray, landmark_id: int | None) -> None:
        slot = self.state.augment(z, R)
        if landmark_id is None:
            while self._next_id in self._slot_of_id:
                self._next_id += 1
            landmark_id = self._next_id
        self._slot_ids.append(int(landmark_id))
        self._slot_of_id[int(landmark_id)] = slot
        self._sightings[slot] = 1
        self._counts["created"] += 1
