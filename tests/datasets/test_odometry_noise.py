"""The alpha fit of ``datasets.odometry_noise``: its covariance against the motion model, the
windows, and the recovery of known alphas from simulated odometry."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from omnislam.core.motion import MotionNoise, OdometryMotionModel, compose_odometry
from omnislam.core.se import se2_compose
from omnislam.core.types import Trajectory
from omnislam.datasets import odometry_noise as on
from omnislam.datasets.sequence import GroundTruth, GroundTruthKind, Sequence
from omnislam.datasets.synthetic.routes import DriveLimits, Path, drive_through, measured_odometry
from omnislam.errors import DataError

#: the thesis presets' alphas (``presets.THESIS_MOTION_NOISE``), as simulated here
TRUE = MotionNoise(a_vv=0.05, a_vw=0.04, a_wv=0.02, a_ww=0.15)
TRUE_ALPHAS = np.array([TRUE.a_vv, TRUE.a_vw, TRUE.a_wv, TRUE.a_ww])
#: a fitted alpha may miss the simulated one by this many of its standard errors
Z_MAX = 3.0
#: ... and its standard error must be below this fraction of the alpha (a test that can fail)
SE_FRACTION_MAX = 0.5
#: a ~90 m drive with turns both ways and straight stretches, 10 Hz
WAYPOINTS = np.array([[0, 0], [10, 0], [10, 6], [2, 6], [2, 12], [14, 12], [14, 0], [20, 0],
                      [20, 10], [0, 0]], dtype=float)
EXACT = on.GroundTruthNoise(0.0, 0.0, "exact")


@pytest.fixture(scope="module")
def path() -> Path:
    return drive_through(WAYPOINTS, DriveLimits(max_speed_mps=0.5, max_turn_rate_radps=0.6,
                                                 lookahead_m=0.8))


def _sequence(path: Path, odometry_r: np.ndarray, truth_w: np.ndarray | None = None,
              kind: GroundTruthKind = GroundTruthKind.EXACT) -> Sequence:
    truth = path.poses_w if truth_w is None else truth_w
    return Sequence(name="drive", source="simulated", stamps_s=path.stamps_s,
                    odometry_r=odometry_r,
                    ground_truth=GroundTruth(kind=kind,
                                             trajectory=Trajectory.from_se2(path.stamps_s, truth)))


def _fit(path: Path, noise: MotionNoise, seed: int, **config: object) -> on.OdometryNoiseFit:
    odometry = measured_odometry(path.odometry_true(), noise, np.random.default_rng(seed))
    return on.fit_odometry_noise(_sequence(path, odometry), EXACT,
                                 on.FitConfig(fraction=1.0, **config))


def test_window_covariance_is_the_composed_motion_model(rng):
    """The quadratic form equals composing ``OdometryMotionModel.covariance`` step by step."""
    odometry = np.zeros((40, 3))
    odometry[1:] = rng.normal([0.05, 0.002, 0.02], [0.03, 0.004, 0.06], (39, 3))
    odometry[5, 0] = -0.04  # a step backwards
    bounds = np.array([[0, 7], [7, 8], [8, 39]])
    sizes = on.component_sizes(odometry, np.arange(40) * 0.1, 0.0)  # each step's own
    T, Q, _ = on.window_quadratic_forms(odometry, sizes, bounds, (1e-6, 1e-6, 1e-6))
    model = OdometryMotionModel(dataclasses.replace(TRUE, min_sigma=(0.0, 0.0, 0.0)))
    C = np.einsum("wijab,i,j->wab", Q, TRUE_ALPHAS, TRUE_ALPHAS)
    for w, (start, end) in enumerate(bounds):
        delta, cov = np.zeros(3), np.zeros((3, 3))
        for k in range(start + 1, end + 1):
            delta, cov = compose_odometry(delta, cov, odometry[k], model.covariance(odometry[k]))
        np.testing.assert_allclose(T[w], delta, atol=1e-12)
        np.testing.assert_allclose(C[w], cov, rtol=1e-9, atol=1e-15)


def test_gradient_is_the_likelihoods(path, rng):
    odometry = measured_odometry(path.odometry_true(), TRUE, np.random.default_rng(3))
    bounds = np.column_stack([np.arange(0, 600, 20), np.arange(20, 620, 20)])
    sizes = on.component_sizes(odometry, path.stamps_s, 2.0)
    residuals = on.pose_residuals(odometry, sizes, path.poses_w, bounds, EXACT, on.FitConfig())
    alphas = TRUE_ALPHAS * rng.uniform(0.5, 1.5, 4)
    _, gradient = on.negative_log_likelihood(residuals, alphas)
    step = 1e-7
    numeric = [(on.negative_log_likelihood(residuals, alphas + step * e)[0]
                - on.negative_log_likelihood(residuals, alphas - step * e)[0]) / (2 * step)
               for e in np.eye(4)]
    np.testing.assert_allclose(gradient, numeric, rtol=1e-5)


@pytest.mark.slow
def test_fit_recovers_the_simulated_alphas_within_their_standard_errors(path):
    """Four runs of the simulator's odometry (no bias): every alpha within Z_MAX standard errors
    of the truth, every standard error informative, the residuals as the model predicts."""
    z = []
    for seed in range(4):
        fit = _fit(path, TRUE, seed)
        assert np.all(fit.standard_errors < SE_FRACTION_MAX * TRUE_ALPHAS), fit.standard_errors
        z.append((fit.alphas - TRUE_ALPHAS) / fit.standard_errors)
        np.testing.assert_allclose(fit.residuals.std, 1.0, atol=0.15)
        np.testing.assert_allclose(fit.residuals.mean, 0.0, atol=0.3)
    assert np.all(np.abs(z) < Z_MAX), np.round(z, 2)
    assert np.sqrt(np.mean(np.square(z))) < 1.5, np.round(z, 2)


@pytest.mark.slow
def test_fit_tells_twice_the_noise_apart(path):
    """Odometry twice as noisy is fitted far outside the standard errors of the original."""
    doubled = MotionNoise(*(2 * TRUE_ALPHAS))
    fit = _fit(path, doubled, 0)
    z_true = (fit.alphas - TRUE_ALPHAS) / fit.standard_errors
    assert z_true[0] > Z_MAX and z_true[1] > Z_MAX, np.round(z_true, 2)
    assert np.all(np.abs((fit.alphas - 2 * TRUE_ALPHAS) / fit.standard_errors) < Z_MAX)


@pytest.mark.slow
def test_positions_alone_recover_the_alphas(path):
    """GPS-like ground truth (positions with 3 mm noise, no heading): the shape residuals of
    window pairs recover the translation and heading-drift alphas."""
    gt = on.GroundTruthNoise(0.003, None, "simulated GPS")
    fits = []
    for seed in range(2):
        generator = np.random.default_rng(100 + seed)
        odometry = measured_odometry(path.odometry_true(), TRUE, generator)
        truth = path.poses_w.copy()
        truth[:, :2] += gt.sigma_position_m * generator.standard_normal(truth[:, :2].shape)
        sequence = _sequence(path, odometry, truth, GroundTruthKind.GPS_PARTIAL)
        fit = on.fit_odometry_noise(sequence, gt, on.FitConfig(fraction=1.0))
        assert fit.residuals.components == on.SHAPE_COMPONENTS
        fits.append(fit)
    for fit in fits:  # a_vv and a_vw: what straight stretches between positions show
        z = (fit.alphas - TRUE_ALPHAS) / fit.standard_errors
        assert np.all(np.abs(z[:2]) < Z_MAX), np.round(z, 2)
        assert np.all(fit.standard_errors[:2] < SE_FRACTION_MAX * TRUE_ALPHAS[:2])
        # the rule bounds each window's x and y; a shape mixes three positions and two windows
        # (the likelihood holds the ground truth's part all the same)
        assert np.all(fit.ground_truth_share[:2] < 0.15), fit.ground_truth_share


def test_windows_close_once_the_ground_truth_noise_is_a_tenth(path):
    odometry = measured_odometry(path.odometry_true(), TRUE, np.random.default_rng(1))
    gt = on.GroundTruthNoise(0.005, 0.002, "stated")
    config = on.FitConfig(min_window_s=0.0)
    frames = np.arange(len(path))
    bounds = on.choose_windows(odometry, path.stamps_s, frames, TRUE, gt, config)
    assert np.all(bounds[1:, 0] == bounds[:-1, 1])  # consecutive
    model = OdometryMotionModel(dataclasses.replace(TRUE, min_sigma=(0.0, 0.0, 0.0)))

    def share(start: int, end: int) -> np.ndarray:
        delta, cov = np.zeros(3), np.zeros((3, 3))
        for k in range(start + 1, end + 1):
            delta, cov = compose_odometry(delta, cov, odometry[k], model.covariance(odometry[k]))
        gt_part = np.diag(on.pose_ground_truth_covariance(delta, gt))
        return gt_part / (gt_part + np.diag(cov))

    for start, end in bounds[::25]:
        assert np.all(share(start, end) <= 0.1 + 1e-6)
        if end - start > 1:
            assert np.any(share(start, end - 1) > 0.1)  # one frame earlier was too short
    assert 2 < np.median(bounds[:, 1] - bounds[:, 0]) < 200


def test_the_first_quarter_only(path):
    fit = _fit(path, TRUE, 0, max_rounds=1)
    quarter = on.fit_odometry_noise(
        _sequence(path, measured_odometry(path.odometry_true(), TRUE,
                                          np.random.default_rng(0))), EXACT)
    stamps = path.stamps_s
    assert quarter.span_s == (stamps[0], stamps[0] + 0.25 * (stamps[-1] - stamps[0]))
    assert 0.2 * fit.windows < quarter.windows < 0.3 * fit.windows


def test_shape_of_points_ignores_where_and_how_the_frame_lies(rng):
    points = rng.normal(size=(5, 3, 2)) * 10
    angle = rng.uniform(-np.pi, np.pi)
    R = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    moved = points @ R.T + rng.normal(size=2) * 100
    np.testing.assert_allclose(on.shape_of_points(*points.transpose(1, 0, 2)),
                               on.shape_of_points(*moved.transpose(1, 0, 2)), atol=1e-9)


def test_shape_of_motion_is_the_shape_of_the_composed_poses(rng):
    d_ab, d_bc = rng.normal(size=3), rng.normal(size=3)
    lever = np.array([0.7, -0.3])
    poses = [np.zeros(3), d_ab, se2_compose(d_ab, d_bc)]
    points = [p[:2] + np.array([[np.cos(p[2]), -np.sin(p[2])], [np.sin(p[2]), np.cos(p[2])]])
              @ lever for p in poses]
    np.testing.assert_allclose(on.shape_of_motion(d_ab, d_bc, lever),
                               on.shape_of_points(*points), atol=1e-12)


def test_second_differences_measure_white_noise(rng):
    stamps = np.arange(20000) / 100.0
    smooth = np.column_stack([np.sin(0.1 * stamps), np.cos(0.07 * stamps), 0.05 * stamps])
    noisy = smooth + rng.normal(size=smooth.shape) * [0.002, 0.002, 0.001]
    noise = on.second_difference_noise(stamps, noisy, True, "test")
    assert noise.sigma_position_m == pytest.approx(0.002, rel=0.05)
    assert noise.sigma_heading_rad == pytest.approx(0.001, rel=0.05)
    assert on.second_difference_noise(stamps, noisy[:, :2], False, "t").sigma_heading_rad is None


def test_a_run_without_ground_truth_cannot_be_fitted(path):
    sequence = Sequence(name="none", source="t", stamps_s=path.stamps_s,
                        odometry_r=path.odometry_true())
    with pytest.raises(DataError, match="no ground-truth trajectory"):
        on.fit_odometry_noise(sequence, EXACT)
