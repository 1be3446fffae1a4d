"""SIFT extraction: named presets, the usable-ring mask, both backends."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from omnislam.errors import ConfigError
from omnislam.frontend.config import (
    LOWE,
    OMNI_THESIS,
    SIFT_PRESETS,
    SiftBackend,
    SiftConfig,
    frontend_config_from_dict,
)
from omnislam.frontend.scale_space import bucket_at, strongest_per_bucket
from omnislam.frontend.sift import MASK_MARGIN_PX, SiftExtractor, detection_mask

cv2 = pytest.importorskip("cv2")


@pytest.fixture(scope="module")
def omni_image(demo_sequence):
    return demo_sequence.image(int(demo_sequence.image_frames[0])), demo_sequence.calibration


def test_presets_are_named_frozen_configs():
    assert SIFT_PRESETS["lowe"] is LOWE and SIFT_PRESETS["omni-thesis"] is OMNI_THESIS
    assert LOWE.edge_threshold == 10.0 and OMNI_THESIS.edge_threshold == 2.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        LOWE.edge_threshold = 3.0  # type: ignore[misc]
    with pytest.raises(ConfigError):
        SiftConfig(edge_threshold=0.5)
    config = frontend_config_from_dict({"sift": {"preset": "lowe", "contrast_threshold": 0.05}})
    assert config.sift.edge_threshold == 10.0 and config.sift.contrast_threshold == 0.05
    with pytest.raises(ConfigError, match="unknown SIFT preset"):
        frontend_config_from_dict({"sift": "harris"})


def test_keypoints_stay_inside_the_shrunk_ring(omni_image):
    image, rig = omni_image
    usable = rig.camera.mask()
    mask = detection_mask(usable, usable.shape)
    features = SiftExtractor(OMNI_THESIS).extract(image, mask)
    assert len(features) > 150
    assert features.descriptors.shape == (len(features), 128)
    u = np.round(features.pixels[:, 0]).astype(int)
    v = np.round(features.pixels[:, 1]).astype(int)
    assert np.all(usable[v, u])
    # nothing within the margin of the ring's border
    border = usable & ~cv2.erode(usable.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    rows, cols = np.nonzero(border)
    gap = np.min(np.hypot(features.pixels[:, None, 0] - cols[None, ::7],
                          features.pixels[:, None, 1] - rows[None, ::7]), axis=1)
    assert gap.min() >= MASK_MARGIN_PX - 1.5


@pytest.mark.parametrize(("bands", "sectors"), [(1, 1), (4, 8)])
def test_the_budget_keeps_the_strongest_features_per_area(omni_image, bands, sectors):
    """``features_per_kpx`` keeps as many features as the density times the detection region's
    area (the mask's, else the image's): with 1 x 1 buckets the strongest of the whole ring,
    with rings x sectors each bucket's share of its strongest plus the strongest of the rest --
    in both cases exactly the features that describing every keypoint and then choosing by the
    same rule gives, in the same order (the budget is applied before orientations and
    descriptors)."""
    image, rig = omni_image
    mask = detection_mask(rig.camera.mask(), rig.camera.mask().shape)
    every = SiftExtractor(dataclasses.replace(OMNI_THESIS, features_per_kpx=0.0)).extract(
        image, mask)
    density = 0.5
    extractor = SiftExtractor(dataclasses.replace(
        OMNI_THESIS, features_per_kpx=density, budget_bands=bands, budget_sectors=sectors))
    budget = round(density * np.count_nonzero(mask) / 1000)
    assert 0 < budget < len(every)
    kept = extractor.extract(image, mask)
    assert len(kept) == budget == extractor.budget(image.shape, mask)
    buckets = extractor.buckets(image.shape[:2], mask)
    assert buckets.max() + 1 == bands * sectors
    chosen = strongest_per_bucket(every.contrast, bucket_at(buckets, every.pixels),
                                  bands * sectors, budget)
    expected = every.subset(chosen)
    for name in ("pixels", "sizes_px", "angles_rad", "contrast", "descriptors"):
        np.testing.assert_array_equal(getattr(kept, name), getattr(expected, name), name)
    if bands * sectors == 1:  # the strongest of the whole ring
        strongest = np.sort(every.contrast)[::-1][:budget]
        np.testing.assert_allclose(np.sort(kept.contrast)[::-1], strongest)
    # without a mask the whole image is the region: a larger budget
    assert extractor.budget(image.shape, None) == round(density * image.shape[0]
                                                        * image.shape[1] / 1000) > budget
    with pytest.raises(ConfigError):
        SiftConfig(features_per_kpx=-1.0)
    with pytest.raises(ConfigError):
        SiftConfig(budget_bands=0)


def test_buckets_spread_the_budget_over_elevation_and_azimuth(omni_image):
    """Shared out over 4 rings x 8 sectors, the budget keeps features in every bucket that has
    any, and at least its share (or all it has) in each: where the strongest of the whole ring
    leave some buckets with less than half their share."""
    image, rig = omni_image
    mask = detection_mask(rig.camera.mask(), rig.camera.mask().shape)
    every = SiftExtractor(dataclasses.replace(OMNI_THESIS, features_per_kpx=0.0)).extract(
        image, mask)
    config = dataclasses.replace(OMNI_THESIS, features_per_kpx=0.5)
    extractor = SiftExtractor(config)
    kept = extractor.extract(image, mask)
    buckets = extractor.buckets(image.shape[:2], mask)
    n = config.budget_bands * config.budget_sectors
    share = len(kept) // n
    have = np.bincount(bucket_at(buckets, every.pixels), minlength=n)
    got = np.bincount(bucket_at(buckets, kept.pixels), minlength=n)
    assert np.all(got >= np.minimum(have, share))
    # the rings have equal areas of the detection region
    area = np.bincount(buckets[mask > 0] // config.budget_sectors)
    assert area.max() / area.min() < 1.02
    flat = SiftExtractor(dataclasses.replace(config, budget_bands=1, budget_sectors=1))
    got_flat = np.bincount(bucket_at(buckets, flat.extract(image, mask).pixels), minlength=n)
    assert np.any(got_flat < np.minimum(have, share) / 2)


def test_strongest_per_bucket_shares_then_spills():
    response = np.array([9.0, 8.0, 7.0, 6.0, 5.0, 1.0, 0.5])
    bucket = np.array([0, 0, 0, 0, 0, 1, 2])
    # 6 over 3 buckets: 2 each; bucket 1 and 2 have one each: 2 left go to the strongest rest
    keep = strongest_per_bucket(response, bucket, 3, 6)
    assert keep.tolist() == [True, True, True, True, False, True, True]
    assert strongest_per_bucket(response, bucket, 3, 6, spill=False).tolist() == [
        True, True, False, False, False, True, True]
    assert not strongest_per_bucket(response, bucket, 3, 0).any()
    assert strongest_per_bucket(response[:0], bucket[:0], 3, 5).shape == (0,)


def test_the_omni_preset_rejects_more_edge_like_keypoints(omni_image):
    image, rig = omni_image
    mask = detection_mask(rig.camera.mask(), rig.camera.mask().shape)
    lowe = SiftExtractor(LOWE).extract(image, mask)
    strict_edges = SiftExtractor(dataclasses.replace(LOWE, edge_threshold=2.0)).extract(image,
                                                                                        mask)
    assert len(strict_edges) < len(lowe)


def test_pycolmap_backend_gives_comparable_features(omni_image):
    pytest.importorskip("pycolmap")
    image, rig = omni_image
    mask = detection_mask(rig.camera.mask(), rig.camera.mask().shape)
    config = dataclasses.replace(LOWE, backend=SiftBackend.PYCOLMAP, max_features=2000)
    features = SiftExtractor(config).extract(image, mask)
    assert len(features) > 100
    assert np.allclose(np.linalg.norm(features.descriptors, axis=1), 512.0, rtol=1e-3)
    u = np.round(features.pixels[:, 0]).astype(int)
    v = np.round(features.pixels[:, 1]).astype(int)
    assert np.all(mask[v, u] > 0)


def test_buckets_follow_the_image_size_without_a_mask():
    extractor = SiftExtractor(dataclasses.replace(OMNI_THESIS, features_per_kpx=0.5))
    assert extractor.buckets((60, 80), None).shape == (60, 80)
    big = extractor.buckets((90, 120), None)
    assert big.shape == (90, 120) and big.max() + 1 == 32
