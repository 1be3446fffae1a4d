"""The omnislam folder format: its loader, its checker, its exporter (round trips bit for bit)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from omnislam.cli import main
from omnislam.core.ackermann import integrate_unicycle
from omnislam.core.motion import MotionNoise, OdometryMotionModel
from omnislam.core.types import UNKNOWN_ID
from omnislam.datasets._common import odometry_from_poses
from omnislam.datasets.folder import check_folder, export_folder, is_folder, load_folder
from omnislam.datasets.folder.reader import metadata_problems
from omnislam.datasets.registry import DatasetFormat, detect_format, load_dataset
from omnislam.errors import DataError

META = {"format": "omnislam-folder", "version": 1, "source": "a test", "licence": "CC0-1.0"}
ODOMETRY = "stamp_s,dx_m,dy_m,dtheta_rad\n0.0,0,0,0\n0.1,0.1,0,0.01\n0.2,0.1,0.0,0.02\n"
SIGHTINGS = (
    "stamp_s,landmark_id,range_m,bearing_rad,sigma_range_m,sigma_bearing_rad\n"
    "0.1,3,2.0,0.5,0.1,0.01\n0.1,,3.0,-0.5,0.1,0.01\n0.2,3,1.9,0.6,0.1,0.01\n"
)


def folder(tmp: Path, meta: dict | None = None, **files: str) -> Path:
    """A small folder: ``dataset.json`` and ``odometry.csv`` (replaced or added by ``files``,
    with ``.`` in names written as ``_``: ``sightings_csv``)."""
    root = tmp / "data"
    root.mkdir(exist_ok=True)
    (root / "dataset.json").write_text(json.dumps(META if meta is None else meta))
    contents = {"odometry.csv": ODOMETRY}
    contents |= {".".join(name.rsplit("_", 1)): text for name, text in files.items()}
    for name, text in contents.items():
        (root / name).write_text(text)
    return root


def test_a_small_folder_is_detected_and_loads(tmp_path):
    root = folder(tmp_path, sightings_csv=SIGHTINGS)
    assert is_folder(root) and detect_format(root) is DatasetFormat.FOLDER
    sequence = load_dataset(str(root))
    assert sequence.name == "data" and len(sequence) == 3
    np.testing.assert_array_equal(sequence.odometry_r[2], [0.1, 0.0, 0.02])
    assert sequence.range_bearing[0] is None  # listed frames only: frame 0 has no sightings
    first = sequence.range_bearing[1]
    np.testing.assert_array_equal(first.landmark_ids, [3, UNKNOWN_ID])
    np.testing.assert_array_equal(first.bearings_rad, [0.5, -0.5])
    assert sequence.odometry_covariance_r is None and check_folder(root) == []


def test_velocities_are_integrated_as_arcs(tmp_path):
    odometry = "stamp_s,v_mps,omega_radps\n0.0,1.0,0.5\n0.5,1.0,0.5\n1.5,0.2,-1.0\n"
    sequence = load_folder(folder(tmp_path, odometry_csv=odometry))
    stamps = np.array([0.0, 0.5, 1.5])
    expected = odometry_from_poses(
        integrate_unicycle(stamps, np.array([1.0, 1.0, 0.2]), np.array([0.5, 0.5, -1.0]), stamps)
    )
    np.testing.assert_array_equal(sequence.odometry_r, expected)
    # one second at 1 m/s and 0.5 rad/s: the chord of the arc, 2 sin(0.25) / 0.5 long
    assert math.hypot(*sequence.odometry_r[2, :2]) == pytest.approx(4 * math.sin(0.25), 1e-12)


def test_the_noise_statement_gives_the_motion_models_covariance(tmp_path):
    noise = {"a_vv": 0.1, "a_vw": 0.01, "a_wv": 0.02, "a_ww": 0.2, "min_sigma": [1e-3] * 3}
    sequence = load_folder(folder(tmp_path, {**META, "odometry": {"noise": noise}}))
    model = OdometryMotionModel(MotionNoise(0.1, 0.01, 0.02, 0.2, (1e-3, 1e-3, 1e-3)))
    np.testing.assert_array_equal(sequence.odometry_covariance_r[1],
                                  model.covariance(sequence.odometry_r[1]))


def test_covariance_columns_and_sigmas_stated_once(tmp_path):
    odometry = ("stamp_s,dx_m,dy_m,dtheta_rad,cov_xx,cov_xy,cov_xtheta,cov_yy,cov_ytheta,"
                "cov_thetatheta\n0,0,0,0,,,,,,\n1,1,0,0,0.04,0.001,0,0.01,0,0.0025\n")
    sightings = "stamp_s,landmark_id,range_m,bearing_rad\n1,7,2.0,0.5\n"
    meta = {**META, "sightings": {"sigma_range_m": 0.2, "sigma_bearing_rad": 0.03,
                                  "every_frame": True}}
    sequence = load_folder(folder(tmp_path, meta, odometry_csv=odometry,
                                  sightings_csv=sightings))
    np.testing.assert_array_equal(sequence.odometry_covariance_r[1],
                                  [[0.04, 0.001, 0], [0.001, 0.01, 0], [0, 0, 0.0025]])
    assert len(sequence.range_bearing[0]) == 0  # every frame: frame 0 saw nothing
    assert sequence.range_bearing[1].sigma_range_m[0] == 0.2
    assert sequence.range_bearing[1].sigma_bearing_rad[0] == 0.03


def test_a_sensor_offset_moves_the_sightings_to_the_robot_frame(tmp_path):
    meta = {**META, "sightings": {"offset_r": [0.5, 0.0, math.pi / 2]}}
    sightings = ("stamp_s,landmark_id,range_m,bearing_rad,sigma_range_m,sigma_bearing_rad\n"
                 "0.1,1,2.0,0.0,0.1,0.01\n")
    sighting = load_folder(folder(tmp_path, meta, sightings_csv=sightings)).range_bearing[1]
    # the sensor 0.5 m ahead looking left sees the landmark at (0.5, 2) in the robot frame
    assert sighting.ranges_m[0] == pytest.approx(math.hypot(0.5, 2.0), abs=1e-12)
    assert sighting.bearings_rad[0] == pytest.approx(math.atan2(2.0, 0.5), abs=1e-12)


def test_the_schema_names_every_metadata_problem():
    problems = metadata_problems({"format": "omnislam-folder", "version": 2, "licence": "",
                                  "laser": {"max_range_m": -1}, "colour": "red"})
    text = "\n".join(problems)
    for needle in ("version", "source", "licence", "angles_rad", "max_range_m", "colour"):
        assert needle in text, text


def test_check_lists_one_line_per_problem_and_exits_2(tmp_path, capsys):
    sightings = SIGHTINGS.replace("0.2,3,1.9", "0.25,3,1.9")
    landmarks = "id,x_m,y_m,z_m\n1,0,0,0\n1,2,0,0\n"
    root = folder(tmp_path, sightings_csv=sightings, landmarks_csv=landmarks,
                  laser_csv="stamp_s,range_0_m\n0.1,2\n")
    meta = {**META, "ground_truth": {"kind": "exact"}}
    (root / "dataset.json").write_text(json.dumps(meta))
    assert main(["dataset", "check", str(root)]) == 2
    lines = capsys.readouterr().out.strip().splitlines()
    assert len(lines) == 3, lines
    assert "sightings.csv: line 4: stamp 0.25 is not the stamp of a frame" in lines[1] + lines[2]
    assert any("landmarks.csv: line 3: id 1" in line for line in lines)
    assert any("dataset.json" in line and "laser" in line for line in lines)


@pytest.mark.parametrize(
    ("files", "needle"),
    [
        ({"odometry_csv": "stamp_s,dx_m,dy_m\n0,0,0\n"}, "line 1: column 'dtheta_rad'"),
        ({"odometry_csv": ODOMETRY + "0.15,0,0,0\n"}, "odometry.csv: line 5: time 0.15"),
        ({"odometry_csv": ODOMETRY + "0.3,0.1,x,0\n"}, "odometry.csv: line 5: dy_m 'x'"),
        ({"odometry_csv": ODOMETRY + "0.3,0.1\n"}, "odometry.csv: line 5: 2 cells"),
        ({"sightings_csv": SIGHTINGS + "0.2,3,-1,0,0.1,0.01\n"}, "line 5: range_m -1.0"),
        ({"sightings_csv": SIGHTINGS + "0.2,2.5,1,0,0.1,0.01\n"}, "line 5: landmark_id 2.5"),
        ({"sightings_csv": SIGHTINGS + "0.2,3,1,0,0,0.01\n"}, "line 5: sigma_range_m must be"),
        ({"images_csv": "stamp_s,file\n0.1,images/a.png\n"}, "images.csv: line 2: image"),
        ({"groundtruth_tum": "0 0 0 0 0 0 0 1\n"}, "ground_truth.kind is needed"),
    ],
)
def test_bad_files_are_named_with_their_line(tmp_path, files, needle):
    root = folder(tmp_path, **files)
    with pytest.raises(DataError) as error:
        load_folder(root)
    assert needle in str(error.value), str(error.value)
    assert any(needle in problem for problem in check_folder(root))


def test_an_unknown_or_missing_column_is_named(tmp_path):
    root = folder(tmp_path, sightings_csv="stamp_s,landmark_id,range_m,bearing,sigma\n")
    with pytest.raises(DataError, match="unknown column 'bearing'"):
        load_folder(root)


def test_export_of_a_small_folder_reads_back_the_same_sequence(tmp_path):
    source = load_folder(folder(tmp_path, sightings_csv=SIGHTINGS))
    again = load_folder(export_folder(source, tmp_path / "again"))
    np.testing.assert_array_equal(again.stamps_s, source.stamps_s)
    np.testing.assert_array_equal(again.odometry_r, source.odometry_r)
    assert [rb is None for rb in again.range_bearing] == [rb is None for rb in
                                                          source.range_bearing]
    np.testing.assert_array_equal(again.range_bearing[1].landmark_ids,
                                  source.range_bearing[1].landmark_ids)


def _identical_runs(tmp: Path, dataset: str, estimator: str) -> None:
    """``dataset export`` then ``run`` gives the trajectory of ``run`` on the dataset itself,
    byte for byte."""
    exported = tmp / "exported"
    assert main(["-q", "dataset", "export", dataset, "--out", str(exported)]) == 0
    assert check_folder(exported) == []
    for name, data in (("original", dataset), ("folder", str(exported))):
        argv = ["-q", "run", data, "--estimator", estimator, "--seed", "0",
                "--out", str(tmp / name)]
        assert main(argv) == 0
    original = (tmp / "original" / "trajectory.tum").read_bytes()
    assert (tmp / "folder" / "trajectory.tum").read_bytes() == original


@pytest.mark.slow
def test_mrclam_exported_runs_graphslam_to_the_same_bytes(tmp_path, shared_data, monkeypatch):
    pytest.importorskip("gtsam")
    monkeypatch.setenv("OMNISLAM_DATA", str(shared_data))
    _identical_runs(tmp_path, "mrclam6-r1", "graphslam")


@pytest.mark.slow
def test_carmen_aces_exported_runs_ekfslam_to_the_same_bytes(tmp_path, shared_data, monkeypatch):
    monkeypatch.setenv("OMNISLAM_DATA", str(shared_data))
    _identical_runs(tmp_path, "carmen-aces", "ekfslam")


@pytest.mark.slow
def test_a_render_exported_runs_the_front_end_and_graphslam_to_the_same_bytes(tmp_path):
    pytest.importorskip("cv2")
    pytest.importorskip("gtsam")
    from omnislam.datasets.synthetic.presets import PRESETS
    from omnislam.datasets.synthetic.simulate import simulate
    from omnislam.datasets.synthetic.writer import write_synthetic

    render = tmp_path / "render"
    write_synthetic(render, simulate(PRESETS["demo"], seed=0, max_images=8))
    _identical_runs(tmp_path, str(render), "graphslam")
    exported = load_folder(tmp_path / "exported")
    np.testing.assert_array_equal(exported.image(int(exported.image_frames[-1])),
                                  load_dataset(str(render)).image(int(exported.image_frames[-1])))


def test_the_specification_documents_every_metadata_key():
    from omnislam.datasets.folder.layout import schema

    spec = (Path(__file__).resolve().parents[2] / "docs" / "datasets" / "folder-format.md")
    text = spec.read_text()
    for key, value in schema()["properties"].items():
        assert f"`{key}" in text, key
        for inner in value.get("properties", {}):
            assert inner in text, f"{key}.{inner}"


def test_metadata_is_written_with_number_lists_on_one_line():
    from omnislam.datasets.folder.writer import metadata_text

    meta = {**META, "laser": {"angles_rad": [-0.5, 0.0, 2.5e-05], "max_range_m": 8.0}}
    text = metadata_text(meta)
    assert '"angles_rad": [-0.5, 0.0, 2.5e-05]' in text
    assert json.loads(text) == meta
