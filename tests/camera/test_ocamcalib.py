"""OCamCalib: the real office calibration file, the toolbox's conventions, malformed files."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from camera_checks import (
    OFFICE_LIKE_OCAM,
    PIXEL_TOL_PX,
    RAY_TOL_RAD,
    angle_between,
    office_camera,
    sample_mask_directions,
    sample_mask_pixels,
)

from omnislam.camera import read_ocamcalib, write_ocamcalib
from omnislam.errors import DataError

#: invpol is a fit; the toolbox accepts it when it reprojects within a fraction of a pixel
INVPOL_TOL_PX = 0.01


def test_real_file_is_parsed_as_the_toolbox_writes_it():
    camera = office_camera()
    assert camera == OFFICE_LIKE_OCAM  # the test constant is a faithful copy of the file
    assert len(camera.pol) == 5 and len(camera.invpol) == 12
    assert (camera.height, camera.width) == (1080, 1300)
    assert camera.original_width == 1920  # example.jpg is 1080 x 1920
    assert (camera.roi_min_radius_px, camera.roi_max_radius_px) == (235.0, 600.0)
    # the centre is written as (row, column): it lies near the middle of the cropped image
    assert camera.center_col == pytest.approx(camera.width / 2, abs=30)
    assert camera.center_row == pytest.approx(camera.height / 2, abs=30)


def test_real_calibration_round_trips_on_its_usable_ring(rng):
    camera = office_camera()
    pixels = sample_mask_pixels(camera, 20_000, rng)
    radius_px = np.hypot(pixels[:, 0] - camera.center_col, pixels[:, 1] - camera.center_row)
    assert radius_px.min() < 240 and radius_px.max() > 590  # the whole ROI ring is covered
    again, valid = camera.project(camera.unproject(pixels))
    assert valid.all() and np.abs(again - pixels).max() <= PIXEL_TOL_PX
    rays_c = sample_mask_directions(camera, 20_000, rng)
    assert angle_between(camera.unproject(camera.project(rays_c)[0]), rays_c).max() <= RAY_TOL_RAD


def test_invpol_agrees_with_the_exact_root_solve(rng):
    camera = OFFICE_LIKE_OCAM
    rays_c = camera.unproject(sample_mask_pixels(camera, 20_000, rng))
    exact, valid_exact = camera.project_exact(rays_c)
    fitted, valid_fitted = camera.project_invpol(rays_c)
    assert valid_exact.all() and valid_fitted.all()
    assert np.abs(fitted - exact).max() < INVPOL_TOL_PX
    toolbox = dataclasses.replace(camera, world2cam="invpol")
    assert np.array_equal(toolbox.project(rays_c)[0], fitted)


def test_cam2world_follows_the_c_code_by_hand():
    camera = OFFICE_LIKE_OCAM
    u, v = 900.25, 300.5  # column, row
    c, d, e = camera.c, camera.d, camera.e
    inv_det = 1.0 / (c - d * e)
    xp = inv_det * ((v - camera.center_row) - d * (u - camera.center_col))
    yp = inv_det * (-e * (v - camera.center_row) + c * (u - camera.center_col))
    rho = np.hypot(xp, yp)
    zp = sum(a * rho**k for k, a in enumerate(camera.pol))
    expected = np.array([xp, yp, zp]) / np.linalg.norm([xp, yp, zp])
    assert np.allclose(camera.unproject(np.array([[u, v]]))[0], expected, atol=1e-15)


def test_frame_centre_looks_down_z_and_the_ring_spans_the_horizon():
    camera = OFFICE_LIKE_OCAM
    centre = camera.unproject(np.array([[camera.center_col, camera.center_row]]))
    assert np.allclose(centre, [[0.0, 0.0, -1.0]])  # pol[0] < 0
    radii = np.array([camera.roi_min_radius_px, camera.roi_max_radius_px])
    pixels = np.column_stack([camera.center_col + radii, np.full(2, camera.center_row)])
    rays = camera.unproject(pixels)
    assert rays[0, 2] < 0.0 < rays[1, 2]  # from ~40 deg below to ~27 deg above the horizon
    assert rays[1, 1] > 0.0 and abs(rays[1, 0]) < 1e-3  # +column is +y (x runs along rows)
    assert camera.project(np.array([[0.0, 0.0, -1.0]]))[1][0]
    assert not camera.project(np.array([[0.0, 0.0, 1.0]]))[1][0]


def test_angular_sigma_on_the_real_calibration_shrinks_towards_the_rim():
    camera = OFFICE_LIKE_OCAM
    radius_px = np.linspace(camera.roi_min_radius_px, 530.0, 50)
    pixels = np.column_stack([camera.center_col + radius_px, np.full(50, camera.center_row)])
    sigma_rad = camera.angular_sigma(pixels)
    assert np.all(np.diff(sigma_rad) < 0)
    assert 2e-3 < sigma_rad[-1] < sigma_rad[0] < 5e-3  # ~0.2 deg per pixel


def test_crop_maps_between_original_and_cropped_pixels():
    camera = OFFICE_LIKE_OCAM
    # pyomniunwarp crops img[:, left:-right]: columns 300..1599 of the 1920-wide original
    original = np.array([[300.0, 10.0], [1599.0, 1079.0]])
    cropped = camera.cropped_from_original(original)
    assert np.allclose(cropped, [[0.0, 10.0], [1299.0, 1079.0]])
    assert camera.in_image(cropped).all()
    assert not camera.in_image(
        camera.cropped_from_original(np.array([[299.0, 0.0], [1600.0, 0.0]]))
    ).any()
    assert np.allclose(camera.original_from_cropped(cropped), original)


def test_write_then_read_returns_an_equal_camera(tmp_path):
    path = tmp_path / "calib_results.txt"
    write_ocamcalib(OFFICE_LIKE_OCAM, path)
    assert read_ocamcalib(path) == OFFICE_LIKE_OCAM
    plain = dataclasses.replace(
        OFFICE_LIKE_OCAM,
        roi_max_radius_px=None,
        roi_min_radius_px=0.0,
        crop_left_px=0,
        crop_right_px=0,
    )
    write_ocamcalib(plain, path)
    assert read_ocamcalib(path) == plain
    assert "#ROI" not in path.read_text()


GOOD = """#polynomial coefficients for the DIRECT mapping function
3 -200.0 0.0 0.002

#polynomial coefficients for the inverse mapping function
2 300.0 100.0
#center
500.0 600.0
#affine
1.0 0.0 0.0
#image size
1000 1200
"""


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (GOOD.replace("500.0 600.0", "500.0 six"), "line 7: expected numbers"),
        (GOOD.replace("3 -200.0", "4 -200.0"), "line 2: pol must be a count"),
        (GOOD.replace("2 300.0 100.0", "2.5 300.0 100.0"), "line 5: invpol must be a count"),
        (GOOD.replace("1.0 0.0 0.0", "1.0 0.0"), "line 9: affine needs 3 numbers"),
        (GOOD.replace("1000 1200", "1000 12.5"), "image width must be a positive integer"),
        (GOOD.replace("1000 1200\n", ""), "missing section"),
        (GOOD + "600 200\n300 320\n1 2\n", "line 14: unexpected extra data"),
        (GOOD.replace("1.0 0.0 0.0", "0.0 1.0 0.0"), "singular"),
        ("", "missing section"),
    ],
)
def test_malformed_files_raise_data_error_naming_file_and_line(tmp_path, text, message):
    path = tmp_path / "calib_results.txt"
    path.write_text(text)
    with pytest.raises(DataError, match=message) as info:
        read_ocamcalib(path)
    assert str(path) in str(info.value) and info.value.path == path


def test_good_minimal_file_and_missing_file(tmp_path):
    path = tmp_path / "calib_results.txt"
    path.write_text(GOOD)
    camera = read_ocamcalib(path, world2cam="invpol")
    assert camera.world2cam == "invpol" and camera.roi_max_radius_px is None
    assert camera.crop_left_px == 0
    with pytest.raises(DataError, match="cannot read"):
        read_ocamcalib(tmp_path / "absent.txt")
