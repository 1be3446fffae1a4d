"""``docs/options_tables.py`` keeps the estimator pages' option tables equal to the code."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

from omnislam.estimators import BUILTIN_ESTIMATORS, estimator_defaults
from omnislam.options import describe_options, main_options

REPO = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location(
    "options_tables", REPO / "docs" / "options_tables.py"
)
options_tables = importlib.util.module_from_spec(_spec)
sys.modules["options_tables"] = options_tables  # dataclasses look their module up
_spec.loader.exec_module(options_tables)

#: the estimator page that holds each registered estimator's option tables
PAGES = {
    "deadreckoning": "deadreckoning.md",
    "graphslam": "graphslam.md",
    "fastslam1": "fastslam.md",
    "ukf": "ukf.md",
    "ekfslam": "ekfslam.md",
    "harness": "index.md",
}


def _page(name: str) -> str:
    block = f"<!-- options:{name}:begin -->\nstale\n<!-- options:{name}:end -->\n"
    return f"# {name}\n\nintro\n\n{block}"


def _option_rows(block: str) -> list[list[str]]:
    """The cells of every option row (four cells: key, default, kind, meaning) of a block."""
    rows = []
    for line in block.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split(" | ")]
        if line.startswith("| `") and len(cells) == 4:
            rows.append([cells[0].strip("`"), *cells[1:]])
    return rows


def test_the_pages_tables_are_the_codes():
    """Fails when a default, a kind or an ``Attributes:`` entry changed and the pages were not
    regenerated (``python docs/options_tables.py``)."""
    assert options_tables.main(["--docs", str(REPO / "docs"), "--check"]) == 0


def test_each_estimator_page_holds_its_tables():
    for name, page in PAGES.items():
        text = (REPO / "docs" / "estimators" / page).read_text()
        assert f"<!-- options:{name}:begin -->" in text, page


@pytest.mark.parametrize(
    "name", [n for n in BUILTIN_ESTIMATORS if estimator_defaults(n)[0] is not None]
)
def test_every_option_is_listed_once_with_its_default_main_ones_first(name):
    block = options_tables.block_text(name)
    config, _ = estimator_defaults(name)
    options = describe_options(config)
    rows = _option_rows(block)
    keys = [row[0] for row in rows]
    assert sorted(keys) == sorted(o.key for o in options)  # each once
    defaults = {row[0]: row[1] for row in rows}
    assert all(defaults[o.key] == f"`{o.default}`" for o in options)
    main = list(main_options(config))
    assert main and keys[: len(main)] == main
    tops = [key.split(".")[0] for key in keys[len(main) :]]
    if "experimental" in tops:
        assert set(tops[tops.index("experimental") :]) == {"experimental"}


def test_a_preset_lists_what_it_changes():
    differences = dict(options_tables.preset_differences("fastslam1"))
    assert differences["fastslam1"] == []
    assert differences["fastslam2"] == ["variant=fastslam2", "particles.n_particles=20"]
    assert options_tables.preset_differences("ekfslam") == []


def test_check_finds_a_stale_page_and_a_rewrite_fixes_it(tmp_path, capsys):
    page = tmp_path / "page.md"
    page.write_text(_page("ekfslam"))
    assert options_tables.main(["--docs", str(tmp_path), "--check"]) == 1
    assert page.read_text() == _page("ekfslam")  # --check writes nothing
    assert options_tables.main(["--docs", str(tmp_path)]) == 0
    text = page.read_text()
    assert text.startswith("# ekfslam\n\nintro\n\n<!-- options:ekfslam:begin -->\n### Main")
    assert text.endswith("|\n<!-- options:ekfslam:end -->\n") and "stale" not in text
    assert options_tables.main(["--docs", str(tmp_path), "--check"]) == 0
    assert capsys.readouterr().out.count("differ from the code") == 1


def test_a_wrong_name_or_an_unclosed_block_exits_2(tmp_path, capsys):
    page = tmp_path / "page.md"
    page.write_text(_page("nosuch"))
    assert options_tables.main(["--docs", str(tmp_path), "--check"]) == 2
    page.write_text("<!-- options:ukf:begin -->\n")
    assert options_tables.main(["--docs", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"options_tables: {page}: options:nosuch names no registered estimator",
        f"options_tables: {page}: options:ukf:begin has no end marker",
    ]


def test_a_cell_stays_one_cell():
    assert options_tables.cell("a | b\n  c <x> <= 3") == "a \\| b c &lt;x> <= 3"


def test_a_section_opens_with_what_its_configuration_says_of_it():
    """The motion noise's alphas have no reason of their own (they differ per estimator): the
    section's entry in the configuration's docstring gives it."""
    from omnislam.fastslam.config import FastSLAMConfig
    from omnislam.options import attribute_docs

    block = options_tables.block_text("fastslam1")
    about = options_tables.cell(attribute_docs(FastSLAMConfig)["motion_noise"])
    assert "twice the simulator's" in about
    assert f"### Section `motion_noise`\n\n`motion_noise`: {about}\n\n| key |" in block
