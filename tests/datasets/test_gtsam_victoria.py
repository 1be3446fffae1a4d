"""gtsam's victoria_park.txt loader."""

import numpy as np
import pytest

from omnislam.datasets.gtsam_victoria import find_gtsam_file, load_gtsam_victoria
from omnislam.datasets.sequence import GroundTruthKind
from omnislam.errors import DataError

GTSAM_FILE = find_gtsam_file()
needs_file = pytest.mark.skipif(
    GTSAM_FILE is None or not GTSAM_FILE.is_file(),
    reason="gtsam (and its victoria_park.txt) missing",
)


@needs_file
def test_gtsam_file_has_6969_poses_151_landmarks_3640_sightings():
    seq = load_gtsam_victoria(GTSAM_FILE)
    assert len(seq) == 6969
    ids = np.concatenate([rb.landmark_ids for rb in seq.range_bearing if rb is not None])
    assert len(ids) == 3640
    assert len(np.unique(ids)) == 151
    assert seq.ground_truth.kind is GroundTruthKind.NONE
    assert seq.ground_truth.trajectory is None


@needs_file
def test_noise_follows_gtsam_load2d():
    seq = load_gtsam_victoria(GTSAM_FILE)
    first = next(rb for rb in seq.range_bearing if rb is not None)
    assert first.sigma_bearing_rad[0] == pytest.approx(np.sqrt(0.4 / 10))
    assert first.sigma_range_m[0] == pytest.approx(np.sqrt(0.4))
    # first sighting: LANDMARK 4 5 11.5387 -3.2007 at pose 4 (frame 4)
    assert seq.range_bearing[4].ranges_m[0] == pytest.approx(np.hypot(11.5387, -3.2007))
    assert seq.range_bearing[4].bearings_rad[0] == pytest.approx(np.arctan2(-3.2007, 11.5387))
    assert seq.odometry_r[1] == pytest.approx([0.000985144, -3.63222e-10, -1.54136e-06])


ODO = "ODOMETRY 0 1 1 0 0 0.0001 0 0 4e-06 0 4e-06\n"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (ODO + "ODOMETRY 1 2 1 0 0 0.0001 0 0 4e-06\n", "line 2: ODOMETRY needs 11 fields, got 9"),
        (ODO + "LANDMARK 1 9 1 one 0.4 0 0.4\n", "line 2: field 'one' is not a number"),
        (ODO + "VERTEX2 1 0 0 0\n", "line 2: unknown record 'VERTEX2'"),
        (ODO + "ODOMETRY 5 6 1 0 0 0.0001 0 0 4e-06 0 4e-06\n", "chain is at 1"),
        (ODO + "LANDMARK 7 9 1 1 0.4 0 0.4\n", "refers to pose 7"),
        ("", "no ODOMETRY records"),
    ],
)
def test_bad_input(tmp_path, text, message):
    path = tmp_path / "graph.txt"
    path.write_text(text)
    with pytest.raises(DataError, match=message) as info:
        load_gtsam_victoria(path)
    assert str(info.value).startswith(str(path))


@needs_file
def test_stated_sighting_noise_can_be_overridden_and_the_rest_is_unchanged():
    file_noise = load_gtsam_victoria(GTSAM_FILE)
    restated = load_gtsam_victoria(GTSAM_FILE, sigma_range_m=0.25, sigma_bearing_rad=0.05)
    pairs = [
        (a, b)
        for a, b in zip(file_noise.range_bearing, restated.range_bearing, strict=True)
        if a is not None
    ]
    assert len(pairs) == 3331
    for a, b in pairs:
        assert np.all(b.sigma_range_m == 0.25)
        assert np.all(b.sigma_bearing_rad == 0.05)
        assert np.array_equal(a.ranges_m, b.ranges_m)
        assert np.array_equal(a.bearings_rad, b.bearings_rad)
        assert np.array_equal(a.landmark_ids, b.landmark_ids)
    assert np.array_equal(file_noise.odometry_covariance_r, restated.odometry_covariance_r)
    assert restated.info["sigma_bearing_rad"] == "0.05"


@needs_file
def test_registry_passes_the_noise_options_to_the_loader():
    from omnislam.datasets.registry import load_dataset, resolve

    seq = load_dataset(resolve("victoria-park-gtsam"), {"sigma_bearing_rad": "0.06"})
    first = next(rb for rb in seq.range_bearing if rb is not None)
    assert first.sigma_bearing_rad[0] == pytest.approx(0.06)
    assert first.sigma_range_m[0] == pytest.approx(np.sqrt(0.4))


@needs_file
def test_stated_odometry_heading_noise_can_be_overridden():
    file_noise = load_gtsam_victoria(GTSAM_FILE)
    restated = load_gtsam_victoria(GTSAM_FILE, odometry_sigma_theta_rad=0.014)
    assert np.array_equal(file_noise.odometry_r, restated.odometry_r)
    assert np.allclose(restated.odometry_covariance_r[1:, 2, 2], 0.014**2)
    assert np.array_equal(
        file_noise.odometry_covariance_r[:, :2, :2], restated.odometry_covariance_r[:, :2, :2]
    )
    assert restated.info["odometry_sigmas"] == "0.01 0.002 0.014"
