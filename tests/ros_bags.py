"""Write ROS 1 and ROS 2 bags from a Sequence with ``rosbags``' own writers (for the importer's
tests): odometry poses, compressed images, ground truth on ``/tf``, laser scans and the robot's
static frames on ``/tf_static``."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from omnislam.core.se import quat_wxyz_from_se3, se2_integrate

#: the bag kinds the tests write: ROS 1, ROS 2 with sqlite3 storage, ROS 2 with MCAP
KINDS = ("ros1", "ros2-sqlite3", "ros2-mcap")


class _Messages:
    """Message builders of one typestore (ROS 1 Noetic or ROS 2 Humble)."""

    def __init__(self, ros1: bool) -> None:
        from rosbags.typesys import Stores, get_types_from_msg, get_typestore

        self.ros1 = ros1
        self.store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
        if ros1:  # Noetic's store has no tf2_msgs: its one-line definition
            self.store.register(get_types_from_msg(
                "geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"))
        self.t = self.store.types

    def serialize(self, message, msgtype: str) -> bytes:
        if self.ros1:
            return self.store.serialize_ros1(message, msgtype)
        return self.store.serialize_cdr(message, msgtype)

    def header(self, stamp_s: float, frame: str):
        sec = int(np.floor(stamp_s))
        time = self.t["builtin_interfaces/msg/Time"](sec=sec, nanosec=round((stamp_s - sec) * 1e9))
        if self.ros1:
            return self.t["std_msgs/msg/Header"](seq=0, stamp=time, frame_id=frame)
        return self.t["std_msgs/msg/Header"](stamp=time, frame_id=frame)

    def pose(self, xyz, q_wxyz):
        t = self.t
        return t["geometry_msgs/msg/Pose"](
            position=t["geometry_msgs/msg/Point"](x=xyz[0], y=xyz[1], z=xyz[2]),
            orientation=t["geometry_msgs/msg/Quaternion"](
                x=q_wxyz[1], y=q_wxyz[2], z=q_wxyz[3], w=q_wxyz[0]),
        )

    def odometry(self, stamp_s: float, x: float, y: float, theta: float):
        t = self.t
        q = [np.cos(theta / 2), 0.0, 0.0, np.sin(theta / 2)]
        twist = t["geometry_msgs/msg/Twist"](
            linear=t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
            angular=t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0))
        return t["nav_msgs/msg/Odometry"](
            header=self.header(stamp_s, "odom"), child_frame_id="base_link",
            pose=t["geometry_msgs/msg/PoseWithCovariance"](
                pose=self.pose([x, y, 0.0], q), covariance=np.zeros(36)),
            twist=t["geometry_msgs/msg/TwistWithCovariance"](twist=twist,
                                                             covariance=np.zeros(36)),
        )

    def transform(self, stamp_s: float, parent: str, child: str, pTc: np.ndarray):
        t = self.t
        q = quat_wxyz_from_se3(pTc)
        transform = t["geometry_msgs/msg/Transform"](
            translation=t["geometry_msgs/msg/Vector3"](x=pTc[0, 3], y=pTc[1, 3], z=pTc[2, 3]),
            rotation=t["geometry_msgs/msg/Quaternion"](x=q[1], y=q[2], z=q[3], w=q[0]))
        return t["geometry_msgs/msg/TransformStamped"](
            header=self.header(stamp_s, parent), child_frame_id=child, transform=transform)

    def tf(self, stamp_s: float, wTr: np.ndarray):
        stamped = self.transform(stamp_s, "world", "base_link", wTr)
        return self.t["tf2_msgs/msg/TFMessage"](transforms=[stamped])

    def tf_static(self, stamp_s: float, edges):
        """One ``/tf_static`` message of ``edges`` ((parent, child, pTc) each)."""
        transforms = [self.transform(stamp_s, p, c, pTc) for p, c, pTc in edges]
        return self.t["tf2_msgs/msg/TFMessage"](transforms=transforms)

    def compressed(self, stamp_s: float, rgb: np.ndarray, fmt: str):
        import cv2

        ok, data = cv2.imencode(f".{fmt}", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
        assert ok
        return self.t["sensor_msgs/msg/CompressedImage"](
            header=self.header(stamp_s, "camera"), format=fmt, data=data.reshape(-1))

    def scan(self, stamp_s: float, angles: np.ndarray, ranges: np.ndarray, max_range: float,
             frame: str = "laser"):
        return self.t["sensor_msgs/msg/LaserScan"](
            header=self.header(stamp_s, frame), angle_min=float(angles[0]),
            angle_max=float(angles[-1]), angle_increment=float(angles[1] - angles[0]),
            time_increment=0.0, scan_time=0.0, range_min=0.0, range_max=float(max_range),
            ranges=np.asarray(ranges, dtype=np.float32), intensities=np.zeros(0, np.float32))


def write_bag(sequence, path: Path, kind: str, *, image_format: str = "png",
              scan: bool = False, static_edges=(), scan_frame: str = "base_link") -> Path:
    """Write ``sequence`` as a bag of ``kind`` (``KINDS``) at ``path``: ``/odom`` (the poses
    its odometry integrates to, child frame ``base_link``), ``/camera/image/compressed``,
    ``/tf`` (ground truth from ``world`` to ``base_link``), with ``scan`` ``/scan`` (in
    ``scan_frame``) and, with ``static_edges`` ((parent, child, pTc (4, 4)) each), one
    ``/tf_static`` message of them before the rest."""
    messages = _Messages(kind == "ros1")
    poses = se2_integrate(sequence.odometry_r)
    truth = sequence.ground_truth.trajectory
    stream = []  # (stamp, topic, msgtype, message)
    if static_edges:
        stamp = float(sequence.stamps_s[0])
        stream.append((stamp, "/tf_static", "tf2_msgs/msg/TFMessage",
                       messages.tf_static(stamp, static_edges)))
    for i, stamp in enumerate(sequence.stamps_s.tolist()):
        odometry = messages.odometry(stamp, *poses[i])
        stream.append((stamp, "/odom", "nav_msgs/msg/Odometry", odometry))
        transform = messages.tf(stamp, truth.poses_w[i])
        stream.append((stamp, "/tf", "tf2_msgs/msg/TFMessage", transform))
        if scan:
            laser = sequence.laser
            stream.append((stamp, "/scan", "sensor_msgs/msg/LaserScan", messages.scan(
                stamp, laser.angles_rad, laser.ranges_m[i], laser.max_range_m, scan_frame)))
    for i in sequence.image_frames.tolist():
        stamp = float(sequence.stamps_s[i])
        stream.append((stamp, "/camera/image/compressed", "sensor_msgs/msg/CompressedImage",
                       messages.compressed(stamp, sequence.image(i), image_format)))
    stream.sort(key=lambda item: item[0])
    if kind == "ros1":
        from rosbags.rosbag1 import Writer

        writer = Writer(path)
    else:
        from rosbags.rosbag2 import StoragePlugin, Writer

        plugin = StoragePlugin.MCAP if kind == "ros2-mcap" else StoragePlugin.SQLITE3
        writer = Writer(path, version=9, storage_plugin=plugin)
    with writer:
        connections = {}
        for _, topic, msgtype, _ in stream:
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, msgtype,
                                                           typestore=messages.store)
        for stamp, topic, msgtype, message in stream:
            writer.write(connections[topic], round(stamp * 1e9),
                         messages.serialize(message, msgtype))
    return path
