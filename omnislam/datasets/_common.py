"""Helpers shared by the real-data loaders: data location, sighting grouping, interpolation."""

from __future__ import annotations

import enum
import os
from pathlib import Path

import numpy as np

from omnislam.core.se import se2_between, wrap_angle
from omnislam.core.types import UNKNOWN_ID, RangeBearing
from omnislam.errors import ConfigError

#: environment variable that overrides where the shared real data is looked for
DATA_ENV = "OMNISLAM_DATA"


def data_root() -> Path:
    """The shared real-data folder: ``$OMNISLAM_DATA`` or ``<repo root>/../shared/data``.

    The repository root is the parent of the ``omnislam`` package folder.
    """
    override = os.environ.get(DATA_ENV)
    if override:
        return Path(override).expanduser()
    return Path(__file__).resolve().parents[2].parent / "shared" / "data"


class Association(enum.Enum):
    """Whether a loader hands the landmark ids of the sightings to the estimators."""

    KNOWN = "known"  # ids as recorded (estimators may use them)
    UNKNOWN = "unknown"  # ids replaced by UNKNOWN_ID: estimators must associate themselves

    @classmethod
    def parse(cls, text: str) -> Association:
        try:
            return cls(text)
        except ValueError:
            names = ", ".join(m.value for m in cls)
            raise ConfigError(f"association must be one of {names}, got {text!r}") from None


def fill_gaps(stamps_s: np.ndarray, max_step_s: float) -> np.ndarray:
    """``stamps_s`` with stamps inserted at equal spacing into every gap longer than
    ``max_step_s``, so that no two consecutive stamps are further apart.

    Args:
        stamps_s: (N,) increasing stamps [s].
        max_step_s: the longest step allowed (positive; infinite: nothing inserted) [s].

    Returns:
        (M,) increasing stamps, M >= N, holding every original stamp.

    Raises:
        ConfigError: ``max_step_s`` not positive.
    """
    if not max_step_s > 0:
        raise ConfigError(f"max_step_s must be positive, got {max_step_s}")
    stamps_s = np.asarray(stamps_s, dtype=float)
    if len(stamps_s) < 2 or not np.isfinite(max_step_s):
        return stamps_s
    gaps = np.diff(stamps_s)
    pieces = np.maximum(np.ceil(gaps / max_step_s - 1e-9).astype(np.int64), 1)
    out = [stamps_s[:1]]
    for start, gap, n in zip(stamps_s[:-1], gaps, pieces, strict=True):
        out.append(start + gap * np.arange(1, n + 1) / n)
    filled = np.concatenate(out)
    filled[np.cumsum(np.concatenate([[0], pieces]))] = stamps_s  # originals exactly
    return filled


def group_sightings(
    frame_stamps_s: np.ndarray,
    stamps_s: np.ndarray,
    landmark_ids: np.ndarray,
    ranges_m: np.ndarray,
    bearings_rad: np.ndarray,
    sigma_range_m: float,
    sigma_bearing_rad: float,
    association: Association = Association.KNOWN,
) -> tuple[RangeBearing | None, ...]:
    """One RangeBearing per frame holding the sightings whose stamp equals the frame's stamp.

    Args:
        frame_stamps_s: (N,) increasing frame stamps [s].
        stamps_s: (K,) stamp of each sighting; each must be one of ``frame_stamps_s``.
        landmark_ids: (K,) ids (UNKNOWN_ID where unknown).
        ranges_m, bearings_rad: (K,) robot-frame range [m] and bearing [rad, ccw from heading].
        sigma_range_m, sigma_bearing_rad: standard deviations given to every sighting.
        association: KNOWN keeps the ids, UNKNOWN replaces them with UNKNOWN_ID.

    Returns:
        A tuple of length N, None for frames without sightings.
    """
    frame_of = np.searchsorted(frame_stamps_s, stamps_s)
    if association is Association.UNKNOWN:
        landmark_ids = np.full_like(landmark_ids, UNKNOWN_ID)
    out: list[RangeBearing | None] = [None] * len(frame_stamps_s)
    if len(stamps_s) == 0:
        return tuple(out)
    order = np.argsort(frame_of, kind="stable")
    frames, starts = np.unique(frame_of[order], return_index=True)
    ends = np.append(starts[1:], len(order))
    for frame, start, end in zip(frames, starts, ends, strict=True):
        rows = order[start:end]
        out[int(frame)] = RangeBearing(
            landmark_ids=landmark_ids[rows],
            ranges_m=ranges_m[rows],
            bearings_rad=wrap_angle(bearings_rad[rows]),
            sigma_range_m=sigma_range_m,
            sigma_bearing_rad=sigma_bearing_rad,
        )
    return tuple(out)


def odometry_from_poses(poses: np.ndarray) -> np.ndarray:
    """(N, 3) poses -> (N, 3) robot-frame steps ``between(pose[i-1], pose[i])``; row 0 is zero."""
    steps = np.zeros_like(poses)
    if len(poses) > 1:
        steps[1:] = se2_between(poses[:-1], poses[1:])
    return steps


def interpolate_se2(
    stamps_s: np.ndarray, poses: np.ndarray, query_s: np.ndarray, max_gap_s: float
) -> tuple[np.ndarray, np.ndarray]:
    """Linear interpolation of planar poses (heading unwrapped) at query times.

    Args:
        stamps_s: (M,) increasing sample times [s].
        poses: (M, 3) [x, y, theta] samples.
        query_s: (Q,) times wanted [s].
        max_gap_s: a query is answered only when both bracketing samples are at most this far
            apart (a motion-capture dropout or a GPS gap gives no answer).

    Returns:
        (valid (Q,) bool, poses (Q_valid, 3)) with theta wrapped to [-pi, pi).
    """
    j = np.searchsorted(stamps_s, query_s, side="right")
    inside = (j > 0) & (j < len(stamps_s))
    j = np.clip(j, 1, len(stamps_s) - 1)
    t0, t1 = stamps_s[j - 1], stamps_s[j]
    nearest = np.clip(np.searchsorted(stamps_s, query_s), 0, len(stamps_s) - 1)
    exact = query_s == stamps_s[nearest]
    valid = (inside & (t1 - t0 <= max_gap_s)) | exact
    valid &= query_s >= stamps_s[0]
    theta = np.unwrap(poses[:, 2])
    w = np.clip((query_s - t0) / np.where(t1 > t0, t1 - t0, 1.0), 0.0, 1.0)
    xy = poses[j - 1, :2] * (1 - w)[:, None] + poses[j, :2] * w[:, None]
    th = theta[j - 1] * (1 - w) + theta[j] * w
    out = np.column_stack([xy, wrap_angle(th)])
    return valid, out[valid]
