"""execute_run's attachments: the estimator's own counts travel with the RUN_DIR."""

from __future__ import annotations

import json

from omnislam.compare.execute import RunSpec, execute_run
from omnislam.compare.rundir import ESTIMATOR_INFO, read_run_dir, write_run_dir


def test_graphslam_counts_are_written_next_to_the_estimate(shared_data, tmp_path):
    record = execute_run(RunSpec("mrclam6-r1", "graphslam", seed=0))
    write_run_dir(tmp_path / "run", record)
    info = json.loads((tmp_path / "run" / ESTIMATOR_INFO).read_text())
    assert info["modality"] == "range-bearing-2d"
    assert info["frames"] == record.config.frames
    assert info["landmarks"] == len(record.estimate.landmark_ids) == 15
    assert info["factorization_fallbacks"] == 0
    assert read_run_dir(tmp_path / "run").attachments[ESTIMATOR_INFO] == (
        tmp_path / "run" / ESTIMATOR_INFO
    ).read_bytes()


def test_an_estimator_without_info_writes_none(shared_data):
    record = execute_run(RunSpec("mrclam6-r1", "deadreckoning", seed=0))
    assert ESTIMATOR_INFO not in record.attachments
