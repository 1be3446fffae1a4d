import numpy as np
import pytest

from omnislam.core.se import se3_exp
from omnislam.core.types import Trajectory
from omnislam.datasets.trajectory_io import read_kitti, read_tum, write_kitti, write_tum
from omnislam.errors import DataError


@pytest.fixture
def trajectory(rng):
    poses = se3_exp(rng.normal(0, 1.0, (50, 6)))
    return Trajectory(np.cumsum(rng.uniform(0.01, 0.2, 50)) + 1e9, poses)


def test_tum_round_trip_is_exact(tmp_path, trajectory):
    write_tum(tmp_path / "t.tum", trajectory)
    back = read_tum(tmp_path / "t.tum")
    np.testing.assert_array_equal(back.stamps_s, trajectory.stamps_s)
    np.testing.assert_allclose(back.poses_w, trajectory.poses_w, atol=1e-12)


def test_kitti_round_trip(tmp_path, trajectory):
    write_kitti(tmp_path / "t.txt", trajectory)
    back = read_kitti(tmp_path / "t.txt", trajectory.stamps_s)
    np.testing.assert_allclose(back.poses_w, trajectory.poses_w, atol=1e-12)
    assert np.array_equal(read_kitti(tmp_path / "t.txt").stamps_s, np.arange(50.0))


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("0 0 0 0 0 0 0 1\n1 0 0 0 0 0 1\n", "line 2: expected 8 values, found 7"),
        ("0 0 0 0 0 0 0 1\n1 0 0 x 0 0 0 1\n", "line 2: not a number"),
        ("0 0 0 0 0 0 0 1\n0 0 0 0 0 0 0 1\n", "line 2: stamp"),
        ("# header\n0 0 0 0 0 0 0 2\n", "line 2: quaternion norm"),
        ("# only a comment\n", "no poses"),
        ("0 0 0 nan 0 0 0 1\n", "line 1: NaN"),
    ],
)
def test_tum_malformed_input_names_file_and_line(tmp_path, text, message):
    path = tmp_path / "bad.tum"
    path.write_text(text)
    with pytest.raises(DataError, match=message) as info:
        read_tum(path)
    assert str(path) in str(info.value)


def test_kitti_rejects_non_rotation_and_missing_file(tmp_path):
    path = tmp_path / "bad.txt"
    path.write_text("2 0 0 0 0 1 0 0 0 0 1 0\n")
    with pytest.raises(DataError, match="line 1: rotation"):
        read_kitti(path)
    with pytest.raises(DataError, match="cannot read"):
        read_kitti(tmp_path / "missing.txt")


def test_writer_leaves_no_partial_file_on_error(tmp_path, trajectory, monkeypatch):
    target = tmp_path / "t.tum"
    write_tum(target, trajectory)
    before = target.read_text()

    def broken(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr("omnislam._files.os.replace", broken)
    with pytest.raises(OSError):
        write_tum(target, Trajectory.from_se2([0.0], [[1.0, 2.0, 0.3]]))
    assert target.read_text() == before
    assert [p.name for p in tmp_path.iterdir()] == ["t.tum"]
