"""Evaluation against ground truth: the bearing-noise ratio on residuals of known spread."""

from __future__ import annotations

import numpy as np
import pytest

from omnislam.frontend.evaluation import BearingResiduals, noise_ratio, noise_ratio_median


def _residuals(rng, sigma_true, sigma_logged, n=18000, track_size=None):
    """Angles of 2-D Gaussian tangent errors of std ``sigma_true`` per axis."""
    error = rng.normal(scale=sigma_true, size=(n, 2))
    dof = np.ones(n)
    if track_size is not None:  # residuals around the mean of each track's own sightings
        error = error.reshape(-1, track_size, 2)
        error = (error - error.mean(axis=1, keepdims=True)).reshape(-1, 2)
        dof = np.full(n, track_size / (track_size - 1.0))
    return BearingResiduals(np.hypot(error[:, 0], error[:, 1]), np.full(n, sigma_logged), dof,
                            np.repeat(np.arange(n // (track_size or 1)), track_size or 1))


@pytest.mark.parametrize("track_size", [None, 3, 6])
def test_the_noise_ratio_is_one_when_sigma_is_right_and_scales_with_it(track_size):
    rng = np.random.default_rng(0)
    right = _residuals(rng, 0.002, 0.002, track_size=track_size)
    assert noise_ratio(right) == pytest.approx(1.0, abs=0.03)
    assert noise_ratio_median(right) == pytest.approx(1.0, abs=0.05 if track_size else 0.03)
    too_large = _residuals(rng, 0.002, 0.01, track_size=track_size)
    assert noise_ratio(too_large) == pytest.approx(0.2, abs=0.01)


def test_gross_errors_beyond_the_trim_do_not_move_the_ratio():
    rng = np.random.default_rng(1)
    res = _residuals(rng, 0.002, 0.002)
    angles = res.angle_rad.copy()
    angles[:100] = 1.0  # 0.5 % wrong associations
    spoiled = BearingResiduals(angles, res.sigma_rad, res.dof, res.track)
    assert noise_ratio(spoiled) == pytest.approx(1.0, abs=0.03)
    assert noise_ratio(spoiled, trim=0.0) > 10


def _keypoints(rng, shape, k):
    """Sub-pixel keypoints over the whole image, a few beyond its border (clipped), a few on
    pixel centres and on the last row and column."""
    h, w = shape
    px = rng.uniform([-2.0, -2.0], [w + 1.0, h + 1.0], size=(k, 2))
    px[:5] = np.round(px[:5])
    px[5:8] = [[w - 1, h - 1], [0, 0], [w - 1.5, 0.25]]
    return px


def test_true_points_at_the_keypoints_pixels_only_equal_those_of_whole_maps(demo_folder):
    """``sampled_point_at_pixels`` over ``SyntheticFolder.pixel_points`` gives the same bits as
    ``point_at_pixels`` over the whole map (edges, clipping, pixels that see nothing)."""
    from omnislam.datasets.synthetic.loader import SyntheticFolder
    from omnislam.frontend.evaluation import point_at_pixels, sampled_point_at_pixels

    folder = SyntheticFolder(demo_folder)
    rng = np.random.default_rng(0)
    frames = sorted(int(p.stem) for p in (demo_folder / "gt").glob("*.npz"))[:4]
    for frame in frames:
        whole = folder.ground_truth_maps(frame).points_w
        px = _keypoints(rng, whole.shape[:2], 400)
        expected = point_at_pixels(whole, px)
        got = sampled_point_at_pixels(
            lambda rows, cols, f=frame: folder.pixel_points(f, rows, cols), whole.shape[:2], px
        )
        assert np.isnan(expected).any() and np.isfinite(expected).any()
        np.testing.assert_array_equal(got, expected)


def test_sampled_true_sightings_equal_true_sightings(demo_sequence):
    """The tracks' true points of a log, keypoint pixels only against whole maps: identical."""
    from omnislam.core.types import Bearings
    from omnislam.frontend.evaluation import (
        sampled_true_sightings,
        track_truth,
        true_sightings,
    )
    from omnislam.frontend.observation_log import ObservationLog

    rng = np.random.default_rng(1)
    camera = demo_sequence.calibration.camera
    shape = (camera.height, camera.width)
    with_bearings = set(demo_sequence.image_frames[:5].tolist())
    frames, pixels = [], []
    for i in range(len(demo_sequence)):
        if i not in with_bearings:
            frames.append(demo_sequence.frame_input(i))
            pixels.append(None)
            continue
        k = 60
        rays = rng.normal(size=(k, 3))
        rays /= np.linalg.norm(rays, axis=1, keepdims=True)
        bearings = Bearings(rng.integers(0, 20, k), rays, np.full(k, 0.01))
        frames.append(demo_sequence.frame_input(i, bearings=bearings))
        pixels.append(_keypoints(rng, shape, k))
    log = ObservationLog("demo", "test", tuple(frames), tuple(pixels))
    whole = true_sightings(log, demo_sequence.point_map_loader)
    sampled = sampled_true_sightings(log, demo_sequence.pixel_points_loader, shape)
    for name in ("frame", "stamp_s", "track", "points_w"):
        np.testing.assert_array_equal(getattr(sampled, name), getattr(whole, name))
    for a, b in zip(track_truth(sampled), track_truth(whole), strict=True):
        np.testing.assert_array_equal(a, b)
