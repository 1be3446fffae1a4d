"""FastSLAM consumes one modality, fixed at construction (``core.modality``)."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from fastslam_scenario import (
    BEARING_SCENARIO_NOISE,
    SENSOR_HEIGHT_M,
    make_bearing_scenario,
    make_scenario,
)

from omnislam.core.modality import Modality
from omnislam.core.motion import OdometryMotionModel
from omnislam.core.sequence_info import SequenceInfo
from omnislam.core.types import Bearings, FrameInput
from omnislam.errors import ConfigError, DataError
from omnislam.estimators import ESTIMATORS, make_estimator
from omnislam.fastslam import (
    MODALITIES,
    BearingsConfig,
    ExperimentalConfig,
    FastSLAM,
    FastSLAMConfig,
    ParticlesConfig,
    Variant,
    make_fastslam,
    make_fastslam1,
    make_fastslam2,
)
from omnislam.options import apply_options

CONFIG = FastSLAMConfig(
    variant=Variant.FASTSLAM2,
    particles=ParticlesConfig(n_particles=10),
    motion_noise=BEARING_SCENARIO_NOISE,
    sensor_height_m=SENSOR_HEIGHT_M,
)


def _final(frames, modality, seed=5):
    slam = make_fastslam(CONFIG, modality, np.random.default_rng(seed))
    for frame in frames:
        slam.step(frame)
    estimate = slam.estimate()
    return estimate.trajectory.poses_w, estimate.landmark_ids, estimate.landmarks_w


@pytest.mark.parametrize("modality", [Modality.VERTICAL_LINES, None, "bearings-3d"])
def test_an_unsupported_or_missing_modality_names_the_allowed_ones(modality):
    with pytest.raises(ConfigError, match="range-bearing-2d or bearings-3d"):
        make_fastslam(FastSLAMConfig(), modality, np.random.default_rng(0))


def test_reads_only_its_modalitys_stream():
    """A frame carrying both streams: each filter gives bit for bit what it gives on its own
    stream alone (the other one is never read)."""
    planar = make_scenario(2, steps=40).frames
    bearing = make_bearing_scenario(2, steps=40).frames
    pairs = list(zip(planar, bearing, strict=True))
    both = [FrameInput(a.index, a.odometry, b.bearings, a.range_bearing) for a, b in pairs]
    bearing = [FrameInput(a.index, a.odometry, bearings=b.bearings) for a, b in pairs]
    for modality, alone in ((Modality.RANGE_BEARING_2D, planar), (Modality.BEARINGS_3D, bearing)):
        for got, expected in zip(_final(both, modality), _final(alone, modality), strict=True):
            np.testing.assert_array_equal(got, expected)


def test_a_frame_without_its_modality_only_predicts():
    bearing_only = make_bearing_scenario(1, steps=5).frames
    slam = make_fastslam(CONFIG, Modality.RANGE_BEARING_2D, np.random.default_rng(0))
    for frame in bearing_only:
        slam.step(frame)
    assert slam.info().frames == 5 and slam.info().frames_with_sightings == 0
    assert len(slam.estimate().landmark_ids) == 0


def test_bearings_without_track_ids_are_refused():
    frame = make_bearing_scenario(1, steps=1).frames[0]
    b = frame.bearings
    unknown = Bearings(np.full(len(b), -1), b.unit_vectors_r, b.sigmas_rad)
    slam = make_fastslam(CONFIG, Modality.BEARINGS_3D, np.random.default_rng(0))
    with pytest.raises(DataError, match="track ids"):
        slam.step(FrameInput(0, frame.odometry, bearings=unknown))


def test_factories_take_the_registry_modality():
    rng = np.random.default_rng(0)
    for factory, variant in (
        (make_fastslam1, Variant.FASTSLAM1),
        (make_fastslam2, Variant.FASTSLAM2),
    ):
        for modality in MODALITIES:
            info = SequenceInfo(name="x", frames=1, modality=modality, sensor_height_m=0.5)
            slam = factory(info, {}, rng)
            assert slam.modality is modality and slam.config.variant is variant
            assert slam.config.sensor_height_m == 0.5
    with pytest.raises(ConfigError, match="range-bearing-2d or bearings-3d"):
        make_fastslam1(SequenceInfo(name="x", frames=1), {}, rng)


def test_the_registry_lists_what_fastslam_consumes():
    for name in ("fastslam1", "fastslam2"):
        assert ESTIMATORS[name].modalities == frozenset(MODALITIES)


def test_the_shared_rule_and_override_pick_the_modality():
    """Data with both streams: bearings-3d by the rule, range-bearing-2d by ``modality=``."""
    both = frozenset({Modality.RANGE_BEARING_2D, Modality.BEARINGS_3D})
    info = SequenceInfo(name="x", frames=1, modalities=both)
    rng = np.random.default_rng(0)
    assert make_estimator("fastslam1", info, {}, rng).modality is Modality.BEARINGS_3D
    chosen = make_estimator("fastslam2", info, {"modality": "range-bearing-2d"}, rng)
    assert chosen.modality is Modality.RANGE_BEARING_2D


def test_the_removed_sensor_mode_option_points_to_modality():
    info = SequenceInfo(name="x", frames=1, modality=Modality.BEARINGS_3D)
    with pytest.raises(ConfigError, match=re.escape("modality=range-bearing-2d|bearings-3d")):
        make_fastslam1(info, {"sensor_mode": "bearings_3d"}, np.random.default_rng(0))


def test_min_parallax_in_degrees_gives_the_radians_float_exactly():
    """3 deg -> math.radians(3.0), to the last bit of the float the filter compares with."""
    assert FastSLAMConfig().bearings.min_parallax_deg == 3.0
    assert math.radians(FastSLAMConfig().bearings.min_parallax_deg) == 0.05235987755982989
    changed = apply_options(FastSLAMConfig(), {"bearings.min_parallax_deg": "6"})
    assert changed.bearings.min_parallax_deg == 6.0
    with pytest.raises(ConfigError, match="min_parallax_deg"):
        BearingsConfig(min_parallax_deg=-1.0)


class _CountingMotion:
    """An injected motion model: the odometry model, counting the calls it gets."""

    def __init__(self, model: OdometryMotionModel) -> None:
        self._model = model
        self.calls = {"sample": 0, "predict": 0, "covariance": 0}

    def sample(self, wTr, delta_r, rng):
        self.calls["sample"] += 1
        return self._model.sample(wTr, delta_r, rng)

    def predict(self, wTr, P, delta_r):
        self.calls["predict"] += 1
        return self._model.predict(wTr, P, delta_r)

    def covariance(self, delta_r):
        self.calls["covariance"] += 1
        return self._model.covariance(delta_r)


@pytest.mark.parametrize("variant", list(Variant))
def test_the_injected_motion_model_is_the_one_used(variant):
    """FastSLAM 1.0 samples from it; 2.0 predicts with it (and samples particles without usable
    sightings); the results equal those of the factory's model."""
    frames = make_scenario(3, steps=15).frames
    config = CONFIG.with_(variant=variant)
    counting = _CountingMotion(OdometryMotionModel(config.motion_noise))
    injected = FastSLAM(
        config, np.random.default_rng(1), modality=Modality.RANGE_BEARING_2D, motion=counting
    )
    built = make_fastslam(config, Modality.RANGE_BEARING_2D, np.random.default_rng(1))
    for frame in frames:
        injected.step(frame)
        built.step(frame)
    np.testing.assert_array_equal(injected.particles.poses, built.particles.poses)
    if variant is Variant.FASTSLAM1:
        assert counting.calls == {"sample": len(frames), "predict": 0, "covariance": 0}
    else:
        assert counting.calls["predict"] == len(frames)
        assert counting.calls["covariance"] == 0  # nothing asks for it by default


@pytest.mark.parametrize("variant", list(Variant))
def test_the_spread_since_a_sighting_takes_the_injected_models_covariance(variant):
    """``experimental.resighting_spread`` composes the step covariances of the motion model
    it is given (``MotionModel.covariance``, once per frame), with the factory's numbers."""
    frames = make_scenario(3, steps=15, unknown_ids=True).frames
    config = CONFIG.with_(
        variant=variant, experimental=ExperimentalConfig(resighting_spread=1.0)
    )
    counting = _CountingMotion(OdometryMotionModel(config.motion_noise))
    injected = FastSLAM(
        config, np.random.default_rng(1), modality=Modality.RANGE_BEARING_2D, motion=counting
    )
    built = make_fastslam(config, Modality.RANGE_BEARING_2D, np.random.default_rng(1))
    for frame in frames:
        injected.step(frame)
        built.step(frame)
    np.testing.assert_array_equal(injected.particles.poses, built.particles.poses)
    assert counting.calls["covariance"] == len(frames)


class _NoCovariance:
    """A motion model that samples and predicts but states no step covariance."""

    def sample(self, wTr, delta_r, rng):
        return OdometryMotionModel().sample(wTr, delta_r, rng)

    def predict(self, wTr, P, delta_r):
        return OdometryMotionModel().predict(wTr, P, delta_r)


def test_a_motion_model_without_a_covariance_is_refused():
    with pytest.raises(ConfigError, match="covariance"):
        FastSLAM(
            CONFIG,
            np.random.default_rng(0),
            modality=Modality.RANGE_BEARING_2D,
            motion=_NoCovariance(),
        )
