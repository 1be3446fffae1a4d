"""CARMEN 2-D laser logs (Radish repository): Intel Research Lab, ACES building, and others.

Intel: recorded by Dirk Haehnel; ACES: by Patrick Beeson; both from the Robotics Data Set
Repository (Radish), Howard & Roy 2003, in the "corrected" versions distributed with the SLAM
benchmark of Kuemmerle, Steder, Dornhege, Ruhnke, Grisetti, Stachniss, Kleiner, "On measuring
the accuracy of SLAM algorithms", Autonomous Robots 27(4), 2009.

One record per line (``gzip`` or plain text), dispatched on the first token:

* ``ODOM x y theta tv rv accel timestamp host logger_timestamp``: the odometry stream.
* ``FLASER n r1..rn x y theta odom_x odom_y odom_theta timestamp host logger_timestamp``: a
  front laser scan (180 beams, 1 deg apart from -90 deg) and the robot pose at the scan.

What the files actually contain (checked on intel and aces) and how it is converted:

* In a *corrected* log, every FLASER is a keyframe whose ``x y theta`` **and**
  ``odom_x odom_y odom_theta`` both hold the pose corrected by a SLAM system (they are equal),
  and the line right after it is an ``ODOM`` with timestamp 0 that resets the odometry stream to
  that corrected pose. The raw motion between keyframes k and k+1 is therefore
  ``between(reset pose after k, last ODOM pose before k+1)`` (that ODOM carries the scan's
  stamp). The odom fields of FLASER must *not* be used as odometry there: they would hand the
  estimators the corrected poses. The corrected poses are the pseudo ground truth (not
  independent of a SLAM system: ``GroundTruthKind.PSEUDO``, said in ``GroundTruth.note``).
* In a raw log (no reset records) the FLASER odom fields are the raw odometry at the scan and
  the odometry is taken from them; there is no ground truth.
* Frames are the FLASER records in file order. The intel log's clock steps back by up to 0.86 s
  at four keyframes (file lines 5647, 10805, 11190, 12936): a stamp that does not increase is
  moved to ``STAMP_REPAIR_S`` after its predecessor and counted in ``info["stamps_repaired"]``;
  a step back larger than ``MAX_CLOCK_STEP_BACK_S`` is an error.
* Some logs print stamps with too few digits (``%g``: 6 significant digits, so many scans share
  one stamp). When more than ``LOW_RESOLUTION_FRACTION`` of the scans repeat their
  predecessor's stamp the stamps are low-resolution, not out of order: one warning, and the
  scans that share a stamp are spread evenly, in record order, up to the next distinct stamp
  (the last ones at the mean scan period of the rest, or ``NOMINAL_SCAN_PERIOD_S`` when every
  scan shares one stamp), counted in ``info["stamps_spread"]``.
* FLASER beams cover -90..90 deg: ``n`` beams are 180/n deg apart from -90 deg for even ``n``
  (the classic 180 beams, 1 deg apart) and 180/(n - 1) deg for odd ``n`` (181 or 361 beams end
  at +90 deg).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from omnislam.core.motion import MotionNoise, OdometryMotionModel
from omnislam.core.se import se2_between
from omnislam.core.types import Trajectory
from omnislam.datasets._text import iter_records, parse_float, parse_int
from omnislam.datasets.sequence import GroundTruth, GroundTruthKind, LaserScans, Sequence
from omnislam.errors import DataError

log = logging.getLogger(__name__)

SOURCE = (
    "CARMEN log from Radish (Howard & Roy 2003), corrected version of Kuemmerle et al., "
    "'On measuring the accuracy of SLAM algorithms', Autonomous Robots 27(4), 2009"
)
PSEUDO_NOTE = (
    "pseudo ground truth: keyframe poses corrected by a SLAM system (not independent; "
    "Kuemmerle et al. 2009)"
)

#: a keyframe stamp that goes back by at most this much is repaired; more is an error [s]
MAX_CLOCK_STEP_BACK_S = 5.0
#: a repaired stamp is put this far after its predecessor [s]
STAMP_REPAIR_S = 1e-3
#: FLASER beams start at -90 deg (CARMEN front laser)
FLASER_FIRST_BEAM_RAD = -np.pi / 2.0
#: more than this fraction of scans repeating the previous stamp marks a low-resolution log
LOW_RESOLUTION_FRACTION = 0.1
#: scan period assumed when a low-resolution log gives no time span at all [s]
NOMINAL_SCAN_PERIOD_S = 0.2
#: plausible FLASER range [m] (a SICK laser reads at most ~80 m; intel: at most 81.83, aces: 50);
#: FLASER states no maximum, so a corrupt 1e9 would otherwise become the "no return" range
MAX_RANGE_M = 200.0
#: plausible |x|, |y| [m] and |theta| [rad] of an ODOM or FLASER pose: intel reaches 16.6 m,
#: 22.6 m and 3.25 rad, aces 23.9 m, 40.0 m and 3.19 rad (the corrected poses and the raw
#: odometry alike); a building's log stays far inside, a corrupt 1e300 does not (the limits
#: leave room for a larger site and an odometry heading that is not wrapped)
MAX_POSITION_M = 1.0e4
MAX_HEADING_RAD = 1.0e3


def flaser_angles_rad(beams: int) -> np.ndarray:
    """Beam angles of a FLASER scan of ``beams`` beams over -90..90 deg (module docstring)."""
    spacing_deg = 180.0 / (beams - 1) if beams % 2 and beams > 1 else 180.0 / beams
    return FLASER_FIRST_BEAM_RAD + np.deg2rad(np.arange(beams) * spacing_deg)


def spread_low_resolution_stamps(stamps_s: np.ndarray) -> tuple[np.ndarray, int]:
    """Spread the scans that share a printed stamp evenly up to the next distinct stamp.

    Returns:
        (stamps (N,), number of scans moved). Groups are runs of equal stamps in file order;
        a clock step back between groups is left for ``repair_stamps`` to judge.
    """
    stamps = np.asarray(stamps_s, dtype=float)
    n = len(stamps)
    starts = np.flatnonzero(np.r_[True, np.diff(stamps) != 0])
    ends = np.r_[starts[1:], n]
    last = starts[-1]
    span = stamps[last] - stamps[0]
    period = span / last if last > 0 and span > 0 else NOMINAL_SCAN_PERIOD_S
    out = stamps.copy()
    for a, b in zip(starts.tolist(), ends.tolist(), strict=True):
        t1 = stamps[b] if b < n else stamps[a] + (b - a) * period
        out[a:b] = stamps[a] + (t1 - stamps[a]) * np.arange(b - a) / (b - a)
    return out, int(n - len(starts))


@dataclass(frozen=True, slots=True)
class CarmenLog:
    """The records of a CARMEN log that omnislam uses, in file order.

    Attributes:
        stamps_s: (N,) FLASER timestamps as recorded [s].
        lines: (N,) 1-based file line of each FLASER record.
        scan_ranges_m: (N, B) ranges.
        scan_poses: (N, 3) ``x y theta`` of each FLASER (corrected pose in corrected logs).
        odom_at_scan: (N, 3) raw-odometry-chain pose at each scan (last ODOM before the FLASER,
            or the FLASER's odom fields when no ODOM precedes it).
        odom_after_scan: (N, 3) pose the odometry chain continues from after each scan (the reset
            ODOM of a corrected log, else ``odom_at_scan``).
        corrected: True when the log has the reset records of a corrected log.
    """

    stamps_s: np.ndarray
    lines: np.ndarray
    scan_ranges_m: np.ndarray
    scan_poses: np.ndarray
    odom_at_scan: np.ndarray
    odom_after_scan: np.ndarray
    corrected: bool


def _parse_pose(tokens: list[str], path: Path, line: int, what: str) -> list[float]:
    """``x y theta`` of a record, each finite and within ``MAX_POSITION_M``/``MAX_HEADING_RAD``.

    Raises:
        DataError: naming the line and the field.
    """
    pose = [parse_float(t, path, line, what) for t in tokens]
    for value, limit, name in zip(
        pose,
        (MAX_POSITION_M, MAX_POSITION_M, MAX_HEADING_RAD),
        ("x[m]", "y[m]", "theta[rad]"),
        strict=True,
    ):
        if abs(value) > limit:
            raise DataError(
                f"line {line}: {what} {name} {value!r} is outside the plausible range "
                f"[{-limit:g}, {limit:g}]",
                path,
            )
    return pose


def read_carmen_log(path: Path) -> CarmenLog:
    """Parse the ODOM and FLASER records of a CARMEN log (other records are skipped).

    Raises:
        DataError: a malformed ODOM/FLASER record (naming the line): a field that is not a
            finite number, a beam count that is not positive, a range outside
            ``[0, MAX_RANGE_M]``, a pose beyond ``MAX_POSITION_M`` or ``MAX_HEADING_RAD``;
            scans of different beam counts, or no FLASER record.
    """
    path = Path(path)
    stamps: list[float] = []
    lines: list[int] = []
    ranges: list[list[float]] = []
    poses: list[list[float]] = []
    at_scan: list[list[float]] = []
    after_scan: list[list[float]] = []
    last_odom: list[float] | None = None
    previous_was_scan = False
    resets = 0
    beams: int | None = None
    for line, fields in iter_records(path):
        tag = fields[0]
        if tag == "ODOM":
            if len(fields) < 8:
                raise DataError(
                    f"line {line}: ODOM needs at least 7 fields, got {len(fields) - 1}", path
                )
            pose = _parse_pose(fields[1:4], path, line, "ODOM pose")
            for token, what in zip(fields[4:7], ("tv", "rv", "accel"), strict=True):
                parse_float(token, path, line, f"ODOM {what}")
            stamp = parse_float(fields[7], path, line, "ODOM timestamp")
            if previous_was_scan and stamp == 0.0:
                after_scan[-1] = pose
                resets += 1
            last_odom = pose
            previous_was_scan = False
        elif tag == "FLASER":
            if len(fields) < 2:
                raise DataError(f"line {line}: FLASER without a beam count", path)
            n = parse_int(fields[1], path, line, "beam count")
            if n <= 0:
                raise DataError(f"line {line}: FLASER beam count {n} is not positive", path)
            if len(fields) < n + 9:
                raise DataError(
                    f"line {line}: FLASER with {n} beams needs {n + 9} fields, "
                    f"got {len(fields) - 1}"
                    " (file truncated?)",
                    path,
                )
            if beams is not None and n != beams:
                raise DataError(f"line {line}: FLASER has {n} beams, earlier ones {beams}", path)
            beams = n
            scan = [parse_float(t, path, line, "range") for t in fields[2 : 2 + n]]
            outside = [r for r in scan if not 0.0 <= r <= MAX_RANGE_M]
            if outside:
                raise DataError(
                    f"line {line}: range {outside[0]!r} is outside the plausible "
                    f"[0, {MAX_RANGE_M:g}] m",
                    path,
                )
            ranges.append(scan)
            pose = _parse_pose(fields[2 + n : 5 + n], path, line, "pose")
            odom = _parse_pose(fields[5 + n : 8 + n], path, line, "odom pose")
            stamps.append(parse_float(fields[8 + n], path, line, "timestamp"))
            lines.append(line)
            poses.append(pose)
            at_scan.append(last_odom if last_odom is not None else odom)
            after_scan.append(at_scan[-1])
            previous_was_scan = True
        else:
            previous_was_scan = False
    if not stamps:
        raise DataError("no FLASER records (not a CARMEN laser log?)", path)
    corrected = resets > 0
    if not corrected:  # raw log: the FLASER odom fields are the raw odometry at the scan
        odom_fields = []
        for _, fields in iter_records(path):
            if fields[0] == "FLASER":
                n = int(fields[1])
                odom_fields.append([float(t) for t in fields[5 + n : 8 + n]])
        at_scan = after_scan = odom_fields
    return CarmenLog(
        stamps_s=np.asarray(stamps),
        lines=np.asarray(lines, dtype=np.int64),
        scan_ranges_m=np.asarray(ranges),
        scan_poses=np.asarray(poses),
        odom_at_scan=np.asarray(at_scan),
        odom_after_scan=np.asarray(after_scan),
        corrected=corrected,
    )


def repair_stamps(stamps_s: np.ndarray, lines: np.ndarray, path: Path) -> tuple[np.ndarray, int]:
    """Make keyframe stamps strictly increasing by moving small clock steps back forward.

    Returns:
        (stamps (N,), number of stamps moved).

    Raises:
        DataError: a step back larger than ``MAX_CLOCK_STEP_BACK_S`` (naming the line).
    """
    out = np.array(stamps_s, dtype=float)
    repaired = 0
    for k in range(1, len(out)):
        if out[k] > out[k - 1]:
            continue
        if stamps_s[k] < out[k - 1] - MAX_CLOCK_STEP_BACK_S:
            raise DataError(
                f"line {int(lines[k])}: time {float(stamps_s[k])!r} is earlier than "
                f"{float(out[k - 1])!r} on "
                f"line {int(lines[k - 1])} by more than {MAX_CLOCK_STEP_BACK_S} s",
                path,
            )
        out[k] = out[k - 1] + STAMP_REPAIR_S
        repaired += 1
    return out, repaired


def is_carmen_log(path: Path) -> bool:
    """True when ``path`` is a file named ``*.log`` or ``*.log.gz`` (a CARMEN log)."""
    path = Path(path)
    return path.is_file() and (path.name.endswith(".log") or path.name.endswith(".log.gz"))


def parse_odometry_noise(text: str) -> MotionNoise:
    """``"a_vv,a_vw,a_wv,a_ww,floor_trans_m,floor_rot_rad"`` -> the MotionNoise it states.

    Raises:
        ValueError: not six non-negative numbers.
    """
    values = [float(v) for v in text.split(",")]
    if len(values) != 6 or min(values) < 0:
        raise ValueError(
            "odometry_noise needs six non-negative numbers: "
            "a_vv,a_vw,a_wv,a_ww,floor_trans_m,floor_rot_rad"
        )
    a_vv, a_vw, a_wv, a_ww, floor_t, floor_r = values
    return MotionNoise(
        a_vv=a_vv, a_vw=a_vw, a_wv=a_wv, a_ww=a_ww, min_sigma=(floor_r, floor_t, floor_r)
    )


def load_carmen(
    path: Path, *, name: str | None = None, odometry_noise: MotionNoise | None = None
) -> Sequence:
    """Load a CARMEN laser log as a Sequence (one frame per FLASER keyframe).

    Args:
        path: ``*.log`` or ``*.log.gz`` file.
        name: sequence name (default: the file name without ``.log[.gz]``).
        odometry_noise: the log's odometry noise, stated with every frame
            (``Sequence.odometry_covariance_r`` from ``OdometryMotionModel.covariance``, thesis
            eq. 4.41) -- a sensor noise, set per dataset by the registry (``--set
            odometry_noise=a_vv,a_vw,a_wv,a_ww,floor_trans_m,floor_rot_rad``); None leaves it
            to each estimator's motion model.

    Returns:
        The Sequence with laser scans, odometry between keyframes, and (for corrected logs) the
        corrected keyframe poses as PSEUDO ground truth.

    Raises:
        DataError: a malformed record or a large clock step back (naming the line).
    """
    path = Path(path)
    record = read_carmen_log(path)
    stamps, spread = record.stamps_s, 0
    repeats = int(np.sum(np.diff(stamps) == 0))
    if repeats > LOW_RESOLUTION_FRACTION * len(stamps):
        stamps, spread = spread_low_resolution_stamps(stamps)
        log.warning(
            "%s: %d of %d scans share their stamp with the previous one (stamps printed with "
            "too few digits); their times are spread evenly between distinct stamps",
            path,
            repeats,
            len(stamps),
        )
    stamps, repaired = repair_stamps(stamps, record.lines, path)
    if repaired:
        log.warning("%s: %d keyframe stamps out of order were moved forward", path, repaired)
    odometry = np.zeros((len(stamps), 3))
    if len(stamps) > 1:
        odometry[1:] = se2_between(record.odom_after_scan[:-1], record.odom_at_scan[1:])
    beams = record.scan_ranges_m.shape[1]
    laser = LaserScans(
        angles_rad=flaser_angles_rad(beams),
        ranges_m=record.scan_ranges_m,
        max_range_m=float(np.max(record.scan_ranges_m)),
    )
    if record.corrected:
        ground_truth = GroundTruth(
            kind=GroundTruthKind.PSEUDO,
            trajectory=Trajectory.from_se2(stamps, record.scan_poses),
            note=PSEUDO_NOTE,
        )
        initial_pose = record.scan_poses[0]
    else:
        ground_truth = GroundTruth(kind=GroundTruthKind.NONE, note="raw log: no ground truth")
        initial_pose = None
    stem = path.name.removesuffix(".gz").removesuffix(".log")
    info = {
        "sensors": f"wheel odometry; front laser ({beams} beams, 180 deg)",
        "scans": str(len(stamps)),
        "corrected_log": str(record.corrected).lower(),
        "odometry": "raw ODOM chain between corrected keyframes"
        if record.corrected
        else "FLASER odom fields",
        "stamps_repaired": str(repaired),
        "stamps_spread": str(spread),
        "odometry_noise": "not stated" if odometry_noise is None else f"stated ({odometry_noise})",
    }
    odometry_cov = None
    if odometry_noise is not None:
        model = OdometryMotionModel(odometry_noise)
        odometry_cov = np.array([model.covariance(delta) for delta in odometry])
    return Sequence(
        name=name or stem,
        source=SOURCE,
        stamps_s=stamps,
        odometry_r=odometry,
        ground_truth=ground_truth,
        initial_pose_w=initial_pose,
        laser=laser,
        info=info,
        odometry_covariance_r=odometry_cov,
    )
