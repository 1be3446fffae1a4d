"""The camera rig: robot-frame projection and rays, including a mirrored camera frame."""

from __future__ import annotations

import numpy as np
import pytest
from camera_checks import angle_between, sample_mask_pixels

from omnislam.camera import CameraRig, HyperbolicCamera, hyperbolic_to_unified
from omnislam.errors import DataError


def _rTs(yaw_rad: float = 0.3, height_m: float = 0.5) -> np.ndarray:
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    rTs = np.eye(4)
    rTs[:3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
    rTs[:3, 3] = [0.05, -0.02, height_m]
    return rTs


def test_rays_and_projection_in_the_robot_frame(rng):
    rig = CameraRig(HyperbolicCamera(), _rTs())
    pixels = sample_mask_pixels(rig.camera, 2_000, rng)
    rays_r = rig.rays_r(pixels)
    assert np.allclose(np.linalg.norm(rays_r, axis=1), 1.0)
    points_r = rig.viewpoint_r + rng.uniform(0.5, 30.0, (2_000, 1)) * rays_r
    again, valid = rig.project_r(points_r)
    assert valid.all() and np.abs(again - pixels).max() < 1e-6
    assert np.allclose(rig.viewpoint_r, [0.05, -0.02, 0.5])
    # z up in S and in the robot frame: the image centre sees straight down
    centre = rig.rays_r(np.array([[rig.camera.cu, rig.camera.cv]]))
    assert np.allclose(centre, [[0.0, 0.0, -1.0]])


def test_unified_equivalent_mounted_through_a_reflection_sees_the_same_rays(rng):
    h = HyperbolicCamera()
    u, R_us = hyperbolic_to_unified(h)
    rTs = _rTs()
    rTu = rTs.copy()
    rTu[:3, :3] = rTs[:3, :3] @ R_us.T
    rig_h, rig_u = CameraRig(h, rTs), CameraRig(u, rTu)
    assert rig_u.is_reflection and not rig_h.is_reflection
    pixels = sample_mask_pixels(h, 2_000, rng)
    assert angle_between(rig_h.rays_r(pixels), rig_u.rays_r(pixels)).max() < 1e-9
    points_r = rig_h.viewpoint_r + 3.0 * rig_h.rays_r(pixels)
    assert np.abs(rig_u.project_r(points_r)[0] - pixels).max() < 1e-6


def test_rig_is_immutable_and_validated():
    rig = CameraRig(HyperbolicCamera(), _rTs())
    with pytest.raises(ValueError, match="read-only"):
        rig.rTc[0, 3] = 1.0
    bad = _rTs()
    bad[3] = [0.0, 0.0, 1.0, 1.0]
    with pytest.raises(DataError, match="last row"):
        CameraRig(HyperbolicCamera(), bad)
    with pytest.raises(DataError, match="CameraModel"):
        CameraRig("hyperbolic", np.eye(4))  # type: ignore[arg-type]
