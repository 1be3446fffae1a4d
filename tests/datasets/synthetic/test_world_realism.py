"""The four parts of the rendered world's realism switched on together from one seed."""

from __future__ import annotations

import json

import numpy as np
import pytest

from omnislam.datasets.synthetic.render import Renderer
from omnislam.datasets.synthetic.rig_error import RigPerturbation
from omnislam.datasets.synthetic.textures import TextureKind
from omnislam.datasets.synthetic.walkers import WalkerPath, Walkers
from omnislam.datasets.synthetic.world_realism import WorldRealism, draw_world_realism


def test_off_draws_nothing_and_renders_as_before(demo_sim):
    drawn = draw_world_realism(demo_sim.world, WorldRealism(), seed=3)
    assert drawn.world == demo_sim.world and drawn.rig_error is None and drawn.walkers == ()
    assert drawn.truth() == {"rig_error": None, "walkers": [],
                             "first_walker_id": len(demo_sim.world.quads),
                             "photo_credit": None, "lighting": False}
    pose = demo_sim.poses_w[demo_sim.image_frames[1]]
    a = drawn.renderer(demo_sim.rig).render(pose, 5.0)
    b = Renderer(demo_sim.world, demo_sim.rig).render(pose)
    np.testing.assert_array_equal(a.image, b.image)
    np.testing.assert_array_equal(a.surface_ids, b.surface_ids)


def test_realistic_is_seeded_and_its_truth_round_trips(demo_sim):
    pytest.importorskip("skimage")
    a = draw_world_realism(demo_sim.world, WorldRealism.realistic(), seed=3)
    b = draw_world_realism(demo_sim.world, WorldRealism.realistic(), seed=3)
    c = draw_world_realism(demo_sim.world, WorldRealism.realistic(), seed=4)
    assert a == b and a.truth() == b.truth()
    assert a.rig_error != c.rig_error and a.walkers != c.walkers
    assert any(t.kind is TextureKind.PHOTO for t in a.world.textures)
    truth = json.loads(json.dumps(a.truth()))
    assert RigPerturbation.from_dict(truth["rig_error"]) == a.rig_error
    assert tuple(WalkerPath.from_dict(w) for w in truth["walkers"]) == a.walkers
    assert "scikit-image" in truth["photo_credit"] and truth["lighting"] is True
    assert a.walker_positions_w(demo_sim.stamps_s[:4]).shape == (4, len(a.walkers), 2)
    # the parts draw from their own streams: the walkers do not depend on the rig's bounds
    only_walkers = draw_world_realism(demo_sim.world, WorldRealism(walkers=Walkers()), seed=3)
    assert only_walkers.walkers == a.walkers

