"""``omnislam compare`` killed with SIGKILL: its workers die with it, and a re-run resumes to the
results of an uninterrupted run."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from room_log import write_room_log
from test_runner import numbers

from omnislam.harness.grid import load_grid
from omnislam.harness.layout import CELLS
from omnislam.harness.runner import SerialExecutor, run_grid

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="uses /proc")

GRID = """
name: killed
datasets: [data/room_a.log, data/room_b.log]
estimators: [deadreckoning]
seeds: [0, 1, 2]
"""


def _children(pid: int) -> set[int]:
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return set()
    return {int(child) for child in text.split()}


def _alive(pid: int) -> bool:
    """True while ``pid`` runs (a zombie waiting for its reaper counts as dead)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state not in ("Z", "X")


@pytest.mark.slow
def test_workers_die_with_a_killed_compare_and_a_rerun_resumes(tmp_path):
    for name, seed in (("room_a", 1), ("room_b", 2)):
        write_room_log(tmp_path / "data" / f"{name}.log", frames=2000, seed=seed)
    grid_file = tmp_path / "grid.yaml"
    grid_file.write_text(GRID)
    out = tmp_path / "results"
    command = [sys.executable, "-m", "omnislam", "compare", str(grid_file), "--out", str(out)]
    parent = subprocess.Popen(
        [*command, "--workers", "2"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    workers: set[int] = set()
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and len(workers) < 2 and parent.poll() is None:
        workers = {c for c in _children(parent.pid) if _alive(c)}
        time.sleep(0.05)
    assert parent.poll() is None and len(workers) >= 2, "the grid ended before it was killed"
    os.kill(parent.pid, signal.SIGKILL)
    parent.wait()
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline and any(_alive(w) for w in workers):
        time.sleep(0.1)
    assert not any(_alive(w) for w in workers), "workers outlived the killed compare"

    finished = len(list((out / CELLS).iterdir())) if (out / CELLS).is_dir() else 0
    assert finished < 6  # killed mid-grid
    subprocess.run([*command, "--workers", "2", "--resume"], check=True, capture_output=True)
    run_grid(load_grid(grid_file), tmp_path / "uninterrupted", SerialExecutor)
    assert numbers(out) == numbers(tmp_path / "uninterrupted")
