"""Front-end fixtures: small renders of the synthetic presets, and the tolerances, in one place."""

from __future__ import annotations

from pathlib import Path

import pytest
from frontend_tolerances import CORRIDOR_IMAGES, DEMO_IMAGES


def _render(root: Path, preset_name: str, images: int) -> Path:
    from omnislam.datasets.synthetic.presets import PRESETS
    from omnislam.datasets.synthetic.simulate import simulate
    from omnislam.datasets.synthetic.writer import write_synthetic

    out = root / preset_name
    write_synthetic(out, simulate(PRESETS[preset_name], seed=0, max_images=images))
    return out


@pytest.fixture(scope="session")
def demo_folder(tmp_path_factory) -> Path:
    """The first DEMO_IMAGES images of the ``demo`` preset, rendered once per session."""
    pytest.importorskip("cv2")
    return _render(tmp_path_factory.mktemp("synth"), "demo", DEMO_IMAGES)


@pytest.fixture(scope="session")
def demo_sequence(demo_folder):
    from omnislam.datasets.synthetic.loader import load_synthetic

    return load_synthetic(demo_folder)


@pytest.fixture(scope="session")
def demo_truth(demo_folder):
    """``points_w_of(frame)``: the renderer's world point of every pixel of a frame."""
    from omnislam.datasets.synthetic.loader import SyntheticFolder

    folder = SyntheticFolder(demo_folder)
    cache: dict[int, object] = {}

    def points_w_of(frame: int):
        if frame not in cache:
            cache[frame] = folder.ground_truth_maps(frame).points_w
        return cache[frame]

    return points_w_of


@pytest.fixture(scope="session")
def corridor_folder(tmp_path_factory) -> Path:
    pytest.importorskip("cv2")
    return _render(tmp_path_factory.mktemp("synth"), "corridor21", CORRIDOR_IMAGES)
