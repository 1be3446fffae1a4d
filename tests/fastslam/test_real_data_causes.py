"""FastSLAM on real logs: a stated odometry covariance and the per-particle outlier gate.

* With ``stated_odometry_noise`` the particles spread as a frame's ``Odometry.covariance``
  says (``core.motion.StatedOdometryMotion``), not as the alpha model would; by default (AUTO)
  they do so for laser odometry (a covariance measured per step) and not for wheel odometry.
* With ``experimental.outlier_gate_probability`` < 1, a misread sighting (an id that names a
  landmark metres away, MR.CLAM's misread barcodes) neither moves the landmark nor refines the
  FastSLAM 2.0 proposal, on the numpy path and the compiled kernels alike.
"""

from __future__ import annotations

import numpy as np
import pytest

from omnislam.core.modality import Modality
from omnislam.core.types import FrameInput, Odometry, OdometrySource, RangeBearing
from omnislam.fastslam import (
    ExperimentalConfig,
    FastSLAMConfig,
    Kernels,
    ParticlesConfig,
    StatedOdometryNoise,
    Variant,
    make_fastslam,
)
from omnislam.fastslam import kernels as kernel_module

#: a stated covariance unlike anything the alpha model gives for the step: wide sideways
STATED = np.array([[1e-4, 0.0, 0.0], [0.0, 0.04, 0.01], [0.0, 0.01, 0.01]])
STEP = np.array([0.5, 0.0, 0.0])
KERNELS = [Kernels.NUMPY] + ([Kernels.NUMBA] if kernel_module.available() else [])


def _spread(
    variant: Variant,
    stated: StatedOdometryNoise,
    with_sighting: bool,
    odometry_source: OdometrySource = OdometrySource.WHEEL,
) -> np.ndarray:
    config = FastSLAMConfig(
        variant=variant,
        particles=ParticlesConfig(n_particles=4000),
        stated_odometry_noise=stated,
    )
    slam = make_fastslam(
        config, Modality.RANGE_BEARING_2D, np.random.default_rng(3), odometry_source=odometry_source
    )
    # a first sighting of a landmark: no established landmark, so FastSLAM 2.0 samples from
    # the motion model too (``proposal_sampling``)
    rb = RangeBearing(np.array([7]), np.array([2.0]), np.array([0.3]), 0.05, 0.01)
    slam.step(
        FrameInput(
            index=0,
            odometry=Odometry(STEP, stamp_s=1.0, covariance=STATED),
            range_bearing=rb if with_sighting else None,
        )
    )
    poses = slam.particles.poses
    assert slam.info().frames_stated_odometry == int(stated.resolve(odometry_source))
    return np.cov((poses - [0.5, 0.0, 0.0]).T)


@pytest.mark.parametrize("variant", list(Variant))
@pytest.mark.parametrize("with_sighting", [False, True])
def test_particles_follow_a_stated_odometry_covariance(variant, with_sighting):
    cov = _spread(variant, StatedOdometryNoise.ON, with_sighting)
    # 4000 draws: a variance is within ~2.2 % (1 sigma), a correlation within ~0.016
    np.testing.assert_allclose(np.diag(cov), np.diag(STATED), rtol=0.1)
    assert cov[1, 2] / np.sqrt(cov[1, 1] * cov[2, 2]) == pytest.approx(0.5, abs=0.06)
    # without the option the alphas decide: almost no sideways spread for a straight step
    assert _spread(variant, StatedOdometryNoise.OFF, with_sighting, OdometrySource.LASER)[1, 1] < (
        0.1 * STATED[1, 1]
    )


@pytest.mark.parametrize("variant", list(Variant))
def test_by_default_laser_odometry_is_sampled_from_its_covariance_and_wheels_are_not(variant):
    assert FastSLAMConfig().stated_odometry_noise is StatedOdometryNoise.AUTO
    laser = _spread(variant, StatedOdometryNoise.AUTO, True, OdometrySource.LASER)
    np.testing.assert_allclose(np.diag(laser), np.diag(STATED), rtol=0.1)
    # wheel odometry with a stated (nominal) covariance keeps the alpha model
    wheel = _spread(variant, StatedOdometryNoise.AUTO, True, OdometrySource.WHEEL)
    assert wheel[1, 1] < 0.1 * STATED[1, 1]


def test_an_unknown_odometry_source_is_refused():
    from omnislam.errors import ConfigError

    with pytest.raises(ConfigError, match="odometry source"):
        make_fastslam(
            FastSLAMConfig(), Modality.RANGE_BEARING_2D, np.random.default_rng(0),
            odometry_source="gps",
        )


def _frame(index: int, rng_range: float, landmark: int = 7) -> FrameInput:
    """Standing still at the origin, a sighting of ``landmark`` at range ``rng_range`` dead
    ahead."""
    rb = RangeBearing(np.array([landmark]), np.array([rng_range]), np.array([0.0]), 0.05, 0.01)
    return FrameInput(
        index=index, odometry=Odometry(np.zeros(3), stamp_s=float(index)), range_bearing=rb
    )


def _run_misread(variant: Variant, gate: float, kernels: Kernels):
    config = FastSLAMConfig(
        variant=variant,
        particles=ParticlesConfig(n_particles=20),
        experimental=ExperimentalConfig(outlier_gate_probability=gate),
        kernels=kernels,
    )
    slam = make_fastslam(config, Modality.RANGE_BEARING_2D, np.random.default_rng(5))
    for k in range(5):
        slam.step(_frame(k, 2.0))
    slam.step(_frame(5, 5.0))  # misread: the landmark is 2 m away, this says 5 m
    return slam


@pytest.mark.parametrize("variant", list(Variant))
@pytest.mark.parametrize("kernels", KERNELS)
def test_a_misread_sighting_is_gated(variant, kernels):
    gated = _run_misread(variant, 0.999, kernels)
    landmark = gated.estimate().landmarks_w[0, :2]
    assert np.linalg.norm(landmark - [2.0, 0.0]) < 0.05
    assert np.abs(gated.estimate().trajectory.se2[-1, :2]).max() < 0.05
    info = gated.info()
    assert info.sightings_gated + info.proposal_sightings_gated >= 20
    # without the gate the misread drags the landmark (and FastSLAM 2.0's poses) towards it
    plain = _run_misread(variant, 1.0, kernels)
    moved = np.linalg.norm(plain.estimate().landmarks_w[0, :2] - [2.0, 0.0])
    pose_moved = np.abs(plain.estimate().trajectory.se2[-1, :2]).max()
    assert max(moved, pose_moved) > 0.2
    assert plain.info().sightings_gated == 0


@pytest.mark.skipif(len(KERNELS) < 2, reason="numba not installed")
@pytest.mark.parametrize("variant", list(Variant))
def test_the_gate_agrees_on_both_paths(variant):
    a, b = (_run_misread(variant, 0.999, kernels) for kernels in KERNELS)
    np.testing.assert_allclose(
        a.estimate().trajectory.se2, b.estimate().trajectory.se2, rtol=0, atol=1e-9
    )
    np.testing.assert_allclose(a.estimate().landmarks_w, b.estimate().landmarks_w, atol=1e-9)
    assert a.info().sightings_gated == b.info().sightings_gated
    assert a.info().proposal_sightings_gated == b.info().proposal_sightings_gated


@pytest.mark.parametrize("variant", list(Variant))
def test_a_gap_without_sightings_is_sampled_as_one_composed_step(variant):
    """``compose_gaps``: the gap's frames report the composed mean (no sampling), and the frame
    with the next sighting draws the whole gap's motion with its composed covariance."""
    from omnislam.core.motion import OdometryMotionModel
    from omnislam.core.se import se2_compose, se2_compose_jacobians
    from omnislam.fastslam.config import DEFAULT_MOTION_NOISE

    config = FastSLAMConfig(
        variant=variant,
        particles=ParticlesConfig(n_particles=4000),
        experimental=ExperimentalConfig(compose_gaps=True),
    )
    slam = make_fastslam(config, Modality.RANGE_BEARING_2D, np.random.default_rng(4))
    step = np.array([0.4, 0.0, 0.15])
    for k in range(5):
        slam.step(FrameInput(index=k, odometry=Odometry(step, stamp_s=float(k))))
        assert np.ptp(slam.particles.poses, axis=0).max() == 0.0  # composed, not sampled
    # a first sighting: nothing to refine the proposal with (``_spread`` above)
    rb = RangeBearing(np.array([7]), np.array([2.0]), np.array([0.3]), 0.05, 0.01)
    slam.step(FrameInput(index=5, odometry=Odometry(step, stamp_s=5.0), range_bearing=rb))
    model = OdometryMotionModel(DEFAULT_MOTION_NOISE)
    delta, cov = np.zeros(3), np.zeros((3, 3))
    for _ in range(6):
        J_a, J_b = se2_compose_jacobians(delta, step)
        cov = J_a @ cov @ J_a.T + J_b @ model.covariance(step) @ J_b.T
        delta = se2_compose(delta, step)
    poses = slam.particles.poses
    np.testing.assert_allclose(poses.mean(axis=0), delta, atol=0.01)
    # 4000 draws: a variance is within ~2.2 % (1 sigma)
    np.testing.assert_allclose(np.diag(np.cov(poses.T)), np.diag(cov), rtol=0.1)
    assert slam.info().frames == 6 and slam.info().frames_with_sightings == 1


def test_a_composed_gap_holds_its_start_and_restarts_empty_after_closing():
    """``ComposedGap``: the frames of a gap report start (+) D_j from the poses at its start
    (a copy: later changes to the particles' array do not move it), D_j and C_j composed by
    ``compose_odometry``; closing returns the whole gap and the next gap starts from zero."""
    from omnislam.core.motion import compose_odometry
    from omnislam.core.se import se2_compose
    from omnislam.fastslam.gap import ComposedGap

    steps = [np.array([0.4, 0.05, 0.2]), np.array([0.3, -0.1, -0.5]), np.array([0.2, 0.0, 0.1])]
    covs = [np.diag([0.01, 0.02, 0.003]) * (j + 1) for j in range(3)]
    delta, cov = np.zeros(3), np.zeros((3, 3))
    composed = []
    for d, c in zip(steps, covs, strict=True):
        delta, cov = compose_odometry(delta, cov, d, c)
        composed.append((delta, cov))
    poses = np.array([[0.0, 0.0, 0.0], [1.0, -2.0, 2.5]])
    start = poses.copy()
    gap = ComposedGap()
    for j in range(2):
        got = gap.extend(poses, steps[j], covs[j])
        np.testing.assert_allclose(got, se2_compose(start, composed[j][0]), atol=1e-12)
        poses += 0.5  # the particles' array moves on (sampled elsewhere): not the gap's start
    np.testing.assert_allclose(gap.covariance, composed[1][1], atol=1e-15)
    first, whole, motion = gap.close(steps[2], covs[2])
    np.testing.assert_array_equal(first, start)
    np.testing.assert_allclose(whole, composed[2][0], atol=1e-12)
    np.testing.assert_allclose(motion.delta_covariance, composed[2][1], atol=1e-15)
    assert not gap.open
    got = gap.extend(poses, steps[0], covs[0])
    np.testing.assert_allclose(got, se2_compose(poses, steps[0]), atol=1e-12)
    np.testing.assert_allclose(gap.covariance, covs[0], atol=1e-15)
