"""The one FrameInput builder (Sequence.frame_input) and prior maps on sequences."""

from __future__ import annotations

import numpy as np
import pytest

from omnislam.core.types import Bearings, FrameInput, Odometry, PriorMap, RangeBearing
from omnislam.datasets.sequence import Sequence
from omnislam.errors import DataError


def _sequence(n: int = 4) -> Sequence:
    covariances = np.tile(np.diag([1e-4, 2e-4, 3e-5]), (n, 1, 1))
    sightings = tuple(
        RangeBearing(np.array([i]), np.array([1.0 + i]), np.array([0.1]), 0.1, 0.01)
        for i in range(n)
    )
    return Sequence(
        name="tiny",
        source="test",
        stamps_s=np.arange(n, dtype=float),
        odometry_r=np.column_stack([np.full(n, 0.5), np.zeros(n), np.full(n, 0.1)]),
        odometry_covariance_r=covariances,
        range_bearing=sightings,
    )


def _log_frame(sequence: Sequence, i: int) -> FrameInput:
    """What a front-end log holds for frame i: its odometry without covariance, bearings."""
    rays = Bearings(np.array([100 + i]), np.array([[0.0, 1.0, 0.0]]), np.array([0.01]))
    return FrameInput(
        index=i,
        odometry=Odometry(sequence.odometry_r[i], sequence.stamps_s[i]),
        bearings=rays,
        range_bearing=None,
    )


def test_frames_carry_the_stated_odometry_covariance_from_frame_one_on():
    sequence = _sequence()
    frames = list(sequence.frame_inputs())
    assert frames[0].odometry.covariance is None  # frame 0 is the origin
    for i, frame in enumerate(frames[1:], start=1):
        assert np.array_equal(frame.odometry.covariance, sequence.odometry_covariance_r[i])
        assert frame.range_bearing.landmark_ids.tolist() == [i]


def test_a_replayed_log_keeps_the_sequences_odometry_and_its_own_sightings():
    sequence = _sequence()
    replayed = list(sequence.frame_inputs(_log_frame(sequence, i) for i in range(4)))
    assert [f.index for f in replayed] == [0, 1, 2, 3]
    for i, frame in enumerate(replayed):
        assert frame.bearings.landmark_ids.tolist() == [100 + i]
        assert frame.range_bearing is None  # the log's sightings replace the loader's
        if i:
            assert np.array_equal(frame.odometry.covariance, sequence.odometry_covariance_r[i])


@pytest.mark.parametrize("frames", [[0, 1, 2], [0, 2, 1, 3], [0, 1, 2, 3, 4]])
def test_a_log_that_does_not_cover_every_frame_once_is_refused(frames):
    sequence = _sequence()
    log = [_log_frame(_sequence(5), i) for i in frames]
    with pytest.raises(DataError, match="tiny"):
        list(sequence.frame_inputs(log))


def test_prior_map_validates_once():
    walls = np.array([[[0.0, 0.0], [4.0, 0.0]]])
    prior = PriorMap(
        "test",
        [3, 1],
        [[1.0, 2.0, 0.0], [0.0, 1.0, 0.0]],
        [True, False],
        walls_w=walls,
        initial_pose_w=[0.0, 0.0, 0.5],
    )
    assert len(prior) == 2 and prior.vertical_line.tolist() == [True, False]
    assert not prior.points_w.flags.writeable
    with pytest.raises(DataError, match="unique"):
        PriorMap("test", [1, 1], np.zeros((2, 3)))
    with pytest.raises(DataError, match="means_left"):
        PriorMap("test", [1], np.zeros((1, 3)), means_left=np.zeros((1, 3)))
    with pytest.raises(DataError, match="points_w"):
        PriorMap("test", [1, 2], np.zeros((1, 3)))


def test_mrclam_prior_map_is_the_surveyed_landmarks(shared_data):
    from omnislam.datasets.registry import load_dataset

    sequence = load_dataset("mrclam6-r1")
    prior = sequence.prior_map
    assert prior is not None and len(prior) == 15
    assert np.array_equal(prior.landmark_ids, sequence.ground_truth.landmark_ids)
    assert np.array_equal(prior.points_w, sequence.ground_truth.landmarks_w)
    assert np.array_equal(prior.initial_pose_w, sequence.initial_pose_w)
