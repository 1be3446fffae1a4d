"""SIFT keypoints and descriptors on the raw omnidirectional image (Lowe 2004; thesis 4.1).

The detector runs on the unwarped catadioptric image, restricted to the camera's usable ring
(thesis Fig. 5.15) shrunk by a margin so that the sharp border of the ring does not produce
keypoints of its own. Two backends:

- OpenCV, the default. ``SiftConfig.first_octave`` picks the scale space: Lowe's doubled image
  (``cv2.SIFT``'s own detector), or octave -1 sampled at the image's pixels
  (``scale_space.detect_keypoints``, the default of the omni preset, at about half the CPU of
  the doubled detector on lab40's 640 x 640 images), or no octave -1; OpenCV's descriptor in
  every case;
- COLMAP's SIFT through ``pycolmap.FeatureExtractor`` (~5x slower; ``pycolmap.Sift`` is
  deprecated), for users who want COLMAP-compatible features.

Presets are ``config.LOWE`` (C = 0.03, R = 10, doubled) and ``config.OMNI_THESIS`` (R ~ 2,
thesis 4.1.2, eq. 4.15: the principal-curvature ratio is larger on omni images; native).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from omnislam._optional import require
from omnislam.errors import DataError
from omnislam.frontend.config import FirstOctave, SiftBackend, SiftConfig
from omnislam.frontend.scale_space import (
    bucket_at,
    budget_buckets,
    detect_keypoints,
    strongest_per_bucket,
)

#: descriptor length of SIFT (4 x 4 cells x 8 orientations)
DESCRIPTOR_SIZE = 128
#: the usable ring is shrunk by this many pixels before detection
MASK_MARGIN_PX = 4


@dataclass(frozen=True, slots=True)
class Features:
    """The keypoints of one image.

    Attributes:
        pixels: (N, 2) ``[u, v]`` keypoint positions [px] (pixel-centre convention of
            ``omnislam.camera.base``).
        sizes_px: (N,) keypoint diameters (scale) [px].
        angles_rad: (N,) dominant gradient orientations [rad].
        contrast: (N,) detector response |D(x^)| (thesis eq. 4.9; backend-specific units).
        descriptors: (N, 128) float32 descriptors, L2-normalised to 512 (OpenCV's scale).
    """

    pixels: np.ndarray
    sizes_px: np.ndarray
    angles_rad: np.ndarray
    contrast: np.ndarray
    descriptors: np.ndarray

    def __len__(self) -> int:
        return int(self.pixels.shape[0])

    def subset(self, index: np.ndarray) -> Features:
        """The features selected by an index or boolean mask."""
        return Features(
            self.pixels[index],
            self.sizes_px[index],
            self.angles_rad[index],
            self.contrast[index],
            self.descriptors[index],
        )

    @staticmethod
    def empty() -> Features:
        return Features(
            np.zeros((0, 2)),
            np.zeros(0),
            np.zeros(0),
            np.zeros(0),
            np.zeros((0, DESCRIPTOR_SIZE), dtype=np.float32),
        )


def detection_mask(usable: np.ndarray | None, shape: tuple[int, int]) -> np.ndarray:
    """uint8 detection mask: the usable region eroded by ``MASK_MARGIN_PX`` (255 = detect).

    Args:
        usable: (H, W) bool usable region (``CameraModel.mask()``), or None for the whole image.
        shape: (H, W) of the image.
    """
    if usable is None:
        return np.full(shape, 255, dtype=np.uint8)
    usable = np.asarray(usable, dtype=bool)
    if usable.shape != shape:
        raise DataError(f"mask shape {usable.shape} differs from the image's {shape}")
    cv2 = require("cv2")
    size = 2 * MASK_MARGIN_PX + 1
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))
    return cv2.erode(usable.astype(np.uint8) * 255, kernel)


def _grey(image: np.ndarray) -> np.ndarray:
    image = np.asarray(image)
    if image.ndim == 3 and image.shape[2] == 3:
        cv2 = require("cv2")
        return cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
    if image.ndim == 2:
        return image
    raise DataError(f"expected an (H, W) or (H, W, 3) image, got shape {image.shape}")


class SiftExtractor:
    """Extracts SIFT features with one configuration (the detector object is built once).

    Args:
        config: detector settings and backend (``config.LOWE``, ``config.OMNI_THESIS``...).
    """

    def __init__(self, config: SiftConfig) -> None:
        self.config = config
        self._area: tuple[np.ndarray, int] | None = None  # (mask, its non-zero pixels)
        self._buckets: tuple[np.ndarray | None, np.ndarray] | None = None  # (mask, buckets)
        if config.backend is SiftBackend.OPENCV:
            cv2 = require("cv2")
            # OpenCV divides contrastThreshold by the number of layers (see cv2.SIFT_create);
            # Lowe's C is per layer, hence the product.
            def opencv_sift(sigma: float):  # noqa: ANN202 (a cv2.SIFT)
                return cv2.SIFT_create(
                    nfeatures=config.max_features,
                    nOctaveLayers=config.n_octave_layers,
                    contrastThreshold=config.contrast_threshold * config.n_octave_layers,
                    edgeThreshold=config.edge_threshold,
                    sigma=sigma,
                    enable_precise_upscale=config.precise_upscale,
                )

            self._sift = opencv_sift(config.sigma)
            # octave -1 sampled at the image's pixels is octave 0 of a SIFT with half the sigma
            self._sift_fine = opencv_sift(config.sigma / 2)
        else:
            pycolmap = require("pycolmap")
            options = pycolmap.FeatureExtractionOptions()
            options.use_gpu = False
            options.num_threads = 1
            sift = options.sift
            sift.peak_threshold = config.contrast_threshold / config.n_octave_layers
            sift.edge_threshold = config.edge_threshold
            sift.octave_resolution = config.n_octave_layers
            sift.first_octave = -1 if config.first_octave is FirstOctave.DOUBLED else 0
            if config.max_features:
                sift.max_num_features = config.max_features
            self._sift = pycolmap.FeatureExtractor.create(options, pycolmap.Device.cpu)

    def extract(self, image: np.ndarray, mask: np.ndarray | None = None) -> Features:
        """Detect and describe keypoints.

        Args:
            image: (H, W, 3) RGB or (H, W) grey uint8 image.
            mask: (H, W) uint8 detection mask from ``detection_mask`` (None: whole image).

        Returns:
            The features, strongest first is not guaranteed.
        """
        grey = _grey(image)
        if self.config.backend is SiftBackend.OPENCV:
            features = self._extract_opencv(grey, mask)
        else:
            features = self._extract_pycolmap(grey, mask)
        budget = self.budget(grey.shape, mask)
        if budget and len(features) > budget:  # the backends that cannot budget themselves
            buckets = self.buckets(grey.shape, mask)
            features = features.subset(strongest_per_bucket(
                features.contrast, bucket_at(buckets, features.pixels),
                int(buckets.max()) + 1, budget))
        return features

    def buckets(self, shape: tuple[int, ...], mask: np.ndarray | None) -> np.ndarray:
        """(H, W) bucket of every pixel for the keypoint budget (``scale_space.budget_buckets``
        over the mask, else the whole image), computed once per mask."""
        if (self._buckets is None or self._buckets[0] is not mask
                or self._buckets[1].shape != tuple(shape[:2])):
            region = np.ones(shape[:2], dtype=np.uint8) if mask is None else mask
            self._buckets = (mask, budget_buckets(region, self.config.budget_bands,
                                                  self.config.budget_sectors))
        return self._buckets[1]

    def budget(self, shape: tuple[int, ...], mask: np.ndarray | None) -> int:
        """Most features ``SiftConfig.features_per_kpx`` keeps on an image (0: no limit)."""
        if not self.config.features_per_kpx:
            return 0
        if mask is None:
            area = shape[0] * shape[1]
        else:  # the mask is the same for every image of a camera: counted once
            if self._area is None or self._area[0] is not mask:
                self._area = (mask, int(np.count_nonzero(mask)))
            area = self._area[1]
        return max(1, round(self.config.features_per_kpx * area / 1000.0))

    def _extract_opencv(self, grey: np.ndarray, mask: np.ndarray | None) -> Features:
        cfg = self.config
        if cfg.first_octave is FirstOctave.DOUBLED:
            keypoints, descriptors = self._sift.detectAndCompute(grey, mask)
            if not keypoints:
                return Features.empty()
            return Features(
                pixels=np.array([k.pt for k in keypoints], dtype=float),
                sizes_px=np.array([k.size for k in keypoints], dtype=float),
                angles_rad=np.deg2rad([k.angle for k in keypoints]),
                contrast=np.array([k.response for k in keypoints], dtype=float),
                descriptors=np.ascontiguousarray(descriptors, dtype=np.float32),
            )
        # the budgets are applied before the orientations and descriptors are computed (the
        # same features as computing them all and keeping the strongest: a test)
        limits = [b for b in (cfg.max_features, self.budget(grey.shape, mask)) if b]
        found = detect_keypoints(
            grey, mask, sigma=cfg.sigma, layers=cfg.n_octave_layers,
            contrast_threshold=cfg.contrast_threshold, edge_threshold=cfg.edge_threshold,
            fine=cfg.first_octave in (FirstOctave.NATIVE, FirstOctave.HALVED),
            halved=cfg.first_octave is FirstOctave.HALVED, max_keypoints=min(limits, default=0),
            buckets=self.buckets(grey.shape, mask) if limits == [self.budget(grey.shape, mask)]
            else None)
        if cfg.max_features:  # strongest first
            found = found.subset(np.argsort(-found.response, kind="stable"))
        if len(found) == 0:
            return Features.empty()
        # OpenCV's descriptor, computed by a SIFT of half the sigma: its octave o is Lowe's
        # octave o - 1 (same scales) sampled at half the resolution, so octave -1 is described
        # at the image's pixels and every octave on samples 0.8 sigma instead of 1.6 sigma
        # apart (on lab40's first 150 images this left track precision and triangulation
        # error unchanged and took a quarter off SIFT's time, against describing octaves
        # >= 0 on their own pyramid by a second SIFT)
        native = cfg.first_octave in (FirstOctave.NATIVE, FirstOctave.HALVED)
        describer = self._sift_fine if native else self._sift
        offset = 1 if native else 0
        _, descriptors = describer.compute(grey, found.keypoints(offset))
        return Features(
            pixels=np.column_stack([found.x, found.y]),
            sizes_px=2.0 * found.sigma,
            angles_rad=np.deg2rad(found.angle_deg),
            contrast=found.response.astype(float),
            descriptors=np.ascontiguousarray(descriptors, dtype=np.float32),
        )

    def _extract_pycolmap(self, grey: np.ndarray, mask: np.ndarray | None) -> Features:
        keypoints, descriptors = self._sift.extract_from_uint8_array(
            np.ascontiguousarray(grey)
        )
        if len(keypoints) == 0:
            return Features.empty()
        # COLMAP puts the top-left image corner at (0, 0): pixel centres are at +0.5.
        pixels = np.array([(k.x - 0.5, k.y - 0.5) for k in keypoints], dtype=float)
        scales = np.array([k.compute_scale() for k in keypoints], dtype=float)
        angles = np.array([k.compute_orientation() for k in keypoints], dtype=float)
        raw = np.asarray(descriptors.data, dtype=np.float32)
        norms = np.maximum(np.linalg.norm(raw, axis=1, keepdims=True), 1e-12)
        # COLMAP gives no contrast; its features come sorted by it, so use the rank instead.
        contrast = np.linspace(1.0, 0.5, len(keypoints))
        features = Features(pixels, 2.0 * scales, angles, contrast, 512.0 * raw / norms)
        if mask is None:
            return features
        u = np.clip(np.round(pixels[:, 0]).astype(int), 0, mask.shape[1] - 1)
        v = np.clip(np.round(pixels[:, 1]).astype(int), 0, mask.shape[0] - 1)
        return features.subset(mask[v, u] > 0)
