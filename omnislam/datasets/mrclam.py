"""UTIAS Multi-Robot Cooperative Localization and Mapping (MR.CLAM) datasets.

Leung, Halpern, Barfoot, Liu, "The UTIAS multi-robot cooperative localization and mapping
dataset", International Journal of Robotics Research 30(8), 2011.

Five iRobot Create robots with monocular cameras in a 15 m x 8 m room with 15 cylindrical
landmarks; Vicon ground truth for the robots and surveyed landmark positions. One Sequence is one
robot of one dataset folder (``MRCLAM_DatasetN``); the robot is chosen with ``robot=`` (1-5).

Conventions converted here, once:

* Column 2 of ``RobotN_Measurement.dat`` is a *barcode*; ``Barcodes.dat`` maps it to a subject.
  Subjects 1-5 are robots (their sightings are dropped: they are not landmarks), 6-20 are the
  landmarks, whose subject number becomes the landmark id. Barcodes that are in no subject's row
  (misreads, e.g. barcode 43 once in dataset 6 robot 1) are dropped and counted.
* Odometry is the *commanded* (v, omega) stream at ~100 Hz. It is integrated in closed form
  (unicycle arcs, zero-order hold) between frame stamps; the robot frame is the robot's centre
  (the Vicon marker frame), x forward, bearing counter-clockwise from x.
* Frames: frame 0 at the first odometry sample, then one frame per camera image with at least
  one landmark sighting, and frames without sightings that fill the gaps between them longer than
  ``MAX_STEP_S``. The sightings of one image can carry stamps a millisecond or two apart
  (``SAME_IMAGE_S``); they share the frame of the image's first stamp.
* Ground truth: Vicon poses interpolated at the stamps of the frames with sightings and frame 0
  (linear, heading unwrapped) where two Vicon samples bracket the stamp within
  ``VICON_MAX_GAP_S``; surveyed landmarks as the map.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from omnislam.core.ackermann import integrate_unicycle
from omnislam.core.motion import MotionNoise, OdometryMotionModel
from omnislam.core.se import wrap_angle
from omnislam.core.types import PriorMap, Trajectory
from omnislam.datasets._common import (
    Association,
    fill_gaps,
    group_sightings,
    interpolate_se2,
    odometry_from_poses,
)
from omnislam.datasets._text import (
    StampOrder,
    Table,
    check_integers,
    check_range,
    check_stream_end,
    check_unique,
    read_table,
)
from omnislam.datasets.sequence import GroundTruth, GroundTruthKind, Sequence
from omnislam.errors import ConfigError, DataError

log = logging.getLogger(__name__)

SOURCE = (
    "UTIAS MR.CLAM: Leung, Halpern, Barfoot, Liu, 'The UTIAS multi-robot cooperative "
    "localization and mapping dataset', IJRR 30(8), 2011"
)

#: subjects 1..ROBOT_SUBJECTS are robots; higher subject numbers are landmarks (Leung et al. 2011)
ROBOT_SUBJECTS = 5

#: Vicon samples further apart than this do not bracket a frame stamp (dropout) [s]
VICON_MAX_GAP_S = 0.5

#: The "range" column is the landmark's *depth along the camera's optical axis*, not its
#: distance: the camera infers it from the barcode's apparent height, which gives the pinhole
#: depth z = r cos(bearing). Measured on dataset 6 against Vicon poses and surveyed landmarks
#: (robots 1-5): range residuals fall from a median of +0.07..+0.15 m at |bearing| < 0.2 rad to
#: -0.3..-0.55 m at the edge of the field of view (|bearing| > 0.45 rad, where every
#: "range-only" outlier of the file lies), while depth residuals are flat in bearing; their
#: robust spread is 0.022-0.050 m against 0.08-0.18 m for ranges. The depths carry a bias of
#: +0.09..+0.18 m per robot (median over all sightings +0.117 m): the loader converts
#: range = (depth - DEPTH_BIAS_M) / cos(bearing). ``tests/datasets/test_mrclam.py`` recomputes
#: both facts on robot 1.
DEPTH_BIAS_M = 0.12

#: The commanded velocities lead the motion by ~0.2 s: the yaw rate they command matches the
#: Vicon yaw rate best (rms 0.077-0.091 rad/s against 0.103-0.137 unshifted) when shifted by
#: +0.2 s on each of robots 1-5. The loader integrates them from their stamps + this delay.
COMMAND_DELAY_S = 0.2

#: Default sighting noise after the conversion, measured on dataset 6 (1.4826 x MAD of the
#: residuals against Vicon, robots 1-5): 0.03-0.09 m in range (growing with range, and with a
#: per-robot scale error of up to 3 %: robot 2) and 0.006-0.011 rad in bearing (robot 4 carries
#: a -0.014 rad bias). The defaults cover the spread of the robots together.
SIGMA_RANGE_M = 0.06
SIGMA_BEARING_RAD = 0.011

#: The noise of the commanded odometry, stated with every frame (``Sequence.odometry_covariance_r``
#: from ``OdometryMotionModel.covariance``, thesis eq. 4.41): the alpha coefficients fitted by
#: maximum likelihood to the frame-to-frame odometry errors against Vicon (robots 1-5, the
#: delay applied; squared Mahalanobis distances capped at 25 against outliers). Commanded
#: velocities know nothing of slip, bumps or the delay's jitter: 1.3-7x the shared default
#: motion noise, under which the frame-to-frame NEES has a median of 15 (3 dof; 2.4 expected)
#: and an outlier gate rejects most of the correct sightings after a sparse stretch. Floor of
#: 1 mm / 1 mrad per step: frames sit at sighting times, some only ~10 ms apart, and a step of
#: 0.07 mm and 9 urad with the model's own 0.1 mrad floor made iSAM2's Cholesky throw
#: "Indeterminate linear system" once on every robot (recovered by the QR rebuild; ATE within
#: 0.5 mm with the floor, ``omnislam run mrclam6-rK --estimator graphslam``).
ODOMETRY_NOISE = MotionNoise(
    a_vv=0.063, a_vw=0.227, a_wv=0.059, a_ww=0.367, min_sigma=(1e-3, 1e-3, 1e-3)
)

#: plausible commanded speeds of an iRobot Create (it tops out at 0.5 m/s; dataset 6 commands
#: at most 0.6 m/s and 0.6 rad/s): anything outside is a corrupt file, not a fast robot
MAX_SPEED_M_S = 5.0
MAX_TURN_RATE_RAD_S = 10.0
#: plausible sighting range [m] (the room is 15 m x 8 m)
MAX_RANGE_M = 100.0
#: plausible |bearing| of a landmark sighting [rad]: the camera sees about +-0.575 rad (dataset
#: 6: at most 0.592); beyond 1 rad the file is not a camera's, and its "range" column cannot be
#: the optical-axis depth (``DEPTH_BIAS_M``; cos(bearing) would reach 0 and turn negative)
MAX_BEARING_RAD = 1.0
#: plausible |x|, |y| of a Vicon pose or a surveyed landmark [m] and |theta| of a Vicon pose
#: [rad]: dataset 6 keeps the robots within 4.70 m and 5.57 m of the origin, the landmarks
#: within 3.47 m and 4.53 m (the room is 15 m x 8 m), and Vicon wraps theta to [-pi, pi]
#: (at most 3.1416); a corrupt 1e300 is not a pose
MAX_POSITION_M = 1000.0
MAX_HEADING_RAD = 100.0

#: Longest odometry step between two frames [s]: where sightings are further apart, frames
#: without sightings are inserted at equal spacing so that no step is longer. Dataset 6 has gaps
#: of up to 53 s between sightings (robot 4: 78 s and 52 s); one frame per sighting time made
#: each gap ONE odometry step of metres and radians, whose stated covariance (the alpha model
#: linearised once, ``OdometryMotionModel.covariance``) is not the spread of the arcs the robot
#: drove, and which a particle filter can only sample as one straight rot1-trans-rot2 motion.
#: With short steps the composed covariance follows the path (``core.motion.compose_odometry``,
#: as graphslam folds them) and the particles spread along the driven arcs.
MAX_STEP_S = 2.0

#: Sightings whose stamps lie within this of the first stamp of their burst come from one camera
#: image and share one frame [s]. The camera runs at ~4 Hz, but the sightings of one image are
#: logged with stamps up to 4 ms apart: on dataset 6, robots 1-5, 5-12 % of the distinct stamps
#: (67 / 158 / 324 / 118 / 268) follow the previous one by 1-4 ms and every other gap is at least
#: 0.1 s (median 0.23 s); no burst holds the same barcode twice. A frame per stamp split one
#: image's sightings over two frames, so an estimator associating unlabelled sightings could not
#: tell that they are of different landmarks (mutual exclusion within a frame).
SAME_IMAGE_S = 0.02

#: the odometry may end this much before the last sighting [s] (dataset 6: it ends after it),
#: and this much before the Vicon ground truth (dataset 6: at most 0.017 s before it)
ODOMETRY_END_TOLERANCE_S = 0.5
#: the Vicon ground truth may end this much before the last sighting [s] (dataset 6: it ends
#: 19.8 s after it for robot 1, 126 s before that robot's odometry; later for the others)
VICON_END_TOLERANCE_S = 0.5


@dataclass(frozen=True, slots=True)
class Sightings:
    """The landmark sightings of one robot after barcode mapping.

    Attributes:
        stamps_s: (K,) non-decreasing times [s].
        landmark_ids: (K,) landmark subject numbers.
        ranges_m: (K,) ranges [m].
        bearings_rad: (K,) bearings, robot frame, counter-clockwise from the heading [rad].
        robot_sightings: how many sightings of other robots were dropped.
        unknown_barcodes: barcode -> count of sightings whose barcode maps to no subject.
    """

    stamps_s: np.ndarray
    landmark_ids: np.ndarray
    ranges_m: np.ndarray
    bearings_rad: np.ndarray
    robot_sightings: int
    unknown_barcodes: dict[int, int]


def read_barcodes(path: Path) -> dict[int, int]:
    """``Barcodes.dat`` -> {barcode: subject}.

    Raises:
        DataError: malformed file, a subject or barcode that is not an integer, or listed twice.
    """
    table = read_table(path, ("subject", "barcode"), stamp_order=StampOrder.ANY)
    check_integers(table, 0, "subject")
    check_integers(table, 1, "barcode")
    check_unique(table, 0, "subject")
    check_unique(table, 1, "barcode")
    return {int(barcode): int(subject) for subject, barcode in table.values}


def read_landmark_groundtruth(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """``Landmark_Groundtruth.dat`` -> (subject ids (M,), positions (M, 2) [m]).

    Raises:
        DataError: malformed file, a subject that is not an integer or is listed twice, a
            position beyond ``MAX_POSITION_M`` (naming the line).
    """
    columns = ("subject", "x[m]", "y[m]", "x_std[m]", "y_std[m]")
    table = read_table(path, columns, stamp_order=StampOrder.ANY)
    check_integers(table, 0, "subject")
    check_unique(table, 0, "subject")
    for column, name in ((1, "x[m]"), (2, "y[m]")):
        check_range(table, column, name, -MAX_POSITION_M, MAX_POSITION_M)
    return table.values[:, 0].astype(np.int64), np.array(table.values[:, 1:3])


def read_robot_groundtruth(path: Path) -> Trajectory:
    """``RobotN_Groundtruth.dat`` (Vicon) -> Trajectory of the robot's poses in the room frame."""
    table = read_robot_groundtruth_table(path)
    return Trajectory.from_se2(table.values[:, 0], table.values[:, 1:4])


def read_robot_groundtruth_table(path: Path) -> Table:
    """``RobotN_Groundtruth.dat`` -> its rows [time s, x m, y m, theta rad].

    Raises:
        DataError: malformed file, times not strictly increasing, or a pose beyond
            ``MAX_POSITION_M`` or ``MAX_HEADING_RAD`` (naming the line).
    """
    columns = ("time[s]", "x[m]", "y[m]", "theta[rad]")
    table = read_table(path, columns, stamp_order=StampOrder.INCREASING)
    check_range(table, 1, "x[m]", -MAX_POSITION_M, MAX_POSITION_M)
    check_range(table, 2, "y[m]", -MAX_POSITION_M, MAX_POSITION_M)
    check_range(table, 3, "theta[rad]", -MAX_HEADING_RAD, MAX_HEADING_RAD)
    return table


def read_robot_odometry_table(path: Path) -> Table:
    """``RobotN_Odometry.dat`` -> its rows [time s, v m/s, omega rad/s], speeds checked.

    Raises:
        DataError: malformed file or a speed outside the plausible range (naming the line).
    """
    table = read_table(path, ("time[s]", "v[m/s]", "omega[rad/s]"))
    check_range(table, 1, "v[m/s]", -MAX_SPEED_M_S, MAX_SPEED_M_S)
    check_range(table, 2, "omega[rad/s]", -MAX_TURN_RATE_RAD_S, MAX_TURN_RATE_RAD_S)
    return table


def read_robot_odometry(path: Path) -> np.ndarray:
    """``RobotN_Odometry.dat`` -> (K, 3) [time s, v m/s, omega rad/s] (commanded velocities)."""
    return np.array(read_robot_odometry_table(path).values)


def read_robot_measurements(path: Path, barcodes: dict[int, int]) -> Sightings:
    """``RobotN_Measurement.dat`` -> landmark sightings with barcodes mapped to subjects.

    Raises:
        DataError: malformed file, no sightings at all (empty or header only), a negative or
            implausible range, a landmark bearing outside the camera's field of view (naming
            the line).
    """
    columns = ("time[s]", "barcode", "range[m]", "bearing[rad]")
    table = read_table(path, columns, min_rows=1)
    check_integers(table, 1, "barcode")
    check_range(table, 2, "range[m]", -np.inf, MAX_RANGE_M)
    values = table.values
    codes = values[:, 1].astype(np.int64)
    subjects = np.array([barcodes.get(int(c), -1) for c in codes], dtype=np.int64)
    unknown = subjects < 0
    robots = (subjects >= 1) & (subjects <= ROBOT_SUBJECTS)
    keep = ~unknown & ~robots
    missing, counts = np.unique(codes[unknown], return_counts=True)
    if np.any(values[keep, 2] < 0):
        row = int(np.argmax(keep & (values[:, 2] < 0)))
        raise DataError(f"{table.where(row)}: negative range", path)
    outside = keep & (np.abs(values[:, 3]) > MAX_BEARING_RAD)
    if np.any(outside):
        row = int(np.argmax(outside))
        raise DataError(
            f"{table.where(row)}: bearing {values[row, 3]:g} rad outside the camera's field of "
            f"view (|bearing| <= {MAX_BEARING_RAD:g} rad)",
            path,
        )
    return Sightings(
        stamps_s=values[keep, 0],
        landmark_ids=subjects[keep],
        ranges_m=values[keep, 2],
        bearings_rad=values[keep, 3],
        robot_sightings=int(np.sum(robots)),
        unknown_barcodes={int(c): int(n) for c, n in zip(missing, counts, strict=True)},
    )


def image_stamps(stamps_s: np.ndarray, same_image_s: float) -> np.ndarray:
    """Each sighting's stamp replaced by the first stamp of its burst (``SAME_IMAGE_S``).

    A burst starts at a stamp more than ``same_image_s`` after the previous burst's first
    stamp, so a burst never spans more than ``same_image_s``, however dense the stamps.

    Args:
        stamps_s: (K,) non-decreasing sighting stamps [s].
        same_image_s: the longest span of one burst [s] (>= 0).

    Raises:
        ConfigError: ``same_image_s`` negative or not finite.
    """
    if not (np.isfinite(same_image_s) and same_image_s >= 0):
        raise ConfigError(f"same_image_s must be finite and >= 0, got {same_image_s}")
    stamps_s = np.asarray(stamps_s, dtype=float)
    if len(stamps_s) == 0:
        return stamps_s
    distinct = np.unique(stamps_s)
    firsts = [distinct[0]]
    for stamp in distinct[1:]:
        if stamp - firsts[-1] > same_image_s:
            firsts.append(stamp)
    firsts_s = np.array(firsts)
    return firsts_s[np.searchsorted(firsts_s, stamps_s, side="right") - 1]


def ranges_from_depths(depths_m: np.ndarray, bearings_rad: np.ndarray) -> np.ndarray:
    """Ranges [m] of landmarks whose optical-axis depths [m] and bearings [rad] were measured.

    range = (depth - DEPTH_BIAS_M) / cos(bearing) (see ``DEPTH_BIAS_M``); the field of view
    (about +-0.575 rad) keeps cos(bearing) above 0.8.
    """
    return (np.asarray(depths_m) - DEPTH_BIAS_M) / np.cos(np.asarray(bearings_rad))


#: the files an MR.CLAM folder shares between its robots
SHARED_FILES = ("Barcodes.dat", "Landmark_Groundtruth.dat")
#: the files of one robot of an MR.CLAM folder (``Robot1_Odometry.dat``, ...)
ROBOT_FILE_KINDS = ("Odometry", "Measurement", "Groundtruth")


def is_mrclam_folder(path: Path) -> bool:
    """True when ``path`` is a folder holding any file of an MR.CLAM dataset (``SHARED_FILES``,
    ``RobotN_{Odometry,Measurement,Groundtruth}.dat``): a folder that lacks one of them is
    recognised and ``load_mrclam`` names the file missing."""
    path = Path(path)
    if not path.is_dir():
        return False
    if any((path / name).is_file() for name in SHARED_FILES):
        return True
    return any(any(path.glob(f"Robot*_{kind}.dat")) for kind in ROBOT_FILE_KINDS)


@dataclass(frozen=True, slots=True)
class _RobotFiles:
    """What one robot's files of an MR.CLAM folder hold, checked against each other.

    Attributes:
        measurement_path: ``RobotN_Measurement.dat`` (warnings name it).
        landmark_ids: (M,) surveyed landmarks' subject numbers.
        landmarks_xy: (M, 2) their positions in the room [m].
        odometry: (K, 3) [time s, v m/s, omega rad/s] commanded velocities.
        sightings: the landmark sightings, barcodes mapped.
        vicon: the Vicon poses, or None without ``RobotN_Groundtruth.dat``.
    """

    measurement_path: Path
    landmark_ids: np.ndarray
    landmarks_xy: np.ndarray
    odometry: np.ndarray
    sightings: Sightings
    vicon: Trajectory | None


def _read_robot_files(folder: Path, robot: int) -> _RobotFiles:
    """Read one robot's files (and the folder's barcodes and landmarks); the odometry and the
    Vicon file must each reach the last sighting, and the odometry the Vicon file's end.

    Raises:
        DataError: not a folder, a missing or malformed file (naming it and the line), or a
            stream ending too early (a file cut short).
        ConfigError: a robot number without files.
    """
    if not folder.is_dir():
        raise DataError("not a folder (expected an MR.CLAM dataset folder)", folder)
    files = {kind: folder / f"Robot{robot}_{kind}.dat" for kind in ("Odometry", "Measurement")}
    robots = sorted(p.name.split("_")[0] for p in folder.glob("Robot*_Odometry.dat"))
    if not files["Odometry"].is_file() and robots:
        raise ConfigError(f"{folder}: no files for robot={robot} (found: {', '.join(robots)})")
    for path in (folder / SHARED_FILES[0], folder / SHARED_FILES[1], *files.values()):
        if not path.is_file():
            raise DataError(
                f"file missing (an MR.CLAM folder holds {', '.join(SHARED_FILES)} and, per "
                "robot N, RobotN_Odometry.dat, RobotN_Measurement.dat, RobotN_Groundtruth.dat)",
                path,
            )
    barcodes = read_barcodes(folder / "Barcodes.dat")
    landmark_ids, landmarks_xy = read_landmark_groundtruth(folder / "Landmark_Groundtruth.dat")
    odometry_table = read_robot_odometry_table(files["Odometry"])
    sightings = read_robot_measurements(files["Measurement"], barcodes)
    vicon_path = folder / f"Robot{robot}_Groundtruth.dat"
    vicon_table = read_robot_groundtruth_table(vicon_path) if vicon_path.is_file() else None
    # the odometry and the Vicon file must each reach the last sighting (a file cut short)
    for table, tolerance_s in (
        (odometry_table, ODOMETRY_END_TOLERANCE_S),
        (vicon_table, VICON_END_TOLERANCE_S),
    ):
        if table is not None and len(sightings.stamps_s):
            check_stream_end(
                table, float(sightings.stamps_s[-1]), files["Measurement"], tolerance_s
            )
    vicon = None
    if vicon_table is not None:
        check_stream_end(
            odometry_table, float(vicon_table.values[-1, 0]), vicon_path, ODOMETRY_END_TOLERANCE_S
        )
        vicon = Trajectory.from_se2(vicon_table.values[:, 0], vicon_table.values[:, 1:4])
    return _RobotFiles(files["Measurement"], landmark_ids, landmarks_xy,
                       np.array(odometry_table.values), sightings, vicon)


@dataclass(frozen=True, slots=True)
class _Frames:
    """When one robot's frames are: frame 0 at the odometry's start, one per image with
    sightings, and frames filling the gaps between them.

    Attributes:
        early: (K,) True for the sightings before the odometry starts (dropped).
        image_stamps_s: (K',) each kept sighting's frame stamp, its image's first stamp [s].
        sighting_frames_s: the stamps of frame 0 and of the frames with sightings [s].
        stamps_s: (N,) every frame's stamp [s].
    """

    early: np.ndarray
    image_stamps_s: np.ndarray
    sighting_frames_s: np.ndarray
    stamps_s: np.ndarray


def _frames(files: _RobotFiles, same_image_s: float, max_step_s: float) -> _Frames:
    """The frames: the sightings within ``same_image_s`` of their burst's first stamp share
    its frame (``image_stamps``); gaps longer than ``max_step_s`` are filled."""
    start_s = float(files.odometry[0, 0])
    early = files.sightings.stamps_s < start_s
    stamps = image_stamps(files.sightings.stamps_s[~early], same_image_s)
    sighting_frames = np.unique(np.concatenate([[start_s], stamps]))
    return _Frames(early, stamps, sighting_frames, fill_gaps(sighting_frames, max_step_s))


def _commanded_odometry(odometry: np.ndarray, frame_stamps: np.ndarray, command_delay_s: float,
                        odometry_noise: bool) -> tuple[np.ndarray, np.ndarray | None]:
    """The (N, 3) odometry between the frames, integrated from the commanded velocities
    (unicycle arcs, zero-order hold, ``command_delay_s`` later), and its (N, 3, 3) stated
    covariance (``ODOMETRY_NOISE``, thesis eq. 4.41) or None without ``odometry_noise``."""
    poses_odom = integrate_unicycle(
        odometry[:, 0] + command_delay_s, odometry[:, 1], odometry[:, 2], frame_stamps
    )
    odometry_r = odometry_from_poses(poses_odom)
    odometry_cov = None
    if odometry_noise:
        model = OdometryMotionModel(ODOMETRY_NOISE)
        odometry_cov = np.array([model.covariance(delta) for delta in odometry_r])
    return odometry_r, odometry_cov


def _ranges_bearings(sightings: Sightings, kept: np.ndarray, depth_ranges: bool, path: Path
                     ) -> tuple[np.ndarray, np.ndarray]:
    """The ranges [m] and bearings [rad] of the ``kept`` sightings, the file's optical-axis
    depths turned into ranges (``ranges_from_depths``) when ``depth_ranges``.

    Raises:
        DataError: a depth below ``DEPTH_BIAS_M`` (naming ``path``, the measurement file).
    """
    bearings = sightings.bearings_rad[kept]
    ranges = sightings.ranges_m[kept]
    if depth_ranges:
        ranges = ranges_from_depths(ranges, bearings)
        if np.any(ranges < 0):
            k = int(np.argmax(ranges < 0))
            raise DataError(
                f"time {float(sightings.stamps_s[kept][k])!r}: depth "
                f"{float(sightings.ranges_m[kept][k]):g} m is below the depth bias "
                f"{DEPTH_BIAS_M:g} m (no range; depth_ranges=false keeps the column as it is)",
                path,
            )
    return ranges, bearings


def _ground_truth(
    files: _RobotFiles, sighting_frames: np.ndarray
) -> tuple[GroundTruth, PriorMap, np.ndarray | None]:
    """The ground truth (Vicon interpolated at the frames with sightings and frame 0, the
    surveyed landmarks), the surveyed map, and the true initial pose (None where Vicon does not
    bracket frame 0)."""
    landmark_ids, vicon = files.landmark_ids, files.vicon
    ground_truth = GroundTruth(
        kind=GroundTruthKind.MOTION_CAPTURE if vicon is not None else GroundTruthKind.NONE,
        landmark_ids=landmark_ids,
        landmarks_w=np.column_stack([files.landmarks_xy, np.zeros(len(landmark_ids))]),
        note="Vicon motion capture interpolated at the frame stamps; surveyed landmarks",
    )
    initial_pose = None
    if vicon is not None:
        # the truth at the frames with sightings (and frame 0) only: the frames that fill the
        # gaps carry nothing to estimate from, and the trajectory metrics stay at the sighting
        # stamps whatever max_step_s is
        valid, poses_true = interpolate_se2(
            vicon.stamps_s, vicon.se2, sighting_frames, VICON_MAX_GAP_S
        )
        ground_truth = GroundTruth(
            kind=ground_truth.kind,
            trajectory=Trajectory.from_se2(sighting_frames[valid], poses_true),
            landmark_ids=ground_truth.landmark_ids,
            landmarks_w=ground_truth.landmarks_w,
            note=ground_truth.note,
        )
        if valid[0]:
            initial_pose = poses_true[0]
    prior_map = PriorMap(
        source="surveyed landmarks (MR.CLAM Landmark_Groundtruth.dat)",
        landmark_ids=ground_truth.landmark_ids,
        points_w=ground_truth.landmarks_w,
        initial_pose_w=initial_pose,
    )
    return ground_truth, prior_map, initial_pose


def load_mrclam(
    folder: Path,
    robot: int = 1,
    *,
    association: Association = Association.KNOWN,
    sigma_range_m: float = SIGMA_RANGE_M,
    sigma_bearing_rad: float = SIGMA_BEARING_RAD,
    depth_ranges: bool = True,
    command_delay_s: float = COMMAND_DELAY_S,
    odometry_noise: bool = True,
    max_step_s: float = MAX_STEP_S,
    same_image_s: float = SAME_IMAGE_S,
    name: str | None = None,
) -> Sequence:
    """Load one robot of an MR.CLAM dataset folder as a Sequence.

    Args:
        folder: ``MRCLAM_DatasetN`` folder (Barcodes.dat, Landmark_Groundtruth.dat, RobotN_*.dat).
        robot: robot number (1-5).
        association: KNOWN keeps the landmark ids in the sightings (ground truth keeps them
            always), UNKNOWN hides them from the estimators.
        sigma_range_m: range noise of the sightings given to the estimators [m].
        sigma_bearing_rad: bearing noise of the sightings given to the estimators [rad].
        depth_ranges: convert the file's optical-axis depths into ranges (``DEPTH_BIAS_M``);
            False keeps the column as it is.
        command_delay_s: delay of the commanded velocities (``COMMAND_DELAY_S``) [s].
        odometry_noise: state the odometry covariance of every frame (``ODOMETRY_NOISE``);
            False leaves it to each estimator's motion model.
        max_step_s: longest odometry step: frames without sightings fill longer gaps between
            sightings (``MAX_STEP_S``; infinite: frames at sighting times only) [s].
        same_image_s: sightings within this of their burst's first stamp share its frame
            (``SAME_IMAGE_S``; 0: one frame per distinct stamp) [s].
        name: sequence name (default ``<folder>-r<robot>``).

    Returns:
        The Sequence (frames at sighting times and filling longer gaps, odometry from the
        commanded velocities, Vicon ground truth interpolated at the frames with sightings,
        surveyed landmarks).

    Raises:
        DataError: a missing or malformed file (naming it and the line), or the odometry or
            the Vicon file ending before the sightings, or the odometry before the Vicon file
            (a file cut short).
        ConfigError: a robot number without files.
    """
    folder = Path(folder)
    files = _read_robot_files(folder, robot)
    sightings = files.sightings
    frames = _frames(files, same_image_s, max_step_s)
    early = frames.early
    odometry_r, odometry_cov = _commanded_odometry(files.odometry, frames.stamps_s,
                                                   command_delay_s, odometry_noise)
    range_bearing = group_sightings(
        frames.stamps_s,
        frames.image_stamps_s,
        sightings.landmark_ids[~early],
        *_ranges_bearings(sightings, ~early, depth_ranges, files.measurement_path),
        sigma_range_m,
        sigma_bearing_rad,
        association,
    )
    ground_truth, prior_map, initial_pose = _ground_truth(files, frames.sighting_frames_s)
    unknown = sightings.unknown_barcodes
    if unknown:
        log.warning("%s: %d sightings with unknown barcodes dropped: %s",
                    files.measurement_path, sum(unknown.values()), unknown)
    info = {
        "sensors": "commanded odometry (v, omega) ~100 Hz; camera range-bearing to barcoded "
        "landmarks; Vicon ground truth",
        "robot": str(robot),
        "landmark_sightings": str(len(frames.image_stamps_s)),
        "robot_sightings_dropped": str(sightings.robot_sightings),
        "unknown_barcode_sightings_dropped": str(sum(unknown.values())),
        "unknown_barcodes": ",".join(str(b) for b in sorted(unknown)) or "none",
        "sightings_before_odometry_dropped": str(int(np.sum(early))),
        "association": association.value,
        "sigma_range_m": str(sigma_range_m),
        "sigma_bearing_rad": str(sigma_bearing_rad),
        "ranges": f"(depth - {DEPTH_BIAS_M} m) / cos(bearing)" if depth_ranges else "as recorded",
        "command_delay_s": str(command_delay_s),
        "max_step_s": str(max_step_s),
        "same_image_s": str(same_image_s),
        "odometry_noise": "stated (ODOMETRY_NOISE)" if odometry_noise else "not stated",
        "robot_frame": "robot centre (Vicon frame), x forward",
    }
    return Sequence(
        name=name or f"{folder.name}-r{robot}",
        source=SOURCE,
        stamps_s=frames.stamps_s,
        odometry_r=odometry_r,
        odometry_covariance_r=odometry_cov,
        ground_truth=ground_truth,
        initial_pose_w=initial_pose,
        range_bearing=range_bearing,
        prior_map=prior_map,
        info=info,
    )


def bearing_residuals(sequence: Sequence) -> np.ndarray:
    """Measured minus predicted bearing [rad] of every sighting at a frame with ground truth.

    The prediction uses the ground-truth pose and landmark map; a check of the loader's
    conventions (barcode mapping, bearing sign, frame stamps).
    """
    gt = sequence.ground_truth
    if gt.trajectory is None or sequence.range_bearing is None:
        return np.zeros(0)
    position = {int(i): p[:2] for i, p in zip(gt.landmark_ids, gt.landmarks_w, strict=True)}
    frame_of = {float(t): k for k, t in enumerate(gt.trajectory.stamps_s)}
    poses = gt.trajectory.se2
    residuals: list[float] = []
    for stamp, sightings in zip(sequence.stamps_s, sequence.range_bearing, strict=True):
        k = frame_of.get(float(stamp))
        if sightings is None or k is None:
            continue
        for lid, bearing in zip(sightings.landmark_ids, sightings.bearings_rad, strict=True):
            if int(lid) not in position:
                continue
            d = position[int(lid)] - poses[k, :2]
            predicted = np.arctan2(d[1], d[0]) - poses[k, 2]
            residuals.append(float(wrap_angle(bearing - predicted)))
    return np.asarray(residuals)
