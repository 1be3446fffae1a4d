"""Synthetic presets in a grid: every (preset, seed, image limit) rendered once into the cache.

A grid names a synthetic dataset by its preset (``{synthetic: lab40, seeds: [0, 1, 2]}``,
``compare.grid``); each seed is rendered as ``omnislam dataset synth PRESET --seed S [--frames
N]`` would render it, into ``cache_dir()/renders/PRESET-sS[-iN]-BACKEND-KEY``. KEY hashes what
the render is a function of: the preset, the seed, the image limit, the ray-casting backend and
the code that renders -- the static import closure, inside omnislam, of the synthetic package's
simulator, presets and writer, each module as its syntax tree without docstrings (an edited
comment re-renders nothing; a changed odometry model or camera re-renders everything, and since
the path changes, every cell on it is computed again).

The path is known before the render exists, so a grid's cells name it from the start; the
writer produces byte-identical folders for the same inputs and writes atomically
(``datasets.synthetic.writer``), so any worker of a cluster may render it into a shared cache.
"""

from __future__ import annotations

import ast
import hashlib
from collections.abc import Callable
from dataclasses import dataclass, fields
from functools import lru_cache
from pathlib import Path

from omnislam.compare.cache import cache_dir
from omnislam.errors import ConfigError

#: sub-folder of the cache holding the renders
RENDERS = "renders"
#: the modules whose code a render is a function of (with everything they import)
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
        key: hash of everything the render is a function of (``render_key``).
    """

    preset: str
    seed: int
    images: int | None
    backend: str
    key: str

    @property
    def folder_name(self) -> str:
        limit = f"-i{self.images}" if self.images is not None else ""
        return f"{self.preset}-s{self.seed}{limit}-{self.backend}-{self.key}"

    def path(self, root: Path | None = None) -> Path:
        """Where the render lives: ``root`` (default ``cache_dir()/renders``) / folder_name."""
        return (root if root is not None else cache_dir() / RENDERS) / self.folder_name


def _source_file(module: str) -> Path | None:
    """The source of an omnislam module, found without importing it (None: not a module)."""
    import omnislam

    parts = module.split(".")[1:]
    base = Path(omnislam.__file__).parent.joinpath(*parts)
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if parts and candidate.is_file():
            return candidate
    return None


def _imported_modules(tree: ast.AST) -> set[str]:
    """Every ``omnislam`` module a syntax tree imports (lazy imports inside functions too)."""
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name.startswith("omnislam"))
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            if node.module.startswith("omnislam"):
                found.add(node.module)
                # ``from omnislam.x import y`` where y is a module
                found.update(f"{node.module}.{a.name}" for a in node.names)
    return found


def _without_docstrings(tree: ast.Module) -> ast.Module:
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                if isinstance(body[0].value.value, str):
                    node.body = body[1:] or [ast.Pass()]
    return tree


@lru_cache(maxsize=1)
def renderer_code_hash() -> str:
    """Hash of the code of the renderer: the static import closure of ``RENDER_ROOTS``."""
    pending, seen = list(RENDER_ROOTS), {}
    while pending:
        module = pending.pop()
        if module in seen:
            continue
        path = _source_file(module)
        if path is None:  # a name imported from a module, not a module
            seen[module] = None
            continue
        tree = ast.parse(path.read_text(), filename=str(path))
        pending.extend(_imported_modules(tree))
        seen[module] = ast.dump(_without_docstrings(tree), annotate_fields=False)
    digest = hashlib.sha256()
    for module in sorted(m for m, dump in seen.items() if dump is not None):
        digest.update(f"{module}\n{seen[module]}\n".encode())
    return digest.hexdigest()


def render_spec(preset: str, seed: int, images: int | None = None) -> RenderSpec:
    """The RenderSpec of a preset's render with this installation's default backend.

    Raises:
        ConfigError: an unknown preset (listing the known ones) or a bad image limit.
    """
    from omnislam.datasets.synthetic import PRESETS
    from omnislam.datasets.synthetic.raycast import Backend

    definition = PRESETS.get(preset)
    if definition is None:
        raise ConfigError(f"unknown synthetic preset {preset!r}; known: {', '.join(PRESETS)}")
    if images is not None and images < 1:
        raise ConfigError(f"synthetic {preset}: images must be >= 1, got {images}")
    backend = Backend.default().value
    parameters = [
        f"{f.name}={getattr(value, '__qualname__', None) or repr(value)}"
        for f in fields(definition)
        for value in [getattr(definition, f.name)]
    ]  # the world builder by name (its code is in renderer_code_hash), not by address
    digest = hashlib.sha256(
        "\n".join([*parameters, str(seed), str(images), backend, renderer_code_hash()]).encode()
    )
    return RenderSpec(preset, seed, images, backend, digest.hexdigest()[:12])


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

    write_synthetic(path, sim, backend=spec.backend, overwrite=True, progress=written)
    return True
