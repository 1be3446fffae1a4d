"""Lazy imports of optional dependencies with an error naming the extra that provides them."""

from __future__ import annotations

import importlib
from types import ModuleType

from omnislam.errors import MissingExtraError

#: module name -> extra of pyproject.toml that installs it
EXTRAS: dict[str, str] = {
    "cv2": "vision",
    "gtsam": "graph",
    "open3d": "render",
    "pycolmap": "colmap",
    "dask": "distributed",
    "distributed": "distributed",
    "matplotlib": "plots",
    "filterpy": "ukf",
    "rerun": "view",
    "numba": "fast",
    "rosbags": "rosbag",
    "skimage": "render",
}


def require(module: str) -> ModuleType:
    """Import ``module`` or raise MissingExtraError naming the omnislam extra to install."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        top = module.split(".")[0]
        raise MissingExtraError(module, EXTRAS.get(top, "all")) from exc


def available(module: str) -> bool:
    """True when ``module`` can be imported (it is imported to find out)."""
    try:
        importlib.import_module(module)
    except ImportError:
        return False
    return True
