"""SIFT detection without doubling the image: a blob of known scale, and OpenCV as the oracle."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.spatial import cKDTree

from omnislam.frontend.config import OMNI_THESIS, FirstOctave
from omnislam.frontend.scale_space import (
    bucket_at,
    budget_buckets,
    build_scale_space,
    detect_keypoints,
    strongest_per_bucket,
)
from omnislam.frontend.sift import SiftExtractor, detection_mask

cv2 = pytest.importorskip("cv2")

#: Lowe's sigma and layers, the omni preset's thresholds
SIFT = {"sigma": 1.6, "layers": 3, "contrast_threshold": 0.02, "edge_threshold": 2.0}
#: a detection "is" an OpenCV keypoint within this [px] ...
SAME_POSITION_PX = 0.5
#: ... and this relative difference in size
SAME_SIZE = 0.15


def _blob(centre: tuple[float, float], sigma: float, size: int = 96) -> np.ndarray:
    """A dark Gaussian blob of std ``sigma`` on a bright background (uint8)."""
    v, u = np.mgrid[0:size, 0:size].astype(float)
    d2 = (u - centre[0]) ** 2 + (v - centre[1]) ** 2
    return np.round(200.0 - 150.0 * np.exp(-d2 / (2 * sigma**2))).astype(np.uint8)


@pytest.mark.parametrize(("sigma", "fine", "halved"), [
    (1.3, True, False), (2.5, True, False), (5.0, False, False), (1.3, True, True),
    (2.5, True, True), (5.0, True, True)])
def test_a_gaussian_blob_is_found_at_its_centre_and_scale(sigma, fine, halved):
    """A Gaussian blob of std s is a DoG extremum at its centre. Its scale: the centre value
    of D(sigma) = G(k sigma) - G(sigma) applied to it, ~ 1/(s^2 + sigma^2) - 1/(s^2 +
    k^2 sigma^2), peaks at sigma = s / sqrt(k); and the detector treats the image as already
    blurred by 0.5 px (Lowe 2004 sec. 3.3), so the blob acts as one of std sqrt(s^2 - 0.25)."""
    centre = (47.3, 44.8)
    found = detect_keypoints(_blob(centre, sigma), None, fine=fine, halved=halved, **SIFT)
    assert len(found) >= 1
    best = int(np.argmax(found.response))
    # located to a small fraction of its scale (octaves are sampled in proportion to it;
    # halved ones twice as sparsely)
    error = np.hypot(found.x[best] - centre[0], found.y[best] - centre[1])
    assert error < 0.02 + (0.04 if halved else 0.02) * found.sigma[best]
    k = 2.0 ** (1.0 / SIFT["layers"])
    expected = np.sqrt(sigma**2 - 0.25) / np.sqrt(k)
    assert found.sigma[best] == pytest.approx(expected, rel=0.05)
    # octave -1 holds the scales below Lowe's sigma (a keypoint's sub-scale may pass it by
    # half a layer)
    assert (found.octave[best] < 0) == (found.sigma[best] < SIFT["sigma"] * k ** 0.5) or (
        abs(np.log(found.sigma[best] / SIFT["sigma"]) / np.log(k)) < 0.5)


def test_the_fine_octave_spans_octaves_minus_one_and_zero_at_the_image_resolution():
    image = np.zeros((64, 80), dtype=np.uint8)
    octaves = build_scale_space(image, 1.6, 3, fine=True)
    first = octaves[0]
    assert first.index == -1 and first.step_px == 1 and first.sigma_px == 0.8
    assert first.gaussian.shape == (9, 64, 80) and first.extrema_layers == 6
    second = octaves[1]
    assert second.index == 1 and second.step_px == 2 and second.gaussian.shape[1:] == (32, 40)
    plain = build_scale_space(image, 1.6, 3, fine=False)
    assert plain[0].index == 0 and plain[0].gaussian.shape == (6, 64, 80)


def test_halved_octaves_each_sample_half_the_previous_ones_pixels():
    """``halved``: octave -1 alone at the image's resolution, then Lowe's octaves 0, 1... at
    2, 4... pixels, each starting from blur sigma / 2 in its own pixels, down to the same
    smallest octave as the merged layout."""
    image = np.zeros((64, 80), dtype=np.uint8)
    octaves = build_scale_space(image, 1.6, 3, fine=True, halved=True)
    assert [o.index for o in octaves] == list(range(-1, len(octaves) - 1))
    assert [o.step_px for o in octaves] == [2 ** i for i in range(len(octaves))]
    assert all(o.sigma_px == 0.8 and o.extrema_layers == 3 for o in octaves)
    assert octaves[0].gaussian.shape == (6, 64, 80)
    assert octaves[1].gaussian.shape == (6, 32, 40)
    merged = build_scale_space(image, 1.6, 3, fine=True)
    assert octaves[-1].gaussian.shape == merged[-1].gaussian.shape


@pytest.fixture(scope="module")
def omni_grey(demo_sequence):
    image = demo_sequence.image(int(demo_sequence.image_frames[5]))
    camera = demo_sequence.calibration.camera
    mask = detection_mask(camera.mask(), (camera.height, camera.width))
    return cv2.cvtColor(image, cv2.COLOR_RGB2GRAY), mask


def _opencv(grey, mask):
    sift = cv2.SIFT_create(0, 3, 0.06, 2.0, 1.6, enable_precise_upscale=True)
    keypoints = sift.detect(grey, mask)
    octave = np.array([(k.octave & 255) - 256 * ((k.octave & 255) >= 128) for k in keypoints])
    xy = np.array([k.pt for k in keypoints])
    size = np.array([k.size for k in keypoints])
    return xy, size, octave


def test_octaves_from_zero_agree_with_opencv(omni_grey):
    """Lowe's octaves 0, 1, ... are built as OpenCV builds them (no doubling involved): most
    of OpenCV's keypoints there are detected at the same position and size."""
    grey, mask = omni_grey
    xy, size, octave = _opencv(grey, mask)
    found = detect_keypoints(grey, mask, fine=False, **SIFT)
    regular = octave >= 0
    d, j = cKDTree(np.column_stack([found.x, found.y])).query(xy[regular])
    same = (d < SAME_POSITION_PX) & (np.abs(2 * found.sigma[j] / size[regular] - 1) < SAME_SIZE)
    assert regular.sum() > 50
    assert same.mean() > 0.8
    assert np.median(d[same]) < 0.05


def test_halved_octaves_agree_with_opencv_at_half_the_sigma(omni_grey):
    """The halved layout is the pyramid of a SIFT of sigma / 2 on the undoubled image:
    OpenCV's octaves 0, 1, ... of ``SIFT(sigma=0.8)`` (it doubles only for its octave -1),
    as the descriptor of every native layout uses it. Most of OpenCV's keypoints there are
    detected at the same position and size."""
    grey, mask = omni_grey
    sift = cv2.SIFT_create(0, 3, 0.06, 2.0, 0.8, enable_precise_upscale=True)
    keypoints = sift.detect(grey, mask)
    octave = np.array([(k.octave & 255) - 256 * ((k.octave & 255) >= 128) for k in keypoints])
    xy = np.array([k.pt for k in keypoints])[octave >= 0]
    size = np.array([k.size for k in keypoints])[octave >= 0]
    found = detect_keypoints(grey, mask, fine=True, halved=True, **SIFT)
    d, j = cKDTree(np.column_stack([found.x, found.y])).query(xy)
    same = (d < SAME_POSITION_PX) & (np.abs(2 * found.sigma[j] / size - 1) < SAME_SIZE)
    assert xy.shape[0] > 50
    # measured 0.70 (OpenCV's octave 0 starts from its doubled image, not bit-identical)
    assert same.mean() > 0.6
    assert np.median(d[same]) < 0.1
    # the same layout labels octaves as Lowe's: -1 at the image's pixels, 0 at every second
    assert set(np.unique(found.octave)) >= {-1, 0}


def test_the_native_fine_octave_finds_what_opencv_finds_on_the_doubled_image(omni_grey):
    grey, mask = omni_grey
    xy, size, octave = _opencv(grey, mask)
    found = detect_keypoints(grey, mask, fine=True, **SIFT)
    fine = octave < 0
    d, j = cKDTree(np.column_stack([found.x, found.y])).query(xy[fine])
    same = (d < SAME_POSITION_PX) & (np.abs(2 * found.sigma[j] / size[fine] - 1) < SAME_SIZE)
    assert fine.sum() > 50
    # measured 0.66 on this image; half a pixel of the doubled image is 0.25 px here
    assert same.mean() > 0.5
    assert np.median(d[same]) < 0.15


def test_native_and_doubled_descriptors_describe_the_same_points(omni_grey):
    """A native feature and the doubled detector's feature at the same place have nearby
    descriptors (they are matched, as tracking needs)."""
    grey, mask = omni_grey
    native = SiftExtractor(OMNI_THESIS).extract(grey, mask)
    doubled = SiftExtractor(dataclasses.replace(OMNI_THESIS, first_octave=FirstOctave.DOUBLED)
                            ).extract(grey, mask)
    d, j = cKDTree(native.pixels).query(doubled.pixels)
    close = (d < 0.3) & (np.abs(native.sizes_px[j] / doubled.sizes_px - 1) < 0.1) & (
        np.abs(np.angle(np.exp(1j * (native.angles_rad[j] - doubled.angles_rad)))) < 0.1)
    assert close.sum() > 50
    distance = np.linalg.norm(native.descriptors[j[close]] - doubled.descriptors[close], axis=1)
    # descriptors are scaled to 512: unrelated ones are ~400 apart, repeats of a point < 150
    assert np.median(distance) < 100


@pytest.mark.parametrize("budget", [1, 37, 150, 300])
def test_the_budget_before_orientations_keeps_the_strongest_detections(omni_grey, budget):
    """``max_keypoints`` gives orientations to the strongest located keypoints only; the result
    is the strongest ``budget`` of every detection (orientations included), in their order."""
    grey, mask = omni_grey
    every = detect_keypoints(grey, mask, **SIFT)
    assert len(every) > budget
    strongest = every.subset(np.sort(np.argsort(-every.response, kind="stable")[:budget]))
    kept = detect_keypoints(grey, mask, max_keypoints=budget, **SIFT)
    assert len(kept) == budget
    for name in type(every).__slots__:
        np.testing.assert_array_equal(getattr(kept, name), getattr(strongest, name), name)
    # shared out over rings x sectors: the same rule applied to every detection
    buckets = budget_buckets(mask, 4, 8)
    chosen = every.subset(strongest_per_bucket(
        every.response, bucket_at(buckets, np.column_stack([every.x, every.y])), 32, budget))
    kept = detect_keypoints(grey, mask, max_keypoints=budget, buckets=buckets, **SIFT)
    assert len(kept) == budget
    for name in type(every).__slots__:
        np.testing.assert_array_equal(getattr(kept, name), getattr(chosen, name), name)
