"""Every reader, fed mutated copies of a small valid input, reads it or refuses it in one line.

``tests/reader_fuzz.py`` builds the inputs, mutates them and judges the outcome (sane output,
or ``DataError`` / ``ConfigError`` naming the input, within a time limit). Hypothesis draws
``EXAMPLES_PER_READER`` mutations per reader, derandomised so that the suite is repeatable;
``benchmarks/fuzz_readers.py --examples 10000`` is the long run. A few mutated inputs also go
through the console script in a subprocess: exit 0, or exit 2 with one line and nothing written.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from reader_fuzz import RandomChooser, Target, build_targets, check

#: hypothesis examples per reader in the suite (12 readers: about 20 s with the inputs built)
EXAMPLES_PER_READER = 30

READERS = (
    "mrclam", "victoria-park", "gtsam-graph", "carmen", "observation-log", "run-dir", "grid",
    "omnislam-folder", "omnislam-folder-check", "omnislam-folder-bearings", "synthetic",
    "camera",
)
REPO = Path(__file__).resolve().parents[2]


class HypothesisChooser:
    """A mutation's choices drawn by hypothesis (so that a failure shrinks)."""

    def __init__(self, data: st.DataObject) -> None:
        self.data = data

    def integer(self, low: int, high: int) -> int:
        return self.data.draw(st.integers(low, high))


@pytest.fixture(scope="module")
def targets(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Target]:
    try:
        import cv2  # noqa: F401 - the synthetic folder and its camera file need the renderer
    except ImportError:
        images = False
    else:
        images = True
    return build_targets(tmp_path_factory.mktemp("fuzz-inputs"), images=images)


def test_every_reader_has_an_input(targets: dict[str, Target]) -> None:
    """The valid inputs read as sane outputs (else every mutation would be judged wrongly)."""
    for name, target in targets.items():
        assert target.sane(target.read(target.pristine)), name
    assert set(targets) <= set(READERS)


@pytest.mark.parametrize("name", READERS)
@settings(
    max_examples=EXAMPLES_PER_READER,
    deadline=None,  # the reader's own time limit (reader_fuzz.TIME_LIMIT_S) applies
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
)
@given(data=st.data())
def test_a_mutated_input_is_read_or_refused_naming_it(
    name: str, targets: dict[str, Target], data: st.DataObject
) -> None:
    if name not in targets:
        pytest.skip(f"{name}: its input needs opencv")
    with tempfile.TemporaryDirectory() as workdir:
        outcome = check(targets[name], Path(workdir), HypothesisChooser(data))
    assert outcome.violation is None, f"{outcome.mutation}: {outcome.violation}"


def _cli(*argv: str) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=str(REPO))
    return subprocess.run([sys.executable, "-m", "omnislam", *argv], env=env,
                          capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("name", ["mrclam", "carmen", "victoria-park", "omnislam-folder",
                                  "run-dir"])
def test_the_console_script_agrees_with_the_reader(
    name: str, targets: dict[str, Target], tmp_path: Path
) -> None:
    """Seeded mutations through ``omnislam run`` (``evaluate`` for a RUN_DIR) in a subprocess:
    exit 2 with the reader's one line and nothing written when the reader refuses the input,
    else exit 0; never a traceback."""
    target = targets[name]
    workdir = tmp_path / "input"
    workdir.mkdir()
    outcome = check(target, workdir, RandomChooser(np.random.default_rng(len(name))))
    assert outcome.violation is None, outcome
    mutated = workdir / target.pristine.name
    out = tmp_path / "R"
    if name == "run-dir":
        result = _cli("evaluate", str(mutated))
    else:
        result = _cli("run", str(mutated), "--estimator", "deadreckoning", "--out", str(out))
    lines = result.stderr.strip().splitlines()
    assert "Traceback" not in result.stderr, (outcome.mutation, result.stderr)
    if outcome.refusal is None:
        assert result.returncode == 0, (outcome.mutation, result.stderr)
    else:
        assert result.returncode == 2, (outcome.mutation, result.stderr)
        assert lines == [f"omnislam {'evaluate' if name == 'run-dir' else 'run'}: error: "
                         f"{outcome.refusal}"], outcome.mutation
        assert not out.exists()
