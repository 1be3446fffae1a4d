"""ACFR Victoria Park (Guivant & Nebot), the ASCII version with GPS.

Guivant, Nebot, "Optimization of the simultaneous localization and map-building algorithm for
real-time implementation", IEEE Transactions on Robotics and Automation 17(3), 2001; data from
the Australian Centre for Field Robotics, University of Sydney.

A utility car drives ~4 km through a park for ~26 min; a 2-D laser detects tree trunks.

Conventions converted here, once:

* **Robot frame = the laser** (x forward along the car, y left). Sightings then need no lever
  arm. The laser's bearing 0..pi (pi/2 straight ahead) becomes ``bearing - pi/2``.
* **Odometry**: ``inputs.dat`` (encoder speed at the rear-left wheel, steering angle, 40 Hz)
  drives the Guivant-Nebot Ackermann model (``omnislam.core.ackermann``: rear axle speed
  v_c = v_e / (1 - tan(alpha) H / L), laser at (a, b) from the rear axle), integrated exactly
  between frame stamps; each frame's odometry is the motion of the laser frame since the
  previous frame.
* **Frames**: one per laser scan with at least one tree detection (simultaneous detections
  share a frame). Association is unknown (ids are ``UNKNOWN_ID``).
* **Ground truth**: GPS positions (``gps.dat``, rotated and offset by the data's authors so the
  run starts near the origin), interpolated at the frame stamps where two fixes bracket the stamp
  within ``GPS_MAX_GAP_S``; frames inside GPS gaps have none (partial ground truth). GPS gives no
  heading: the ground-truth yaw is a placeholder 0 and only positions may be compared. The GPS
  antenna's offset from the laser is not documented; it is ignored (GPS error is metres anyway).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from omnislam.core.ackermann import AckermannGeometry, integrate_ackermann
from omnislam.core.types import UNKNOWN_ID, Trajectory
from omnislam.datasets._common import group_sightings, interpolate_se2, odometry_from_poses
from omnislam.datasets._text import (
    StampOrder,
    Table,
    check_range,
    check_stream_end,
    check_stream_start,
    read_table,
)
from omnislam.datasets.sequence import GroundTruth, GroundTruthKind, Sequence
from omnislam.errors import DataError

SOURCE = (
    "ACFR Victoria Park: Guivant & Nebot, 'Optimization of the simultaneous localization and "
    "map-building algorithm for real-time implementation', IEEE T-RA 17(3), 2001"
)

#: two GPS fixes further apart than this leave the frames between them without ground truth [s]
GPS_MAX_GAP_S = 0.5

#: Default sighting noise. Victoria Park has no surveyed tree map to measure it against: these
#: are an engineering choice (trunk centres from 0.5-deg laser beams on 0.1-1 m wide trunks);
#: override with ``--set sigma_range_m=... --set sigma_bearing_rad=...``.
SIGMA_RANGE_M = 0.5
SIGMA_BEARING_RAD = 0.05

#: plausible encoder speed [m/s] (the run tops out near 7 m/s) and steering angle (the
#: Ackermann model is singular at +-pi/2) [rad]
MAX_SPEED_M_S = 50.0
MAX_STEERING_RAD = np.pi / 2
#: plausible laser range [m] (the SICK laser reads at most ~80 m)
MAX_RANGE_M = 200.0
#: plausible |x|, |y| of a GPS position [m]: the run stays within 183.6 m and 222.6 m of the
#: origin the data's authors chose near its start; a corrupt 1e308 is not a position
MAX_GPS_POSITION_M = 1.0e4
#: ``inputs.dat`` may end this much before the last tree detection [s] (it ends after it), and
#: start this much after the first (it starts 0.121 s after it)
INPUTS_END_TOLERANCE_S = 0.5
#: ``gps.dat`` may start this much after the first tree detection and end this much before the
#: last [s] (it starts 0.852 s before the first and ends 0.015 s before the last; inside the run
#: GPS has gaps of up to 58 s, but the file covers the run from end to end)
GPS_SPAN_TOLERANCE_S = 1.0

GPS_NOTE = (
    "GPS positions (partial: compared only where GPS exists; no heading, yaw is a placeholder)"
)


def read_inputs_table(path: Path) -> Table:
    """``inputs.dat`` -> its rows [time s, encoder speed m/s, steering rad], values checked.

    Raises:
        DataError: malformed file, or a speed or steering angle outside the plausible range.
    """
    table = read_table(path, ("time[s]", "speed[m/s]", "steering[rad]"))
    check_range(table, 1, "speed[m/s]", -MAX_SPEED_M_S, MAX_SPEED_M_S)
    check_range(table, 2, "steering[rad]", -MAX_STEERING_RAD, MAX_STEERING_RAD, inclusive=False)
    return table


def read_inputs(path: Path) -> np.ndarray:
    """``inputs.dat`` -> (K, 3) [time s, encoder speed m/s, steering rad] (40 Hz)."""
    return np.array(read_inputs_table(path).values)


def read_measurements(path: Path) -> np.ndarray:
    """``measurements.dat`` -> (K, 4) [time s, range m, laser bearing rad (0..pi), diameter m].

    The laser bearing is returned as recorded; ``load_victoria_park`` converts it to the robot
    frame (``bearing - pi/2``).

    Raises:
        DataError: malformed file, a negative or implausible range, a bearing outside the
            laser's 0..pi or a negative diameter (naming the line).
    """
    table = read_table(path, ("time[s]", "range[m]", "bearing[rad]", "diameter[m]"))
    if np.any(table.values[:, 1] < 0):
        row = int(np.argmax(table.values[:, 1] < 0))
        raise DataError(f"{table.where(row)}: negative range", path)
    check_range(table, 1, "range[m]", 0.0, MAX_RANGE_M)
    check_range(table, 2, "bearing[rad]", 0.0, np.pi)
    check_range(table, 3, "diameter[m]", 0.0, np.inf)
    return np.array(table.values)


def read_gps(path: Path) -> np.ndarray:
    """``gps.dat`` -> (K, 3) [time s, x m, y m] (strictly increasing times)."""
    return np.array(read_gps_table(path).values)


def read_gps_table(path: Path) -> Table:
    """``gps.dat`` -> its rows [time s, x m, y m].

    Raises:
        DataError: malformed file, times not strictly increasing or a position beyond
            ``MAX_GPS_POSITION_M`` (naming the line).
    """
    table = read_table(path, ("time[s]", "x[m]", "y[m]"), stamp_order=StampOrder.INCREASING)
    check_range(table, 1, "x[m]", -MAX_GPS_POSITION_M, MAX_GPS_POSITION_M)
    check_range(table, 2, "y[m]", -MAX_GPS_POSITION_M, MAX_GPS_POSITION_M)
    return table


def is_victoria_park_folder(path: Path) -> bool:
    """True when ``path`` is a folder with ``inputs.dat`` and ``measurements.dat``."""
    path = Path(path)
    return (
        path.is_dir() and (path / "inputs.dat").is_file() and (path / "measurements.dat").is_file()
    )


def load_victoria_park(
    folder: Path,
    *,
    geometry: AckermannGeometry | None = None,
    sigma_range_m: float = SIGMA_RANGE_M,
    sigma_bearing_rad: float = SIGMA_BEARING_RAD,
    name: str | None = None,
) -> Sequence:
    """Load the Victoria Park run as a Sequence (robot frame = laser).

    Args:
        folder: folder with ``inputs.dat``, ``measurements.dat`` and (optionally) ``gps.dat``.
        geometry: vehicle geometry (default: L = 2.83, H = 0.76, a = 3.78, b = 0.50 m).
        sigma_range_m: range noise of the sightings given to the estimators [m].
        sigma_bearing_rad: bearing noise of the sightings given to the estimators [rad].
        name: sequence name (default: the folder's name).

    Returns:
        The Sequence; ground truth is GPS_PARTIAL when ``gps.dat`` exists, else NONE.

    Raises:
        DataError: a missing or malformed file (naming it and the line), or ``inputs.dat`` or
            ``gps.dat`` not covering the tree detections (a file cut short).
    """
    folder = Path(folder)
    geometry = geometry or AckermannGeometry()
    inputs_table = read_inputs_table(folder / "inputs.dat")
    inputs = np.array(inputs_table.values)
    detections = read_measurements(folder / "measurements.dat")
    first_s, last_s = float(detections[0, 0]), float(detections[-1, 0])
    measurements_path = folder / "measurements.dat"
    check_stream_start(inputs_table, first_s, measurements_path, INPUTS_END_TOLERANCE_S)
    check_stream_end(inputs_table, last_s, measurements_path, INPUTS_END_TOLERANCE_S)
    frame_stamps = np.unique(detections[:, 0])
    wTl = integrate_ackermann(inputs[:, 0], inputs[:, 1], inputs[:, 2], frame_stamps, geometry)
    range_bearing = group_sightings(
        frame_stamps,
        detections[:, 0],
        np.full(len(detections), UNKNOWN_ID, dtype=np.int64),
        detections[:, 1],
        detections[:, 2] - np.pi / 2.0,
        sigma_range_m,
        sigma_bearing_rad,
    )
    ground_truth = GroundTruth(kind=GroundTruthKind.NONE, note="no GPS file")
    gps_path = folder / "gps.dat"
    gps_coverage = 0.0
    if gps_path.is_file():
        gps_table = read_gps_table(gps_path)
        check_stream_start(gps_table, first_s, measurements_path, GPS_SPAN_TOLERANCE_S)
        check_stream_end(gps_table, last_s, measurements_path, GPS_SPAN_TOLERANCE_S)
        gps = np.array(gps_table.values)
        fixes = np.column_stack([gps[:, 1:3], np.zeros(len(gps))])
        valid, positions = interpolate_se2(gps[:, 0], fixes, frame_stamps, GPS_MAX_GAP_S)
        positions[:, 2] = 0.0  # GPS has no heading: placeholder yaw
        gps_coverage = float(np.mean(valid))
        ground_truth = GroundTruth(
            kind=GroundTruthKind.GPS_PARTIAL,
            trajectory=Trajectory.from_se2(frame_stamps[valid], positions),
            note=GPS_NOTE,
        )
    info = {
        "sensors": "wheel encoder speed + steering (Ackermann, 40 Hz); 2-D laser tree "
        "detections (range, bearing, diameter); GPS",
        "sightings": str(len(detections)),
        "association": "unknown",
        "robot_frame": f"laser, at a={geometry.laser_forward_m} m, b={geometry.laser_left_m} m "
        "from the rear axle centre",
        "gps_frame_coverage": f"{gps_coverage:.3f}",
        "sigma_range_m": str(sigma_range_m),
        "sigma_bearing_rad": str(sigma_bearing_rad),
    }
    return Sequence(
        name=name or folder.name,
        source=SOURCE,
        stamps_s=frame_stamps,
        odometry_r=odometry_from_poses(wTl),
        ground_truth=ground_truth,
        range_bearing=range_bearing,
        info=info,
    )
