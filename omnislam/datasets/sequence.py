"""The Sequence: one recorded or rendered run, as every loader returns it.

A Sequence holds what the sensors gave (odometry, range-bearing sightings, bearing-only
sightings, laser scans, images read on demand) and the ground truth, aligned to one list of
frame stamps. It never estimates. ``frame_input(i, ...)`` is the one builder of the FrameInput
records estimators consume: the loaders' direct sightings, and the front end's bearings,
vertical lines and laser landmarks on top (``frame_inputs(observations)`` replays a front-end
log with the sequence's own odometry; a frame the log gives no bearings keeps the loader's).
A sequence may carry a ``PriorMap`` (surveyed landmarks, a synthetic world's line map) for
localisers.
"""

from __future__ import annotations

import enum
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from omnislam.core.se import se2_compose
from omnislam.core.sensor_mount import is_at_origin
from omnislam.core.types import (
    Bearings,
    FrameInput,
    Odometry,
    PriorMap,
    RangeBearing,
    Trajectory,
    VerticalLines,
    _frozen,
)
from omnislam.errors import DataError


class GroundTruthKind(enum.Enum):
    """Where a sequence's ground truth comes from (reports say it next to every number)."""

    EXACT = "exact"  # synthetic: the renderer's own poses and points
    MOTION_CAPTURE = "motion-capture"  # Vicon (MR.CLAM)
    GPS_PARTIAL = "gps-partial"  # GPS with gaps (Victoria Park): compare only where it exists
    PSEUDO = "pseudo"  # poses corrected by another SLAM system (CARMEN): not independent
    REFERENCE = "reference"  # a reference solution computed by omnislam (gtsam's file)
    NONE = "none"


@dataclass(frozen=True, slots=True)
class GroundTruth:
    """True poses (possibly at a subset of the frame stamps) and true landmark positions.

    Attributes:
        kind: where it comes from.
        trajectory: true poses; its stamps are a subset of the sequence's stamps (GPS gaps),
            or None.
        landmark_ids: (M,) ids matching the ids in the sightings (when the data has ids).
        landmarks_w: (M, 3) landmark positions [m] (z = 0 for 2-D maps).
        note: one sentence a report prints with the numbers (e.g. "pseudo ground truth ...").
    """

    kind: GroundTruthKind = GroundTruthKind.NONE
    trajectory: Trajectory | None = None
    landmark_ids: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    landmarks_w: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    note: str = ""

    def __post_init__(self) -> None:
        ids = _frozen(self.landmark_ids, np.int64, (None,), "GroundTruth.landmark_ids")
        object.__setattr__(self, "landmark_ids", ids)
        object.__setattr__(
            self,
            "landmarks_w",
            _frozen(self.landmarks_w, float, (ids.shape[0], 3), "GroundTruth.landmarks_w"),
        )


class LaserRole(enum.Enum):
    """What a sequence's laser scans are for."""

    SENSOR = "sensor"  # the front end may register them (laser odometry) and extract landmarks
    # the occupancy grid of reports only, never the estimators: the thesis's lower laser
    # ("nao influencia de forma alguma no SLAM", Guizilini 2008 sec. 5.1.1)
    OCCUPANCY = "occupancy"


@dataclass(frozen=True, slots=True)
class LaserScans:
    """Planar laser scans, one row per frame (NaN where a frame has no scan).

    Attributes:
        angles_rad: (B,) beam angles in the scanner frame, counter-clockwise from its heading.
        ranges_m: (N, B) ranges from the scanner; values >= max_range_m mean "no return".
        max_range_m: the sensor's maximum range.
        role: SENSOR (the default) or OCCUPANCY (for the occupancy grid only: the front end
            neither registers nor extracts landmarks from them).
        offset_r: (3,) the scanner's pose [x, y, yaw] in the robot frame [m, m, rad]; default
            zero (the scanner frame is the robot frame). A SICK on a Pioneer sits 0.1-0.3 m
            ahead of the axle: every consumer of the scans moves them by it
            (``omnislam.core.sensor_mount``).
    """

    angles_rad: np.ndarray
    ranges_m: np.ndarray
    max_range_m: float
    role: LaserRole = LaserRole.SENSOR
    offset_r: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        angles = _frozen(self.angles_rad, float, (None,), "LaserScans.angles_rad")
        ranges = np.array(self.ranges_m, dtype=float)
        if ranges.ndim != 2 or ranges.shape[1] != angles.shape[0]:
            raise DataError(
                f"LaserScans.ranges_m must be (N, {angles.shape[0]}), got {ranges.shape}"
            )
        ranges.setflags(write=False)
        object.__setattr__(self, "angles_rad", angles)
        object.__setattr__(self, "ranges_m", ranges)
        object.__setattr__(self, "max_range_m", float(self.max_range_m))
        object.__setattr__(self, "offset_r", _frozen(self.offset_r, float, (3,),
                                                     "LaserScans.offset_r"))

    def scanner_poses_w(self, wTr: np.ndarray) -> np.ndarray:
        """(..., 3) the scanner's poses wTs = wTr (+) offset_r of robot poses ``wTr``
        (..., 3) ([x, y, yaw]; ``wTr`` itself when the offset is zero)."""
        if is_at_origin(self.offset_r):
            return wTr
        return se2_compose(wTr, self.offset_r)

    @property
    def senses(self) -> bool:
        """The front end may register these scans and extract landmarks from them (role
        SENSOR); False for scans kept for the occupancy grid only."""
        return self.role is LaserRole.SENSOR


@dataclass(frozen=True, slots=True)
class BearingSightings:
    """A bearing-only sensor's sightings (a camera's landmark bearings, with or without their
    elevation), one record per frame: the estimators take them as the omni front end's
    bearings (``Modality.BEARINGS_3D``).

    Attributes:
        frames: per frame, the bearings (unit vectors in the robot frame from the sensor's
            viewpoint, landmark ids or ``UNKNOWN_ID``, angular sigmas), None where a frame has
            none.
        sensor_height_m: height of the sensor's viewpoint above the robot frame's origin [m]
            (the bearing estimators triangulate from there, as from a camera rig's viewpoint);
            default 0.
    """

    frames: tuple[Bearings | None, ...]
    sensor_height_m: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "frames", tuple(self.frames))
        object.__setattr__(self, "sensor_height_m", float(self.sensor_height_m))
        if not np.isfinite(self.sensor_height_m):
            raise DataError("BearingSightings.sensor_height_m must be finite")

    def __len__(self) -> int:
        return len(self.frames)


class _Default:
    """Marker type of "the loader's own sightings" in ``Sequence.frame_input``."""


_DEFAULT = _Default()


@dataclass(frozen=True, slots=True)
class Sequence:
    """One run: frame stamps, odometry between frames, sensor data, ground truth.

    Attributes:
        name: registry name or folder name.
        source: citation / provenance, one line.
        stamps_s: (N,) strictly increasing frame times [s].
        odometry_r: (N, 3) measured motion [dx, dy, dtheta] from frame i-1 to frame i in the
            frame of pose i-1 (row 0 is zero: the first frame defines the origin).
        odometry_true_r: (N, 3) the same without noise, when known (synthetic data).
        odometry_covariance_r: (N, 3, 3) covariance of each odometry row when the data states
            one (row 0 is ignored), else None.
        initial_pose_w: (3,) pose of frame 0 in the ground-truth world frame, when known
            (estimators start at the origin; evaluation aligns).
        range_bearing: per-frame sightings (None where a frame has none), or None.
        bearing_sightings: a bearing-only sensor's sightings (``BearingSightings``), or None;
            the frames' bearings unless a front-end log gives a frame its own.
        laser: laser scans, or None.
        image_loader: ``image_loader(i)`` reads image i (H, W, 3) uint8, or None.
        image_frames: (K,) indices of the frames that have an image.
        point_map_loader: ``point_map_loader(i)`` returns the world point each pixel of image i
            sees, (H, W, 3) [m] with NaN where none (synthetic renders), or None. It gives the
            true position of any keypoint, hence of every front-end landmark.
        pixel_points_loader: ``pixel_points_loader(i, rows, cols)`` returns
            ``point_map_loader(i)[rows, cols]``, (K, 3) for integer pixel centres, computed at
            those pixels only (the true points of a log's keypoints without whole maps), or
            None.
        calibration: the camera rig (``omnislam.camera``), or None.
        ground_truth: see GroundTruth.
        prior_map: a map known before the run (surveyed landmarks, a world's line map and
            walls), for localisers; None when the data have none.
        info: short facts for ``dataset list`` and reports (sensor names, counts, warnings).
    """

    name: str
    source: str
    stamps_s: np.ndarray
    odometry_r: np.ndarray
    ground_truth: GroundTruth = field(default_factory=GroundTruth)
    odometry_true_r: np.ndarray | None = None
    odometry_covariance_r: np.ndarray | None = None
    initial_pose_w: np.ndarray | None = None
    range_bearing: tuple[RangeBearing | None, ...] | None = None
    bearing_sightings: BearingSightings | None = None
    laser: LaserScans | None = None
    image_loader: Callable[[int], np.ndarray] | None = None
    image_frames: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    point_map_loader: Callable[[int], np.ndarray] | None = None
    pixel_points_loader: Callable[[int, np.ndarray, np.ndarray], np.ndarray] | None = None
    calibration: object | None = None
    prior_map: PriorMap | None = None
    info: Mapping[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        stamps = _frozen(self.stamps_s, float, (None,), f"{self.name}: stamps_s")
        n = stamps.shape[0]
        if n == 0:
            raise DataError(f"{self.name}: the sequence has no frames")
        if n > 1 and np.any(np.diff(stamps) <= 0):
            raise DataError(f"{self.name}: frame stamps must be strictly increasing")
        object.__setattr__(self, "stamps_s", stamps)
        odometry = _frozen(self.odometry_r, float, (n, 3), f"{self.name}: odometry_r")
        if not np.all(np.isfinite(odometry)):
            k = int(np.argmax(~np.all(np.isfinite(odometry), axis=1)))
            raise DataError(
                f"{self.name}: the odometry of frame {k} (t = {float(stamps[k])!r} s) is not "
                "finite (implausible speeds in the data?)"
            )
        object.__setattr__(self, "odometry_r", odometry)
        if self.odometry_true_r is not None:
            object.__setattr__(
                self,
                "odometry_true_r",
                _frozen(self.odometry_true_r, float, (n, 3), f"{self.name}: odometry_true_r"),
            )
        if self.odometry_covariance_r is not None:
            object.__setattr__(
                self,
                "odometry_covariance_r",
                _frozen(self.odometry_covariance_r, float, (n, 3, 3), f"{self.name}: odometry cov"),
            )
        if self.initial_pose_w is not None:
            object.__setattr__(
                self, "initial_pose_w", _frozen(self.initial_pose_w, float, (3,), "initial_pose_w")
            )
        if self.range_bearing is not None and len(self.range_bearing) != n:
            raise DataError(f"{self.name}: range_bearing must have one entry per frame")
        if self.bearing_sightings is not None and len(self.bearing_sightings) != n:
            raise DataError(f"{self.name}: bearing_sightings must have one entry per frame")
        if self.laser is not None and self.laser.ranges_m.shape[0] != n:
            raise DataError(f"{self.name}: laser must have one row per frame")
        frames = _frozen(self.image_frames, np.int64, (None,), f"{self.name}: image_frames")
        if frames.size and (frames.min() < 0 or frames.max() >= n):
            raise DataError(f"{self.name}: image_frames out of range")
        object.__setattr__(self, "image_frames", frames)
        object.__setattr__(self, "info", dict(self.info))

    def __len__(self) -> int:
        return int(self.stamps_s.shape[0])

    def image(self, index: int) -> np.ndarray:
        """Read the image of frame ``index`` (H, W, 3) uint8."""
        if self.image_loader is None:
            raise DataError(f"{self.name}: the sequence has no images")
        return self.image_loader(index)

    def frame_input(
        self,
        index: int,
        *,
        bearings: Bearings | _Default | None = _DEFAULT,
        range_bearing: RangeBearing | _Default | None = _DEFAULT,
        vertical_lines: VerticalLines | None = None,
    ) -> FrameInput:
        """The FrameInput of frame ``index``: its odometry (with the stated covariance, from
        frame 1 on) and sightings.

        Args:
            index: the frame.
            bearings: omni bearings of the front end, or None; by default the loader's own
                bearing-only sightings (``self.bearing_sightings``), if any.
            range_bearing: range-bearing sightings; by default the loader's own
                (``self.range_bearing[index]``); the front end passes those merged with its
                laser landmarks.
            vertical_lines: vertical lines of the front end, or None.
        """
        if isinstance(bearings, _Default):
            own = self.bearing_sightings
            bearings = own.frames[index] if own is not None else None
        if isinstance(range_bearing, _Default):
            range_bearing = self.range_bearing[index] if self.range_bearing is not None else None
        cov = None
        if self.odometry_covariance_r is not None and index > 0:
            cov = self.odometry_covariance_r[index]
        return FrameInput(
            index=index,
            odometry=Odometry(self.odometry_r[index], self.stamps_s[index], cov),
            bearings=bearings,
            range_bearing=range_bearing,
            vertical_lines=vertical_lines,
        )

    def frame_inputs(
        self, observations: Iterable[FrameInput] | None = None, *, odometry: bool = False
    ) -> Iterator[FrameInput]:
        """Yield one FrameInput per frame.

        Args:
            observations: a front-end log's frames (one per frame, in order): their bearings,
                range-bearing sightings and vertical lines replace the loader's sightings (a
                frame without bearings in the log keeps the loader's bearing-only sightings).
                None: the loader's sightings only.
            odometry: take the odometry (and its covariance) from ``observations`` too (a
                log's laser odometry); else it comes from the sequence.

        Raises:
            DataError: the observations do not have one frame per frame of the sequence.
        """
        if observations is None:
            for i in range(len(self)):
                yield self.frame_input(i)
            return
        count = 0
        for count, seen in enumerate(observations, start=1):
            if seen.index != count - 1 or count > len(self):
                raise DataError(
                    f"{self.name}: observation frame {seen.index} does not follow frame "
                    f"{count - 2} of {len(self)}"
                )
            frame = self.frame_input(
                seen.index,
                bearings=_DEFAULT if seen.bearings is None else seen.bearings,
                range_bearing=seen.range_bearing,
                vertical_lines=seen.vertical_lines,
            )
            if odometry and seen.index > 0:
                own = frame.odometry  # kept with its stated covariance where the log kept it
                if not (seen.odometry.covariance is None
                        and np.array_equal(seen.odometry.delta, own.delta)):
                    frame = replace(frame, odometry=seen.odometry)
            yield frame
        if count != len(self):
            raise DataError(f"{self.name}: observations for {count} of {len(self)} frames")
