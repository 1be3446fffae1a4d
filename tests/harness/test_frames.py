"""The frames an estimator is fed (``harness.frames``) and a run's options split by who takes
them (``execute.parse_run_options``), on the small MR.CLAM folder (range-bearing sightings with
their true ids, no front-end log)."""

from __future__ import annotations

import numpy as np
import pytest
from small_mrclam import write_small_mrclam

from omnislam.core.types import UNKNOWN_ID
from omnislam.datasets.registry import load_dataset
from omnislam.errors import ConfigError
from omnislam.harness.execute import parse_run_options
from omnislam.harness.frames import fed_frames, sequence_info


@pytest.fixture(scope="module")
def sequence(tmp_path_factory: pytest.TempPathFactory):
    return load_dataset(str(write_small_mrclam(tmp_path_factory.mktemp("data") / "MRCLAM_Small")))


def _ids(frames) -> list[np.ndarray]:
    return [f.range_bearing.landmark_ids for f in frames if f.range_bearing is not None]


def test_the_options_split_into_the_harnesss_the_loaders_and_the_estimators():
    options = parse_run_options(
        {"wrong_id_fraction": "0.25", "clutter_per_frame": "1.5", "prior_map": "runs/a",
         "association": "unknown", "particles": "50"},
        loader_keys={"association"},
    )
    assert (options.wrong_id_fraction, options.clutter_per_frame) == (0.25, 1.5)
    assert options.prior_map == "runs/a"
    assert options.dataset == {"association": "unknown"}
    assert options.estimator == {"particles": "50"}
    plain = parse_run_options({"particles": "50"}, loader_keys=())
    assert (plain.wrong_id_fraction, plain.clutter_per_frame, plain.prior_map) == (0.0, 0.0, None)
    with pytest.raises(ConfigError, match="wrong_id_fraction"):
        parse_run_options({"wrong_id_fraction": "2"}, loader_keys=())


def test_without_faults_the_estimator_is_fed_the_datasets_own_frames(sequence):
    fed = fed_frames(sequence, "ekfslam", seed=0)
    own = list(sequence.frame_inputs())
    assert len(fed.frames) == len(own) == len(sequence)
    assert all(np.array_equal(a, b) for a, b in zip(_ids(fed.frames), _ids(own), strict=True))
    assert (fed.replay, fed.log, fed.reassigned, fed.clutter_added) == (None, None, 0, 0)
    assert fed.info.known_association


def test_the_estimator_is_told_about_the_data_before_the_clutter_is_added(sequence):
    fed = fed_frames(sequence, "ekfslam", clutter_per_frame=2.0, seed=0)
    assert fed.clutter_added > 0
    assert any(np.any(ids == UNKNOWN_ID) for ids in _ids(fed.frames))
    # the clutter has no ids, yet the data's sightings all carry theirs: that is what it is told
    assert fed.info.known_association
    assert not sequence_info(sequence, fed.frames).known_association


def test_wrong_ids_are_counted_and_drawn_from_their_own_stream(sequence):
    wrong = fed_frames(sequence, "ekfslam", wrong_id_fraction=0.3, seed=4)
    own = _ids(sequence.frame_inputs())
    changed = sum(int(np.sum(a != b)) for a, b in zip(_ids(wrong.frames), own, strict=True))
    assert wrong.reassigned == changed > 0
    again = fed_frames(sequence, "ekfslam", wrong_id_fraction=0.3, clutter_per_frame=1.0, seed=4)
    assert again.clutter_added > 0
    # the clutter, drawn after, leaves the re-labelled ids of the data's own rows as they were
    for before, after in zip(wrong.frames, again.frames, strict=True):
        if before.range_bearing is not None:
            ids = before.range_bearing.landmark_ids
            assert np.array_equal(after.range_bearing.landmark_ids[: len(ids)], ids)
