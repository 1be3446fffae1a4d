"""The documentation site cannot go stale: the API reference covers every public module, and
every ``omnislam`` command the pages show is one the command line knows, flags included.

The site's strict build (``make docs``, part of ``make test``) checks the links and the nav.
"""

import argparse
import importlib.util
import pkgutil
import re
import shlex
import sys
from pathlib import Path

import pytest

from omnislam.cli import build_parser

REPO = Path(__file__).resolve().parents[1]
DOCS = REPO / "docs"
#: the pages whose commands are checked: the guides, tutorials and concepts of the site
PAGES = sorted([*DOCS.glob("*.md"), *DOCS.glob("tutorials/*.md")])
#: a fenced block of shell commands: its language and body
FENCED = re.compile(r"^```(?P<lang>[a-z]*)\n(?P<body>.*?)^```", re.M | re.S)
SHELL = {"sh", "bash", "shell", "console"}
INLINE = re.compile(r"(?<!`)`(?P<code>[^`\n]+)`(?!`)")
#: ``omnislam`` as a command: alone, as a path's last part or after ``python -m``
COMMAND = re.compile(r"(?:^|(?<=[\s/]))omnislam(?=\s)")


def _load_hook(name: str):
    """A hook of the site (docs/hooks), imported as MkDocs imports it: from its file."""
    module_name = f"docs_hooks_{name}"
    spec = importlib.util.spec_from_file_location(module_name, DOCS / "hooks" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[module_name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


reference = _load_hook("reference")
repository_links = _load_hook("repository_links")


# -- the API reference ------------------------------------------------------------------------
def walk_public(path: Path, prefix: str) -> set[str]:
    """The public modules below a package folder, found with pkgutil (an independent oracle)."""
    found = set()
    for info in pkgutil.iter_modules([str(path)]):
        if info.name.startswith("_"):
            continue
        found.add(f"{prefix}.{info.name}")
        if info.ispkg:
            found |= walk_public(path / info.name, f"{prefix}.{info.name}")
    return found


def nav_pages(entries: list) -> list[str]:
    pages = []
    for entry in entries:
        if isinstance(entry, str):
            pages.append(entry)
        else:
            for value in entry.values():
                pages.extend(nav_pages(value) if isinstance(value, list) else [value])
    return pages


def test_every_public_module_has_a_reference_page_in_the_nav():
    modules = reference.public_modules(REPO)
    expected = walk_public(REPO / "omnislam", "omnislam") | {"omnislam"}
    assert {m.name for m in modules} == expected
    assert len(expected) > 150
    pages = nav_pages(reference.nav_section(modules))
    assert len(pages) == len(set(pages)) == len(modules)
    for module in modules:
        assert module.page in pages
        if module.parts:
            assert f"::: {module.name}\n" in reference.page_markdown(module)
    index = reference.index_markdown(modules)
    assert all(f"[`{m.name}`]" in index for m in modules if m.parts)


def test_the_reference_skips_private_modules_and_nests_packages(tmp_path):
    root = tmp_path / "pkg"
    for relative in ("__init__.py", "_private.py", "a.py", "sub/__init__.py", "sub/b.py",
                     "sub/_hidden/__init__.py", "sub/_hidden/c.py", "scripts/d.py"):
        (root / relative).parent.mkdir(parents=True, exist_ok=True)
        (root / relative).write_text('"""Summary line.\n\nMore."""\n')
    modules = reference.public_modules(tmp_path, "pkg")
    assert [m.name for m in modules] == ["pkg", "pkg.a", "pkg.sub", "pkg.sub.b"]
    assert [m.page for m in modules] == [
        "reference/index.md", "reference/a.md", "reference/sub/index.md", "reference/sub/b.md",
    ]
    assert modules[1].summary == "Summary line."
    assert reference.nav_section(modules) == [
        "reference/index.md",
        {"a": "reference/a.md"},
        {"sub": ["reference/sub/index.md", {"b": "reference/sub/b.md"}]},
    ]


# -- links to repository files outside docs/ ---------------------------------------------------
@pytest.fixture
def repo(tmp_path):
    for relative in ("docs/results/index.md", "docs/metrics.md", "benchmarks/README.md",
                     "CHANGELOG.md"):
        (tmp_path / relative).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / relative).write_text("# x\n")
    return tmp_path


def test_links_leaving_docs_become_repository_paths_or_addresses(repo):
    page_dir = repo / "docs" / "results"
    text = (
        "See [the scripts](../../benchmarks/README.md#speed), [`benchmarks/README.md`]"
        "(../../benchmarks/README.md), [metrics](../metrics.md#ate) and [gone](../../nope.md).\n"
        "```sh\ncat [x](../../benchmarks/README.md)\n```\n"
    )
    plain = repository_links.LinkRebaser(repo, repo / "docs", page_dir, page_dir, None)
    assert plain.rewrite(text) == (
        "See the scripts (`benchmarks/README.md`), `benchmarks/README.md`, [metrics]"
        "(../metrics.md#ate) and [gone](../../nope.md).\n"
        "```sh\ncat [x](../../benchmarks/README.md)\n```\n"
    )
    web = repository_links.LinkRebaser(repo, repo / "docs", page_dir, page_dir, "https://h/o/r/")
    assert "[the scripts](https://h/o/r/blob/HEAD/benchmarks/README.md#speed)" in web.rewrite(text)


def test_the_changelog_links_are_rebased_from_the_repository_root(repo):
    docs = repo / "docs"
    rebaser = repository_links.LinkRebaser(repo, docs, repo, docs, None)
    text = "[results](docs/results/index.md), ![p](docs/metrics.md), [b](benchmarks/README.md)"
    assert rebaser.rewrite(text) == (
        "[results](results/index.md), ![p](metrics.md), b (`benchmarks/README.md`)"
    )


# -- commands shown on the pages ----------------------------------------------------------------
def shown_commands(markdown: str) -> list[str]:
    """Every ``omnislam ...`` command of the shell blocks and inline code spans of a page."""
    lines = []
    for block in FENCED.finditer(markdown):
        if block["lang"] in SHELL:
            lines.extend(block["body"].replace("\\\n", " ").splitlines())
    # inline code is a command only when it starts as one (`a valid omnislam folder` is output)
    lines.extend(
        m["code"] for m in INLINE.finditer(FENCED.sub("", markdown))
        if re.match(r"(\S*/)?omnislam\s|python -m omnislam\s", m["code"])
    )
    commands = []
    for line in lines:
        for part in re.split(r"&&|\|\||;|\|", line):
            match = COMMAND.search(part)
            if match:
                commands.append(part[match.end():].split("#")[0].strip())
    return [c for c in commands if c]


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def command_problems(command: str, parser: argparse.ArgumentParser) -> list[str]:
    """What the command line would not know in ``omnislam COMMAND``: subcommands and flags."""
    problems = []
    for token in shlex.split(command):
        token = token.strip("[]()|.,")
        sub = _subparsers(parser)
        if token.startswith("-"):
            flag = token.split("=")[0]
            if flag not in parser._option_string_actions:
                problems.append(f"{flag} (in 'omnislam {command}')")
        elif sub and token.isupper():
            break  # a placeholder (`omnislam COMMAND --help`) stands for any command
        elif sub and token in sub:
            parser = sub[token]
        elif sub:
            problems.append(f"command {token!r} (in 'omnislam {command}')")
            break
    return problems


def test_the_checker_sees_unknown_commands_and_flags():
    parser = build_parser()
    page = (
        "```sh\nomnislam run mrclam6-r1 --estimator ekfslam --out r \\\n  --no-such-flag\n```\n"
        "and `omnislam frobnicate --x`, `.venv/bin/omnislam dataset synth demo --seed 1 --out d`"
        "\n```text\nomnislam run: not a command (output)\n```\n"
    )
    commands = shown_commands(page)
    assert commands == [
        "run mrclam6-r1 --estimator ekfslam --out r    --no-such-flag",
        "frobnicate --x",
        "dataset synth demo --seed 1 --out d",
    ]
    assert [len(command_problems(c, parser)) for c in commands] == [1, 1, 0]


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(DOCS)))
def test_every_command_a_page_shows_is_known_to_the_command_line(page):
    parser = build_parser()
    problems = [p for c in shown_commands(page.read_text()) for p in command_problems(c, parser)]
    assert problems == []
