"""Fixtures of the synthetic-world tests: a short demo run rendered once per session."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from omnislam.datasets.synthetic.presets import PRESETS
from omnislam.datasets.synthetic.simulate import Simulation, simulate
from omnislam.datasets.synthetic.writer import write_synthetic

#: images of the demo preset rendered by the session fixture
DEMO_IMAGES = 8


@pytest.fixture(scope="session")
def demo_sim() -> Simulation:
    return simulate(PRESETS["demo"], seed=3, max_images=DEMO_IMAGES, backend="numpy")


@pytest.fixture(scope="session")
def demo_folder(tmp_path_factory: pytest.TempPathFactory, demo_sim: Simulation) -> Path:
    pytest.importorskip("cv2")
    out = tmp_path_factory.mktemp("synth") / "demo"
    return write_synthetic(out, demo_sim)  # open3d when installed (fast), else numpy


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(5)
