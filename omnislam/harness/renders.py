"""Synthetic presets in a grid: every (preset, seed, image limit, realism) rendered once into the
cache.

A grid names a synthetic dataset by its preset (``{synthetic: lab40, seeds: [0, 1, 2]}``,
optionally ``realism: realistic``, ``harness.grid``); each seed is rendered as ``omnislam
dataset synth PRESET --seed S [--frames N] [--realism R]`` would render it, into
``cache_dir()/renders/PRESET-sS[-iN][-R]-BACKEND-KEY`` (``-R`` only when not clean). KEY hashes
what the render is a function of: the preset, the seed, the image limit, the realism, the
ray-casting backend and the code that renders -- the synthetic package's simulator, presets
and writer and, name by name, what they can execute inside omnislam (``harness.code_closure``:
of ``frontend.config`` only ``VerticalEdgeConfig``, of ``frontend.evaluation`` only
``visible_lines``), each statement as its syntax tree without docstrings. An edited comment or
a front-end setting the renderer never reads re-renders nothing; a changed odometry model or
camera re-renders everything, and since the path changes, every cell on it is computed again.

The path is known before the render exists, so a grid's cells name it from the start
(``omnislam run PRESET`` renders into the same folder: ``preset_render``); the writer produces
byte-identical folders for the same inputs and writes atomically (``datasets.synthetic.writer``),
so any worker of a cluster may render it into a shared cache.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass, fields
from functools import lru_cache
from pathlib import Path

from omnislam.errors import ConfigError
from omnislam.harness.cache import cache_dir
from omnislam.harness.code_closure import Closure, code_closure, code_digest

#: sub-folder of the cache holding the renders
RENDERS = "renders"
#: the modules a render runs: all of them, and what they can execute of what they import
RENDER_ROOTS = (
    "omnislam.datasets.synthetic.presets",
    "omnislam.datasets.synthetic.simulate",
    "omnislam.datasets.synthetic.writer",
)


@dataclass(frozen=True, slots=True)
class RenderSpec:
    """One synthetic dataset of a grid.

    Attributes:
        preset: preset name (``omnislam.datasets.synthetic.PRESETS``).
        seed: the render's seed (world details and every noise).
        images: keep the run up to its ``images``-th image (None: the whole route).
        backend: ray-casting backend (``Backend`` value).
        key: hash of everything the render is a function of (``render_spec``).
        realism: how realistic the images are (``datasets.synthetic.realism.Realism`` value).
    """

    preset: str
    seed: int
    images: int | None
    backend: str
    key: str
    realism: str = "clean"

    @property
    def folder_name(self) -> str:
        limit = f"-i{self.images}" if self.images is not None else ""
        realism = f"-{self.realism}" if self.realism != "clean" else ""
        return f"{self.preset}-s{self.seed}{limit}{realism}-{self.backend}-{self.key}"

    def path(self, root: Path | None = None) -> Path:
        """Where the render lives: ``root`` (default ``cache_dir()/renders``) / folder_name."""
        return (root if root is not None else cache_dir() / RENDERS) / self.folder_name


def renderer_code(package_dir: Path | None = None) -> Closure:
    """The code a render can execute: ``code_closure`` of ``RENDER_ROOTS``.

    Args:
        package_dir: the omnislam source folder to read (default: this installation's).
    """
    return code_closure(RENDER_ROOTS, package_dir or Path(__file__).resolve().parents[1])


@lru_cache(maxsize=1)
def renderer_code_hash() -> str:
    """Hash of the code a render can execute (``renderer_code``), as SHA-256 hex."""
    return code_digest(renderer_code())


def render_spec(preset: str, seed: int, images: int | None = None, realism: str = "clean"
                ) -> RenderSpec:
    """The RenderSpec of a preset's render with this installation's default backend.

    Raises:
        ConfigError: an unknown preset (listing the known ones) or realism, or a bad image
            limit.
    """
    from omnislam.datasets.synthetic import PRESETS
    from omnislam.datasets.synthetic.raycast import Backend
    from omnislam.datasets.synthetic.realism import Realism

    definition = PRESETS.get(preset)
    if definition is None:
        raise ConfigError(f"unknown synthetic preset {preset!r}; known: {', '.join(PRESETS)}")
    if images is not None and images < 1:
        raise ConfigError(f"synthetic {preset}: images must be >= 1, got {images}")
    realism = Realism.parse(realism).value
    backend = Backend.default().value
    parameters = [
        f"{f.name}={getattr(value, '__qualname__', None) or repr(value)}"
        for f in fields(definition)
        for value in [getattr(definition, f.name)]
    ]  # the world builder by name (its code is in renderer_code_hash), not by address
    digest = hashlib.sha256(
        "\n".join([*parameters, str(seed), str(images), realism, backend,
                   renderer_code_hash()]).encode()
    )
    return RenderSpec(preset, seed, images, backend, digest.hexdigest()[:12], realism)


def preset_render(dataset: str, seed: int) -> RenderSpec | None:
    """The render a run's dataset argument names, or None when it names data on disk.

    ``omnislam run demo`` renders the preset as a grid's ``{synthetic: demo}`` with that seed
    does (the same cache folder, so a run and a grid cell share the render and its front-end
    log): a synthetic preset's name that is neither a registered dataset nor an existing path.
    """
    from omnislam.datasets.registry import REGISTRY, preset_names

    if dataset in REGISTRY or dataset not in preset_names() or Path(dataset).exists():
        return None
    return render_spec(dataset, seed)


def ensure_render(
    spec: RenderSpec, path: str | Path, on_step: Callable[[str, int, int], None] | None = None
) -> bool:
    """Render ``spec`` into ``path`` unless a complete render is there; True when it rendered.

    The writer renames a finished folder into place, so a folder that is there is complete.
    ``on_step(stage, done, total)`` hears "simulating" (0 of 0) and then "rendering" with the
    images written of the images to write.
    """
    from omnislam.datasets.synthetic import PRESETS, is_synthetic_folder
    from omnislam.datasets.synthetic.simulate import simulate
    from omnislam.datasets.synthetic.writer import write_synthetic

    path = Path(path)
    if is_synthetic_folder(path):
        return False
    if on_step is not None:
        on_step("simulating", 0, 0)
    sim = simulate(PRESETS[spec.preset], spec.seed, max_images=spec.images, backend=spec.backend)
    images = len(sim.image_frames)

    def written(count: int) -> None:
        if on_step is not None:
            on_step("rendering", count, images)

    write_synthetic(path, sim, backend=spec.backend, overwrite=True, progress=written,
                    realism=spec.realism)
    return True
