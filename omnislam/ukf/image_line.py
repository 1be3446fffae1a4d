"""The 1-D image of Barra & Costa (sec. 2.1): vertical lines become points on a line.

With the camera's vertical axis aligned with the world's, a vertical world line projects to an
image column (perspective camera) or to a radial segment (omni camera with a vertical mirror
axis); either way the image reduces to one coordinate u [px] that depends only on the line's
bearing in the robot frame. The paper's pixel thresholds (the u_shift windows of 3, 6, 12 and
24 px, the widened image plane) are expressed through this mapping:

* ``PerspectiveLine``: u = c + s f tan(b - b0) on the image plane (s = +-1 from the rig, so
  that u grows to the right of the image), the widened plane has ``widening`` times the
  image's width about its centre (sec. 3.2: "o dobro de seu tamanho").
* ``AngularLine``: u = k b, arc length on a circle of k px per radian; for an omni camera k is
  the radius of the horizon's image (so a window of 3 px spans the same angle it spans there),
  for sightings without a camera (MR.CLAM) k is an option. Its field of view is an angle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from omnislam.core.se import wrap_angle


@dataclass(frozen=True, slots=True)
class PerspectiveLine:
    """The image row of a pinhole camera with a level optical axis.

    Attributes:
        focal_px: f [px].
        centre_px: u of the principal point [px].
        half_width_px: half the image width [px].
        axis_rad: bearing of the optical axis in the robot frame [rad].
        sign: +1 when u grows with the bearing, -1 when it decreases (the usual camera).
        widening: the widened plane's size over the image's (paper: 2).
    """

    focal_px: float
    centre_px: float
    half_width_px: float
    axis_rad: float = 0.0
    sign: float = -1.0
    widening: float = 2.0

    def u_px(self, bearings_rad: np.ndarray) -> np.ndarray:
        """u [px] of lines at ``bearings_rad`` (NaN behind the camera)."""
        off = wrap_angle(np.asarray(bearings_rad, dtype=float) - self.axis_rad)
        with np.errstate(invalid="ignore"):
            u = self.centre_px + self.sign * self.focal_px * np.tan(off)
        return np.where(np.abs(off) < 0.5 * math.pi - 1e-6, u, np.nan)

    def in_widened_view(self, bearings_rad: np.ndarray) -> np.ndarray:
        """True where the ray meets the widened image plane (sec. 3.2, candidate selection)."""
        u = self.u_px(bearings_rad)
        with np.errstate(invalid="ignore"):
            return np.abs(u - self.centre_px) <= self.widening * self.half_width_px

    @property
    def px_per_rad(self) -> float:
        """Image scale at the principal point [px / rad]."""
        return self.focal_px


@dataclass(frozen=True, slots=True)
class AngularLine:
    """u = k b: the horizon circle of an omni image, or the bearing of a camera-less sensor.

    Attributes:
        px_per_rad: k [px / rad].
        fov_rad: full field of view before widening [rad] (2 pi: all round).
        widening: the widened field's size over the field's (paper: 2), capped at 2 pi.
    """

    px_per_rad: float
    fov_rad: float = 2.0 * math.pi
    widening: float = 2.0

    def u_px(self, bearings_rad: np.ndarray) -> np.ndarray:
        """u = k wrap(b) [px]."""
        return self.px_per_rad * wrap_angle(np.asarray(bearings_rad, dtype=float))

    def in_widened_view(self, bearings_rad: np.ndarray) -> np.ndarray:
        """True where |b| is within half the widened field of view."""
        half = min(math.pi, 0.5 * self.widening * self.fov_rad)
        b = wrap_angle(np.asarray(bearings_rad, dtype=float))
        return np.abs(b) <= half + 1e-12


ImageLine = PerspectiveLine | AngularLine


def image_line_from_rig(rig: object, widening: float = 2.0) -> ImageLine:
    """The 1-D image of a camera rig (``omnislam.camera.CameraRig``).

    A pinhole camera gives a ``PerspectiveLine`` whose focal length, centre and orientation are
    measured by projecting level points through the rig (so a rotated or distorted mount is
    handled to first order); any other camera is taken as omnidirectional with a vertical axis
    and gives an ``AngularLine`` whose scale is the radius of the horizon's image.
    """
    from omnislam.camera.pinhole import PinholeCamera

    camera = rig.camera  # type: ignore[attr-defined]
    viewpoint = np.asarray(rig.viewpoint_r, dtype=float)  # type: ignore[attr-defined]

    def u_of(bearings: np.ndarray) -> np.ndarray:
        points = viewpoint + np.column_stack(
            [np.cos(bearings), np.sin(bearings), np.zeros_like(bearings)]
        )
        pixels, _ = rig.project_r(points)  # type: ignore[attr-defined]
        return np.asarray(pixels, dtype=float)[:, 0]

    if isinstance(camera, PinholeCamera):
        axis_r = np.asarray(rig.rTc, dtype=float)[:3, 2]  # type: ignore[attr-defined]
        axis = math.atan2(axis_r[1], axis_r[0])
        delta = 0.05
        u0, up = u_of(np.array([axis, axis + delta]))
        sign = 1.0 if up > u0 else -1.0
        return PerspectiveLine(
            focal_px=abs(up - u0) / math.tan(delta),
            centre_px=float(u0),
            half_width_px=0.5 * camera.width,
            axis_rad=axis,
            sign=sign,
            widening=widening,
        )
    delta = 0.01
    points = viewpoint + np.array([[1.0, 0.0, 0.0], [math.cos(delta), math.sin(delta), 0.0]])
    pixels, _ = rig.project_r(points)  # type: ignore[attr-defined]
    chord = float(np.linalg.norm(np.asarray(pixels)[1] - np.asarray(pixels)[0]))
    return AngularLine(px_per_rad=chord / delta, widening=widening)
