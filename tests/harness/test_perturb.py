"""Wrong ids and clutter on purpose (harness.perturb) and the harness options that apply them."""

from __future__ import annotations

import numpy as np
import pytest

from omnislam.core.types import UNKNOWN_ID, Bearings, FrameInput, Odometry, RangeBearing
from omnislam.errors import ConfigError
from omnislam.harness.execute import RunSpec, execute_run
from omnislam.harness.perturb import (
    add_clutter,
    clutter_stream,
    parse_clutter_rate,
    parse_fraction,
    reassign_ids,
)


def frames(count: int, rng: np.random.Generator) -> list[FrameInput]:
    """Frames with 12 labelled bearings (ids 0..39), 2 unlabelled, and 3 range-bearings."""
    out = []
    for k in range(count):
        ids = np.concatenate([rng.choice(40, 12, replace=False), [UNKNOWN_ID, UNKNOWN_ID]])
        rays = rng.normal(size=(14, 3))
        rays /= np.linalg.norm(rays, axis=1, keepdims=True)
        out.append(
            FrameInput(
                k,
                Odometry(np.array([0.1, 0.0, 0.01]), float(k)),
                bearings=Bearings(ids, rays, np.full(14, 0.01)),
                range_bearing=RangeBearing(np.array([3, 5, 7]), np.ones(3), np.zeros(3), 0.1, 0.01),
            )
        )
    return out


def test_reassigned_sightings_take_another_id_of_their_own_frame(rng):
    clean = frames(300, rng)
    wrong, count = reassign_ids(clean, 0.2, np.random.default_rng(1))
    changed = 0
    for before, after in zip(clean, wrong, strict=True):
        assert after.odometry is before.odometry
        for name in ("bearings", "range_bearing"):
            a, b = getattr(before, name), getattr(after, name)
            np.testing.assert_array_equal(
                getattr(a, "unit_vectors_r", getattr(a, "ranges_m", None)),
                getattr(b, "unit_vectors_r", getattr(b, "ranges_m", None)),
            )
            moved = a.landmark_ids != b.landmark_ids
            changed += int(moved.sum())
            assert np.all(a.landmark_ids[a.landmark_ids == UNKNOWN_ID] == UNKNOWN_ID)
            assert np.all(b.landmark_ids[a.landmark_ids == UNKNOWN_ID] == UNKNOWN_ID)
            assert set(b.landmark_ids[moved].tolist()) <= set(a.landmark_ids.tolist())
            assert np.all(b.landmark_ids[moved] != UNKNOWN_ID)  # never made unlabelled
    assert changed == count
    labelled = 300 * 15
    # binomial(4500, 0.2): sd 27, the count lands within 4 sd of 900
    assert abs(count - 0.2 * labelled) < 4 * np.sqrt(labelled * 0.2 * 0.8)


def test_reassignment_is_deterministic_and_zero_is_the_identity(rng):
    clean = frames(20, rng)
    a, na = reassign_ids(clean, 0.3, np.random.default_rng(7))
    b, nb = reassign_ids(clean, 0.3, np.random.default_rng(7))
    assert na == nb > 0
    for fa, fb in zip(a, b, strict=True):
        np.testing.assert_array_equal(fa.bearings.landmark_ids, fb.bearings.landmark_ids)
    same, none = reassign_ids(clean, 0.0, np.random.default_rng(7))
    assert none == 0 and all(x is y for x, y in zip(same, clean, strict=True))


def lonely(index: int, landmark: int) -> FrameInput:
    return FrameInput(
        index,
        Odometry(np.zeros(3), float(index)),
        range_bearing=RangeBearing(np.array([landmark] * 2), np.ones(2), np.zeros(2), 0.1, 0.01),
    )


def test_a_frame_with_a_single_id_borrows_a_wrong_one_from_the_whole_input():
    out, count = reassign_ids([lonely(0, 4), lonely(1, 9)], 0.99, np.random.default_rng(0))
    assert count > 0
    ids = np.concatenate([f.range_bearing.landmark_ids for f in out])
    assert set(ids.tolist()) <= {4, 9} and not np.array_equal(ids, [4, 4, 9, 9])
    # nor does it borrow UNKNOWN_ID from frames without labels: 40 sightings, each would
    # take it with probability 1/2 if it counted as an id of the input
    unlabelled = lonely(40, UNKNOWN_ID)
    many = [lonely(k, (4, 9)[k % 2]) for k in range(20)] + [unlabelled]
    out, count = reassign_ids(many, 0.99, np.random.default_rng(0))
    assert count > 30
    ids = np.concatenate([f.range_bearing.landmark_ids for f in out[:20]])
    assert set(ids.tolist()) <= {4, 9}
    alone, none = reassign_ids([lonely(0, 4)], 0.99, np.random.default_rng(0))
    assert none == 0 and alone[0].range_bearing.landmark_ids.tolist() == [4, 4]


@pytest.mark.parametrize("fraction", [-0.1, 1.0, 2.0])
def test_a_fraction_outside_0_1_is_refused(fraction):
    with pytest.raises(ConfigError, match="wrong_id_fraction"):
        reassign_ids([], fraction, np.random.default_rng(0))
    with pytest.raises(ConfigError, match="wrong_id_fraction"):
        parse_fraction(str(fraction))


def test_the_option_texts_parse_to_their_values():
    assert parse_fraction("0") == 0.0 and parse_fraction("0.25") == 0.25
    assert parse_clutter_rate("0") == 0.0 and parse_clutter_rate("1.5") == 1.5
    for parse in (parse_fraction, parse_clutter_rate):
        with pytest.raises(ConfigError):
            parse("x")


def test_the_harness_option_relabels_sightings_and_records_it(shared_data):
    clean = execute_run(RunSpec("mrclam6-r1", "deadreckoning", seed=3))
    wrong = execute_run(
        RunSpec("mrclam6-r1", "deadreckoning", seed=3, options={"wrong_id_fraction": "0.2"})
    )
    assert clean.config.wrong_id_fraction == 0.0 and clean.config.sightings_reassigned == 0
    assert wrong.config.wrong_id_fraction == 0.2
    assert 230 < wrong.config.sightings_reassigned < 385  # 20% of 1534: 307, sd 16
    assert "wrong_id_fraction" not in wrong.config.estimator_options
    # dead reckoning ignores sightings: the perturbation must not touch anything else
    np.testing.assert_array_equal(
        clean.estimate.trajectory.poses_w, wrong.estimate.trajectory.poses_w
    )
    with pytest.raises(ConfigError, match="wrong_id_fraction"):
        execute_run(RunSpec("mrclam6-r1", "deadreckoning", options={"wrong_id_fraction": "x"}))


def test_clutter_is_poisson_per_sensed_frame_unlabelled_and_inside_the_datas_span(rng):
    clean = frames(400, rng)
    clean[7] = FrameInput(7, clean[7].odometry, bearings=clean[7].bearings)  # no range sensor
    ranges = rng.uniform(2.0, 9.0, 3)
    clean[3] = FrameInput(
        3,
        clean[3].odometry,
        range_bearing=RangeBearing(np.array([1, 2, 3]), ranges, [-0.5, 0.2, 1.1], 0.3, 0.02),
    )
    cluttered, added = add_clutter(clean, 0.5, np.random.default_rng(4))
    per_frame = []
    for before, after in zip(clean, cluttered, strict=True):
        assert after.odometry is before.odometry and after.bearings is before.bearings
        if before.range_bearing is None:
            assert after.range_bearing is None
            continue
        a, b = before.range_bearing, after.range_bearing
        k = len(a)
        np.testing.assert_array_equal(b.landmark_ids[:k], a.landmark_ids)  # kept, in front
        np.testing.assert_array_equal(b.ranges_m[:k], a.ranges_m)
        extra = len(b) - k
        per_frame.append(extra)
        assert np.all(b.landmark_ids[k:] == UNKNOWN_ID)
        assert np.all((b.ranges_m[k:] >= 1.0) & (b.ranges_m[k:] <= ranges.max()))
        assert np.all((b.bearings_rad[k:] >= -0.5) & (b.bearings_rad[k:] <= 1.1))
        np.testing.assert_array_equal(b.sigma_range_m[k:], 0.1)  # the data's median sigma
        np.testing.assert_array_equal(b.sigma_bearing_rad[k:], 0.01)
    assert sum(per_frame) == added and len(per_frame) == 399
    assert 0.4 < np.mean(per_frame) < 0.6  # Poisson(0.5) over 399 frames: sd 0.035
    assert 0.32 < np.mean(np.array(per_frame) == 0) < 0.9  # e^-0.5 = 0.61 frames without any
    again, _ = add_clutter(clean, 0.5, np.random.default_rng(4))
    for a, b in zip(cluttered, again, strict=True):
        if a.range_bearing is not None:
            np.testing.assert_array_equal(a.range_bearing.ranges_m, b.range_bearing.ranges_m)
    same, none = add_clutter(clean, 0.0, np.random.default_rng(4))
    assert none == 0 and all(a is b for a, b in zip(same, clean, strict=True))


@pytest.mark.parametrize("rate", [-0.1, float("nan"), float("inf")])
def test_a_clutter_rate_that_is_not_a_finite_non_negative_number_is_refused(rate, rng):
    with pytest.raises(ConfigError, match="clutter_per_frame"):
        add_clutter(frames(3, rng), rate, np.random.default_rng(0))


def test_a_sensed_frame_without_sightings_gets_clutter_too():
    """The sensor reported and saw nothing: still Poisson(rate); 200 such frames at rate 2
    all without clutter has probability e^-400."""
    seen = FrameInput(
        0,
        Odometry(np.zeros(3), 0.0),
        range_bearing=RangeBearing(np.array([1, 2]), np.array([1.0, 5.0]), np.zeros(2), 0.1, 0.01),
    )
    empty = RangeBearing(np.zeros(0, np.int64), np.zeros(0), np.zeros(0), 0.1, 0.01)
    blank = [
        FrameInput(k, Odometry(np.zeros(3), float(k)), range_bearing=empty) for k in range(1, 201)
    ]
    out, added = add_clutter([seen, *blank], 2.0, np.random.default_rng(0))
    on_blank = sum(len(f.range_bearing) for f in out[1:])
    assert on_blank > 0 and added - on_blank == len(out[0].range_bearing) - 2


def test_the_clutter_stream_is_neither_the_estimators_nor_the_wrong_ids():
    """``execute_run`` seeds the estimator with the seed itself and the wrong ids with the
    first spawned child: clutter must draw from neither (with and without clutter the
    estimator's numbers, and the wrong ids, stay the same)."""
    clutter = clutter_stream(3).random(4)
    estimator = np.random.default_rng(3).random(4)
    wrong_ids = np.random.default_rng(np.random.SeedSequence(3).spawn(1)[0]).random(4)
    assert not np.allclose(clutter, estimator) and not np.allclose(clutter, wrong_ids)
    np.testing.assert_array_equal(clutter, clutter_stream(3).random(4))


def test_clutter_needs_range_bearing_sightings(rng):
    bearings_only = [FrameInput(f.index, f.odometry, bearings=f.bearings) for f in frames(3, rng)]
    with pytest.raises(ConfigError, match="no range-bearing sightings"):
        add_clutter(bearings_only, 0.5, np.random.default_rng(0))


def test_the_harness_option_adds_clutter_and_records_it(shared_data):
    clean = execute_run(RunSpec("mrclam6-r1", "deadreckoning", seed=3))
    noisy = execute_run(
        RunSpec("mrclam6-r1", "deadreckoning", seed=3, options={"clutter_per_frame": "0.5"})
    )
    assert clean.config.clutter_per_frame == 0.0 and clean.config.clutter_added == 0
    assert noisy.config.clutter_per_frame == 0.5
    sensed = noisy.config.frames  # every MR.CLAM frame carries its (maybe empty) sightings
    assert abs(noisy.config.clutter_added - 0.5 * sensed) < 5 * np.sqrt(0.5 * sensed)
    assert "clutter_per_frame" not in noisy.config.estimator_options
    np.testing.assert_array_equal(
        clean.estimate.trajectory.poses_w, noisy.estimate.trajectory.poses_w
    )
    with pytest.raises(ConfigError, match="clutter_per_frame"):
        execute_run(RunSpec("mrclam6-r1", "deadreckoning", options={"clutter_per_frame": "x"}))
