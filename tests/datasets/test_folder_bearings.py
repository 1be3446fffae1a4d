"""Bearing-only sightings of the omnislam folder: read as the estimators' bearings, checked row
by row, exported; graphslam on a folder of the demo log's bearings gives the log's trajectory."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from test_folder import META, folder

from omnislam.cli import main
from omnislam.core.modality import Modality
from omnislam.core.types import UNKNOWN_ID, Bearings, FrameInput, Odometry
from omnislam.datasets.folder import check_folder, export_folder, load_folder
from omnislam.errors import DataError
from omnislam.harness.frames import fed_frames

BEARINGS = (
    "stamp_s,landmark_id,bearing_rad,elevation_rad,sigma_bearing_rad\n"
    "0.1,3,0.5,0.25,0.01\n0.1,,-0.5,,0.02\n0.2,3,0.6,0.2,0.01\n"
)
#: graphslam on the folder against graphslam on the log [m]: the folder writes each unit vector
#: as azimuth and elevation, which give it back to 1 ulp (2.2e-16), not bit for bit; the
#: solution moves by ~1e-16 m (poses) and ~4e-15 m (landmarks)
SAME_SOLUTION_M = 1e-12


def unit(azimuth: float, elevation: float) -> list[float]:
    return [math.cos(elevation) * math.cos(azimuth), math.cos(elevation) * math.sin(azimuth),
            math.sin(elevation)]


def test_bearing_only_rows_are_the_frames_bearings(tmp_path):
    meta = {**META, "sightings": {"height_m": 0.8}}
    sequence = load_folder(folder(tmp_path, meta, sightings_csv=BEARINGS))
    assert sequence.range_bearing is None and sequence.bearing_sightings.sensor_height_m == 0.8
    seen = sequence.bearing_sightings.frames[1]
    np.testing.assert_array_equal(seen.landmark_ids, [3, UNKNOWN_ID])
    np.testing.assert_allclose(seen.unit_vectors_r, [unit(0.5, 0.25), unit(-0.5, 0.0)],
                               rtol=0, atol=1e-15)  # an empty elevation: 0
    np.testing.assert_array_equal(seen.sigmas_rad, [0.01, 0.02])
    assert sequence.bearing_sightings.frames[0] is None
    fed = fed_frames(sequence, "graphslam")
    assert fed.info.modalities == {Modality.BEARINGS_3D} and fed.info.sensor_height_m == 0.8
    assert fed.frames[2].bearings is sequence.bearing_sightings.frames[2]
    assert check_folder(tmp_path / "data") == []


def test_planar_bearings_and_a_turned_sensor(tmp_path):
    sightings = "stamp_s,landmark_id,bearing_rad\n0.1,1,0.5\n"
    meta = {**META, "sightings": {"sigma_bearing_rad": 0.05, "every_frame": True,
                                  "offset_r": [0.0, 0.0, math.pi / 2]}}
    sequence = load_folder(folder(tmp_path, meta, sightings_csv=sightings))
    own = sequence.bearing_sightings
    assert own.sensor_height_m == 0.0 and len(own.frames[0]) == 0  # every frame: saw nothing
    np.testing.assert_allclose(own.frames[1].unit_vectors_r, [unit(0.5 + math.pi / 2, 0.0)],
                               rtol=0, atol=1e-15)
    assert own.frames[1].sigmas_rad[0] == 0.05


@pytest.mark.parametrize(
    ("text", "meta", "needle"),
    [
        (BEARINGS.replace("0.2,3,0.6", "0.2,3,0.6").replace(
            "stamp_s,landmark_id,bearing_rad", "stamp_s,landmark_id,range_m,bearing_rad").replace(
            "0.1,3,0.5", "0.1,3,2.0,0.5").replace("0.1,,-0.5", "0.1,,,-0.5").replace(
            "0.2,3,0.6", "0.2,3,,0.6"), {},
         "sightings.csv: line 3: has no range_m, line 2 does (a file holds range-bearing or "
         "bearing-only sightings, not both)"),
        (BEARINGS + "0.2,4,0.1,1.7,0.01\n", {}, "line 5: elevation_rad 1.7"),
        (BEARINGS + "0.2,4,3.5,0.1,0.01\n", {}, "line 5: bearing_rad 3.5"),
        (BEARINGS + "0.2,4,0.1,0.1,\n", {}, "line 5: no sigma_bearing_rad"),
        (BEARINGS + "0.2,4,0.1,0.1,-0.1\n", {}, "line 5: sigma_bearing_rad must be positive"),
        (BEARINGS + "0.25,4,0.1,0.1,0.01\n", {}, "line 5: stamp 0.25 is not the stamp of a frame"),
        ("stamp_s,landmark_id,bearing_rad,sigma_bearing_rad,sigma_elevation_rad\n"
         "0.1,1,0.5,0.01,0.01\n0.1,2,0.5,0.01,0.03\n", {},
         "line 3: sigma_elevation_rad differs from sigma_bearing_rad"),
        ("stamp_s,landmark_id,bearing_rad,sigma_bearing_rad,sigma_range_m\n0.1,1,0.5,0.01,0.1\n",
         {}, "line 2: sigma_range_m is given, but the row has no range"),
        ("stamp_s,landmark_id,range_m,bearing_rad,elevation_rad\n0.1,1,2,0.5,0.1\n",
         {"sigma_range_m": 0.1, "sigma_bearing_rad": 0.01},
         "line 2: elevation_rad is given, but range-bearing sightings are planar"),
        (BEARINGS, {"offset_r": [0.1, 0.0, 0.0]},
         "dataset.json: sightings.offset_r: bearing-only sightings need the sensor on the "
         "robot's vertical axis"),
    ],
)
def test_bad_bearing_rows_are_named_with_their_line(tmp_path, text, meta, needle):
    root = folder(tmp_path, {**META, "sightings": meta}, sightings_csv=text)
    with pytest.raises(DataError) as error:
        load_folder(root)
    assert needle in str(error.value), str(error.value)
    assert [p for p in check_folder(root) if needle in p], check_folder(root)


def test_dataset_check_names_a_bad_bearing_row(tmp_path, capsys):
    root = folder(tmp_path, sightings_csv=BEARINGS + "0.2,x,0.1,0.1,0.01\n")
    assert main(["dataset", "check", str(root)]) == 2
    lines = capsys.readouterr().out.strip().splitlines()
    assert len(lines) == 1 and "sightings.csv: line 5: landmark_id 'x' is not a number" in lines[0]


def test_bearing_only_sightings_and_images_are_refused(tmp_path):
    root = folder(tmp_path, sightings_csv=BEARINGS, images_csv="stamp_s,file\n0.1,a.png\n")
    (root / "a.png").write_bytes(b"")
    with pytest.raises(DataError, match=r"bearing-only sightings and images\.csv"):
        load_folder(root)


def test_a_laser_log_keeps_the_loaders_bearings(tmp_path):
    sequence = load_folder(folder(tmp_path, sightings_csv=BEARINGS))
    log = [FrameInput(i, Odometry(sequence.odometry_r[i], sequence.stamps_s[i]))
           for i in range(len(sequence))]
    front = Bearings([9], [[1.0, 0.0, 0.0]], [0.1])
    log[2] = replace(log[2], bearings=front)
    frames = list(sequence.frame_inputs(log))
    assert frames[0].bearings is None and frames[2].bearings is front
    assert frames[1].bearings is sequence.bearing_sightings.frames[1]


def test_export_writes_the_bearings_back(tmp_path):
    meta = {**META, "sightings": {"height_m": 0.5}}
    source = load_folder(folder(tmp_path, meta, sightings_csv=BEARINGS))
    again = load_folder(export_folder(source, tmp_path / "again"))
    assert json.loads((tmp_path / "again" / "dataset.json").read_text())["sightings"] == {
        "every_frame": False, "height_m": 0.5}
    for mine, theirs in zip(again.bearing_sightings.frames, source.bearing_sightings.frames,
                            strict=True):
        assert (mine is None) == (theirs is None)
        if mine is not None:
            np.testing.assert_array_equal(mine.landmark_ids, theirs.landmark_ids)
            np.testing.assert_array_equal(mine.sigmas_rad, theirs.sigmas_rad)
            np.testing.assert_allclose(mine.unit_vectors_r, theirs.unit_vectors_r, rtol=0,
                                       atol=4e-16)


@pytest.mark.slow
def test_graphslam_on_a_folder_of_the_logs_bearings_gives_the_logs_solution(tmp_path):
    """The demo's front-end log written as a folder of bearing-only sightings with the track
    ids (its odometry, the camera's height; no images): graphslam there and on the log
    replayed agree to ``SAME_SOLUTION_M``."""
    pytest.importorskip("cv2")
    pytest.importorskip("gtsam")
    from omnislam.datasets.registry import load_dataset
    from omnislam.datasets.sequence import BearingSightings
    from omnislam.datasets.synthetic.presets import PRESETS
    from omnislam.datasets.synthetic.simulate import simulate
    from omnislam.datasets.synthetic.writer import write_synthetic
    from omnislam.frontend.observation_log import load_observation_log
    from omnislam.harness.frames import sensor_height_m

    render, log = tmp_path / "demo", tmp_path / "log.npz"
    write_synthetic(render, simulate(PRESETS["demo"], seed=0, max_images=6))
    assert main(["-q", "frontend", str(render), "--out", str(log)]) == 0
    sequence = load_dataset(str(render))
    bearings = BearingSightings(tuple(f.bearings for f in load_observation_log(log).frames),
                                sensor_height_m(sequence.calibration))
    camera_free = replace(sequence, range_bearing=None, bearing_sightings=bearings, laser=None,
                          image_loader=None, image_frames=np.zeros(0, np.int64),
                          calibration=None, point_map_loader=None, pixel_points_loader=None)
    export_folder(camera_free, tmp_path / "bearings")
    assert check_folder(tmp_path / "bearings") == []
    for name, data in (("log", [str(render), "--log", str(log)]),
                       ("folder", [str(tmp_path / "bearings")])):
        assert main(["-q", "run", *data, "--estimator", "graphslam", "--seed", "0",
                     "--out", str(tmp_path / name)]) == 0
    for file, reader in (("trajectory.tum", np.loadtxt),
                         ("landmarks.csv", lambda p: np.loadtxt(p, delimiter=",", skiprows=1))):
        expected, got = (reader(tmp_path / name / file) for name in ("log", "folder"))
        assert expected.shape == got.shape and len(expected) > 10, file
        np.testing.assert_allclose(got, expected, rtol=0, atol=SAME_SOLUTION_M)
    config = (tmp_path / "folder" / "config.yaml").read_text()
    assert "modality: bearings-3d" in config


def test_a_laser_offset_is_the_scanners_pose_kept_with_its_scans_and_exported(tmp_path):
    for name in "ab":
        (tmp_path / name).mkdir()
    angles, offset = [-0.5, 0.0, 0.5], [0.25, 0.05, 0.1]
    scans = "stamp_s,range_0_m,range_1_m,range_2_m\n0.1,2.0,3.0,\n0.2,2.5,8.0,1.0\n"
    laser = {"angles_rad": angles, "max_range_m": 8.0}
    root = folder(tmp_path / "a", {**META, "laser": {**laser, "offset_r": offset}},
                  laser_csv=scans)
    assert check_folder(root) == []
    mounted = load_folder(root)
    np.testing.assert_array_equal(mounted.laser.angles_rad, angles)  # the scanner's frame
    np.testing.assert_array_equal(mounted.laser.offset_r, offset)
    centred = load_folder(folder(tmp_path / "b", {**META, "laser": laser}, laser_csv=scans))
    np.testing.assert_array_equal(centred.laser.offset_r, np.zeros(3))
    np.testing.assert_array_equal(mounted.laser.ranges_m, centred.laser.ranges_m)
    again = load_folder(export_folder(mounted, tmp_path / "again")).laser
    assert json.loads((tmp_path / "again" / "dataset.json").read_text())["laser"][
        "offset_r"] == offset
    np.testing.assert_array_equal(again.offset_r, mounted.laser.offset_r)
    np.testing.assert_array_equal(again.angles_rad, mounted.laser.angles_rad)
    np.testing.assert_array_equal(again.ranges_m, mounted.laser.ranges_m)
    export_folder(centred, tmp_path / "centred")
    assert "offset_r" not in json.loads((tmp_path / "centred" / "dataset.json").read_text())[
        "laser"]
