"""MR.CLAM loader: facts from dataset 6 and malformed-input handling."""

from pathlib import Path

import numpy as np
import pytest

from omnislam.core.types import UNKNOWN_ID
from omnislam.datasets._common import Association
from omnislam.datasets.mrclam import (
    SIGMA_BEARING_RAD,
    SIGMA_RANGE_M,
    bearing_residuals,
    load_mrclam,
    read_robot_groundtruth,
)
from omnislam.datasets.sequence import GroundTruthKind
from omnislam.errors import ConfigError, DataError

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"
DATASET6 = DATA / "mrclam" / "MRCLAM_Dataset6"
needs_data = pytest.mark.skipif(not DATASET6.is_dir(), reason=f"MR.CLAM data not in {DATASET6}")

HEADER = "# a\n# b\n# c\n# d\n"


@pytest.fixture(scope="module")
def robot1():
    return load_mrclam(DATASET6, 1)


@needs_data
def test_dataset6_robot1_has_1534_landmark_sightings(robot1):
    count = sum(len(rb) for rb in robot1.range_bearing if rb is not None)
    assert count == 1534
    assert robot1.info["unknown_barcodes"] == "43"
    assert robot1.info["unknown_barcode_sightings_dropped"] == "1"
    assert int(robot1.info["robot_sightings_dropped"]) > 0


@needs_data
def test_dataset6_robot1_vicon_path_is_49_6_m():
    vicon = read_robot_groundtruth(DATASET6 / "Robot1_Groundtruth.dat")
    length = np.sum(np.linalg.norm(np.diff(vicon.positions_w[:, :2], axis=0), axis=1))
    assert length == pytest.approx(49.6, abs=0.5)


@needs_data
def test_bearings_agree_with_vicon_and_surveyed_landmarks(robot1):
    residuals = bearing_residuals(robot1)
    assert len(residuals) == 1534
    assert abs(np.median(residuals)) < 0.002
    # the default sigma covers the measured robust spread (the source of the default)
    assert 1.4826 * np.median(np.abs(residuals - np.median(residuals))) < SIGMA_BEARING_RAD


@needs_data
def test_ground_truth_and_frames(robot1):
    gt = robot1.ground_truth
    assert gt.kind is GroundTruthKind.MOTION_CAPTURE
    assert list(gt.landmark_ids) == list(range(6, 21))
    assert len(gt.trajectory) == len(robot1)  # Vicon covers every frame of robot 1
    assert np.all(np.diff(robot1.stamps_s) > 0)
    ids = np.concatenate([rb.landmark_ids for rb in robot1.range_bearing if rb is not None])
    assert set(ids) <= set(range(6, 21))
    assert np.allclose(robot1.initial_pose_w, gt.trajectory.se2[0])


@needs_data
def test_unknown_association_hides_ids_but_keeps_ground_truth():
    seq = load_mrclam(DATASET6, 1, association=Association.UNKNOWN)
    ids = np.concatenate([rb.landmark_ids for rb in seq.range_bearing if rb is not None])
    assert np.all(ids == UNKNOWN_ID)
    assert len(seq.ground_truth.landmark_ids) == 15


def write_folder(folder: Path, odometry: str, measurement: str, groundtruth: str | None = None):
    folder.mkdir(exist_ok=True)
    (folder / "Barcodes.dat").write_text(HEADER + "1 5\n2 14\n6 63\n7 81\n")
    (folder / "Landmark_Groundtruth.dat").write_text(HEADER + "6 2.0 0.0 0 0\n7 0.0 2.0 0 0\n")
    (folder / "Robot1_Odometry.dat").write_text(HEADER + odometry)
    (folder / "Robot1_Measurement.dat").write_text(HEADER + measurement)
    if groundtruth is not None:
        (folder / "Robot1_Groundtruth.dat").write_text(HEADER + groundtruth)
    return folder


def test_commanded_velocities_integrate_to_an_exact_arc(tmp_path):
    # v = 1 m/s, omega = pi/2 rad/s for 1 s: a quarter circle of radius 2/pi
    odometry = "".join(f"{t:.2f} 1.0 {np.pi / 2}\n" for t in np.arange(0.0, 1.0, 0.01))
    measurement = "0.5 63 2.0 0.1\n0.5 81 1.0 0.2\n0.5 14 3.0 0.0\n1.0 99 1.0 0.0\n1.0 63 1.0 0.0\n"
    seq = load_mrclam(write_folder(tmp_path / "ds", odometry, measurement), 1)
    assert list(seq.stamps_s) == [0.0, 0.5, 1.0]
    total = seq.odometry_r[1].copy()
    from omnislam.core.se import se2_compose

    total = se2_compose(total, seq.odometry_r[2])
    radius = 2.0 / np.pi
    assert np.allclose(total, [radius, radius, np.pi / 2], atol=1e-12)
    assert len(seq.range_bearing[1]) == 2  # robot 2 (barcode 14) dropped
    assert seq.info["unknown_barcodes"] == "99"
    assert seq.ground_truth.kind is GroundTruthKind.NONE


def test_unknown_robot_is_a_config_error(tmp_path):
    folder = write_folder(tmp_path / "ds", "0 0 0\n1 0 0\n", "0.5 63 1 0\n")
    with pytest.raises(ConfigError, match="robot=3"):
        load_mrclam(folder, 3)


@pytest.mark.parametrize(
    ("odometry", "measurement", "file", "message"),
    [
        ("0 0 0\n1 0.1\n", "0.5 63 1 0\n", "Robot1_Odometry.dat", "line 6: expected 3 columns"),
        ("0 0 0\n1 0 0\n", "0.5 63 1 0 7\n", "Robot1_Measurement.dat", "line 5: expected 4"),
        ("0 0 0\n1 x 0\n", "0.5 63 1 0\n", "Robot1_Odometry.dat", "line 6: v.m/s. 'x' is not"),
        ("0 0 0\n2 0 0\n1 0 0\n", "0.5 63 1 0\n", "Robot1_Odometry.dat", "line 7: time 1.0 is"),
        ("0 0 0\n1 0 0\n", "0.5 63 -1 0\n", "Robot1_Measurement.dat", "line 5: negative range"),
    ],
)
def test_bad_input_names_file_and_line(tmp_path, odometry, measurement, file, message):
    folder = write_folder(tmp_path / "ds", odometry, measurement)
    with pytest.raises(DataError, match=message) as info:
        load_mrclam(folder, 1)
    assert str(info.value).startswith(str(folder / file))


def test_defaults_are_positive():
    assert SIGMA_RANGE_M > 0 and SIGMA_BEARING_RAD > 0
