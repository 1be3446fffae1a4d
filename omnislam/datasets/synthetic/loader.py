"""Read a synthetic folder (format: ``omnislam.datasets.synthetic.writer``) as a Sequence.

Images are read on demand (``Sequence.image_loader``); per-pixel ground truth is read with
``read_ground_truth_maps`` or, for many frames, a ``SyntheticFolder`` that keeps the world and
the calibration in memory.
"""

from __future__ import annotations

import enum
import io
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

import numpy as np

from omnislam._files import NPZ_ERRORS, npz_reason
from omnislam.core.se import se2_from_se3
from omnislam.core.types import UNKNOWN_ID, PriorMap, RangeBearing
from omnislam.datasets._common import Association
from omnislam.datasets._text import Table, check_integers, check_range, check_unique
from omnislam.datasets.sequence import (
    GroundTruth,
    GroundTruthKind,
    LaserRole,
    LaserScans,
    Sequence,
)
from omnislam.datasets.synthetic.hit_distances import plane_distances
from omnislam.datasets.synthetic.realism import Realism
from omnislam.datasets.synthetic.world import MAX_COORDINATE_M
from omnislam.datasets.synthetic.writer import FORMAT_NAME, FORMAT_VERSION, frame_name
from omnislam.errors import DataError

_E = TypeVar("_E", bound=enum.Enum)

#: plausible odometry step of one frame (10 Hz) [m] and [rad]: the presets' largest, measured
#: and true, are 0.073 m (campus1500) and 0.067 rad (demo); 10 m and pi leave a margin of over
#: 100x and 40x, and a corrupt 1e308 is not a step
MAX_STEP_M = 10.0
MAX_STEP_RAD = math.pi
#: a pole sighting's range may exceed the laser's ``max_range_m`` by this much (range noise:
#: sigma 0.01 m in every preset) [m]
POLE_RANGE_MARGIN_M = 1.0


def is_synthetic_folder(path: str | Path) -> bool:
    """True when ``path`` is a folder written by ``omnislam dataset synth``: its ``meta.json``
    names the format, or it holds a ``meta.json`` and a ``world.json`` (the metadata is then
    malformed, and ``load_synthetic`` says how)."""
    meta = Path(path) / "meta.json"
    try:
        doc = json.loads(meta.read_text())
    except (OSError, ValueError):
        doc = None
    if isinstance(doc, dict) and "format" in doc:
        return doc["format"] == FORMAT_NAME
    return meta.is_file() and (Path(path) / "world.json").is_file()


def _read_meta(folder: Path) -> dict[str, object]:
    path = folder / "meta.json"
    try:
        meta = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise DataError(f"cannot read synthetic metadata: {exc}", path) from exc
    if not isinstance(meta, dict):
        raise DataError(f"malformed: expected a JSON object, found {type(meta).__name__}", path)
    if "format" not in meta:
        raise DataError("key 'format' missing", path)
    if meta["format"] != FORMAT_NAME:
        raise DataError(f"not an {FORMAT_NAME} folder", path)
    if meta.get("version") != FORMAT_VERSION:
        raise DataError(f"unsupported format version {meta.get('version')!r}", path)
    missing = [key for key in ("preset", "seed", "source") if key not in meta]
    if missing:
        raise DataError(f"key {missing[0]!r} missing", path)
    return meta


def _read_csv(path: Path, columns: int, *, finite: bool = True) -> Table:
    """Numeric CSV with one header line -> its (rows, columns) float values and line numbers.

    Raises:
        DataError: naming the file: unreadable, no header, a wrong column count, a value that
            is not a number, or (``finite``) the line of the first NaN or infinite value.
    """
    try:
        with path.open() as handle:
            header = handle.readline()
            body = handle.read()
        # a header alone is a valid empty table (corridor21 has no poles): no loadtxt warning
        data = (
            np.loadtxt(io.StringIO(body), delimiter=",", ndmin=2)
            if body.strip()
            else np.empty((0, columns))
        )
    except (OSError, ValueError) as exc:
        raise DataError(f"cannot parse CSV: {exc}", path) from exc
    if not header.strip():
        raise DataError("missing header line", path)
    data = data.reshape(-1, columns) if data.size == 0 else data
    if data.shape[1] != columns:
        raise DataError(f"expected {columns} columns, got {data.shape[1]}", path)
    # the lines np.loadtxt read: every line after the header that is not blank or a comment
    numbers = [
        number
        for number, line in enumerate(body.splitlines(), start=2)
        if line.split("#", 1)[0].strip()
    ]
    table = Table(path, data, np.asarray(numbers, dtype=np.int64).reshape(data.shape[0]))
    if finite and not np.all(np.isfinite(data)):
        row = int(np.argmax(~np.all(np.isfinite(data), axis=1)))
        raise DataError(f"{table.where(row)}: NaN or infinite value", path)
    return table


@dataclass(frozen=True, slots=True)
class GroundTruthMaps:
    """Per-pixel ground truth of one image.

    Attributes:
        points_w: (H, W, 3) float32 world point seen by each pixel centre [m]; NaN none.
        surface_ids: (H, W) int32 surface id (``World.quads`` index); -1 none.
    """

    points_w: np.ndarray
    surface_ids: np.ndarray


class SyntheticFolder:
    """A synthetic folder with its world, calibration and true poses loaded once."""

    def __init__(self, path: str | Path) -> None:
        from omnislam.camera.io import load_rig
        from omnislam.datasets.synthetic.world import World
        from omnislam.datasets.trajectory_io import read_tum

        self.path = Path(path)
        self.meta = _read_meta(self.path)
        world_path = self.path / "world.json"
        try:
            text = world_path.read_text()
        except (OSError, UnicodeDecodeError) as exc:
            raise DataError(f"cannot read world: {exc}", world_path) from exc
        self.world = World.from_json(text, world_path)
        self.quads = self.world.arrays()
        calibration = self.path / "calibration.yaml"
        self.rig = load_rig(calibration) if calibration.exists() else None
        self.groundtruth = read_tum(self.path / "groundtruth.tum")
        positions = self.groundtruth.poses_w[:, :3, 3]
        far = ~np.all(np.abs(positions) <= MAX_COORDINATE_M, axis=1)
        if far.any():
            k = int(np.argmax(far))
            raise DataError(
                f"stamp {float(self.groundtruth.stamps_s[k])!r}: position "
                f"{positions[k].tolist()} is beyond {MAX_COORDINATE_M:g} m",
                self.path / "groundtruth.tum",
            )
        self._pixel_rays_r: np.ndarray | None = None  # (H, W, 3), computed on first use

    def _rays_r_at(self, rows: np.ndarray, cols: np.ndarray, shape: tuple[int, int]
                   ) -> np.ndarray:
        """Robot-frame rays of pixel centres: the camera is the same in every frame, so the
        rays of every pixel are computed once (``ground_truth_maps`` of a whole run spent
        two thirds of its time unprojecting the same pixels again)."""
        assert self.rig is not None
        if self._pixel_rays_r is None or self._pixel_rays_r.shape[:2] != shape:
            r, c = np.indices(shape).reshape(2, -1)
            pixels = np.column_stack([c, r]).astype(float)
            self._pixel_rays_r = self.rig.rays_r(pixels).reshape(*shape, 3)
        return self._pixel_rays_r[rows, cols]

    def surface_ids(self, index: int) -> np.ndarray:
        """(H, W) int32 surface ids of frame ``index``'s image."""
        path = self.path / "gt" / f"{frame_name(index)}.npz"
        try:
            with np.load(path, allow_pickle=False) as data:
                ids = np.asarray(data["surface_id"], dtype=np.int32)
        except NPZ_ERRORS as exc:
            raise DataError(f"cannot read ground-truth map ({npz_reason(exc)})", path) from None
        except (TypeError, ValueError) as exc:
            raise DataError(f"surface_id is not an integer array ({exc})", path) from None
        if ids.ndim != 2:
            raise DataError(f"surface_id is {ids.shape}, expected (height, width)", path)
        bad = (ids < -1) | (ids >= len(self.quads))
        if bad.any():
            raise DataError(
                f"surface id {int(ids[bad][0])} is not a quad of world.json "
                f"(-1 or 0 to {len(self.quads) - 1})",
                path,
            )
        return ids

    def ground_truth_maps(self, index: int) -> GroundTruthMaps:
        """World points and surface ids of frame ``index`` (see ``writer`` for how)."""
        if self.rig is None:
            raise DataError("the folder has no camera", self.path)
        ids = self.surface_ids(index)
        height, width = ids.shape
        rows, cols = np.nonzero(ids >= 0)
        points = np.full((height, width, 3), np.nan, dtype=np.float32)
        points[rows, cols] = self._points_at(index, ids, rows, cols)
        return GroundTruthMaps(points_w=points, surface_ids=ids)

    def pixel_points(self, index: int, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """World points seen by some pixel centres of frame ``index``'s image.

        ``ground_truth_maps(index).points_w[rows, cols]``, bit for bit, computed at those
        pixels only: the true points of a few hundred keypoints cost the surface-id map's
        read instead of intersecting every pixel's ray.

        Args:
            index: frame index.
            rows: (K,) integer pixel-centre rows (``v``) in the image.
            cols: (K,) integer pixel-centre columns (``u``) in the image.

        Returns:
            (K, 3) float32 world points [m]; NaN where the pixel sees nothing.

        Raises:
            DataError: no camera, an unreadable map, a pixel outside it.
        """
        if self.rig is None:
            raise DataError("the folder has no camera", self.path)
        ids = self.surface_ids(index)
        rows = np.asarray(rows, dtype=np.int64).reshape(-1)
        cols = np.asarray(cols, dtype=np.int64).reshape(-1)
        height, width = ids.shape
        if rows.size and (rows.min() < 0 or rows.max() >= height or cols.min() < 0
                          or cols.max() >= width):
            raise DataError(
                f"pixel outside the {width}x{height} ground-truth map of frame {index}",
                self.path / "gt" / f"{frame_name(index)}.npz",
            )
        return self._points_at(index, ids, rows, cols)

    def _points_at(self, index: int, ids: np.ndarray, rows: np.ndarray, cols: np.ndarray
                   ) -> np.ndarray:
        """(K, 3) float32 world points of pixel centres ``(rows, cols)`` given the frame's
        surface-id map: each pixel's ray intersected with the plane of its surface (NaN: none).
        Every operation is per pixel, so any subset of pixels gets the same bits."""
        assert self.rig is not None
        wTr = self.groundtruth.poses_w[index]
        rays_w = self._rays_r_at(rows, cols, ids.shape) @ wTr[:3, :3].T
        origin_w = wTr[:3, :3] @ self.rig.viewpoint_r + wTr[:3, 3]
        hit = ids[rows, cols].astype(np.int64)
        seen = hit >= 0
        t = plane_distances(self.quads, origin_w, rays_w[seen], hit[seen])
        points = np.full((rows.shape[0], 3), np.nan, dtype=np.float32)
        points[seen] = origin_w + t[:, None] * rays_w[seen]
        return points

    def world_points(self, index: int, pixels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Exact world points seen at sub-pixel locations of frame ``index``'s image.

        The ray of each pixel (e.g. a SIFT keypoint) is intersected with the plane of the
        surface seen at the nearest pixel centre, so the point is exact on the surface's plane
        (wrong only within half a pixel of a depth edge).

        Args:
            index: frame index.
            pixels: (K, 2) ``[u, v]`` [px].

        Returns:
            ``(points_w (K, 3) [m], NaN where nothing is seen; surface_ids (K,) int, -1)``.
        """
        if self.rig is None:
            raise DataError("the folder has no camera", self.path)
        ids_map = self.surface_ids(index)
        pixels = np.asarray(pixels, dtype=float).reshape(-1, 2)
        cols = np.clip(np.round(pixels[:, 0]).astype(np.int64), 0, ids_map.shape[1] - 1)
        rows = np.clip(np.round(pixels[:, 1]).astype(np.int64), 0, ids_map.shape[0] - 1)
        ids = ids_map[rows, cols].astype(np.int64)
        wTr = self.groundtruth.poses_w[index]
        rays_w = self.rig.rays_r(pixels) @ wTr[:3, :3].T
        ids[~np.all(np.isfinite(rays_w), axis=1)] = -1
        origin_w = wTr[:3, :3] @ self.rig.viewpoint_r + wTr[:3, 3]
        t = plane_distances(self.quads, origin_w, rays_w, ids)
        points = origin_w + t[:, None] * rays_w
        points[ids < 0] = np.nan
        return points, ids

    def image(self, index: int) -> np.ndarray:
        """(H, W, 3) uint8 RGB image of frame ``index``.

        Raises:
            DataError: naming the image: unreadable, truncated or corrupt
                (``camera.image_file.read_image``), or of another size than the calibration's.
        """
        from omnislam._optional import require
        from omnislam.camera.image_file import read_image

        cv2 = require("cv2")
        path = self.path / "images" / f"{frame_name(index)}.png"
        bgr = read_image(path)
        if self.rig is not None:
            camera = self.rig.camera
            if bgr.shape[:2] != (camera.height, camera.width):
                raise DataError(
                    f"image is {bgr.shape[1]}x{bgr.shape[0]} px, the calibration "
                    f"({self.path / 'calibration.yaml'}) is for {camera.width}x{camera.height}",
                    path,
                )
        return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)  # 20x cheaper than numpy's [..., ::-1] copy


def read_ground_truth_maps(path: str | Path, index: int) -> GroundTruthMaps:
    """Per-pixel world points and surface ids of frame ``index`` of the folder ``path``."""
    return SyntheticFolder(path).ground_truth_maps(index)


def _line_colours(path: Path, landmark_ids: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """``line_colours.csv`` as (means_left, means_right) rows of ``landmark_ids`` (NaN where the
    survey has none), or None when the folder has no such file (rendered before it existed, or
    without images)."""
    if not path.exists():
        return None
    table = _read_csv(path, 8, finite=False)
    if not np.all(np.isfinite(table.values[:, :2])):
        row = int(np.argmax(~np.all(np.isfinite(table.values[:, :2]), axis=1)))
        raise DataError(f"{table.where(row)}: id and count must be numbers", path)
    check_integers(table, 0, "id")
    check_unique(table, 0, "id")
    check_integers(table, 1, "count")
    check_range(table, 1, "count", 0, math.inf)
    row = {int(i): k for k, i in enumerate(landmark_ids)}
    left = np.full((len(landmark_ids), 3), np.nan)
    right = np.full((len(landmark_ids), 3), np.nan)
    for index, values in enumerate(table.values):
        line = table.where(index)
        k = row.get(int(values[0]))
        if k is None:
            raise DataError(f"{line}: landmark {int(values[0])} is not in landmarks.csv", path)
        colours = values[2:]
        # an 8-bit colour's mean, or NaN (never seen); inf, -5 or 1e308 is not a colour
        if not np.all(((colours >= 0) & (colours <= 255)) | np.isnan(colours)):
            raise DataError(f"{line}: colours must be in [0, 255] or empty", path)
        left[k], right[k] = values[2:5], values[5:8]
    return left, right


def _meta_enum(meta: dict[str, object], key: str, default: _E, root: Path) -> _E:
    """The enum member ``meta[key]`` names (``default`` when absent).

    Raises:
        DataError: naming ``meta.json``: a value that is no member's.
    """
    value = meta.get(key, default.value)
    try:
        return type(default)(value)
    except ValueError:
        names = ", ".join(str(m.value) for m in type(default))
        raise DataError(f"{key!r} must be one of {names}, got {value!r}",
                        root / "meta.json") from None


def _pole_range_m(meta: dict[str, object], laser: LaserScans, root: Path) -> float:
    """Maximum range of the laser that sighted the poles: the pole scanner's (``meta.json``)
    when the folder has one, else the scans' own.

    Raises:
        DataError: naming ``meta.json``: a pole scanner without a positive ``max_range_m``.
    """
    scanner = meta.get("pole_scanner")
    if scanner is None:
        return laser.max_range_m
    try:
        value = float(scanner["laser"]["max_range_m"])  # type: ignore[index]
    except (TypeError, KeyError, ValueError):
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise DataError("pole_scanner.laser.max_range_m must be a positive number",
                        root / "meta.json")
    return value


def _read_laser(path: Path, frames: int, role: LaserRole = LaserRole.SENSOR) -> LaserScans:
    """``laser.npz`` checked against the folder: one scan per frame, ranges in [0, max]."""
    try:
        with np.load(path, allow_pickle=False) as data:
            angles = np.asarray(data["angles_rad"], dtype=float)
            ranges = np.asarray(data["ranges_m"], dtype=float)
            max_range = float(data["max_range_m"])
    except NPZ_ERRORS as exc:
        raise DataError(f"cannot read laser scans ({npz_reason(exc)})", path) from None
    except (TypeError, ValueError) as exc:
        raise DataError(f"laser scans are not numeric arrays ({exc})", path) from None
    if angles.ndim != 1 or not np.all(np.isfinite(angles)) or np.any(np.diff(angles) <= 0):
        raise DataError("angles_rad must be finite and increasing, one per beam", path)
    if ranges.ndim != 2 or ranges.shape[1] != angles.size:
        raise DataError(
            f"ranges_m is {ranges.shape}, expected ({frames}, {angles.size}): "
            "one row per frame, one column per beam", path)
    if ranges.shape[0] != frames:
        raise DataError(
            f"{ranges.shape[0]} laser scans for {frames} frames (odometry.csv)", path)
    if not (np.isfinite(max_range) and max_range > 0):
        raise DataError(f"max_range_m must be positive, got {max_range}", path)
    bad = ~np.isfinite(ranges) | (ranges < 0) | (ranges > max_range)
    if bad.any():
        frame, beam = (int(v) for v in np.argwhere(bad)[0])
        raise DataError(
            f"scan {frame}, beam {beam}: range {ranges[frame, beam]} outside "
            f"[0, max_range_m = {max_range:g}] ({int(bad.sum())} such ranges)", path)
    return LaserScans(angles, ranges, max_range, role)


def _pole_sightings(
    poles: np.ndarray, frames: int, association: Association
) -> tuple[RangeBearing, ...]:
    """One RangeBearing per frame from ``poles.csv``'s rows (ids hidden with UNKNOWN)."""
    of_frame = poles[:, 0].astype(np.int64)
    sightings = []
    for i in range(frames):
        rows = poles[of_frame == i]
        ids = rows[:, 1].astype(np.int64)
        if association is Association.UNKNOWN:
            ids = np.full_like(ids, UNKNOWN_ID)
        sightings.append(RangeBearing(ids, rows[:, 2], rows[:, 3], rows[:, 4], rows[:, 5]))
    return tuple(sightings)


def _prior_map(folder: SyntheticFolder, landmarks: np.ndarray) -> PriorMap:
    """The world's 2-D map as a prior map: ``landmarks.csv``'s poles and vertical lines (with
    the colours ``line_colours.csv`` surveyed, when present) and ``walls.csv``."""
    landmark_ids = landmarks[:, 0].astype(np.int64)
    line_ids = {line.landmark_id for line in folder.world.vertical_lines}
    walls = np.array([[w.x0_m, w.y0_m, w.x1_m, w.y1_m] for w in folder.world.walls_2d])
    means = _line_colours(folder.path / "line_colours.csv", landmark_ids)
    return PriorMap(
        source="the world's 2-D map (landmarks.csv: poles and vertical lines; walls.csv"
        + ("; MC surveyed in the rendered images, line_colours.csv)" if means else ")"),
        landmark_ids=landmark_ids,
        points_w=landmarks[:, 1:4],
        vertical_line=np.isin(landmark_ids, sorted(line_ids)),
        means_left=means[0] if means else None,
        means_right=means[1] if means else None,
        walls_w=walls.reshape(-1, 2, 2),
        initial_pose_w=se2_from_se3(folder.groundtruth.poses_w[0]),
    )


def load_synthetic(path: str | Path, association: Association | None = None) -> Sequence:
    """Read a synthetic folder as a Sequence (images on demand, exact ground truth).

    Args:
        path: the folder.
        association: KNOWN hands the pole sightings' true ids to the estimators; UNKNOWN
            replaces them by ``UNKNOWN_ID`` (the thesis's experiments, where the filter must
            associate by itself; evaluation still uses the true map). None: the folder's own
            default (``meta.json``'s ``association``, written by the thesis presets), else
            KNOWN.

    The images' realism (``meta.json``'s ``realism``, absent = clean) is in ``info``.

    Raises:
        DataError: naming the file: a malformed or inconsistent file, images lost or named
            after no frame, images without ``calibration.yaml``, or a first or last image that
            cannot be read or has another size than the calibration's.
    """
    folder = SyntheticFolder(path)
    root = folder.path
    odometry_table = _read_csv(root / "odometry.csv", 7)
    odometry = odometry_table.values
    n = odometry.shape[0]
    if n == 0 or len(folder.groundtruth) != n:
        raise DataError(f"{n} odometry rows but {len(folder.groundtruth)} poses",
                        root / "odometry.csv")
    recorded = folder.meta.get("frames", n)
    if recorded != n or isinstance(recorded, bool):
        raise DataError(f"'frames' is {recorded!r}, odometry.csv has {n} rows",
                        root / "meta.json")
    _check_odometry(odometry_table, folder.groundtruth.stamps_s)
    if association is None:
        association = _meta_enum(folder.meta, "association", Association.KNOWN, root)
    realism = _meta_enum(folder.meta, "realism", Realism.CLEAN, root)
    laser = _read_laser(root / "laser.npz", n,
                        _meta_enum(folder.meta, "laser_role", LaserRole.SENSOR, root))
    landmarks_table = _read_csv(root / "landmarks.csv", 4)
    _check_landmarks(landmarks_table)
    landmarks = landmarks_table.values
    poles_table = _read_csv(root / "poles.csv", 6)
    _check_poles(poles_table, n, landmarks[:, 0], _pole_range_m(folder.meta, laser, root))
    sightings = _pole_sightings(poles_table.values, n, association)
    images = _image_frames(root, folder.meta, n)
    gt_traj = folder.groundtruth
    meta = folder.meta
    landmark_ids = landmarks[:, 0].astype(np.int64)
    if images and folder.rig is None:
        raise DataError("file missing: the folder has images but no calibration",
                        root / "calibration.yaml")
    if images:
        _check_image_size(folder, images)
    return Sequence(
        name=root.name,
        source=f"synthetic preset {meta['preset']} (seed {meta['seed']}): {meta['source']}",
        stamps_s=odometry[:, 0],
        odometry_r=odometry[:, 1:4],
        odometry_true_r=odometry[:, 4:7],
        initial_pose_w=se2_from_se3(gt_traj.poses_w[0]),
        ground_truth=GroundTruth(
            kind=GroundTruthKind.EXACT,
            trajectory=gt_traj,
            landmark_ids=landmark_ids,
            landmarks_w=landmarks[:, 1:4],
            note="exact: the renderer's own poses and landmark positions",
        ),
        range_bearing=sightings,
        laser=laser,
        image_loader=folder.image if images else None,
        image_frames=np.array(images, dtype=np.int64),
        point_map_loader=(lambda i: folder.ground_truth_maps(i).points_w) if images else None,
        pixel_points_loader=folder.pixel_points if images else None,
        calibration=folder.rig,
        prior_map=_prior_map(folder, landmarks),
        info={
            "preset": str(meta["preset"]),
            "seed": str(meta["seed"]),
            "frames": str(n),
            "images": str(len(images)),
            "backend": str(meta.get("backend")),
            "association": association.value,
            "laser": "occupancy grid only" if laser.role is LaserRole.OCCUPANCY else "sensor",
            "realism": realism.value,
        },
    )


def _check_odometry(table: Table, groundtruth_stamps_s: np.ndarray) -> None:
    """``odometry.csv`` against the folder: the stamps of ``groundtruth.tum`` (both are the
    frames' times), steps within ``MAX_STEP_M`` and ``MAX_STEP_RAD``.

    Raises:
        DataError: naming ``odometry.csv`` and the line.
    """
    stamps_s = table.values[:, 0]
    # both files print the same floats with 17 digits: equal to the last bits
    differ = np.abs(stamps_s - groundtruth_stamps_s) > 1e-9 * np.maximum(1.0, np.abs(stamps_s))
    if differ.any():
        row = int(np.argmax(differ))
        raise DataError(
            f"{table.where(row)}: stamp {float(stamps_s[row])!r} is not the stamp of pose {row} "
            f"in groundtruth.tum ({float(groundtruth_stamps_s[row])!r})",
            table.path,
        )
    names = ("dx[m]", "dy[m]", "dtheta[rad]", "true_dx[m]", "true_dy[m]", "true_dtheta[rad]")
    for column, name in enumerate(names, start=1):
        limit = MAX_STEP_RAD if "theta" in name else MAX_STEP_M
        check_range(table, column, name, -limit, limit)


def _check_landmarks(table: Table) -> None:
    """``landmarks.csv``: whole, unique, non-negative ids; coordinates within
    ``MAX_COORDINATE_M``.

    Raises:
        DataError: naming ``landmarks.csv`` and the line.
    """
    check_integers(table, 0, "id")
    check_range(table, 0, "id", 0, math.inf)
    check_unique(table, 0, "id")
    for column, name in enumerate(("x[m]", "y[m]", "z[m]"), start=1):
        check_range(table, column, name, -MAX_COORDINATE_M, MAX_COORDINATE_M)


def _check_poles(table: Table, frames: int, landmark_ids: np.ndarray, max_range_m: float
                 ) -> None:
    """``poles.csv`` against the folder: frames of ``odometry.csv``, landmarks of
    ``landmarks.csv``, ranges the laser (``laser.npz``) can measure, bearings in [-pi, pi],
    positive sigmas.

    Raises:
        DataError: naming ``poles.csv`` and the line.
    """
    check_integers(table, 0, "frame")
    check_range(table, 0, "frame", 0, frames - 1)
    check_integers(table, 1, "landmark_id")
    unknown = ~np.isin(table.values[:, 1], landmark_ids)
    if unknown.any():
        row = int(np.argmax(unknown))
        raise DataError(
            f"{table.where(row)}: landmark {int(table.values[row, 1])} is not in landmarks.csv",
            table.path,
        )
    check_range(table, 2, "range_m", 0.0, max_range_m + POLE_RANGE_MARGIN_M)
    check_range(table, 3, "bearing_rad", -math.pi, math.pi)
    check_range(table, 4, "sigma_range_m", 0.0, math.inf, inclusive=False)
    check_range(table, 5, "sigma_bearing_rad", 0.0, math.inf, inclusive=False)


def _image_frames(root: Path, meta: dict[str, object], frames: int) -> list[int]:
    """The frame indices of ``images/NNNNNN.png``, checked against the folder.

    Raises:
        DataError: an image whose name is not a frame index of the folder (naming it), or
            fewer or more images than ``meta.json`` records (images lost or added).
    """
    folder = root / "images"
    paths = sorted(folder.glob("*.png")) if folder.is_dir() else []
    images = []
    for path in paths:
        if not path.stem.isdigit() or int(path.stem) >= frames:
            raise DataError(
                f"an image's name must be its frame's index, 0 to {frames - 1} "
                f"(odometry.csv has {frames} rows)",
                path,
            )
        images.append(int(path.stem))
    expected = meta.get("images", len(images))
    if not isinstance(expected, int) or isinstance(expected, bool) or expected < 0:
        raise DataError(f"'images' must be a count of images, got {expected!r}", root / "meta.json")
    if len(images) != expected:
        raise DataError(
            f"{len(images)} images, meta.json records {expected} (images lost or added?)",
            folder,
        )
    return sorted(images)


def _check_image_size(folder: SyntheticFolder, images: list[int]) -> None:
    """Every image at load time (not midway through a front-end pass): whole (PNG chunk CRCs
    and end) and of the calibration's size, from its header; the first and last are decoded
    too. About 1 ms per 1 MB image (``SyntheticFolder.image`` checks each one again).

    Raises:
        DataError: naming the first image that is not a whole PNG of the calibration's size.
    """
    from omnislam.camera.image_file import png_size

    assert folder.rig is not None
    camera = folder.rig.camera
    for index in images:
        path = folder.path / "images" / f"{frame_name(index)}.png"
        width, height = png_size(path)
        if (width, height) != (camera.width, camera.height):
            raise DataError(
                f"image is {width}x{height} px, the calibration "
                f"({folder.path / 'calibration.yaml'}) is for {camera.width}x{camera.height}",
                path,
            )
        _check_ground_truth_map(folder.path / "gt" / f"{frame_name(index)}.npz",
                                (camera.height, camera.width))
    for index in sorted({images[0], images[-1]}):
        folder.image(index)


def _check_ground_truth_map(path: Path, shape: tuple[int, int]) -> None:
    """An image's ``gt/NNNNNN.npz`` from its array's header (0.1 ms, no decompression of the
    map): present, an integer ``surface_id`` of the image's size. Its ids are checked when the
    map is read (``SyntheticFolder.surface_ids``).

    Raises:
        DataError: naming the file.
    """
    import zipfile

    try:
        with zipfile.ZipFile(path) as archive, archive.open("surface_id.npy") as member:
            fmt = np.lib.format
            version = fmt.read_magic(member)
            read = fmt.read_array_header_1_0 if version == (1, 0) else fmt.read_array_header_2_0
            found, _, dtype = read(member)
    except NPZ_ERRORS as exc:
        raise DataError(f"cannot read ground-truth map ({npz_reason(exc)})", path) from None
    if found != shape or dtype.kind not in "iu":
        raise DataError(
            f"surface_id is {dtype} {found}, the image's is an integer map of {shape}", path
        )
