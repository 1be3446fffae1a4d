"""The camera sensor model's statistics: noise of a flat patch, 8-bit output, vignetting,
blur length, the image motion of a turn, auto-exposure."""

from __future__ import annotations

import math

import numpy as np
import pytest

from omnislam.camera.pinhole import PinholeCamera
from omnislam.camera.rig import CameraRig
from omnislam.datasets.synthetic.presets import PRESETS
from omnislam.datasets.synthetic.sensor import (
    ADC_BITS,
    AutoExposureConfig,
    CameraSensor,
    Exposure,
    PixelConfig,
    SensorConfig,
    display_lut,
    expose,
    image_motion,
    motion_blur,
    standard_normal,
    vignetting_gain,
)

pytest.importorskip("cv2")

#: relative tolerance on a variance measured on 3 x 120 x 120 samples (its standard error is
#: sqrt(2 / 43200) = 0.7 %: 5 % is seven standard errors, and far below a missing noise term)
VARIANCE_RTOL = 0.05
#: the 8-bit quantisation's variance [DN^2] (a uniform error of one level)
QUANTISATION_VAR = 1.0 / 12.0


def _flat_patch(value: float) -> np.ndarray:
    return np.full((120, 120, 3), value, dtype=np.float32)


@pytest.mark.parametrize(("radiance", "gain"), [(0.5, 1.0), (0.05, 1.0), (0.0045, 8.0)])
def test_the_noise_of_a_flat_patch_is_shot_plus_read_noise(radiance, gain):
    pixel = PixelConfig()
    electrons = radiance * pixel.full_well_e  # at the reference exposure
    k_dn_per_e = gain * 255.0 / pixel.full_well_e  # 8-bit system gain of a linear encoding
    image = expose(_flat_patch(radiance), Exposure(pixel.reference_exposure_s, gain), pixel,
                   display_lut(1.0), np.random.default_rng(1))
    expected = k_dn_per_e**2 * (electrons + pixel.read_noise_e**2) + QUANTISATION_VAR
    assert image.mean() == pytest.approx(k_dn_per_e * electrons, abs=0.05)
    assert image.astype(float).var() == pytest.approx(expected, rel=VARIANCE_RTOL)


def test_read_noise_counts_where_shot_noise_is_small():
    # 20 electrons at gain 8: read noise is a third of the variance; without it the
    # measurement would fall 30 % short of the prediction
    pixel = PixelConfig(read_noise_e=3.0)
    silent = PixelConfig(read_noise_e=0.0)
    patch = 20.0 / pixel.full_well_e
    variances = [
        expose(_flat_patch(patch), Exposure(p.reference_exposure_s, 8.0), p, display_lut(1.0),
               np.random.default_rng(2)).astype(float).var()
        for p in (pixel, silent)
    ]
    assert variances[0] / variances[1] == pytest.approx((20 + 9 + 0.4) / (20 + 0.4), rel=0.1)


def test_the_output_is_8_bit_and_saturates_at_the_full_well():
    pixel = PixelConfig()
    bright = expose(_flat_patch(1.0), Exposure(4 * pixel.reference_exposure_s, 1.0), pixel,
                    display_lut(2.2), np.random.default_rng(3))
    assert bright.dtype == np.uint8 and np.all(bright == 255)
    lut = display_lut(2.2)
    assert lut.shape == (1 << ADC_BITS,) and lut[0] == 0 and lut[-1] == 255
    assert np.all(np.diff(lut.astype(int)) >= 0)
    assert len(np.unique(display_lut(1.0))) == 256  # a linear encoding reaches every level;
    assert len(np.unique(lut)) >= 245  # a gamma skips the darkest few (its steep start)


def test_the_normal_samples_have_unit_variance_and_no_correlation():
    z = standard_normal(np.random.default_rng(4), (300, 300, 3)).astype(float)
    assert abs(z.mean()) < 0.01 and z.var() == pytest.approx(1.0, abs=0.01)
    assert abs(np.corrcoef(z[:, :-1].ravel(), z[:, 1:].ravel())[0, 1]) < 0.01


def test_vignetting_falls_monotonically_with_the_radius_to_the_rim_gain():
    v, u = np.mgrid[0:201, 0:201]
    radius = np.hypot(u - 100.0, v - 100.0)
    mask = (radius >= 20) & (radius <= 90)
    gain = vignetting_gain(mask, (100.0, 100.0), 0.6)
    row = gain[100, 100:]
    assert row[0] == pytest.approx(1.0)
    assert np.all(np.diff(row) < 0)
    assert gain[100, 190] == pytest.approx(0.6, rel=1e-6)  # the mask's outer radius


@pytest.mark.parametrize("k_px", [2, 4, 7])
def test_a_line_moving_k_pixels_smears_over_k_pixels(k_px):
    image = np.zeros((9, 40, 3), dtype=np.float32)
    image[:, 20] = 1.0
    motion = np.zeros((9, 40, 2), dtype=np.float32)
    motion[..., 0] = k_px
    blurred = motion_blur(image, motion, max_samples=16)[4, :, 0]
    lit = np.flatnonzero(blurred > 1e-6)
    assert k_px <= lit[-1] - lit[0] <= k_px + 1  # + 1: half-pixel sample offsets (odd k)
    assert blurred.sum() == pytest.approx(1.0, rel=1e-5)  # the light is spread, not lost
    motion[..., 0] = 0.4
    assert motion_blur(image, motion, max_samples=16) is image  # under half a pixel


def test_the_image_motion_of_a_turn_is_the_radius_times_the_angle():
    rig = PRESETS["lab40"].rig()
    camera = rig.camera
    mask = np.asarray(camera.mask(), dtype=bool)
    rows, cols = np.nonzero(mask)
    points_w = np.full((*mask.shape, 3), np.nan, dtype=np.float32)
    rays_r = rig.rays_r(np.column_stack([cols, rows]).astype(float))
    points_w[rows, cols] = rig.viewpoint_r + 3.0 * rays_r  # the robot at the origin
    turn_rad = 0.01
    motion = image_motion(rig, points_w, np.zeros(3), np.array([0.0, 0.0, turn_rad]), 8)
    radius = np.hypot(cols - camera.cu, rows - camera.cv)
    inner = (radius > camera.inner_radius_px + 10) & (radius < camera.outer_radius_px - 10)
    length = np.hypot(*motion[rows, cols].T)
    np.testing.assert_allclose(length[inner], radius[inner] * turn_rad, rtol=0.02)


def _flat_sensor(config: SensorConfig) -> tuple[CameraSensor, np.ndarray]:
    camera = PinholeCamera(fx=50.0, fy=50.0, cu=39.5, cv=29.5, width=80, height=60)
    rig = CameraRig(camera, np.eye(4))
    stamps = np.arange(40) * 0.1
    return CameraSensor(config, rig, stamps, np.zeros((40, 3)), seed=0), stamps


def test_auto_exposure_converges_to_its_target_with_a_lag():
    config = SensorConfig(motion_blur=None, vignetting=None, jpeg_quality=None,
                          exposure=AutoExposureConfig(target_mean=100.0, rate=0.3))
    sensor, stamps = _flat_sensor(config)
    grey = np.full((60, 80, 3), 80, dtype=np.uint8)  # dim: needs 1.6x the first exposure
    means = [sensor.capture(grey, np.full((60, 80, 3), np.nan), k).mean()
             for k in range(len(stamps))]
    errors = np.abs(np.array(means) - 100.0)
    assert errors[0] > 15  # the first frame is far off ...
    assert errors[3] > 3  # ... and the controller takes several frames (its lag) ...
    assert errors[-1] < 1.0  # ... to reach the target
    times = [e.time_s for e in sensor.exposures]
    assert np.all(np.diff(times[:8]) > 0)  # exposure changes from frame to frame
    assert times[-1] == pytest.approx(times[-2], rel=0.02)


def test_auto_exposure_spends_gain_only_beyond_the_longest_exposure():
    config = SensorConfig(motion_blur=None, vignetting=None, jpeg_quality=None,
                          exposure=AutoExposureConfig(rate=1.0))
    sensor, _ = _flat_sensor(config)
    dark = np.full((60, 80, 3), 8, dtype=np.uint8)
    for k in range(12):
        sensor.capture(dark, np.full((60, 80, 3), np.nan), k)
    last = sensor.exposures[-1]
    assert last.time_s == pytest.approx(config.exposure.max_exposure_s)
    assert 1.0 < last.gain <= config.exposure.max_gain
    assert math.isclose(sensor.exposures[0].gain, 1.0)
