"""The pose spread since a landmark's last sighting (``fastslam/resighting.py``) and the
association that uses it (``association.maximum_likelihood_association``)."""

from __future__ import annotations

import numpy as np
import pytest

from omnislam.core.gating import chi_square_gate
from omnislam.core.measurement import RangeBearing2D
from omnislam.core.motion import MotionNoise, OdometryMotionModel, compose_odometry
from omnislam.fastslam.association import NEW_LANDMARK, maximum_likelihood_association
from omnislam.fastslam.config import AssociationConfig
from omnislam.fastslam.resighting import ResightingSpread


def _rotation(theta: float) -> np.ndarray:
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _steps(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """n odometry deltas of a curving path and their alpha-model covariances."""
    motion = OdometryMotionModel(MotionNoise())
    deltas = np.column_stack(
        [rng.uniform(0.05, 0.3, n), rng.normal(0.0, 0.01, n), rng.normal(0.05, 0.1, n)]
    )
    return deltas, np.array([motion.covariance(d) for d in deltas])


def test_the_running_sum_equals_composing_the_gap_step_by_step():
    """The prefix-sum form gives, for any slot, the covariance that composing the odometry of
    the steps since its sighting gives (``core.motion.compose_odometry``), turned from the frame
    of the sighting's pose into the current robot frame."""
    deltas, covs = _steps(np.random.default_rng(4), 60)
    spread = ResightingSpread()
    seen_at = {0: 0, 1: 17, 2: 41}
    headings = [0.0]
    for t, (d, c) in enumerate(zip(deltas, covs, strict=True)):
        spread.advance(d, c)
        headings.append(spread.pose[2])
        for slot, k in seen_at.items():
            if k == t + 1:
                spread.seen(np.array([slot]))
    got = spread.robot_frame(np.array([1, 2, 7]))
    for row, slot in enumerate((1, 2)):
        k = seen_at[slot]
        delta, cov = np.zeros(3), np.zeros((3, 3))
        for d, c in zip(deltas[k:], covs[k:], strict=True):
            delta, cov = compose_odometry(delta, cov, d, c)
        turn = _rotation(headings[k] - headings[-1])
        np.testing.assert_allclose(got[row], turn @ cov @ turn.T, rtol=1e-9, atol=1e-15)
    # a slot never seen has no spread
    np.testing.assert_array_equal(got[2], np.zeros((3, 3)))


def test_a_slot_seen_now_has_no_spread_and_the_scale_multiplies():
    deltas, covs = _steps(np.random.default_rng(5), 20)
    one, three = ResightingSpread(1.0), ResightingSpread(3.0)
    for spread in (one, three):
        spread.seen(np.array([0, 1]))
        for d, c in zip(deltas, covs, strict=True):
            spread.advance(d, c)
        spread.seen(np.array([1]))
    a, b = one.robot_frame(np.array([0, 1])), three.robot_frame(np.array([0, 1]))
    assert np.trace(a[0]) > 0
    np.testing.assert_allclose(b[0], 3.0 * a[0])
    np.testing.assert_array_equal(a[1], np.zeros((3, 3)))
    # the world frame of a particle turned by pi/2 rotates the position block
    world = one.world_frame(np.array([0]), np.array([one.pose[2] + np.pi / 2]))[0, 0]
    turn = _rotation(one.pose[2] + np.pi / 2)
    np.testing.assert_allclose(world, turn @ a[0] @ turn.T, atol=1e-15)


def _resighting(pose_error_rad: float):
    """One particle whose heading drifted by ``pose_error_rad`` sees a landmark 4 m ahead that
    its map holds exactly: the sighting's bearing is off by the drift."""
    model = RangeBearing2D()
    pose = np.array([[0.0, 0.0, pose_error_rad]])
    mean = np.array([[[4.0, 0.0]]])
    cov = np.array([[np.diag([1e-4, 1e-4])]])
    z = np.array([[4.0, 0.0]])
    R = np.array([np.diag([0.06**2, 0.011**2])])
    return model, pose, mean, cov, z, R


@pytest.mark.parametrize("gate", [None, chi_square_gate(0.999, 2)])
def test_the_spread_keeps_a_drifted_resighting_on_its_landmark(gate):
    """8 deg of heading drift since the sighting: without the spread the landmark is 12 sigma
    off and a new landmark starts; with a heading spread of 0.1 rad it is the same landmark."""
    model, pose, mean, cov, z, R = _resighting(np.radians(8.0))
    valid = np.ones((1, 1), dtype=bool)
    choice, _ = maximum_likelihood_association(
        pose, None, mean, cov, valid, z, R, model, -6.0, gate=gate
    )
    assert choice[0, 0] == NEW_LANDMARK
    spread = np.diag([1e-4, 1e-4, 0.1**2])[None, None]  # (P, C, 3, 3)
    choice, _ = maximum_likelihood_association(
        pose, spread, mean, cov, valid, z, R, model, -6.0, gate=gate
    )
    assert choice[0, 0] == 0


def test_the_gate_decides_by_mahalanobis_distance_alone():
    """A very wide spread lowers the best likelihood below p0 by its determinant although the
    innovation is well inside one sigma: p0 starts a new landmark, the chi-square gate keeps
    the landmark."""
    model, pose, mean, cov, z, R = _resighting(np.radians(8.0))
    valid = np.ones((1, 1), dtype=bool)
    wide = np.diag([1e4, 1e4, 1.0])[None, None]
    choice, ll = maximum_likelihood_association(pose, wide, mean, cov, valid, z, R, model, -6.0)
    assert choice[0, 0] == NEW_LANDMARK and ll[0, 0] == -6.0
    choice, ll = maximum_likelihood_association(
        pose, wide, mean, cov, valid, z, R, model, -6.0, gate=chi_square_gate(0.999, 2)
    )
    assert choice[0, 0] == 0 and ll[0, 0] == -6.0


def _random_spd(rng: np.random.Generator, shape: tuple[int, ...], n: int) -> np.ndarray:
    A = rng.normal(0.0, 0.3, (*shape, n, n))
    return A @ np.swapaxes(A, -1, -2) + 0.01 * np.eye(n)


@pytest.mark.parametrize("pose_cov_kind", ["none", "per particle", "per candidate"])
def test_association_log_likelihood_is_the_gaussian_of_the_full_innovation_covariance(
    rng, pose_cov_kind
):
    """log N(z_k; h(x, mu_c), S) with S = H_m Sigma_c H_m^T + H_x P H_x^T + R_k and the
    bearing residual wrapped, entry by entry against scipy's Gaussian (the compiled path is
    tested against this numpy one; dropping the landmark's covariance passed both)."""
    from scipy.stats import multivariate_normal

    from omnislam.fastslam.association import association_log_likelihood

    p, k, c = 3, 2, 4
    model = RangeBearing2D()
    poses = np.column_stack([rng.uniform(-1, 1, (p, 2)), rng.uniform(-np.pi, np.pi, p)])
    mean = rng.uniform(-5, 5, (p, c, 2))
    cov = _random_spd(rng, (p, c), 2)
    valid = np.ones((p, c), dtype=bool)
    valid[1, 2] = False
    z = np.column_stack([rng.uniform(1, 6, k), rng.uniform(-np.pi, np.pi, k)])
    R = _random_spd(rng, (k,), 2) * 0.1
    pose_cov = {
        "none": None,
        "per particle": _random_spd(rng, (p,), 3),
        "per candidate": _random_spd(rng, (p, c), 3),
    }[pose_cov_kind]
    ll, d2 = association_log_likelihood(poses, pose_cov, mean, cov, valid, z, R, model)
    for i in range(p):
        for m in range(c):
            z_hat, H_x, H_m = model.predict(poses[i], mean[i, m])
            S_m = H_m @ cov[i, m] @ H_m.T
            if pose_cov is not None:
                P = pose_cov[i] if pose_cov.ndim == 3 else pose_cov[i, m]
                S_m = S_m + H_x @ P @ H_x.T
            for j in range(k):
                if not valid[i, m]:
                    assert ll[i, j, m] == -np.inf and d2[i, j, m] == np.inf
                    continue
                y = model.residual(z[j], z_hat)
                S = S_m + R[j]
                expected = multivariate_normal(np.zeros(2), S).logpdf(y)
                assert ll[i, j, m] == pytest.approx(expected, rel=1e-10, abs=1e-10)
                assert d2[i, j, m] == pytest.approx(y @ np.linalg.solve(S, y), rel=1e-10)


def test_sighting_association_adds_both_spreads_to_the_prediction_about_the_weighted_mean(
    monkeypatch,
):
    """With FastSLAM 2.0's prediction covariance, the filter's pose spread and the resighting
    spread, each candidate's pose term is their sum (P + C_pose + C_gap(c)); the candidates
    are looked up about the weighted mean pose within the farthest sighting plus the margin."""
    from omnislam.fastslam import association
    from omnislam.fastslam.landmark_store import ESTIMATED, LandmarkBlock
    from omnislam.fastslam.sightings import Sightings

    p, c = 2, 3
    candidates = np.array([4, 7, 9])
    looked_up = {}

    class Registry:
        def near(self, center_xy, radius_m):
            looked_up.update(center=center_xy, radius=radius_m)
            return candidates

        def add(self, external_ids, count):
            return np.arange(100, 100 + count)

    class Store:
        def gather(self, particles, slots):
            block = LandmarkBlock.empty(len(particles), 2, 0)
            block.status[:] = ESTIMATED
            return block

    prediction = np.broadcast_to(np.diag([1.0, 2.0, 3.0]), (p, 3, 3)).copy()
    extra = np.diag([10.0, 20.0, 30.0])
    gap = np.arange(p * c)[:, None, None] * np.ones((p * c, 3, 3))
    gap = gap.reshape(p, c, 3, 3)

    class PoseSpreadStub:
        def world_frame(self, n):
            return np.broadcast_to(extra, (n, 3, 3))

    class GapStub:
        def world_frame(self, slots, headings):
            np.testing.assert_array_equal(slots, candidates)
            return gap

    seen = {}

    def capture(poses, pose_cov, *args, **kwargs):
        seen["pose_cov"] = pose_cov
        return np.full((p, 1), association.NEW_LANDMARK), np.zeros((p, 1))

    monkeypatch.setattr(association, "maximum_likelihood_association", capture)
    matcher = association.SightingAssociation(
        Registry(),
        Store(),
        AssociationConfig(new_landmark_log_likelihood=-6.0, margin_m=2.0),
        spread=GapStub(),
        pose_spread=PoseSpreadStub(),
    )
    sightings = Sightings(
        np.array([-1, -1]), np.array([[3.0, 0.0], [5.0, 1.0]]), np.zeros((2, 2, 2))
    )
    poses = np.array([[0.0, 0.0, 0.0], [4.0, 2.0, 0.5]])
    weights = np.array([0.75, 0.25])
    matcher._unknown(sightings, np.array([0]), poses, prediction, weights)
    expected = prediction[:, None] + extra + gap
    np.testing.assert_allclose(seen["pose_cov"], expected)
    np.testing.assert_allclose(looked_up["center"], [1.0, 0.5])
    assert looked_up["radius"] == pytest.approx(3.0 + 2.0)
