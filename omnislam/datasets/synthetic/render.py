"""Render camera images of a world, with the ground truth of every pixel.

For every pixel inside the camera's mask the ray ``camera.unproject(pixel)`` is moved into the
robot frame by the rig (``rTc``) and into the world by the robot pose (``wTr``), cast against
the world's quads, and coloured by the hit surface's texture (bilinear, mip-mapped by the
pixel's footprint) times a deterministic shading term

    shade = (AMBIENT + DIFFUSE |n . d|) * exp(-t / FALLOFF_M)

(``n`` the surface normal, ``d`` the ray, ``t`` the distance; light panels are not shaded).
With a ``LightingConfig`` the bracket is the ambient term plus the world's lamps (point lights
at the light panels, Lambert's cosine and inverse-square falloff: ``lighting``) instead.
With a ``RigPerturbation`` the rays are those of the true, imperfect rig (``rig_error``:
non-central, each ray with its own origin) while the calibration stays the nominal one; with
walkers (``walkers``) people-sized cylinders moving along their paths occlude the quads.
With ``supersample=2`` the colour is the mean of four sub-pixel rays at offsets (+-1/4, +-1/4)
px, while the ground truth always belongs to the ray through the pixel centre: the world point
``points_w = origin + t d`` and the surface id of the first hit.

Works with any ``omnislam.camera`` model (catadioptric or pinhole) and either ray caster.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from omnislam.camera.rig import CameraRig
from omnislam.core.se import se3_from_se2
from omnislam.datasets.synthetic.hit_distances import MIN_DISTANCE_M
from omnislam.datasets.synthetic.lighting import (
    LightingConfig,
    lamp_heights,
    lamp_irradiance,
    lamp_positions,
)
from omnislam.datasets.synthetic.raycast import Backend, RayCaster, make_ray_caster
from omnislam.datasets.synthetic.rig_error import RigPerturbation, true_rays_r
from omnislam.datasets.synthetic.textures import TextureAtlas, Workspace
from omnislam.datasets.synthetic.walkers import WalkerPath, walker_hits, walker_positions_w
from omnislam.datasets.synthetic.world import QuadArrays, SurfaceKind, World
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
        surface_ids: (H, W) int32 id of the surface (``World.quads`` index) seen; -1 none;
            ``len(World.quads) + k`` walker k (only when the renderer has walkers).
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
        origin_r: (3,) the camera's single viewpoint in the robot frame [m] (of a non-central
            rig: its mounting point).
        shape: (H, W).
        centre_offset_r: (P, 3) of a non-central rig: each centre ray's origin minus
            ``origin_r`` [m]; None: every ray leaves ``origin_r``.
        sub_offset_r: (P, S, 3) the same for the sub-pixel rays; None with ``centre_offset_r``.
    """

    pixel_index: np.ndarray
    centre_r: np.ndarray
    sub_r: np.ndarray
    pixel_angle_rad: np.ndarray
    origin_r: np.ndarray
    shape: tuple[int, int]
    centre_offset_r: np.ndarray | None = None
    sub_offset_r: np.ndarray | None = None


def rig_rays(
    rig: CameraRig, supersample: int = 1, perturbation: RigPerturbation | None = None
) -> RigRays:
    """Rays of every usable pixel (inside ``camera.mask()``, with a ray) of a camera rig.

    Args:
        rig: the camera and its mounting ``rTc`` on the robot.
        supersample: 1 (centre ray only) or 2 (2 x 2 sub-pixel rays for the colour).
        perturbation: the true rig's departure from ``rig`` (``rig_error.true_rays_r``);
            None: the nominal, central rig.
    """
    if supersample not in (1, 2):
        raise ConfigError(f"supersample must be 1 or 2, got {supersample}")
    camera = rig.camera
    height, width = int(camera.height), int(camera.width)
    origin_r = rig.viewpoint_r

    def rays(pixels: np.ndarray) -> tuple[np.ndarray | None, np.ndarray]:
        if perturbation is None:
            return None, rig.rays_r(pixels)
        origins_r, rays_r = true_rays_r(rig, perturbation, pixels)
        return origins_r - origin_r, rays_r

    rows, cols = np.nonzero(np.asarray(camera.mask(), dtype=bool))
    pixels = np.column_stack([cols, rows]).astype(float)
    centre_offset, centre_r = rays(pixels)
    keep = np.all(np.isfinite(centre_r), axis=1)
    pixels, centre_r = pixels[keep], centre_r[keep]
    centre_offset = None if centre_offset is None else centre_offset[keep]
    right_r = rays(pixels + np.array([1.0, 0.0]))[1]
    with np.errstate(invalid="ignore"):
        angle = np.arccos(np.clip(np.sum(centre_r * right_r, axis=1), -1.0, 1.0))
    angle = np.where(np.isfinite(angle), angle, np.nanmedian(angle))
    if supersample == 1:
        sub_r = centre_r[:, None, :]
        sub_offset = None if centre_offset is None else centre_offset[:, None, :]
    else:
        offsets = np.array([[-0.25, -0.25], [0.25, -0.25], [-0.25, 0.25], [0.25, 0.25]])
        samples = [rays(pixels + o) for o in offsets]
        sub_r = np.stack([ray for _, ray in samples], axis=1)
        sub_offset = None if centre_offset is None else np.stack([o for o, _ in samples], axis=1)
    index = pixels[:, 1].astype(np.int64) * width + pixels[:, 0].astype(np.int64)
    return RigRays(
        pixel_index=index,
        centre_r=centre_r,
        sub_r=sub_r,
        pixel_angle_rad=angle,
        origin_r=origin_r,
        shape=(height, width),
        centre_offset_r=centre_offset,
        sub_offset_r=sub_offset,
    )


def _rotate(R: np.ndarray, rays: np.ndarray, out: np.ndarray) -> np.ndarray:
    """(3, N) rays ``R @ r`` of (3, N) rays ``r`` into ``out``, row by row (no BLAS: its
    threads made the tall (N, 3) @ (3, 3) product 200 ms instead of 2 ms on a loaded machine)."""
    tmp = np.empty_like(rays[0])
    for k in range(3):
        np.multiply(rays[0], R[k, 0], out=out[k])
        out[k] += np.multiply(rays[1], R[k, 1], out=tmp)
        out[k] += np.multiply(rays[2], R[k, 2], out=tmp)
    return out


def _gather(table: np.ndarray, ids: np.ndarray, out: np.ndarray) -> np.ndarray:
    """(K, N) columns ``ids`` (intp; -1 is the last column) of a (K, M + 1) table into
    ``out``, row by row (~3x faster than ``table.take(ids, axis=1)``)."""
    for row, dest in zip(table, out, strict=True):
        np.take(row, ids, out=dest, mode="wrap")
    return out


# rows of the per-surface shading table (float32, (rows, M + 1): one column per quad and a
# last "no hit" column, so that surface id -1 selects it)
_AU = slice(0, 3)  # level-0 texels of u per metre along each world axis
_AV = slice(3, 6)
_CU, _CV = 6, 7  # texel (u, v) of the ray origin's projection on the plane (per frame)
_AMBIENT, _DIFFUSE, _INV_FALLOFF = 8, 9, 10
_TEXTURE = slice(11, 17)  # the texture's TextureAtlas.table row


class Renderer:
    """Renders frames of one world through one camera rig (see module docstring).

    Everything that does not depend on the pose is computed once here: the pixel rays, the
    texture atlas, and per-surface tables indexed by surface id (texture axes, shading
    constants, the texture's atlas entry), so a frame is one rotation of the rays, one cast,
    one table gather per ray and one vectorised bilinear lookup. Per-ray arrays are kept
    component-major ((3, N)) so that every numpy loop runs over the rays; shading and texture
    lookups are float32, the ground truth (distances, points) float64. Large per-ray arrays
    are reused from frame to frame (``Workspace``), so one Renderer must not render in two
    threads at once; the frames it returns are new arrays.

    Args:
        world: the world.
        rig: the camera model and its mounting on the robot.
        backend: ray caster (default: open3d when installed, else numpy).
        supersample: 1 or 2 rays per pixel side.
        lighting: lamps at the light panels (``lighting`` module); None: the global shading
            term of the module docstring.
        rig_error: the true rig's departure from ``rig`` (``rig_error``): the rays cast are
            the true rig's (non-central: each has its own origin), and so is the ground truth;
            None: ``rig`` itself.
        walkers: people walking through the world (``walkers``), drawn where they are at the
            frame's time; their surface ids follow the quads' (``len(world.quads) + k`` for
            walker k).
    """

    def __init__(
        self,
        world: World,
        rig: CameraRig,
        backend: Backend | str | None = None,
        supersample: int = 1,
        lighting: LightingConfig | None = None,
        rig_error: RigPerturbation | None = None,
        walkers: tuple[WalkerPath, ...] = (),
    ) -> None:
        self.world = world
        self.quads = world.arrays()
        self.caster: RayCaster = make_ray_caster(self.quads, backend)
        self.atlas = TextureAtlas(world.textures + tuple(w.texture for w in walkers))
        self.rays = rig_rays(rig, supersample, rig_error)
        self._centre_r = np.ascontiguousarray(self.rays.centre_r.T)
        self._angle = self.rays.pixel_angle_rad.astype(np.float32)
        n_sub = self.rays.sub_r.shape[1]
        sub_r = self.rays.sub_r.reshape(-1, 3)
        self._sub_valid = np.all(np.isfinite(sub_r), axis=1)
        self._sub_r = np.ascontiguousarray(sub_r[self._sub_valid].T)
        self._sub_angle = np.repeat(self._angle / 2.0, n_sub)[self._sub_valid]
        self._sub_count = self._sub_valid.reshape(-1, n_sub).sum(axis=1).astype(np.float32)
        self._centre_offset_r = self._sub_offset_r = None
        if self.rays.centre_offset_r is not None and self.rays.sub_offset_r is not None:
            self._centre_offset_r = np.ascontiguousarray(self.rays.centre_offset_r.T)
            sub_offset = self.rays.sub_offset_r.reshape(-1, 3)[self._sub_valid]
            self._sub_offset_r = np.ascontiguousarray(sub_offset.T)

        quads = self.quads
        m = len(quads)
        unshaded = np.array([k is SurfaceKind.LIGHT for k in world.surface_kinds()], dtype=bool)
        texture = self.atlas.table[quads.textures]  # (M, 6)
        extent = np.array([s.extent_m for s in world.textures], dtype=float).reshape(-1, 2)
        extent = extent[quads.textures]
        # level-0 texel coordinates: fx0 = (p - o_q) . dual_u |edge_u| / extent_u * width
        self._texel_u = quads.dual_u_w * (quads.length_u_m / extent[:, 0] * texture[:, 0])[:, None]
        self._texel_v = quads.dual_v_w * (quads.length_v_m / extent[:, 1] * texture[:, 1])[:, None]
        # walkers' columns follow the quads' (their texels come from ``_Crowd``)
        m_all = m + len(walkers)
        unshaded = np.concatenate([unshaded, np.zeros(len(walkers), dtype=bool)])
        texture = np.concatenate([texture, self.atlas.table[len(world.textures):]])
        table = np.zeros((_TEXTURE.stop, m_all + 1), dtype=np.float32)
        table[_AU, :m] = self._texel_u.T
        table[_AV, :m] = self._texel_v.T
        table[_AMBIENT, :m_all] = np.where(unshaded, 1.0, AMBIENT)
        table[_DIFFUSE, :m_all] = np.where(unshaded, 0.0, DIFFUSE)
        table[_INV_FALLOFF, :m_all] = np.where(unshaded, 0.0, 1.0 / FALLOFF_M)
        if m_all:
            table[_TEXTURE, :m_all] = texture.T
            table[_TEXTURE, m_all] = texture[0]  # any valid texture; misses get BACKGROUND_RGB
        self._table = table
        # float64 planes: normal and n . (o_q - origin) (per frame); the no-hit column gives NaN
        self._plane = np.zeros((4, m + 1))
        self._plane[:3, :m] = quads.normals_w.T
        self._plane[3, m] = np.nan
        self._work = Workspace()
        self._lamps = _Lamps(world, quads, unshaded, lighting, table) if lighting else None
        self._crowd = _Crowd(walkers, m, self.rays, self._sub_r) if walkers else None

    def render(self, wTr: np.ndarray, stamp_s: float = 0.0) -> RenderedFrame:
        """Render the frame seen from robot pose ``wTr``.

        Args:
            wTr: (3,) planar pose [x, y, theta] or (4, 4) SE(3) robot -> world.
            stamp_s: the frame's time [s]: where the walkers are (no effect without them).

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
        self._start_frame(origin_w)
        if self._crowd is not None:
            self._crowd.start_frame(stamp_s, R_wr, origin_w)

        work = self._work
        centre_w = _rotate(R_wr, self._centre_r, work.get("centre_w", self._centre_r.shape, float))
        offset_w = self._rotate_offsets(R_wr, self._centre_offset_r, "centre")
        ids_c, t_c, cos_c = self._trace(origin_w, centre_w, "centre", offset_w)
        if rays.sub_r.shape[1] == 1:
            centre32_w = work.get("directions32", centre_w.shape, np.float32)
            centre32_w[...] = centre_w
            colour = self._colour(centre32_w, ids_c, t_c, cos_c, self._angle, offset_w)
        else:
            sub_w = _rotate(R_wr, self._sub_r, work.get("sub_w", self._sub_r.shape, float))
            sub_offset_w = self._rotate_offsets(R_wr, self._sub_offset_r, "sub")
            ids_s, t_s, cos_s = self._trace(origin_w, sub_w, "sub", sub_offset_w)
            sub = np.zeros((3, self._sub_valid.size), dtype=np.float32)
            sub[:, self._sub_valid] = self._colour(sub_w.astype(np.float32), ids_s, t_s, cos_s,
                                                   self._sub_angle, sub_offset_w)
            colour = sub.reshape(3, self._sub_count.size, -1).sum(axis=2)
            colour /= np.maximum(self._sub_count, 1.0)
        np.rint(colour, out=colour)
        np.clip(colour, 0, 255, out=colour)
        rgba = work.get("rgba", (colour.shape[1], 4), np.uint8)  # scattered as one uint32
        rgba[:, 3] = 0
        rgba[:, :3] = colour.T
        image = np.zeros(n_pix, dtype=np.uint32)
        image[rays.pixel_index] = rgba.view(np.uint32)[:, 0]
        image = np.ascontiguousarray(image.view(np.uint8).reshape(height, width, 4)[..., :3])

        centre_w *= t_c  # NaN where nothing is hit
        if offset_w is not None:
            centre_w += offset_w
        centre_w += origin_w[:, None]
        points = np.full((n_pix, 3), np.nan, dtype=np.float32)
        points[rays.pixel_index] = centre_w.T
        surface = np.full(n_pix, -1, dtype=np.int32)
        surface[rays.pixel_index] = ids_c
        return RenderedFrame(
            image=image,
            points_w=points.reshape(height, width, 3),
            surface_ids=surface.reshape(height, width),
        )

    def _start_frame(self, origin_w: np.ndarray) -> None:
        """Fill the per-frame entries of the surface tables for rays leaving ``origin_w``."""
        m = len(self.quads)
        rel = origin_w - self.quads.origins_w
        self._plane[3, :m] = -np.einsum("ij,ij->i", self.quads.normals_w, rel)
        self._table[_CU, :m] = np.einsum("ij,ij->i", rel, self._texel_u)
        self._table[_CV, :m] = np.einsum("ij,ij->i", rel, self._texel_v)
        if self._lamps is not None:
            self._lamps.start_frame(origin_w, self._plane[3, :m])

    def _rotate_offsets(self, R_wr: np.ndarray, offsets_r: np.ndarray | None,
                        name: str) -> np.ndarray | None:
        """(3, N) ray origins of a non-central rig relative to the frame's viewpoint, in the
        world (a work array ``name``); None for a central rig."""
        if offsets_r is None:
            return None
        return _rotate(R_wr, offsets_r, self._work.get(f"{name}.offset_w", offsets_r.shape,
                                                       float))

    def _trace(
        self, origin_w: np.ndarray, directions_w: np.ndarray, name: str,
        offsets_w: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """First hits of (3, N) rays from ``origin_w`` (plus ``offsets_w`` (3, N), each ray's
        own origin's offset, for a non-central rig): surface ids (N,) intp (-1 none), exact
        float64 distances to the hit planes (N,) [m] (NaN none) and |n . d| (N,).

        The results are work arrays ``name``: valid until the next frame.
        """
        n = directions_w.shape[1]
        ids = self._work.get(f"{name}.ids", (n,), np.intp)
        if offsets_w is None:
            ids[...] = self.caster.first_hits(origin_w, directions_w.T)
        else:
            ids[...] = self.caster.first_hits((offsets_w + origin_w[:, None]).T, directions_w.T)
        plane = _gather(self._plane, ids, self._work.get(f"{name}.plane", (4, n), np.float64))
        if offsets_w is not None:  # n . (o_q - o - offset): the plane seen from the ray's origin
            plane[3] -= plane[0] * offsets_w[0] + plane[1] * offsets_w[1] + plane[2] * offsets_w[2]
        cos = np.multiply(plane[0], directions_w[0], out=plane[0])
        cos += np.multiply(plane[1], directions_w[1], out=plane[1])
        cos += np.multiply(plane[2], directions_w[2], out=plane[2])
        with np.errstate(invalid="ignore", divide="ignore"):
            t = np.divide(plane[3], cos, out=plane[3])
            too_close = t <= MIN_DISTANCE_M
        if too_close.any():
            ids[too_close] = -1
            t[too_close] = np.nan
        cos = np.abs(cos, out=cos)
        if self._crowd is not None:
            self._crowd.occlude(name, origin_w, directions_w, offsets_w, ids, t, cos)
        return ids, t, cos

    def _colour(
        self,
        directions_w: np.ndarray,
        ids: np.ndarray,
        distances_m: np.ndarray,
        cos_incidence: np.ndarray,
        pixel_angle_rad: np.ndarray,
        offsets_w: np.ndarray | None = None,
    ) -> np.ndarray:
        """(3, N) float32 colour channels (R, G, B); background where ids < 0.

        Args:
            directions_w: (3, N) float32 unit rays.
            ids, distances_m, cos_incidence: ``_trace`` results.
            pixel_angle_rad: (N,) float32 angular size of the ray's pixel.
            offsets_w: (3, N) the rays' origins relative to the viewpoint (non-central rig);
                None: every ray leaves the viewpoint. (The lamps are measured from the
                viewpoint: the origins' few centimetres are neglected there.)
        """
        if not len(self.quads):  # nothing to hit, and no texture for the no-hit column
            return np.repeat(np.array(BACKGROUND_RGB, np.float32)[:, None], ids.size, axis=1)
        n = ids.shape[0]
        work = self._work
        rows = _gather(self._table, ids, work.get("rows", (self._table.shape[0], n), np.float32))
        t = work.get("t", (n,), np.float32)
        t[...] = distances_m
        np.nan_to_num(t, copy=False, nan=0.0)
        cos = work.get("cos", (n,), np.float32)
        cos[...] = cos_incidence
        texel = work.get("texel", (2, n), np.float32)
        # texel = a . (p - o_q) = a . (t d) + a . (o - o_q) [+ a . offset, non-central]
        reach = directions_w
        if offsets_w is not None:
            reach = np.multiply(directions_w, t, out=work.get("reach", (3, n), np.float32))
            reach += offsets_w
        for f, axes, offset in ((texel[0], _AU, _CU), (texel[1], _AV, _CV)):
            a = rows[axes]
            np.multiply(reach[0], a[0], out=f)
            f += np.multiply(reach[1], a[1], out=a[1])
            f += np.multiply(reach[2], a[2], out=a[2])
            if offsets_w is None:
                f *= t
            f += rows[offset]
        if self._crowd is not None:
            walkers = self._crowd.texels(ids, directions_w, t, offsets_w, texel)
        footprint = np.maximum(cos, np.float32(0.25), out=work.get("footprint", (n,), np.float32))
        np.divide(pixel_angle_rad, footprint, out=footprint)
        footprint *= t
        texture = rows[_TEXTURE]
        level = self.atlas.level_of(texture, footprint)
        colour = self.atlas.bilinear(texture, texel, level, work)
        shade = np.multiply(rows[_DIFFUSE], cos, out=cos)
        shade += rows[_AMBIENT]
        if self._lamps is not None:
            shade += self._lamps.irradiance(directions_w, t, ids, work)
            if self._crowd is not None:
                shade[walkers.index] += lamp_irradiance(
                    walkers.points_w, walkers.normals_w, self._crowd.origin_w,
                    self._lamps.lamps_w, self._lamps.config).astype(np.float32)
        t *= rows[_INV_FALLOFF]
        np.negative(t, out=t)
        shade *= np.exp(t, out=t)
        colour *= shade
        miss = np.flatnonzero(ids < 0)
        if miss.size:
            colour[:, miss] = np.array(BACKGROUND_RGB, dtype=np.float32)[:, None]
        return colour


class _Lamps:
    """The lamp term of ``lighting`` evaluated per ray (see ``lighting.lamp_irradiance``, its
    reference implementation).

    Per quad and lamp, ``n . (L_k - o_q)`` is tabulated once; per frame, the lamps on the
    camera's side of each quad keep it (times the power), the others get 0; per ray only the
    squared distance ``|L_k - p|^2 = |L'_k|^2 - 2 t (L'_k . d) + t^2`` (``L' = L - o``, the
    lamp seen from the frame's viewpoint) is computed, in float32.

    Args:
        world: the world (its light panels are the lamps).
        quads: its quad arrays.
        unshaded: (M + W,) surfaces the lamps do not light (light panels); W walkers follow
            the M quads (their lamp term is ``_Crowd``'s: here they get none).
        config: the lighting.
        table: the renderer's surface table: the global shading is replaced by
            ``config.ambient`` (no view-dependent diffuse term) on the shaded surfaces.
    """

    def __init__(self, world: World, quads: QuadArrays, unshaded: np.ndarray,
                 config: LightingConfig, table: np.ndarray) -> None:
        m = len(quads)
        self.config = config
        self.lamps_w = lamp_positions(world, config)
        self._heights = lamp_heights(quads.normals_w, quads.origins_w, self.lamps_w)
        self._heights[:, unshaded[:m]] = 0.0
        self._weights = np.zeros((self.lamps_w.shape[0], len(unshaded) + 1), dtype=np.float32)
        self._lamps_o = np.zeros((self.lamps_w.shape[0], 3), dtype=np.float32)
        self._square_o = np.zeros(self.lamps_w.shape[0], dtype=np.float32)
        table[_AMBIENT, :len(unshaded)] = np.where(unshaded, 1.0, config.ambient)
        table[_DIFFUSE, :len(unshaded)] = 0.0

    def start_frame(self, origin_w: np.ndarray, plane_offsets: np.ndarray) -> None:
        """Keep the lamps on the side of each quad seen from ``origin_w``.

        Args:
            origin_w: (3,) the frame's viewpoint [m].
            plane_offsets: (M,) ``-n_q . (origin - o_q)`` of the renderer's plane table.
        """
        side = -np.sign(plane_offsets)
        np.maximum(self._heights * side[None, :], 0.0, out=self._weights[:, :side.size],
                   casting="same_kind")
        self._weights *= np.float32(self.config.lamp_power_m2)
        self._lamps_o[...] = self.lamps_w - origin_w
        self._square_o[...] = np.sum(self._lamps_o.astype(float) ** 2, axis=1)

    def irradiance(self, directions_w: np.ndarray, distances_m: np.ndarray, ids: np.ndarray,
                   work: Workspace) -> np.ndarray:
        """(N,) float32 lamp term of rays (3, N) float32 ``directions_w`` hitting surfaces
        ``ids`` at float32 ``distances_m`` (0 where nothing is hit) from the viewpoint."""
        n = ids.shape[0]
        total = work.get("lamps.total", (n,), np.float32)
        total[...] = 0.0
        if not self.lamps_w.shape[0]:
            return total
        weights = _gather(self._weights, ids, work.get("lamps.weights",
                                                       (self._weights.shape[0], n), np.float32))
        minus_2t = np.multiply(distances_m, np.float32(-2.0), out=work.get("lamps.m2t", (n,),
                                                                             np.float32))
        t_square = np.multiply(distances_m, distances_m, out=work.get("lamps.t2", (n,),
                                                                      np.float32))
        square = work.get("lamps.d2", (n,), np.float32)
        tmp = work.get("lamps.tmp", (n,), np.float32)
        min_square = np.float32(self.config.min_distance_m**2)
        for k, (lamp, weight) in enumerate(zip(self._lamps_o, weights, strict=True)):
            np.multiply(directions_w[0], lamp[0], out=square)
            square += np.multiply(directions_w[1], lamp[1], out=tmp)
            square += np.multiply(directions_w[2], lamp[2], out=tmp)
            square *= minus_2t
            square += t_square
            square += self._square_o[k]
            np.maximum(square, min_square, out=square)
            np.sqrt(square, out=tmp)
            square *= tmp  # d^3
            weight /= square
            total += weight
        return total


@dataclass(frozen=True, slots=True)
class _WalkerSamples:
    """The rays of one ``_colour`` call that see walkers.

    Attributes:
        index: (K,) their positions among the call's rays.
        points_w: (K, 3) the points seen [m].
        normals_w: (K, 3) the walkers' outward normals there.
    """

    index: np.ndarray
    points_w: np.ndarray
    normals_w: np.ndarray


def _sorted_azimuths(directions_r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Order and sorted azimuths [rad] (in [-pi, pi]) of (3, N) robot-frame rays."""
    azimuth = np.arctan2(directions_r[1], directions_r[0])
    order = np.argsort(azimuth, kind="stable")
    return order, azimuth[order]


def _wrap(angle_rad: float) -> float:
    """``angle_rad`` in [-pi, pi)."""
    return (angle_rad + math.pi) % (2.0 * math.pi) - math.pi


class _Crowd:
    """The walkers of a renderer (``walkers``): where they are this frame, which rays they
    stop, and the texels and normals of what those rays see.

    Only rays whose azimuth points at a walker are tested: for a planar pose the robot-frame
    azimuths of the rays, sorted once, give them by two binary searches per walker (every ray
    is tested for other poses, or when the viewpoint is next to a walker).

    Args:
        walkers: the walkers; surface id ``first_id + k`` is walker k.
        first_id: the number of quads.
        rays: the renderer's rays (their robot-frame directions and origin offsets).
        sub_r: (3, S) the sub-pixel rays actually traced (robot frame).
    """

    def __init__(self, walkers: tuple[WalkerPath, ...], first_id: int, rays: RigRays,
                 sub_r: np.ndarray) -> None:
        self.walkers = walkers
        self.first_id = first_id
        self._radii = np.array([w.radius_m for w in walkers])
        self._heights = np.array([w.height_m for w in walkers])
        self._sizes_px = np.array([w.texture.size_px for w in walkers], dtype=float)
        self._azimuth = {"centre": _sorted_azimuths(rays.centre_r.T),
                         "sub": _sorted_azimuths(sub_r)}
        offsets = [o for o in (rays.centre_offset_r, rays.sub_offset_r) if o is not None]
        self._margin_m = max((float(np.max(np.hypot(o[..., 0], o[..., 1]))) for o in offsets),
                             default=0.0)
        self.centres_w = np.zeros((len(walkers), 2))
        self.origin_w = np.zeros(3)
        self._yaw: float | None = None

    def start_frame(self, stamp_s: float, R_wr: np.ndarray, origin_w: np.ndarray) -> None:
        """Place the walkers at time ``stamp_s`` [s], seen from ``origin_w`` with the robot's
        rotation ``R_wr``."""
        self.centres_w = walker_positions_w(self.walkers, np.array([stamp_s]))[0]
        self.origin_w = origin_w
        planar = abs(R_wr[2, 2] - 1.0) < 1e-12
        self._yaw = math.atan2(R_wr[1, 0], R_wr[0, 0]) if planar else None

    def _candidates(self, name: str, n: int) -> np.ndarray:
        """Indices of the rays of set ``name`` (``n`` rays) that may meet a walker."""
        if self._yaw is None:
            return np.arange(n)
        order, azimuth = self._azimuth[name]
        chosen = np.zeros(n, dtype=bool)
        for centre, radius in zip(self.centres_w, self._radii, strict=True):
            rel = centre - self.origin_w[:2]
            distance = math.hypot(rel[0], rel[1]) - self._margin_m
            reach = radius + self._margin_m
            if distance <= reach:
                return np.arange(n)
            half = math.asin(reach / distance)
            middle = math.atan2(rel[1], rel[0]) - self._yaw
            low, high = _wrap(middle - half), _wrap(middle + half)
            first = np.searchsorted(azimuth, low, side="left")
            last = np.searchsorted(azimuth, high, side="right")
            if low <= high:
                chosen[order[first:last]] = True
            else:
                chosen[order[first:]] = True
                chosen[order[:last]] = True
        return np.flatnonzero(chosen)

    def occlude(self, name: str, origin_w: np.ndarray, directions_w: np.ndarray,
                offsets_w: np.ndarray | None, ids: np.ndarray, t: np.ndarray,
                cos: np.ndarray) -> None:
        """Where a walker is nearer than the static hit, make ``ids``, ``t`` and ``cos`` (the
        ``_trace`` results, updated in place) the walker's."""
        candidates = self._candidates(name, ids.size)
        if not candidates.size:
            return
        d = directions_w[:, candidates]
        origins = np.repeat(origin_w[:, None], candidates.size, axis=1)
        if offsets_w is not None:
            origins += offsets_w[:, candidates]
        t_walker, walker = walker_hits(self.centres_w, self._radii, self._heights, origins, d)
        static = t[candidates]
        nearer = t_walker < np.where(np.isnan(static), np.inf, static)
        chosen, k, t_hit = candidates[nearer], walker[nearer], t_walker[nearer]
        ids[chosen] = self.first_id + k
        t[chosen] = t_hit
        hit_xy = origins[:2, nearer] + t_hit * d[:2, nearer]
        normal = (hit_xy - self.centres_w[k].T) / self._radii[k]
        cos[chosen] = np.abs(normal[0] * d[0, nearer] + normal[1] * d[1, nearer])

    def texels(self, ids: np.ndarray, directions_w: np.ndarray, distances_m: np.ndarray,
               offsets_w: np.ndarray | None, texel: np.ndarray) -> _WalkerSamples:
        """Write the level-0 texels of the rays that see walkers into ``texel`` (2, N): u
        around the body from its +x side, v down from the top of its head.

        Args:
            ids: (N,) surface ids of the rays.
            directions_w: (3, N) float32 directions.
            distances_m: (N,) float32 distances (0 where nothing is hit).
            offsets_w: (3, N) ray origin offsets (non-central rig) or None.
            texel: (2, N) the planar texels, overwritten where a walker is seen.
        """
        index = np.flatnonzero(ids >= self.first_id)
        k = ids[index] - self.first_id
        points = directions_w[:, index].astype(float) * distances_m[index]
        if offsets_w is not None:
            points += offsets_w[:, index]
        points += self.origin_w[:, None]
        normal_xy = (points[:2] - self.centres_w[k].T) / self._radii[k]
        around = np.mod(np.arctan2(normal_xy[1], normal_xy[0]), 2.0 * math.pi)
        texel[0, index] = around / (2.0 * math.pi) * self._sizes_px[k, 0]
        texel[1, index] = (self._heights[k] - points[2]) / self._heights[k] * self._sizes_px[k, 1]
        normals = np.zeros((index.size, 3))
        normals[:, :2] = normal_xy.T
        return _WalkerSamples(index, points.T, normals)
