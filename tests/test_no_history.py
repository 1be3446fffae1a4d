"""The project speaks of the software only: no development history in code, tests or docs.

Comments, docstrings, the benchmarks and the documentation say what the software does, why, what
was measured and the command that reproduces it; they do not narrate how the project got there.
The scan flags the marks of such narration: numbered work periods (the word for a sitting
followed by its number), issue numbers of our own (the word "issue" followed by a number, a
number in brackets after a hash, the possessive of "issue" after "the"), and dates of work
(ISO dates, or a day, a month and a year). URLs are left out before the scan: another project's
issue, cited by its address (github.com/OWNER/REPO/issues/N), is a reference, not our history.
CHANGELOG.md is the one place for history, and so is a docs/changelog.md that only includes it.

The patterns are assembled from pieces below, so that this file, which the scan also reads, holds
none of them literally.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: folders scanned whole, and single files scanned when present
FOLDERS = ("omnislam", "tests", "benchmarks", "docs")
FILES = ("README.md", "mkdocs.yml")
#: the kinds of text file in those folders
SUFFIXES = frozenset({".py", ".md", ".yaml", ".yml", ".toml", ".txt", ".cfg", ".html", ".sh"})
#: where the history is written down on purpose
CHANGELOG = "CHANGELOG" + ".md"

_MONTH = "(?:jan|feb|mar|apr|may|jun|jul|aug|sep|oct|nov|dec)[a-z]*"
_YEAR = "20" + r"\d{2}"
#: name -> pattern of one mark of history (case-insensitive)
PATTERNS = {
    "numbered work period": re.compile(r"\bsess" + r"ions? \d", re.IGNORECASE),
    "issue number": re.compile(r"\biss" + r"ues? #?\d", re.IGNORECASE),
    "issue number in brackets": re.compile(r"\(" + "#" + r"\d+\)"),
    "an issue's goal": re.compile(r"\bthe iss" + r"ue's\b", re.IGNORECASE),
    "ISO date": re.compile(r"\b" + _YEAR + r"-[01]\d-[0-3]\d\b"),
    "day month year": re.compile(r"\b\d{1,2} " + _MONTH + " " + _YEAR + r"\b", re.IGNORECASE),
}
#: addresses, left out of the scan (another project's issue is cited by its address)
URL = re.compile(r"https?://\S+")


def history_marks(text: str, where: str) -> list[str]:
    """``where:line: name: 'match'`` for every mark of development history in ``text``."""
    found = []
    for number, line in enumerate(text.splitlines(), start=1):
        line = URL.sub("", line)
        for name, pattern in PATTERNS.items():
            found += [f"{where}:{number}: {name}: {m.group(0)!r}" for m in pattern.finditer(line)]
    return found


def only_includes_the_changelog(text: str) -> bool:
    """Whether a page's every non-blank line is a heading or names the changelog (an include)."""
    lines = [line for line in text.splitlines() if line.strip()]
    return bool(lines) and all(line.startswith("#") or CHANGELOG in line for line in lines)


def scanned_files(root: Path) -> list[Path]:
    """The text files of ``FOLDERS`` and ``FILES`` under ``root``, the changelog left out."""
    paths = [root / name for name in FILES if (root / name).is_file()]
    for folder in FOLDERS:
        paths += [path for path in sorted((root / folder).rglob("*"))
                  if path.is_file() and path.suffix in SUFFIXES
                  and "__pycache__" not in path.parts]
    changelog_page = root / "docs" / CHANGELOG.lower()
    return [path for path in paths
            if path.name != CHANGELOG
            and not (path == changelog_page and only_includes_the_changelog(path.read_text()))]


def test_no_development_history_in_code_tests_benchmarks_or_docs():
    found = []
    for path in scanned_files(ROOT):
        found += history_marks(path.read_text(encoding="utf-8"), path.relative_to(ROOT).as_posix())
    assert found == []


def test_the_scan_flags_each_kind_of_history_and_spares_other_projects_issue_urls():
    planted = [
        "# measured in sess" + "ion 21",
        "fixed in sess" + "ions 13-15",
        "the outlier gate (iss" + "ue 14)",
        "see iss" + "ues 14 and 16",
        "FastSLAM on real logs (" + "#" + "21)",
        "the iss" + "ue's goal",
        "measured on " + "20" + "26-12-05",
        "measured on 5 Dec" + "ember 20" + "26",
    ]
    found = history_marks("\n".join(planted), "m.py")
    assert [mark.split(":")[1] for mark in found] == [str(i) for i in range(1, len(planted) + 1)]
    innocent = "\n".join([
        "cf. https://github.com/borglab/gtsam/iss" + "ues/1890 and borglab/gtsam#2474",
        "session = FixedLagSession(config)  # the iSAM2 session of a run",
        "palette = {'ekfslam': '#123456'}; latex_escape('#1')",
        "iSAM2 updates 2026 frames; seeds 0-2",
    ])
    assert history_marks(innocent, "m.py") == []


def test_a_planted_file_is_found_and_the_changelog_is_left_out(tmp_path):
    (tmp_path / "omnislam").mkdir()
    (tmp_path / "omnislam" / "module.py").write_text('"""Added in sess' + 'ion 7."""\n')
    (tmp_path / CHANGELOG).write_text("## [0.1.0] - " + "20" + "26-11-01\n")
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / CHANGELOG.lower()).write_text('--8<-- "' + CHANGELOG + '"\n')
    files = scanned_files(tmp_path)
    assert [path.relative_to(tmp_path).as_posix() for path in files] == ["omnislam/module.py"]
    marks = history_marks(files[0].read_text(), "omnislam/module.py")
    assert marks == ["omnislam/module.py:1: numbered work period: " + repr("sess" + "ion 7")]
