"""A small simulated 2-D world for the FastSLAM tests, built from the core models only.

A robot drives ~1.5 laps of a circle among point landmarks; odometry is corrupted with the
shared motion model (``OdometryMotionModel.sample_delta``), sightings with Gaussian range and
bearing noise inside a limited sensor range.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from omnislam.core.measurement import (
    BearingElevation3D,
    RangeBearing2D,
    unit_vectors_from_azimuth_elevation,
)
from omnislam.core.motion import MotionNoise, OdometryMotionModel
from omnislam.core.se import se2_between, se2_compose, wrap_angle
from omnislam.core.types import UNKNOWN_ID, Bearings, FrameInput, Odometry, RangeBearing

#: odometry noise used to corrupt the simulated odometry and assumed by the filters
SCENARIO_NOISE = MotionNoise(a_vv=0.1, a_vw=0.1, a_wv=0.01, a_ww=0.1)
SIGMA_RANGE_M = 0.05
SIGMA_BEARING_RAD = 0.01
MAX_RANGE_M = 7.0


@dataclass(frozen=True)
class Scenario:
    """Ground truth and the frames a filter consumes."""

    true_poses: np.ndarray  # (T + 1, 3), first = start
    dead_reckoning: np.ndarray  # (T + 1, 3)
    landmarks_w: np.ndarray  # (M, 2)
    frames: list[FrameInput]

    @property
    def sightings_per_step(self) -> float:
        counts = [len(f.range_bearing) for f in self.frames if f.range_bearing is not None]
        return float(np.mean(counts))


def ring_landmarks() -> np.ndarray:
    """18 landmarks on two rings inside and outside a circle of radius 8 m, >= 3.8 m apart."""
    angles = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    inner = np.stack([5.0 * np.cos(angles), 5.0 * np.sin(angles)], axis=-1)
    outer_angles = np.linspace(0, 2 * np.pi, 10, endpoint=False) + np.pi / 10
    outer = np.stack([11.0 * np.cos(outer_angles), 11.0 * np.sin(outer_angles)], axis=-1)
    return np.concatenate([inner, outer]) + np.array([0.0, 8.0])


def make_scenario(
    seed: int,
    steps: int = 190,
    step_m: float = 0.4,
    radius_m: float = 8.0,
    unknown_ids: bool = False,
    landmarks_w: np.ndarray | None = None,
    max_range_m: float = MAX_RANGE_M,
    noise: MotionNoise = SCENARIO_NOISE,
) -> Scenario:
    """Robot starts at the origin heading +x and circles counter-clockwise around (0, 8)."""
    rng = np.random.default_rng(seed)
    motion = OdometryMotionModel(noise)
    sensor = RangeBearing2D()
    landmarks = ring_landmarks() if landmarks_w is None else landmarks_w
    dtheta = step_m / radius_m
    chord = 2 * radius_m * np.sin(dtheta / 2)
    true_delta = np.array([chord * np.cos(dtheta / 2), chord * np.sin(dtheta / 2), dtheta])
    true = [np.zeros(3)]
    odo = [np.zeros(3)]
    frames = []
    for t in range(steps):
        true.append(se2_compose(true[-1], true_delta))
        measured = motion.sample_delta(true_delta, rng)
        odo.append(se2_compose(odo[-1], measured))
        z, _, _ = sensor.predict(np.broadcast_to(true[-1], (len(landmarks), 3)), landmarks)
        seen = np.flatnonzero(z[:, 0] <= max_range_m)
        ranges = z[seen, 0] + SIGMA_RANGE_M * rng.standard_normal(seen.size)
        bearings = wrap_angle(z[seen, 1] + SIGMA_BEARING_RAD * rng.standard_normal(seen.size))
        ids = np.full(seen.size, UNKNOWN_ID) if unknown_ids else seen
        frames.append(
            FrameInput(
                index=t,
                odometry=Odometry(se2_between(odo[-2], odo[-1]), stamp_s=0.1 * (t + 1)),
                range_bearing=RangeBearing(
                    ids, np.abs(ranges), bearings, SIGMA_RANGE_M, SIGMA_BEARING_RAD
                ),
            )
        )
    return Scenario(np.array(true), np.array(odo), landmarks, frames)


def ate_rmse(estimated_xy: np.ndarray, true_xy: np.ndarray) -> float:
    """Root mean square position error (the frame is anchored at the first pose: no alignment)."""
    return float(np.sqrt(np.mean(np.sum((estimated_xy - true_xy) ** 2, axis=1))))


SENSOR_HEIGHT_M = 0.8
SIGMA_BEARING_3D_RAD = 0.005


#: milder odometry noise for the bearing-only scenario (bearing-only SLAM is far less forgiving)
BEARING_SCENARIO_NOISE = MotionNoise(a_vv=0.05, a_vw=0.03, a_wv=0.01, a_ww=0.05)


def make_bearing_scenario(
    seed: int, steps: int = 150, max_range_m: float = 8.0, outlier_fraction: float = 0.0
) -> Scenario:
    """The same loop seen by an omni camera: unit bearings to 3-D landmarks with track ids.

    With ``outlier_fraction`` > 0 that fraction of the sightings (drawn independently) point in
    a uniformly random direction but keep their track id: a front-end track that jumped to
    another point, as SIFT tracks on real images sometimes do.
    """
    rng = np.random.default_rng(seed)
    base = make_scenario(seed, steps=steps, noise=BEARING_SCENARIO_NOISE)
    heights = np.random.default_rng(seed + 1).uniform(0.2, 2.5, len(base.landmarks_w))
    landmarks = np.column_stack([base.landmarks_w, heights])
    sensor = BearingElevation3D(SENSOR_HEIGHT_M)
    frames = []
    for t, frame in enumerate(base.frames):
        pose = base.true_poses[t + 1]
        z, _, _ = sensor.predict(np.broadcast_to(pose, (len(landmarks), 3)), landmarks)
        distance = np.linalg.norm(landmarks[:, :2] - pose[:2], axis=1)
        seen = np.flatnonzero(distance <= max_range_m)
        noisy = z[seen] + SIGMA_BEARING_3D_RAD * rng.standard_normal((seen.size, 2))
        if outlier_fraction > 0:
            jumped = rng.random(seen.size) < outlier_fraction
            noisy[jumped, 0] = rng.uniform(-np.pi, np.pi, jumped.sum())
            noisy[jumped, 1] = rng.uniform(-0.5, 0.5, jumped.sum())
        frames.append(
            FrameInput(
                index=t,
                odometry=frame.odometry,
                bearings=Bearings(
                    seen,
                    unit_vectors_from_azimuth_elevation(noisy[:, 0], noisy[:, 1]),
                    np.full(seen.size, SIGMA_BEARING_3D_RAD),
                ),
            )
        )
    return Scenario(base.true_poses, base.dead_reckoning, landmarks, frames)
