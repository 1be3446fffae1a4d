"""Trajectory files: TUM and KITTI, as ``read_*`` / ``write_*`` pairs.

* TUM RGB-D format: one pose per line, ``stamp tx ty tz qx qy qz qw`` (Hamilton quaternion,
  scalar last), ``#`` comments; the pose maps the robot frame into the world frame.
* KITTI odometry format: one pose per line, the 12 entries of the upper 3x4 block of ``wTr``
  in row-major order, no stamps (stamps are taken as the line index unless given).

Writers write to a temporary file next to the target and rename it, so a failure never leaves a
half-written file. Readers raise ``DataError`` naming the file and the line.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np

from omnislam._files import atomic_write_text
from omnislam.core.se import quat_wxyz_from_se3, se3_from_xyz_quat
from omnislam.core.types import Trajectory
from omnislam.errors import DataError

#: digits written for stamps and values (round trips exactly at double precision)
_FORMAT = "%.17g"
#: largest position coordinate read [m]: beyond any place on Earth in UTM or ECEF coordinates
#: (within 1e7 m) by a factor of ten; a corrupt 1e306 is not a position (its squares overflow
#: in the alignment's SVD)
MAX_COORDINATE_M = 1.0e8


def _numeric_rows(path: Path, columns: int) -> Iterator[tuple[str, np.ndarray]]:
    """Yield (where, values) for each non-comment line, checking count and numbers.

    ``where`` is ``"line N"`` for messages; on a last line without its line break (a file cut
    mid-line, whose last number may be cut short too) it says so.

    Raises:
        DataError: unreadable file, wrong column count, non-numeric or non-finite value.
    """
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) else "not a text file"
        raise DataError(f"cannot read file ({reason})", path) from exc
    lines = text.splitlines()
    for number, line in enumerate(lines, start=1):
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            continue
        where = f"line {number}"
        if number == len(lines) and not text.endswith("\n"):
            where += " (the last, without a line break: file truncated?)"
        fields = stripped.replace(",", " ").split()
        if len(fields) != columns:
            raise DataError(f"{where}: expected {columns} values, found {len(fields)}", path)
        try:
            values = np.array([float(f) for f in fields])
        except ValueError as exc:
            raise DataError(f"{where}: not a number ({exc})", path) from exc
        if not np.all(np.isfinite(values)):
            raise DataError(f"{where}: NaN or infinite value", path)
        yield where, values


def _check_position(where: str, xyz: np.ndarray, path: Path) -> None:
    """Raise DataError when a coordinate of ``xyz`` (3,) is beyond ``MAX_COORDINATE_M``."""
    if not np.all(np.abs(xyz) <= MAX_COORDINATE_M):
        raise DataError(f"{where}: position {xyz.tolist()} is beyond {MAX_COORDINATE_M:g} m", path)


def read_tum(path: str | Path) -> Trajectory:
    """Read a TUM trajectory file.

    Raises:
        DataError: unreadable file, wrong column count, non-numeric value, a position beyond
            ``MAX_COORDINATE_M``, a quaternion far from unit norm, or stamps that are not
            strictly increasing (file and line named).
    """
    path = Path(path)
    stamps, xyz, quats = [], [], []
    for where, values in _numeric_rows(path, 8):
        q_xyzw = values[4:8]
        norm = np.linalg.norm(q_xyzw)
        if abs(norm - 1.0) > 1e-3:
            raise DataError(f"{where}: quaternion norm {norm:.6g} is not 1", path)
        if stamps and values[0] <= stamps[-1]:
            raise DataError(
                f"{where}: stamp {float(values[0])!r} is not after the previous one "
                f"({float(stamps[-1])!r})",
                path,
            )
        _check_position(where, values[1:4], path)
        stamps.append(values[0])
        xyz.append(values[1:4])
        quats.append(np.r_[q_xyzw[3], q_xyzw[:3]] / norm)
    if not stamps:
        raise DataError("no poses in file", path)
    return Trajectory(np.array(stamps), se3_from_xyz_quat(np.array(xyz), np.array(quats)))


def write_tum(path: str | Path, trajectory: Trajectory) -> None:
    """Write a trajectory as a TUM file (atomically)."""
    q_wxyz = quat_wxyz_from_se3(trajectory.poses_w)
    rows = np.column_stack(
        [trajectory.stamps_s, trajectory.positions_w, q_wxyz[:, 1:4], q_wxyz[:, 0]]
    )
    lines = ["# timestamp tx ty tz qx qy qz qw"]
    lines += [" ".join(_FORMAT % v for v in row) for row in rows]
    atomic_write_text(Path(path), "\n".join(lines) + "\n")


def read_kitti(path: str | Path, stamps_s: np.ndarray | None = None) -> Trajectory:
    """Read a KITTI pose file; ``stamps_s`` (N,) default to 0, 1, 2, ...

    Raises:
        DataError: as ``read_tum``, or a rotation block that is not orthonormal.
    """
    path = Path(path)
    poses = []
    for where, values in _numeric_rows(path, 12):
        pose = np.eye(4)
        pose[:3, :4] = values.reshape(3, 4)
        _check_position(where, pose[:3, 3], path)
        R = pose[:3, :3]
        if not np.allclose(R @ R.T, np.eye(3), atol=1e-5) or np.linalg.det(R) < 0:
            raise DataError(f"{where}: rotation block is not a rotation", path)
        # re-orthonormalise the printed rotation so that Trajectory's check holds exactly
        u, _, vt = np.linalg.svd(R)
        pose[:3, :3] = u @ vt
        poses.append(pose)
    if not poses:
        raise DataError("no poses in file", path)
    if stamps_s is None:
        stamps_s = np.arange(len(poses), dtype=float)
    elif len(stamps_s) != len(poses):
        raise DataError(f"{len(poses)} poses but {len(stamps_s)} stamps given", path)
    return Trajectory(np.asarray(stamps_s, dtype=float), np.array(poses))


def write_kitti(path: str | Path, trajectory: Trajectory) -> None:
    """Write a trajectory as a KITTI pose file (atomically; stamps are not stored)."""
    rows = trajectory.poses_w[:, :3, :4].reshape(-1, 12)
    atomic_write_text(
        Path(path), "".join(" ".join(_FORMAT % v for v in row) + "\n" for row in rows)
    )


#: trajectory file formats ``read_trajectory`` knows, by their number of values per line
TRAJECTORY_FORMATS = {"tum": 8, "kitti": 12}


def detect_trajectory_format(path: str | Path) -> str:
    """``"tum"`` (8 values a line) or ``"kitti"`` (12), from the file's first pose line.

    Raises:
        DataError: unreadable, empty, or a first line with another number of values.
    """
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise DataError(f"cannot read file ({exc.strerror})", path) from exc
    for number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            continue
        count = len(stripped.replace(",", " ").split())
        for name, columns in TRAJECTORY_FORMATS.items():
            if count == columns:
                return name
        raise DataError(
            f"line {number}: {count} values; a TUM line has 8 (stamp x y z qx qy qz qw), "
            "a KITTI line 12 (the 3x4 pose, row-major)",
            path,
        )
    raise DataError("no poses in file", path)


def read_trajectory(path: str | Path, fmt: str | None = None) -> Trajectory:
    """Read a TUM or KITTI file (``fmt`` None: ``detect_trajectory_format``).

    Raises:
        DataError: as ``read_tum`` / ``read_kitti``, or an unknown format.
    """
    fmt = detect_trajectory_format(path) if fmt is None else fmt
    if fmt == "tum":
        return read_tum(path)
    if fmt == "kitti":
        return read_kitti(path)
    raise DataError(f"unknown trajectory format {fmt!r}; known: tum, kitti", Path(path))
