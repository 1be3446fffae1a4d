"""The rendered world's realism in one place: lamps, an imperfect rig, photographs, walkers.

Each part is off unless its section is set (``WorldRealism``); ``WorldRealism.realistic()``
switches all four on with their defaults. ``draw_world_realism`` draws one render's share of
randomness (which posters show photographs, the true rig, the walkers' paths) from streams of
the render's seed that the simulation does not use, and returns what the renderer needs and
what a writer records (``RealWorld.truth``).

Seed streams: ``simulate`` draws the world, the odometry and the laser from the first three
children of ``SeedSequence(seed)``; the photographs, the rig and the walkers come from the
next three, so switching a part on changes neither the route, the sensors nor the other parts.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from omnislam.camera.rig import CameraRig
from omnislam.datasets.synthetic.lighting import LightingConfig
from omnislam.datasets.synthetic.photo_posters import (
    PhotoTextures,
    with_photo_textures,
    world_photo_credit,
)
from omnislam.datasets.synthetic.raycast import Backend
from omnislam.datasets.synthetic.render import Renderer
from omnislam.datasets.synthetic.rig_error import (
    RigError,
    RigPerturbation,
    draw_rig_perturbation,
)
from omnislam.datasets.synthetic.walkers import (
    WalkerPath,
    Walkers,
    draw_walkers,
    walker_positions_w,
)
from omnislam.datasets.synthetic.world import World

#: children of ``SeedSequence(seed)`` used by ``simulate`` (world, odometry, laser)
_SIMULATION_STREAMS = 3


@dataclass(frozen=True, slots=True)
class WorldRealism:
    """Which parts of the rendered world's realism are on (None: off, as in a clean render).

    Attributes:
        lighting: lamps at the light panels (``lighting``). Default None: the global shading.
        rig_error: bounds of the true rig's departure from the calibrated one
            (``rig_error``). Default None: the rig is the calibration.
        photo_textures: photographs on a fraction of the posters (``photo_posters``).
            Default None: procedural posters only.
        walkers: people walking through the world (``walkers``). Default None: a static
            world.
    """

    lighting: LightingConfig | None = None
    rig_error: RigError | None = None
    photo_textures: PhotoTextures | None = None
    walkers: Walkers | None = None

    @classmethod
    def realistic(cls) -> WorldRealism:
        """Every part on, with its defaults."""
        return cls(LightingConfig(), RigError(), PhotoTextures(), Walkers())


@dataclass(frozen=True, slots=True)
class RealWorld:
    """One render's realism, drawn: the world to render and the truth to record.

    Attributes:
        world: the world (with photographs on posters when they are on).
        lighting: the lamps, or None.
        rig_error: the true rig's departure from the calibrated one, or None.
        walkers: the walkers' bodies and paths (empty: none).
    """

    world: World
    lighting: LightingConfig | None
    rig_error: RigPerturbation | None
    walkers: tuple[WalkerPath, ...]

    def renderer(self, rig: CameraRig, backend: Backend | str | None = None,
                 supersample: int = 1) -> Renderer:
        """The renderer of this world through the (nominal) ``rig``; pass each frame's time
        to ``Renderer.render`` so that the walkers move."""
        return Renderer(self.world, rig, backend, supersample, lighting=self.lighting,
                        rig_error=self.rig_error, walkers=self.walkers)

    def walker_positions_w(self, stamps_s: np.ndarray) -> np.ndarray:
        """(N, W, 2) the walkers' centres at the frames' times ``stamps_s`` (N,) [s]."""
        return walker_positions_w(self.walkers, stamps_s)

    def truth(self) -> dict[str, Any]:
        """What a writer records (JSON-ready): the true rig (``RigPerturbation.to_dict``), the
        walkers (``WalkerPath.to_dict``; walker k has surface id ``len(world.quads) + k``),
        the photographs' credit (``world_photo_credit``) and whether the lamps were on; a part
        that is off is None (walkers: empty)."""
        return {
            "rig_error": None if self.rig_error is None else self.rig_error.to_dict(),
            "walkers": [w.to_dict() for w in self.walkers],
            "first_walker_id": len(self.world.quads),
            "photo_credit": world_photo_credit(self.world),
            "lighting": self.lighting is not None,
        }


def draw_world_realism(world: World, realism: WorldRealism, seed: int) -> RealWorld:
    """Draw the parts of ``realism`` that are on for the render of ``world`` with ``seed``.

    Args:
        world: the preset's world (``simulate(...).world``).
        realism: the parts on.
        seed: the render's seed (the one ``simulate`` took).
    """
    streams = np.random.SeedSequence(seed).spawn(_SIMULATION_STREAMS + 3)[_SIMULATION_STREAMS:]
    photo_rng, rig_rng, walker_rng = (np.random.default_rng(s) for s in streams)
    if realism.photo_textures is not None:
        world = with_photo_textures(world, realism.photo_textures, photo_rng)
    rig_error = (None if realism.rig_error is None
                 else draw_rig_perturbation(realism.rig_error, rig_rng))
    walkers = () if realism.walkers is None else draw_walkers(world, realism.walkers, walker_rng)
    return RealWorld(world, realism.lighting, rig_error, walkers)
