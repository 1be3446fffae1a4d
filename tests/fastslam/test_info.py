"""``FastSLAM.info()``: the counts the harness writes to ``estimator_info.json``."""

from __future__ import annotations

import dataclasses
import enum

import numpy as np
import pytest
from fastslam_scenario import (
    BEARING_SCENARIO_NOISE,
    SCENARIO_NOISE,
    SENSOR_HEIGHT_M,
    make_bearing_scenario,
    make_scenario,
)
from fastslam_tolerances import OUTLIER_FRACTION

from omnislam.core.modality import Modality
from omnislam.core.types import Introspectable
from omnislam.fastslam import (
    BearingsConfig,
    ExperimentalConfig,
    FastSLAMConfig,
    FastSLAMInfo,
    ParticlesConfig,
    Variant,
    make_fastslam,
)
from omnislam.fastslam.slot_registry import UNKNOWN_SLOT_ID_BASE


def _run(config, frames, modality, seed=0):
    slam = make_fastslam(config, modality, np.random.default_rng(seed))
    for frame in frames:
        slam.step(frame)
    return slam


def test_counts_agree_with_the_filter_and_its_estimate():
    scenario = make_scenario(0, steps=50)
    config = FastSLAMConfig(
        variant=Variant.FASTSLAM1,
        particles=ParticlesConfig(n_particles=20),
        motion_noise=SCENARIO_NOISE,
    )
    slam = _run(config, scenario.frames, Modality.RANGE_BEARING_2D)
    assert isinstance(slam, Introspectable)
    info = slam.info()
    assert isinstance(info, FastSLAMInfo)
    with pytest.raises(dataclasses.FrozenInstanceError):
        info.frames = 0  # type: ignore[misc]
    assert (info.variant, info.modality) == (Variant.FASTSLAM1, Modality.RANGE_BEARING_2D)
    assert info.particles == 20 and info.frames == info.frames_with_sightings == 50
    assert info.resample_count == slam.resample_count > 0
    assert info.last_ess == slam.last_ess
    assert info.landmarks == len(slam.estimate().landmark_ids) == info.landmark_slots
    assert info.rays_pending == info.unknown_slots == 0
    assert info.sightings_gated == info.proposal_sightings_gated == 0
    for value in dataclasses.asdict(info).values():
        assert isinstance(value, int | float | enum.Enum)


def test_unknown_association_counts_its_slots():
    scenario = make_scenario(1, steps=40, unknown_ids=True)
    config = FastSLAMConfig(
        variant=Variant.FASTSLAM2,
        particles=ParticlesConfig(n_particles=10),
        motion_noise=SCENARIO_NOISE,
    )
    slam = _run(config, scenario.frames, Modality.RANGE_BEARING_2D)
    info = slam.info()
    assert info.unknown_slots == info.landmark_slots > 0
    assert np.all(slam.estimate().landmark_ids >= UNKNOWN_SLOT_ID_BASE)


@pytest.mark.parametrize("variant", list(Variant))
def test_the_bearing_gate_counts_what_it_rejects(variant):
    """5% jumped tracks: rejected landmark updates (and, for 2.0, proposal sightings) are
    counted; with the gate disabled nothing is."""
    frames = make_bearing_scenario(1, steps=60, outlier_fraction=OUTLIER_FRACTION).frames
    config = FastSLAMConfig(
        variant=variant,
        particles=ParticlesConfig(n_particles=10),
        motion_noise=BEARING_SCENARIO_NOISE,
        sensor_height_m=SENSOR_HEIGHT_M,
    )
    gated = _run(config, frames, Modality.BEARINGS_3D).info()
    assert gated.modality is Modality.BEARINGS_3D
    assert gated.sightings_gated > 0 and gated.triangulation_fallbacks > 0
    assert (gated.proposal_sightings_gated > 0) is (variant is Variant.FASTSLAM2)
    ungated_config = config.with_(bearings=BearingsConfig(gate_probability=1.0))
    ungated = _run(ungated_config, frames, Modality.BEARINGS_3D)
    assert ungated.info().sightings_gated == ungated.info().proposal_sightings_gated == 0
    first = _run(config, frames[:1], Modality.BEARINGS_3D).info()
    assert first.rays_pending == len(frames[0].bearings) and first.landmarks == 0


@pytest.mark.parametrize(("spread", "pose_spread"), [(0.0, 0.0), (5.0, 0.0), (0.0, 30.0)])
def test_every_unknown_decision_is_counted_matched_or_new(spread, pose_spread):
    """Each (particle, unknown sighting) is one decision: matched or new; a new landmark's
    decisions can only outnumber its slots (several particles create the same slot)."""
    scenario = make_scenario(1, steps=40, unknown_ids=True)
    config = FastSLAMConfig(
        variant=Variant.FASTSLAM2,
        particles=ParticlesConfig(n_particles=10),
        motion_noise=SCENARIO_NOISE,
        experimental=ExperimentalConfig(
            resighting_spread=spread, association_pose_spread=pose_spread
        ),
    )
    slam = _run(config, scenario.frames, Modality.RANGE_BEARING_2D)
    info = slam.info()
    sightings = sum(len(f.range_bearing) for f in scenario.frames if f.range_bearing is not None)
    assert info.unknown_matched + info.unknown_new == 10 * sightings
    assert info.unknown_new >= info.unknown_slots > 0 and info.unknown_matched > 0
    assert info.landmarks_pruned == 0
