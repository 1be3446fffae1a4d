"""Joint compatibility over a sliding window of frames, for unlabelled range-bearing sightings.

``AssociationTest.JOINT`` (``config.py``). A frame's unlabelled sightings are not associated
when the frame arrives: they wait until ``AssociationConfig.lag_frames`` more frames with
unlabelled sightings have come (or the run ends). Then JCBB (``core.compatibility.jcbb``) runs
over every waiting frame together -- the oldest and the ``lag`` after it -- and the decisions of
the *oldest* frame are kept; the others are decided again, with one more frame, next time.

Why a window: one frame often holds a single sighting (MR.CLAM after a turn, Victoria Park:
~1.1 per frame), and after a stretch of odometry a lone sighting fits several landmarks (MR.CLAM's
stand in groups 0.18 m apart). Sightings of several frames, whose poses the odometry ties together
(their joint covariance from iSAM2 is strongly correlated), constrain the assignment jointly:
swapping two neighbours moves each predicted sighting differently from frame to frame.

The joint state holds the poses of the waiting frames (in iSAM2 already: each was added with its
odometry), the current frame's guess (``joint_state``: propagated from the newest pose) and the
candidate landmarks close enough to matter, with iSAM2's joint marginal of all of them; tentative
landmarks (``tentative.py``) join with their fused covariance, independent of the rest.

Decisions (``core.compatibility.decide``): PAIRED takes the candidate; NEW starts a landmark
(every free candidate beyond the new-landmark gate; a candidate paired with another sighting of
the same frame is not free); AMBIGUOUS (between the gates, or a pairing the runner-up hypothesis
makes differently within ``AssociationConfig.ambiguity_margin``) and REJECTED are dropped.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from omnislam.core.compatibility import Decision, Pairings, decide, jcbb
from omnislam.core.measurement import RangeBearing2D
from omnislam.core.types import RangeBearing
from omnislam.graphslam import factors as fx
from omnislam.graphslam.association import Gates, mahalanobis2, sighting_points
from omnislam.graphslam.builder import LandmarkRegistry
from omnislam.graphslam.config import AssociationConfig
from omnislam.graphslam.joint_state import joint_state
from omnislam.graphslam.session import ISAM2Session
from omnislam.graphslam.tentative import TentativeLandmarks

_MODEL = RangeBearing2D()


@dataclass(frozen=True, slots=True)
class Decided:
    """The association of one frame's unlabelled sightings.

    Attributes:
        k: the frame.
        sightings: its unlabelled sightings.
        candidate_ids: (K,) the landmark each takes (mapped or tentative id), or -1.
        decisions: (K,) ``core.compatibility.Decision`` of each.
    """

    k: int
    sightings: RangeBearing
    candidate_ids: np.ndarray
    decisions: np.ndarray


@dataclass(slots=True)
class _Waiting:
    k: int
    sightings: RangeBearing


class WindowAssociation:
    """Sightings of unknown landmark waiting for ``lag`` later frames, then JCBB over them all.

    Args:
        config: the association's section: gates, lag, ambiguity margin, fixed landmark sigma
            (candidate selection), re-elimination of the candidates.
        session: the iSAM2 session (poses, landmarks and their joint marginal).
        registry: the landmarks in the graph.
        tentative: the tentative landmarks (or None without a tentative stage).
        pose_of: ``pose_of(k)`` the current estimate (3,) of an earlier frame's pose.
    """

    def __init__(
        self,
        config: AssociationConfig,
        session: ISAM2Session,
        registry: LandmarkRegistry,
        tentative: TentativeLandmarks | None,
        pose_of: Callable[[int], np.ndarray],
    ) -> None:
        self._config = config
        self._session = session
        self._registry = registry
        self._tentative = tentative
        self._pose_of = pose_of
        self._gates = Gates.from_probabilities(
            config.gate_probability, config.new_landmark_probability
        )
        self._waiting: list[_Waiting] = []
        self.incomplete_searches = 0

    def __len__(self) -> int:
        return len(self._waiting)

    def push(
        self,
        k: int,
        sightings: RangeBearing,
        guess_w: np.ndarray,
        odometry_step: tuple[int, np.ndarray, np.ndarray],
    ) -> list[Decided]:
        """Queue frame k's unlabelled sightings; returns the frames decided now (oldest first).

        Args:
            k: the frame being added (its pose is not in iSAM2 yet).
            sightings: its unlabelled sightings (non-empty).
            guess_w: (3,) its pose guess.
            odometry_step: (newest key frame, delta, Q): the guess is that key frame's
                estimate composed with delta (``PoseChain.odometry_step``).
        """
        self._waiting.append(_Waiting(k, sightings))
        decided = []
        while len(self._waiting) > self._config.lag_frames:
            decided.append(self._decide_oldest((k, guess_w, *odometry_step)))
        return decided

    def flush(self) -> list[Decided]:
        """Decide every waiting frame (all poses are in iSAM2: after the frame's update)."""
        decided = []
        while self._waiting:
            decided.append(self._decide_oldest(None))
        return decided

    def _decide_oldest(
        self, newest: tuple[int, np.ndarray, int, np.ndarray, np.ndarray] | None
    ) -> Decided:
        """JCBB over every waiting frame; returns (and forgets) the oldest frame's decisions."""
        waiting = self._waiting
        oldest = waiting[0]
        k_new = None if newest is None else newest[0]
        poses = [
            newest[1] if w.k == k_new else self._pose_of(w.k)  # type: ignore[index]
            for w in waiting
        ]
        groups = np.concatenate(
            [np.full(len(w.sightings), i, dtype=np.int64) for i, w in enumerate(waiting)]
        )
        z = np.concatenate(
            [np.column_stack([w.sightings.ranges_m, w.sightings.bearings_rad]) for w in waiting]
        )
        R = np.zeros((len(z), 2, 2))
        R[:, 0, 0] = np.concatenate([w.sightings.sigma_range_m for w in waiting]) ** 2
        R[:, 1, 1] = np.concatenate([w.sightings.sigma_bearing_rad for w in waiting]) ** 2
        key_from = None if newest is None else newest[2]
        mapped, tentative = self._candidates(waiting, poses, z, R, k_new, key_from)
        if self._config.reorder_candidates and mapped:
            self._session.reeliminate_next(fx.landmark_key(i) for i in mapped)
        n_old = len(oldest.sightings)
        if not mapped and not tentative:
            decisions = np.full(n_old, Decision.NEW, dtype=np.int64)
            waiting.pop(0)
            return Decided(oldest.k, oldest.sightings, np.full(n_old, -1), decisions)
        frames_in_graph = [w.k for w in waiting if w.k != k_new]
        step = None if newest is None else (newest[0], newest[2], newest[3], newest[4])
        state = joint_state(self._session, frames_in_graph, mapped, step)
        n0 = state.dim
        P = np.zeros((n0 + 2 * len(tentative), n0 + 2 * len(tentative)))
        P[:n0, :n0] = state.covariance
        xy = [state.landmark(i) for i in mapped]
        columns = [state.landmark_column[i] for i in mapped]
        if tentative:
            tentative_ids, tentative_xy, tentative_covs = self._tentative.candidates()  # type: ignore[union-attr]
            row_of = {int(i): r for r, i in enumerate(tentative_ids.tolist())}
            for t, lid in enumerate(tentative):
                c = n0 + 2 * t
                P[c : c + 2, c : c + 2] = tentative_covs[row_of[lid]]
                xy.append(tentative_xy[row_of[lid]])
                columns.append(c)
        xy_arr = np.asarray(xy).reshape(-1, 2)
        K, M, n = len(z), len(xy_arr), len(P)
        nu = np.zeros((K, M, 2))
        H = np.zeros((K, M, 2, n))
        row = 0
        for w in waiting:
            pose = state.pose(w.k)
            pose_col = state.pose_column[w.k]
            z_hat, H_r, H_l = _MODEL.predict(np.broadcast_to(pose, (M, 3)), xy_arr)
            rows = slice(row, row + len(w.sightings))
            nu[rows] = _MODEL.residual(z[rows, None, :], z_hat[None, :, :])
            H[rows, :, :, pose_col : pose_col + 3] = H_r[None]
            for m, c in enumerate(columns):
                H[rows, m, :, c : c + 2] = H_l[m]
            row += len(w.sightings)
        result = jcbb(Pairings(nu, H, P, R, groups), self._config.gate_probability)
        self.incomplete_searches += int(not result.complete)
        decisions = decide(
            result,
            groups,
            self._gates.match,
            self._gates.new_landmark,
            self._config.ambiguity_margin,
        )[:n_old]
        ids = [*mapped, *tentative]
        candidate_ids = np.array(
            [ids[int(a)] if a >= 0 else -1 for a in result.assignment[:n_old]], dtype=np.int64
        )
        candidate_ids[decisions != Decision.PAIRED] = -1
        waiting.pop(0)
        return Decided(oldest.k, oldest.sightings, candidate_ids, decisions)

    def _candidates(
        self,
        waiting: list[_Waiting],
        poses: list[np.ndarray],
        z: np.ndarray,
        R: np.ndarray,
        k_new: int | None,
        key_from: int | None,
    ) -> tuple[list[int], list[int]]:
        """Mapped and tentative landmarks some waiting sighting could match (loose test).

        A landmark is kept when the squared distance of some sighting's world point to it --
        with the sighting noise, the newest estimated pose's marginal and the fixed landmark
        sigma -- is within 4x the new-landmark gate (as for the NEAREST test's landmark marginals).
        Positions of the mapped ones near the window are refreshed from iSAM2.
        """
        config = self._config
        newest_in_graph = max((w.k for w in waiting if w.k != k_new), default=None)
        if newest_in_graph is None and k_new is not None and k_new > 0:
            newest_in_graph = key_from  # the key frame the guess was composed from
        pose_cov = None
        if newest_in_graph is not None and self._session.exists(fx.pose_key(newest_in_graph)):
            marginal = self._session.marginal_covariance(fx.pose_key(newest_in_graph))
            c, s = np.cos(poses[-1][2]), np.sin(poses[-1][2])
            A = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
            pose_cov = A @ marginal @ A.T
        points, covs = [], []
        row = 0
        for w, pose in zip(waiting, poses, strict=True):
            n = len(w.sightings)
            p, c = sighting_points(
                pose,
                z[row : row + n, 0],
                z[row : row + n, 1],
                np.sqrt(R[row : row + n, 0, 0]),
                np.sqrt(R[row : row + n, 1, 1]),
                pose_cov,
            )
            points.append(p)
            covs.append(c)
            row += n
        points_w, covs_w = np.concatenate(points), np.concatenate(covs)
        loose = 4.0 * self._gates.new_landmark
        mapped: list[int] = []
        cached = self._registry.xy
        if len(cached):
            reach = float(np.max(z[:, 0])) + 3.0 * np.sqrt(loose) * (
                config.landmark_sigma_m
                + np.sqrt(np.linalg.eigvalsh(covs_w)[:, -1].max())
            )
            centres = np.asarray(poses)[:, :2]
            dist = np.min(
                np.hypot(*(cached[:, None, :] - centres[None, :, :]).transpose(2, 0, 1)), axis=1
            )
            near = np.flatnonzero(dist <= reach)
            for r in near.tolist():
                key = fx.landmark_key(self._registry.id_at(r))
                if self._session.exists(key):
                    cached[r] = self._session.point2(key)
            if len(near):
                sigma2 = config.landmark_sigma_m**2
                fixed = np.broadcast_to(sigma2 * np.eye(2), (len(near), 2, 2))
                d2 = mahalanobis2(points_w, covs_w, cached[near], fixed)
                close = near[d2.min(axis=0) <= loose]
                mapped = [self._registry.id_at(int(r)) for r in close]
                mapped = [
                    i
                    for i in mapped
                    if self._registry.active(i) and self._session.exists(fx.landmark_key(i))
                ]
        tentative: list[int] = []
        if self._tentative is not None and len(self._tentative):
            ids, xy, tcovs = self._tentative.candidates()
            d2 = mahalanobis2(points_w, covs_w, xy, tcovs)
            tentative = [int(i) for i, d in zip(ids, d2.min(axis=0), strict=True) if d <= loose]
        return mapped, tentative
