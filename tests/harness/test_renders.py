"""The render cache's key: preset, seed, image limit, backend and the code a render can execute
-- an edit to that code re-keys every render, a docstring or code the renderer never reaches
does not."""

from __future__ import annotations

import ast
import shutil
import sys
from collections import defaultdict
from pathlib import Path

import pytest

import omnislam
from omnislam.datasets.synthetic.presets import PRESETS
from omnislam.datasets.synthetic.simulate import simulate
from omnislam.datasets.synthetic.writer import write_synthetic
from omnislam.harness import renders
from omnislam.harness.code_closure import closure_names, code_digest, without_docstrings

PACKAGE = Path(omnislam.__file__).parent


@pytest.fixture
def source(tmp_path: Path) -> Path:
    """A copy of omnislam's sources, to edit."""
    return shutil.copytree(
        PACKAGE, tmp_path / "omnislam", ignore=shutil.ignore_patterns("__pycache__")
    )


def key_after(source: Path, file: str, old: str, new: str) -> str:
    """The renderer's code hash once ``old`` (found once) is ``new`` in ``source/file``."""
    path = source / file
    text = path.read_text()
    assert text.count(old) == 1, (file, old)
    path.write_text(text.replace(old, new))
    return code_digest(renders.renderer_code(source))


def module_file(module: str) -> Path:
    base = PACKAGE.joinpath(*module.split(".")[1:])
    return base / "__init__.py" if (base / "__init__.py").is_file() else base.with_suffix(".py")


def test_the_render_key_ignores_docstrings_and_comments_but_not_code():
    def dump(source: str) -> str:
        return ast.dump(without_docstrings(ast.parse(source)), annotate_fields=False)

    base = 'def f(x):\n    """Doc."""\n    return x + 1  # one\n'
    assert dump(base) == dump('def f(x):\n    """Other doc."""\n    return x + 1\n')
    assert dump(base) != dump('def f(x):\n    """Doc."""\n    return x + 2\n')


def test_the_renderer_code_is_the_renderer_and_what_it_uses_of_the_front_end():
    names = closure_names(renders.renderer_code())
    # the odometry model and the camera models
    assert "OdometryMotionModel" in names["omnislam.core.motion"]
    assert "HyperbolicCamera" in names["omnislam.camera.hyperbolic"]
    # the render surveys the lines' MC descriptors with the front end's extraction
    # (datasets/synthetic/line_survey.py): that much of the front end, not its other settings
    assert "extract_vertical_lines" in names["omnislam.frontend.vertical_edges"]
    assert names["omnislam.frontend.config"] == ["ConfigError", "VerticalEdgeConfig", "dataclass"]
    assert names["omnislam.frontend.evaluation"] == ["np", "visible_lines"]
    assert "omnislam.frontend.observation_log" not in names
    # nor the harness
    rooms = ("omnislam.metrics", "omnislam.harness", "omnislam.report", "omnislam.demo")
    assert not any(m.startswith((*rooms, "omnislam.cli")) for m in names)


def test_the_key_of_a_copy_of_the_sources_is_the_installation_s(source):
    assert code_digest(renders.renderer_code(source)) == renders.renderer_code_hash()


@pytest.mark.parametrize(
    ("file", "old", "new"),
    [
        # the line survey's extraction, its configuration and its visibility test
        ("frontend/vertical_edges.py", "NMS_RADIUS = 3", "NMS_RADIUS = 4"),
        ("frontend/config.py", "    min_gradient: float = 20.0", "    min_gradient: float = 25.0"),
        ("frontend/evaluation.py", "np.arange(-3, 4)", "np.arange(-2, 3)"),
        # a helper of a helper: wrap_angle of the laser and the routes
        ("core/se.py", "shifted.size >= _WRAP_MASK_MIN_SIZE", "shifted.size > _WRAP_MASK_MIN_SIZE"),
    ],
)
def test_an_edit_to_code_a_render_runs_changes_the_key(source, file, old, new):
    assert key_after(source, file, old, new) != renders.renderer_code_hash()


@pytest.mark.parametrize(
    ("file", "old", "new"),
    [
        # docstrings of code the render runs
        ("frontend/config.py", "extraction (Barra & Costa sec. 2).", "extraction (sec. 2)."),
        ("frontend/evaluation.py", "The vertical-line landmarks visible", "The lines visible"),
        # the front end's other settings and functions, which no render reads
        ("frontend/config.py", "    max_iterations: int = 300", "    max_iterations: int = 400"),
        (
            "frontend/config.py",
            "return hashlib.sha256(text.encode()).hexdigest()[:16]",
            "return ''",
        ),
        ("frontend/evaluation.py", "return (good / total if total else 1.0), total", "return 0, 0"),
        ("frontend/observation_log.py", "LOG_FORMAT_VERSION = 2", "LOG_FORMAT_VERSION = 3"),
        ("core/se.py", "def se3_log(aTb: np.ndarray) -> np.ndarray:", "def se3_log(aTb):"),
    ],
)
def test_an_edit_no_render_can_see_keeps_the_key(source, file, old, new):
    assert key_after(source, file, old, new) == renders.renderer_code_hash()


def test_every_function_a_render_runs_is_in_the_key(tmp_path):
    spans = defaultdict(list)  # file -> line spans of the statements in the key
    for module, statements in renders.renderer_code().items():
        for s in statements:
            first = min([s.lineno, *(d.lineno for d in getattr(s, "decorator_list", []))])
            spans[str(module_file(module))].append((first, s.end_lineno))

    package = str(PACKAGE)

    def importing(frame: object) -> bool:
        """An omnislam module is being imported (its class bodies define, they do not render)."""
        while frame is not None:
            if frame.f_code.co_name == "<module>" and frame.f_code.co_filename.startswith(package):
                return True
            frame = frame.f_back
        return False

    ran = set()

    def profile(frame, event, arg):
        code = frame.f_code
        if event == "call" and code.co_filename.startswith(package):
            if code.co_name != "<module>" and not importing(frame.f_back):
                ran.add((code.co_filename, code.co_firstlineno, code.co_qualname))

    sys.setprofile(profile)
    try:  # corridor21: vertical lines, so the line survey runs the front end's extraction
        sim = simulate(PRESETS["corridor21"], 0, max_images=2, backend="numpy")
        write_synthetic(tmp_path / "render", sim, backend="numpy")
    finally:
        sys.setprofile(None)
    outside = [
        (Path(file).relative_to(PACKAGE).as_posix(), name)
        for file, line, name in ran
        if not any(a <= line <= b for a, b in spans[file])
    ]
    assert not outside
    assert any(name == "extract_vertical_lines" for _, _, name in ran)


def test_the_render_path_depends_on_preset_seed_images_and_nothing_random():
    a = renders.render_spec("lab40", 0)
    assert a == renders.render_spec("lab40", 0)  # stable within the process ...
    assert a.key != renders.render_spec("lab40", 1).key
    assert a.key != renders.render_spec("lab40", 0, images=5).key
    assert a.key != renders.render_spec("loop150", 0).key
    assert a.folder_name.startswith(f"lab40-s0-{a.backend}-")
