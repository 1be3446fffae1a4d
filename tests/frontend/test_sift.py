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


def test_the_budget_keeps_the_strongest_features_per_area(omni_image):
    """``features_per_kpx`` keeps the strongest of the unbudgeted features, as many as the
    density times the detection region's area (the mask's, else the image's)."""
    image, rig = omni_image
    mask = detection_mask(rig.camera.mask(), rig.camera.mask().shape)
    every = SiftExtractor(dataclasses.replace(OMNI_THESIS, features_per_kpx=0.0)).extract(
        image, mask)
    density = 0.5
    extractor = SiftExtractor(dataclasses.replace(OMNI_THESIS, features_per_kpx=density))
    budget = round(density * np.count_nonzero(mask) / 1000)
    assert 0 < budget < len(every)
    kept = extractor.extract(image, mask)
    assert len(kept) == budget == extractor.budget(image.shape, mask)
    strongest = np.sort(every.contrast)[::-1][:budget]
    np.testing.assert_allclose(np.sort(kept.contrast)[::-1], strongest)
    # applied before the orientations and descriptors, the budget keeps exactly the features
    # that describing every keypoint and then keeping the strongest gives, in the same order
    discarded = every.subset(np.sort(np.argsort(-every.contrast, kind="stable")[:budget]))
    for name in ("pixels", "sizes_px", "angles_rad", "contrast", "descriptors"):
        np.testing.assert_array_equal(getattr(kept, name), getattr(discarded, name), name)
    # without a mask the whole image is the region: a larger budget
    assert extractor.budget(image.shape, None) == round(density * image.shape[0]
                                                        * image.shape[1] / 1000) > budget
    with pytest.raises(ConfigError):
        SiftConfig(features_per_kpx=-1.0)


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
