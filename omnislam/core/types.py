"""Frozen record types that travel between modules (docs/design.md, "Data flow and contracts").

Arrays are converted once, validated, and made read-only, so a record cannot be changed by
whoever receives it. Frames and units are in the names: ``wTr`` is the robot in the world,
``*_r`` vectors are in the robot frame, ``*_w`` in the world frame.
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from omnislam.core.se import se2_from_se3, se3_from_se2
from omnislam.errors import DataError


def _frozen(array: object, dtype: type, shape: tuple[int | None, ...], name: str) -> np.ndarray:
    """Return ``array`` as a read-only ndarray of ``dtype``; None in ``shape`` matches any size."""
    out = np.array(array, dtype=dtype, copy=True)
    if out.ndim != len(shape) or any(
        want is not None and got != want for got, want in zip(out.shape, shape, strict=True)
    ):
        raise DataError(f"{name} must have shape {shape}, got {out.shape}")
    if out.dtype.kind == "f" and not np.all(np.isfinite(out)):
        raise DataError(f"{name} contains NaN or infinite values")
    out.setflags(write=False)
    return out


def _set(obj: object, name: str, value: object) -> None:
    object.__setattr__(obj, name, value)


class OdometrySource(enum.StrEnum):
    """Where a run's odometry comes from.

    WHEEL: the dataset's own (wheel encoders or commanded velocities), with the loader's stated
        covariance where it gives one (a nominal formula of the step).
    LASER: the front end's scan matching (``frontend.scan_matching``), with a covariance measured
        per step from the scan's geometry; it replaces the wheels' for the SLAM estimators.
    """

    WHEEL = "wheel"
    LASER = "laser"


@dataclass(frozen=True, slots=True)
class Odometry:
    """Robot-frame motion since the previous frame.

    Attributes:
        delta: (3,) [dx, dy, dtheta] of the new pose expressed in the previous pose's frame
            [m, m, rad], i.e. ``rTr' = se2_between(wTr, wTr')``.
        stamp_s: time of the new pose [s].
        covariance: (3, 3) covariance of ``delta`` when the data states one (e.g. the factors
            of gtsam's victoria_park.txt), else None: estimators then use their motion model.
    """

    delta: np.ndarray
    stamp_s: float
    covariance: np.ndarray | None = None

    def __post_init__(self) -> None:
        _set(self, "delta", _frozen(self.delta, float, (3,), "Odometry.delta"))
        _set(self, "stamp_s", float(self.stamp_s))
        if self.covariance is not None:
            cov = _frozen(self.covariance, float, (3, 3), "Odometry.covariance")
            if not np.allclose(cov, cov.T) or np.any(np.linalg.eigvalsh(cov) <= 0):
                raise DataError("Odometry.covariance must be symmetric positive definite")
            _set(self, "covariance", cov)


@dataclass(frozen=True, slots=True)
class Bearings:
    """What the omni front end saw in one frame.

    Attributes:
        landmark_ids: (K,) track ids, stable across frames.
        unit_vectors_r: (K, 3) unit bearing vectors in the robot frame (x forward, z up),
            from the sensor's single viewpoint.
        sigmas_rad: (K,) angular standard deviation of each bearing (larger towards the rim).
    """

    landmark_ids: np.ndarray
    unit_vectors_r: np.ndarray
    sigmas_rad: np.ndarray

    def __post_init__(self) -> None:
        ids = _frozen(self.landmark_ids, np.int64, (None,), "Bearings.landmark_ids")
        k = ids.shape[0]
        vectors = _frozen(self.unit_vectors_r, float, (k, 3), "Bearings.unit_vectors_r")
        if k and not np.allclose(np.linalg.norm(vectors, axis=1), 1.0, atol=1e-6):
            raise DataError("Bearings.unit_vectors_r must have unit norm")
        sigmas = _frozen(self.sigmas_rad, float, (k,), "Bearings.sigmas_rad")
        if np.any(sigmas <= 0):
            raise DataError("Bearings.sigmas_rad must be positive")
        _set(self, "landmark_ids", ids)
        _set(self, "unit_vectors_r", vectors)
        _set(self, "sigmas_rad", sigmas)

    def __len__(self) -> int:
        return int(self.landmark_ids.shape[0])


#: landmark id of a sighting whose association is unknown
UNKNOWN_ID = -1


@dataclass(frozen=True, slots=True)
class RangeBearing:
    """2-D range-bearing sightings of one frame (laser landmarks, MR.CLAM, Victoria Park).

    Attributes:
        landmark_ids: (K,) landmark ids, ``UNKNOWN_ID`` (-1) where the association is unknown.
        ranges_m: (K,) ranges from the sensor [m].
        bearings_rad: (K,) bearings in the robot frame, counter-clockwise from the heading.
        sigma_range_m: (K,) range standard deviations [m].
        sigma_bearing_rad: (K,) bearing standard deviations [rad].
    """

    landmark_ids: np.ndarray
    ranges_m: np.ndarray
    bearings_rad: np.ndarray
    sigma_range_m: np.ndarray
    sigma_bearing_rad: np.ndarray

    def __post_init__(self) -> None:
        ids = _frozen(self.landmark_ids, np.int64, (None,), "RangeBearing.landmark_ids")
        k = ids.shape[0]
        _set(self, "landmark_ids", ids)
        for name in ("ranges_m", "bearings_rad", "sigma_range_m", "sigma_bearing_rad"):
            value = np.broadcast_to(np.asarray(getattr(self, name), dtype=float), (k,))
            _set(self, name, _frozen(value, float, (k,), f"RangeBearing.{name}"))
        if np.any(self.ranges_m < 0):
            raise DataError("RangeBearing.ranges_m must be non-negative")
        if np.any(self.sigma_range_m <= 0) or np.any(self.sigma_bearing_rad <= 0):
            raise DataError("RangeBearing sigmas must be positive")

    def __len__(self) -> int:
        return int(self.landmark_ids.shape[0])


@dataclass(frozen=True, slots=True)
class VerticalLines:
    """Vertical-line projections of one frame with their photometric features (Barra & Costa).

    Attributes:
        bearings_rad: (K,) azimuth of each line in the robot frame [rad].
        sigma_bearing_rad: (K,) bearing standard deviations [rad].
        profiles: (K, 3, W) mean colour profile (PMC) per band across W = 2n+1 columns.
        means_left: (K, 3) mean colour per band left of the line (MC).
        means_right: (K, 3) mean colour per band right of the line (MC).
        landmark_ids: (K,) ids when known (ground truth / validated), else ``UNKNOWN_ID``.
    """

    bearings_rad: np.ndarray
    sigma_bearing_rad: np.ndarray
    profiles: np.ndarray
    means_left: np.ndarray
    means_right: np.ndarray
    landmark_ids: np.ndarray

    def __post_init__(self) -> None:
        bearings = _frozen(self.bearings_rad, float, (None,), "VerticalLines.bearings_rad")
        k = bearings.shape[0]
        _set(self, "bearings_rad", bearings)
        sig = np.broadcast_to(np.asarray(self.sigma_bearing_rad, dtype=float), (k,))
        _set(self, "sigma_bearing_rad", _frozen(sig, float, (k,), "VerticalLines.sigma"))
        _set(
            self, "profiles", _frozen(self.profiles, float, (k, 3, None), "VerticalLines.profiles")
        )
        _set(
            self, "means_left", _frozen(self.means_left, float, (k, 3), "VerticalLines.means_left")
        )
        _set(
            self,
            "means_right",
            _frozen(self.means_right, float, (k, 3), "VerticalLines.means_right"),
        )
        _set(self, "landmark_ids", _frozen(self.landmark_ids, np.int64, (k,), "VerticalLines.ids"))

    def __len__(self) -> int:
        return int(self.bearings_rad.shape[0])


@dataclass(frozen=True, slots=True)
class FrameInput:
    """One step of an ObservationLog: the odometry since the previous frame and what was seen.

    A frame without sensor data (asynchronous front end) only predicts.
    """

    index: int
    odometry: Odometry
    bearings: Bearings | None = None
    range_bearing: RangeBearing | None = None
    vertical_lines: VerticalLines | None = None

    @property
    def stamp_s(self) -> float:
        return self.odometry.stamp_s


@dataclass(frozen=True, slots=True)
class Trajectory:
    """Time-stamped poses ``wTr`` of the robot in the world.

    Attributes:
        stamps_s: (N,) strictly increasing times [s].
        poses_w: (N, 4, 4) homogeneous SE(3) transforms robot -> world; planar runs have z = 0.
    """

    stamps_s: np.ndarray
    poses_w: np.ndarray

    def __post_init__(self) -> None:
        stamps = _frozen(self.stamps_s, float, (None,), "Trajectory.stamps_s")
        n = stamps.shape[0]
        if n > 1 and np.any(np.diff(stamps) <= 0):
            raise DataError("Trajectory.stamps_s must be strictly increasing")
        poses = _frozen(self.poses_w, float, (n, 4, 4), "Trajectory.poses_w")
        rotations = poses[:, :3, :3]
        if n and not np.allclose(rotations @ np.swapaxes(rotations, 1, 2), np.eye(3), atol=1e-6):
            raise DataError("Trajectory.poses_w rotations must be orthonormal")
        _set(self, "stamps_s", stamps)
        _set(self, "poses_w", poses)

    @classmethod
    def from_se2(cls, stamps_s: np.ndarray, poses_xyt: np.ndarray) -> Trajectory:
        """Build from planar poses (N, 3) [x, y, theta] (z = 0)."""
        poses_xyt = np.asarray(poses_xyt, dtype=float).reshape(-1, 3)
        return cls(stamps_s, se3_from_se2(poses_xyt))

    @property
    def positions_w(self) -> np.ndarray:
        """(N, 3) positions [m]."""
        return self.poses_w[:, :3, 3]

    @property
    def se2(self) -> np.ndarray:
        """(N, 3) planar poses [x, y, yaw] (the projection of each pose onto the ground plane)."""
        return se2_from_se3(self.poses_w)

    def __len__(self) -> int:
        return int(self.stamps_s.shape[0])


@dataclass(frozen=True, slots=True)
class Estimate:
    """What an estimator believes now: the path so far, the landmark map, covariances if known.

    Attributes:
        trajectory: one pose per processed frame.
        landmark_ids: (M,) ids of the mapped landmarks.
        landmarks_w: (M, 3) landmark positions in the world [m] (z = 0 for 2-D maps).
        landmark_covariances: (M, 3, 3) position covariances [m^2] or None.
        pose_covariances: (N, 3, 3) covariances of [x, y, yaw] per pose, or None.
    """

    trajectory: Trajectory
    landmark_ids: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    landmarks_w: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    landmark_covariances: np.ndarray | None = None
    pose_covariances: np.ndarray | None = None

    def __post_init__(self) -> None:
        ids = _frozen(self.landmark_ids, np.int64, (None,), "Estimate.landmark_ids")
        m = ids.shape[0]
        if len(np.unique(ids)) != m:
            raise DataError("Estimate.landmark_ids must be unique")
        _set(self, "landmark_ids", ids)
        _set(self, "landmarks_w", _frozen(self.landmarks_w, float, (m, 3), "Estimate.landmarks_w"))
        if self.landmark_covariances is not None:
            _set(
                self,
                "landmark_covariances",
                _frozen(self.landmark_covariances, float, (m, 3, 3), "Estimate.landmark_cov"),
            )
        if self.pose_covariances is not None:
            n = len(self.trajectory)
            _set(
                self,
                "pose_covariances",
                _frozen(self.pose_covariances, float, (n, 3, 3), "Estimate.pose_covariances"),
            )


@runtime_checkable
class Estimator(Protocol):
    """The one protocol every back end implements; the harness calls nothing else."""

    name: str

    def step(self, frame: FrameInput) -> None:
        """Consume one frame (predict with its odometry, update with what it saw)."""
        ...

    def estimate(self) -> Estimate:
        """The estimate after the frames consumed so far."""
        ...


@runtime_checkable
class Introspectable(Protocol):
    """Optional: an estimator that counts what it did (fallbacks, gated sightings, ...).

    ``info()`` returns a frozen dataclass of plain values (numbers, strings, enums); the harness
    stores it in the RUN_DIR as ``estimator_info.json``.
    """

    def info(self) -> object:
        """The counts so far, as a frozen dataclass."""
        ...


@runtime_checkable
class Exporting(Protocol):
    """Optional: an estimator that exports files of its own (``graph.g2o`` of a factor graph).

    ``attachments()`` maps a RUN_DIR file name to its bytes; the harness writes them into the
    RUN_DIR with the estimate, atomically, and reports link them.
    """

    def attachments(self) -> Mapping[str, bytes]:
        """File name -> content, after the last frame."""
        ...


@dataclass(frozen=True, slots=True)
class PriorMap:
    """A map known before the run: what a localiser (the vertical-line UKF) localises against.

    SLAM estimators ignore it. Landmarks are points in the world frame; vertical lines are
    points on the floor plane (z = 0) whose line is vertical, optionally with the photometric
    descriptors of Barra & Costa (mean colour left and right of the line, MC); walls are the
    2-D segments that decide occlusion.

    Attributes:
        source: where it comes from, one line (e.g. "surveyed landmarks (MR.CLAM)").
        landmark_ids: (M,) ids, matching the ids of the sightings when the data have ids.
        points_w: (M, 3) positions in the world frame [m] (z = 0 for 2-D maps).
        vertical_line: (M,) True where the landmark is a vertical line.
        means_left, means_right: (M, 3) mean colour per band left/right of each vertical line
            (NaN rows where unknown), or None when the map has no descriptors.
        walls_w: (W, 2, 2) wall segments [[x0, y0], [x1, y1]] in the world frame [m].
        initial_pose_w: (3,) pose [x, y, theta] of the run's first frame in the map's frame,
            when known (a localiser starts there), else None.
    """

    source: str
    landmark_ids: np.ndarray
    points_w: np.ndarray
    vertical_line: np.ndarray | None = None
    means_left: np.ndarray | None = None
    means_right: np.ndarray | None = None
    walls_w: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 2)))
    initial_pose_w: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.initial_pose_w is not None:
            pose = _frozen(self.initial_pose_w, float, (3,), "PriorMap.initial_pose_w")
            _set(self, "initial_pose_w", pose)
        ids = _frozen(self.landmark_ids, np.int64, (None,), "PriorMap.landmark_ids")
        m = ids.shape[0]
        if np.unique(ids).size != m:
            raise DataError("PriorMap.landmark_ids must be unique")
        _set(self, "landmark_ids", ids)
        _set(self, "points_w", _frozen(self.points_w, float, (m, 3), "PriorMap.points_w"))
        lines = np.zeros(m, dtype=bool) if self.vertical_line is None else self.vertical_line
        _set(self, "vertical_line", _frozen(lines, bool, (m,), "PriorMap.vertical_line"))
        if (self.means_left is None) != (self.means_right is None):
            raise DataError("PriorMap: give both means_left and means_right, or neither")
        if self.means_left is not None:
            for name in ("means_left", "means_right"):
                values = np.array(getattr(self, name), dtype=float)
                if values.shape != (m, 3) or np.isinf(values).any():
                    raise DataError(f"PriorMap.{name} must be ({m}, 3) without infinities")
                values.setflags(write=False)
                _set(self, name, values)
        _set(self, "walls_w", _frozen(self.walls_w, float, (None, 2, 2), "PriorMap.walls_w"))

    def __len__(self) -> int:
        return int(self.landmark_ids.shape[0])
