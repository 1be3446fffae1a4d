"""The name-level code closure: what a root can execute counts, nothing else does; in doubt,
the whole module."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from omnislam.harness.code_closure import ON_IMPORT, closure_names, code_closure, code_digest

#: a small package: the root uses ``used`` of ``lib`` (lazily) and ``Thing`` through ``api``
PACKAGE = {
    "__init__.py": "",
    "root.py": '''
        """The root."""
        from pkg.api import Thing


        def run(x):
            from pkg.lib import used

            return used(x) + Thing().size
    ''',
    "lib.py": '''
        from pkg.errors import LibError, OtherError

        SCALE = 2.0
        """How much bigger."""
        TABLE = [1, 2]
        TABLE.append(3)


        def _helper(x):
            """Twice x."""
            return SCALE * x


        def used(x):
            """Used by the root."""
            if x < 0:
                raise LibError(x)
            return _helper(x)


        def unused(x):
            raise OtherError(x)
    ''',
    "errors.py": """
        class LibError(Exception):
            pass


        class OtherError(Exception):
            pass
    """,
    "api/__init__.py": "from pkg.api.thing import Thing\n",
    "api/thing.py": """
        class Thing:
            size = 3


        class Other:
            size = 4
    """,
}


def write_package(root: Path, files: dict[str, str]) -> Path:
    for name, text in files.items():
        path = root / "pkg" / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(text).lstrip("\n"))
    return root / "pkg"


def digest(tmp_path: Path, files: dict[str, str], edit: tuple[str, str, str] | None = None) -> str:
    """The closure's digest of ``pkg.root`` with one text replaced: (file, old, new)."""
    files = dict(files)
    if edit is not None:
        name, old, new = edit
        assert old in files[name]
        files[name] = files[name].replace(old, new)
    folder = tmp_path / ("edited" if edit is not None else "original")
    return code_digest(code_closure(["pkg.root"], write_package(folder, files)))


def test_the_closure_holds_the_names_the_root_reaches_and_what_runs_on_import(tmp_path):
    closure = code_closure(["pkg.root"], write_package(tmp_path, PACKAGE))
    assert closure_names(closure) == {
        "pkg.api": ["Thing"],
        "pkg.api.thing": ["Thing"],
        "pkg.errors": ["LibError"],
        "pkg.lib": [ON_IMPORT, "LibError", "SCALE", "TABLE", "_helper", "used"],
        "pkg.root": ["Thing", "run"],
    }


@pytest.mark.parametrize(
    ("edit", "changes"),
    [
        (("lib.py", "SCALE * x", "SCALE * x + 1"), True),  # a helper of a used function
        (("lib.py", "SCALE = 2.0", "SCALE = 3.0"), True),  # a constant it reads
        (("lib.py", "TABLE.append(3)", "TABLE.append(4)"), True),  # runs on import
        (("api/thing.py", "size = 3", "size = 5"), True),  # through a package's re-export
        (("root.py", "Thing().size", "Thing().size * 2"), True),  # the root itself
        (("lib.py", '"""Twice x."""', '"""Two times x."""'), False),  # a docstring
        (("lib.py", "return _helper(x)", "return _helper(x)  # why"), False),  # a comment
        (("lib.py", "much bigger", "much larger"), False),  # an attribute's docstring
        (("lib.py", "raise OtherError(x)", "raise OtherError(-x)"), False),  # never called
        (("api/thing.py", "size = 4", "size = 6"), False),  # another class of the module
        (("errors.py", "OtherError(Exception)", "OtherError(KeyError)"), False),
    ],
)
def test_only_an_edit_to_code_the_root_reaches_changes_the_digest(tmp_path, edit, changes):
    assert (digest(tmp_path, PACKAGE, edit) != digest(tmp_path, PACKAGE)) == changes


@pytest.mark.parametrize(
    "use",
    [
        "import pkg.lib\n\n\ndef run(x):\n    return pkg.lib.used(x)\n",  # a module object
        "from pkg import lib\n\n\ndef run(x):\n    return lib.used(x)\n",  # a submodule by name
        "import importlib\n\n\ndef run(x):\n    return importlib.import_module('pkg.lib')\n",
        "from pkg.lazy import used\n",  # a name bound where it cannot be seen: all of the module
        "from pkg.lib import *\n",
    ],
)
def test_in_doubt_the_whole_module_counts(tmp_path, use):
    files = {
        **PACKAGE,
        "root.py": use,
        "lazy.py": "import importlib\n\n\ndef __getattr__(name):\n"
        "    return getattr(importlib.import_module('pkg.lib'), name)\n",
    }
    edit = ("lib.py", "raise OtherError(x)", "raise OtherError(-x)")
    assert digest(tmp_path, files, edit) != digest(tmp_path, files)


def test_relative_imports_are_followed(tmp_path):
    files = {**PACKAGE, "api/__init__.py": "from .thing import Thing\n"}
    edit = ("api/thing.py", "size = 3", "size = 5")
    assert digest(tmp_path, files, edit) != digest(tmp_path, files)


def test_a_root_outside_the_package_is_an_error(tmp_path):
    with pytest.raises(ValueError, match=r"'pkg\.nowhere' is not a module"):
        code_closure(["pkg.nowhere"], write_package(tmp_path, PACKAGE))
