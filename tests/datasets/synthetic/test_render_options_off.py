"""With every realism option off the renderer draws exactly what it drew before they existed."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from omnislam.datasets.synthetic.render import Renderer

#: sha256 of image, surface ids and points of demo seed 3, image 5 (numpy caster), rendered by
#: the renderer before the lighting, rig-error, photo-texture and walker options existed
GOLDEN_SHA256 = {
    1: "bc26e6d6757515c7ee1398f02b5ceabed97e7e4ded0416257f4da79aeed36ef6",
    2: "893e900ccb9107381033cbf3baf4ab492ca899cac7abd211c923cb4df3c53c64",
}


@pytest.mark.parametrize("supersample", [1, 2])
def test_every_option_off_renders_the_golden_frame(demo_sim, supersample):
    renderer = Renderer(demo_sim.world, demo_sim.rig, "numpy", supersample)
    frame = renderer.render(demo_sim.poses_w[demo_sim.image_frames[5]])
    digest = hashlib.sha256()
    for array in (frame.image, frame.surface_ids, frame.points_w):
        digest.update(np.ascontiguousarray(array).tobytes())
    assert digest.hexdigest() == GOLDEN_SHA256[supersample]
