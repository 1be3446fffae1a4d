"""Render camera images of a world, with the ground truth of every pixel.

For every pixel inside the camera's mask the ray ``camera.unproject(pixel)`` is moved into the
robot frame by the rig (``rTc``) and into the world by the robot pose (``wTr``), cast against
the world's quads, and coloured by the hit surface's texture (bilinear, mip-mapped by the
pixel's footprint) times a deterministic shading term

    shade = (AMBIENT + DIFFUSE |n . d|) * exp(-t / FALLOFF_M)

(``n`` the surface normal, ``d`` the ray, ``t`` the distance; light panels are not shaded).
With ``supersample=2`` the colour is the mean of four sub-pixel rays at offsets (+-1/4, +-1/4)
px, while the ground truth always belongs to the ray through the pixel centre: the world point
``points_w = origin + t d`` and the surface id of the first hit.

Works with any ``omnislam.camera`` model (catadioptric or pinhole) and either ray caster.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from omnislam.camera.rig import CameraRig
from omnislam.core.se import se3_from_se2
from omnislam.datasets.synthetic.raycast import Backend, RayCaster, make_ray_caster
from omnislam.datasets.synthetic.textures import TextureAtlas
from omnislam.datasets.synthetic.world import SurfaceKind, World
from omnislam.errors import ConfigError

AMBIENT = 0.55
DIFFUSE = 0.45
FALLOFF_M = 60.0
#: colour of pixels inside the mask whose ray hits nothing (RGB)
BACKGROUND_RGB = (20, 20, 20)


@dataclass(frozen=True, slots=True)
class RenderedFrame:
    """One rendered image and its per-pixel ground truth.

    Attributes:
        image: (H, W, 3) uint8 RGB; black outside the mask.
        points_w: (H, W, 3) float32 world point seen by each pixel centre [m]; NaN outside the
            mask or where the ray hits nothing.
        surface_ids: (H, W) int32 id of the surface (``World.quads`` index) seen; -1 none.
    """

    image: np.ndarray
    points_w: np.ndarray
    surface_ids: np.ndarray


@dataclass(frozen=True, slots=True)
class RigRays:
    """The rays of a camera rig's pixels, computed once per camera.

    Attributes:
        pixel_index: (P,) flat indices (row * W + col) of the pixels rendered (mask and a ray).
        centre_r: (P, 3) unit rays of the pixel centres in the robot frame.
        sub_r: (P, S, 3) unit rays of the S sub-pixel samples in the robot frame (S = 1: the
            centre ray); NaN where a sample has no ray.
        pixel_angle_rad: (P,) angle between a pixel's ray and its right neighbour's (the
            angular size of a pixel, used to pick texture mip levels).
        origin_r: (3,) the camera's single viewpoint in the robot frame [m].
        shape: (H, W).
    """

    pixel_index: np.ndarray
    centre_r: np.ndarray
    sub_r: np.ndarray
    pixel_angle_rad: np.ndarray
    origin_r: np.ndarray
    shape: tuple[int, int]


def rig_rays(rig: CameraRig, supersample: int = 1) -> RigRays:
    """Rays of every usable pixel (inside ``camera.mask()``, with a ray) of a camera rig.

    Args:
        rig: the camera and its mounting ``rTc`` on the robot.
        supersample: 1 (centre ray only) or 2 (2 x 2 sub-pixel rays for the colour).
    """
    if supersample not in (1, 2):
        raise ConfigError(f"supersample must be 1 or 2, got {supersample}")
    camera = rig.camera
    height, width = int(camera.height), int(camera.width)
    rows, cols = np.nonzero(np.asarray(camera.mask(), dtype=bool))
    pixels = np.column_stack([cols, rows]).astype(float)
    centre_r = rig.rays_r(pixels)
    keep = np.all(np.isfinite(centre_r), axis=1)
    pixels, centre_r = pixels[keep], centre_r[keep]
    right_r = rig.rays_r(pixels + np.array([1.0, 0.0]))
    with np.errstate(invalid="ignore"):
        angle = np.arccos(np.clip(np.sum(centre_r * right_r, axis=1), -1.0, 1.0))
    angle = np.where(np.isfinite(angle), angle, np.nanmedian(angle))
    if supersample == 1:
        sub_r = centre_r[:, None, :]
    else:
        offsets = np.array([[-0.25, -0.25], [0.25, -0.25], [-0.25, 0.25], [0.25, 0.25]])
        sub_r = np.stack([rig.rays_r(pixels + o) for o in offsets], axis=1)
    index = pixels[:, 1].astype(np.int64) * width + pixels[:, 0].astype(np.int64)
    return RigRays(
        pixel_index=index,
        centre_r=centre_r,
        sub_r=sub_r,
        pixel_angle_rad=angle,
        origin_r=rig.viewpoint_r,
        shape=(height, width),
    )


class Renderer:
    """Renders frames of one world through one camera rig (see module docstring).

    Args:
        world: the world.
        rig: the camera model and its mounting on the robot.
        backend: ray caster (default: open3d when installed, else numpy).
        supersample: 1 or 2 rays per pixel side.
    """

    def __init__(
        self,
        world: World,
        rig: CameraRig,
        backend: Backend | str | None = None,
        supersample: int = 1,
    ) -> None:
        self.world = world
        self.quads = world.arrays()
        self.caster: RayCaster = make_ray_caster(self.quads, backend)
        self.atlas = TextureAtlas(world.textures)
        self.rays = rig_rays(rig, supersample)
        kinds = world.surface_kinds()
        self._scaled_dual_u = self.quads.dual_u_w * self.quads.length_u_m[:, None]
        self._scaled_dual_v = self.quads.dual_v_w * self.quads.length_v_m[:, None]
        self._unshaded = np.array([k is SurfaceKind.LIGHT for k in kinds], dtype=bool)

    def render(self, wTr: np.ndarray) -> RenderedFrame:
        """Render the frame seen from robot pose ``wTr``.

        Args:
            wTr: (3,) planar pose [x, y, theta] or (4, 4) SE(3) robot -> world.

        Returns:
            The image and its ground-truth maps.
        """
        wTr = np.asarray(wTr, dtype=float)
        if wTr.shape == (3,):
            wTr = se3_from_se2(wTr)
        R_wr, t_wr = wTr[:3, :3], wTr[:3, 3]
        rays = self.rays
        origin_w = R_wr @ rays.origin_r + t_wr
        height, width = rays.shape
        n_pix = height * width

        centre_w = rays.centre_r @ R_wr.T
        t_c, ids_c = self.caster.cast(origin_w, centre_w)
        hit = ids_c >= 0
        points = np.full((n_pix, 3), np.nan, dtype=np.float32)
        points[rays.pixel_index[hit]] = origin_w + t_c[hit, None] * centre_w[hit]
        surface = np.full(n_pix, -1, dtype=np.int32)
        surface[rays.pixel_index] = ids_c

        n_sub = rays.sub_r.shape[1]
        if n_sub == 1:
            colour = self._shade(origin_w, centre_w, t_c, ids_c, rays.pixel_angle_rad)
        else:
            sub_w = rays.sub_r.reshape(-1, 3) @ R_wr.T
            valid = np.all(np.isfinite(sub_w), axis=1)
            t_s = np.full(sub_w.shape[0], np.inf)
            ids_s = np.full(sub_w.shape[0], -1, dtype=np.int64)
            t_s[valid], ids_s[valid] = self.caster.cast(origin_w, sub_w[valid])
            angle = np.repeat(rays.pixel_angle_rad / 2.0, n_sub)
            sub_colour = np.zeros((sub_w.shape[0], 3), dtype=np.float32)
            sub_colour[valid] = self._shade(origin_w, sub_w[valid], t_s[valid], ids_s[valid],
                                            angle[valid])
            weight = valid.reshape(-1, n_sub).astype(np.float32)
            colour = (sub_colour.reshape(-1, n_sub, 3) * weight[..., None]).sum(axis=1)
            colour /= np.maximum(weight.sum(axis=1), 1.0)[:, None]
        image = np.zeros((n_pix, 3), dtype=np.uint8)
        image[rays.pixel_index] = np.clip(np.round(colour), 0, 255).astype(np.uint8)
        return RenderedFrame(
            image=image.reshape(height, width, 3),
            points_w=points.reshape(height, width, 3),
            surface_ids=surface.reshape(height, width),
        )

    def _shade(
        self,
        origin_w: np.ndarray,
        directions_w: np.ndarray,
        distances_m: np.ndarray,
        ids: np.ndarray,
        pixel_angle_rad: np.ndarray,
    ) -> np.ndarray:
        """(N, 3) float32 colour of rays with known hits (background where ids < 0)."""
        out = np.empty((ids.shape[0], 3), dtype=np.float32)
        out[:] = BACKGROUND_RGB
        hit = ids >= 0
        q = ids[hit]
        d = directions_w[hit]
        t = distances_m[hit]
        # u = ((origin - o_q) + t d) . dual_u * |edge_u|, with the per-quad part computed once
        quads = self.quads
        rel = origin_w - quads.origins_w
        u0 = np.einsum("ij,ij->i", rel, quads.dual_u_w) * quads.length_u_m
        v0 = np.einsum("ij,ij->i", rel, quads.dual_v_w) * quads.length_v_m
        u_m = u0[q] + t * np.einsum("ij,ij->i", d, self._scaled_dual_u[q])
        v_m = v0[q] + t * np.einsum("ij,ij->i", d, self._scaled_dual_v[q])
        cos_incidence = np.abs(np.einsum("ij,ij->i", quads.normals_w[q], d))
        footprint_m = t * pixel_angle_rad[hit] / np.maximum(cos_incidence, 0.25)
        albedo = self.atlas.sample(self.quads.textures[q], u_m, v_m, footprint_m)
        shade = (AMBIENT + DIFFUSE * cos_incidence) * np.exp(-t / FALLOFF_M)
        shade = np.where(self._unshaded[q], 1.0, shade).astype(np.float32)
        out[hit] = albedo * shade[:, None]
        return out
