"""An imperfect camera rig: the rays a real, hand-assembled rig casts, not the calibrated ones.

A catadioptric rig is rarely central: the camera's pinhole sits a few millimetres off the
mirror's outer focus ``F1`` (Baker & Nayar 1999: only ``pinhole = F1`` gives a single
viewpoint), and the rig stands slightly tilted on the robot. Both are drawn per render
(``draw_rig_perturbation``) and rendered, while the calibration written for the front end and
the estimators stays the nominal central model, as a real rig's calibration file does.

Non-central mirror (``HyperbolicCamera``). In the camera's frame ``S`` (origin ``F2``, ``z`` up
the mirror axis; see ``camera.hyperbolic``) the pinhole sits at ``C = F1 + delta`` and looks up
the axis. Pixel ``(u, v)`` is the line ``C + alpha d``, ``d = [(u - cu') s, (v - cv') s, f]``;
``cu', cv'`` is where the mirror rim's centre ``(0, 0, z_rim)`` images, the image centre a
calibration finds from the rim (so a sideways offset moves the image by no more than a
calibration would absorb). The line meets the mirror ``(z + e)^2 / a^2 - (x^2 + y^2) / b^2 = 1``
where ``A alpha^2 + B alpha + C0 = 0`` with ``w0 = C_z + e``,

    A = d_z^2 / a^2 - (d_x^2 + d_y^2) / b^2,
    B = 2 w0 d_z / a^2 - 2 (C_x d_x + C_y d_y) / b^2,
    C0 = w0^2 / a^2 - (C_x^2 + C_y^2) / b^2 - 1

(thesis eq. 4.19 with the line's origin off ``F1``; the larger root is the mirror's sheet
around ``F2``), and leaves the mirror point ``P`` reflected about the mirror's normal
``N ~ (-P_x / b^2, -P_y / b^2, (P_z + e) / a^2)``: ``r = d - 2 (d . N) N`` (unit ``d``, ``N``).
For ``delta = 0`` every ``r`` passes through ``F2`` (the focal property); otherwise each pixel's
ray has its own origin ``P``. Other cameras (pinhole) have no mirror: the offset moves their
centre.

Tilt. The rig turns about its mounting point by the rotation vector ``tilt_r_rad`` (robot
frame): ``rTc' = [R_tilt R, t]`` for the nominal ``rTc = [R, t]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from omnislam.camera.hyperbolic import HyperbolicCamera
from omnislam.camera.rig import CameraRig
from omnislam.errors import ConfigError, DataError


@dataclass(frozen=True, slots=True)
class RigError:
    """How far from the nominal rig a render's true rig may be (each drawn uniformly).

    Attributes:
        max_offset_m: bound of each component of the pinhole's offset from the mirror's outer
            focus (frame ``S``) [m]. Default 0.001: a hand-assembled catadioptric rig (camera
            on a tube under the mirror) is aligned to about a millimetre (under 1.8 mm in
            all). With the default mirror, 1 mm sideways turns the rays by 0.4 deg (median
            over the image) and 1 mm along the axis by 0.5 deg, bearing errors the nominal
            calibration leaves to the estimators.
        max_tilt_rad: bound of the rig's roll and pitch on the robot [rad]. Default
            0.5 deg: a camera mast bolted on a mobile robot stands within a degree of the
            vertical (under 0.71 deg in all; no yaw: a yaw offset is a calibration question).
    """

    max_offset_m: float = 0.001
    max_tilt_rad: float = math.radians(0.5)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.max_offset_m) and 0.0 <= self.max_offset_m <= 0.01):
            raise ConfigError(f"rig_error.max_offset_m must lie in [0, 0.01] m, got "
                              f"{self.max_offset_m}")
        if not (math.isfinite(self.max_tilt_rad) and 0.0 <= self.max_tilt_rad <= 0.1):
            raise ConfigError(f"rig_error.max_tilt_rad must lie in [0, 0.1] rad, got "
                              f"{self.max_tilt_rad}")


@dataclass(frozen=True, slots=True)
class RigPerturbation:
    """The true rig of one render, relative to the nominal one (the render's truth).

    Attributes:
        offset_s_m: (3,) the pinhole's offset from the mirror's outer focus in the camera's
            frame ``S`` (for cameras without a mirror: the centre's offset) [m].
        tilt_r_rad: (3,) rotation vector of the rig's tilt about its mounting point, robot
            frame [rad].
    """

    offset_s_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    tilt_r_rad: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def rotation(self) -> np.ndarray:
        """(3, 3) ``R_tilt`` (robot frame)."""
        from scipy.spatial.transform import Rotation

        return Rotation.from_rotvec(np.asarray(self.tilt_r_rad, dtype=float)).as_matrix()

    def to_dict(self) -> dict[str, list[float]]:
        """Plain-Python form for a render's truth file (``from_dict`` reads it)."""
        return {"offset_s_m": list(self.offset_s_m), "tilt_r_rad": list(self.tilt_r_rad)}

    @classmethod
    def from_dict(cls, doc: Any) -> RigPerturbation:
        """Inverse of ``to_dict``; DataError on a malformed entry."""
        try:
            offset = tuple(float(c) for c in doc["offset_s_m"])
            tilt = tuple(float(c) for c in doc["tilt_r_rad"])
        except (KeyError, TypeError, ValueError) as exc:
            raise DataError(f"malformed rig perturbation: {exc!r}") from exc
        if len(offset) != 3 or len(tilt) != 3 or not np.all(np.isfinite(offset + tilt)):
            raise DataError(f"a rig perturbation needs 3 finite offsets and tilts, got {doc}")
        return cls(offset, tilt)  # type: ignore[arg-type]


def draw_rig_perturbation(config: RigError, rng: np.random.Generator) -> RigPerturbation:
    """A true rig within ``config``'s bounds: each offset component and the roll and pitch
    uniform in ``[-max, max]``."""
    offset = rng.uniform(-config.max_offset_m, config.max_offset_m, size=3)
    roll, pitch = rng.uniform(-config.max_tilt_rad, config.max_tilt_rad, size=2)
    return RigPerturbation(tuple(offset.tolist()), (float(roll), float(pitch), 0.0))


def true_rays_r(
    rig: CameraRig, perturbation: RigPerturbation, pixels: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The rays the true rig casts through pixels (module docstring).

    Args:
        rig: the nominal rig.
        perturbation: the true rig's departure from it.
        pixels: (N, 2) ``[u, v]`` [px].

    Returns:
        ``(origins_r, rays_r)``: (N, 3) ray origins in the robot frame [m] and (N, 3) unit
        directions; NaN rows where the true rig has no ray.
    """
    pixels = np.asarray(pixels, dtype=float).reshape(-1, 2)
    offset = np.asarray(perturbation.offset_s_m, dtype=float)
    if isinstance(rig.camera, HyperbolicCamera):
        origins_c, rays_c = mirror_rays_s(rig.camera, offset, pixels)
    else:
        rays_c = rig.camera.unproject(pixels)
        origins_c = np.broadcast_to(offset, rays_c.shape)
    R = perturbation.rotation() @ rig.rTc[:3, :3]
    return origins_c @ R.T + rig.rTc[:3, 3], rays_c @ R.T


def mirror_rays_s(
    camera: HyperbolicCamera, offset_s_m: np.ndarray, pixels: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Mirror points and reflected rays, frame ``S``, of a pinhole at ``F1 + offset``.

    Args:
        camera: the nominal mirror and camera.
        offset_s_m: (3,) the pinhole's offset from ``F1`` [m].
        pixels: (N, 2) ``[u, v]`` [px].

    Returns:
        ``(points_s, rays_s)``: (N, 3) mirror points [m] and (N, 3) unit outgoing rays; NaN
        where the pixel's line misses the mirror.
    """
    a2, b2, e = camera.a_m**2, camera.b_m**2, camera.e_m
    pinhole = np.array([0.0, 0.0, -2.0 * e]) + offset_s_m
    z_rim = camera.a_m * math.sqrt(1.0 + (camera.rim_radius_m / camera.b_m) ** 2) - e
    centre = np.array([camera.cu, camera.cv]) + camera.focal_px * offset_s_m[:2] / (
        z_rim - pinhole[2])
    d = np.column_stack([(pixels - centre) * camera.pixel_size_m,
                         np.full(len(pixels), camera.focal_length_m)])
    w0 = pinhole[2] + e
    A = d[:, 2] ** 2 / a2 - (d[:, 0] ** 2 + d[:, 1] ** 2) / b2
    B = 2.0 * w0 * d[:, 2] / a2 - 2.0 * (pinhole[0] * d[:, 0] + pinhole[1] * d[:, 1]) / b2
    C0 = w0**2 / a2 - (pinhole[0] ** 2 + pinhole[1] ** 2) / b2 - 1.0
    discriminant = B**2 - 4.0 * A * C0
    with np.errstate(divide="ignore", invalid="ignore"):
        ok = (A > 0.0) & (discriminant >= 0.0)
        alpha = np.where(ok, (-B + np.sqrt(np.where(ok, discriminant, 0.0))) / (2.0 * A), np.nan)
    points = pinhole + alpha[:, None] * d
    normal = np.column_stack([-points[:, 0] / b2, -points[:, 1] / b2, (points[:, 2] + e) / a2])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    rays = d - 2.0 * np.einsum("ij,ij->i", d, normal)[:, None] * normal
    return points, rays / np.linalg.norm(rays, axis=1, keepdims=True)
