"""The fixed-lag smoother's restart with a landmark its window cannot determine (lab40 seed 1)."""

from __future__ import annotations

import numpy as np
import pytest

from omnislam.graphslam import factors as fx
from omnislam.graphslam.config import BatchConfig, LandmarkConfig, SolverConfig
from omnislam.graphslam.session import FixedLagSession

gtsam = pytest.importorskip("gtsam")

LANDMARK = np.array([2.0, 3.0, 1.0])
BEARING_SIGMA_RAD = 1e-3
#: the prior a restart puts on its window's oldest pose (the planar prior's default) [m]
ANCHOR_SIGMA_M = 1e-3


def _pose(k: int) -> np.ndarray:
    return np.array([0.2 * k, 0.0, 0.0])


def _bearing(k: int, landmark_id: int, noise) -> object:
    """The exact bearing of LANDMARK from pose k (sensor frame = body frame, planar pose)."""
    x, y, _ = _pose(k)
    ray = LANDMARK - np.array([x, y, 0.0])
    return fx.bearing_3d(k, landmark_id, ray / np.linalg.norm(ray), noise)


def _chain_step(k: int, noise) -> tuple[object, object]:
    """Pose k of the straight chain: its variable, and the prior (k = 0) or the odometry from
    pose k - 1, both exact."""
    graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
    pose = fx.pose3_planar(_pose(k))
    values.insert(fx.pose_key(k), pose)
    if k == 0:
        graph.add(gtsam.PriorFactorPose3(fx.pose_key(0), pose, noise))
    else:
        between = fx.pose3_planar(_pose(k - 1)).between(pose)
        graph.add(gtsam.BetweenFactorPose3(fx.pose_key(k - 1), fx.pose_key(k), between, noise))
    return graph, values


class _FailingAt(FixedLagSession):
    """A session whose smoother fails at one update, as GTSAM's did on lab40 seed 1."""

    def __init__(self, solver: SolverConfig, fail_at: int) -> None:
        super().__init__(solver, BatchConfig(), ANCHOR_SIGMA_M)
        real, outer = self._smoother, self

        class Smoother:
            def update(self, *args):
                if outer._updates == fail_at:
                    raise RuntimeError("Indeterminate linear system detected")
                return real.update(*args)

            def __getattr__(self, name):
                return getattr(real, name)

        self._smoother = Smoother()


def test_a_restart_holds_out_a_landmark_with_one_bearing_in_its_window_and_keeps_it_final():
    """A track inserted long after its first sightings: its bearings from marginalised poses
    go to the full graph only, so the window would hold it by one bearing and the weak 10 m
    prior -- on lab40 seed 1 GTSAM's Cholesky called that indeterminate, in the update and again
    in the restart. The restart leaves it out of the window; the final LM over every factor
    places it from all three bearings."""
    session = _FailingAt(SolverConfig(online_lag_key_frames=3), fail_at=9)
    step = gtsam.noiseModel.Isotropic.Sigma(6, 1e-3)
    bearing_noise = gtsam.noiseModel.Isotropic.Sigma(2, BEARING_SIGMA_RAD)
    for k in range(10):
        graph, values = _chain_step(k, step)
        if k == 9:  # the track's insertion: sighted from poses 1 and 2 long ago, and now
            key = fx.landmark_key(7)
            start = gtsam.Point3(*(LANDMARK + np.array([0.3, -0.2, 0.1])))
            values.insert(key, start)
            weak = gtsam.noiseModel.Isotropic.Sigma(3, LandmarkConfig().prior_sigma_m)
            graph.add(gtsam.PriorFactorPoint3(key, start, weak))
            for j in (1, 2, 9):
                graph.add(_bearing(j, 7, bearing_noise))
        session.update(graph, values, k)
    assert session.online_restarts == 1
    assert session.online_landmarks_held_out == 1
    assert fx.landmark_key(7) not in session._alive  # not in the smoother's window
    final = session.estimate()
    np.testing.assert_allclose(final.atPoint3(fx.landmark_key(7)), LANDMARK, atol=1e-3)
    np.testing.assert_allclose(
        final.atPose3(fx.pose_key(9)).translation(), [1.8, 0.0, 0.0], atol=1e-6
    )


class _Recording(_FailingAt):
    """``_FailingAt`` whose restarted smoothers record the variables of their first update."""

    def __init__(self, solver: SolverConfig, fail_at: int) -> None:
        super().__init__(solver, fail_at)
        self.restart_keys: list[int] = []

    def _new_smoother(self):
        real, outer = super()._new_smoother(), self

        class Smoother:
            def update(self, factors, values, stamps):
                if not outer.restart_keys:
                    outer.restart_keys = [int(k) for k in values.keys()]
                return real.update(factors, values, stamps)

            def __getattr__(self, name):
                return getattr(real, name)

        return Smoother()


def test_a_restart_leaves_out_the_variables_its_update_would_marginalise():
    """The failed update's variables older than the lag are not handed to the restarted
    smoother: marginalising them in its first update failed the same way on GTSAM 4.3
    (campus1500 seed 1, frame 23330, "Asking to remove variables ... not unused"). The run
    goes on, and the final estimate is the chain's."""
    lag, fail_at = 3, 7
    session = _Recording(SolverConfig(online_lag_key_frames=lag), fail_at=fail_at)
    session.restart_keys = [-1]  # the first smoother (built in __init__) records nothing
    step = gtsam.noiseModel.Isotropic.Sigma(6, 1e-3)
    for k in range(10):
        if k == fail_at:
            session.restart_keys = []
        graph, values = _chain_step(k, step)
        session.update(graph, values, k)
    assert session.online_restarts == 1
    kept = sorted(gtsam.Symbol(key).index() for key in session.restart_keys)
    # a pose's time is its newest factor's: pose k - 1 is touched by the odometry to pose k, so
    # at update 7 (lag 3, variables older than 7 - 2.5 leave) pose 3 (time 4) leaves, 4 stays
    assert kept == list(range(fail_at - lag, fail_at + 1))
    final = session.estimate()
    np.testing.assert_allclose(
        final.atPose3(fx.pose_key(9)).translation(), [1.8, 0.0, 0.0], atol=1e-6
    )
