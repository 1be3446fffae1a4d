"""A robot's static frames (ROS ``/tf_static``): the pose of one frame in another, composed along
the tree, and a planar sensor's mounting [x, y, yaw] from it.

A static transform message gives ``pTc``, the pose of a child frame in its parent (translation
and unit quaternion). The tree is walked in either direction (an edge read backwards is the
inverse pose), so the laser's frame is found from the robot's whichever of the two is nearer the
root (``base_link -> base_laser`` or ``base_footprint -> base_link -> laser``).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping

import numpy as np

from omnislam.core.se import se3_from_xyz_quat, se3_inverse
from omnislam.errors import DataError

#: how far a planar sensor's z axis may tilt from the robot's and still scan the robot's plane
MAX_TILT_RAD = math.radians(5.0)


def frame_name(name: str) -> str:
    """A frame's name as tf2 compares them (ROS 1 names may carry a leading slash)."""
    return name.lstrip("/")


def static_edge(translation_xyz: np.ndarray, quaternion_wxyz: np.ndarray) -> np.ndarray:
    """(4, 4) ``pTc`` of one static transform (the quaternion normalised)."""
    q = np.asarray(quaternion_wxyz, dtype=float)
    norm = float(np.linalg.norm(q))
    if not math.isfinite(norm) or norm < 1e-9:
        raise ValueError(f"not a rotation: quaternion {q.tolist()}")
    pose = se3_from_xyz_quat(np.asarray(translation_xyz, dtype=float)[None], (q / norm)[None])
    return pose[0]


def pose_in(edges: Mapping[tuple[str, str], np.ndarray], frame: str, of: str
            ) -> np.ndarray | None:
    """(4, 4) ``fTo``: the pose of frame ``of`` in frame ``frame``, composed along the tree of
    ``edges`` ((parent, child) -> pTc), or None when no chain of edges joins them.

    Args:
        edges: the static transforms, names as ``frame_name`` gives them.
        frame: the frame the pose is expressed in (e.g. the robot's base).
        of: the frame whose pose is asked for (e.g. the laser's).
    """
    frame, of = frame_name(frame), frame_name(of)
    neighbours: dict[str, list[tuple[str, np.ndarray]]] = {}
    for (parent, child), pTc in edges.items():
        neighbours.setdefault(parent, []).append((child, pTc))
        neighbours.setdefault(child, []).append((parent, se3_inverse(pTc)))
    reached = {frame: np.eye(4)}
    queue = deque([frame])
    while queue:  # breadth first: the shortest chain (a tree has one)
        name = queue.popleft()
        if name == of:
            return reached[name]
        for other, step in neighbours.get(name, ()):
            if other not in reached:
                reached[other] = reached[name] @ step
                queue.append(other)
    return None


def planar_mount(rTs: np.ndarray, robot: str, sensor: str) -> np.ndarray:
    """(3,) [x, y, yaw] of a sensor scanning the robot's plane, from its pose ``rTs`` (4, 4).

    The height is dropped (a planar scan does not depend on it); the sensor's z axis must be
    within ``MAX_TILT_RAD`` of the robot's, since a tilted or upside-down scanner's beams do not
    lie in the robot's plane at the angles its scan states.

    Raises:
        DataError: the sensor's frame is tilted (naming both frames and the angle).
    """
    R = np.asarray(rTs, dtype=float)[:3, :3]
    tilt = math.acos(max(-1.0, min(1.0, float(R[2, 2]))))
    if tilt > MAX_TILT_RAD:
        raise DataError(
            f"/tf_static: frame {sensor!r} is tilted {math.degrees(tilt):.1f} deg against "
            f"{robot!r} (at most {math.degrees(MAX_TILT_RAD):g}): its scans are not in the "
            "robot's plane; give the mounting with --laser-offset X,Y,YAW if they are")
    return np.array([rTs[0, 3], rTs[1, 3], math.atan2(R[1, 0], R[0, 0])])
