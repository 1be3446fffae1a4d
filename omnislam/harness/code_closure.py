"""The code some root modules can execute, statement by statement, and its hash.

A cached product (a synthetic render, ``harness.renders``) is a function of the code that made
it, so its cache key hashes that code -- and no more, or an edit to a class the product never
uses, in a module it imports one name from, throws the cache away. The closure is static and
follows names, not whole modules:

- a root module counts whole: every top-level statement;
- a top-level statement that binds names (``def``, ``class``, an assignment, one name of an
  import) counts when one of its names is needed; one that binds none (``X.setflags(...)``,
  ``if __name__ == ...``) counts whenever its module is imported, as do those of the packages
  above it and of the modules it imports at its top level (Python runs them all); a
  ``from __future__ import`` counts with any statement of its module;
- a counted statement needs its module's top-level names it mentions anywhere (bodies,
  decorators, defaults, annotations) and what it imports, lazy imports inside functions too:
  ``from M import name`` needs ``name``'s statements in M (through re-exports), ``import M``,
  a submodule imported by name or a string naming a module need the whole of M;
- when in doubt, the whole module: a name M does not bind at its top level (a module
  ``__getattr__``, ``import *``) and a statement that looks names up at run time (``globals``,
  ``vars``, ``eval``, ``exec``, ``__import__``, ``importlib``) need all of M.

Statements are compared as syntax trees without docstrings (a comment or a docstring changes
nothing). Only the roots' own package is followed: third-party code is the environment's.
"""

from __future__ import annotations

import ast
import hashlib
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

#: names through which a statement can reach any name of its module at run time
DYNAMIC_LOOKUPS = frozenset({"globals", "vars", "eval", "exec", "__import__", "importlib"})
#: how ``closure_names`` lists a statement that binds no name (it runs on import)
ON_IMPORT = "<on import>"

#: expressions whose names are their own, not the module's
_OWN_SCOPES = (ast.Lambda, ast.ListComp, ast.SetComp, ast.DictComp, ast.GeneratorExp)

#: module name -> its counted top-level statements, in source order, without docstrings
Closure = dict[str, list[ast.stmt]]


def without_docstrings(tree: ast.Module) -> ast.Module:
    """``tree`` without the docstrings of the module, its classes and functions, nor any other
    bare string in their bodies (an attribute's docstring): statements that do nothing. In place.
    """
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            body = [s for s in node.body if not _is_bare_string(s)]
            node.body = body or ([] if isinstance(node, ast.Module) else [ast.Pass()])
    return tree


def _is_bare_string(statement: ast.stmt) -> bool:
    return (
        isinstance(statement, ast.Expr)
        and isinstance(statement.value, ast.Constant)
        and isinstance(statement.value.value, str)
    )


def bound_names(statement: ast.stmt) -> set[str]:
    """The module-level names a top-level statement binds (not those local to its functions)."""
    names: set[str] = set()
    pending: list[ast.AST] = [statement]
    while pending:
        node = pending.pop()
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            names.add(node.name)
            continue
        if isinstance(node, _OWN_SCOPES):
            continue
        if isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store | ast.Del):
            names.add(node.id)
        elif isinstance(node, ast.alias) and node.name != "*":
            names.add(node.asname or node.name.split(".")[0])
        elif isinstance(node, ast.ExceptHandler) and node.name:
            names.add(node.name)
        pending.extend(ast.iter_child_nodes(node))
    return names


@dataclass
class _Module:
    """One module's top-level statements (an import of several names split into one per name)."""

    name: str
    is_package: bool
    statements: list[ast.stmt]
    binders: dict[str, list[int]] = field(default_factory=dict)  # name -> statements binding it
    on_import: list[int] = field(default_factory=list)  # statements binding no name
    directives: list[int] = field(default_factory=list)  # ``from __future__ import``

    def __post_init__(self) -> None:
        for index, statement in enumerate(self.statements):
            if _is_directive(statement):
                self.directives.append(index)
                continue
            names = bound_names(statement)
            for name in names:
                self.binders.setdefault(name, []).append(index)
            if not names:
                self.on_import.append(index)

    def absolute(self, node: ast.ImportFrom) -> str:
        """The module a ``from ... import`` names, relative imports resolved."""
        if not node.level:
            return node.module or ""
        package = self.name if self.is_package else self.name.rpartition(".")[0]
        parts = package.split(".")
        base = parts[: len(parts) - node.level + 1]
        return ".".join([*base, node.module] if node.module else base)


def _is_directive(statement: ast.stmt) -> bool:
    """A ``from __future__ import``: how the compiler reads its module, not a name."""
    return isinstance(statement, ast.ImportFrom) and statement.module == "__future__"


def _split_imports(body: list[ast.stmt]) -> list[ast.stmt]:
    """``body`` with ``from M import a, b`` as ``from M import a`` and ``from M import b``."""
    split: list[ast.stmt] = []
    for statement in body:
        if isinstance(statement, ast.Import | ast.ImportFrom) and len(statement.names) > 1:
            for alias in statement.names:
                if isinstance(statement, ast.Import):
                    one: ast.stmt = ast.Import(names=[alias])
                else:
                    one = ast.ImportFrom(statement.module, [alias], statement.level)
                split.append(ast.copy_location(one, statement))
        else:
            split.append(statement)
    return split


def _import_time_nodes(statement: ast.stmt) -> Iterator[ast.AST]:
    """The nodes of a top-level statement that run on import (not the bodies of functions)."""
    pending: list[ast.AST] = [statement]
    while pending:
        node = pending.pop()
        yield node
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            pending.extend([*node.decorator_list, node.args])
            if node.returns is not None:
                pending.append(node.returns)
        else:
            pending.extend(ast.iter_child_nodes(node))


class _Walk:
    """The closure being collected: statements counted, modules imported, work to do."""

    def __init__(self, package_dir: Path) -> None:
        self.package_dir = package_dir
        self.package = package_dir.name
        self.modules: dict[str, _Module | None] = {}
        self.counted: dict[str, set[int]] = {}
        self.imported: set[str] = set()
        self.pending: list[tuple[str, int]] = []

    def module(self, name: str) -> _Module | None:
        """The package's module ``name``, parsed (None: no such module in the package)."""
        if name not in self.modules:
            self.modules[name] = self._load(name)
        return self.modules[name]

    def _load(self, name: str) -> _Module | None:
        first, *parts = name.split(".")
        if first != self.package:
            return None
        base = self.package_dir.joinpath(*parts)
        candidates = [base / "__init__.py"] + ([base.with_suffix(".py")] if parts else [])
        for path in candidates:
            if path.is_file():
                tree = without_docstrings(ast.parse(path.read_text(), filename=str(path)))
                is_package = path.name == "__init__.py"
                return _Module(name, is_package, _split_imports(tree.body))
        return None

    def imports(
        self, module: _Module, nodes: Iterable[ast.AST]
    ) -> Iterator[tuple[str, str | None]]:
        """(module, name) of every import of the package among ``nodes``; name None: all of it."""
        for node in nodes:
            if isinstance(node, ast.Import):
                for alias in node.names:
                    if self.module(alias.name) is not None:
                        yield alias.name, None
            elif isinstance(node, ast.ImportFrom) and self.module(module.absolute(node)):
                target = module.absolute(node)
                for alias in node.names:
                    yield target, (None if alias.name == "*" else alias.name)

    def on_import(self, name: str) -> None:
        """Module ``name`` is imported: its packages' and its own import-time effects count."""
        module = self.module(name)
        if module is None or name in self.imported:
            return
        self.imported.add(name)
        parent = name.rpartition(".")[0]
        if parent:
            self.on_import(parent)
        for index in module.on_import:
            self.count(name, index)
        for statement in module.statements:
            for target, attribute in self.imports(module, _import_time_nodes(statement)):
                self.on_import(target)
                if attribute is not None:
                    self.on_import(f"{target}.{attribute}")  # a submodule, if it is one

    def need(self, name: str, attribute: str | None) -> None:
        """The statements behind ``from name import attribute`` (None: all of module ``name``)."""
        module = self.module(name)
        if module is None:
            return
        self.on_import(name)
        if attribute is not None and attribute in module.binders:
            indices: Iterable[int] = module.binders[attribute]
        elif attribute is not None and self.module(f"{name}.{attribute}") is not None:
            self.need(f"{name}.{attribute}", None)
            return
        else:  # all of it, or a name bound where we cannot see it: all of it too
            indices = range(len(module.statements))
        for index in indices:
            self.count(name, index)

    def count(self, name: str, index: int) -> None:
        counted = self.counted.setdefault(name, set())
        if not counted:  # the compiler directives of a module hold for every statement of it
            module = self.module(name)
            assert module is not None
            counted.update(module.directives)
        if index not in counted:
            counted.add(index)
            self.pending.append((name, index))

    def follow(self, name: str, index: int) -> None:
        """What a counted statement needs."""
        module = self.module(name)
        assert module is not None
        statement = module.statements[index]
        nodes = list(ast.walk(statement))
        mentioned = {node.id for node in nodes if isinstance(node, ast.Name)}
        if mentioned & DYNAMIC_LOOKUPS:
            self.need(name, None)
        for mention in mentioned:
            for binder in module.binders.get(mention, ()):
                self.count(name, binder)
        for target, attribute in self.imports(module, nodes):
            self.need(target, attribute)
        for node in nodes:  # a module named in a string (an import by name)
            if isinstance(node, ast.Constant) and isinstance(node.value, str):
                if node.value.split(".")[0] == self.package and self.module(node.value):
                    self.need(node.value, None)

    def run(self, roots: Iterable[str]) -> Closure:
        for root in roots:
            if self.module(root) is None:
                raise ValueError(f"{root!r} is not a module under {self.package_dir}")
            self.need(root, None)
        while self.pending:
            self.follow(*self.pending.pop())
        closure: Closure = {}
        for name in sorted(self.counted):
            module = self.module(name)
            assert module is not None
            closure[name] = [module.statements[i] for i in sorted(self.counted[name])]
        return closure


def code_closure(roots: Iterable[str], package_dir: Path) -> Closure:
    """The top-level statements of the package in ``package_dir`` that ``roots`` can execute.

    Args:
        roots: dotted names of modules of the package (``omnislam.datasets.synthetic.writer``).
        package_dir: the package's source folder; its name is the package's (``.../omnislam``).

    Returns:
        module name -> its statements in the closure, in source order (modules with none left
        out), each without docstrings; a top-level ``from M import a, b`` counts as one
        statement per name.

    Raises:
        ValueError: a root that is not a module of the package.
    """
    return _Walk(package_dir).run(roots)


def code_digest(closure: Closure) -> str:
    """SHA-256 (hex) of a closure: each module's name and its statements' syntax trees."""
    digest = hashlib.sha256()
    for name in sorted(closure):
        digest.update(f"{name}\n".encode())
        for statement in closure[name]:
            digest.update(f"{ast.dump(statement, annotate_fields=False)}\n".encode())
    return digest.hexdigest()


def closure_names(closure: Closure) -> dict[str, list[str]]:
    """What a closure holds, for people: module -> the names its statements bind (sorted;
    ``ON_IMPORT`` for statements that bind none, compiler directives left out)."""
    return {
        name: sorted(
            {n for s in statements if not _is_directive(s) for n in bound_names(s) or {ON_IMPORT}}
        )
        for name, statements in closure.items()
    }
