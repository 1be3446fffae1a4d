"""``benchmarks/thesis_metrics.py``: poles mapped twice and the loop's closure, on a square
100 m loop whose answers are known -- a pole near the start is seen again at the end; an
estimate that agrees with the truth re-associates it there, one that drifts does not."""

from __future__ import annotations

import importlib.util
import itertools
import math
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location(
    "thesis_metrics", REPO / "benchmarks" / "thesis_metrics.py"
)
tm = importlib.util.module_from_spec(_spec)
sys.modules["thesis_metrics"] = tm
_spec.loader.exec_module(tm)

#: the side of the square loop [m] and the step between frames [m]
SIDE_M, STEP_M = 25.0, 0.5
#: the sensor's range [m]
RANGE_M = 4.0
#: poles: one near the start (seen at the start and the end), one half-way along the third side
POLES_XY = np.array([[2.0, -1.5], [12.5, 26.5]])
#: the drift of the drifting estimate: x offset per metre travelled
DRIFT_PER_M = 0.02


def _square_loop() -> np.ndarray:
    """(N, 3) poses round the square counter-clockwise from the origin, back to it."""
    corners = np.array([[0, 0], [SIDE_M, 0], [SIDE_M, SIDE_M], [0, SIDE_M], [0, 0]], float)
    poses = []
    for a, b in itertools.pairwise(corners):
        heading = math.atan2(*(b - a)[::-1])
        for s in np.arange(0.0, SIDE_M, STEP_M):
            poses.append([*(a + s / SIDE_M * (b - a)), heading])
    poses.append([0.0, 0.0, 0.0])
    return np.array(poses)


def _sightings(wTr: np.ndarray) -> object:
    """Exact sightings of every pole within range."""
    frames, poles, ranges, bearings = [], [], [], []
    for k, (x, y, theta) in enumerate(wTr):
        for pole, (px, py) in enumerate(POLES_XY):
            r = math.hypot(px - x, py - y)
            if r <= RANGE_M:
                frames.append(k)
                poles.append(pole)
                ranges.append(r)
                bearings.append(math.atan2(py - y, px - x) - theta)
    return tm.Sightings(np.array(frames), np.array(poles), np.array(ranges), np.array(bearings))


@pytest.fixture
def loop():
    wTr = _square_loop()
    travel = tm.travelled_m(wTr[:, :2])
    sightings = _sightings(wTr)
    return wTr, travel, sightings, tm.revisits(sightings, travel)


def test_a_pole_seen_at_the_start_is_revisited_at_the_end(loop):
    _, travel, sightings, found = loop
    assert travel[-1] == pytest.approx(4 * SIDE_M)
    assert len(found) == 1  # the half-way pole is seen once, in one visit
    revisit = found[0]
    assert revisit.pole == 0
    at_end = sightings.frames[sightings.poles == 0]
    expected_frame = int(at_end[travel[at_end] > 50].min())
    assert revisit.frame == expected_frame
    assert revisit.travel_m == pytest.approx(travel[expected_frame])
    assert np.all(travel[sightings.frames[revisit.first_visit]] < 10)
    window_travel = travel[sightings.frames[revisit.window]]
    assert window_travel.max() - window_travel.min() <= tm.REVISIT_WINDOW_M
    assert tm.revisits(sightings, travel, gap_m=200.0) == []


def test_the_truth_closes_the_loop_at_the_first_revisit(loop):
    wTr, travel, sightings, found = loop
    errors = tm.revisit_errors(sightings, found, wTr)
    np.testing.assert_allclose(errors, 0.0, atol=1e-9)
    start, end = tm.blind_stretch(sightings, travel)
    assert start < 10 and end > 50  # between the start pole and the half-way pole
    closure = tm.loop_closure(found, errors, end)
    assert closure.closed_frame == closure.first_chance_frame == found[0].frame
    assert closure.closed_m == pytest.approx(found[0].travel_m)
    assert closure.closed_share == 1.0


def test_a_drifting_estimate_never_closes_the_loop(loop):
    wTr, travel, sightings, found = loop
    drifted = wTr + np.column_stack([DRIFT_PER_M * travel, np.zeros((len(wTr), 2))])
    errors = tm.revisit_errors(sightings, found, drifted)
    revisit = found[0]
    mean_travel = [travel[sightings.frames[i]].mean() for i in (revisit.window,
                                                                 revisit.first_visit)]
    assert errors[0] == pytest.approx(DRIFT_PER_M * (mean_travel[0] - mean_travel[1]))
    assert errors[0] > tm.CLOSE_M
    closure = tm.loop_closure(found, errors, blind_end_m=0.0)
    assert closure.closed_frame is None and closure.closed_m is None
    assert closure.first_chance_frame == revisit.frame
    assert closure.closed_share == closure.after_blind_share == 0.0
    nothing = tm.loop_closure([], np.zeros(0), 0.0)
    assert nothing.first_chance_frame is None and math.isnan(nothing.closed_share)


def test_a_pole_with_two_landmarks_near_it_is_mapped_twice():
    poles = np.array([[0.0, 0.0], [1.5, 0.0], [8.0, 0.0]])
    landmarks = np.array([
        [0.1, 0.0], [-0.2, 0.3],  # pole 0, twice
        [0.9, 0.0],  # 0.9 m from pole 0 but nearer pole 1: pole 1's
        [6.5, 0.0],  # 1.5 m from pole 2: nobody's
    ])
    result = tm.pole_duplicates(landmarks, poles)
    np.testing.assert_array_equal(result.per_pole, [2, 1, 0])
    assert result.mapped_twice == 1 and result.far == 1
    empty = tm.pole_duplicates(np.zeros((0, 2)), poles)
    assert empty.mapped_twice == 0 and empty.far == 0
