"""The outlier gate on sightings of mapped landmarks (the default of every Gaussian back end)."""

from __future__ import annotations

import numpy as np
import pytest
from biased_loop import LOOP_MOTION_NOISE, simulate_biased_loop
from graphslam_scenarios import MOTION_NOISE, run, simulate_planar

from omnislam.core.modality import Modality
from omnislam.core.types import FrameInput, RangeBearing
from omnislam.graphslam import GraphSLAM, GraphSLAMConfig
from omnislam.graphslam.config import LandmarkConfig

pytest.importorskip("gtsam")

RB = Modality.RANGE_BEARING_2D
#: two runs that differ only by a sighting the gate rejected agree to this [m]
SAME_ESTIMATE_M = 1e-9


def _with_sighting(frame: FrameInput, landmark_id: int, range_m: float, bearing_rad: float):
    """The frame with one more range-bearing sighting of ``landmark_id`` (a misread id)."""
    rb = frame.range_bearing
    return FrameInput(
        frame.index,
        frame.odometry,
        range_bearing=RangeBearing(
            np.append(rb.landmark_ids, landmark_id),
            np.append(rb.ranges_m, range_m),
            np.append(rb.bearings_rad, bearing_rad),
            np.append(rb.sigma_range_m, rb.sigma_range_m[0]),
            np.append(rb.sigma_bearing_rad, rb.sigma_bearing_rad[0]),
        ),
    )


def test_a_misread_id_is_rejected_and_the_estimate_is_as_without_it(rng):
    scenario = simulate_planar(rng)
    k = 80
    seen = scenario.frames[k].range_bearing.landmark_ids
    # a landmark seen since frame 0 and not in frame k: the sighting names it but points 1 m
    # beside another landmark, as MR.CLAM's misread barcodes do
    early = set(scenario.frames[0].range_bearing.landmark_ids.tolist())
    wrong_id = next(i for i in sorted(early) if i not in seen)
    rb = scenario.frames[k].range_bearing
    corrupted = list(scenario.frames)
    corrupted[k] = _with_sighting(
        scenario.frames[k], wrong_id, rb.ranges_m[0] + 1.0, rb.bearings_rad[0]
    )
    config = GraphSLAMConfig(motion_noise=MOTION_NOISE)
    clean_estimator = GraphSLAM(RB, config, scenario.poses_true[0])
    clean = run(clean_estimator, scenario.frames)
    gated_estimator = GraphSLAM(RB, config, scenario.poses_true[0])
    gated = run(gated_estimator, corrupted)
    assert gated_estimator.info().sightings_gated == clean_estimator.info().sightings_gated + 1
    np.testing.assert_allclose(gated.trajectory.se2, clean.trajectory.se2, atol=SAME_ESTIMATE_M)
    np.testing.assert_allclose(gated.landmarks_w, clean.landmarks_w, atol=SAME_ESTIMATE_M)
    # without the gate the one sighting moves the estimate
    ungated = run(
        GraphSLAM(
            RB,
            GraphSLAMConfig(
                motion_noise=MOTION_NOISE,
                landmarks=LandmarkConfig(outlier_gate_probability=1.0),
            ),
            scenario.poses_true[0],
        ),
        corrupted,
    )
    assert np.abs(ungated.trajectory.se2[:, :2] - clean.trajectory.se2[:, :2]).max() > 0.01


def test_correct_sightings_pass_the_gate_at_its_probability(rng):
    """On consistent simulated data the gate rejects about 0.1 % of the sightings."""
    scenario = simulate_planar(rng)
    estimator = GraphSLAM(RB, GraphSLAMConfig(motion_noise=MOTION_NOISE), scenario.poses_true[0])
    run(estimator, scenario.frames)
    total = sum(len(f.range_bearing) for f in scenario.frames)
    assert estimator.info().sightings_gated <= 0.005 * total


@pytest.mark.parametrize("seed", [0, 1])
def test_agreeing_re_sightings_close_a_loop_the_gate_rejected(seed):
    """A lap under biased odometry: the gate alone rejects the first landmarks' re-sightings
    and the loop stays open; three agreeing ones overrule it and the graph closes it."""
    loop = simulate_biased_loop(np.random.default_rng(seed))
    ends = {}
    for votes in (0, 3):
        config = GraphSLAMConfig(
            motion_noise=LOOP_MOTION_NOISE, landmarks=LandmarkConfig(outlier_gate_votes=votes)
        )
        estimator = GraphSLAM(RB, config, loop.poses_true[0])
        ends[votes] = loop.end_error_m(run(estimator, loop.frames).trajectory.se2)
        readmitted = estimator.info().sightings_readmitted
        assert (readmitted > 0) == (votes > 0)
    assert ends[0] > 2.5, ends  # the threat is real: the loop stays open by metres
    assert ends[3] < 0.15 * ends[0], ends


def test_a_misread_id_repeated_on_another_landmark_stays_rejected(rng):
    """The same wrong id read again and again while the robot looks at another landmark (as
    MR.CLAM's barcodes are misread): its points agree with each other, but they lie on the
    landmark really seen, so they never overrule the gate."""
    scenario = simulate_planar(rng)
    early = set(scenario.frames[0].range_bearing.landmark_ids.tolist())
    corrupted, misreads = list(scenario.frames), 0
    for k in range(80, 90):
        rb = scenario.frames[k].range_bearing
        wrong_id = next(i for i in sorted(early) if i not in rb.landmark_ids)
        # the first landmark of the frame seen again under a wrong id
        corrupted[k] = _with_sighting(
            scenario.frames[k], wrong_id, rb.ranges_m[0], rb.bearings_rad[0]
        )
        misreads += 1
    config = GraphSLAMConfig(motion_noise=MOTION_NOISE)
    clean_estimator = GraphSLAM(RB, config, scenario.poses_true[0])
    clean = run(clean_estimator, scenario.frames)
    estimator = GraphSLAM(RB, config, scenario.poses_true[0])
    misread = run(estimator, corrupted)
    info = estimator.info()
    assert info.sightings_readmitted == 0
    assert info.sightings_gated >= clean_estimator.info().sightings_gated + misreads - 1
    np.testing.assert_allclose(misread.trajectory.se2, clean.trajectory.se2, atol=1e-3)
