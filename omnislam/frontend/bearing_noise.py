"""The angular standard deviation of every bearing the front end emits.

A keypoint's position is uncertain in the image by ``sigma_px``; the camera model turns pixel
noise into angular noise through its Jacobian (``CameraModel.angular_sigma``: the worst
direction of ``sigma_px / s_min(J_project T)``, larger where the mirror compresses the scene,
thesis eq. 4.23).
"""

from __future__ import annotations

import numpy as np

from omnislam.frontend.config import TrackConfig


def pixel_sigmas(sizes_px: np.ndarray, config: TrackConfig) -> np.ndarray:
    """(N,) keypoint localisation std [px] of keypoints of diameter ``sizes_px``."""
    return np.full(np.shape(sizes_px), config.sigma_px, dtype=float)


def bearing_sigmas(camera: object, features: object, config: TrackConfig) -> np.ndarray:
    """(N,) angular std [rad] of the bearings of ``features`` (NaN where there is no ray).

    Args:
        camera: the ``CameraModel`` the features were seen with.
        features: ``sift.Features`` (pixels and sizes).
        config: the pixel-noise model.
    """
    pixels = features.pixels  # type: ignore[attr-defined]
    sizes = features.sizes_px  # type: ignore[attr-defined]
    return camera.angular_sigma(pixels, pixel_sigmas(sizes, config))  # type: ignore[attr-defined]
