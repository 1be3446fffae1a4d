"""The tutorials' commands, run as a reader runs them: docs/tutorials/own-estimator.md and
docs/tutorials/external-results.md.

Each page's fenced ``sh`` blocks are run line by line in a fresh folder, in order, with each
``yaml`` block whose first line is ``# FILE`` written to FILE first; ``omnislam`` is this
Python's ``-m omnislam``. Every command must succeed. The lines that install the example plugin
or run its own tests are left to ``make test`` (which installs it and runs them); the own-estimator
page needs the plugin installed.
"""

from __future__ import annotations

import csv
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]
TUTORIALS = REPO_ROOT / "docs" / "tutorials"
BLOCK = re.compile(r"^```(\w+)\n(.*?)^```", re.MULTILINE | re.DOTALL)
#: commands of the pages that this test leaves to ``make test``
LEFT_TO_MAKE = (
    "pip install -e examples/estimator_plugin",
    "python -m pytest examples/estimator_plugin/tests",
)


def run_page(page: Path, folder: Path) -> list[str]:
    """Run the page's blocks in ``folder``; returns the commands run."""
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(REPO_ROOT), os.environ.get("PYTHONPATH", "")]),
        "OMNISLAM_PROGRESS": "0",
    }
    ran = []
    for kind, body in BLOCK.findall(page.read_text()):
        first = body.partition("\n")[0]
        if kind == "yaml" and first.startswith("# "):
            (folder / first[2:].strip()).write_text(body)
        if kind != "sh":
            continue
        for line in filter(None, (raw.strip() for raw in body.splitlines())):
            if line in LEFT_TO_MAKE:
                continue
            assert line.startswith("omnislam "), f"{page.name}: cannot run {line!r}"
            argv = [sys.executable, "-m", "omnislam", *shlex.split(line)[1:]]
            done = subprocess.run(
                argv, cwd=folder, env=env, capture_output=True, text=True, timeout=1800
            )
            assert done.returncode == 0, f"{page.name}: {line}\n{done.stderr}"
            ran.append(line)
    return ran


def _verdict(report: Path) -> list[dict[str, str]]:
    """The verdict table's rows: one per method family of each dataset and input."""
    with (report / "tables" / "verdict.csv").open() as f:
        return list(csv.DictReader(f))


@pytest.mark.slow
def test_own_estimator(shared_data: Path, tmp_path: Path):
    pytest.importorskip("ekf_localiser", reason="install examples/estimator_plugin (make test)")
    ran = run_page(TUTORIALS / "own-estimator.md", tmp_path)
    assert len(ran) == 5
    assert _verdict(tmp_path / "reports" / "plugin-grid")[0]["best"].startswith("ekf-")


@pytest.mark.slow
def test_external_results(shared_data: Path, tmp_path: Path):
    ran = run_page(TUTORIALS / "external-results.md", tmp_path)
    assert len(ran) == 3
    verdict = _verdict(tmp_path / "reports" / "external")
    assert {row["best"] for row in verdict} == {"ekfslam", "mysys"}
    assert all(float(row["behind the best [m]"]) == 0.0 for row in verdict)
