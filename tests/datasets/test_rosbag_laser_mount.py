"""The laser's mounting on the robot from a bag's ``/tf_static``: ``omnislam dataset import``
composes the scans' frame in the odometry's child frame along the static tree, states it as
``laser.offset_r``, and the imported folder's laser odometry then follows the robot, not the
scanner (the room of ``mounted_laser_room``: a scanner 0.25 m ahead of the axle, yawed 0.1 rad).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from mounted_laser_room import OFFSET_R, mounted_room
from ros_bags import KINDS, write_bag

from omnislam.cli import main
from omnislam.core.se import se2_between, se3_from_se2, se3_from_xyz_quat
from omnislam.datasets.folder import load_folder
from omnislam.datasets.tf_tree import pose_in

pytest.importorskip("rosbags")

FRAMES = 30
TOPICS = ["--topic", "odometry=/odom", "--topic", "scan=/scan", "--topic", "groundtruth=/tf"]
#: the offset read back against the one written: float32-free doubles through a quaternion
SAME_OFFSET = 1e-12


@pytest.fixture(scope="module")
def room():
    return mounted_room(FRAMES)


def _chain(offset_r: np.ndarray, height_m: float = 0.3) -> list:
    """Static edges base_link -> chassis -> laser whose composition is the planar mount
    ``offset_r`` at ``height_m``: the chassis carries part of the translation and of the yaw,
    the laser frame the rest."""
    base_chassis = se3_from_se2(np.array([0.1, -0.02, 0.04]))
    base_chassis[2, 3] = 0.1
    base_laser = se3_from_se2(offset_r)
    base_laser[2, 3] = height_m
    chassis_laser = np.linalg.inv(base_chassis) @ base_laser
    return [("base_link", "chassis", base_chassis), ("chassis", "laser", chassis_laser)]


def _import(bag, out, *extra: str) -> int:
    return main(["-q", "dataset", "import", str(bag), "--out", str(out), *TOPICS, *extra])


@pytest.mark.parametrize("kind", KINDS)
def test_the_static_frames_give_the_lasers_offset(room, tmp_path, kind):
    path = tmp_path / (f"{kind}.bag" if kind == "ros1" else kind)
    bag = write_bag(room, path, kind, scan=True,
                    static_edges=_chain(OFFSET_R), scan_frame="laser")
    assert _import(bag, tmp_path / "out") == 0
    folder = load_folder(tmp_path / "out")
    np.testing.assert_allclose(folder.laser.offset_r, OFFSET_R, rtol=0, atol=SAME_OFFSET)
    stated = json.loads((tmp_path / "out" / "dataset.json").read_text())["laser"]["offset_r"]
    np.testing.assert_allclose(stated, OFFSET_R, rtol=0, atol=SAME_OFFSET)


def test_the_imported_mount_puts_laser_odometry_on_the_robot(room, tmp_path):
    """Laser odometry of the imported folder against the robot's true steps: with the mount
    read from /tf_static its steps are the robot's (a millimetre), without it they are the
    scanner's, off by centimetres in the turns."""
    from omnislam.frontend.config import LaserOdometryConfig
    from omnislam.frontend.mounted_laser import robot_laser_odometry

    truth = room.ground_truth.trajectory.se2
    true_steps = se2_between(truth[:-1], truth[1:])
    errors = {}
    for name, edges in (("mounted", _chain(OFFSET_R)), ("unstated", [])):
        bag = write_bag(room, tmp_path / f"{name}.bag", "ros1", scan=True, static_edges=edges,
                        scan_frame="laser")
        assert _import(bag, tmp_path / name) == 0
        folder = load_folder(tmp_path / name)
        steps = robot_laser_odometry(folder.laser, folder.odometry_r,
                                     LaserOdometryConfig()).deltas[1:]
        errors[name] = float(np.median(np.linalg.norm(steps[:, :2] - true_steps[:, :2], axis=1)))
    assert errors["mounted"] < 0.002
    assert errors["unstated"] > 5 * errors["mounted"]


def test_without_static_frames_the_laser_is_at_the_origin_with_a_warning(room, tmp_path, caplog):
    bag = write_bag(room, tmp_path / "b.bag", "ros1", scan=True, scan_frame="laser")
    assert _import(bag, tmp_path / "out") == 0
    np.testing.assert_array_equal(load_folder(tmp_path / "out").laser.offset_r, np.zeros(3))
    assert "/tf_static does not join the scans' frame 'laser' to the robot's 'base_link'" \
        in caplog.text


def test_a_stated_offset_wins_and_a_bad_one_is_refused(room, tmp_path, capsys):
    bag = write_bag(room, tmp_path / "b.bag", "ros1", scan=True,
                    static_edges=_chain(OFFSET_R), scan_frame="laser")
    assert _import(bag, tmp_path / "out", "--laser-offset", "0.2,0,0.05") == 0
    np.testing.assert_allclose(load_folder(tmp_path / "out").laser.offset_r, [0.2, 0.0, 0.05])
    capsys.readouterr()
    assert _import(bag, tmp_path / "bad", "--laser-offset", "0.2,0") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--laser-offset needs X,Y,YAW" in err[0]
    assert not (tmp_path / "bad").exists()


def test_a_tilted_laser_is_refused_naming_its_frame(room, tmp_path, capsys):
    tilted = se3_from_se2(OFFSET_R)
    tilted[:3, :3] = tilted[:3, :3] @ se3_from_xyz_quat(
        np.zeros(3), np.array([math.cos(0.1), math.sin(0.1), 0.0, 0.0]))[:3, :3]  # 11.5 deg roll
    bag = write_bag(room, tmp_path / "b.bag", "ros1", scan=True,
                    static_edges=[("base_link", "laser", tilted)], scan_frame="laser")
    assert _import(bag, tmp_path / "out") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert "frame 'laser' is tilted 11.5 deg against 'base_link'" in err[0] and "b.bag" in err[0]
    assert not (tmp_path / "out").exists()


def test_poses_compose_along_the_tree_either_way():
    edges = {(p, c): pTc for p, c, pTc in _chain(OFFSET_R)}
    base_laser = pose_in(edges, "base_link", "laser")
    np.testing.assert_allclose(base_laser[:2, 3], OFFSET_R[:2], atol=1e-12)
    np.testing.assert_allclose(pose_in(edges, "/laser", "base_link"), np.linalg.inv(base_laser),
                               atol=1e-12)
    assert pose_in(edges, "base_link", "camera") is None
    np.testing.assert_array_equal(pose_in(edges, "chassis", "chassis"), np.eye(4))
