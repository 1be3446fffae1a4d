"""MR.CLAM loader: facts from dataset 6 and malformed-input handling."""

from pathlib import Path

import numpy as np
import pytest

from omnislam.core.motion import MotionNoise, OdometryMotionModel
from omnislam.core.se import se2_between, se2_compose, wrap_angle
from omnislam.core.types import UNKNOWN_ID
from omnislam.datasets._common import Association, fill_gaps
from omnislam.datasets.mrclam import (
    COMMAND_DELAY_S,
    DEPTH_BIAS_M,
    MAX_STEP_S,
    ODOMETRY_NOISE,
    SAME_IMAGE_S,
    SIGMA_BEARING_RAD,
    SIGMA_RANGE_M,
    bearing_residuals,
    image_stamps,
    load_mrclam,
    read_barcodes,
    read_landmark_groundtruth,
    read_robot_groundtruth,
    read_robot_measurements,
    read_robot_odometry,
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
    # Vicon covers every frame with sightings of robot 1 (and frame 0); the frames that fill
    # the gaps between sightings carry no truth
    with_sightings = [0] + [k for k, rb in enumerate(robot1.range_bearing) if rb is not None]
    np.testing.assert_array_equal(gt.trajectory.stamps_s, robot1.stamps_s[with_sightings])
    assert len(robot1) > len(with_sightings)  # dataset 6 robot 1 has gaps > MAX_STEP_S
    assert np.all(np.diff(robot1.stamps_s) > 0)
    assert np.diff(robot1.stamps_s).max() <= MAX_STEP_S + 1e-9
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
    seq = load_mrclam(write_folder(tmp_path / "ds", odometry, measurement), 1, command_delay_s=0)
    assert list(seq.stamps_s) == [0.0, 0.5, 1.0]
    total = seq.odometry_r[1].copy()
    total = se2_compose(total, seq.odometry_r[2])
    radius = 2.0 / np.pi
    assert np.allclose(total, [radius, radius, np.pi / 2], atol=1e-12)
    assert len(seq.range_bearing[1]) == 2  # robot 2 (barcode 14) dropped
    assert seq.info["unknown_barcodes"] == "99"
    assert seq.ground_truth.kind is GroundTruthKind.NONE


def test_a_sighting_gap_is_split_into_odometry_steps(tmp_path):
    """Sightings at 0.5 s and 10 s: the 9.5 s between them become 5 steps of 1.9 s (frames
    without sightings) whose odometry composes to the one long step; the truth stays at the
    frames with sightings."""
    odometry = "".join(f"{t:.2f} 0.2 0.3\n" for t in np.arange(0.0, 10.5, 0.01))
    measurement = "0.5 63 2.0 0.1\n10.0 81 1.0 0.2\n"
    vicon = "".join(f"{t:.2f} 0.0 0.0 0.0\n" for t in np.arange(0.0, 10.5, 0.05))
    folder = write_folder(tmp_path / "ds", odometry, measurement, vicon)
    long = load_mrclam(folder, 1, command_delay_s=0, max_step_s=np.inf)
    split = load_mrclam(folder, 1, command_delay_s=0, max_step_s=2.0)
    assert list(long.stamps_s) == [0.0, 0.5, 10.0]
    np.testing.assert_allclose(split.stamps_s, [0.0, 0.5, 2.4, 4.3, 6.2, 8.1, 10.0])
    assert [rb is not None for rb in split.range_bearing] == [False, True] + [False] * 4 + [True]
    composed = split.odometry_r[2]
    for delta in split.odometry_r[3:]:
        composed = se2_compose(composed, delta)
    np.testing.assert_allclose(composed, long.odometry_r[2], atol=1e-9)
    assert np.abs(split.odometry_r[3:, 2]).max() < 0.6  # no step turns more than 1.9 s x 0.3
    np.testing.assert_array_equal(split.ground_truth.trajectory.stamps_s, [0.0, 0.5, 10.0])
    assert split.info["max_step_s"] == "2.0"


def test_one_images_sightings_share_a_frame(tmp_path):
    """Sightings stamped 1 ms apart are one image's: one frame, which mutual exclusion within a
    frame needs; 0.25 s apart they are the next image."""
    odometry = "".join(f"{t:.2f} 0.2 0.0\n" for t in np.arange(0.0, 2.0, 0.01))
    measurement = "0.500 63 2.0 0.1\n0.501 81 1.0 0.2\n0.750 63 2.0 0.1\n"
    folder = write_folder(tmp_path / "ds", odometry, measurement)
    seq = load_mrclam(folder, 1, command_delay_s=0)
    np.testing.assert_allclose(seq.stamps_s, [0.0, 0.5, 0.75])
    assert sorted(seq.range_bearing[1].landmark_ids.tolist()) == [6, 7]
    assert seq.info["same_image_s"] == str(SAME_IMAGE_S)
    apart = load_mrclam(folder, 1, command_delay_s=0, same_image_s=0.0)
    np.testing.assert_allclose(apart.stamps_s, [0.0, 0.5, 0.501, 0.75])


def test_image_stamps_bound_a_burst_by_its_first_stamp():
    stamps = np.array([0.0, 0.01, 0.02, 0.03, 0.5, 0.5, 0.505])
    np.testing.assert_allclose(image_stamps(stamps, 0.02), [0.0, 0.0, 0.0, 0.03, 0.5, 0.5, 0.5])
    np.testing.assert_array_equal(image_stamps(stamps, 0.0), stamps)
    assert image_stamps(np.zeros(0), 0.02).shape == (0,)
    with pytest.raises(ConfigError, match="same_image_s"):
        image_stamps(stamps, -1.0)


@needs_data
@pytest.mark.parametrize("robot", [1, 2, 3, 4, 5])
def test_dataset6_stamps_split_images_by_milliseconds(robot):
    """The fact behind SAME_IMAGE_S: consecutive distinct stamps are either <= 4 ms apart (one
    image) or >= 0.1 s (the next), and no burst holds a barcode twice."""
    table = np.loadtxt(DATASET6 / f"Robot{robot}_Measurement.dat")
    gaps = np.diff(np.unique(table[:, 0]))
    assert np.sum(gaps <= 0.0045) > 50
    assert not np.any((gaps > 0.0045) & (gaps < 0.1))
    bursts = image_stamps(table[:, 0], SAME_IMAGE_S)
    pairs = {(b, c) for b, c in zip(bursts.tolist(), table[:, 1].astype(int).tolist(), strict=True)}
    assert len(pairs) == len(table)


def test_fill_gaps_keeps_every_stamp_and_bounds_the_steps():
    stamps = np.array([0.0, 0.1, 3.0, 3.05, 10.0])
    filled = fill_gaps(stamps, 1.0)
    assert set(stamps) <= set(filled)
    assert np.all(np.diff(filled) > 0) and np.diff(filled).max() <= 1.0
    assert len(filled) == 2 + 3 + 1 + 7
    np.testing.assert_array_equal(fill_gaps(stamps, np.inf), stamps)
    with pytest.raises(ConfigError, match="max_step_s"):
        fill_gaps(stamps, 0.0)


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


def test_the_command_delay_shifts_the_arc(tmp_path):
    # the same quarter circle commanded from t = 0: with a 0.25 s delay it has not ended at 1 s
    odometry = "".join(f"{t:.2f} 1.0 {np.pi / 2}\n" for t in np.arange(0.0, 1.0, 0.01))
    folder = write_folder(tmp_path / "ds", odometry, "0.5 63 2.0 0.1\n1.0 63 1.0 0.0\n")
    seq = load_mrclam(folder, 1, command_delay_s=0.25)
    heading = seq.odometry_r[1, 2] + seq.odometry_r[2, 2]
    assert heading == pytest.approx(0.75 * np.pi / 2, abs=1e-12)


def test_depths_become_ranges_and_can_be_kept(tmp_path):
    odometry = "0.0 0 0\n1.0 0 0\n"
    folder = write_folder(tmp_path / "ds", odometry, "0.5 63 2.0 0.5\n")
    converted = load_mrclam(folder, 1).range_bearing[1]
    assert converted.ranges_m[0] == pytest.approx((2.0 - DEPTH_BIAS_M) / np.cos(0.5))
    kept = load_mrclam(folder, 1, depth_ranges=False).range_bearing[1]
    assert kept.ranges_m[0] == 2.0


def _residuals(robot: int, shift_s: float = 0.0):
    """Recorded (depth, bearing) of every sighting of a robot and its true range and bearing."""
    barcodes = read_barcodes(DATASET6 / "Barcodes.dat")
    ids, xy = read_landmark_groundtruth(DATASET6 / "Landmark_Groundtruth.dat")
    position = dict(zip(ids.tolist(), xy, strict=True))
    vicon = read_robot_groundtruth(DATASET6 / f"Robot{robot}_Groundtruth.dat")
    sightings = read_robot_measurements(DATASET6 / f"Robot{robot}_Measurement.dat", barcodes)
    t = sightings.stamps_s + shift_s
    pose = np.column_stack(
        [np.interp(t, vicon.stamps_s, c) for c in (vicon.se2[:, 0], vicon.se2[:, 1])]
        + [np.interp(t, vicon.stamps_s, np.unwrap(vicon.se2[:, 2]))]
    )
    d = np.array([position[int(i)] for i in sightings.landmark_ids]) - pose[:, :2]
    true_bearing = wrap_angle(np.arctan2(d[:, 1], d[:, 0]) - pose[:, 2])
    return sightings.ranges_m, sightings.bearings_rad, np.hypot(*d.T), true_bearing


def _mad(x: np.ndarray) -> float:
    return float(1.4826 * np.median(np.abs(x - np.median(x))))


@needs_data
def test_the_range_column_is_an_optical_axis_depth():
    """Robot 1: range residuals fall with |bearing|, depth residuals do not; converted ranges
    agree with Vicon within the stated noise."""
    depth, bearing, true_range, true_bearing = _residuals(1)
    centre, edge = np.abs(bearing) < 0.2, np.abs(bearing) > 0.45
    as_range = depth - true_range
    assert np.median(as_range[centre]) - np.median(as_range[edge]) > 0.25
    as_depth = depth - true_range * np.cos(true_bearing)
    assert abs(np.median(as_depth[centre]) - np.median(as_depth[edge])) < 0.05
    assert np.median(as_depth) == pytest.approx(DEPTH_BIAS_M, abs=0.04)
    converted = (depth - DEPTH_BIAS_M) / np.cos(bearing) - true_range
    assert _mad(converted) < 0.6 * SIGMA_RANGE_M < _mad(as_range)
    assert abs(np.median(converted)) < SIGMA_RANGE_M  # the per-robot part of the bias


@needs_data
def test_commanded_velocities_lead_vicon_by_the_command_delay():
    """Robot 1: the commanded yaw rate matches the Vicon yaw rate best when delayed 0.2 s."""
    vicon = read_robot_groundtruth(DATASET6 / "Robot1_Groundtruth.dat")
    commands = read_robot_odometry(DATASET6 / "Robot1_Odometry.dat")
    t = vicon.stamps_s[::6]
    yaw_rate = np.gradient(np.unwrap(vicon.se2[::6, 2]), t)
    shifts = np.round(np.arange(0.0, 0.45, 0.05), 2)
    rms = [
        np.sqrt(np.mean((np.interp(t, commands[:, 0] + s, commands[:, 2]) - yaw_rate) ** 2))
        for s in shifts
    ]
    assert shifts[int(np.argmin(rms))] == pytest.approx(COMMAND_DELAY_S, abs=0.05)


@needs_data
def test_the_stated_odometry_noise_is_consistent_and_the_default_is_not(robot1):
    """Frame-to-frame odometry errors against Vicon: NEES median near chi2(3)'s 2.37 under
    ``ODOMETRY_NOISE``, far above it under the shared default motion noise."""
    truth = robot1.ground_truth.trajectory
    frame = np.searchsorted(robot1.stamps_s, truth.stamps_s)
    pairs = np.flatnonzero(np.diff(frame) == 1)
    true_steps = se2_between(truth.se2[pairs], truth.se2[pairs + 1])
    steps = robot1.odometry_r[frame[pairs + 1]]
    error = steps - true_steps
    error[:, 2] = wrap_angle(error[:, 2])
    stated = robot1.odometry_covariance_r[frame[pairs + 1]]
    default = np.array([OdometryMotionModel(MotionNoise()).covariance(d) for d in steps])

    def nees(cov):  # with 1 mm / 1 mrad of Vicon noise: standing still, the odometry is exact
        return np.einsum("ni,nij,nj->n", error, np.linalg.inv(cov + 1e-6 * np.eye(3)), error)

    np.testing.assert_allclose(
        stated[:5], [OdometryMotionModel(ODOMETRY_NOISE).covariance(d) for d in steps[:5]]
    )
    assert 1.0 < np.median(nees(stated)) < 4.0
    assert np.median(nees(default)) > 8.0


@needs_data
def test_robot3s_misread_barcodes_name_landmark_20():
    """The gross outliers of robot 3: four sightings (t ~ 255 s) name landmark 20 but lie
    ~3 rad from it (they fit landmark 11: ``benchmarks/association_mrclam.py``)."""
    _, bearing, _, true_bearing = _residuals(3)
    barcodes = read_barcodes(DATASET6 / "Barcodes.dat")
    ids = read_robot_measurements(DATASET6 / "Robot3_Measurement.dat", barcodes).landmark_ids
    gross = np.flatnonzero(np.abs(wrap_angle(bearing - true_bearing)) > 1.0)
    assert len(gross) == 4 and set(ids[gross].tolist()) == {20}
