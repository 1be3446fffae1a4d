"""The angular standard deviation of every bearing the front end emits.

Two factors (thesis eq. 4.23: the sensor noise may grow with the pixel's radius):

1. **Keypoint localisation** in the image: a DoG extremum is located by the Taylor expansion
   of D at its own scale (thesis eqs. 4.6-4.8), on samples spaced in proportion to that scale,
   so its error grows with the keypoint's size: ``sigma_px = a + b * size`` (size = SIFT's
   diameter, 2 sigma). Measured on the ``lab40`` and ``demo`` renders against the true points
   of the tracks (``benchmarks/bearing_noise.py``): the RMS pixel residual is 0.15 px for the
   smallest keypoints (2 px) and 0.7 px at 19 px; the least-squares line through the per-size
   RMS is ``a = 0.09 px``, ``b = 0.027`` (``TrackConfig.sigma_px``, ``sigma_px_per_size``).
2. **The camera model** turns pixel noise into angular noise through its Jacobian
   (``CameraModel.angular_sigma``: ``sigma_px / s_min(J_project T)`` along the worst direction
   of the tangent plane; on the hyperbolic mirror the angle per pixel shrinks towards the rim).

The residuals have heavier tails than a Gaussian (per size, their RMS is ~1.8x the MAD-based
std: keypoints on corners and silhouettes slide as the viewpoint moves). The sigma matches
their RMS (moment matching: the weight least squares needs, and the spread the estimators'
chi-square gates must admit), so the median normalised residual is ~0.6 of a Gaussian's.
"""

from __future__ import annotations

import numpy as np

from omnislam.frontend.config import TrackConfig


def pixel_sigmas(sizes_px: np.ndarray, config: TrackConfig) -> np.ndarray:
    """(N,) keypoint localisation std [px] of keypoints of SIFT diameter ``sizes_px``."""
    return config.sigma_px + config.sigma_px_per_size * np.asarray(sizes_px, dtype=float)


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
