"""Loop closure by map matching (``graphslam.loop_closure``): duplicates merged, wrong merges not.

A hand-built graph: the robot sees two landmarks A, B from x0 and x1, drives a loop whose
odometry is weak (one between-factor with 0.5 m / 0.05 rad std, biased by the ``drift``), and
from x2, x3 sees two landmarks it started afresh (A', B'): the local map after the gap. When the
robot really came back to A and B, A' and B' are their duplicates, offset by the drift the
odometry cannot tell; the merger must find and merge them. When the robot sees two other
landmarks whose spacing differs from A-B's, each may be near A or B, but no single correction
explains both: nothing may be merged.
"""

from __future__ import annotations

import numpy as np
import pytest
from graphslam_scenarios import hide_ids, run, simulate_planar

from omnislam.core.measurement import RangeBearing2D
from omnislam.core.modality import Modality
from omnislam.core.se import se2_between, se2_compose
from omnislam.graphslam import GraphSLAM
from omnislam.graphslam import factors as fx
from omnislam.graphslam.builder import LandmarkRegistry
from omnislam.graphslam.config import (
    AssociationConfig,
    ExperimentalConfig,
    GraphSLAMConfig,
    LoopClosureConfig,
    SolverConfig,
)
from omnislam.graphslam.loop_closure import LandmarkMerger
from omnislam.graphslam.range_bearing import CREATED_ID_BASE
from omnislam.graphslam.session import ISAM2Session

gtsam = pytest.importorskip("gtsam")

A, B, A2, B2 = (CREATED_ID_BASE + i for i in range(4))
TRUE_XY = {A: np.array([2.0, 1.0]), B: np.array([2.0, -1.0])}
POSES = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [0.1, 0.2, 0.05], [0.6, 0.1, 0.0]])
SIGHTING_SIGMAS = (0.01, 0.05)  # bearing [rad], range [m]
#: the merged landmarks coincide to this [m] (the merging factor's 1 mm std)
MERGED_TOL_M = 5e-3
#: after the merge the poses beyond the gap are back near the truth [m]
CORRECTED_TOL_M = 0.05

_MODEL = RangeBearing2D()


def _graph(
    seen_after_gap: dict[int, np.ndarray],
    drift: np.ndarray,
    also_old: bool = False,
    association: dict[str, float] | None = None,
    **loop_closure: float,
):
    """Session, registry and merger with A, B seen before the gap, ``seen_after_gap`` after
    (``association`` and ``loop_closure``: their sections' fields)."""
    config = LoopClosureConfig(enabled=True, **{"every_frames": 1, **loop_closure})
    gates = AssociationConfig(**(association or {}))
    session = ISAM2Session(SolverConfig())
    registry = LandmarkRegistry()
    merger = LandmarkMerger(
        config,
        session,
        registry,
        lambda lid: lid >= CREATED_ID_BASE,
        gate_probability=gates.gate_probability,
        new_landmark_probability=gates.new_landmark_probability,
        ambiguity_margin=gates.ambiguity_margin,
        landmark_sigma_m=gates.landmark_sigma_m,
    )
    graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
    noise = gtsam.noiseModel.Diagonal.Sigmas(np.array(SIGHTING_SIGMAS))
    graph.add(
        gtsam.PriorFactorPose2(
            fx.pose_key(0), gtsam.Pose2(*POSES[0]), gtsam.noiseModel.Isotropic.Sigma(3, 1e-3)
        )
    )
    tight = gtsam.noiseModel.Diagonal.Sigmas(np.array([0.005, 0.005, 0.002]))
    weak = gtsam.noiseModel.Diagonal.Sigmas(np.array([0.5, 0.5, 0.05]))
    guesses = [POSES[0]]
    for k in range(1, len(POSES)):
        delta = se2_between(POSES[k - 1], POSES[k])
        if k == 2:  # the loop: odometry biased by the drift, weakly weighted
            delta = delta + drift
        graph.add(
            gtsam.BetweenFactorPose2(
                fx.pose_key(k - 1), fx.pose_key(k), gtsam.Pose2(*delta), tight if k != 2 else weak
            )
        )
        guesses.append(se2_compose(guesses[-1], delta))
    for k, guess in enumerate(guesses):
        values.insert(fx.pose_key(k), gtsam.Pose2(*guess))
    sightings = {
        0: dict(TRUE_XY),
        1: dict(TRUE_XY),
        2: dict(seen_after_gap),
        3: dict(seen_after_gap),
    }
    if also_old:  # x3 also sees the old A
        sightings[3][A] = TRUE_XY[A]
    for k, seen in sightings.items():
        for lid, xy in seen.items():
            r, b = _MODEL.predict(POSES[k], xy)[0]
            graph.add(fx.bearing_range_2d(k, lid, b, r, noise))
            merger.seen(lid, k)
            if lid not in registry:
                point = _MODEL.inverse(guesses[k], np.array([r, b]))[0]
                values.insert(fx.landmark_key(lid), gtsam.Point2(point))
                registry.add(lid, point)
    session.update(graph, values, 0)
    return session, registry, merger


def _check(session, merger, k: int = 4):
    graph = gtsam.NonlinearFactorGraph()
    merges = merger.check(k, graph)
    session.update(graph, gtsam.Values(), k)
    return merges


def test_duplicates_of_a_revisited_place_are_merged_and_the_drift_corrected():
    drift = np.array([0.4, 0.3, 0.0])
    session, registry, merger = _graph({A2: TRUE_XY[A], B2: TRUE_XY[B]}, drift)
    before = session.point2(fx.landmark_key(A2))
    assert np.hypot(*(before - TRUE_XY[A])) > 0.3  # the duplicate sits where the drift put it
    merges = _check(session, merger)
    assert {(m.duplicate, m.kept) for m in merges} == {(A2, A), (B2, B)}
    assert merger.merged == 2 and merger.loop_closures == 1
    for dup, kept in ((A2, A), (B2, B)):
        assert not registry.active(dup) and registry.active(kept)
        assert registry.resolve(dup) == kept
        dup_xy, kept_xy = (session.point2(fx.landmark_key(i)) for i in (dup, kept))
        assert np.hypot(*(dup_xy - kept_xy)) < MERGED_TOL_M
    x2 = session.pose2(fx.pose_key(2))
    assert np.hypot(x2.x() - POSES[2, 0], x2.y() - POSES[2, 1]) < CORRECTED_TOL_M


def test_a_local_map_that_no_single_correction_explains_is_not_merged():
    # two other landmarks, 2.6 m apart instead of A-B's 2 m: each is within the loop's
    # uncertainty of A or B, but not both with one shift
    other = {A2: np.array([2.0, 1.3]), B2: np.array([2.0, -1.3])}
    session, registry, merger = _graph(other, np.zeros(3))
    assert _check(session, merger) == []
    assert merger.merged == 0 and registry.active(A2) and registry.active(B2)
    # each alone is compatible: accepting the best single pairing would merge one wrongly
    session, registry, merger = _graph(
        other, np.zeros(3), association={"ambiguity_margin": 0.0}, min_landmarks=1
    )
    assert len(_check(session, merger)) == 1


def test_one_pairing_is_not_enough_and_landmarks_seen_together_stay_apart():
    # x3 sees A and A' in one frame: they are two landmarks, which leaves B' -> B alone
    drift = np.array([0.4, 0.3, 0.0])
    session, registry, merger = _graph({A2: TRUE_XY[A], B2: TRUE_XY[B]}, drift, also_old=True)
    assert _check(session, merger) == []
    assert registry.active(A2) and registry.active(B2)
    session, registry, merger = _graph(
        {A2: TRUE_XY[A], B2: TRUE_XY[B]}, drift, also_old=True, min_landmarks=1
    )
    assert [(m.duplicate, m.kept) for m in _check(session, merger)] == [(B2, B)]


def test_the_reach_grows_with_the_local_landmarks_own_spread():
    """With a landmark std of 5 cm the fixed part of the reach, sqrt(4 chi2_2(0.9999)) 0.05 =
    0.43 m, is short of the duplicates' 0.5 m offset: the reach's 2 x spread term (the weak
    loop step's 0.5 m std) is what lets them be found, and merged."""
    drift = np.array([0.4, 0.3, 0.0])
    session, _, merger = _graph(
        {A2: TRUE_XY[A], B2: TRUE_XY[B]}, drift, association={"landmark_sigma_m": 0.05}
    )
    assert {(m.duplicate, m.kept) for m in _check(session, merger)} == {(A2, A), (B2, B)}


def test_the_local_map_is_matched_every_few_frames_and_holds_recent_landmarks_only():
    drift = np.array([0.4, 0.3, 0.0])
    seen = {A2: TRUE_XY[A], B2: TRUE_XY[B]}
    session, _, merger = _graph(seen, drift, every_frames=2)
    assert _check(session, merger) == [] and merger.checks == 0  # first call: no match
    assert len(_check(session, merger, 5)) == 2 and merger.checks == 1
    # A', B' last seen in frame 3: outside a 5-frame window at frame 9, inside at frame 8
    session, _, merger = _graph(seen, drift, window_frames=5)
    assert _check(session, merger, 9) == [] and merger.checks == 0
    assert len(_check(session, merger, 8)) == 2


def test_a_merged_landmark_carries_on_with_the_duplicates_frames():
    """After A' -> A: A' 's frames (2, 3) count as A's (landmarks seen with A' were seen with
    A), its last sighting is A's, and a later sighting of A' is recorded for A."""
    drift = np.array([0.4, 0.3, 0.0])
    session, _, merger = _graph({A2: TRUE_XY[A], B2: TRUE_XY[B]}, drift)
    _check(session, merger)
    assert merger._frames[A] == {0, 1, 2, 3} and merger._last_seen[A] == 3
    merger.seen(A2, 7)
    assert 7 in merger._frames[A] and merger._last_seen[A] == 7 and A2 not in merger._frames


def test_landmarks_with_given_ids_are_never_merged():
    drift = np.array([0.4, 0.3, 0.0])
    session, _, merger = _graph({A2: TRUE_XY[A], B2: TRUE_XY[B]}, drift)
    merger._is_created = lambda lid: False  # as if every id had been given
    assert _check(session, merger) == []


def test_on_a_clean_loop_nothing_distinct_is_merged_and_retired_landmarks_leave_the_map(rng):
    scenario = simulate_planar(rng)
    frames = hide_ids(scenario.frames)
    closing = ExperimentalConfig(loop_closure=LoopClosureConfig(enabled=True))
    with_closure = GraphSLAM(Modality.RANGE_BEARING_2D, GraphSLAMConfig(experimental=closing))
    estimate = run(with_closure, frames)
    without = run(GraphSLAM(Modality.RANGE_BEARING_2D, GraphSLAMConfig()), frames)
    info = with_closure.info()
    # the association closes this loop itself: no duplicates, so nothing may be merged
    assert info.landmarks_merged == 0 and info.loop_closures == 0
    assert len(estimate.landmark_ids) == len(without.landmark_ids) == info.landmarks
    # a retired landmark keeps its variable but leaves the exported map
    builder = with_closure._graph
    kept, retired = (int(i) for i in estimate.landmark_ids[:2])
    builder._registry.retire(retired, kept)
    after = with_closure.estimate()
    assert retired not in after.landmark_ids.tolist()
    assert len(after.landmark_ids) == len(after.landmarks_w) == len(estimate.landmark_ids) - 1
    rows = [estimate.landmark_ids.tolist().index(i) for i in after.landmark_ids.tolist()]
    np.testing.assert_allclose(after.landmarks_w, estimate.landmarks_w[rows])
