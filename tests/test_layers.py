"""omnislam's own layer order: every import (top-level or lazy) points down or sideways.

``core`` <- ``camera`` <- ``datasets``, ``frontend`` <- estimators <- ``metrics`` <- ``harness``
<- ``report`` <- ``demo`` <- ``cli``
(DESIGN.md), with the package's base modules (errors, optional extras, file helpers) below
everything; an estimator package never imports another estimator package, so shared algebra
has to live in ``core``. The rooms: ``metrics`` (numbers of a run) below ``harness`` (running
estimators, writing what they leave on disk) below ``report`` (reading it), and ``demo`` above
both; the report reads the harness's file layout, RUN_DIRs and evaluation but never reaches
its runner or executor, not even through another module.
"""

import ast
from collections.abc import Mapping
from pathlib import Path

from test_no_import_cycles import import_graphs

import omnislam

ROOT = Path(omnislam.__file__).parent
BASE = (
    "omnislam.errors",
    "omnislam._optional",
    "omnislam._files",
    "omnislam._progress",
    "omnislam._version",
)
ESTIMATOR_PACKAGES = (
    "omnislam.graphslam",
    "omnislam.fastslam",
    "omnislam.ukf",
    "omnislam.ekfslam",
    "omnislam.deadreckoning",
)
LAYERS = (
    BASE,
    ("omnislam.core",),
    ("omnislam.camera",),
    ("omnislam.datasets", "omnislam.frontend"),
    (*ESTIMATOR_PACKAGES, "omnislam.estimators", "omnislam.options"),
    ("omnislam.metrics",),
    ("omnislam.harness",),
    ("omnislam.report",),
    ("omnislam.demo",),
    ("omnislam.cli", "omnislam.__main__"),
)
#: the harness's machinery that runs estimators: the report reads what the harness wrote (the
#: file names of ``harness.layout``, RUN_DIRs, metrics) and never imports it, not even through
#: another module, so a report can be written where nothing can run
RUNNING = ("omnislam.harness.execute", "omnislam.harness.runner")


def _owner(module: str, groups: tuple[str, ...]) -> str | None:
    return next((g for g in groups if module == g or module.startswith(g + ".")), None)


def layer_of(module: str) -> int | None:
    for level, groups in enumerate(LAYERS):
        if _owner(module, groups) is not None:
            return level
    return None


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports_of(path: Path) -> set[str]:
    """Every omnislam module ``path`` imports, at any depth of the file (lazy imports too)."""
    tree = ast.parse(path.read_text())
    package = module_name(path) if path.name == "__init__.py" else module_name(path.parent)
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                found.add(".".join([*base, node.module] if node.module else base))
            elif node.module:
                found.add(node.module)
    return {name for name in found if name == "omnislam" or name.startswith("omnislam.")}


def violations() -> list[str]:
    bad = []
    for path in sorted(ROOT.rglob("*.py")):
        source = module_name(path)
        level = layer_of(source)
        if source == "omnislam":
            continue
        assert level is not None, f"{source} belongs to no layer: add it to LAYERS"
        for target in sorted(imports_of(path)):
            if target == "omnislam":
                continue
            target_level = layer_of(target)
            assert target_level is not None, f"{source} imports {target}, which has no layer"
            if target_level > level:
                bad.append(f"{source} -> {target} (layer {level} imports layer {target_level})")
            own = _owner(source, ESTIMATOR_PACKAGES)
            other = _owner(target, ESTIMATOR_PACKAGES)
            if own is not None and other is not None and own != other:
                bad.append(f"{source} -> {target} (one estimator imports another)")
    return bad


def test_every_module_has_a_layer_and_imports_point_down():
    assert violations() == []


def test_the_checker_sees_lazy_and_relative_imports(tmp_path):
    sample = tmp_path / "omnislam" / "core" / "sample.py"
    sample.parent.mkdir(parents=True)
    sample.write_text(
        "def f():\n    from omnislam.report import plots\n"
        "from . import se\nimport omnislam.cli\n"
    )
    global ROOT
    saved, ROOT = ROOT, tmp_path / "omnislam"
    try:
        assert imports_of(sample) == {"omnislam.report", "omnislam.core", "omnislam.cli"}
    finally:
        ROOT = saved
    assert layer_of("omnislam.report.comparison") > layer_of("omnislam.core.se")


def reachable(start: str, graph: Mapping[str, set[str]]) -> set[str]:
    """Every module ``start`` imports, directly or through other modules."""
    seen: set[str] = set()
    pending = [start]
    while pending:
        for target in graph.get(pending.pop(), ()):
            if target not in seen:
                seen.add(target)
                pending.append(target)
    return seen


def test_the_report_imports_neither_the_runner_nor_the_executor():
    top, lazy = import_graphs()
    graph = {m: top[m] | lazy[m] for m in top}
    report = [m for m in sorted(graph) if _owner(m, ("omnislam.report",))]
    assert "omnislam.report.view" in report
    running = {m: sorted(reachable(m, graph) & set(RUNNING)) for m in report}
    assert {m: names for m, names in running.items() if names} == {}
    # what the report does read of the harness
    assert "omnislam.harness.layout" in reachable("omnislam.report.comparison", graph)
    # the check sees a path when there is one: the demo runs the grid through the runner
    assert set(RUNNING) <= reachable("omnislam.demo", graph)
