"""The pose UKF: dead reckoning without vision, an EKF on a nearly linear problem, NEES."""

from __future__ import annotations

import math

import numpy as np
import pytest
from tolerances import UKF_DR_FRACTION_OF_SIGMA, UKF_EKF_COV_RTOL, UKF_EKF_MEAN_ATOL

from omnislam.core.measurement import Bearing2D
from omnislam.core.modality import Modality
from omnislam.core.motion import MotionNoise, OdometryMotionModel
from omnislam.core.se import se2_integrate, wrap_angle
from omnislam.core.types import FrameInput, Odometry, PriorMap, RangeBearing
from omnislam.ukf import (
    AssociationConfig,
    FilterConfig,
    SpacingConfig,
    UKFConfig,
    VerticalLineUKF,
)
from omnislam.ukf.filter import PoseUKF, bearing_mean, pose_mean
from omnislam.ukf.image_line import AngularLine

LANDMARKS_W = np.array([[5.0, 5.0], [-5.0, 5.0], [5.0, -5.0], [-5.0, -5.0], [0.0, 8.0]])
MAP = PriorMap(
    source="test",
    landmark_ids=np.arange(len(LANDMARKS_W)),
    points_w=np.column_stack([LANDMARKS_W, np.zeros(len(LANDMARKS_W))]),
    initial_pose_w=np.zeros(3),
)
#: independent simulated runs whose final-pose NEES is averaged (chi-square with 3 x runs dof)
NEES_RUNS = 30


def circle_deltas(n: int) -> np.ndarray:
    return np.tile([0.1, 0.0, 0.05], (n, 1))


def frames(deltas: np.ndarray, sightings=None) -> list[FrameInput]:
    out = []
    for k, d in enumerate(deltas):
        rb = None if sightings is None else sightings[k]
        out.append(FrameInput(k, Odometry(d if k else np.zeros(3), float(k)), range_bearing=rb))
    return out


def localiser(**changes) -> VerticalLineUKF:
    config = UKFConfig(
        spacing=SpacingConfig(d_it_m=0.0), filter=FilterConfig(innovation_gate=None)
    ).with_(**changes)
    return VerticalLineUKF(MAP, config, Modality.RANGE_BEARING_2D, AngularLine(400.0))


def test_circular_means_average_across_the_wrap():
    w = np.array([0.25, 0.25, 0.5])
    poses = np.array([[0, 0, math.pi - 0.1], [0, 0, -math.pi + 0.1], [0, 0, math.pi]])
    assert abs(wrap_angle(pose_mean(poses, w)[2] - math.pi)) < 1e-12
    assert abs(wrap_angle(bearing_mean(poses[:, 2:], w)[0] - math.pi)) < 1e-12


def test_without_vision_the_ukf_follows_dead_reckoning():
    deltas = circle_deltas(200)
    ukf = localiser()
    for frame in frames(deltas):
        ukf.step(frame)
    estimate = ukf.estimate()
    dr = se2_integrate(deltas)
    gap = np.linalg.norm(estimate.trajectory.se2[:, :2] - dr[:, :2], axis=1)
    sigma = np.sqrt(np.trace(estimate.pose_covariances[:, :2, :2], axis1=1, axis2=2))
    assert np.all(gap <= UKF_DR_FRACTION_OF_SIGMA * sigma + 1e-9)
    assert np.allclose(wrap_angle(estimate.trajectory.se2[:, 2] - dr[:, 2]), 0.0, atol=1e-9)
    assert ukf.info().frames_updated == 0


def ekf_step(motion, x, P, delta, z, landmarks, sigma):
    x, P = motion.predict(x, P, delta)
    zh, H, _ = Bearing2D().predict(x, landmarks)
    H = H[:, 0, :]
    S = H @ P @ H.T + sigma**2 * np.eye(len(z))
    K = P @ H.T @ np.linalg.inv(S)
    x = x + K @ wrap_angle(z - zh[:, 0])
    return x, (np.eye(3) - K @ H) @ P


def test_ukf_agrees_with_an_ekf_from_core_jacobians_when_nearly_linear(rng):
    # far landmarks, small uncertainty: the models are linear over the sigma-point spread
    motion = OdometryMotionModel(MotionNoise(1e-3, 1e-4, 1e-4, 1e-3, (1e-5, 1e-5, 1e-5)))
    far = 1000.0 * np.array([[1.0, 0.2], [0.1, 1.0], [-1.0, 0.3]])
    P0 = np.diag([1e-4, 1e-4, 1e-6])
    ukf = PoseUKF(np.zeros(3), P0, motion)
    x, P = np.zeros(3), P0.copy()
    for _ in range(20):
        delta = np.array([0.2, 0.0, 0.01])
        z = wrap_angle(
            Bearing2D().predict(x, far, jacobians=False)[0][:, 0] + rng.normal(0, 1e-3, 3)
        )
        x, P = ekf_step(motion, x, P, delta, z, far, 1e-3)
        ukf.predict(delta)
        ukf.update(z, far, np.full(3, 1e-3))
        assert np.allclose(ukf.x, x, atol=UKF_EKF_MEAN_ATOL)
        assert np.allclose(ukf.P, P, rtol=UKF_EKF_COV_RTOL, atol=1e-12)


def simulate(rng, n=150, sigma=0.01):
    """A circle among landmarks: odometry from the motion model, bearings with ids."""
    motion = OdometryMotionModel(MotionNoise())
    true_deltas = circle_deltas(n)
    true = se2_integrate(true_deltas)
    measured = np.array(
        [np.zeros(3)]
        + [
            # odometry = the truth with the model's noise, so that the filter's Q is right
            motion.recompose(
                2 * motion.decompose(d) - motion.decompose(motion.sample_delta(d, rng))
            )
            for d in true_deltas[1:]
        ]
    )
    sightings = []
    for k in range(n):
        z = Bearing2D().predict(true[k], LANDMARKS_W, jacobians=False)[0][:, 0]
        z = wrap_angle(z + rng.normal(0, sigma, z.shape))
        sightings.append(RangeBearing(MAP.landmark_ids, 1.0, z, 1.0, sigma))
    return measured, sightings, true


def test_pose_nees_of_a_simulated_run_is_in_the_95_percent_band(rng):
    from scipy.stats import chi2

    nees = []
    for _ in range(NEES_RUNS):
        deltas, sightings, true = simulate(rng)
        # the filter's noise is the simulation's (the UKF's own default is 4x larger)
        ukf = localiser(motion_noise=MotionNoise(), association=AssociationConfig(use_ids=True))
        for frame in frames(deltas, sightings):
            ukf.step(frame)
        est = ukf.estimate()
        e = est.trajectory.se2[-1] - true[-1]
        e[2] = wrap_angle(e[2])
        nees.append(float(e @ np.linalg.solve(est.pose_covariances[-1], e)))
    dof = 3 * NEES_RUNS
    low, high = chi2.ppf([0.025, 0.975], dof) / NEES_RUNS
    assert low <= np.mean(nees) <= high, (np.mean(nees), low, high)


@pytest.mark.parametrize("d_it", [0.0, 0.35])
def test_frames_are_processed_every_d_it_of_travel(rng, d_it):
    _, sightings, _ = simulate(rng, n=40)
    deltas = circle_deltas(40)  # exact 0.1 m steps
    # range-bearing frames follow d_it_sightings_m; d_it_m (the images') does not apply
    ukf = localiser(
        spacing=SpacingConfig(d_it_m=0.35 - d_it, d_it_sightings_m=d_it),
        association=AssociationConfig(use_ids=True),
    )
    for frame in frames(deltas, sightings):
        ukf.step(frame)
    processed = [a.index for a in ukf.associations]
    # 0.1 m per frame: every frame, or every 4th (0.4 m >= 0.9 * 0.35 m; 0.3 m is not)
    assert processed == (list(range(40)) if d_it == 0 else list(range(0, 40, 4)))


def test_a_covariance_that_lost_definiteness_in_rounding_is_repaired():
    from omnislam.ukf.filter import positive_definite

    good = np.diag([1e-2, 4e-3, 1e-4])
    assert np.array_equal(positive_definite(good), good)
    v = np.array([1.0, -1.0, 0.0]) / math.sqrt(2.0)
    bad = np.diag([1e-2, 1e-2, 1e-4]) - (1e-2 + 1e-15) * np.outer(v, v)  # eigenvalue -1e-15
    fixed = positive_definite(bad)
    np.linalg.cholesky(fixed)
    assert np.allclose(fixed, bad, atol=1e-11)


def test_a_sighting_far_outside_the_innovation_gate_is_dropped_with_ids(rng):
    # a misread id (MR.CLAM robot 3: 3.0 rad from its landmark's predicted bearing) must not
    # throw the pose; without the gate the unscented update follows it
    deltas, sightings, true = simulate(rng, n=30)
    bad = sightings[20]
    wrong = bad.bearings_rad.copy()
    wrong[0] = wrap_angle(wrong[0] + 3.0)
    sightings[20] = RangeBearing(bad.landmark_ids, 1.0, wrong, 1.0, 0.01)
    errors = {}
    default = FilterConfig().innovation_gate
    for gate in (default, None):
        ukf = localiser(
            filter=FilterConfig(innovation_gate=gate), association=AssociationConfig(use_ids=True)
        )
        for frame in frames(deltas[:21], sightings[:21]):
            ukf.step(frame)
        errors[gate] = float(np.hypot(*(ukf.estimate().trajectory.se2[20, :2] - true[20, :2])))
        if gate is not None:
            assert ukf.info().pairs_gated_out == 1
    assert errors[default] < 0.05 < errors[None]


def test_by_default_ids_are_the_association_where_every_sighting_carries_one(rng):
    from dataclasses import replace

    from omnislam.core.types import UNKNOWN_ID

    deltas, sightings, _ = simulate(rng, n=60)
    hidden = [replace(s, landmark_ids=np.full_like(s.landmark_ids, UNKNOWN_ID)) for s in sightings]

    def run(rb, use_ids):
        ukf = localiser(association=AssociationConfig(use_ids=use_ids))
        for frame in frames(deltas, rb):
            ukf.step(frame)
        return ukf.estimate().trajectory.se2

    # the dataset's own ids (MR.CLAM's barcodes) are used as every other estimator uses them
    np.testing.assert_array_equal(run(sightings, None), run(sightings, True))
    assert not np.array_equal(run(sightings, None), run(sightings, False))
    # hidden ids (a dataset's association=unknown): steps 3-5, as with use_ids=false
    np.testing.assert_array_equal(run(hidden, None), run(hidden, False))


def _ukf_at_heading(theta: float, heading_var: float):
    from omnislam.ukf.filter import PoseUKF

    P = np.diag([1e-4, 1e-4, heading_var])
    return PoseUKF(np.array([0.0, 0.0, theta]), P, OdometryMotionModel(MotionNoise()))


def test_an_update_turning_the_heading_past_pi_wraps_it():
    """Heading pi - 0.005 (variance 0.01) and a bearing 0.05 rad short of the prediction
    (std 0.02): the update turns the heading by ~+0.048 (the EKF gain 0.01 / 0.0104), past
    pi; the state holds it wrapped, within a tenth of the step of the linear answer."""
    ukf = _ukf_at_heading(np.pi - 0.005, 0.01)
    landmark = np.array([[-3.0, 0.5]])
    predicted = Bearing2D().predict(ukf.x, landmark[0])[0][0]
    ukf.update(np.array([predicted - 0.05]), landmark, np.array([0.02]))
    assert -np.pi <= ukf.x[2] < np.pi
    linear = np.pi - 0.005 + 0.05 * 0.01 / (0.01 + 0.02**2)
    assert abs(wrap_angle(ukf.x[2] - linear)) < 0.1 * 0.048


def test_innovation_gate_distance_is_y2_over_h_p_h_plus_sigma2():
    ukf = _ukf_at_heading(0.3, 0.01)
    landmarks = np.array([[3.0, 1.0], [-2.0, 2.0]])
    bearings = np.array([0.1, 2.0])
    sigmas = np.array([0.02, 0.05])
    z, H, _ = Bearing2D().predict(ukf.x, landmarks)
    y = wrap_angle(bearings - z[:, 0])
    s = np.array([H[k, 0] @ ukf.P @ H[k, 0] + sigmas[k] ** 2 for k in range(2)])
    np.testing.assert_allclose(ukf.innovations(bearings, landmarks, sigmas), y**2 / s, rtol=1e-12)


def test_predicted_bearing_deviations_are_wrapped_across_pi():
    """A landmark straight behind: the sigma points' bearings straddle +-pi; the deviations
    from the circular mean are small (about sqrt(3) times the heading std) not ~2 pi."""
    ukf = _ukf_at_heading(0.0, 0.01)
    prediction = ukf.predict_bearings(np.array([[-4.0, 0.0]]))
    assert np.max(np.abs(prediction.deviations)) < 0.5
    assert prediction.variance[0] == pytest.approx(0.01 + 1e-4 / 16, rel=0.05)
