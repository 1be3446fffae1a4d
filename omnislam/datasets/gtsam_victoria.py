"""gtsam's pre-processed Victoria Park graph file (``gtsam/Data/victoria_park.txt``).

The file ships inside the gtsam wheel (find it with
``gtsam.findExampleDataFile("victoria_park.txt")``); it is the Victoria Park run of Guivant &
Nebot (IEEE T-RA 17(3), 2001) reduced by the GTSAM authors to odometry factors and landmark
sightings with data association solved. One line per factor (format of gtsam's
``gtsam/slam/dataset.cpp``):

* ``ODOMETRY i j dx dy dtheta c11 c12 c13 c22 c23 c33``: pose j seen from pose i with the upper
  triangle of its 3x3 *covariance* (gtsam's ``NoiseFormatCOV``, detected automatically by
  ``load2D``: here diag(1e-4, 4e-6, 4e-6), i.e. sigmas 1 cm, 2 mm, 2 mrad).
* ``LANDMARK i l x y v1 v2 v3``: landmark l at (x, y) in the frame of pose i. gtsam converts it to
  bearing = atan2(y, x), range = hypot(x, y) and, when v1 == v3, to sigmas
  bearing = sqrt(v1 / 10), range = sqrt(v1) ("the x-y covariance ... describes the uncertainty
  at a range of 10 m"); with v1 = 0.4 that is 0.2 rad and 0.63 m. The same is done here so that
  omnislam's estimators see what gtsam's examples see.
* ``BR i l bearing range sigma_bearing sigma_range``: a bearing-range sighting (accepted too).

Poses and landmarks share one id space. Frames are the poses in chain order; the file has no
time stamps, so frame k gets the nominal stamp k [s]. There is no ground truth, and loaders never
estimate: the Sequence's ground truth is NONE, and ``omnislam run`` scores against the reference
solution ``omnislam.harness.reference`` computes and caches (the warm-started LM optimum of this
file's graph, ``GroundTruthKind.REFERENCE``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from omnislam.core.types import UNKNOWN_ID
from omnislam.datasets._common import Association, group_sightings
from omnislam.datasets._text import iter_records, parse_float, parse_int
from omnislam.datasets.sequence import GroundTruth, GroundTruthKind, Sequence
from omnislam.errors import DataError

SOURCE = (
    "gtsam example data victoria_park.txt (GTSAM authors), from ACFR Victoria Park: Guivant & "
    "Nebot, IEEE T-RA 17(3), 2001"
)
FILE_NAME = "victoria_park.txt"

#: fields after the tag, per record type
_WIDTHS = {"ODOMETRY": 11, "LANDMARK": 7, "BR": 6}
#: plausible length of one odometry step and of one sighting [m] (victoria_park.txt: at most
#: 1.5 m and 21 m); anything longer is a corrupt file, not a fast car or a far tree
MAX_STEP_M = 1000.0
MAX_RANGE_M = 1000.0


def find_gtsam_file() -> Path | None:
    """Path of gtsam's ``victoria_park.txt``, or None when gtsam (or the file) is missing."""
    try:
        import gtsam
    except ImportError:
        return None
    try:
        return Path(gtsam.findExampleDataFile(FILE_NAME))
    except (RuntimeError, ValueError, IndexError):
        return None


def read_gtsam_graph(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Parse a gtsam 2-D graph file with ODOMETRY, LANDMARK and BR records.

    Returns:
        (edges (E, 2) int [i, j], deltas (E, 3) [dx, dy, dtheta], edge_sigmas (E, 3) [m, m, rad],
        sightings (S, 6) [pose id, landmark id, range m, bearing rad, sigma_range m,
        sigma_bearing rad]) in file order.

    Raises:
        DataError: unknown record, wrong field count, non-numeric field, a covariance or sigma
            that is not positive, an implausible step or range, ODOMETRY records that do not
            form one chain through distinct poses, a sighting from a pose outside the chain or
            of a landmark whose id is a pose's (naming the line).
    """
    edges: list[tuple[int, int]] = []
    deltas: list[list[float]] = []
    sigmas: list[list[float]] = []
    sightings: list[list[float]] = []
    edge_lines: list[int] = []
    sighting_lines: list[int] = []
    for line, fields in iter_records(path):
        tag = fields[0]
        if tag not in _WIDTHS:
            raise DataError(
                f"line {line}: unknown record {tag!r} (expected {', '.join(_WIDTHS)})", path
            )
        if len(fields) - 1 != _WIDTHS[tag]:
            raise DataError(
                f"line {line}: {tag} needs {_WIDTHS[tag]} fields, got {len(fields) - 1}", path
            )
        i = parse_int(fields[1], path, line, "id")
        j = parse_int(fields[2], path, line, "id")
        values = [parse_float(t, path, line) for t in fields[3:]]
        if tag == "ODOMETRY":
            c11, c12, c13, c22, c23, c33 = values[3:]
            cov = np.array([[c11, c12, c13], [c12, c22, c23], [c13, c23, c33]])
            if np.any(np.linalg.eigvalsh(cov) <= 0):
                raise DataError(f"line {line}: odometry covariance is not positive definite", path)
            if np.hypot(values[0], values[1]) > MAX_STEP_M:
                raise DataError(
                    f"line {line}: odometry step of {np.hypot(values[0], values[1]):g} m is "
                    f"longer than the plausible {MAX_STEP_M:g} m",
                    path,
                )
            edges.append((i, j))
            edge_lines.append(line)
            deltas.append(values[:3])
            sigmas.append(list(np.sqrt(np.diag(cov))))
        elif tag == "LANDMARK":
            x, y, v1, v2, v3 = values
            if v1 <= 0 or v3 <= 0 or v1 * v3 - v2 * v2 <= 0:
                raise DataError(f"line {line}: landmark covariance is not positive definite", path)
            if abs(v1 - v3) < 1e-4:  # gtsam dataset.cpp conversion
                sigma_bearing, sigma_range = np.sqrt(v1 / 10.0), np.sqrt(v1)
            else:
                sigma_bearing, sigma_range = 1.0, 1.0
            range_m = float(np.hypot(x, y))
            sightings.append([i, j, range_m, np.arctan2(y, x), sigma_range, sigma_bearing])
        else:  # BR
            bearing, range_m, sigma_bearing, sigma_range = values
            if sigma_bearing <= 0 or sigma_range <= 0:
                raise DataError(f"line {line}: BR sigmas must be positive", path)
            sightings.append([i, j, range_m, bearing, sigma_range, sigma_bearing])
        if tag != "ODOMETRY":
            if not 0 < range_m <= MAX_RANGE_M:
                raise DataError(
                    f"line {line}: landmark range {range_m:g} m is outside the plausible "
                    f"(0, {MAX_RANGE_M:g}]",
                    path,
                )
            sighting_lines.append(line)
    if not edges:
        raise DataError("no ODOMETRY records", path)
    _check_graph(edges, edge_lines, sightings, sighting_lines, path)
    return (
        np.asarray(edges, dtype=np.int64),
        np.asarray(deltas, dtype=float),
        np.asarray(sigmas, dtype=float),
        np.asarray(sightings, dtype=float).reshape(-1, 6),
    )


def _check_graph(
    edges: list[tuple[int, int]],
    edge_lines: list[int],
    sightings: list[list[float]],
    sighting_lines: list[int],
    path: Path,
) -> None:
    """Raise DataError unless the ODOMETRY records form one chain through distinct poses and
    every sighting is from a pose of the chain, of a landmark whose id is no pose's (poses and
    landmarks share one id space); the message names the line."""
    first_line = {edges[0][0]: edge_lines[0]}
    for k, ((i, j), line) in enumerate(zip(edges, edge_lines, strict=True)):
        if k and i != edges[k - 1][1]:
            raise DataError(
                f"line {line}: ODOMETRY starts at pose {i}, the chain is at {edges[k - 1][1]}",
                path,
            )
        if j in first_line:
            raise DataError(
                f"line {line}: ODOMETRY returns to pose {j} (already in the chain on line "
                f"{first_line[j]})",
                path,
            )
        first_line[j] = line
    for (pose, landmark, *_), line in zip(sightings, sighting_lines, strict=True):
        if int(pose) not in first_line:
            raise DataError(
                f"line {line}: the sighting refers to pose {int(pose)}, which is not in the "
                "odometry chain",
                path,
            )
        if int(landmark) in first_line:
            raise DataError(
                f"line {line}: landmark id {int(landmark)} is a pose of the odometry chain "
                f"(line {first_line[int(landmark)]}; poses and landmarks share one id space)",
                path,
            )


def is_gtsam_graph_file(path: Path) -> bool:
    """True when ``path`` is a text file whose first record is ODOMETRY, LANDMARK or BR."""
    path = Path(path)
    if not path.is_file():
        return False
    try:
        with open(path, encoding="utf-8", errors="replace") as stream:
            for line in stream:
                if line.strip() and not line.lstrip().startswith("#"):
                    return line.split()[0] in _WIDTHS
    except OSError:
        return False
    return False


def load_gtsam_victoria(
    path: Path | None = None,
    *,
    association: Association = Association.KNOWN,
    name: str | None = None,
    sigma_range_m: float | None = None,
    sigma_bearing_rad: float | None = None,
    odometry_sigma_theta_rad: float | None = None,
) -> Sequence:
    """Load gtsam's ``victoria_park.txt`` (or any file in that format) as a Sequence.

    Args:
        path: the file; None finds gtsam's copy.
        association: KNOWN keeps the file's landmark ids, UNKNOWN hides them.
        name: sequence name (default: the file's stem).
        sigma_range_m: range noise of the sightings given to the estimators instead of the
            file's [m] (``--set sigma_range_m=...``, as for the raw ``victoria-park``); None
            keeps the file's, gtsam's ``load2D`` conversion. The reference
            (``harness.reference``) is always the optimum with the file's noise.
        sigma_bearing_rad: bearing noise of the sightings given to the estimators instead of
            the file's [rad] (``--set sigma_bearing_rad=...``); None keeps the file's.
        odometry_sigma_theta_rad: heading std of every odometry step given to the estimators
            instead of the file's [rad] (the translation sigmas stay the file's); None keeps it.

    Returns:
        The Sequence: one frame per pose of the odometry chain (stamp = pose index), each frame's
        sightings with the file's noise; ground truth NONE (see the module docstring).

    Raises:
        DataError: file missing or malformed, or the ODOMETRY records not forming one chain.
    """
    if path is None:
        path = find_gtsam_file()
        if path is None:
            raise DataError(f"gtsam's {FILE_NAME} not found: install the 'graph' extra (gtsam)")
    path = Path(path)
    edges, deltas, sigmas, sightings = read_gtsam_graph(path)  # one chain, checked
    pose_ids = np.append(edges[:, 0], edges[-1, 1])
    frame_of_pose = {int(p): k for k, p in enumerate(pose_ids)}
    frames = np.array([frame_of_pose[int(p)] for p in sightings[:, 0]], dtype=np.int64)
    stamps = np.arange(len(pose_ids), dtype=float)
    if odometry_sigma_theta_rad is not None:
        sigmas = sigmas.copy()
        sigmas[:, 2] = odometry_sigma_theta_rad
    odometry = np.vstack([np.zeros(3), deltas])
    # the file gives each sighting its own sigma; gtsam's LANDMARK records all share one
    sigma_range = float(np.median(sightings[:, 4])) if len(sightings) else 1.0
    sigma_bearing = float(np.median(sightings[:, 5])) if len(sightings) else 1.0
    if sigma_range_m is not None:
        sigma_range = sigma_range_m
    if sigma_bearing_rad is not None:
        sigma_bearing = sigma_bearing_rad
    ids = sightings[:, 1].astype(np.int64)
    range_bearing = group_sightings(
        stamps,
        stamps[frames],
        ids,
        sightings[:, 2],
        sightings[:, 3],
        sigma_range,
        sigma_bearing,
        association,
    )
    info = {
        "sensors": "odometry factors; landmark sightings (x, y in the pose frame) with ids",
        "poses": str(len(pose_ids)),
        "landmarks": str(len(np.unique(ids))),
        "sightings": str(len(sightings)),
        "association": association.value,
        "odometry_sigmas": " ".join(f"{s:.3g}" for s in np.median(sigmas, axis=0)),
        "sigma_range_m": f"{sigma_range:.3g}",
        "sigma_bearing_rad": f"{sigma_bearing:.3g}",
        "stamps": "nominal: frame index (the file has no times)",
        "unknown_id": str(UNKNOWN_ID),
    }
    return Sequence(
        name=name or path.stem,
        source=SOURCE,
        stamps_s=stamps,
        odometry_r=odometry,
        ground_truth=GroundTruth(
            kind=GroundTruthKind.NONE,
            note="no ground truth; runs are scored against the warm-started LM optimum "
            "(omnislam.harness.reference)",
        ),
        range_bearing=range_bearing,
        odometry_covariance_r=np.concatenate(
            [np.eye(3)[None], np.einsum("ki,ij->kij", np.square(sigmas), np.eye(3))]
        ),
        info=info,
    )
