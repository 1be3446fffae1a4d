"""The existence index of thesis sec. 5.1.2: which landmarks the sensor should have seen.

A landmark's index rises by one when it is seen and falls by one when it lies inside the
sensor's field (range, horizontal field of view and, for the omni camera, elevation band) from
the particle's pose but was not seen; it is deleted once negative. This removes landmarks born
from wrong correspondences.
"""

from __future__ import annotations

import numpy as np

from omnislam.core.se import wrap_angle
from omnislam.fastslam.config import ExistenceIndexConfig


def predicted_visible(
    config: ExistenceIndexConfig,
    wTr: np.ndarray,
    landmarks_w: np.ndarray,
    sensor_height_m: float = 0.0,
) -> np.ndarray:
    """Whether each landmark lies inside the sensor's field from each pose.

    Args:
        config: the sensor field.
        wTr: (N, 3) poses.
        landmarks_w: (N, 2) or (N, 3) landmark positions.
        sensor_height_m: viewpoint height for 3-D landmarks [m].

    Returns:
        (N,) bool.
    """
    dx = landmarks_w[:, 0] - wTr[:, 0]
    dy = landmarks_w[:, 1] - wTr[:, 1]
    horizontal = np.hypot(dx, dy)
    if landmarks_w.shape[1] > 2:
        dz = landmarks_w[:, 2] - sensor_height_m
        distance = np.hypot(horizontal, dz)
        elevation = np.arctan2(dz, horizontal)
        in_band = (elevation >= config.min_elevation_rad) & (elevation <= config.max_elevation_rad)
    else:
        distance = horizontal
        in_band = np.ones(len(dx), dtype=bool)
    bearing = wrap_angle(np.arctan2(dy, dx) - wTr[:, 2])
    in_range = (distance >= config.min_range_m) & (distance <= config.max_range_m)
    return in_range & in_band & (np.abs(bearing) <= config.half_fov_rad)
