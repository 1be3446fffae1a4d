"""The registry's factories: the modality comes resolved from the registry, never an option."""

from __future__ import annotations

import numpy as np
import pytest

from omnislam.core.modality import Modality
from omnislam.core.sequence_info import SequenceInfo
from omnislam.errors import ConfigError
from omnislam.estimators import make_estimator
from omnislam.graphslam import BatchGraphSLAM, GraphSLAM

pytest.importorskip("gtsam")

#: a sequence like the demo's: omni bearings of the front end and pole sightings
BOTH = SequenceInfo(
    name="both",
    frames=10,
    modalities=frozenset({Modality.BEARINGS_3D, Modality.RANGE_BEARING_2D}),
    sensor_height_m=0.4,
)


@pytest.mark.parametrize(
    "name, cls", [("graphslam", GraphSLAM), ("graphslam-batch", BatchGraphSLAM)]
)
@pytest.mark.parametrize(
    "options, modality",
    [
        ({}, Modality.BEARINGS_3D),  # the shared rule: bearings first
        ({"modality": "bearings-3d"}, Modality.BEARINGS_3D),
        ({"modality": "range-bearing-2d"}, Modality.RANGE_BEARING_2D),
    ],
)
def test_the_factory_builds_the_graph_of_the_resolved_modality(name, cls, options, modality):
    estimator = make_estimator(name, BOTH, options, np.random.default_rng(0))
    assert type(estimator) is cls and estimator.modality is modality
    assert estimator.config.poses.sensor_height_m == 0.4


def test_the_old_mode_option_is_unknown():
    with pytest.raises(ConfigError, match="unknown option 'mode'"):
        make_estimator("graphslam", BOTH, {"mode": "omni"}, np.random.default_rng(0))


def test_a_modality_the_data_lack_is_refused():
    with pytest.raises(ConfigError, match="vertical-lines"):
        make_estimator("graphslam", BOTH, {"modality": "vertical-lines"}, np.random.default_rng(0))
