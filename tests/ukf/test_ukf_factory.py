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


@pytest.mark.parametrize(
    ("old", "new", "value"),
    [
        ("d_it_m", "spacing.d_it_m", "0.5"),
        ("innovation_gate", "filter.innovation_gate", "0.99"),
        ("alpha", "sigma_points.alpha", "0.5"),
        ("association.fov_widening", "image.fov_widening", "3.0"),
        ("colour.max_diff_band", "photometric.max_diff_band", "20.0"),
    ],
)
def test_a_key_that_moved_to_a_section_names_its_dotted_key(rng, old, new, value):
    with pytest.raises(ConfigError, match=f"it is set as '{new}'"):
        make_estimator("ukf", info(), {old: value}, rng)
    section, field = new.split(".")
    ukf = make_estimator("ukf", info(), {new: value}, rng)
    assert str(getattr(getattr(ukf.config, section), field)) == value
