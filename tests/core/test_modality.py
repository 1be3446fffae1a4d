"""The one modality rule shared by every estimator (core.modality)."""

import numpy as np
import pytest

from omnislam.core.modality import (
    PRIORITY,
    Modality,
    modalities_of,
    resolve_modality,
)
from omnislam.core.types import Bearings, FrameInput, Odometry, RangeBearing
from omnislam.errors import ConfigError

ALL = frozenset(Modality)


def _frame(index: int, rb: bool = False, bearings: bool = False) -> FrameInput:
    sightings = RangeBearing(np.array([1]), np.array([2.0]), np.array([0.1]), 0.1, 0.01)
    rays = Bearings(np.array([7]), np.array([[1.0, 0.0, 0.0]]), np.array([0.01]))
    return FrameInput(
        index=index,
        odometry=Odometry(np.zeros(3), float(index)),
        range_bearing=sightings if rb else None,
        bearings=rays if bearings else None,
    )


def test_streams_found_in_any_frame():
    frames = [_frame(0), _frame(1, rb=True), _frame(2, bearings=True)]
    assert modalities_of(frames) == {Modality.RANGE_BEARING_2D, Modality.BEARINGS_3D}
    assert modalities_of([_frame(0)]) == frozenset()


def test_priority_picks_the_first_shared_stream():
    available = {Modality.RANGE_BEARING_2D, Modality.BEARINGS_3D}
    assert resolve_modality(available, ALL) is Modality.BEARINGS_3D
    assert resolve_modality(available, {Modality.RANGE_BEARING_2D}) is Modality.RANGE_BEARING_2D
    assert PRIORITY[0] is Modality.BEARINGS_3D and set(PRIORITY) == ALL
    # the image streams of the front end come before direct range-bearing sightings
    lines_and_poles = {Modality.RANGE_BEARING_2D, Modality.VERTICAL_LINES}
    assert resolve_modality(lines_and_poles, ALL) is Modality.VERTICAL_LINES


def test_override_wins_when_usable():
    available = {Modality.RANGE_BEARING_2D, Modality.BEARINGS_3D}
    chosen = resolve_modality(available, ALL, Modality.RANGE_BEARING_2D)
    assert chosen is Modality.RANGE_BEARING_2D


@pytest.mark.parametrize(
    ("available", "accepted", "override"),
    [
        ({Modality.VERTICAL_LINES}, {Modality.RANGE_BEARING_2D}, None),
        ({Modality.RANGE_BEARING_2D}, ALL, Modality.BEARINGS_3D),
        ({Modality.BEARINGS_3D}, {Modality.RANGE_BEARING_2D}, Modality.BEARINGS_3D),
        (set(), ALL, None),
    ],
)
def test_unusable_data_names_both_sides(available, accepted, override):
    with pytest.raises(ConfigError) as raised:
        resolve_modality(available, accepted, override, estimator="ukf", dataset="mrclam6-r1")
    message = str(raised.value)
    assert "mrclam6-r1 has:" in message and "ukf takes:" in message
    assert "\n" not in message


def test_data_without_a_usable_stream_are_told_what_would_provide_one():
    accepted = {Modality.VERTICAL_LINES, Modality.RANGE_BEARING_2D}
    with pytest.raises(ConfigError) as raised:
        resolve_modality(set(), accepted, estimator="ukf", dataset="room")
    message = str(raised.value)
    assert "give it camera images" in message and "landmark sightings with bearings" in message
    assert "omni camera" not in message  # ukf does not take the omni bearings


def test_parse_accepts_both_spellings_and_lists_known_names():
    assert Modality.parse("range_bearing_2d") is Modality.RANGE_BEARING_2D
    assert Modality.parse("Bearings-3D") is Modality.BEARINGS_3D
    with pytest.raises(ConfigError, match="known: range-bearing-2d, bearings-3d, vertical-lines"):
        Modality.parse("sonar")
