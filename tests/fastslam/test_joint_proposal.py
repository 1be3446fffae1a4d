"""The joint FastSLAM 2.0 proposal (``ProposalUpdateMode.JOINT``) against the sequential one
and against dense (km x km) references computed with numpy directly."""

from __future__ import annotations

import numpy as np
import pytest
from fastslam_scenario import (
    BEARING_SCENARIO_NOISE,
    SCENARIO_NOISE,
    SENSOR_HEIGHT_M,
    ate_rmse,
    make_bearing_scenario,
    make_scenario,
)
from fastslam_tolerances import (
    ATE_FRACTION_OF_DEAD_RECKONING,
    ATE_FRACTION_OF_DEAD_RECKONING_3D,
    OUTLIER_FRACTION,
)
from scipy.stats import multivariate_normal

from omnislam.core.gating import chi_square_gate
from omnislam.core.gaussian import LOG_2PI
from omnislam.core.measurement import RangeBearing2D
from omnislam.core.modality import Modality
from omnislam.core.motion import MotionNoise, OdometryMotionModel
from omnislam.fastslam import (
    FastSLAMConfig,
    ParticlesConfig,
    ProposalConfig,
    ProposalUpdateMode,
    Variant,
    make_fastslam,
)
from omnislam.fastslam.proposal import joint_proposal, refine_proposal
from omnislam.options import apply_options

#: joint == sequential for one observation: same Gaussian update, different rounding
SINGLE_OBSERVATION_ATOL = 1e-10
#: Woodbury / determinant-lemma log-likelihood vs the dense multivariate normal
LOGPDF_ATOL = 1e-9


class LinearModel:
    """z = C x + D m: a linear measurement model, for which the sequential proposal (chain
    rule) and the joint one are the same Gaussian update."""

    def __init__(self, C: np.ndarray, D: np.ndarray) -> None:
        self.C, self.D = C, D

    @property
    def dim_z(self) -> int:
        return self.C.shape[0]

    def predict(self, wTr: np.ndarray, landmarks_w: np.ndarray) -> tuple[np.ndarray, ...]:
        n = wTr.shape[0]
        z_hat = wTr @ self.C.T + landmarks_w @ self.D.T
        H_x = np.broadcast_to(self.C, (n, *self.C.shape)).copy()
        H_m = np.broadcast_to(self.D, (n, *self.D.shape)).copy()
        return z_hat, H_x, H_m

    def residual(self, z_measured: np.ndarray, z_predicted: np.ndarray) -> np.ndarray:
        return z_measured - z_predicted


def _spd(rng, n, d, scale, floor=0.0):
    A = rng.normal(size=(n, d, d)) * scale
    return A @ np.swapaxes(A, 1, 2) + floor * np.eye(d)


def _problem(rng, counts, model_kind="range_bearing", singular=False):
    """Predictions of len(counts) particles and counts[i] observations of particle i."""
    p = len(counts)
    mu0 = np.column_stack([rng.normal(0, 1, (p, 2)), rng.uniform(-0.5, 0.5, p)])
    if singular:  # turning on the spot: P has rank 1 (heading only)
        P = np.zeros((p, 3, 3))
        P[:, 2, 2] = rng.uniform(0.01, 0.05, p)
    else:
        P = _spd(rng, p, 3, 0.1, 1e-4)
    particle = np.repeat(np.arange(p), counts)
    rng.shuffle(particle)  # pairs in any order
    n = particle.size
    landmarks = mu0[particle, :2] + rng.uniform(2, 5, (n, 2)) * rng.choice([-1, 1], (n, 2))
    landmark_cov = _spd(rng, n, 2, 0.05, 1e-3)
    R = np.broadcast_to(np.diag([0.1**2, 0.03**2]), (n, 2, 2)).copy()
    if model_kind == "linear":
        model = LinearModel(rng.normal(size=(2, 3)), rng.normal(size=(2, 2)))
    else:
        model = RangeBearing2D()
    z_true, _, _ = model.predict(mu0[particle] + rng.normal(0, 0.1, (n, 3)), landmarks)
    z = z_true + rng.normal(0, [0.1, 0.03], (n, 2))
    return mu0, P, particle, z, R, landmarks, landmark_cov, model


def _sequential(mu0, P, particle, z, R, landmarks, landmark_cov, model, gate=np.inf):
    """The default proposal: the particle's pairs one after the other (refine_proposal)."""
    mean, cov, log_likelihood = mu0.copy(), P.copy(), np.zeros(len(mu0))
    for i in range(len(mu0)):
        for row in np.flatnonzero(particle == i):
            sel = slice(row, row + 1)
            update = refine_proposal(
                mean[i : i + 1],
                cov[i : i + 1],
                z[sel],
                R[sel],
                landmarks[sel],
                landmark_cov[sel],
                model,
                gate,
            )
            mean[i], cov[i] = update.mean[0], update.cov[0]
            log_likelihood[i] += update.log_likelihood[0]
    return mean, cov, log_likelihood


def _dense(mu0, P, particle, z, R, landmarks, landmark_cov, model):
    """Stacked (km x km) Kalman update at the prediction and scipy's logpdf, per particle."""
    z_hat, H_x, H_m = model.predict(mu0[particle], landmarks)
    y = model.residual(z, z_hat)
    means, covs, logpdfs = [], [], []
    for i in range(len(mu0)):
        rows = np.flatnonzero(particle == i)
        if rows.size == 0:
            means.append(mu0[i]), covs.append(P[i]), logpdfs.append(0.0)
            continue
        H = np.concatenate(H_x[rows])  # (km, 3)
        blocks = [H_m[r] @ landmark_cov[r] @ H_m[r].T + R[r] for r in rows]
        Q = np.zeros((H.shape[0], H.shape[0]))
        for j, block in enumerate(blocks):
            Q[2 * j : 2 * j + 2, 2 * j : 2 * j + 2] = block
        L = H @ P[i] @ H.T + Q
        K = P[i] @ H.T @ np.linalg.inv(L)
        stacked = np.concatenate(y[rows])
        means.append(mu0[i] + K @ stacked)
        covs.append(P[i] - K @ H @ P[i])
        logpdfs.append(multivariate_normal(np.zeros(stacked.size), L).logpdf(stacked))
    return np.array(means), np.array(covs), np.array(logpdfs)


def test_one_observation_equals_sequential(rng):
    """One observation per particle: the joint update is the sequential one (1e-10)."""
    problem = _problem(rng, [1] * 7)
    joint = joint_proposal(*problem)
    mean, cov, log_likelihood = _sequential(*problem)
    np.testing.assert_allclose(joint.mean, mean, rtol=0, atol=SINGLE_OBSERVATION_ATOL)
    np.testing.assert_allclose(joint.cov, cov, rtol=0, atol=SINGLE_OBSERVATION_ATOL)
    np.testing.assert_allclose(
        joint.log_likelihood, log_likelihood, rtol=0, atol=SINGLE_OBSERVATION_ATOL
    )
    assert joint.accepted.all()


@pytest.mark.parametrize("singular", [False, True])
def test_linear_model_joint_equals_sequential_and_dense(rng, singular):
    """Several observations, linear model: joint == sequential (chain rule) == dense Kalman
    with stacked observations and scipy's logpdf; particles without observations keep the
    prediction with factor 1. Also with a singular P (turning on the spot)."""
    problem = _problem(rng, [3, 1, 0, 5, 2], model_kind="linear", singular=singular)
    joint = joint_proposal(*problem)
    mean, cov, log_likelihood = _sequential(*problem)
    d_mean, d_cov, d_logpdf = _dense(*problem)
    for reference in ((mean, cov, log_likelihood), (d_mean, d_cov, d_logpdf)):
        np.testing.assert_allclose(joint.mean, reference[0], rtol=0, atol=1e-10)
        np.testing.assert_allclose(joint.cov, reference[1], rtol=0, atol=1e-10)
        np.testing.assert_allclose(joint.log_likelihood, reference[2], rtol=0, atol=LOGPDF_ATOL)
    np.testing.assert_allclose(joint.mean[2], problem[0][2], rtol=0, atol=1e-15)
    assert joint.log_likelihood[2] == 0.0


@pytest.mark.parametrize("singular", [False, True])
def test_woodbury_log_likelihood_equals_dense_logpdf(rng, singular):
    """Range-bearing (nonlinear) model: at the prediction the joint update is the stacked
    Kalman update, and the determinant-lemma / Woodbury log-likelihood equals
    N(y; 0, H P H^T + blockdiag(Q)) from scipy within 1e-9."""
    problem = _problem(rng, [4, 2, 6, 1, 3, 0], singular=singular)
    joint = joint_proposal(*problem)
    d_mean, d_cov, d_logpdf = _dense(*problem)
    np.testing.assert_allclose(joint.log_likelihood, d_logpdf, rtol=0, atol=LOGPDF_ATOL)
    np.testing.assert_allclose(joint.mean, d_mean, rtol=0, atol=1e-10)
    np.testing.assert_allclose(joint.cov, d_cov, rtol=0, atol=1e-10)
    assert np.all(np.linalg.eigvalsh(joint.cov) > -1e-12)


def test_nonlinear_joint_close_to_sequential(rng):
    """Range-bearing: the relinearised sequential proposal and the joint one differ only by
    the linearisation point (small for a proposal much tighter than the landmark range)."""
    problem = _problem(rng, [6] * 5)
    mu0, P = problem[0], problem[1]
    problem = (mu0, 0.01 * P, *problem[2:])
    joint = joint_proposal(*problem)
    mean, cov, log_likelihood = _sequential(*problem)
    np.testing.assert_allclose(joint.mean, mean, rtol=0, atol=1e-3)
    np.testing.assert_allclose(joint.cov, cov, rtol=0, atol=1e-5)
    np.testing.assert_allclose(joint.log_likelihood, log_likelihood, rtol=0, atol=0.05)


def test_gate_excludes_an_outlier_with_the_truncated_factor(rng):
    """An observation outside the gate (y^T L^-1 y at the prediction) is left out of the
    update and contributes the Gaussian truncated at the gate, as in the sequential version."""
    mu0, P, particle, z, R, landmarks, landmark_cov, model = _problem(rng, [3, 2])
    outlier = np.flatnonzero(particle == 0)[1]
    z = z.copy()
    z[outlier, 0] += 5.0  # 5 m range error: far outside the gate
    gate = chi_square_gate(0.999, 2)
    joint = joint_proposal(mu0, P, particle, z, R, landmarks, landmark_cov, model, gate)
    assert joint.accepted.sum() == particle.size - 1 and not joint.accepted[outlier]
    keep = np.arange(particle.size) != outlier
    clean = joint_proposal(
        mu0, P, particle[keep], z[keep], R[keep], landmarks[keep], landmark_cov[keep], model
    )
    np.testing.assert_allclose(joint.mean, clean.mean, rtol=0, atol=1e-12)
    np.testing.assert_allclose(joint.cov, clean.cov, rtol=0, atol=1e-12)
    # the outlier's factor: -1/2 (gate + log det L_j + m log 2 pi) with L_j at the prediction
    _, H_x, H_m = model.predict(mu0[:1], landmarks[outlier : outlier + 1])
    L = H_x[0] @ P[0] @ H_x[0].T + H_m[0] @ landmark_cov[outlier] @ H_m[0].T + R[outlier]
    truncated = -0.5 * (gate + np.linalg.slogdet(L)[1] + 2 * LOG_2PI)
    expected = clean.log_likelihood + np.array([truncated, 0.0])
    np.testing.assert_allclose(joint.log_likelihood, expected, rtol=0, atol=1e-10)


def test_motion_prediction_input(rng):
    """From the motion model's own prediction (the filter's inputs), as refine_proposal."""
    motion = OdometryMotionModel(MotionNoise())
    problem = _problem(rng, [2, 3, 1])
    mu0, P = motion.predict(problem[0], None, np.array([0.5, 0.05, 0.2]))
    problem = (mu0, P, *problem[2:])
    joint = joint_proposal(*problem)
    d_mean, d_cov, d_logpdf = _dense(*problem)
    np.testing.assert_allclose(joint.log_likelihood, d_logpdf, rtol=0, atol=LOGPDF_ATOL)
    np.testing.assert_allclose(joint.mean, d_mean, rtol=0, atol=1e-10)
    np.testing.assert_allclose(joint.cov, d_cov, rtol=0, atol=1e-10)


def test_option_parses_from_the_command_line():
    config = apply_options(FastSLAMConfig(), {"proposal.update": "joint"})
    assert config.proposal.update is ProposalUpdateMode.JOINT
    assert FastSLAMConfig().proposal.update is ProposalUpdateMode.SEQUENTIAL


def _ate(config, scenario, seed, modality):
    slam = make_fastslam(config, modality, np.random.default_rng(seed))
    for frame in scenario.frames:
        slam.step(frame)
    positions = slam.estimate().trajectory.positions_w[:, :2]
    return ate_rmse(positions, scenario.true_poses[1:, :2])


def _mean_ates(config, scenarios, seeds, modality):
    """Mean ATE of SEQUENTIAL and JOINT over the scenarios, and dead reckoning's."""
    ates = {
        mode: np.mean(
            [
                _ate(config.with_(proposal=ProposalConfig(update=mode)), scenario, seed, modality)
                for scenario, seed in zip(scenarios, seeds, strict=True)
            ]
        )
        for mode in ProposalUpdateMode
    }
    dead_reckoning = np.mean(
        [ate_rmse(s.dead_reckoning[1:, :2], s.true_poses[1:, :2]) for s in scenarios]
    )
    return ates[ProposalUpdateMode.SEQUENTIAL], ates[ProposalUpdateMode.JOINT], dead_reckoning


def test_filter_joint_close_to_sequential_on_the_loop():
    """End to end on the 2-D loop (3 seeds, 10 particles): JOINT's mean ATE is close to
    SEQUENTIAL's and well below dead reckoning's."""
    config = FastSLAMConfig(
        variant=Variant.FASTSLAM2,
        particles=ParticlesConfig(n_particles=10),
        motion_noise=SCENARIO_NOISE,
    )
    seeds = range(3)
    sequential, joint, dead_reckoning = _mean_ates(
        config,
        [make_scenario(seed) for seed in seeds],
        [seed + 100 for seed in seeds],
        Modality.RANGE_BEARING_2D,
    )
    assert joint < ATE_FRACTION_OF_DEAD_RECKONING * dead_reckoning
    assert joint < 1.25 * sequential


def test_filter_joint_with_bearings_and_outliers():
    """3-D bearings with 5% outlier tracks (as ``test_fastslam2_3d_survives_outlier_tracks``):
    the gate, evaluated at the prediction, keeps JOINT well below dead reckoning."""
    config = FastSLAMConfig(
        variant=Variant.FASTSLAM2,
        particles=ParticlesConfig(n_particles=20),
        motion_noise=BEARING_SCENARIO_NOISE,
        sensor_height_m=SENSOR_HEIGHT_M,
    )
    seeds = (1, 2, 3)
    scenarios = [make_bearing_scenario(seed, outlier_fraction=OUTLIER_FRACTION) for seed in seeds]
    sequential, joint, dead_reckoning = _mean_ates(config, scenarios, seeds, Modality.BEARINGS_3D)
    assert joint < ATE_FRACTION_OF_DEAD_RECKONING_3D * dead_reckoning
    assert joint < 1.25 * sequential
