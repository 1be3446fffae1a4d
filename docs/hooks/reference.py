"""MkDocs hook: the API reference, one page per public module, written at build time.

Every module and package under ``omnislam/`` whose dotted name has no part starting with ``_``
gets a page ``reference/<path>.md`` (a package: ``reference/<path>/index.md``) holding the
mkdocstrings directive ``::: omnislam.x.y``, and the nav entry ``API reference`` of mkdocs.yml
becomes a section with those pages, nested like the packages. The list comes from the source
tree at each build, so a module added or removed changes the reference without an edit here.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path
from typing import Any

PACKAGE = "omnislam"
SECTION = "reference"
NAV_TITLE = "API reference"


@dataclass(frozen=True, slots=True)
class Module:
    """One public module of the package.

    Attributes:
        name: dotted name, e.g. ``omnislam.core.se``.
        is_package: True for a package (its ``__init__.py``).
        summary: first line of the module's docstring ('' when it has none).
    """

    name: str
    is_package: bool
    summary: str

    @property
    def parts(self) -> tuple[str, ...]:
        """The dotted name's parts below the top package (empty for the top package)."""
        return tuple(self.name.split(".")[1:])

    @property
    def page(self) -> str:
        """The page's path inside docs/, e.g. ``reference/core/se.md``."""
        if self.is_package:
            return "/".join((SECTION, *self.parts, "index.md"))
        return "/".join((SECTION, *self.parts)) + ".md"


def _summary(path: Path) -> str:
    docstring = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
    return docstring.strip().split("\n\n")[0].replace("\n", " ")


def public_modules(source_root: Path, package: str = PACKAGE) -> list[Module]:
    """Every public module and package under ``source_root/package``, in dotted-name order.

    Args:
        source_root: folder holding the package (the repository root).
        package: the top package's name.

    Returns:
        One ``Module`` per ``.py`` file and package whose dotted name has no part starting
        with ``_`` (``__init__.py`` stands for its package), the top package first.
    """
    modules = []
    for path in sorted((source_root / package).rglob("*.py")):
        parts = path.relative_to(source_root).with_suffix("").parts
        is_package = parts[-1] == "__init__"
        if is_package:
            parts = parts[:-1]
        if any(part.startswith("_") for part in parts):
            continue
        if not all((source_root / Path(*parts[:i]) / "__init__.py").is_file()
                   for i in range(1, len(parts))):
            continue  # a script in a folder that is not a package
        modules.append(Module(".".join(parts), is_package, _summary(path)))
    return sorted(modules, key=lambda module: module.parts)


def page_markdown(module: Module) -> str:
    """The Markdown of a module's page: its name as the title, then the directive."""
    return f"# `{module.name}`\n\n::: {module.name}\n"


def index_markdown(modules: list[Module]) -> str:
    """The reference's home page: the top package's docstring and a table of every module."""
    rows = [
        f"| [`{m.name}`]({Path(m.page).relative_to(SECTION).as_posix()}) | {m.summary} |"
        for m in modules
        if m.parts
    ]
    return "\n".join(
        [
            "# API reference",
            "",
            f"One page per public module of `{PACKAGE}`, generated from the source at each"
            " build (`docs/hooks/reference.py`); the text is the code's docstrings.",
            "",
            f"::: {PACKAGE}",
            "    options:",
            "      members: false",
            "",
            "| module | what it is |",
            "|---|---|",
            *rows,
            "",
        ]
    )


def nav_section(modules: list[Module]) -> list[Any]:
    """The nav of the reference: the index, then one section per package, nested."""
    root: list[Any] = [f"{SECTION}/index.md"]
    sections: dict[tuple[str, ...], list[Any]] = {(): root}
    for module in modules:
        if not module.parts:
            continue
        parent = sections[module.parts[:-1]]
        if module.is_package:
            children: list[Any] = [module.page]
            sections[module.parts] = children
            parent.append({module.parts[-1]: children})
        else:
            parent.append({module.parts[-1]: module.page})
    return root


def _source_root(config: Any) -> Path:
    return Path(config.config_file_path).parent


def on_config(config: Any) -> Any:
    """Replace the nav entry ``API reference`` by the section of every public module."""
    modules = public_modules(_source_root(config))
    for i, entry in enumerate(config.nav or []):
        if isinstance(entry, dict) and NAV_TITLE in entry:
            config.nav[i] = {NAV_TITLE: nav_section(modules)}
            break
    else:
        raise ValueError(f"mkdocs.yml's nav has no entry {NAV_TITLE!r} for the reference")
    return config


def on_files(files: Any, config: Any) -> Any:
    """Add the generated pages to the site's files."""
    from mkdocs.structure.files import File

    modules = public_modules(_source_root(config))
    pages = {f"{SECTION}/index.md": index_markdown(modules)}
    pages.update({m.page: page_markdown(m) for m in modules if m.parts})
    for uri, content in pages.items():
        files.append(File.generated(config, uri, content=content))
    return files
