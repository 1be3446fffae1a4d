"""Ray casters and renderer: backend agreement, ground-truth points, masks."""

from __future__ import annotations

import numpy as np
import pytest

from omnislam.core.se import se3_from_se2, se3_inverse, se3_transform_points
from omnislam.datasets.synthetic.raycast_numpy import NumpyRayCaster
from omnislam.datasets.synthetic.render import Renderer

#: surface-id agreement required between the open3d and numpy ray casters
BACKEND_AGREEMENT = 0.999


def test_numpy_caster_hits_a_known_wall(demo_sim):
    caster = NumpyRayCaster(demo_sim.world.arrays())
    origin = np.array([1.5, 2.5, 1.0])
    t, ids = caster.cast(origin, np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]))
    assert ids[1] >= 0 and t[1] == pytest.approx(1.0)  # the floor, 1 m below
    assert ids[0] >= 0 and 0 < t[0] <= 4.5 + 1e-9  # the wall at x = 6 (or a poster on it)


def test_open3d_and_numpy_agree_on_surface_ids(demo_sim):
    pytest.importorskip("open3d")
    pose = demo_sim.poses_w[demo_sim.image_frames[3]]
    a = Renderer(demo_sim.world, demo_sim.rig, "open3d").render(pose)
    b = Renderer(demo_sim.world, demo_sim.rig, "numpy").render(pose)
    inside = demo_sim.rig.camera.mask()
    agreement = np.mean(a.surface_ids[inside] == b.surface_ids[inside])
    assert agreement >= BACKEND_AGREEMENT
    same = inside & (a.surface_ids == b.surface_ids) & (a.surface_ids >= 0)
    np.testing.assert_allclose(a.points_w[same], b.points_w[same], atol=1e-4)
    assert np.mean(np.all(np.abs(a.image.astype(int) - b.image) <= 1, axis=2)[inside]) > 0.999


def test_ground_truth_points_project_back_to_their_pixels(demo_sim):
    pose = demo_sim.poses_w[demo_sim.image_frames[0]]
    frame = Renderer(demo_sim.world, demo_sim.rig, "numpy").render(pose)
    rows, cols = np.nonzero(frame.surface_ids >= 0)
    pick = np.random.default_rng(0).choice(rows.size, 500, replace=False)
    points_w = frame.points_w[rows[pick], cols[pick]].astype(float)
    points_r = se3_transform_points(se3_inverse(se3_from_se2(pose)), points_w)
    pixels, valid = demo_sim.rig.project_r(points_r)
    assert valid.all()
    err = np.hypot(pixels[:, 0] - cols[pick], pixels[:, 1] - rows[pick])
    assert np.median(err) < 0.01 and err.max() < 0.1  # float32 storage only


def test_outside_the_mask_is_empty_and_render_is_deterministic(demo_sim):
    renderer = Renderer(demo_sim.world, demo_sim.rig, None, supersample=2)
    pose = demo_sim.poses_w[demo_sim.image_frames[1]]
    a, b = renderer.render(pose), renderer.render(pose)
    np.testing.assert_array_equal(a.image, b.image)
    outside = ~demo_sim.rig.camera.mask()
    assert np.all(a.image[outside] == 0)
    assert np.all(a.surface_ids[outside] == -1)
    assert np.all(np.isnan(a.points_w[outside]))
    assert np.mean(a.surface_ids[~outside] >= 0) > 0.99  # a closed room: every ray hits
