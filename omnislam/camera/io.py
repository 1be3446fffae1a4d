"""YAML files of cameras (``camera.yaml``) and rigs (``calibration.yaml``).

A camera file is the model's ``to_dict`` form, e.g.::

    model: hyperbolic
    a_m: 0.0281
    b_m: 0.0234
    ...

A rig file holds the camera under ``camera:`` and the 4x4 ``rTc`` (camera frame in the robot
frame) under ``rTc:``. A camera file written by ``omnislam calibrate`` also holds how well it
fits (``reprojection_rms_px``) and a ``calibration:`` mapping (images, standard deviations);
``load_camera`` ignores these keys (:data:`METADATA_KEYS`). Floats are written with ``repr``
precision, so a save/load round trip returns an equal object. Malformed files raise
:class:`~omnislam.errors.DataError` naming the file and the problem.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from omnislam._files import yaml_error_line
from omnislam.camera.base import CameraModel
from omnislam.camera.registry import CAMERA_MODELS, camera_from_dict
from omnislam.camera.rig import CameraRig
from omnislam.errors import DataError

__all__ = ["CAMERA_MODELS", "METADATA_KEYS", "load_camera", "load_rig", "save_camera", "save_rig"]

#: keys of a camera file that describe its calibration rather than the model
METADATA_KEYS = ("reprojection_rms_px", "calibration")


def _read_yaml(path: Path) -> Any:
    """Parse a YAML file, turning I/O and syntax errors into DataError."""
    import yaml

    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise DataError(f"cannot read file: {exc}", path) from exc
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise DataError(yaml_error_line(exc), path) from None


def _write_yaml(data: dict[str, Any], path: Path) -> None:
    """Block-style mappings; lists of numbers (polynomials, rows of rTc) on one line each."""
    import yaml

    class _Dumper(yaml.SafeDumper):
        pass

    def represent_list(dumper: yaml.SafeDumper, items: list[Any]) -> yaml.Node:
        flat = all(not isinstance(item, (list, dict)) for item in items)
        return dumper.represent_sequence("tag:yaml.org,2002:seq", items, flow_style=flat)

    _Dumper.add_representer(list, represent_list)
    path.write_text(yaml.dump(data, Dumper=_Dumper, sort_keys=False, default_flow_style=False))


def load_camera(path: str | Path) -> CameraModel:
    """Read a camera YAML file.

    Raises:
        DataError: naming the file and the problem (unreadable, not YAML, unknown model,
            missing or unknown key, wrong type, parameters the model rejects).
    """
    path = Path(path)
    data = _read_yaml(path)
    if isinstance(data, dict):
        data = {key: value for key, value in data.items() if key not in METADATA_KEYS}
    try:
        return camera_from_dict(data)
    except DataError as exc:
        raise DataError(str(exc), path) from exc


def save_camera(
    camera: CameraModel, path: str | Path, metadata: dict[str, Any] | None = None
) -> None:
    """Write ``camera`` as YAML (its ``to_dict`` form, then the ``metadata`` keys if any).

    Raises:
        DataError: a metadata key that is not one of :data:`METADATA_KEYS`.
    """
    data = camera.to_dict()
    for key, value in (metadata or {}).items():
        if key not in METADATA_KEYS:
            raise DataError(f"unknown camera-file metadata key {key!r} (known: {METADATA_KEYS})")
        data[key] = value
    _write_yaml(data, Path(path))


def load_rig(path: str | Path) -> CameraRig:
    """Read a rig (``calibration.yaml``: ``camera:`` + ``rTc:``).

    Raises:
        DataError: naming the file and the problem.
    """
    path = Path(path)
    data = _read_yaml(path)
    try:
        return CameraRig.from_dict(data)
    except DataError as exc:
        raise DataError(str(exc), path) from exc


def save_rig(rig: CameraRig, path: str | Path) -> None:
    """Write a rig as YAML (``camera:`` mapping and ``rTc:`` as four rows)."""
    _write_yaml(rig.to_dict(), Path(path))
