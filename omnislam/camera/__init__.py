"""Camera models: pixels <-> unit rays from a single viewpoint, masks, noise and YAML I/O.

Models: :class:`HyperbolicCamera` (the thesis's hyperbolic-mirror camera, section 4.3),
:class:`UnifiedCamera` (Mei's unified sphere model), :class:`OCamCalibCamera` (Scaramuzza's
polynomial model, :func:`read_ocamcalib`) and :class:`PinholeCamera`. All implement
:class:`CameraModel`; :class:`CameraRig` mounts one on the robot.
"""

from omnislam.camera.base import CameraModel
from omnislam.camera.distortion import RadialTangential
from omnislam.camera.hyperbolic import HyperbolicCamera
from omnislam.camera.io import load_camera, load_rig, save_camera, save_rig
from omnislam.camera.ocamcalib import OCamCalibCamera, read_ocamcalib, write_ocamcalib
from omnislam.camera.pinhole import PinholeCamera
from omnislam.camera.registry import CAMERA_MODELS, camera_from_dict
from omnislam.camera.rig import CameraRig
from omnislam.camera.unified import UnifiedCamera, hyperbolic_to_unified

__all__ = [
    "CAMERA_MODELS",
    "CameraModel",
    "CameraRig",
    "HyperbolicCamera",
    "OCamCalibCamera",
    "PinholeCamera",
    "RadialTangential",
    "UnifiedCamera",
    "camera_from_dict",
    "hyperbolic_to_unified",
    "load_camera",
    "load_rig",
    "read_ocamcalib",
    "save_camera",
    "save_rig",
    "write_ocamcalib",
]
