"""``benchmarks/association_two_models.py`` relabels a dataset's sightings with the landmarks the
association gave them: merges followed, dropped sightings left out, a frame without any kept
sighting left empty, and a sighting the association never decided is an error."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from omnislam.core.types import RangeBearing
from omnislam.datasets.sequence import Sequence

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "benchmarks"))  # the script's own imports (association_diagnosis)
_spec = importlib.util.spec_from_file_location(
    "association_two_models", REPO / "benchmarks" / "association_two_models.py"
)
two_models = importlib.util.module_from_spec(_spec)
sys.modules["association_two_models"] = two_models
_spec.loader.exec_module(two_models)


def _sightings(ids, ranges, bearings) -> RangeBearing:
    n = len(ids)
    return RangeBearing(
        landmark_ids=np.array(ids, dtype=np.int64),
        ranges_m=np.array(ranges, dtype=float),
        bearings_rad=np.array(bearings, dtype=float),
        sigma_range_m=np.full(n, 0.1),
        sigma_bearing_rad=np.full(n, 0.01),
    )


def _sequence() -> Sequence:
    # frame 0: none; frame 1: true ids 7 and 8; frame 2: true id 7 (the association drops it)
    return Sequence(
        name="toy",
        source="test",
        stamps_s=np.array([0.0, 1.0, 2.0]),
        odometry_r=np.zeros((3, 3)),
        range_bearing=(
            None,
            _sightings([7, 8], [2.0, 3.0], [0.1, -0.2]),
            _sightings([7], [2.5], [0.3]),
        ),
    )


def test_relabel_gives_each_sighting_its_decided_landmark_after_merges():
    decided = {(1, 2.0, 0.1): 100, (1, 3.0, -0.2): 101, (2, 2.5, 0.3): -1}
    merged_into = {101: 100}  # the loop closure retired 101 into 100

    relabelled, dropped = two_models.relabel(
        _sequence(), decided, lambda lid: merged_into.get(lid, lid)
    )

    assert dropped == 1
    frames = relabelled.range_bearing
    assert frames[0] is None
    np.testing.assert_array_equal(frames[1].landmark_ids, [100, 100])
    np.testing.assert_array_equal(frames[1].ranges_m, [2.0, 3.0])
    np.testing.assert_array_equal(frames[1].bearings_rad, [0.1, -0.2])
    np.testing.assert_array_equal(frames[1].sigma_range_m, [0.1, 0.1])
    assert frames[2] is None  # its only sighting was dropped
    np.testing.assert_array_equal(relabelled.odometry_r, _sequence().odometry_r)


def test_relabel_refuses_a_sighting_the_association_never_decided():
    decided = {(1, 2.0, 0.1): 100, (2, 2.5, 0.3): 102}  # frame 1's second sighting missing

    with pytest.raises(KeyError):
        two_models.relabel(_sequence(), decided, lambda lid: lid)
