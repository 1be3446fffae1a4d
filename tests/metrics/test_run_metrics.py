"""RunMetrics and metrics.json: round trips, one definition of the keys, malformed files."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from room_log import write_room_log

from omnislam.cli import main
from omnislam.datasets.sequence import GroundTruthKind
from omnislam.errors import DataError
from omnislam.harness.evaluation import evaluate_run
from omnislam.harness.grid import load_grid
from omnislam.harness.layout import CELLS, METRICS, RESULTS_CSV
from omnislam.harness.rundir import read_run_dir, write_run_dir
from omnislam.harness.runner import CSV_LABELS, SerialExecutor, run_grid
from omnislam.metrics.landmarks import LandmarkAssociation
from omnislam.metrics.run_metrics import (
    CSV_FIELDS,
    MEASURED_KEYS,
    METRIC_FIELDS,
    SCHEMA_KEY,
    SCHEMA_VERSION,
    AteMetrics,
    ConsistencyMetrics,
    GroundTruthInfo,
    LandmarkMetrics,
    RpeMetrics,
    RpeSegment,
    RunInfo,
    RunMetrics,
    TimingMetrics,
    read_run_metrics,
    write_run_metrics,
)
from omnislam.metrics.trajectory import Alignment

#: the metrics.json keys DESIGN.md promises to scripts, benchmarks and reports
DESIGN_CONTRACT_KEYS = (
    "ate_rmse_m",
    "ate_max_m",
    "rpe_trans_rmse_m",
    "landmark_rmse_m",
    "landmarks_estimated",
    "landmarks_matched",
    "nees_mean",
    "frames",
    "step_ms_median",
    "step_ms_p95",
    "total_s",
    "peak_rss_mb",
    "alignment",
)
#: the header of results.csv (a regression guard: the file's columns must not change)
RESULTS_CSV_HEADER = (
    "cell,dataset,estimator,override,seed,status,ate_rmse_m,ate_max_m,ate_origin_rmse_m,"
    "rpe_trans_rmse_m,rpe_rot_rmse_deg,landmark_rmse_m,landmarks_estimated,landmarks_matched,"
    "nees_mean,frames,step_ms_median,step_ms_p95,total_s,peak_rss_mb,alignment,ground_truth"
)


def full_metrics() -> RunMetrics:
    """A RunMetrics with a value (not None) in every field."""
    return RunMetrics(
        run=RunInfo(
            dataset="mrclam6-r1",
            estimator="fastslam1",
            seed=3,
            estimator_options={"particles.n_particles": "50"},
            dataset_options={"association": "known"},
        ),
        ate=AteMetrics(
            rmse_m=0.6,
            max_m=1.26,
            mean_m=0.5,
            median_m=0.45,
            origin_rmse_m=1.33,
            origin_max_m=2.5,
            matched=1013,
            coverage=1.0,
        ),
        rpe=RpeMetrics(
            segment_m=10.0,
            trans_rmse_m=0.48,
            rot_rmse_deg=13.9,
            pairs=706,
            planar=True,
            frame_trans_rmse_m=0.02,
            frame_rot_rmse_deg=1.2,
            travel_m=43.8,
            by_distance=(
                RpeSegment(length_m=1.0, trans_rmse_m=0.1, rot_rmse_deg=6.8, pairs=769),
                RpeSegment(length_m=2.0, trans_rmse_m=0.2, rot_rmse_deg=10.2, pairs=772),
            ),
        ),
        landmarks=LandmarkMetrics(
            rmse_m=0.59,
            median_m=0.39,
            max_m=1.4,
            estimated=16,
            matched=15,
            truth=15,
            missed=0,
            duplicates=1,
            spurious=0,
            association=LandmarkAssociation.ASSIGNMENT,
            gate_m=2.0,
        ),
        nees=ConsistencyMetrics(
            has_pose_covariances=True,
            pose_mean=3.2,
            pose_anees=1.07,
            pose_dof=3,
            pose_within_bounds=0.93,
            pose_count=1013,
            has_landmark_covariances=True,
            landmark_mean=2.1,
            landmark_anees=1.05,
            landmark_dof=2,
            landmark_count=15,
        ),
        timing=TimingMetrics(
            frames=1013,
            step_median_ms=0.29,
            step_p95_ms=0.44,
            step_mean_ms=0.31,
            step_max_ms=2.5,
            total_s=0.31,
            peak_rss_mb=116.8,
        ),
        ground_truth=GroundTruthInfo(
            alignment=Alignment.SE2,
            kind=GroundTruthKind.MOTION_CAPTURE,
            label="motion-capture ground truth (Vicon)",
            note="Vicon",
            reference="lm-optimum",
        ),
    )


def no_truth_metrics() -> RunMetrics:
    """The metrics of a run without ground truth and covariances: everything optional is None."""
    return RunMetrics(
        run=RunInfo(
            dataset="raw.log",
            estimator="deadreckoning",
            seed=None,
            estimator_options={},
            dataset_options={},
        ),
        ate=AteMetrics(),
        rpe=RpeMetrics(),
        landmarks=LandmarkMetrics(estimated=0),
        nees=ConsistencyMetrics(has_pose_covariances=False, has_landmark_covariances=False),
        timing=TimingMetrics(  # no steps: no step statistics
            frames=0,
            step_median_ms=None,
            step_p95_ms=None,
            step_mean_ms=None,
            step_max_ms=None,
            total_s=0.0,
            peak_rss_mb=80.0,
        ),
        ground_truth=GroundTruthInfo(kind=GroundTruthKind.NONE, label="no ground truth", note=""),
    )


def written(tmp_path: Path, raw: dict) -> Path:
    path = tmp_path / METRICS
    path.write_text(json.dumps(raw))
    return path


# --------------------------------------------------------------------------------------------
# round trips
# --------------------------------------------------------------------------------------------


def test_full_metrics_fill_every_field():
    assert all(value is not None for value in full_metrics().to_json().values())


@pytest.mark.parametrize("make", [full_metrics, no_truth_metrics])
def test_write_then_read_gives_the_same_record(tmp_path, make):
    metrics = make()
    write_run_metrics(tmp_path / METRICS, metrics)
    back = read_run_metrics(tmp_path / METRICS)
    assert back == metrics
    assert back.to_json() == metrics.to_json()
    write_run_metrics(tmp_path / "again.json", back)
    assert (tmp_path / "again.json").read_text() == (tmp_path / METRICS).read_text()


def test_an_evaluated_run_round_trips(tmp_path, record_with_a_map):
    write_run_dir(tmp_path / "run", record_with_a_map)
    metrics = evaluate_run(read_run_dir(tmp_path / "run"))
    assert metrics.nees.pose_mean is not None and metrics.nees.landmark_mean is not None
    assert metrics.rpe.by_distance and metrics.landmarks.matched == 12
    write_run_metrics(tmp_path / "run" / METRICS, metrics)
    assert read_run_metrics(tmp_path / "run" / METRICS) == metrics


def test_the_file_is_flat_json_with_the_schema_version_first_and_nulls(tmp_path):
    write_run_metrics(tmp_path / METRICS, no_truth_metrics())
    raw = json.loads((tmp_path / METRICS).read_text())
    assert list(raw) == [SCHEMA_KEY, *(spec.key for spec in METRIC_FIELDS)]
    assert raw[SCHEMA_KEY] == SCHEMA_VERSION == 1
    assert raw["nees_mean"] is None and raw["ate_rmse_m"] is None  # no covariance, no truth
    assert raw["rpe_by_distance"] is None and raw["estimator_options"] == {}
    assert raw["ground_truth"] == "none" and raw["landmarks_estimated"] == 0


def test_enums_and_curves_are_written_as_json_values():
    raw = full_metrics().to_json()
    assert raw["alignment"] == "se2" and raw["ground_truth"] == "motion-capture"
    assert raw["landmark_association"] == "assignment"
    assert raw["rpe_by_distance"][1] == {
        "length_m": 2.0,
        "trans_rmse_m": 0.2,
        "rot_rmse_deg": 10.2,
        "pairs": 772,
    }


def test_a_file_without_schema_version_is_read_as_version_1(tmp_path):
    metrics = full_metrics()
    legacy = metrics.to_json()
    del legacy[SCHEMA_KEY]
    assert read_run_metrics(written(tmp_path, legacy)) == metrics


# --------------------------------------------------------------------------------------------
# one definition of the keys
# --------------------------------------------------------------------------------------------


def test_every_key_is_declared_once_and_names_a_field():
    keys = [spec.key for spec in METRIC_FIELDS]
    assert len(keys) == len(set(keys)) and SCHEMA_KEY not in keys
    parts = {f.name: f.type for f in dataclasses.fields(RunMetrics)}
    declared = [
        (part, f.name)
        for part in parts
        for f in dataclasses.fields(type(getattr(full_metrics(), part)))
    ]
    assert [(spec.part, spec.name) for spec in METRIC_FIELDS] == declared


def test_the_design_contract_keys_are_in_metrics_json():
    assert set(DESIGN_CONTRACT_KEYS) <= {spec.key for spec in METRIC_FIELDS}


def test_measured_keys_are_the_timing_part_but_frames():
    timing = {spec.key for spec in METRIC_FIELDS if spec.part == "timing"}
    assert MEASURED_KEYS == timing - {"frames"}


def test_results_csv_columns_come_from_the_record_fields(tmp_path):
    keys = [spec.key for spec in METRIC_FIELDS]
    assert all(spec.key in keys for spec in CSV_FIELDS)
    assert ",".join([*CSV_LABELS, *(spec.key for spec in CSV_FIELDS)]) == RESULTS_CSV_HEADER
    write_room_log(tmp_path / "data" / "room.log", frames=30)
    grid = tmp_path / "grid.yaml"
    grid.write_text("datasets: [data/room.log]\nestimators: [deadreckoning]\nseeds: [0]\n")
    run_grid(load_grid(grid), tmp_path / "out", SerialExecutor)
    header, row = (tmp_path / "out" / RESULTS_CSV).read_text().splitlines()
    assert header == RESULTS_CSV_HEADER
    cell = tmp_path / "out" / CELLS / row.split(",")[0]
    metrics = read_run_metrics(cell / METRICS)
    values = dict(zip(header.split(","), row.split(","), strict=True))
    for spec in CSV_FIELDS:
        value = spec.json_value(metrics)
        assert values[spec.key] == ("" if value is None else str(value))


# --------------------------------------------------------------------------------------------
# validation
# --------------------------------------------------------------------------------------------


def test_records_are_frozen_and_normalise_numpy_values():
    ate = AteMetrics(rmse_m=np.float64(0.5), matched=np.int64(7))
    assert type(ate.rmse_m) is float and type(ate.matched) is int
    with pytest.raises(dataclasses.FrozenInstanceError):
        ate.rmse_m = 1.0  # type: ignore[misc]
    run = full_metrics().run
    with pytest.raises(TypeError):
        run.estimator_options["particles.n_particles"] = "5"  # type: ignore[index]


@pytest.mark.parametrize(
    ("make", "key"),
    [
        (lambda: AteMetrics(rmse_m=float("nan")), "ate_rmse_m"),
        (lambda: AteMetrics(max_m=-1.0), "ate_max_m"),
        (lambda: AteMetrics(matched=True), "ate_matched"),
        (lambda: LandmarkMetrics(estimated=None), "landmarks_estimated"),  # type: ignore[arg-type]
        (lambda: RpeSegment(length_m=1.0, trans_rmse_m=0.1, rot_rmse_deg=None, pairs=1.5), "pairs"),
    ],
)
def test_bad_values_are_refused_when_the_record_is_made(make, key):
    with pytest.raises(DataError, match=f"'{key}'"):
        make()


@pytest.mark.parametrize("key", ["ate_rmse_m", "frames", "rpe_by_distance", "ground_truth"])
def test_a_missing_key_names_file_and_key(tmp_path, key):
    raw = full_metrics().to_json()
    del raw[key]
    path = written(tmp_path, raw)
    with pytest.raises(DataError, match=f"missing key '{key}'") as info:
        read_run_metrics(path)
    assert str(path) in str(info.value)


def test_an_unknown_key_is_refused(tmp_path):
    raw = {**full_metrics().to_json(), "ate_rmse": 0.1}
    with pytest.raises(DataError, match="unknown key 'ate_rmse'"):
        read_run_metrics(written(tmp_path, raw))


@pytest.mark.parametrize(
    ("key", "value", "expected"),
    [
        ("ate_rmse_m", "0.6", "a finite number >= 0 or null"),
        ("ate_rmse_m", -0.1, "a finite number >= 0 or null"),
        ("frames", 12.5, "an integer >= 0"),
        ("frames", None, "an integer >= 0"),
        ("landmarks_estimated", True, "an integer >= 0"),
        ("rpe_planar", "yes", "true or false or null"),
        ("ground_truth", "martian", "one of 'exact'"),
        ("alignment", "affine", "one of 'none'"),
        ("estimator_options", {"particles.n_particles": 50}, "an object of strings"),
        ("rpe_by_distance", {"length_m": 1.0}, "a list of objects or null"),
        ("dataset", 7, "a string"),
        ("has_pose_covariances", 1, "true or false"),
    ],
)
def test_a_wrong_type_names_file_key_and_expectation(tmp_path, key, value, expected):
    raw = {**full_metrics().to_json(), key: value}
    path = written(tmp_path, raw)
    with pytest.raises(DataError, match=f"key '{key}': expected {expected}") as info:
        read_run_metrics(path)
    assert str(info.value).startswith(f"{path}: ")


def test_a_bad_curve_point_names_its_index_and_key(tmp_path):
    raw = full_metrics().to_json()
    raw["rpe_by_distance"][1]["length_m"] = "x"
    with pytest.raises(DataError, match=r"rpe_by_distance\[1\]: key 'length_m'"):
        read_run_metrics(written(tmp_path, raw))
    del raw["rpe_by_distance"][1]["length_m"]
    with pytest.raises(DataError, match=r"rpe_by_distance\[1\]: missing key 'length_m'"):
        read_run_metrics(written(tmp_path, raw))


@pytest.mark.parametrize("literal", ["NaN", "Infinity", "-Infinity"])
def test_non_finite_numbers_are_refused_naming_the_key(tmp_path, literal):
    text = json.dumps(full_metrics().to_json()).replace(
        '"ate_max_m": 1.26', f'"ate_max_m": {literal}'
    )
    assert literal in text
    path = tmp_path / METRICS
    path.write_text(text)
    with pytest.raises(DataError, match="key 'ate_max_m': expected a finite number"):
        read_run_metrics(path)


@pytest.mark.parametrize("version", [2, 0, "1", True, None])
def test_an_unsupported_schema_version_is_refused(tmp_path, version):
    raw = {**full_metrics().to_json(), SCHEMA_KEY: version}
    path = written(tmp_path, raw)
    with pytest.raises(DataError, match=f"key '{SCHEMA_KEY}': this omnislam reads version 1"):
        read_run_metrics(path)


def test_truncated_json_names_the_file_and_position(tmp_path):
    write_run_metrics(tmp_path / METRICS, full_metrics())
    path = tmp_path / METRICS
    path.write_text(path.read_text()[:200])
    with pytest.raises(DataError, match="not valid JSON") as info:
        read_run_metrics(path)
    assert str(path) in str(info.value) and "line" in str(info.value)


def test_not_an_object_and_a_missing_file(tmp_path):
    with pytest.raises(DataError, match="expected a JSON object"):
        read_run_metrics(written(tmp_path, [1, 2]))  # type: ignore[arg-type]
    with pytest.raises(DataError, match="cannot read the file") as info:
        read_run_metrics(tmp_path / "nowhere" / METRICS)
    assert "nowhere" in str(info.value)


# --------------------------------------------------------------------------------------------
# readers of metrics.json
# --------------------------------------------------------------------------------------------


def test_report_on_a_malformed_metrics_json_exits_2_naming_file_and_key(tmp_path, capsys):
    log = write_room_log(tmp_path / "data" / "room.log", frames=20)
    run = tmp_path / "run"
    assert main(["run", str(log), "--estimator", "deadreckoning", "--out", str(run)]) == 0
    assert main(["evaluate", str(run)]) == 0
    raw = json.loads((run / METRICS).read_text())
    raw["landmarks_estimated"] = "none"
    (run / METRICS).write_text(json.dumps(raw))
    capsys.readouterr()
    assert main(["report", str(run), "--out", str(tmp_path / "report")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert str(run / METRICS) in err and "'landmarks_estimated'" in err
    assert not (tmp_path / "report").exists()


def test_evaluate_json_prints_the_file(tmp_path, capsys):
    log = write_room_log(tmp_path / "data" / "room.log", frames=20)
    run = tmp_path / "run"
    assert main(["run", str(log), "--estimator", "deadreckoning", "--out", str(run)]) == 0
    capsys.readouterr()
    assert main(["evaluate", str(run), "--json"]) == 0
    assert json.loads(capsys.readouterr().out) == json.loads((run / METRICS).read_text())
    assert read_run_metrics(run / METRICS).run.estimator == "deadreckoning"


def test_the_runner_evaluates_again_a_cell_whose_metrics_json_it_cannot_read(tmp_path):
    write_room_log(tmp_path / "data" / "room.log", frames=30)
    grid = tmp_path / "grid.yaml"
    grid.write_text("datasets: [data/room.log]\nestimators: [deadreckoning]\nseeds: [0]\n")
    first = run_grid(load_grid(grid), tmp_path / "out", SerialExecutor)
    (cell,) = (tmp_path / "out" / CELLS).iterdir()
    (cell / METRICS).write_text('{"ate_rmse_m": ')  # e.g. cut short by a full disk
    again = run_grid(load_grid(grid), tmp_path / "out", SerialExecutor)
    assert again.outcomes[0].status.value == "reused"
    assert again.outcomes[0].metrics == first.outcomes[0].metrics
    assert read_run_metrics(cell / METRICS) == first.outcomes[0].metrics
