"""One image's sightings (``image_tracking.ImageSightings``): what the log keeps of them and how
the floor tracks' follow the landmark tracks'."""

from __future__ import annotations

import numpy as np

from omnislam.frontend.image_tracking import ImageSightings, TrackedImages


def _sightings() -> ImageSightings:
    return ImageSightings(
        track_ids=np.array([0, 1, 2, 1]),
        rays_r=np.array([[2.0, 0, 0], [0, 3.0, 0], [0, 0, 0.5], [1.0, 1.0, 0]]),
        pixels=np.array([[10.0, 11], [20, 21], [30, 31], [40, 41]]),
        sigmas_rad=np.array([0.01, 0.02, np.nan, 0.0]),
    )


def test_bearings_keep_the_usable_sightings_of_kept_tracks_as_unit_vectors():
    """Track 0 is dropped (short), row 2 has no finite sigma, row 3 a zero sigma: only row 1
    (track 1) remains, its ray normalised, its pixel and sigma aligned with it."""
    bearings, pixels = _sightings().bearings(keep_track=np.array([False, True, True]))
    np.testing.assert_array_equal(bearings.landmark_ids, [1])
    np.testing.assert_allclose(bearings.unit_vectors_r, [[0.0, 1.0, 0.0]], atol=1e-15)
    np.testing.assert_array_equal(bearings.sigmas_rad, [0.02])
    np.testing.assert_array_equal(pixels, [[20.0, 21.0]])


def test_followed_by_appends_the_other_sightings_with_their_ids_shifted():
    own, floor = _sightings(), _sightings().subset(np.array([2, 0]))
    both = own.followed_by(floor, id_offset=100)
    np.testing.assert_array_equal(both.track_ids, [0, 1, 2, 1, 102, 100])
    np.testing.assert_array_equal(both.rays_r[4:], own.rays_r[[2, 0]])
    np.testing.assert_array_equal(both.pixels[4:], own.pixels[[2, 0]])
    np.testing.assert_array_equal(both.sigmas_rad[4:], own.sigmas_rad[[2, 0]])
    np.testing.assert_array_equal(own.track_ids, [0, 1, 2, 1])  # unchanged


def test_no_image_tracked_has_no_track_and_no_floor():
    none = TrackedImages.none()
    assert none.sightings == {} and none.lines == {} and none.floor_ids_from is None
    assert none.track_sightings.shape == (0,) and none.track_sightings.dtype == np.int64
