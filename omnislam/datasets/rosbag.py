"""Import a ROS 1 or ROS 2 bag (sqlite3 or MCAP) into an omnislam folder.

``omnislam dataset import BAG --out DIR --topic odometry=/odom --topic images=/camera/compressed
--topic scan=/scan --topic groundtruth=/tf`` reads the bag with the ``rosbags`` library (pure
Python, no ROS install: the ``rosbag`` extra) and writes the folder (``datasets.folder``).

Topics by role and the message types each takes:

* ``odometry``: ``nav_msgs/Odometry`` (its planar pose; the increments between frames are
  taken between the poses, interpolated at the frames' stamps). Required.
* ``images``: ``sensor_msgs/CompressedImage`` (PNG or JPEG bytes) or ``sensor_msgs/Image``
  (``rgb8``, ``bgr8``, ``mono8``); the camera's calibration is an omnislam rig YAML given with
  ``--calibration`` (a ROS ``CameraInfo`` describes a pinhole camera only).
* ``scan``: ``sensor_msgs/LaserScan``, every scan with the same beams; a range outside
  ``[range_min, range_max]`` or not finite is "no return" (``range_max``). The scanner's
  mounting on the robot (``LaserScans.offset_r``) is the pose of the scans' ``frame_id`` in the
  odometry's ``child_frame_id``, composed from the bag's ``/tf_static`` (``datasets.tf_tree``;
  ``--laser-offset X,Y,YAW`` states it instead); a scanner frame that ``/tf_static`` does not
  join to the robot's is taken to be at the robot's origin, with a warning.
* ``groundtruth``: ``geometry_msgs/PoseStamped``, ``nav_msgs/Odometry``,
  ``geometry_msgs/TransformStamped``, or ``tf2_msgs/TFMessage`` (``/tf``: the transforms from
  ``world_frame`` to ``gt_frame``).

The frames are the odometry's stamps and the sensors' (images, scans) within the odometry's
time span: every image and scan gets a frame of its own stamp. Stamps are the messages'
header stamps. Long bags show progress on stderr; a topic that is missing, of a type this
importer cannot use, or a message that cannot be decoded is one error line naming the topic
and the message.
"""

from __future__ import annotations

import enum
import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from omnislam.core.se import se2_from_se3, se3_from_xyz_quat
from omnislam.core.types import Trajectory
from omnislam.datasets._common import interpolate_se2, odometry_from_poses
from omnislam.datasets.sequence import GroundTruth, GroundTruthKind, LaserScans
from omnislam.datasets.sequence import Sequence as DataSequence
from omnislam.datasets.tf_tree import frame_name, planar_mount, pose_in, static_edge
from omnislam.errors import ConfigError, DataError

log = logging.getLogger(__name__)


class Role(enum.Enum):
    """What a topic of the bag is for."""

    ODOMETRY = "odometry"
    IMAGES = "images"
    SCAN = "scan"
    GROUNDTRUTH = "groundtruth"


#: the message types each role accepts (ROS 2 names; rosbags names ROS 1 types the same way)
ACCEPTED: dict[Role, tuple[str, ...]] = {
    Role.ODOMETRY: ("nav_msgs/msg/Odometry",),
    Role.IMAGES: ("sensor_msgs/msg/CompressedImage", "sensor_msgs/msg/Image"),
    Role.SCAN: ("sensor_msgs/msg/LaserScan",),
    Role.GROUNDTRUTH: (
        "geometry_msgs/msg/PoseStamped",
        "nav_msgs/msg/Odometry",
        "geometry_msgs/msg/TransformStamped",
        "tf2_msgs/msg/TFMessage",
    ),
}
#: how long a gap in the odometry may be bridged by interpolation [s]
MAX_ODOMETRY_GAP_S = 1.0
#: how long a gap in the ground truth may be bridged to give the first frame's pose [s]
MAX_GROUND_TRUTH_GAP_S = 0.5
#: the topic of the robot's static frames (read for the laser's mounting when scans are asked for)
STATIC_TOPIC = "/tf_static"
#: the robot's frame when the odometry names none
DEFAULT_ROBOT_FRAME = "base_link"


def parse_topics(items: Sequence[str]) -> dict[Role, str]:
    """``["odometry=/odom", ...]`` -> role -> topic.

    Raises:
        ConfigError: a malformed item, an unknown role, a role given twice, no odometry.
    """
    topics: dict[Role, str] = {}
    roles = ", ".join(r.value for r in Role)
    for item in items:
        name, sep, topic = item.partition("=")
        if not sep or not topic.strip():
            raise ConfigError(f"--topic expects ROLE=/topic, got {item!r}")
        try:
            role = Role(name.strip())
        except ValueError:
            raise ConfigError(f"--topic {item}: unknown role {name!r} (roles: {roles})") from None
        if role in topics:
            raise ConfigError(f"--topic {role.value} given twice")
        topics[role] = topic.strip()
    if Role.ODOMETRY not in topics:
        raise ConfigError("--topic odometry=/topic is required (the motion between frames)")
    return topics


@dataclass(frozen=True, slots=True)
class TfFrames:
    """Which transforms of a ``tf2_msgs/TFMessage`` topic are the ground truth."""

    world: str = "world"
    robot: str = "base_link"


@dataclass(slots=True)
class _Streams:
    """What the bag's topics gave, in the order of their messages."""

    odometry: list[tuple[float, np.ndarray]] = field(default_factory=list)  # (stamp, [x, y, th])
    images: list[tuple[float, Any, str]] = field(default_factory=list)  # (stamp, message, where)
    scans: list[tuple[float, np.ndarray]] = field(default_factory=list)  # (stamp, ranges)
    scan_geometry: tuple[np.ndarray, float] | None = None  # (angles_rad, max_range_m)
    truth: list[tuple[float, np.ndarray, np.ndarray]] = field(default_factory=list)
    robot_frame: str = ""  # the first odometry message's child_frame_id
    scan_frame: str = ""  # the first scan's frame_id
    static: dict[tuple[str, str], np.ndarray] = field(default_factory=dict)  # (parent, child)


def _stamp_s(header: Any) -> float:
    """A header's stamp [s] (ROS 1 ``secs``/``nsecs`` and ROS 2 ``sec``/``nanosec`` alike)."""
    stamp = header.stamp
    return float(stamp.sec) + float(stamp.nanosec) * 1e-9


def _quaternion_wxyz(q: Any) -> np.ndarray:
    return np.array([q.w, q.x, q.y, q.z], dtype=float)


def _yaw(q: Any) -> float:
    """The heading of a quaternion [rad] (rotation about z of its ZYX Euler angles)."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def import_bag(
    bag: str | Path,
    out: str | Path,
    topics: Mapping[Role, str],
    *,
    calibration: str | Path | None = None,
    world_frame: str = "world",
    gt_frame: str = "base_link",
    source: str | None = None,
    licence: str = "unstated",
    groundtruth_kind: GroundTruthKind = GroundTruthKind.MOTION_CAPTURE,
    laser_offset_r: Sequence[float] | None = None,
) -> Path:
    """Convert a bag into an omnislam folder.

    Args:
        bag: a ROS 1 ``.bag`` file or a ROS 2 bag folder (sqlite3 or MCAP).
        out: the folder to write.
        topics: role -> topic (``parse_topics``).
        calibration: the camera rig YAML of the images (required with ``images``).
        world_frame: parent frame of the ground truth on a TF topic.
        gt_frame: child frame of the ground truth on a TF topic.
        source: one line saying where the data come from (default: the bag's name).
        licence: the data's licence.
        groundtruth_kind: where the ground-truth topic's poses come from, written as the
            folder's ``ground_truth.kind`` (default MOTION_CAPTURE, a Vicon or OptiTrack
            topic; NONE is refused: a ground-truth topic is some kind of truth).
        laser_offset_r: the scanner's [x, y, yaw] on the robot [m, m, rad], stated instead of
            read from ``/tf_static``.

    Returns:
        ``out``.

    Raises:
        MissingExtraError: ``rosbags`` is not installed (the ``rosbag`` extra).
        ConfigError: images without a calibration; ``groundtruth_kind`` NONE; a
            ``laser_offset_r`` that is not three finite numbers.
        DataError: an unreadable bag; a missing topic, a topic of a type its role cannot use,
            a message that cannot be decoded (naming the topic and the message); a scanner
            frame tilted out of the robot's plane.
    """
    from omnislam.datasets.folder import export_folder

    bag = Path(bag)
    if groundtruth_kind is GroundTruthKind.NONE:
        raise ConfigError("--groundtruth-kind none: a ground-truth topic is motion-capture, "
                          "gps-partial, pseudo, reference or exact")
    offset = _checked_offset(laser_offset_r)
    rig = None
    if Role.IMAGES in topics:
        if calibration is None:
            raise ConfigError("images need --calibration YAML (the omnislam rig of the camera)")
        from omnislam.camera.io import load_rig

        rig = load_rig(calibration)
    streams = read_bag(bag, topics, TfFrames(world_frame, gt_frame))
    if Role.SCAN in topics and offset is None:
        offset = laser_mount(streams, bag)
    sequence = _sequence(bag, streams, rig, source or f"ROS bag {bag.name}", groundtruth_kind,
                         offset)
    return export_folder(sequence, out, licence=licence)


def _checked_offset(laser_offset_r: Sequence[float] | None) -> np.ndarray | None:
    """A stated laser mounting as (3,) floats, or None."""
    if laser_offset_r is None:
        return None
    offset = np.asarray(laser_offset_r, dtype=float)
    if offset.shape != (3,) or not np.all(np.isfinite(offset)):
        raise ConfigError(f"--laser-offset needs three finite numbers X,Y,YAW [m, m, rad], got "
                          f"{list(laser_offset_r)}")
    return offset


def laser_mount(streams: _Streams, bag: Path) -> np.ndarray:
    """(3,) the scanner's [x, y, yaw] on the robot from the bag's static frames: the pose of
    the scans' frame in the odometry's child frame (zero when they are one frame, or, with a
    warning, when ``/tf_static`` does not join them).

    Raises:
        DataError: the scanner's frame is tilted out of the robot's plane.
    """
    robot = streams.robot_frame or DEFAULT_ROBOT_FRAME
    scanner = streams.scan_frame
    if not scanner or scanner == robot:
        return np.zeros(3)
    rTs = pose_in(streams.static, robot, scanner)
    if rTs is None:
        log.warning("%s: %s does not join the scans' frame %r to the robot's %r: the laser is "
                    "taken to be at the robot's origin (--laser-offset X,Y,YAW states it)",
                    bag, STATIC_TOPIC, scanner, robot)
        return np.zeros(3)
    try:
        return planar_mount(rTs, robot, scanner)
    except DataError as exc:
        raise DataError(str(exc), bag) from None


def read_bag(bag: Path, topics: Mapping[Role, str], tf: TfFrames) -> _Streams:
    """Every message of the topics asked for, decoded by role.

    Raises:
        DataError: as ``import_bag``.
    """
    from omnislam._optional import require
    from omnislam._progress import Progress

    highlevel = require("rosbags.highlevel")
    if not bag.exists():
        raise DataError("bag not found", bag)
    streams = _Streams()
    try:
        with highlevel.AnyReader([bag]) as reader:
            connections = _connections(reader, topics, bag)
            role_of = {c.topic: role for role, c in connections.items()}
            static = _static_connections(reader, topics)
            wanted = list(connections.values()) + static
            total = sum(c.msgcount for c in wanted)
            counts = dict.fromkeys([c.topic for c in wanted], 0)
            with Progress(f"import {bag.name}", total, "message") as progress:
                for connection, _, raw in reader.messages(connections=wanted):
                    topic = connection.topic
                    counts[topic] += 1
                    where = f"topic {topic}, message {counts[topic]}"
                    try:
                        message = reader.deserialize(raw, connection.msgtype)
                    except Exception as exc:  # a library error of any kind: a corrupt message
                        raise DataError(f"{where}: cannot decode {connection.msgtype} ({exc})",
                                        bag) from None
                    if topic in role_of:
                        _take(streams, role_of[topic], message, where, tf, bag)
                    else:
                        _take_static(streams, message, where, bag)
                    progress.advance()
    except highlevel.AnyReaderError as exc:
        raise DataError(f"cannot read the bag ({' '.join(str(exc).split())})", bag) from None
    _check_streams(streams, topics, tf, bag)
    return streams


def _connections(reader: Any, topics: Mapping[Role, str], bag: Path) -> dict[Role, Any]:
    """The bag's connection of each role's topic, checked for its message type."""
    found: dict[Role, Any] = {}
    present = sorted({c.topic for c in reader.connections})
    for role, topic in topics.items():
        matches = [c for c in reader.connections if c.topic == topic]
        if not matches:
            raise DataError(
                f"topic {topic} ({role.value}) is not in the bag (its topics: "
                f"{', '.join(present) or 'none'})", bag)
        connection = matches[0]
        if connection.msgtype not in ACCEPTED[role]:
            raise DataError(
                f"topic {topic}: message type {connection.msgtype} cannot be used as "
                f"{role.value} (expected {' or '.join(ACCEPTED[role])})", bag)
        found[role] = connection
    return found


def _static_connections(reader: Any, topics: Mapping[Role, str]) -> list[Any]:
    """The bag's ``/tf_static`` connections, when scans are asked for and no role takes it."""
    if Role.SCAN not in topics or STATIC_TOPIC in topics.values():
        return []
    return [c for c in reader.connections
            if c.topic == STATIC_TOPIC and c.msgtype == "tf2_msgs/msg/TFMessage"]


def _take_static(streams: _Streams, message: Any, where: str, bag: Path) -> None:
    """The static transforms of one ``/tf_static`` message (a later one replaces an edge)."""
    for transform in message.transforms:
        t = transform.transform
        try:
            pTc = static_edge(np.array([t.translation.x, t.translation.y, t.translation.z]),
                              _quaternion_wxyz(t.rotation))
        except ValueError as exc:
            raise DataError(f"{where}: {transform.child_frame_id!r}: {exc}", bag) from None
        key = (frame_name(transform.header.frame_id), frame_name(transform.child_frame_id))
        streams.static[key] = pTc


def _take(streams: _Streams, role: Role, message: Any, where: str, tf: TfFrames, bag: Path
          ) -> None:
    """Append one decoded message to its role's stream."""
    if role is Role.ODOMETRY:
        if not streams.odometry:
            streams.robot_frame = frame_name(message.child_frame_id)
        pose = message.pose.pose
        streams.odometry.append((_stamp_s(message.header),
                                 np.array([pose.position.x, pose.position.y,
                                           _yaw(pose.orientation)])))
    elif role is Role.IMAGES:
        streams.images.append((_stamp_s(message.header), message, where))
    elif role is Role.SCAN:
        _take_scan(streams, message, where, bag)
    else:
        _take_truth(streams, message, tf)


def _take_scan(streams: _Streams, scan: Any, where: str, bag: Path) -> None:
    """A LaserScan's ranges, "no return" as ``range_max``; its beams must be the first's."""
    ranges = np.asarray(scan.ranges, dtype=float)
    angles = scan.angle_min + scan.angle_increment * np.arange(len(ranges))
    geometry = (angles, float(scan.range_max))
    if streams.scan_geometry is None:
        if not len(ranges) or not scan.angle_increment > 0 or not scan.range_max > 0:
            raise DataError(f"{where}: a scan needs beams, a positive angle_increment and "
                            "range_max", bag)
        streams.scan_geometry = geometry
    elif len(angles) != len(streams.scan_geometry[0]) or not np.allclose(
            angles, streams.scan_geometry[0], atol=1e-9) or geometry[1] != streams.scan_geometry[1]:
        raise DataError(f"{where}: its beams or range_max differ from the first scan's", bag)
    if not streams.scans:
        streams.scan_frame = frame_name(scan.header.frame_id)
    none = ~np.isfinite(ranges) | (ranges < scan.range_min) | (ranges > scan.range_max)
    ranges[none] = scan.range_max
    streams.scans.append((_stamp_s(scan.header), ranges))


def _take_truth(streams: _Streams, message: Any, tf: TfFrames) -> None:
    """A ground-truth pose: a pose, an odometry's pose, or the TF transforms asked for."""
    if hasattr(message, "transforms"):
        for transform in message.transforms:
            if transform.header.frame_id.lstrip("/") == tf.world and \
                    transform.child_frame_id.lstrip("/") == tf.robot:
                _take_truth(streams, transform, tf)
        return
    if hasattr(message, "transform"):
        t = message.transform
        xyz, q = [t.translation.x, t.translation.y, t.translation.z], t.rotation
    else:
        pose = message.pose.pose if hasattr(message.pose, "pose") else message.pose
        xyz, q = [pose.position.x, pose.position.y, pose.position.z], pose.orientation
    streams.truth.append((_stamp_s(message.header), np.array(xyz), _quaternion_wxyz(q)))


def _check_streams(streams: _Streams, topics: Mapping[Role, str], tf: TfFrames, bag: Path
                   ) -> None:
    """Every role asked for gave messages; stamps of one topic increase."""
    given = {Role.ODOMETRY: streams.odometry, Role.IMAGES: streams.images,
             Role.SCAN: streams.scans, Role.GROUNDTRUTH: streams.truth}
    for role, topic in topics.items():
        if not given[role]:
            extra = (f" from {tf.world} to {tf.robot} (--world-frame, --gt-frame)"
                     if role is Role.GROUNDTRUTH else "")
            raise DataError(f"topic {topic} ({role.value}) has no usable message{extra}", bag)
        stamps = np.array([item[0] for item in given[role]])
        back = np.diff(stamps) <= 0
        if back.any():
            k = int(np.argmax(back)) + 2
            raise DataError(f"topic {topic}, message {k}: stamp {stamps[k - 1]!r} is not after "
                            f"the previous one ({stamps[k - 2]!r})", bag)


def _sequence(bag: Path, streams: _Streams, rig: Any, source: str,
              groundtruth_kind: GroundTruthKind, laser_offset_r: np.ndarray | None = None
              ) -> DataSequence:
    """The Sequence of the streams: frames at the odometry's and the sensors' stamps, the
    ground truth of kind ``groundtruth_kind``, the scanner at ``laser_offset_r`` on the robot
    (None: at its origin)."""
    odom_s = np.array([s for s, _ in streams.odometry])
    odom_poses = np.array([p for _, p in streams.odometry])
    sensor_s = np.array([s for s, _, _ in streams.images] + [s for s, _ in streams.scans])
    inside = (sensor_s >= odom_s[0]) & (sensor_s <= odom_s[-1])
    stamps = np.union1d(odom_s, sensor_s[inside])
    valid, poses = interpolate_se2(odom_s, odom_poses, stamps, MAX_ODOMETRY_GAP_S)
    if not valid.all():
        raise DataError(f"the odometry has a gap over {MAX_ODOMETRY_GAP_S:g} s at "
                        f"{float(stamps[int(np.argmin(valid))])!r} s", bag)
    odometry = odometry_from_poses(poses)
    laser = None
    if streams.scans:
        assert streams.scan_geometry is not None
        angles, max_range = streams.scan_geometry
        ranges = np.full((len(stamps), len(angles)), np.nan)
        for stamp, row in streams.scans:
            if odom_s[0] <= stamp <= odom_s[-1]:
                ranges[np.searchsorted(stamps, stamp)] = row
        offset = np.zeros(3) if laser_offset_r is None else laser_offset_r
        laser = LaserScans(angles, ranges, max_range, offset_r=offset)
    images = {int(np.searchsorted(stamps, s)): (m, where) for s, m, where in streams.images
              if odom_s[0] <= s <= odom_s[-1]}
    truth, initial = _ground_truth(streams, stamps, groundtruth_kind)
    return DataSequence(
        name=bag.stem,
        source=source,
        stamps_s=stamps,
        odometry_r=odometry,
        ground_truth=truth,
        initial_pose_w=initial,
        laser=laser,
        image_loader=(lambda i: _decode(*images[i], bag)) if images else None,
        image_frames=np.array(sorted(images), dtype=np.int64),
        calibration=rig,
        info={"bag": bag.name, "frames": str(len(stamps)), "images": str(len(images))},
    )


def _ground_truth(streams: _Streams, stamps: np.ndarray, kind: GroundTruthKind
                  ) -> tuple[GroundTruth, np.ndarray | None]:
    """The ground truth trajectory (of ``kind``) and the pose of the first frame in its world
    (when the truth brackets it)."""
    if not streams.truth:
        return GroundTruth(), None
    truth_s = np.array([s for s, _, _ in streams.truth])
    xyz = np.array([p for _, p, _ in streams.truth])
    quats = np.array([q for _, _, q in streams.truth])
    quats /= np.linalg.norm(quats, axis=1, keepdims=True)
    trajectory = Trajectory(truth_s, se3_from_xyz_quat(xyz, quats))
    valid, first = interpolate_se2(truth_s, se2_from_se3(trajectory.poses_w), stamps[:1],
                                   MAX_GROUND_TRUTH_GAP_S)
    truth = GroundTruth(kind, trajectory,
                        note="ground truth from the bag's ground-truth topic")
    return truth, first[0] if valid[0] else None


def _decode(message: Any, where: str, bag: Path) -> np.ndarray:
    """(H, W, 3) uint8 RGB of an Image or CompressedImage message.

    Raises:
        DataError: naming the topic and the message: bytes that do not decode, an encoding
            other than rgb8, bgr8 and mono8, a size that does not match the data.
    """
    from omnislam._optional import require

    cv2 = require("cv2")
    if hasattr(message, "format"):  # CompressedImage
        data = np.frombuffer(bytes(message.data), np.uint8)
        bgr = cv2.imdecode(data, cv2.IMREAD_COLOR) if data.size else None
        if bgr is None:
            raise DataError(f"{where}: the {message.format!r} image cannot be decoded", bag)
        return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
    data = np.frombuffer(bytes(message.data), np.uint8)
    channels = {"rgb8": 3, "bgr8": 3, "mono8": 1}.get(message.encoding)
    if channels is None:
        raise DataError(f"{where}: image encoding {message.encoding!r} is not rgb8, bgr8 or "
                        "mono8", bag)
    if data.size != message.height * message.step or message.step < message.width * channels:
        raise DataError(f"{where}: {data.size} bytes for a {message.width}x{message.height} "
                        f"image of step {message.step}", bag)
    image = data.reshape(message.height, message.step)[:, : message.width * channels]
    image = image.reshape(message.height, message.width, channels)
    if message.encoding == "mono8":
        return np.repeat(image, 3, axis=2)
    return image[..., ::-1].copy() if message.encoding == "bgr8" else image.copy()
