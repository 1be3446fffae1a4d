"""Batch re-association of unlabelled range-bearing sightings (``graphslam/reassociation.py``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

gtsam = pytest.importorskip("gtsam")
from gtsam.symbol_shorthand import L, X  # noqa: E402

from omnislam.graphslam.levenberg_marquardt import optimize_batch  # noqa: E402
from omnislam.graphslam.range_bearing import CREATED_ID_BASE  # noqa: E402
from omnislam.graphslam.reassociation import reassociate, squared_distances  # noqa: E402

A, B, C = (L(CREATED_ID_BASE + i) for i in range(3))
TRUE = {A: np.array([3.0, 0.0]), B: np.array([3.0, 0.2]), C: np.array([0.0, 5.0])}
POSES = [np.array([0.0, 0.0, 0.0]), np.array([0.5, 0.0, 0.0]), np.array([1.0, -0.2, 0.1])]
SIGMAS = np.array([0.005, 0.02])  # (bearing rad, range m)
GATE = 9.21


def sighting(frame: int, landmark: int, seen: int) -> object:
    """A noiseless sighting of landmark ``seen`` from pose ``frame``, given to ``landmark``."""
    x, y, th = POSES[frame]
    d = TRUE[seen] - [x, y]
    bearing, rng = np.arctan2(d[1], d[0]) - th, np.hypot(*d)
    noise = gtsam.noiseModel.Diagonal.Sigmas(SIGMAS)
    return gtsam.BearingRangeFactor2D(X(frame), landmark, gtsam.Rot2(bearing), rng, noise)


def problem(assignments: list[tuple[int, int, int]]) -> tuple[object, object]:
    """Poses held by tight priors, the sightings (frame, given to, really of), and values with
    every landmark 5 cm off its true position."""
    graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
    prior = gtsam.noiseModel.Diagonal.Sigmas(np.array([1e-4, 1e-4, 1e-5]))
    for k, p in enumerate(POSES):
        graph.add(gtsam.PriorFactorPose2(X(k), gtsam.Pose2(*p), prior))
        values.insert(X(k), gtsam.Pose2(*p))
    for frame, given, seen in assignments:
        graph.add(sighting(frame, given, seen))
    for key in {given for _, given, _ in assignments}:
        values.insert(key, gtsam.Point2(TRUE[key] + 0.05))
    return graph, values


def lm(graph, values):
    return optimize_batch(graph, values).values


def landmark_of(graph, frame: int, row: int) -> int:
    """The landmark key of the ``row``-th range-bearing factor on pose ``frame``."""
    found = [
        graph.at(i).keys()[1]
        for i in range(graph.size())
        if isinstance(graph.at(i), gtsam.BearingRangeFactor2D) and graph.at(i).keys()[0] == X(frame)
    ]
    return found[row]


def test_a_sighting_given_to_the_neighbour_moves_back_and_the_map_is_exact():
    # frame 0 sees A and B; frames 1 and 2 see B, but the sighting was given to A
    graph, values = problem([(0, A, A), (0, B, B), (1, A, B), (2, A, B), (2, C, C), (1, C, C)])
    start = lm(graph, values)
    assert np.linalg.norm(start.atPoint2(A) - TRUE[A]) > 0.02  # A pulled towards B
    out = reassociate(graph, start, lambda key: True, GATE, 3, lm)
    assert out.moved == 2 and out.rounds == 2  # the second round moved nothing
    assert landmark_of(out.graph, 1, 0) == B and landmark_of(out.graph, 2, 0) == B
    for key in (A, B, C):
        np.testing.assert_allclose(out.values.atPoint2(key), TRUE[key], atol=1e-6)
    assert out.graph.error(out.values) < 1e-8 < graph.error(start)


def exact(graph) -> object:
    """Values at the truth: every pose and every landmark the graph names."""
    values = gtsam.Values()
    for k, p in enumerate(POSES):
        values.insert(X(k), gtsam.Pose2(*p))
    for i in range(graph.size()):
        key = graph.at(i).keys()[-1]
        if key in TRUE and not values.exists(key):
            values.insert(key, gtsam.Point2(TRUE[key]))
    return values


def test_a_landmark_keeps_its_last_sighting():
    # C's only sighting is really of B: moving it to B would leave C without a sighting
    graph, _ = problem([(0, A, A), (0, B, B), (1, C, B)])
    values = exact(graph)
    assert squared_distances(values, [_row(graph, 5)], [B, C])[0, 0] < 1e-12  # it fits B
    out = reassociate(graph, values, lambda key: True, GATE, 3, lm)
    assert landmark_of(out.graph, 1, 0) == C and out.moved == 0
    assert out.graph is graph and out.values is values


def test_landmarks_that_are_not_movable_neither_give_nor_take_sightings():
    # frame 1's sighting of A was given to B, frame 2's of B to A; B is not movable
    graph, _ = problem([(0, A, A), (0, B, B), (1, B, A), (2, A, B)])
    out = reassociate(graph, exact(graph), lambda key: key != B, GATE, 3, lm)
    assert landmark_of(out.graph, 1, 0) == B and landmark_of(out.graph, 2, 0) == A
    assert out.moved == 0


def _row(graph, index: int) -> object:
    """A factor as the ``squared_distances`` row it becomes."""
    f = graph.at(index)
    return type("Row", (), {"pose": f.keys()[0], "bearing_rad": f.measured().bearing().theta(),
                            "range_m": f.measured().range(), "sigmas": SIGMAS})()  # fmt: skip


def test_one_frame_gives_a_landmark_at_most_one_sighting():
    # frame 1 sees A and B, both given to A: the assignment splits them
    graph, values = problem([(0, A, A), (0, B, B), (1, A, A), (1, A, B)])
    out = reassociate(graph, lm(graph, values), lambda key: True, GATE, 3, lm)
    assert {landmark_of(out.graph, 1, 0), landmark_of(out.graph, 1, 1)} == {A, B}
    assert out.moved == 1


def test_squared_distances_are_the_factors_own_whitened_error():
    graph, values = problem([(2, A, A), (2, B, B)])
    values = lm(graph, values)
    d2 = squared_distances(values, [_row(graph, 3), _row(graph, 4)], [A, B])
    for r, f in enumerate((graph.at(3), graph.at(4))):
        for c, key in enumerate((A, B)):
            moved = gtsam.BearingRangeFactor2D(X(2), key, f.measured().bearing(),
                                               f.measured().range(), f.noiseModel())  # fmt: skip
            assert d2[r, c] == pytest.approx(2 * moved.error(values), rel=1e-9, abs=1e-12)


def test_a_sighting_outside_every_gate_stays_where_it_is():
    """Frame 1's sighting, given to A, is of a point 0.3 m beside B: B is the nearest landmark
    but, at 0.005 rad and 2 cm, far outside the 2-dof gate; nothing moves."""
    graph, _ = problem([(0, A, A), (0, B, B), (2, A, A)])
    x, y, th = POSES[1]
    d = TRUE[B] + [0.0, 0.3] - [x, y]
    noise = gtsam.noiseModel.Diagonal.Sigmas(SIGMAS)
    bearing = gtsam.Rot2(np.arctan2(d[1], d[0]) - th)
    graph.add(gtsam.BearingRangeFactor2D(X(1), A, bearing, np.hypot(*d), noise))
    values = exact(graph)
    d2 = squared_distances(values, [_row(graph, 6)], [A, B])[0]
    assert d2[1] < d2[0] and d2[1] > GATE
    out = reassociate(graph, values, lambda key: True, GATE, 3, lm)
    assert out.moved == 0 and landmark_of(out.graph, 1, 0) == A


def test_a_landmark_that_took_a_sighting_may_give_its_own_in_the_same_round():
    """Frame 1's sighting of B was given to A, frame 2's of C to B (B's only one): B takes
    frame 1's first, so it may give frame 2's to C in the same round: one round moves both and
    the second moves nothing."""
    graph, _ = problem([(0, A, A), (0, C, C), (1, A, B), (2, B, C)])
    out = reassociate(graph, exact(graph), lambda key: True, GATE, 3, lm)
    assert out.moved == 2 and out.rounds == 2
    assert landmark_of(out.graph, 1, 0) == B and landmark_of(out.graph, 2, 0) == C


def test_robust_sightings_are_gated_by_their_gaussian_sigmas():
    graph, _ = problem([(0, A, A), (0, B, B), (2, A, A)])
    x, y, th = POSES[1]
    d = TRUE[B] - [x, y]
    huber = gtsam.noiseModel.mEstimator.Huber.Create(1.345)
    noise = gtsam.noiseModel.Robust.Create(huber, gtsam.noiseModel.Diagonal.Sigmas(SIGMAS))
    bearing = gtsam.Rot2(np.arctan2(d[1], d[0]) - th)
    graph.add(gtsam.BearingRangeFactor2D(X(1), A, bearing, np.hypot(*d), noise))
    out = reassociate(graph, exact(graph), lambda key: True, GATE, 3, lm)
    assert out.moved == 1 and landmark_of(out.graph, 1, 0) == B


DATASET6 = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "mrclam"


@pytest.mark.slow
@pytest.mark.skipif(not (DATASET6 / "MRCLAM_Dataset6").is_dir(), reason="no MR.CLAM data")
def test_mrclam_robot1_without_ids_gains_and_with_ids_nothing_moves(monkeypatch):
    """Robot 1 without ids: the batch optimum 0.095 m, re-associated 0.084 m (with ids: 0.061 m)."""
    from omnislam.harness.evaluation import evaluate_run
    from omnislam.harness.execute import RunSpec, execute_run

    monkeypatch.setenv("OMNISLAM_DATA", str(DATASET6.parent))

    def ate(options: dict[str, str]) -> tuple[float, dict]:
        record = execute_run(RunSpec("mrclam6-r1", "graphslam-batch", 0, options))
        import json

        info = json.loads(record.attachments["estimator_info.json"])
        return evaluate_run(record).ate.rmse_m, info

    plain, _ = ate({"association": "unknown"})
    again, info = ate({"association": "unknown", "experimental.batch_reassociation_rounds": "3"})
    assert info["sightings_reassociated"] > 0
    assert again < plain - 0.005
    with_ids, _ = ate({})
    same, info = ate({"experimental.batch_reassociation_rounds": "3"})
    assert info["sightings_reassociated"] == 0 and same == with_ids
