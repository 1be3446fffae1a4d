"""``omnislam dataset import BAG``: ROS 1 and ROS 2 bags written here with rosbags' own writers
from a short render of the demo give the render's numbers.

The bags carry what a robot records: odometry poses (``/odom``, the render's odometry
integrated), compressed images, laser scans and ground truth on ``/tf``. The increments the
importer takes between the odometry poses differ from the render's by float round-off, so the
front end and graphslam on the imported folder give the render's trajectory to 1e-9 m with PNG
images; JPEG images (quality 95) change the pixels and move it by millimetres.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from ros_bags import KINDS, write_bag

from omnislam.cli import main
from omnislam.datasets.folder import check_folder, export_folder, load_folder
from omnislam.datasets.registry import load_dataset
from omnislam.datasets.rosbag import Role, parse_topics
from omnislam.errors import ConfigError, DataError

pytest.importorskip("rosbags")
pytest.importorskip("cv2")

#: images of the demo render the bags hold (a few dozen frames)
IMAGES = 6
#: the imported folder's odometry and ground truth against the render's (round-off of the
#: poses the bag carries and of the header stamps' nanoseconds)
ROUND_OFF = 1e-12
#: graphslam's trajectory on the imported folder against the render's, PNG images [m]
SAME_TRAJECTORY_M = 1e-9
TOPICS = ["--topic", "odometry=/odom", "--topic", "images=/camera/image/compressed",
          "--topic", "scan=/scan", "--topic", "groundtruth=/tf"]


@pytest.fixture(scope="module")
def render(tmp_path_factory) -> Path:
    from omnislam.datasets.synthetic.presets import PRESETS
    from omnislam.datasets.synthetic.simulate import simulate
    from omnislam.datasets.synthetic.writer import write_synthetic

    out = tmp_path_factory.mktemp("render") / "demo"
    write_synthetic(out, simulate(PRESETS["demo"], seed=0, max_images=IMAGES))
    return out


def _bag_path(root: Path, kind: str) -> Path:
    return root / (f"{kind}.bag" if kind == "ros1" else kind)


def _import(render: Path, bag: Path, out: Path, *extra: str) -> int:
    argv = ["-q", "dataset", "import", str(bag), "--out", str(out), *TOPICS,
            "--calibration", str(render / "calibration.yaml"), *extra]
    return main(argv)


@pytest.mark.parametrize("kind", KINDS)
def test_a_bag_imports_the_renders_streams(render, tmp_path, kind):
    original = load_dataset(str(render))
    bag = write_bag(original, _bag_path(tmp_path, kind), kind, scan=True)
    assert _import(render, bag, tmp_path / "imported") == 0
    assert check_folder(tmp_path / "imported") == []
    imported = load_folder(tmp_path / "imported")
    np.testing.assert_allclose(imported.stamps_s, original.stamps_s, rtol=0, atol=ROUND_OFF)
    np.testing.assert_allclose(imported.odometry_r, original.odometry_r, rtol=0, atol=ROUND_OFF)
    np.testing.assert_array_equal(imported.image_frames, original.image_frames)
    last = int(original.image_frames[-1])
    np.testing.assert_array_equal(imported.image(last), original.image(last))  # PNG: lossless
    np.testing.assert_array_equal(imported.laser.ranges_m,
                                  original.laser.ranges_m.astype(np.float32))
    np.testing.assert_allclose(imported.laser.angles_rad, original.laser.angles_rad, atol=1e-6)
    truth, expected = imported.ground_truth.trajectory, original.ground_truth.trajectory
    np.testing.assert_allclose(truth.poses_w, expected.poses_w, rtol=0, atol=ROUND_OFF)
    np.testing.assert_allclose(imported.initial_pose_w, original.initial_pose_w, atol=ROUND_OFF)


def _graphslam(folder: Path, out: Path) -> np.ndarray:
    argv = ["-q", "run", str(folder), "--estimator", "graphslam", "--seed", "0", "--out", str(out)]
    assert main(argv) == 0
    return np.loadtxt(out / "trajectory.tum")


@pytest.fixture(scope="module")
def render_trajectory(render, tmp_path_factory) -> np.ndarray:
    """graphslam through the front end on the render's streams a bag carries (its pole
    sightings are no topic of the bags: the folder is the render's without them)."""
    pytest.importorskip("gtsam")
    root = tmp_path_factory.mktemp("reference")
    export_folder(load_dataset(str(render)), root / "render")
    (root / "render" / "sightings.csv").unlink()
    return _graphslam(root / "render", root / "run")


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["ros1", "ros2-mcap"])
def test_front_end_and_graphslam_give_the_renders_trajectory(render, render_trajectory,
                                                             tmp_path, kind):
    bag = write_bag(load_dataset(str(render)), _bag_path(tmp_path, kind), kind, scan=True)
    assert _import(render, bag, tmp_path / "imported") == 0
    trajectory = _graphslam(tmp_path / "imported", tmp_path / "run")
    np.testing.assert_allclose(trajectory, render_trajectory, rtol=0, atol=SAME_TRAJECTORY_M)


def test_jpeg_images_change_pixels_only_slightly(render, tmp_path):
    original = load_dataset(str(render))
    bag = write_bag(original, _bag_path(tmp_path, "ros2-sqlite3"), "ros2-sqlite3",
                    image_format="jpg", scan=True)
    assert _import(render, bag, tmp_path / "imported") == 0
    frame = int(original.image_frames[0])
    difference = np.abs(load_folder(tmp_path / "imported").image(frame).astype(int)
                        - original.image(frame).astype(int))
    assert 0 < difference.mean() < 2.0  # JPEG at quality 95: lossy, about one grey level


def test_topics_parse_and_bad_ones_are_config_errors():
    assert parse_topics(["odometry=/odom", "scan=/scan"]) == {Role.ODOMETRY: "/odom",
                                                             Role.SCAN: "/scan"}
    for bad, needle in ((["odometry"], "ROLE=/topic"), (["odometry=/a", "lidar=/b"], "lidar"),
                        (["scan=/scan"], "odometry=/topic is required"),
                        (["odometry=/a", "odometry=/b"], "twice")):
        with pytest.raises(ConfigError, match=needle):
            parse_topics(bad)


def test_a_missing_topic_or_a_wrong_type_names_the_topic(render, tmp_path):
    from omnislam.datasets.rosbag import import_bag

    bag = write_bag(load_dataset(str(render)), _bag_path(tmp_path, "ros1"), "ros1")
    with pytest.raises(DataError, match=r"topic /scan \(scan\) is not in the bag"):
        import_bag(bag, tmp_path / "out", {Role.ODOMETRY: "/odom", Role.SCAN: "/scan"})
    with pytest.raises(DataError, match="topic /tf: message type tf2_msgs/msg/TFMessage cannot "
                                        "be used as odometry"):
        import_bag(bag, tmp_path / "out", {Role.ODOMETRY: "/tf"})
    with pytest.raises(DataError, match="from map to base_link"):
        import_bag(bag, tmp_path / "out", {Role.ODOMETRY: "/odom", Role.GROUNDTRUTH: "/tf"},
                   world_frame="map")
    assert not (tmp_path / "out").exists()


def test_images_need_a_calibration(render, tmp_path):
    from omnislam.datasets.rosbag import import_bag

    bag = write_bag(load_dataset(str(render)), _bag_path(tmp_path, "ros1"), "ros1")
    with pytest.raises(ConfigError, match="--calibration"):
        import_bag(bag, tmp_path / "out", {Role.ODOMETRY: "/odom",
                                           Role.IMAGES: "/camera/image/compressed"})


def test_the_ground_truths_kind_is_motion_capture_unless_told(render, tmp_path):
    import json

    from omnislam.cli.dataset import GROUNDTRUTH_KINDS
    from omnislam.datasets.rosbag import import_bag
    from omnislam.datasets.sequence import GroundTruthKind

    assert set(GROUNDTRUTH_KINDS) == {k.value for k in GroundTruthKind} - {"none"}
    bag = write_bag(load_dataset(str(render)), _bag_path(tmp_path, "ros1"), "ros1")
    topics = ["--topic", "odometry=/odom", "--topic", "groundtruth=/tf"]
    for kind, extra in (("motion-capture", []), ("pseudo", ["--groundtruth-kind", "pseudo"])):
        out = tmp_path / kind
        assert main(["-q", "dataset", "import", str(bag), "--out", str(out), *topics,
                     *extra]) == 0
        assert json.loads((out / "dataset.json").read_text())["ground_truth"]["kind"] == kind
        assert load_folder(out).ground_truth.kind is GroundTruthKind(kind)
    with pytest.raises(ConfigError, match="groundtruth-kind none"):
        import_bag(bag, tmp_path / "none", {Role.ODOMETRY: "/odom", Role.GROUNDTRUTH: "/tf"},
                   groundtruth_kind=GroundTruthKind.NONE)
    with pytest.raises(SystemExit):
        main(["-q", "dataset", "import", str(bag), "--out", str(tmp_path / "x"), *topics,
              "--groundtruth-kind", "none"])
