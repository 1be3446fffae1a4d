"""execute_run's attachments: the estimator's own counts travel with the RUN_DIR."""

from __future__ import annotations

import json

import numpy as np
import pytest

from omnislam.deadreckoning import DeadReckoning
from omnislam.errors import ConfigError, DataError
from omnislam.harness.execute import RunSpec, execute_run
from omnislam.harness.layout import ESTIMATOR_INFO
from omnislam.harness.rundir import read_run_dir, write_run_dir


def test_graphslam_counts_are_written_next_to_the_estimate(shared_data, tmp_path):
    record = execute_run(RunSpec("mrclam6-r1", "graphslam", seed=0))
    write_run_dir(tmp_path / "run", record)
    info = json.loads((tmp_path / "run" / ESTIMATOR_INFO).read_text())
    assert info["modality"] == "range-bearing-2d"
    assert info["frames"] == record.config.frames
    assert info["landmarks"] == len(record.estimate.landmark_ids) == 15
    assert info["factorization_fallbacks"] == 0
    assert (
        read_run_dir(tmp_path / "run").attachments[ESTIMATOR_INFO]
        == (tmp_path / "run" / ESTIMATOR_INFO).read_bytes()
    )


def test_the_stages_of_a_run_are_timed_and_written(shared_data, tmp_path):
    from omnislam.harness.rundir import read_run_config

    seen = []
    record = execute_run(
        RunSpec("mrclam6-r1", "graphslam", seed=0), on_step=lambda *args: seen.append(args)
    )
    stages = ["loading", "front end", "running", "final estimate"]  # front end: nothing to do
    assert seen[0][0] == "loading" and seen[-1][0] == "final estimate"  # every call passed on
    config = record.config
    assert list(config.stages_wall_s) == list(config.stages_cpu_s) == stages
    assert all(v >= 0 for v in (*config.stages_wall_s.values(), *config.stages_cpu_s.values()))
    # the steps and the final estimate are within their stages
    assert config.stages_wall_s["running"] + config.stages_wall_s["final estimate"] >= (
        0.9 * config.total_s
    )
    write_run_dir(tmp_path / "run", record)
    assert read_run_config(tmp_path / "run").stages_cpu_s == config.stages_cpu_s


def test_an_estimator_without_info_writes_none(shared_data):
    record = execute_run(RunSpec("mrclam6-r1", "deadreckoning", seed=0))
    assert ESTIMATOR_INFO not in record.attachments


def test_the_resolved_modality_is_recorded(shared_data):
    record = execute_run(RunSpec("mrclam6-r1", "fastslam1", seed=0))
    assert record.config.modality == "range-bearing-2d"
    assert execute_run(RunSpec("mrclam6-r1", "deadreckoning")).config.modality is None


def test_a_modality_the_data_lack_is_one_clear_error(shared_data):
    spec = RunSpec("mrclam6-r1", "graphslam", options={"modality": "bearings-3d"})
    with pytest.raises(ConfigError) as raised:
        execute_run(spec)
    assert "has: range-bearing-2d" in str(raised.value)
    assert "\n" not in str(raised.value)


def test_prior_map_from_an_earlier_run_reaches_the_estimator(shared_data, tmp_path, monkeypatch):
    import omnislam.estimators as registry

    mapped = execute_run(RunSpec("mrclam6-r1", "graphslam", seed=0))
    write_run_dir(tmp_path / "map", mapped)
    seen = {}

    def capture(info, options, rng):
        seen["info"] = info
        return DeadReckoning()

    monkeypatch.setattr(registry, "estimator_factory", lambda name: capture)
    record = execute_run(
        RunSpec("mrclam6-r1", "deadreckoning", options={"prior_map": str(tmp_path / "map")})
    )
    prior = seen["info"].prior_map
    assert record.config.prior_map == str(tmp_path / "map")
    assert np.array_equal(prior.landmark_ids, mapped.estimate.landmark_ids)
    assert np.allclose(prior.points_w, mapped.estimate.landmarks_w, atol=1e-9)
    assert np.allclose(prior.initial_pose_w, 0.0, atol=1e-12)


def test_the_datasets_own_prior_map_reaches_the_estimator(shared_data, monkeypatch):
    import omnislam.estimators as registry

    seen = {}

    def capture(info, options, rng):
        seen["info"] = info
        return DeadReckoning()

    monkeypatch.setattr(registry, "estimator_factory", lambda name: capture)
    execute_run(RunSpec("mrclam6-r1", "deadreckoning"))
    assert len(seen["info"].prior_map) == 15


def test_prior_map_of_a_missing_or_empty_run_is_refused(shared_data, tmp_path):
    with pytest.raises(ConfigError, match="prior_map"):
        execute_run(RunSpec("mrclam6-r1", "deadreckoning", options={"prior_map": "nope"}))
    empty = execute_run(RunSpec("mrclam6-r1", "deadreckoning"))
    write_run_dir(tmp_path / "dr", empty)
    with pytest.raises(DataError, match="no landmarks"):
        execute_run(
            RunSpec("mrclam6-r1", "deadreckoning", options={"prior_map": str(tmp_path / "dr")})
        )


def test_a_loader_option_hiding_ids_reaches_the_estimator_through_the_shared_log(tmp_path):
    """The shared front-end log of a synthetic world stores its pole sightings with their ids;
    the ``-noids`` cell replaying it must still see them without (otherwise demo-noids would
    give byte-identical trajectories to demo)."""
    from omnislam.frontend.observation_log import load_observation_log
    from omnislam.harness.grid import load_grid
    from omnislam.harness.layout import CELLS
    from omnislam.harness.runner import CellStatus, SerialExecutor, run_grid

    grid_file = tmp_path / "grid.yaml"
    grid_file.write_text(
        "name: ids and no ids\n"
        "datasets:\n"
        "  - {synthetic: demo, images: 2, seeds: [0], estimators: [ekfslam]}\n"
        "  - {synthetic: demo, label: demo-noids, images: 2, seeds: [0],\n"
        "     options: {association: unknown}, estimators: [ekfslam]}\n"
        "estimators: [ekfslam]\n"
    )
    grid = load_grid(grid_file)
    result = run_grid(grid, tmp_path / "out", lambda: SerialExecutor())
    assert result.count(CellStatus.COMPUTED) == 2, [o.error for o in result.outcomes]
    runs = {o.cell.dataset_label: read_run_dir(tmp_path / "out" / CELLS / o.cell.cell_id)
            for o in result.outcomes}
    log = load_observation_log(runs["demo"].config.frontend_log)
    assert runs["demo-noids"].config.frontend_log == runs["demo"].config.frontend_log
    logged = [f.range_bearing for f in log.frames if f.range_bearing is not None]
    assert sum(len(rb) for rb in logged) > 0 and all(np.all(rb.landmark_ids >= 0) for rb in logged)
    assert runs["demo"].config.landmark_ids_from_truth
    assert not runs["demo-noids"].config.landmark_ids_from_truth
    info = {k: json.loads(r.attachments[ESTIMATOR_INFO]) for k, r in runs.items()}
    assert info["demo"]["sightings"] == info["demo-noids"]["sightings"] > 0
    assert info["demo"]["ambiguous"] == info["demo"]["gated"] == 0  # ids: nothing to decide
    assert info["demo-noids"]["tentative_created"] > 0  # it associated by itself


def test_fastslam_samples_the_laser_odometrys_covariance_by_default(tmp_path):
    """A laser log's odometry (scan matching, a covariance per step) reaches FastSLAM as laser
    odometry: by default (``stated_odometry_noise`` auto) its poses are drawn from the stated
    covariance of every matched step; dead reckoning's wheels and an explicit ``false`` are not."""
    pytest.importorskip("open3d")
    from room_log import write_room_log

    # 180 beams: the walls' RANSAC lines give the front end landmarks to sight
    room_log = write_room_log(tmp_path / "data" / "room.log", beams=180)

    def stated_frames(options: dict[str, str]) -> int:
        record = execute_run(RunSpec(str(room_log), "fastslam2", 0, options))
        return json.loads(record.attachments[ESTIMATOR_INFO])["frames_stated_odometry"]

    matched = stated_frames({})
    assert matched > 0.8 * 60  # the room's scans register almost every step
    assert stated_frames({"stated_odometry_noise": "false"}) == 0
    assert stated_frames({"stated_odometry_noise": "true"}) == matched
