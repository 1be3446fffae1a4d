"""Camera models by the ``model:`` key of their dictionary / YAML form."""

from __future__ import annotations

from typing import Any

from omnislam.camera.base import CameraModel
from omnislam.camera.hyperbolic import HyperbolicCamera
from omnislam.camera.ocamcalib import OCamCalibCamera
from omnislam.camera.pinhole import PinholeCamera
from omnislam.camera.unified import UnifiedCamera
from omnislam.errors import DataError

#: ``model`` key -> model class
CAMERA_MODELS: dict[str, type[CameraModel]] = {
    cls.MODEL: cls for cls in (HyperbolicCamera, UnifiedCamera, OCamCalibCamera, PinholeCamera)
}


def camera_from_dict(d: Any) -> CameraModel:
    """Build a camera from its ``to_dict`` form, dispatching on the ``model`` key.

    Raises:
        DataError: not a mapping, no or unknown ``model``, or a field the model rejects.
    """
    if not isinstance(d, dict):
        raise DataError(f"a camera must be a mapping with a 'model' key, got {type(d).__name__}")
    if "model" not in d:
        raise DataError(f"missing key 'model' (one of: {', '.join(sorted(CAMERA_MODELS))})")
    name = d["model"]
    if name not in CAMERA_MODELS:
        raise DataError(
            f"unknown camera model {name!r} (known: {', '.join(sorted(CAMERA_MODELS))})"
        )
    return CAMERA_MODELS[name].from_dict(d)
