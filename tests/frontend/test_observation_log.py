"""ObservationLog: round trip, stale-cache protection, malformed files."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from omnislam.core.types import Bearings, FrameInput, Odometry, RangeBearing, VerticalLines
from omnislam.errors import DataError
from omnislam.frontend.observation_log import (
    LOG_FORMAT_VERSION,
    ObservationLog,
    StaleLogError,
    load_observation_log,
    read_log_key,
    save_observation_log,
)


def _log() -> ObservationLog:
    rng = np.random.default_rng(0)
    vectors = rng.normal(size=(4, 3))
    vectors /= np.linalg.norm(vectors, axis=1, keepdims=True)
    frames = (
        FrameInput(0, Odometry(np.zeros(3), 0.0)),
        FrameInput(
            1,
            Odometry(np.array([0.1, 0.0, 0.02]), 0.1),
            bearings=Bearings(np.array([3, 7, 8, 9]), vectors, np.full(4, 0.01)),
            range_bearing=RangeBearing(np.array([-1]), [2.0], [0.3], [0.02], [0.0175]),
            vertical_lines=VerticalLines(
                np.array([0.5]), [0.005], rng.random((1, 3, 11)), rng.random((1, 3)),
                rng.random((1, 3)), np.array([-1]),
            ),
        ),
        FrameInput(2, Odometry(np.array([0.1, 0.0, 0.0]), 0.2),
                   bearings=Bearings(np.zeros(0), np.zeros((0, 3)), np.zeros(0))),
    )
    pixels = (None, rng.random((4, 2)) * 640, np.zeros((0, 2)))
    return ObservationLog("demo-abc", "0123456789abcdef", frames, pixels,
                          config={"sift": {"edge_threshold": 2.0}}, stats={"images": 2.0})


def test_round_trip_keeps_every_record(tmp_path):
    log = _log()
    path = tmp_path / "log.npz"
    save_observation_log(log, path)
    back = load_observation_log(path, dataset_id="demo-abc", config_hash="0123456789abcdef")
    assert (back.dataset_id, back.config_hash) == (log.dataset_id, log.config_hash)
    assert back.config == log.config and back.stats == log.stats
    assert len(back) == len(log)
    for a, b, pa, pb in zip(log.frames, back.frames, log.pixels, back.pixels, strict=True):
        assert a.index == b.index and a.stamp_s == b.stamp_s
        np.testing.assert_array_equal(a.odometry.delta, b.odometry.delta)
        for name in ("bearings", "range_bearing", "vertical_lines"):
            ra, rb = getattr(a, name), getattr(b, name)
            assert (ra is None) == (rb is None)
            if ra is not None:
                for field in ra.__slots__:
                    np.testing.assert_array_equal(getattr(ra, field), getattr(rb, field))
        assert (pa is None) == (pb is None)
        if pa is not None:
            np.testing.assert_array_equal(pa, pb)
    assert read_log_key(path) == ("demo-abc", "0123456789abcdef")


def test_a_changed_config_or_dataset_never_reuses_the_cache(tmp_path):
    path = tmp_path / "log.npz"
    save_observation_log(_log(), path)
    with pytest.raises(StaleLogError, match="configuration"):
        load_observation_log(path, config_hash="ffffffffffffffff")
    with pytest.raises(StaleLogError, match="dataset"):
        load_observation_log(path, dataset_id="lab40-000000000000")


def test_another_format_version_is_stale(tmp_path):
    path = tmp_path / "log.npz"
    save_observation_log(_log(), path)
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    meta = json.loads(str(arrays["meta"]))
    meta["version"] = LOG_FORMAT_VERSION + 1
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez_compressed(path, **arrays)
    with pytest.raises(StaleLogError, match="version"):
        load_observation_log(path)


def _with_meta(path, **changes):
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    meta = json.loads(str(arrays["meta"]))
    meta.update(changes)
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez_compressed(path, **arrays)


def test_the_floor_tracks_first_id_round_trips_and_is_checked(tmp_path):
    path = tmp_path / "log.npz"
    log = dataclasses.replace(_log(), floor_ids_from=8)
    save_observation_log(log, path)
    assert load_observation_log(path).floor_ids_from == 8
    save_observation_log(_log(), path)
    assert load_observation_log(path).floor_ids_from is None
    for bad in (-1, 2.5, "8", True):
        _with_meta(path, floor_ids_from=bad)
        with pytest.raises(DataError, match="floor_ids_from"):
            load_observation_log(path)
    with pytest.raises(DataError, match="floor_ids_from"):
        dataclasses.replace(_log(), floor_ids_from=-3)


@pytest.mark.parametrize("content", [b"", b"not a zip", None])
def test_malformed_or_missing_files_raise_data_error(tmp_path, content):
    path = tmp_path / "log.npz"
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(DataError):
        load_observation_log(path)
