"""The option tables of the estimator pages, generated from the configuration dataclasses::

    python docs/options_tables.py [--docs docs] [--check]

Each page under ``docs/estimators/`` marks where an estimator's options go with
``<!-- options:NAME:begin -->`` and ``<!-- options:NAME:end -->``, NAME a registered estimator
(``omnislam.estimators.ESTIMATORS``) or ``harness`` (the options the harness takes for every
estimator). The script rewrites each marked block from what ``omnislam estimators NAME --all
--json`` prints -- the configuration's defaults, its kinds and the ``Attributes:`` docstrings
(``omnislam.options.describe_options``) -- so no table is typed by hand:

* the presets (``--set preset=NAME``), each with the options it sets differently from the
  estimator's own;
* the main options (the configuration's ``MAIN_OPTIONS``);
* every other option, one table per section in the order the dataclass declares them, the
  ``experimental`` section last.

``--check`` rewrites nothing and exits 1 when a page's block is not what the code gives (for CI
and ``tests/test_docs_options.py``, after a default or a docstring changed); 2 means a page or a
marked name is wrong.
"""

from __future__ import annotations

import argparse
import re
import sys
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
MARKER = re.compile(r"<!-- options:(?P<name>[a-z0-9-]+):(?P<edge>begin|end) -->")
#: the pseudo-estimator whose block lists the options the harness takes for every estimator
HARNESS = "harness"
#: the section listed last
EXPERIMENTAL = "experimental"
HEADER = "| key | default | kind | meaning |\n|---|---|---|---|\n"


class OptionsTableError(Exception):
    """A page has unbalanced markers or marks a name that is no registered estimator."""


@dataclass(frozen=True, slots=True)
class Block:
    """One marked block of a page: the estimator it names and where its text lies."""

    name: str
    start: int  # just after the begin marker
    end: int  # at the end marker


def cell(text: str) -> str:
    """``text`` as one Markdown table cell: on one line, pipes escaped, no tag-like ``<x``."""
    flat = " ".join(str(text).split())
    return re.sub(r"<(?=[A-Za-z/])", "&lt;", flat).replace("|", "\\|")


def _row(option: dict) -> str:
    return (
        f"| `{option['key']}` | `{option['default']}` | {cell(option['kind'])} "
        f"| {cell(option['meaning'])} |\n"
    )


def _top_section(option: dict) -> str:
    return str(option["key"]).split(".", 1)[0] if option["section"] else ""


def _sections(options: list[dict]) -> dict[str, list[dict]]:
    """Top-level section -> its options, in declaration order, ``experimental`` last."""
    grouped: dict[str, list[dict]] = {}
    for option in options:
        grouped.setdefault(_top_section(option), []).append(option)
    if EXPERIMENTAL in grouped:
        grouped[EXPERIMENTAL] = grouped.pop(EXPERIMENTAL)
    return grouped


def _with_data_notes(options: list[dict]) -> list[dict]:
    """The options, with the note ``omnislam estimators`` prints on a default the factories
    take from the dataset appended where the meaning does not say so itself."""
    from omnislam.cli.estimators import FROM_THE_DATA

    out = []
    for option in options:
        note = FROM_THE_DATA.get(str(option["key"]).rsplit(".", 1)[-1])
        if note and not re.search(r"\brig\b", str(option["meaning"])):
            option = {**option, "meaning": f"{option['meaning']} {note}"}
        out.append(option)
    return out


def preset_differences(name: str) -> list[tuple[str, list[str]]]:
    """(preset, ``key=value`` of every option it sets differently from estimator ``name``'s
    starting configuration) for each preset of ``name``; empty when it has none."""
    import importlib

    from omnislam.estimators import ESTIMATORS, estimator_defaults
    from omnislam.options import describe_options

    base, presets = estimator_defaults(name)
    if not presets:
        return []
    module_name, attribute = ESTIMATORS[name].config.split(":")
    mapping = getattr(importlib.import_module(module_name), attribute)
    defaults = {o.key: o.default for o in describe_options(base)}
    out = []
    for preset in presets:
        changed = [
            f"{o.key}={o.default}"
            for o in describe_options(mapping[preset])
            if defaults.get(o.key) != o.default
        ]
        out.append((preset, changed))
    return out


def _presets_table(name: str, start: str) -> str:
    rows = preset_differences(name)
    if not rows:
        return ""
    lines = [
        f"Presets (`--set preset=NAME`; `{name}` starts from `{start}`):\n\n",
        f"| preset | what it sets differently from `{start}` |\n|---|---|\n",
    ]
    for preset, changed in rows:
        what = ", ".join(f"`{c}`" for c in changed) or "(the starting configuration)"
        lines.append(f"| `{preset}` | {cell(what)} |\n")
    return "".join(lines) + "\n"


def estimator_tables(name: str) -> str:
    """The Markdown of estimator ``name``'s block: presets, main options, then the sections."""
    from omnislam.cli.estimators import describe

    described = describe(name)
    options = _with_data_notes(list(described["options"]))  # type: ignore[arg-type]
    if not options:
        return f"`{name}` takes no options of its own.\n"
    text = _presets_table(name, str(described["preset"]))
    main_keys = list(described["main_options"])  # type: ignore[arg-type]
    main = [o for key in main_keys for o in options if o["key"] == key]
    if main:
        text += "### Main options\n\n" + HEADER + "".join(_row(o) for o in main) + "\n"
    rest = [o for o in options if o["key"] not in main_keys]
    about = _section_docs(name)
    for section, members in _sections(rest).items():
        title = f"Section `{section}`" if section else "Other top-level options"
        intro = f"`{section}`: {cell(about[section])}\n\n" if about.get(section) else ""
        text += f"### {title}\n\n{intro}" + HEADER + "".join(_row(o) for o in members) + "\n"
    return text


def _section_docs(name: str) -> dict[str, str]:
    """Section -> what the configuration's ``Attributes:`` entry says of it (its default and
    why, where the section's own fields cannot: the motion noise's alphas differ per estimator)."""
    from omnislam.estimators import estimator_defaults
    from omnislam.options import attribute_docs

    config, _ = estimator_defaults(name)
    return {} if config is None else attribute_docs(type(config))


def harness_table() -> str:
    """The Markdown of the options the harness takes for every estimator."""
    from omnislam.cli.estimators import harness_options

    lines = ["| key | takes | meaning |\n|---|---|---|\n"]
    for key, (kind, meaning) in harness_options().items():
        lines.append(f"| `{key}` | {cell(kind)} | {cell(meaning)} |\n")
    return "".join(lines)


def block_text(name: str) -> str:
    """The generated text of a block naming ``name``.

    Raises:
        OptionsTableError: ``name`` is neither ``harness`` nor a registered estimator.
    """
    from omnislam.estimators import ESTIMATORS

    if name == HARNESS:
        return harness_table()
    if name not in ESTIMATORS:
        raise OptionsTableError(f"options:{name} names no registered estimator")
    return estimator_tables(name)


def find_blocks(text: str) -> list[Block]:
    """The marked blocks of a page, in order.

    Raises:
        OptionsTableError: a begin without its end, an end without its begin, or nesting.
    """
    blocks, open_name, open_at = [], None, 0
    for match in MARKER.finditer(text):
        name, edge = match["name"], match["edge"]
        if edge == "begin" and open_name is None:
            open_name, open_at = name, match.end()
        elif edge == "end" and open_name == name:
            blocks.append(Block(name, open_at, match.start()))
            open_name = None
        else:
            raise OptionsTableError(f"unexpected marker {match[0]}")
    if open_name is not None:
        raise OptionsTableError(f"options:{open_name}:begin has no end marker")
    return blocks


def rewrite(text: str) -> str:
    """``text`` with every marked block replaced by its generated tables."""
    out, last = [], 0
    for block in find_blocks(text):
        out += [text[last : block.start], "\n", block_text(block.name).rstrip("\n"), "\n"]
        last = block.end
    return "".join(out) + text[last:]


def pages(docs: Path) -> list[Path]:
    """The Markdown pages under ``docs`` that hold at least one marked block."""
    return [p for p in sorted(docs.rglob("*.md")) if MARKER.search(p.read_text())]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--docs", default=str(REPO / "docs"), help="the pages' folder")
    parser.add_argument("--check", action="store_true", help="exit 1 if a page is stale")
    args = parser.parse_args(argv)
    stale = []
    for page in pages(Path(args.docs)):
        text = page.read_text()
        try:
            updated = rewrite(text)
        except OptionsTableError as exc:
            print(f"options_tables: {page}: {exc}", file=sys.stderr)
            return 2
        if updated != text:
            stale.append(page)
            if not args.check:
                page.write_text(updated)
    verb = "differ from the code" if args.check else "rewritten"
    for page in stale:
        print(f"options_tables: {page}: options tables {verb}")
    return 1 if args.check and stale else 0


if __name__ == "__main__":
    sys.exit(main())
