"""Simulated scenarios for the GTSAM back end, built from the core models, and tolerances.

* ``simulate_planar``: a robot driving ``laps`` loops of a circle among 2-D point landmarks;
  odometry measured through ``OdometryMotionModel.sample_delta``, range-bearing sightings
  through ``RangeBearing2D`` and bearings (vertical lines) through ``Bearing2D``, with noise.
* ``simulate_omni``: the same path among 3-D landmarks at various heights, bearings from the
  omni viewpoint at ``SENSOR_HEIGHT_M`` through ``BearingElevation3D``, with angular noise.

Every draw comes from the ``rng`` passed in: a seed gives the same scenario.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from omnislam.core.measurement import (
    Bearing2D,
    BearingElevation3D,
    RangeBearing2D,
    unit_vectors_from_azimuth_elevation,
)
from omnislam.core.motion import MotionNoise, OdometryMotionModel
from omnislam.core.se import se2_between, se2_compose
from omnislam.core.types import (
    UNKNOWN_ID,
    Bearings,
    FrameInput,
    Odometry,
    RangeBearing,
    VerticalLines,
)

#: omni viewpoint height above the robot frame [m]
SENSOR_HEIGHT_M = 0.8
#: iSAM2 (relinearisation threshold 0.1) vs LM on the same graph: poses [m], landmarks [m]
ISAM_VS_BATCH_TOL_M = 0.02
#: relative agreement of iSAM2 and batch marginal covariances
MARGINALS_RTOL = 0.05
MOTION_NOISE = MotionNoise(a_vv=0.05, a_vw=0.02, a_wv=0.01, a_ww=0.05)


def configured(config: Any, **changes: Any) -> Any:
    """``config`` (a ``GraphSLAMConfig``) with top-level fields replaced, a section's fields
    given as a dict: ``configured(c, poses={"sensor_height_m": 0.8}, compute_covariances=True)``.
    """
    fields = {
        name: replace(getattr(config, name), **value) if isinstance(value, dict) else value
        for name, value in changes.items()
    }
    return replace(config, **fields)


@dataclass(frozen=True)
class Scenario:
    """Frames to feed an estimator and the truth to score it against."""

    frames: list[FrameInput]
    poses_true: np.ndarray  # (N, 3) [x, y, theta]
    landmarks_true: np.ndarray  # (M, 2) or (M, 3)
    dead_reckoning: np.ndarray  # (N, 3) odometry integrated

    def ate(self, poses: np.ndarray) -> float:
        """RMS position error [m] (no alignment: both start at the true first pose)."""
        diff = np.asarray(poses)[:, :2] - self.poses_true[:, :2]
        return float(np.sqrt(np.mean(np.sum(diff**2, axis=1))))


def _loop_path(n: int, laps: float, radius_m: float) -> np.ndarray:
    angles = np.linspace(0.0, 2 * np.pi * laps, n)
    return np.column_stack([radius_m * np.sin(angles), radius_m * (1 - np.cos(angles)), angles])


def _odometry(poses_true: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    model = OdometryMotionModel(MOTION_NOISE)
    deltas = np.zeros_like(poses_true)
    for k in range(1, len(poses_true)):
        deltas[k] = model.sample_delta(se2_between(poses_true[k - 1], poses_true[k]), rng)
    dr = [poses_true[0]]
    for k in range(1, len(poses_true)):
        dr.append(se2_compose(dr[-1], deltas[k]))
    return deltas, np.asarray(dr)


def _odometry_chain(start: np.ndarray, frames: list[FrameInput]) -> np.ndarray:
    poses = [start]
    for frame in frames[1:]:
        poses.append(se2_compose(poses[-1], frame.odometry.delta))
    return np.asarray(poses)


def _ring_landmarks(
    m: int, rng: np.random.Generator, center: np.ndarray, r_in: float, r_out: float
) -> np.ndarray:
    angle = rng.uniform(0, 2 * np.pi, m)
    radius = np.sqrt(rng.uniform(r_in**2, r_out**2, m))
    return center + np.column_stack([radius * np.cos(angle), radius * np.sin(angle)])


def simulate_planar(
    rng: np.random.Generator,
    n: int = 150,
    laps: float = 1.5,
    landmarks: int = 30,
    max_range_m: float = 7.0,
    sigma_range_m: float = 0.05,
    sigma_bearing_rad: float = 0.01,
) -> Scenario:
    """2-D loop scenario with range-bearing sightings and vertical-line bearings (same ids)."""
    radius = 8.0
    poses = _loop_path(n, laps, radius)
    deltas, dr = _odometry(poses, rng)
    lms = _ring_landmarks(landmarks, rng, np.array([0.0, radius]), 3.0, 13.0)
    rb_model, b_model = RangeBearing2D(), Bearing2D()
    frames = []
    for k in range(n):
        z, _, _ = rb_model.predict(np.broadcast_to(poses[k], (landmarks, 3)), lms)
        seen = np.flatnonzero(z[:, 0] < max_range_m)
        ranges = z[seen, 0] + sigma_range_m * rng.standard_normal(len(seen))
        bearings = z[seen, 1] + sigma_bearing_rad * rng.standard_normal(len(seen))
        zb, _, _ = b_model.predict(np.broadcast_to(poses[k], (len(seen), 3)), lms[seen])
        lines = zb[:, 0] + sigma_bearing_rad * rng.standard_normal(len(seen))
        frames.append(
            FrameInput(
                index=k,
                odometry=Odometry(deltas[k], float(k)),
                range_bearing=RangeBearing(
                    seen, ranges, bearings, sigma_range_m, sigma_bearing_rad
                ),
                vertical_lines=VerticalLines(
                    lines,
                    sigma_bearing_rad,
                    np.zeros((len(seen), 3, 1)),
                    np.zeros((len(seen), 3)),
                    np.zeros((len(seen), 3)),
                    seen,
                ),
            )
        )
    return Scenario(frames, poses, lms, dr)


def simulate_omni(
    rng: np.random.Generator,
    n: int = 150,
    laps: float = 1.5,
    landmarks: int = 60,
    max_range_m: float = 9.0,
    sigma_rad: float = 0.005,
) -> Scenario:
    """Omni loop scenario: 3-D landmarks 0-3 m high, bearings from the viewpoint at h."""
    radius = 8.0
    poses = _loop_path(n, laps, radius)
    deltas, dr = _odometry(poses, rng)
    xy = _ring_landmarks(landmarks, rng, np.array([0.0, radius]), 2.0, 14.0)
    lms = np.column_stack([xy, rng.uniform(0.0, 3.0, landmarks)])
    model = BearingElevation3D(SENSOR_HEIGHT_M)
    frames = []
    for k in range(n):
        z, _, _ = model.predict(np.broadcast_to(poses[k], (landmarks, 3)), lms)
        seen = np.flatnonzero(np.hypot(*(lms[:, :2] - poses[k, :2]).T) < max_range_m)
        noisy = z[seen] + sigma_rad * rng.standard_normal((len(seen), 2))
        frames.append(
            FrameInput(
                index=k,
                odometry=Odometry(deltas[k], float(k)),
                bearings=Bearings(
                    seen,
                    unit_vectors_from_azimuth_elevation(noisy[:, 0], noisy[:, 1]),
                    np.full(len(seen), sigma_rad),
                ),
            )
        )
    return Scenario(frames, poses, lms, dr)


def simulate_stopping(
    rng: np.random.Generator, cruise: int = 60, stopping: int = 40, speed_m: float = 1.0
) -> Scenario:
    """A car-like run that drives away from its start, then slows geometrically to a stop.

    Victoria Park's failure in miniature: after the cruise the poses are ~1 m uncertain in
    absolute terms, while the motion model (``MotionNoise()`` defaults) makes each creeping
    step's lateral motion known to ~0.1 mm. Sightings as on Victoria Park: trees in two rows
    6 m either side, range-bearing noise 0.5 m / 0.05 rad, 15 m range, known ids.
    """
    steps = np.concatenate([np.full(cruise, speed_m), speed_m * 0.8 ** np.arange(1, stopping + 1)])
    x = np.concatenate([[0.0], np.cumsum(steps)])
    y = 0.3 * np.sin(x / 10.0)
    poses = np.column_stack([x, y, np.arctan2(np.gradient(y), np.gradient(x))])
    along = np.arange(5.0, x[-1] + 20.0, 8.0)
    lms = np.column_stack([along, np.where(np.arange(len(along)) % 2, 6.0, -6.0)])
    model, rb_model = OdometryMotionModel(MotionNoise()), RangeBearing2D()
    frames = []
    for k in range(len(poses)):
        delta = np.zeros(3)
        if k:
            delta = model.sample_delta(se2_between(poses[k - 1], poses[k]), rng)
        z, _, _ = rb_model.predict(np.broadcast_to(poses[k], (len(lms), 3)), lms)
        seen = np.flatnonzero(z[:, 0] < 15.0)
        frames.append(
            FrameInput(
                index=k,
                odometry=Odometry(delta, float(k)),
                range_bearing=RangeBearing(
                    seen,
                    z[seen, 0] + 0.5 * rng.standard_normal(len(seen)),
                    z[seen, 1] + 0.05 * rng.standard_normal(len(seen)),
                    0.5,
                    0.05,
                ),
            )
        )
    return Scenario(frames, poses, lms, _odometry_chain(poses[0], frames))


def hide_ids(frames: list[FrameInput]) -> list[FrameInput]:
    """The frames with every range-bearing id replaced by UNKNOWN_ID."""
    out = []
    for f in frames:
        rb = f.range_bearing
        out.append(
            FrameInput(
                f.index,
                f.odometry,
                range_bearing=RangeBearing(
                    np.full(len(rb), UNKNOWN_ID),
                    rb.ranges_m,
                    rb.bearings_rad,
                    rb.sigma_range_m,
                    rb.sigma_bearing_rad,
                ),
            )
        )
    return out


def add_clutter(
    frames: list[FrameInput],
    rate: float,
    max_range_m: float,
    rng: np.random.Generator,
    sigma_range_m: float = 0.05,
    sigma_bearing_rad: float = 0.01,
) -> tuple[list[FrameInput], int]:
    """Add spurious range-bearing sightings (clutter) with UNKNOWN_ID to the frames.

    Each frame gets a Poisson(``rate``) number of false detections, uniform in range (1 m to
    ``max_range_m``) and bearing (-pi..pi), never seen twice at one place -- Victoria Park's
    tree detector firing on passing objects -- with the stated sigmas.

    Returns:
        (frames with the clutter appended to their sightings, number of clutter sightings).
    """
    out, added = [], 0
    for f in frames:
        rb = f.range_bearing
        n = int(rng.poisson(rate))
        added += n
        out.append(
            FrameInput(
                f.index,
                f.odometry,
                range_bearing=RangeBearing(
                    np.concatenate([rb.landmark_ids, np.full(n, UNKNOWN_ID)]),
                    np.concatenate([rb.ranges_m, rng.uniform(1.0, max_range_m, n)]),
                    np.concatenate([rb.bearings_rad, rng.uniform(-np.pi, np.pi, n)]),
                    np.concatenate([rb.sigma_range_m, np.full(n, sigma_range_m)]),
                    np.concatenate([rb.sigma_bearing_rad, np.full(n, sigma_bearing_rad)]),
                ),
            )
        )
    return out, added


def corrupt_ids(
    frames: list[FrameInput], fraction: float, landmarks: int, rng: np.random.Generator
) -> tuple[list[FrameInput], int]:
    """Re-assign ``fraction`` of the range-bearing sightings to a wrong (other) landmark id."""
    out, wrong = [], 0
    for f in frames:
        rb = f.range_bearing
        ids = rb.landmark_ids.copy()
        flip = rng.random(len(ids)) < fraction
        ids[flip] = (ids[flip] + rng.integers(1, landmarks, flip.sum())) % landmarks
        wrong += int(flip.sum())
        out.append(
            FrameInput(
                f.index,
                f.odometry,
                range_bearing=RangeBearing(
                    ids, rb.ranges_m, rb.bearings_rad, rb.sigma_range_m, rb.sigma_bearing_rad
                ),
            )
        )
    return out, wrong


def run(estimator, frames):
    for frame in frames:
        estimator.step(frame)
    return estimator.estimate()
