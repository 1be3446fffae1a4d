"""CARMEN log loader (corrected intel/aces logs and raw logs)."""

import gzip
from pathlib import Path

import numpy as np
import pytest

from omnislam.core.se import se2_between
from omnislam.datasets.carmen import PSEUDO_NOTE, load_carmen
from omnislam.datasets.sequence import GroundTruthKind
from omnislam.errors import DataError

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"
INTEL = DATA / "carmen" / "intel-corrected.log.gz"
ACES = DATA / "carmen" / "aces-corrected.log.gz"
needs_data = pytest.mark.skipif(not INTEL.is_file(), reason=f"CARMEN logs not in {INTEL.parent}")


@needs_data
def test_intel_has_910_scans_with_pseudo_ground_truth():
    seq = load_carmen(INTEL)
    assert len(seq) == 910
    assert seq.laser.ranges_m.shape == (910, 180)
    assert seq.laser.angles_rad[0] == pytest.approx(-np.pi / 2)
    assert seq.ground_truth.kind is GroundTruthKind.PSEUDO
    assert seq.ground_truth.note == PSEUDO_NOTE
    assert seq.info["stamps_repaired"] == "4"  # the intel clock steps back four times


@needs_data
def test_odometry_is_raw_not_the_corrected_poses():
    seq = load_carmen(ACES)
    assert len(seq) == 440
    truth_steps = se2_between(
        seq.ground_truth.trajectory.se2[:-1], seq.ground_truth.trajectory.se2[1:]
    )
    difference = np.abs(seq.odometry_r[1:] - truth_steps)
    assert np.median(difference[:, 2]) > 1e-3  # not a copy of the ground truth ...
    assert np.median(difference[:, 2]) < 0.05  # ... but close to it


def flaser(pose, odom, stamp, beams=4):
    ranges = " ".join(["1.0"] * beams)
    p = " ".join(map(str, pose))
    o = " ".join(map(str, odom))
    return f"FLASER {beams} {ranges} {p} {o} {stamp} host {stamp}\n"


def odom(pose, stamp):
    return f"ODOM {pose[0]} {pose[1]} {pose[2]} 0 0 0 {stamp} host {stamp}\n"


def test_corrected_log_uses_the_odom_chain(tmp_path):
    text = (
        "# comment\n"
        + odom((0, 0, 0), 0.1)
        + flaser((0, 0, 0), (0, 0, 0), 0.1)
        + odom((0, 0, 0), 0)  # reset to the corrected pose
        + odom((1.1, 0, 0), 1.0)
        + flaser((1.0, 0.1, 0.05), (1.0, 0.1, 0.05), 1.0)
        + odom((1.0, 0.1, 0.05), 0)
        + odom((1.0, 0.1, 0.55), 2.0)
        + flaser((1.0, 0.1, 0.5), (1.0, 0.1, 0.5), 2.0)
    )
    path = tmp_path / "small.log.gz"
    with gzip.open(path, "wt") as stream:
        stream.write(text)
    seq = load_carmen(path)
    assert seq.info["corrected_log"] == "true"
    assert np.allclose(seq.odometry_r[1], [1.1, 0, 0])
    assert np.allclose(seq.odometry_r[2], [0, 0, 0.5])
    assert seq.ground_truth.kind is GroundTruthKind.PSEUDO


def test_raw_log_uses_flaser_odom_fields(tmp_path):
    text = flaser((9, 9, 0), (0, 0, 0), 1.0) + flaser((9, 9, 0), (2, 0, 0), 2.0)
    path = tmp_path / "raw.log"
    path.write_text(text)
    seq = load_carmen(path)
    assert np.allclose(seq.odometry_r[1], [2, 0, 0])
    assert seq.ground_truth.kind is GroundTruthKind.NONE


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            flaser((0, 0, 0), (0, 0, 0), 1.0)[:30] + "\n",
            "line 1: FLASER with 4 beams needs 13 fields.*truncated",
        ),
        (
            flaser((0, 0, 0), (0, 0, 0), 1.0).replace("1.0 1.0 1.0 1.0", "1.0 x 1.0 1.0"),
            "line 1: range 'x'",
        ),
        ("ODOM 0 0\n", "line 1: ODOM needs at least 7 fields"),
        (
            flaser((0, 0, 0), (0, 0, 0), 10.0) + flaser((0, 0, 0), (0, 0, 0), 1.0),
            "line 2: time 1.0 is earlier",
        ),
        ("PARAM x 1\n", "no FLASER records"),
        (
            flaser((0, 0, 0), (0, 0, 0), 1.0) + flaser((0, 0, 0), (0, 0, 0), 2.0, beams=5),
            "line 2: FLASER has 5 beams, earlier ones 4",
        ),
    ],
)
def test_bad_input(tmp_path, text, message):
    path = tmp_path / "bad.log"
    path.write_text(text)
    with pytest.raises(DataError, match=message) as info:
        load_carmen(path)
    assert str(info.value).startswith(str(path))


def test_truncated_gzip_is_a_data_error(tmp_path):
    path = tmp_path / "cut.log.gz"
    with gzip.open(path, "wt") as stream:
        stream.write(flaser((0, 0, 0), (0, 0, 0), 1.0) * 200)
    path.write_bytes(path.read_bytes()[:-20])
    with pytest.raises(DataError, match="cannot read"):
        load_carmen(path)


def test_low_resolution_stamps_are_spread_between_distinct_stamps(tmp_path, caplog):
    """Stamps printed with 6 significant digits: 12 scans over two printed values. They keep
    their order, become strictly increasing, and fill the interval to the next distinct stamp
    (the last group at the mean scan period), with one warning."""
    stamps = [1.00213e9] * 6 + [1.00214e9] * 6
    text = "".join(
        flaser((0.1 * k, 0, 0), (0.1 * k, 0, 0), stamp) for k, stamp in enumerate(stamps)
    )
    path = tmp_path / "lowres.log"
    path.write_text(text)
    with caplog.at_level("WARNING"):
        seq = load_carmen(path)
    assert sum("too few digits" in r.getMessage() for r in caplog.records) == 1
    assert np.all(np.diff(seq.stamps_s) > 0)
    assert seq.info["stamps_spread"] == "10" and seq.info["stamps_repaired"] == "0"
    assert np.allclose(np.diff(seq.stamps_s), 1e4 / 6)  # 10 000 s over 6 scans, then the same
    assert seq.stamps_s[0] == 1.00213e9 and seq.stamps_s[6] == 1.00214e9


def test_a_few_repeated_stamps_are_repaired_not_spread(tmp_path):
    stamps = [float(k) for k in range(20)]
    stamps[10] = stamps[9]  # one repeat in 20: a clock glitch, not a low-resolution log
    text = "".join(flaser((0.1 * k, 0, 0), (0.1 * k, 0, 0), t) for k, t in enumerate(stamps))
    path = tmp_path / "glitch.log"
    path.write_text(text)
    seq = load_carmen(path)
    assert seq.info["stamps_spread"] == "0" and seq.info["stamps_repaired"] == "1"
    assert seq.stamps_s[10] == pytest.approx(9.001)


@pytest.mark.parametrize(
    ("beams", "last_deg", "step_deg"),
    [(180, 89.0, 1.0), (181, 90.0, 1.0), (361, 90.0, 0.5), (360, 89.5, 0.5)],
)
def test_beam_angles_cover_minus_90_to_90_degrees(beams, last_deg, step_deg):
    from omnislam.datasets.carmen import flaser_angles_rad

    angles = np.rad2deg(flaser_angles_rad(beams))
    assert angles[0] == pytest.approx(-90.0) and angles[-1] == pytest.approx(last_deg)
    assert np.allclose(np.diff(angles), step_deg)


def test_a_stated_odometry_noise_gives_every_frame_the_motion_model_covariance(tmp_path):
    from omnislam.core.motion import OdometryMotionModel
    from omnislam.datasets.carmen import parse_odometry_noise
    from omnislam.datasets.registry import CARMEN_ODOMETRY_NOISE, DatasetFormat, parse_options

    text = (
        odom((0, 0, 0), 0.1)
        + flaser((0, 0, 0), (0, 0, 0), 0.1)
        + odom((0, 0, 0), 0)
        + odom((1.1, 0, 0.3), 1.0)
        + flaser((1.0, 0.1, 0.05), (1.0, 0.1, 0.05), 1.0)
    )
    path = tmp_path / "small.log.gz"
    with gzip.open(path, "wt") as stream:
        stream.write(text)
    assert load_carmen(path).odometry_covariance_r is None  # not stated by default
    options = parse_options(
        DatasetFormat.CARMEN, {"odometry_noise": CARMEN_ODOMETRY_NOISE["carmen-aces"]}
    )
    seq = load_carmen(path, **options)
    noise = parse_odometry_noise(CARMEN_ODOMETRY_NOISE["carmen-aces"])
    assert noise.min_sigma == (0.0018, 0.0302, 0.0018)  # (rot, trans, rot) floors
    expected = OdometryMotionModel(noise).covariance(seq.odometry_r[1])
    np.testing.assert_allclose(seq.odometry_covariance_r[1], expected)
    np.testing.assert_allclose(seq.frame_input(1).odometry.covariance, expected)
    with pytest.raises(ValueError):
        parse_odometry_noise("0.1,0.2")
