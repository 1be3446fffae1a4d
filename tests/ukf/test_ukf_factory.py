"""The ukf factory and its bad-input errors (one line, naming what is missing)."""

from __future__ import annotations

import numpy as np
import pytest

from omnislam.core.modality import Modality
from omnislam.core.sequence_info import SequenceInfo
from omnislam.core.types import PriorMap
from omnislam.errors import ConfigError
from omnislam.estimators import make_estimator
from omnislam.ukf import VerticalLineUKF

MAP = PriorMap(
    source="test map",
    landmark_ids=np.arange(3),
    points_w=np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]]),
    initial_pose_w=np.zeros(3),
)
RB = frozenset({Modality.RANGE_BEARING_2D})


def info(**changes) -> SequenceInfo:
    return SequenceInfo(
        **{"name": "seq", "frames": 3, "modalities": RB, "prior_map": MAP} | changes
    )


def test_registered_ukf_builds_from_the_prior_map(rng):
    ukf = make_estimator("ukf", info(), {}, rng)
    assert isinstance(ukf, VerticalLineUKF) and ukf.modality is Modality.RANGE_BEARING_2D


@pytest.mark.parametrize(
    ("changes", "options", "needle"),
    [
        ({"prior_map": None}, {}, "prior_map=RUN_DIR"),
        ({}, {"photometric.mode": "on"}, "MC descriptors"),
        ({"modalities": frozenset()}, {}, "ukf cannot run on seq"),
        ({}, {"no_such_option": "1"}, "no_such_option"),
        ({"prior_map": PriorMap("m", np.arange(1), np.zeros((1, 3)))}, {}, "no initial pose"),
    ],
)
def test_bad_input_is_one_line_naming_what_is_missing(rng, changes, options, needle):
    with pytest.raises(ConfigError) as error:
        make_estimator("ukf", info(**changes), options, rng)
    assert needle in str(error.value) and "\n" not in str(error.value)
