"""No function in ``omnislam/`` over 100 lines and no class over 400, outside the numba kernels.

A function longer than a screen and a half does several jobs; a class past 400 lines holds several
collaborators. The numba kernels (``fastslam/kernels.py``, ``frontend/kernels.py``) are exempt:
a compiled kernel keeps its loop in one body so that the compiler sees it whole. Lines are counted
from the ``def`` or ``class`` line to the last line of the body, docstring included, as ``ast``
reports them.
"""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "omnislam"

MAX_FUNCTION_LINES = 100
MAX_CLASS_LINES = 400

#: modules of numba kernels, whose loops stay in one compiled body
KERNEL_MODULES = frozenset({"fastslam/kernels.py", "frontend/kernels.py"})


def oversized(source: str, where: str) -> list[str]:
    """``where:line name (N lines)`` for every function over ``MAX_FUNCTION_LINES`` and every
    class over ``MAX_CLASS_LINES`` in ``source``."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            limit = MAX_FUNCTION_LINES
        elif isinstance(node, ast.ClassDef):
            limit = MAX_CLASS_LINES
        else:
            continue
        lines = node.end_lineno - node.lineno + 1  # type: ignore[operator]
        if lines > limit:
            found.append(f"{where}:{node.lineno} {node.name} ({lines} lines)")
    return found


def test_no_function_over_100_lines_and_no_class_over_400():
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        relative = path.relative_to(PACKAGE).as_posix()
        if relative not in KERNEL_MODULES:
            found += oversized(path.read_text(), relative)
    assert found == []


def test_the_kernel_modules_exist():
    """The exemption names modules that are there (a renamed kernel module loses it)."""
    assert all((PACKAGE / module).is_file() for module in KERNEL_MODULES)


def test_the_check_sees_a_long_function_and_a_long_class():
    body = "".join(f"    x{i} = {i}\n" for i in range(MAX_FUNCTION_LINES))
    assert oversized("def f():\n" + body, "m.py") == ["m.py:1 f (101 lines)"]
    assert oversized("def f():\n" + body[: -len("    x99 = 99\n")], "m.py") == []
    methods = "".join(f"    def m{i}(self):\n        return {i}\n\n" for i in range(134))
    assert oversized("class C:\n" + methods, "m.py") == ["m.py:1 C (402 lines)"]
