"""The ObservationLog: what the front end saw, frame by frame, cached on disk for every estimator.

File format (``.npz``, compressed, ``allow_pickle=False``): a ``meta`` JSON string with
``format``, ``version``, ``dataset_id``, ``config_hash``, ``config`` and ``stats``, and flat
arrays per record type with CSR offsets (``*_offsets`` of length N + 1, ``*_present`` masks
telling a frame with no record from one with an empty record). A log is keyed by the dataset
fingerprint and the configuration hash: ``load_observation_log`` refuses a file whose key
differs from the expected one (``StaleLogError``), so a changed configuration or a re-rendered
dataset never reuses a stale cache.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from omnislam._files import NPZ_ERRORS, make_public, npz_reason, output_error
from omnislam.core.types import (
    Bearings,
    FrameInput,
    Odometry,
    OdometrySource,
    RangeBearing,
    VerticalLines,
)
from omnislam.errors import DataError

LOG_FORMAT = "omnislam-observation-log"
#: bump when the layout changes; older files are refused (2: ``floor_ids_from``, without which
#: a log's floor tracks could not be told from its landmark tracks)
LOG_FORMAT_VERSION = 2


class StaleLogError(DataError):
    """A cached log was built from another dataset or with another configuration."""


@dataclass(frozen=True, slots=True)
class ObservationLog:
    """One FrameInput per frame of a Sequence, plus what is needed to audit the front end.

    Attributes:
        dataset_id: fingerprint of the sequence (``dataset_fingerprint``).
        config_hash: hash of the front-end configuration (``config.config_hash``).
        frames: one FrameInput per frame (odometry always; bearings on processed images).
        pixels: per frame, (K, 2) image positions [px] of the bearings' keypoints (None on
            frames without bearings); aligned with ``frames[i].bearings``.
        config: the configuration as plain data (for reports).
        stats: counts and seconds per stage.
        odometry_source: WHEEL: the frames' odometry is the dataset's; LASER: it is
            the front end's laser odometry (``frontend.scan_matching``: scans registered by
            ICP, with their covariance; the wheel odometry where a match was rejected), which
            ``omnislam run`` hands the SLAM estimators instead of the dataset's (dead
            reckoning keeps the wheel odometry).
        floor_ids_from: the floor tracks' ids (``frontend.floor_tracks``, the front end's
            ``FrontendConfig.floor``) are this number and above, the landmark tracks' below it;
            None when the front end tracked no floor. Only estimators that model the floor
            take the floor tracks (``estimators.EstimatorEntry.floor_tracks``).
    """

    dataset_id: str
    config_hash: str
    frames: tuple[FrameInput, ...]
    pixels: tuple[np.ndarray | None, ...]
    config: Mapping[str, Any] = field(default_factory=dict)
    stats: Mapping[str, float] = field(default_factory=dict)
    odometry_source: OdometrySource = OdometrySource.WHEEL
    floor_ids_from: int | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.odometry_source, OdometrySource):
            raise DataError(f"ObservationLog: unknown odometry source {self.odometry_source!r}")
        if not _is_first_id(self.floor_ids_from):
            raise DataError(
                f"ObservationLog: floor_ids_from must be an id >= 0, got {self.floor_ids_from!r}"
            )
        if len(self.pixels) != len(self.frames):
            raise DataError("ObservationLog: one pixels entry per frame is required")
        for frame, px in zip(self.frames, self.pixels, strict=True):
            k = 0 if frame.bearings is None else len(frame.bearings)
            if (px is None) != (frame.bearings is None) or (px is not None and px.shape != (k, 2)):
                raise DataError(f"ObservationLog: pixels of frame {frame.index} do not match")

    def __len__(self) -> int:
        return len(self.frames)

    @property
    def image_frames(self) -> np.ndarray:
        """(M,) indices of the frames with bearings."""
        return np.array([f.index for f in self.frames if f.bearings is not None], dtype=np.int64)


def dataset_fingerprint(sequence: Any) -> str:
    """``name-<12 hex>``: the sequence's name and a hash of its stamps, odometry and images
    (and of its scanner's offset on the robot, when not zero).

    Args:
        sequence: an ``omnislam.datasets.Sequence``.
    """
    digest = hashlib.sha256()
    for array in (sequence.stamps_s, sequence.odometry_r, sequence.image_frames):
        digest.update(np.ascontiguousarray(array).tobytes())
    digest.update(str(sequence.laser is not None).encode())
    if sequence.laser is not None and np.any(sequence.laser.offset_r):
        digest.update(np.ascontiguousarray(sequence.laser.offset_r).tobytes())
    digest.update(str(sequence.range_bearing is not None).encode())
    calibration = getattr(sequence.calibration, "to_dict", None)
    if calibration is not None:
        digest.update(json.dumps(calibration(), sort_keys=True, default=str).encode())
    return f"{sequence.name}-{digest.hexdigest()[:12]}"


# --- writing --------------------------------------------------------------------------------
def _csr(records: list[Any], fields: dict[str, tuple[str, tuple[int, ...], type]],
         prefix: str) -> dict[str, np.ndarray]:
    """Concatenate per-frame records into flat arrays + offsets + a presence mask."""
    present = np.array([r is not None for r in records], dtype=bool)
    counts = [0 if r is None else len(r) for r in records]
    out = {
        f"{prefix}_present": present,
        f"{prefix}_offsets": np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
    }
    for key, (attr, tail, dtype) in fields.items():
        chunks = [np.asarray(getattr(r, attr) if attr else r, dtype=dtype).reshape(-1, *tail)
                  for r in records if r is not None]
        out[f"{prefix}_{key}"] = (np.concatenate(chunks) if chunks
                                  else np.zeros((0, *tail), dtype=dtype))
    return out


_BEARINGS = {
    "ids": ("landmark_ids", (), np.int64),
    "vectors": ("unit_vectors_r", (3,), float),
    "sigmas": ("sigmas_rad", (), float),
}
_RANGE_BEARING = {
    "ids": ("landmark_ids", (), np.int64),
    "ranges": ("ranges_m", (), float),
    "bearings": ("bearings_rad", (), float),
    "sigma_range": ("sigma_range_m", (), float),
    "sigma_bearing": ("sigma_bearing_rad", (), float),
}
_LINES = {
    "bearings": ("bearings_rad", (), float),
    "sigma": ("sigma_bearing_rad", (), float),
    "means_left": ("means_left", (3,), float),
    "means_right": ("means_right", (3,), float),
    "ids": ("landmark_ids", (), np.int64),
}


def save_observation_log(log: ObservationLog, path: str | Path) -> None:
    """Write ``log`` to ``path`` (compressed npz), atomically (temporary file + rename)."""
    path = Path(path)
    frames = log.frames
    arrays: dict[str, np.ndarray] = {
        "index": np.array([f.index for f in frames], dtype=np.int64),
        "stamps_s": np.array([f.odometry.stamp_s for f in frames], dtype=float),
        "odometry": np.array([f.odometry.delta for f in frames], dtype=float).reshape(-1, 3),
    }
    if any(f.odometry.covariance is not None for f in frames):  # NaN: none stated
        arrays["odometry_cov"] = np.array(
            [np.full((3, 3), np.nan) if f.odometry.covariance is None else f.odometry.covariance
             for f in frames], dtype=float,
        ).reshape(-1, 3, 3)
    arrays |= _csr([f.bearings for f in frames], _BEARINGS, "bearings")
    arrays |= _csr(list(log.pixels), {"pixels": ("", (2,), float)}, "pixels")
    arrays |= _csr([f.range_bearing for f in frames], _RANGE_BEARING, "rb")
    lines = [f.vertical_lines for f in frames]
    arrays |= _csr(lines, _LINES, "lines")
    width = next((v.profiles.shape[2] for v in lines if v is not None and len(v)), 1)
    arrays["lines_profiles"] = (
        np.concatenate([v.profiles for v in lines if v is not None and len(v)])
        if any(v is not None and len(v) for v in lines)
        else np.zeros((0, 3, width))
    )
    meta = {
        "format": LOG_FORMAT,
        "version": LOG_FORMAT_VERSION,
        "dataset_id": log.dataset_id,
        "config_hash": log.config_hash,
        "config": dict(log.config),
        "stats": dict(log.stats),
        "odometry_source": log.odometry_source.value,
        "floor_ids_from": log.floor_ids_from,
    }
    arrays["meta"] = np.array(json.dumps(meta, sort_keys=True))
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(suffix=".npz", dir=path.parent)
    except OSError as exc:
        raise output_error(exc, path, "observation log") from None
    try:
        with os.fdopen(fd, "wb") as handle:
            np.savez_compressed(handle, **arrays)
        make_public(tmp)
        os.replace(tmp, path)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        raise output_error(exc, path, "observation log") from None
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


# --- reading --------------------------------------------------------------------------------
def read_log_key(path: str | Path) -> tuple[str, str]:
    """``(dataset_id, config_hash)`` of a log file without reading its arrays."""
    return tuple(_read_meta(Path(path))[k] for k in ("dataset_id", "config_hash"))  # type: ignore[return-value]


def _read_meta(path: Path, data: Any | None = None) -> dict[str, Any]:
    try:
        if data is None:
            with np.load(path, allow_pickle=False) as npz:
                text = str(npz["meta"])
        else:
            text = str(data["meta"])
        meta = json.loads(text)
    except NPZ_ERRORS as exc:
        raise DataError(f"not an observation log ({npz_reason(exc)})", path) from None
    if not isinstance(meta, dict) or meta.get("format") != LOG_FORMAT:
        raise DataError("not an observation log", path)
    if meta.get("version") != LOG_FORMAT_VERSION:
        raise StaleLogError(
            f"log format version {meta.get('version')!r}, expected {LOG_FORMAT_VERSION}", path
        )
    for key, kind in (("dataset_id", str), ("config_hash", str), ("config", dict),
                      ("stats", dict), ("odometry_source", str)):
        if key in meta and not isinstance(meta[key], kind):
            raise DataError(
                f"malformed observation log (meta {key!r} must be a {kind.__name__}, got "
                f"{type(meta[key]).__name__})", path)
        if key in ("dataset_id", "config_hash") and key not in meta:
            raise DataError(f"malformed observation log (meta has no {key!r})", path)
    if meta.get("odometry_source", "wheel") not in tuple(OdometrySource):
        raise DataError(
            f"malformed observation log (meta odometry_source {meta['odometry_source']!r}, "
            "expected 'wheel' or 'laser')", path)
    return meta


def load_observation_log(
    path: str | Path, *, dataset_id: str | None = None, config_hash: str | None = None
) -> ObservationLog:
    """Read a log, refusing it when its key differs from the expected one.

    Args:
        path: the ``.npz`` file.
        dataset_id: expected dataset fingerprint (None: accept any).
        config_hash: expected configuration hash (None: accept any).

    Raises:
        StaleLogError: the file was built for another dataset, configuration or format version.
        DataError: the file is missing or malformed.
    """
    path = Path(path)
    try:
        npz = np.load(path, allow_pickle=False)
    except FileNotFoundError:
        raise DataError("observation log not found", path) from None
    except NPZ_ERRORS as exc:
        raise DataError(f"cannot read observation log ({npz_reason(exc)})", path) from None
    with npz as data:
        meta = _read_meta(path, data)
        if dataset_id is not None and meta["dataset_id"] != dataset_id:
            raise StaleLogError(
                f"built for dataset {meta['dataset_id']}, not {dataset_id}", path
            )
        if config_hash is not None and meta["config_hash"] != config_hash:
            raise StaleLogError(
                f"built with configuration {meta['config_hash']}, not {config_hash}", path
            )
        try:
            arrays = {key: data[key] for key in data.files if key != "meta"}
        except NPZ_ERRORS as exc:
            raise DataError(f"malformed observation log ({npz_reason(exc)})", path) from None
    not_arrays = sorted(key for key, value in arrays.items() if not isinstance(value, np.ndarray))
    if not_arrays:  # a member whose name lost its .npy: numpy hands its raw bytes
        raise DataError(f"malformed observation log (member {not_arrays[0]!r} is no array)", path)
    _check_arrays(arrays, path)
    frames, pixels = _frames_from_arrays(arrays, path)
    return ObservationLog(
        dataset_id=meta["dataset_id"],
        config_hash=meta["config_hash"],
        frames=frames,
        pixels=pixels,
        config=meta.get("config", {}),
        stats=meta.get("stats", {}),
        odometry_source=OdometrySource(meta.get("odometry_source", "wheel")),
        floor_ids_from=_floor_ids_from(path, meta),
    )


def _is_first_id(value: object) -> bool:
    """Whether ``value`` can be ``ObservationLog.floor_ids_from``: None or an int >= 0."""
    return value is None or (isinstance(value, int) and not isinstance(value, bool) and value >= 0)


def _floor_ids_from(path: Path, meta: dict[str, Any]) -> int | None:
    """The log's ``floor_ids_from`` (None: no floor tracks)."""
    first = meta.get("floor_ids_from")
    if not _is_first_id(first):
        raise DataError(f"malformed observation log (floor_ids_from {first!r})", path)
    return first  # type: ignore[return-value]


#: record prefix -> its per-record arrays (after the prefix) and their shape after the first axis
_RECORDS: dict[str, dict[str, tuple[int, ...]]] = {
    "bearings": {key: tail for key, (_, tail, _) in _BEARINGS.items()},
    "pixels": {"pixels": (2,)},
    "rb": {key: tail for key, (_, tail, _) in _RANGE_BEARING.items()},
    "lines": {**{key: tail for key, (_, tail, _) in _LINES.items()}, "profiles": (3, None)},
}


def _check_arrays(a: dict[str, np.ndarray], path: Path) -> None:
    """The arrays of a log file against its layout (module docstring), before any record is
    built from them: frames ``0..N-1`` with finite, increasing stamps, one odometry row per
    frame, per record type a presence mask and increasing CSR offsets that cover its arrays
    exactly, and finite keypoint pixels.

    Raises:
        DataError: naming the file and the first array that breaks the layout.
    """

    def bad(message: str) -> DataError:
        return DataError(f"malformed observation log ({message})", path)

    def numeric(key: str, kind: str) -> np.ndarray:
        if key not in a:
            raise bad(f"no {key!r} array")
        array = a[key]
        if array.dtype.kind not in kind:
            raise bad(f"{key!r} has dtype {array.dtype}")
        return array

    index = numeric("index", "iu")
    n = index.shape[0]
    if index.ndim != 1 or not np.array_equal(index, np.arange(n)):
        raise bad(f"'index' must be the frames 0..{n - 1} in order")
    stamps = numeric("stamps_s", "fiu")
    if stamps.shape != (n,):
        raise bad(f"'stamps_s' has shape {stamps.shape}, expected ({n},)")
    if not np.all(np.isfinite(stamps)):
        k = int(np.flatnonzero(~np.isfinite(stamps))[0])
        raise bad(f"'stamps_s' of frame {k} is {stamps[k]}")
    if n > 1 and np.any(np.diff(stamps) <= 0):
        k = int(np.flatnonzero(np.diff(stamps) <= 0)[0]) + 1
        raise bad(f"'stamps_s' of frame {k} does not follow frame {k - 1}'s")
    for key, shape in (("odometry", (n, 3)), ("odometry_cov", (n, 3, 3))):
        if key in a and numeric(key, "fiu").shape != shape:
            raise bad(f"{key!r} has shape {a[key].shape}, expected {shape}")
    if "odometry" not in a:
        raise bad("no 'odometry' array")
    for prefix, fields in _RECORDS.items():
        present = numeric(f"{prefix}_present", "b")
        offsets = numeric(f"{prefix}_offsets", "iu")
        if present.shape != (n,) or offsets.shape != (n + 1,):
            raise bad(f"{prefix}_present and {prefix}_offsets must have {n} and {n + 1} entries, "
                      f"got {present.shape[0] if present.ndim else 0} and "
                      f"{offsets.shape[0] if offsets.ndim else 0}")
        if offsets[0] != 0 or np.any(np.diff(offsets) < 0):
            raise bad(f"{prefix}_offsets must start at 0 and never decrease")
        total = int(offsets[-1])
        for key, tail in fields.items():
            array = numeric(f"{prefix}_{key}", "fiu" if key != "ids" else "iu")
            wanted = (total, *tail)
            if array.ndim != len(wanted) or any(
                w is not None and w != got for w, got in zip(wanted, array.shape, strict=True)
            ):
                shown = ", ".join("any" if w is None else str(w) for w in wanted)
                raise bad(f"{prefix}_{key} has shape {array.shape}, expected ({shown}) "
                          f"({prefix}_offsets ends at {total})")
    if not np.all(np.isfinite(a["pixels_pixels"])):
        raise bad("a keypoint pixel is NaN or infinite")


def _slices(arrays: dict[str, np.ndarray], prefix: str, i: int) -> slice | None:
    if not arrays[f"{prefix}_present"][i]:
        return None
    offsets = arrays[f"{prefix}_offsets"]
    return slice(int(offsets[i]), int(offsets[i + 1]))


def _frames_from_arrays(
    a: dict[str, np.ndarray], path: Path
) -> tuple[tuple[FrameInput, ...], tuple[np.ndarray | None, ...]]:
    """The frames of checked arrays (``_check_arrays``).

    Raises:
        DataError: naming the file and the frame whose record is invalid (a NaN bearing, a
            negative range or sigma, a vector that is not a unit vector, ...).
    """
    frames: list[FrameInput] = []
    pixels: list[np.ndarray | None] = []
    for i, index in enumerate(a["index"]):
        try:
            frame, pixel = _frame_from_arrays(a, i, int(index))
        except DataError as exc:
            raise DataError(f"frame {i}: {exc}", path) from None
        frames.append(frame)
        pixels.append(pixel)
    return tuple(frames), tuple(pixels)


def _frame_from_arrays(
    a: dict[str, np.ndarray], i: int, index: int
) -> tuple[FrameInput, np.ndarray | None]:
    """Frame ``i`` of the arrays and its keypoints' pixels (None without bearings)."""
    s = _slices(a, "bearings", i)
    bearings = None if s is None else Bearings(
        a["bearings_ids"][s], a["bearings_vectors"][s], a["bearings_sigmas"][s]
    )
    p = _slices(a, "pixels", i)
    pixel = None if p is None else np.array(a["pixels_pixels"][p])
    r = _slices(a, "rb", i)
    rb = None if r is None else RangeBearing(
        a["rb_ids"][r], a["rb_ranges"][r], a["rb_bearings"][r], a["rb_sigma_range"][r],
        a["rb_sigma_bearing"][r],
    )
    v = _slices(a, "lines", i)
    lines = None if v is None else VerticalLines(
        a["lines_bearings"][v], a["lines_sigma"][v], a["lines_profiles"][v],
        a["lines_means_left"][v], a["lines_means_right"][v], a["lines_ids"][v],
    )
    cov = a["odometry_cov"][i] if "odometry_cov" in a else None
    if cov is not None and np.any(np.isnan(cov)):
        cov = None
    frame = FrameInput(
        index=index,
        odometry=Odometry(a["odometry"][i], float(a["stamps_s"][i]), cov),
        bearings=bearings,
        range_bearing=rb,
        vertical_lines=lines,
    )
    k = 0 if bearings is None else len(bearings)
    if (pixel is None) != (bearings is None) or (pixel is not None and pixel.shape != (k, 2)):
        raise DataError("its keypoint pixels do not match its bearings")
    return frame, pixel
