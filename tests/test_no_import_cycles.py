"""Imports inside ``omnislam/`` form no cycle: the module graph, read with ``ast``, is acyclic.

Top-level imports (module body, including ``if``/``try``/``with`` blocks and class bodies, but not
``if TYPE_CHECKING:``) run when a module is imported: a cycle among them makes the import order
matter and half-initialised modules appear. Imports inside functions run later (lazy imports of
optional or heavy parts) and may not close a cycle either: the whole package's graph, lazy
imports included, is acyclic, so that no module's behaviour depends on which of two was imported
first. ``python tests/test_no_import_cycles.py`` prints any cycle lazy imports close.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator, Mapping
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "omnislam"

Graph = dict[str, set[str]]


def module_name(path: Path) -> str:
    """``omnislam/harness/rundir.py`` -> ``omnislam.harness.rundir`` (packages: their folder)."""
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _imports(node: ast.AST, in_function: bool = False) -> Iterator[tuple[ast.stmt, bool]]:
    """(import statement, inside a function) for every import under ``node``."""
    for child in ast.iter_child_nodes(node):
        if isinstance(child, ast.Import | ast.ImportFrom):
            yield child, in_function
        elif isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda):
            yield from _imports(child, True)
        elif isinstance(child, ast.If) and _is_type_checking(child):
            yield from _imports(ast.Module(body=child.orelse, type_ignores=[]), in_function)
        else:
            yield from _imports(child, in_function)


def _targets(node: ast.stmt, here: str, is_package: bool, modules: set[str]) -> set[str]:
    """The omnislam modules one import statement loads (``from pkg import submodule`` included)."""
    if isinstance(node, ast.Import):
        return {alias.name for alias in node.names if alias.name.split(".")[0] == "omnislam"}
    assert isinstance(node, ast.ImportFrom)
    if node.level:  # relative: resolve against this module's package
        base = here.split(".") if is_package else here.split(".")[:-1]
        base = base[: len(base) - (node.level - 1)]
        source = ".".join(base + ([node.module] if node.module else []))
    else:
        source = node.module or ""
    if source.split(".")[0] != "omnislam":
        return set()
    out = set()
    for alias in node.names:
        sub = f"{source}.{alias.name}"
        out.add(sub if sub in modules else source)
    return out


def import_graphs() -> tuple[Graph, Graph]:
    """(top-level graph, lazy graph): module -> omnislam modules it imports."""
    files = sorted(PACKAGE.rglob("*.py"))
    modules = {module_name(f) for f in files}
    top: Graph = {m: set() for m in modules}
    lazy: Graph = {m: set() for m in modules}
    for file in files:
        here = module_name(file)
        tree = ast.parse(file.read_text(), str(file))
        for node, in_function in _imports(tree):
            targets = _targets(node, here, file.name == "__init__.py", modules) - {here}
            (lazy if in_function else top)[here] |= targets & modules
    return top, lazy


def find_cycles(graph: Mapping[str, set[str]]) -> list[list[str]]:
    """Every strongly connected component with more than one module (Tarjan), sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in sorted(graph.get(node, ())):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                components.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return sorted(components)


def lazy_cycles() -> list[list[str]]:
    """Cycles that appear once the imports inside functions are counted too."""
    top, lazy = import_graphs()
    both = {m: top[m] | lazy[m] for m in top}
    return find_cycles(both)


def test_the_graph_sees_the_known_imports():
    top, lazy = import_graphs()
    assert "omnislam.metrics.trajectory" in top["omnislam.harness.evaluation"]
    assert "omnislam.core.types" in top["omnislam.harness.rundir"]
    assert "omnislam.report.plots" in lazy["omnislam.report.figures"]  # from pkg import module


def test_cycle_finder_finds_a_cycle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert find_cycles(graph) == [["a", "b", "c"]]


def test_top_level_imports_are_acyclic():
    top, _ = import_graphs()
    assert find_cycles(top) == []


#: the rooms of the harness and its results: no cycle among their modules, lazy imports included
ROOMS = ("omnislam.metrics", "omnislam.harness", "omnislam.report", "omnislam.demo")


def test_evaluation_and_rundir_do_not_import_each_other():
    top, lazy = import_graphs()
    rundir, evaluation = "omnislam.harness.rundir", "omnislam.harness.evaluation"
    assert evaluation not in top[rundir] | lazy[rundir]


def test_the_rooms_have_no_cycle_lazy_imports_included():
    top, lazy = import_graphs()
    rooms = {m: top[m] | lazy[m] for m in top if m.startswith(ROOMS)}
    assert {"omnislam.metrics.trajectory", "omnislam.harness.frames", "omnislam.report.model",
            "omnislam.demo"} <= set(rooms)
    assert find_cycles(rooms) == []
    # a lazy import back from the layout to the runner would close one
    layout, runner = "omnislam.harness.layout", "omnislam.harness.runner"
    rooms[layout] = rooms[layout] | {runner}
    assert find_cycles(rooms) != []


def test_no_cycle_anywhere_lazy_imports_included():
    top, lazy = import_graphs()
    assert find_cycles({m: top[m] | lazy[m] for m in top}) == []


def _in_package(module: str, package: str) -> bool:
    return module == package or module.startswith(package + ".")


def test_frontend_and_datasets_have_no_cycle_even_with_their_lazy_imports():
    """No cycle, lazy imports counted, passes through the front end or the loaders (the
    compiled SIFT kernels are chosen in ``kernels_compiled``, above ``kernels`` and
    ``kernels_aot``; the ray casters' shared distances live in ``hit_distances``, below
    ``raycast`` and its back ends)."""
    top, lazy = import_graphs()
    # the lazy imports are in the graph: the backend choice, the kernels' loading
    raycast = "omnislam.datasets.synthetic.raycast"
    assert f"{raycast}_numpy" in lazy[raycast]
    assert "omnislam.frontend.kernels_compiled" in lazy["omnislam.frontend.scale_space"]
    both = {m: top[m] | lazy[m] for m in top}
    for package in ("omnislam.frontend", "omnislam.datasets"):
        through = [c for c in find_cycles(both) if any(_in_package(m, package) for m in c)]
        assert through == [], package
    # an import back up (the kernels loading their ahead-of-time module) would be one
    both["omnislam.frontend.kernels"] = both["omnislam.frontend.kernels"] | {
        "omnislam.frontend.kernels_aot"}
    assert ["omnislam.frontend.kernels", "omnislam.frontend.kernels_aot"] in find_cycles(both)


if __name__ == "__main__":
    for cycle in lazy_cycles():
        print("lazy import cycle:", " <-> ".join(cycle))
