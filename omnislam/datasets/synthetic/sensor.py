"""A camera sensor between the renderer's scene radiance and the image written to disk.

The renderer's clean 8-bit output is taken as the scene radiance seen by each pixel (a display
value: linear radiance is ``(value / 255) ** gamma``). ``CameraSensor.capture`` turns it into
the image a small colour CMOS board camera would record, in the order light meets the parts:

1. **motion blur** from the robot's own motion during the exposure: each pixel's world point
   (``RenderedFrame.points_w``) is projected through the rig at the poses of the exposure's
   start and end (the route's ground truth, interpolated), and the radiance is averaged along
   that image motion (``motion_blur``);
2. the mirror's **vignetting**, a radial falloff about the image centre (``vignetting_gain``);
3. **photons to electrons** for the exposure time, saturating at the full-well capacity;
4. **shot and read noise** and **gain**, in the linear camera model of EMVA 1288 (Release 4
   Linear, sec. 2): ``mu_y = K mu_e``, ``sigma_y^2 = K^2 (sigma_d^2 + mu_e) + 1/12``; the
   photon (Poisson) noise is drawn as a Gaussian of the same variance (exact to <1 % of the
   variance above ~20 electrons, every pixel but the darkest);
5. a 12-bit ADC and the camera's **display encoding** (gamma) as an 8-bit lookup table:
   quantisation to ``uint8``;
6. optional **JPEG compression** (OpenCV ``imencode``/``imdecode``) at a stated quality.

An **auto-exposure** controller chooses each frame's exposure time and gain from the previous
frame's mean brightness with a lag (``AutoExposureConfig``), so exposure drifts along a route
as a real camera's does; exposure time first, gain once the time reaches its limit.

The default parameters are those of a typical 1/4" colour board camera with ~1.1-1.4 um
pixels (the Raspberry Pi camera's Sony IMX219 / OmniVision OV5647 class): a full-well capacity
of 4500 electrons, 3 electrons of read (temporal dark) noise, an analogue gain up to 8x (18 dB),
exposure 0.1-40 ms. They are representative values of that class stated in EMVA 1288 terms,
not one camera's measured data sheet. Colour channels are treated as three independent
pixels (no Bayer mosaic, no demosaicing); pixels outside the camera's mask stay black.

All randomness comes from ``np.random.default_rng((seed, SENSOR_STREAM, frame_index))``, so a
render is byte-deterministic for its seed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache
from statistics import NormalDist

import numpy as np

from omnislam.camera.rig import CameraRig
from omnislam.core.se import se3_from_se2, se3_inverse, se3_transform_points
from omnislam.datasets._common import interpolate_se2
from omnislam.errors import ConfigError

#: the sensor's entry in a render's seed sequence (the world and the route use others)
SENSOR_STREAM = 0x5E
#: bits of the analogue-to-digital converter before the 8-bit display encoding
ADC_BITS = 12


@dataclass(frozen=True, slots=True)
class PixelConfig:
    """The pixels' electrons and noise (EMVA 1288 linear model).

    Attributes:
        full_well_e: saturation capacity [electrons]. Default 4500: a 1.1-1.4 um pixel.
        read_noise_e: temporal dark (read) noise [electrons rms]. Default 3.0: typical of
            that pixel class at unity gain.
        reference_exposure_s: the exposure at which a clean value of 255 fills the full well
            [s] (sets how bright the rendered scene is in photons). Default 0.02: the rendered
            rooms then need 15-30 ms, an indoor exposure.
    """

    full_well_e: float = 4500.0
    read_noise_e: float = 3.0
    reference_exposure_s: float = 0.02

    def __post_init__(self) -> None:
        if not (self.full_well_e > 0 and self.read_noise_e >= 0 and self.reference_exposure_s > 0):
            raise ConfigError("PixelConfig: full_well_e > 0, read_noise_e >= 0, "
                              "reference_exposure_s > 0")


@dataclass(frozen=True, slots=True)
class AutoExposureConfig:
    """The auto-exposure controller: log exposure steered towards a target mean brightness.

    ``log H_{k+1} = log H_k + rate * gamma * log(target / mean_k)`` where ``H`` = exposure time
    x gain and ``mean_k`` the mean 8-bit value of frame k inside the mask (``gamma``: the
    display encoding's exponent, so that a step undoes a brightness error in one go at
    ``rate`` 1). ``H`` is spent on exposure time first, then on gain.

    Attributes:
        target_mean: the mean 8-bit brightness aimed at. Default 100: the VMR lab images'
            mean (92-109).
        rate: fraction of the log error corrected per frame (0 = fixed exposure). Default 0.3:
            a lag of a few frames, as small cameras' controllers have.
        initial_exposure_s: exposure time of the first frame [s]. Default 0.02.
        min_exposure_s, max_exposure_s: exposure time limits [s]. Defaults 1e-4 and 0.04
            (below the 10 Hz frame period).
        max_gain: analogue gain limit (unity = 1). Default 8 (18 dB).
    """

    target_mean: float = 100.0
    rate: float = 0.3
    initial_exposure_s: float = 0.02
    min_exposure_s: float = 1e-4
    max_exposure_s: float = 0.04
    max_gain: float = 8.0

    def __post_init__(self) -> None:
        if not (0 < self.target_mean < 255 and 0 <= self.rate <= 1 and self.max_gain >= 1
                and 0 < self.min_exposure_s <= self.initial_exposure_s <= self.max_exposure_s):
            raise ConfigError("AutoExposureConfig: 0 < target_mean < 255, 0 <= rate <= 1, "
                              "max_gain >= 1, min <= initial <= max exposure")


@dataclass(frozen=True, slots=True)
class VignettingConfig:
    """The mirror's radial falloff: ``g(rho) = (1 + a rho^2)^-2`` (the cos^4 law's form) with
    ``rho`` the radius over the mask's outer radius and ``a`` such that ``g(1) = rim_gain``.

    Attributes:
        rim_gain: relative illumination at the mask's outer radius (1 = none). Default 0.6:
            catadioptric images lose ~40 % towards the mirror's rim.
    """

    rim_gain: float = 0.6

    def __post_init__(self) -> None:
        if not 0 < self.rim_gain <= 1:
            raise ConfigError("VignettingConfig: 0 < rim_gain <= 1")


@dataclass(frozen=True, slots=True)
class MotionBlurConfig:
    """How the blur along each pixel's image motion is computed.

    Attributes:
        flow_step_px: the image motion is projected on a grid of this pitch and interpolated
            between (a full-resolution projection costs twice the render). Default 8: the
            motion varies slowly except at depth edges, where the parallax of a few
            millimetres of travel is sub-pixel (and within a grid step of the mask's edge,
            where samples outside the mask count as still).
        max_samples: at most this many samples along a pixel's motion (one per pixel of the
            longest motion). Default 9.
    """

    flow_step_px: int = 8
    max_samples: int = 9

    def __post_init__(self) -> None:
        if self.flow_step_px < 1 or self.max_samples < 2:
            raise ConfigError("MotionBlurConfig: flow_step_px >= 1, max_samples >= 2")


@dataclass(frozen=True, slots=True)
class SensorConfig:
    """The camera sensor model's parameters (module docstring), one section per part.

    Attributes:
        pixel: full well, read noise and the radiance scale.
        exposure: the auto-exposure controller.
        vignetting: the mirror's radial falloff; None: none.
        motion_blur: blur from the robot's motion during the exposure; None: none.
        gamma: exponent of the display encoding (linear = value ** gamma). Default 2.2: sRGB's
            approximate exponent, what a board camera's image processor outputs.
        jpeg_quality: JPEG quality 1-100 of a compression round trip; None: none. Default 90:
            the quality of a camera's JPEG stream (the real images compared are JPEGs).
    """

    pixel: PixelConfig = field(default_factory=PixelConfig)
    exposure: AutoExposureConfig = field(default_factory=AutoExposureConfig)
    vignetting: VignettingConfig | None = field(default_factory=VignettingConfig)
    motion_blur: MotionBlurConfig | None = field(default_factory=MotionBlurConfig)
    gamma: float = 2.2
    jpeg_quality: int | None = 90

    def __post_init__(self) -> None:
        if not self.gamma > 0:
            raise ConfigError("SensorConfig: gamma > 0")
        if self.jpeg_quality is not None and not 1 <= self.jpeg_quality <= 100:
            raise ConfigError("SensorConfig: jpeg_quality in 1..100 or None")


@dataclass(frozen=True, slots=True)
class Exposure:
    """One frame's exposure.

    Attributes:
        time_s: exposure time [s].
        gain: analogue gain (1 = unity).
    """

    time_s: float
    gain: float


class AutoExposure:
    """The controller of ``AutoExposureConfig``: ``current`` for the next frame, ``update``
    with the mean brightness that frame came out with."""

    def __init__(self, config: AutoExposureConfig, gamma: float) -> None:
        self.config = config
        self.gamma = gamma
        self._log_h = math.log(config.initial_exposure_s)

    @property
    def current(self) -> Exposure:
        """Exposure time and gain for the next frame (time first, then gain)."""
        c = self.config
        h = math.exp(self._log_h)
        time_s = min(max(h, c.min_exposure_s), c.max_exposure_s)
        return Exposure(time_s, min(max(h / time_s, 1.0), c.max_gain))

    def update(self, mean_value: float) -> None:
        """Steer by the mean 8-bit value of the frame just taken, ``H`` kept in its limits."""
        c = self.config
        error = math.log(c.target_mean / max(mean_value, 0.5))
        self._log_h += c.rate * self.gamma * error
        self._log_h = min(max(self._log_h, math.log(c.min_exposure_s)),
                          math.log(c.max_exposure_s * c.max_gain))


def pose_at(stamps_s: np.ndarray, poses_w: np.ndarray, t_s: float) -> np.ndarray:
    """The (3,) planar pose at time ``t_s`` (``datasets._common.interpolate_se2``: linear, the
    heading unwrapped), held at the route's ends.

    Args:
        stamps_s: (N,) increasing times [s].
        poses_w: (N, 3) poses [x, y, theta] in the world.
    """
    t = np.clip(np.array([t_s], dtype=float), stamps_s[0], stamps_s[-1])
    return interpolate_se2(stamps_s, poses_w, t, math.inf)[1][0]


def image_motion(
    rig: CameraRig, points_w: np.ndarray, wTr_start: np.ndarray, wTr_end: np.ndarray, step_px: int
) -> np.ndarray:
    """(H, W, 2) image motion [px] of each pixel's world point from the exposure's start to its
    end, projected on a grid of ``step_px`` pitch and interpolated bilinearly; 0 where a pixel
    sees nothing.

    Args:
        rig: the camera rig.
        points_w: (H, W, 3) the world point of each pixel (NaN: none).
        wTr_start, wTr_end: (3,) planar robot poses at the exposure's start and end.
        step_px: the grid's pitch [px].
    """
    cv2 = _cv2()
    height, width = points_w.shape[:2]
    grid = points_w[step_px // 2::step_px, step_px // 2::step_px]
    flat = grid.reshape(-1, 3).astype(float)
    ends = [rig.project_r(se3_transform_points(se3_inverse(se3_from_se2(wTr)), flat))[0]
            for wTr in (wTr_start, wTr_end)]
    motion = np.nan_to_num(ends[1] - ends[0], nan=0.0).astype(np.float32)
    motion = motion.reshape(*grid.shape[:2], 2)
    # cv2.resize maps output pixel x to grid coordinate (x + 0.5) / step - 0.5: the grid's
    # samples sit at the pixels step // 2 + k step (exact for an even step dividing the sides,
    # as 8 divides the presets' 640 px)
    return cv2.resize(motion, (width, height), interpolation=cv2.INTER_LINEAR)


def motion_blur(radiance: np.ndarray, motion_px: np.ndarray, max_samples: int) -> np.ndarray:
    """Radiance averaged along each pixel's image motion during the exposure.

    A pixel ``p`` records ``(1/T) int I(p - s m(p)) ds`` over ``s`` in [-1/2, 1/2] (``m`` the
    motion over the exposure ``T``, the clean image ``I`` taken at its middle), sampled at
    ``n = min(max_samples, ceil(max |m|) + 1)`` evenly spaced ``s`` with bilinear lookups.

    Args:
        radiance: (H, W, C) float32 radiance.
        motion_px: (H, W, 2) float32 motion [px].
        max_samples: the most samples along a motion.

    Returns:
        (H, W, C) float32; ``radiance`` itself when no pixel moves half a pixel.
    """
    cv2 = _cv2()
    motion_u, motion_v = cv2.split(motion_px)  # contiguous planes: 10x faster arithmetic
    longest = float(cv2.minMaxLoc(cv2.magnitude(motion_u, motion_v))[1])
    if longest < 0.5:
        return radiance
    n = int(min(max_samples, math.ceil(longest) + 1))
    height, width = radiance.shape[:2]
    u, v = np.meshgrid(np.arange(width, dtype=np.float32), np.arange(height, dtype=np.float32))
    total = np.zeros_like(radiance)
    for s in np.linspace(-0.5, 0.5, n):
        sample = cv2.remap(radiance, cv2.scaleAdd(motion_u, -s, u), cv2.scaleAdd(motion_v, -s, v),
                           cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        total += sample.reshape(radiance.shape)
    total *= np.float32(1.0 / n)
    return total


def vignetting_gain(mask: np.ndarray, centre_px: tuple[float, float], rim_gain: float
                    ) -> np.ndarray:
    """(H, W) float32 relative illumination ``(1 + a rho^2)^-2``, ``rho`` = radius about
    ``centre_px`` over the mask's outer radius, ``a`` so that the rim gets ``rim_gain``
    (``VignettingConfig``); decreasing with the radius.

    Args:
        mask: (H, W) bool, the camera's usable pixels.
        centre_px: (u, v) the image centre (the mirror axis' image) [px].
        rim_gain: illumination at the outer radius, relative to the centre's.
    """
    height, width = mask.shape
    u, v = np.meshgrid(np.arange(width) - centre_px[0], np.arange(height) - centre_px[1])
    radius = np.hypot(u, v)
    outer = float(radius[mask].max()) if mask.any() else float(radius.max())
    a = 1.0 / math.sqrt(rim_gain) - 1.0
    return ((1.0 + a * (radius / outer) ** 2) ** -2).astype(np.float32)


def display_lut(gamma: float) -> np.ndarray:
    """(2^ADC_BITS,) uint8: the display encoding ``255 (x / x_max) ** (1 / gamma)``, rounded."""
    levels = (1 << ADC_BITS) - 1
    return np.rint(255.0 * (np.arange(levels + 1) / levels) ** (1.0 / gamma)).astype(np.uint8)


def expose(
    radiance: np.ndarray, exposure: Exposure, pixel: PixelConfig, lut: np.ndarray,
    rng: np.random.Generator
) -> np.ndarray:
    """Linear radiance in [0, 1] to an 8-bit image: electrons, noise, gain, ADC, encoding.

    ``mu_e = radiance * full_well * t / t_ref``; ``e = min(mu_e + sqrt(mu_e + sigma_d^2) z,
    full_well)`` with ``z`` standard normal (``standard_normal``: the charge saturates);
    ``adc = round(e * gain * (2^12 - 1) / full_well)`` clipped to the ADC's range; the image is
    ``lut[adc]`` (EMVA 1288 linear model, system gain ``K = gain (2^12 - 1) / full_well``
    DN/e).

    Args:
        radiance: (H, W, C) float32 linear radiance, 1 = a clean value of 255; overwritten.
        exposure: time and gain.
        pixel: full well, read noise, reference exposure.
        lut: ``display_lut`` of the encoding.
        rng: the frame's generator.

    Returns:
        (H, W, C) uint8.
    """
    electrons = radiance
    electrons *= np.float32(pixel.full_well_e * exposure.time_s / pixel.reference_exposure_s)
    sigma = np.add(electrons, np.float32(pixel.read_noise_e ** 2))
    np.sqrt(sigma, out=sigma)
    sigma *= standard_normal(rng, electrons.shape)
    electrons += sigma
    np.minimum(electrons, np.float32(pixel.full_well_e), out=electrons)
    levels = (1 << ADC_BITS) - 1
    electrons *= np.float32(exposure.gain * levels / pixel.full_well_e)
    np.clip(electrons, 0, levels, out=electrons)
    np.rint(electrons, out=electrons)
    return np.take(lut, electrons.astype(np.uint16))


#: levels of the normal samples' quantile table (``standard_normal``)
NORMAL_LEVELS = 256


@lru_cache(maxsize=1)
def _normal_quantiles() -> np.ndarray:
    """(NORMAL_LEVELS,) float32 quantiles of the standard normal at the bins' centres, scaled
    to unit variance."""
    normal = NormalDist()
    quantiles = np.array([normal.inv_cdf((k + 0.5) / NORMAL_LEVELS)
                          for k in range(NORMAL_LEVELS)])
    return (quantiles / quantiles.std()).astype(np.float32)


def standard_normal(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """Standard normal float32 samples as the quantiles of uniform bytes (inverse transform
    sampling on ``NORMAL_LEVELS`` equal-probability bins, scaled to variance exactly 1;
    truncated at +-2.9 sigma, where 0.4 % of a normal's mass lies beyond): ~10x faster than
    ``rng.standard_normal`` for the ~10^6 samples of an image, and noise only enters the
    images through its variance and its spatial independence."""
    cv2 = _cv2()
    codes = rng.integers(0, NORMAL_LEVELS, size=shape, dtype=np.uint8)
    if len(shape) == 3 and shape[2] in (1, 3, 4):
        return cv2.LUT(codes, _normal_quantiles())
    return np.take(_normal_quantiles(), codes)


def jpeg_round_trip(image_rgb: np.ndarray, quality: int) -> np.ndarray:
    """The (H, W, 3) uint8 RGB image after JPEG compression at ``quality`` (OpenCV)."""
    cv2 = _cv2()
    ok, data = cv2.imencode(".jpg", image_rgb[..., ::-1], [cv2.IMWRITE_JPEG_QUALITY, quality])
    if not ok:  # pragma: no cover - OpenCV encodes any uint8 image
        raise ConfigError("JPEG encoding failed")
    return np.ascontiguousarray(cv2.imdecode(data, cv2.IMREAD_COLOR)[..., ::-1])


class CameraSensor:
    """The sensor of one render: its auto-exposure state runs along the route's images, so
    ``capture`` must see them in order (module docstring).

    Args:
        config: the sensor's parameters.
        rig: the camera rig (its mask, centre and projection).
        stamps_s: (N,) the route's frame times [s].
        poses_w: (N, 3) the route's true planar poses (the exposure's poses interpolate them).
        seed: the render's seed.
    """

    def __init__(self, config: SensorConfig, rig: CameraRig, stamps_s: np.ndarray,
                 poses_w: np.ndarray, seed: int) -> None:
        self.config = config
        self.rig = rig
        self.stamps_s = np.asarray(stamps_s, dtype=float)
        self.poses_w = np.asarray(poses_w, dtype=float)
        self.seed = int(seed)
        camera = rig.camera
        self.mask = np.asarray(camera.mask(), dtype=bool)
        # the vignetting's centre: the principal point (cu, cv), else the image's centre
        self._mask_u8 = self.mask.astype(np.uint8)
        centre = (float(getattr(camera, "cu", (camera.width - 1) / 2)),
                  float(getattr(camera, "cv", (camera.height - 1) / 2)))
        self.vignetting = (None if config.vignetting is None else np.repeat(
            vignetting_gain(self.mask, centre, config.vignetting.rim_gain)[..., None], 3, axis=2))
        self.to_linear = ((np.arange(256) / 255.0) ** config.gamma).astype(np.float32)
        self.lut = display_lut(config.gamma)
        self.auto_exposure = AutoExposure(config.exposure, config.gamma)
        self.exposures: list[Exposure] = []

    def capture(self, image: np.ndarray, points_w: np.ndarray, frame_index: int) -> np.ndarray:
        """The recorded (H, W, 3) uint8 RGB image of a clean render at frame ``frame_index``.

        Args:
            image: (H, W, 3) uint8 the renderer's clean image (the scene radiance).
            points_w: (H, W, 3) the renderer's world point of each pixel (NaN: none).
            frame_index: the frame's index on the route (its stamp, its seed).
        """
        cv2 = _cv2()
        exposure = self.auto_exposure.current
        radiance = cv2.LUT(image, self.to_linear)
        if self.config.motion_blur is not None:
            radiance = self._blur(radiance, points_w, frame_index, exposure.time_s,
                                  self.config.motion_blur)
        if self.vignetting is not None:
            radiance *= self.vignetting
        rng = np.random.default_rng((self.seed, SENSOR_STREAM, int(frame_index)))
        out = expose(radiance, exposure, self.config.pixel, self.lut, rng)
        if self.config.jpeg_quality is not None:
            out = jpeg_round_trip(out, self.config.jpeg_quality)
        out *= self._mask_u8[..., None]  # after the JPEG's ringing
        self.auto_exposure.update(float(np.mean(cv2.mean(out, self._mask_u8)[:3])))
        self.exposures.append(exposure)
        return out

    def _blur(self, radiance: np.ndarray, points_w: np.ndarray, frame_index: int,
              exposure_s: float, blur: MotionBlurConfig) -> np.ndarray:
        """``radiance`` blurred by the motion between the exposure's start and end poses, the
        exposure centred on the frame's stamp."""
        stamp_s = float(self.stamps_s[frame_index])
        start, end = (pose_at(self.stamps_s, self.poses_w, stamp_s + d * exposure_s)
                      for d in (-0.5, 0.5))
        motion = image_motion(self.rig, points_w, start, end, blur.flow_step_px)
        return motion_blur(radiance, motion, blur.max_samples)


def _cv2() -> object:
    from omnislam._optional import require

    return require("cv2")
