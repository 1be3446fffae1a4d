"""An interactive look at one run: a Rerun recording (``.rrd``) of a RUN_DIR.

``write_recording(run_dir, out)`` logs, on the timelines ``frame`` (frame index) and ``time``
(seconds since the first frame):

* ``world/ground_truth/path`` and ``world/estimate/path``: the whole trajectories (static), the
  estimate moved into the ground truth's frame by the same SE(2) alignment as its ATE
  (``metrics.trajectory.ate``; without ground truth it is shown as estimated);
* ``world/ground_truth/robot`` and ``world/estimate/robot``: the pose at each frame (a point
  and the robot's axes), ``world/estimate/pose_covariance``: the 2-sigma ellipse of the pose's
  x-y covariance where the estimator gives one;
* ``world/ground_truth/landmarks`` and ``world/estimate/landmarks`` (static): the final maps,
  ``world/estimate/landmark_covariances``: one 2-sigma ellipsoid per landmark with a covariance
  (its principal axes; 2-D maps get a flat one);
* ``world/sightings``: at each frame, a ray from the estimated pose to what it sighted (the
  measured point of a range-bearing sighting, the estimated landmark of an omni bearing's
  track), from the observations the run replayed (its front-end log, else the dataset's own);
* ``camera/image`` and ``camera/image/sightings``: for image datasets, every image (JPEG) with
  the keypoints of the bearings it gave, coloured by track id;
* ``errors/position_m``: the ATE position error of each pose over time;
* ``run``: a text document naming the run, its ground truth and its metrics.

Images and sightings need the dataset (``config.yaml``'s ``dataset_path``) and the log to be
where the run found them; when they are not, the recording says so and holds the rest. Rerun is
the optional ``view`` extra (``pip install '.[view]'`` in a clone).
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from omnislam._files import make_public, output_error
from omnislam._optional import require
from omnislam.datasets.sequence import GroundTruthKind
from omnislam.errors import OmnislamError
from omnislam.harness.layout import METRICS
from omnislam.harness.rundir import RunRecord, read_run_dir
from omnislam.metrics.trajectory import Alignment, ate

#: Rerun application id of the recordings
APPLICATION_ID = "omnislam"
#: covariance ellipses and ellipsoids are drawn at this many standard deviations
SIGMAS = 2.0
#: smallest half axis drawn [m] (a flat 2-D ellipsoid keeps a visible thickness)
MIN_HALF_AXIS_M = 1e-3
#: JPEG quality of the logged images
JPEG_QUALITY = 85
#: length of a sighting ray when nothing places its far end [m]
DEFAULT_RAY_M = 1.0

_GROUND_TRUTH = (40, 160, 40)
_ESTIMATE = (30, 100, 220)
_SIGHTING = (240, 150, 30)


@dataclass(frozen=True, slots=True)
class ViewOptions:
    """What to put in the recording.

    Attributes:
        images: log the dataset's images and their sightings (image datasets).
        image_every: log every k-th image only (1: all).
        sightings: log the sighting rays.
    """

    images: bool = True
    image_every: int = 1
    sightings: bool = True


@dataclass(frozen=True, slots=True)
class ViewSummary:
    """What ``write_recording`` wrote.

    Attributes:
        path: the .rrd file.
        frames: frames logged.
        images: images logged.
        landmarks: estimated landmarks logged.
        ellipsoids: landmark covariance ellipsoids logged.
        notes: what could not be shown, and why.
    """

    path: Path
    frames: int
    images: int
    landmarks: int
    ellipsoids: int
    notes: tuple[str, ...] = field(default_factory=tuple)


def covariance_ellipsoids(
    covariances: np.ndarray, sigmas: float = SIGMAS, min_half_m: float = MIN_HALF_AXIS_M
) -> tuple[np.ndarray, np.ndarray]:
    """Principal axes of (K, 3, 3) position covariances.

    Returns:
        (half_sizes (K, 3) = sigmas * sqrt(eigenvalues) [m], floored at ``min_half_m``;
        quaternions (K, 4) xyzw of the rotation whose columns are the eigenvectors).
    """
    from scipy.spatial.transform import Rotation

    cov = np.asarray(covariances, dtype=float).reshape(-1, 3, 3)
    sym = 0.5 * (cov + np.swapaxes(cov, 1, 2))
    eigenvalues, vectors = np.linalg.eigh(sym)
    flip = np.linalg.det(vectors) < 0  # a proper rotation: flip one axis (an ellipsoid is
    vectors[flip, :, 0] *= -1.0  # symmetric about its axes, so nothing else changes)
    half = np.maximum(sigmas * np.sqrt(np.clip(eigenvalues, 0.0, None)), min_half_m)
    quaternions = Rotation.from_matrix(vectors).as_quat() if len(cov) else np.zeros((0, 4))
    return half, quaternions


def _se2_alignment(record: RunRecord) -> tuple[np.ndarray, Any]:
    """(gtTest (4, 4), the ATE result or None): how the estimate is drawn in the truth's frame."""
    truth = record.ground_truth.trajectory
    if truth is None:
        return np.eye(4), None
    try:
        result = ate(
            record.estimate.trajectory,
            truth,
            Alignment.SE2,
            truth_has_orientation=record.ground_truth.kind is not GroundTruthKind.GPS_PARTIAL,
        )
    except OmnislamError:
        return np.eye(4), None
    return result.gtTest, result


def _sightings_source(
    record: RunRecord, notes: list[str]
) -> tuple[Any, list[Any] | None, Any]:
    """(sequence or None, the frames the run replayed or None, the replayed log or None)."""
    from omnislam.datasets.registry import load_dataset
    from omnislam.estimators import ESTIMATORS
    from omnislam.harness.frames import frames_for_estimator

    config = record.config
    try:
        sequence = load_dataset(config.dataset_path or config.dataset, dict(config.dataset_options))
    except OmnislamError as exc:
        notes.append(f"dataset not loaded, so no images and no sightings: {exc}")
        return None, None, None
    log = None
    if config.frontend_log:
        try:
            from omnislam.frontend.observation_log import (
                dataset_fingerprint,
                load_observation_log,
            )

            log = load_observation_log(
                Path(config.frontend_log), dataset_id=dataset_fingerprint(sequence)
            )
        except (OmnislamError, ImportError) as exc:
            notes.append(f"front-end log not read, so no image sightings: {exc}")
    try:
        frames = list(sequence.frame_inputs(log.frames if log is not None else None))
        if log is not None and config.estimator in ESTIMATORS:
            frames = frames_for_estimator(config.estimator, frames, log.floor_ids_from)
    except OmnislamError as exc:
        notes.append(f"sightings not replayed: {exc}")
        frames = None
    if config.wrong_id_fraction:
        notes.append(
            f"the run re-labelled {config.wrong_id_fraction:g} of the sightings; they are "
            "shown as the data has them"
        )
    if config.clutter_per_frame:
        notes.append(
            f"the run added {config.clutter_added} false detections "
            f"({config.clutter_per_frame:g} per frame); they are not shown"
        )
    return sequence, frames, log


def _rays(
    frame: Any, wTr: np.ndarray, landmarks: dict[int, np.ndarray], viewpoint_r: np.ndarray
) -> list[np.ndarray]:
    """Sighting rays of one frame in the world frame (a list of (2, 3) segments)."""
    segments = []
    rb = frame.range_bearing
    if rb is not None and len(rb):
        local = np.column_stack(
            [
                rb.ranges_m * np.cos(rb.bearings_rad),
                rb.ranges_m * np.sin(rb.bearings_rad),
                np.zeros(len(rb)),
            ]
        )
        ends = local @ wTr[:3, :3].T + wTr[:3, 3]
        segments += [np.vstack([wTr[:3, 3], end]) for end in ends]
    bearings = frame.bearings
    if bearings is not None and len(bearings.landmark_ids):
        origin = wTr[:3, :3] @ viewpoint_r + wTr[:3, 3]
        for lid, ray_r in zip(bearings.landmark_ids, bearings.unit_vectors_r, strict=True):
            end = landmarks.get(int(lid))
            if end is None:
                end = origin + DEFAULT_RAY_M * (wTr[:3, :3] @ ray_r)
            segments.append(np.vstack([origin, end]))
    return segments


def _run_text(record: RunRecord, run_dir: Path, alignment: Any, notes: list[str]) -> str:
    config = record.config
    lines = [
        f"# {config.estimator} on {config.dataset}",
        "",
        f"- RUN_DIR: `{run_dir}`",
        f"- frames: {config.frames}, seed: {config.seed}, omnislam {config.omnislam_version}",
        f"- ground truth: {record.ground_truth.kind.value}"
        + (f" ({record.ground_truth.note})" if record.ground_truth.note else ""),
        f"- estimator options: {dict(config.estimator_options) or 'defaults'}",
    ]
    if alignment is not None:
        lines.append(
            f"- the estimate is drawn SE(2)-aligned to the ground truth (as its ATE): "
            f"ATE RMSE {alignment.rmse_m:.4g} m over {alignment.matched} poses"
        )
    lines.append(f"- covariance ellipses and ellipsoids: {SIGMAS:g} sigma")
    if (run_dir / METRICS).is_file():
        try:
            metrics = json.loads((run_dir / METRICS).read_text())
            lines.append("")
            lines.append("## metrics.json")
            lines.append("")
            lines += [
                f"- {key}: {value}"
                for key, value in metrics.items()
                if not isinstance(value, list | dict)
            ]
        except (OSError, ValueError):
            pass
    if notes:
        lines += ["", "## not shown", ""] + [f"- {n}" for n in notes]
    return "\n".join(lines) + "\n"


def write_recording(
    run_dir: str | Path,
    out: str | Path,
    options: ViewOptions | None = None,
    *,
    on_frame: Callable[[int, int], None] | None = None,
) -> ViewSummary:
    """Write the Rerun recording of a RUN_DIR (see the module docstring) to ``out`` atomically.

    Args:
        run_dir: a folder written by ``omnislam run`` (or a cell of ``omnislam compare``).
        out: the ``.rrd`` file to write.
        options: what to include.
        on_frame: called with (frames logged, frames) as the recording is written (progress).

    Raises:
        MissingExtraError: rerun-sdk is not installed (the ``view`` extra).
        DataError: the RUN_DIR is missing or malformed.
        ConfigError: ``out`` cannot be written.
    """
    rr = require("rerun")
    options = options or ViewOptions()
    run_dir, out = Path(run_dir), Path(out)
    record = read_run_dir(run_dir)
    notes: list[str] = []
    aligned = _Aligned.of(record)
    sequence = frames = log = None
    if options.sightings or options.images:
        sequence, frames, log = _sightings_source(record, notes)
    tmp = _temporary_file(out)
    try:
        rec = rr.RecordingStream(APPLICATION_ID)
        rec.save(tmp)
        ellipsoids = _log_maps(rr, rec, record, aligned, notes)
        frame_log = _FrameLog(rr, rec, record, aligned, sequence, frames, log, options)
        for k in range(frame_log.count):
            frame_log.log(k)
            if on_frame is not None:
                on_frame(k + 1, frame_log.count)
        if sequence is not None and options.images and sequence.image_loader is None:
            notes.append("the dataset has no images")
        text = _run_text(record, run_dir, aligned.alignment, notes)
        rec.log("run", rr.TextDocument(text, media_type=rr.MediaType.MARKDOWN), static=True)
        rec.flush()
        rec.disconnect()
        make_public(tmp)
        os.replace(tmp, out)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        raise output_error(exc, out, "recording") from None
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return ViewSummary(
        out,
        frame_log.count,
        frame_log.images,
        len(record.estimate.landmark_ids),
        ellipsoids,
        tuple(notes),
    )


@dataclass(frozen=True, slots=True)
class _Aligned:
    """The estimate moved into the ground truth's frame by its ATE's SE(2) alignment.

    Attributes:
        R, t: rotation (3, 3) and translation (3,) of that alignment (identity without one).
        alignment: the ATE result (None without ground truth).
        poses: (N, 4, 4) estimated poses, aligned.
        landmarks_w: (M, 3) estimated landmarks, aligned.
        landmark_of: landmark id -> its aligned position.
    """

    R: np.ndarray
    t: np.ndarray
    alignment: Any
    poses: np.ndarray
    landmarks_w: np.ndarray
    landmark_of: dict[int, np.ndarray]

    @classmethod
    def of(cls, record: RunRecord) -> _Aligned:
        gtTest, alignment = _se2_alignment(record)
        R, t = gtTest[:3, :3], gtTest[:3, 3]
        estimate = record.estimate
        poses = estimate.trajectory.poses_w.copy()
        poses[:, :3, :3] = R @ poses[:, :3, :3]
        poses[:, :3, 3] = poses[:, :3, 3] @ R.T + t
        landmarks_w = (
            estimate.landmarks_w @ R.T + t if len(estimate.landmark_ids) else np.zeros((0, 3))
        )
        landmark_of = {
            int(i): p for i, p in zip(estimate.landmark_ids, landmarks_w, strict=True)
        }
        return cls(R, t, alignment, poses, landmarks_w, landmark_of)


def _temporary_file(out: Path) -> str:
    """A hidden temporary file next to ``out``, renamed into place when the recording is done.

    Raises:
        ConfigError: ``out``'s folder cannot be written.
    """
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=out.parent, prefix=f".{out.name}.", suffix=".tmp")
        os.close(fd)
    except OSError as exc:
        raise output_error(exc, out, "recording") from None
    return tmp


def _log_maps(rr: Any, rec: Any, record: RunRecord, aligned: _Aligned, notes: list[str]) -> int:
    """The static part: both paths, both maps and the landmark covariance ellipsoids.

    Returns:
        The number of ellipsoids logged.
    """
    rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    truth, estimate = record.ground_truth, record.estimate
    if truth.trajectory is not None:
        rec.log(
            "world/ground_truth/path",
            rr.LineStrips3D([truth.trajectory.positions_w], colors=[_GROUND_TRUTH]),
            static=True,
        )
    else:
        notes.append(f"no ground-truth trajectory ({truth.kind.value})")
    rec.log(
        "world/estimate/path",
        rr.LineStrips3D([aligned.poses[:, :3, 3]], colors=[_ESTIMATE]),
        static=True,
    )
    if len(truth.landmark_ids):
        rec.log(
            "world/ground_truth/landmarks",
            rr.Points3D(truth.landmarks_w, colors=[_GROUND_TRUTH], radii=0.03),
            static=True,
        )
    if not len(estimate.landmark_ids):
        return 0
    rec.log(
        "world/estimate/landmarks",
        rr.Points3D(
            aligned.landmarks_w,
            colors=[_ESTIMATE],
            radii=0.03,
            labels=[str(int(i)) for i in estimate.landmark_ids],
            show_labels=False,
        ),
        static=True,
    )
    if estimate.landmark_covariances is None:
        notes.append(f"{record.config.estimator} gives no landmark covariances")
        return 0
    half, quaternions = covariance_ellipsoids(
        aligned.R @ estimate.landmark_covariances @ aligned.R.T
    )
    rec.log(
        "world/estimate/landmark_covariances",
        rr.Ellipsoids3D(
            centers=aligned.landmarks_w,
            half_sizes=half,
            quaternions=[rr.Quaternion(xyzw=q) for q in quaternions],
            colors=[_ESTIMATE],
        ),
        static=True,
    )
    return len(half)


class _FrameLog:
    """Logs one frame at a time: the poses, the position error, the pose covariance, the
    sighting rays and the image with its keypoints (``log(k)``); counts the images logged."""

    def __init__(
        self,
        rr: Any,
        rec: Any,
        record: RunRecord,
        aligned: _Aligned,
        sequence: Any,
        frames: list[Any] | None,
        log: Any,
        options: ViewOptions,
    ) -> None:
        self.rr, self.rec, self.aligned = rr, rec, aligned
        self.sequence, self.frames, self.log_replayed, self.options = sequence, frames, log, options
        self.stamps = record.estimate.trajectory.stamps_s
        self.count = len(self.stamps)
        self.images = 0
        self.pose_covariances = record.estimate.pose_covariances
        alignment = aligned.alignment
        self.errors = {}
        if alignment is not None:
            self.errors = {
                float(s): float(e)
                for s, e in zip(alignment.stamps_s, alignment.errors_m, strict=True)
            }
        truth = record.ground_truth.trajectory
        self.truth_at = {}
        if truth is not None:
            self.truth_at = {
                float(s): p for s, p in zip(truth.stamps_s, truth.positions_w, strict=True)
            }
        self.viewpoint_r = np.asarray(
            getattr(getattr(sequence, "calibration", None), "viewpoint_r", np.zeros(3)),
            dtype=float,
        ).reshape(3)
        self.image_frames: set[int] = set()
        if sequence is not None and options.images and sequence.image_loader is not None:
            self.image_frames = {
                int(i) for k, i in enumerate(sequence.image_frames) if k % options.image_every == 0
            }
        rec.log("world/estimate/robot", rr.TransformAxes3D(axis_length=0.3), static=True)

    def log(self, k: int) -> None:
        """Everything of frame ``k``, on the timelines ``frame`` and ``time``."""
        rr, rec, stamp = self.rr, self.rec, float(self.stamps[k])
        rec.set_time("frame", sequence=k)
        rec.set_time("time", duration=float(self.stamps[k] - self.stamps[0]))
        wTr = self.aligned.poses[k]
        q = _quaternion_xyzw(wTr[:3, :3])
        rec.log(
            "world/estimate/robot",
            rr.Transform3D(translation=wTr[:3, 3], quaternion=rr.Quaternion(xyzw=q)),
        )
        rec.log(
            "world/estimate/position", rr.Points3D([wTr[:3, 3]], colors=[_ESTIMATE], radii=0.05)
        )
        p_true = self.truth_at.get(stamp)
        if p_true is not None:
            rec.log(
                "world/ground_truth/robot",
                rr.Points3D([p_true], colors=[_GROUND_TRUTH], radii=0.05),
            )
        error = self.errors.get(stamp)
        if error is not None:
            rec.log("errors/position_m", rr.Scalars(error))
        if self.pose_covariances is not None:
            self._pose_covariance(wTr, self.pose_covariances[k])
        if self.frames is not None and self.options.sightings:
            segments = _rays(self.frames[k], wTr, self.aligned.landmark_of, self.viewpoint_r)
            rec.log(
                "world/sightings",
                rr.LineStrips3D(segments, colors=[_SIGHTING], radii=0.005)
                if segments
                else rr.Clear(recursive=False),
            )
        if k in self.image_frames:
            self._image(k)

    def _pose_covariance(self, wTr: np.ndarray, covariance: np.ndarray) -> None:
        """The x-y covariance of the pose as a flat ellipsoid at it."""
        rr, R = self.rr, self.aligned.R
        cov = np.zeros((3, 3))
        cov[:2, :2] = R[:2, :2] @ covariance[:2, :2] @ R[:2, :2].T
        half, quaternions = covariance_ellipsoids(cov[None])
        self.rec.log(
            "world/estimate/pose_covariance",
            rr.Ellipsoids3D(
                centers=[wTr[:3, 3]],
                half_sizes=half,
                quaternions=[rr.Quaternion(xyzw=quaternions[0])],
                colors=[_ESTIMATE],
            ),
        )

    def _image(self, k: int) -> None:
        """Frame ``k``'s image (JPEG) and the keypoints of its bearings, coloured by track."""
        rr, rec = self.rr, self.rec
        image = self.sequence.image(k)
        rec.log("camera/image", rr.Image(image).compress(jpeg_quality=JPEG_QUALITY))
        self.images += 1
        pixels = self.log_replayed.pixels[k] if self.log_replayed is not None else None
        bearings = self.frames[k].bearings if self.frames is not None else None
        if pixels is not None and bearings is not None and len(pixels):
            ids = np.asarray(bearings.landmark_ids, dtype=np.int64)
            keypoints = rr.Points2D(pixels, class_ids=ids % 65536, radii=3.0)
            rec.log("camera/image/sightings", keypoints)
        else:
            rec.log("camera/image/sightings", rr.Clear(recursive=False))


def _quaternion_xyzw(R: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    q = Rotation.from_matrix(R).as_quat()
    return q / math.sqrt(float(q @ q))
