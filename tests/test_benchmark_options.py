"""The benchmarks' ``--set KEY=VALUE`` options: a malformed item is a usage error.

Every benchmark parses its option items through ``harness_cells.set_options`` (one usage line
and an error line naming the flag, exit 2, no traceback), so no script may split the items
itself; a few scripts are run to see it end to end.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
BENCHMARKS = REPO / "benchmarks"


def test_no_benchmark_splits_its_option_items_itself() -> None:
    raw = re.compile(r"""\.split\(\s*["']=["']\s*,\s*1\s*\)""")
    offenders = [
        f"{path.name}:{number}"
        for path in sorted(BENCHMARKS.glob("*.py"))
        for number, line in enumerate(path.read_text().splitlines(), start=1)
        if raw.search(line)
    ]
    assert offenders == []


def _run(*argv: str) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=str(REPO))
    return subprocess.run(
        [sys.executable, *argv], cwd=REPO, env=env, capture_output=True, text=True, timeout=120
    )


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (
            ["benchmarks/fastslam_readout.py", "--set", "particles.n_particles"],
            "--set takes KEY=VALUE, got 'particles.n_particles'",
        ),
        (
            ["benchmarks/fastslam_mrclam.py", "--loader-set", "=1"],
            "--loader-set takes KEY=VALUE, got '=1'",
        ),
        (
            ["benchmarks/fastslam_loop150.py", "--graph-set", "x"],
            "--graph-set takes KEY=VALUE, got 'x'",
        ),
        (
            ["benchmarks/bearing_noise.py", "--dataset", "nowhere", "--set", "tracks.sigma_px=x"],
            "--set tracks.sigma_px: 'x' is not JSON",
        ),
        (
            ["benchmarks/bearing_noise.py", "--dataset", "nowhere", "--set", "tracks.nosuch=1"],
            "--set tracks.nosuch: no such front-end setting",
        ),
    ],
)
def test_a_malformed_option_is_a_usage_error(argv: list[str], message: str) -> None:
    result = _run(*argv)
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    assert result.stderr.splitlines()[-1].endswith(message)
    assert result.stdout == ""
