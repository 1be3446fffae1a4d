"""Synthetic omnidirectional worlds: textured rooms and corridors, a catadioptric renderer with
per-pixel ground truth, the seeds' routes as presets, and the on-disk dataset format.

Modules: ``world`` (geometry + landmarks, JSON), ``textures`` (procedural textures + lookup),
``raycast``/``raycast_numpy``/``raycast_open3d`` (first-hit ray casting; ``hit_distances``
their exact distances), ``render`` (images and ground-truth maps; its optional realism:
``lighting`` lamps, ``rig_error`` an imperfect rig, ``photos``/``photo_posters`` photographs on
posters, ``walkers`` people walking), ``routes``
(differential-drive paths, odometry), ``laser`` (scans and pole sightings), ``presets`` (named
scenarios), ``simulate`` (a preset's non-image data), ``writer``/``loader`` (folder format),
``cli`` (``omnislam dataset synth``).

Heavy parts (renderer, open3d, cv2) are imported only when used.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "cli_synth": "omnislam.datasets.synthetic.cli",
    "is_synthetic_folder": "omnislam.datasets.synthetic.loader",
    "load_synthetic": "omnislam.datasets.synthetic.loader",
    "read_ground_truth_maps": "omnislam.datasets.synthetic.loader",
    "SyntheticFolder": "omnislam.datasets.synthetic.loader",
    "GroundTruthMaps": "omnislam.datasets.synthetic.loader",
    "PRESETS": "omnislam.datasets.synthetic.presets",
    "Preset": "omnislam.datasets.synthetic.presets",
    "Renderer": "omnislam.datasets.synthetic.render",
    "RenderedFrame": "omnislam.datasets.synthetic.render",
    "Backend": "omnislam.datasets.synthetic.raycast",
    "World": "omnislam.datasets.synthetic.world",
    "simulate": "omnislam.datasets.synthetic.simulate",
    "write_synthetic": "omnislam.datasets.synthetic.writer",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)
