"""A RUN_DIR writer killed mid-write (SIGKILL skips every ``finally``) leaves temporaries that
carry its process id; the next write of that RUN_DIR removes them, a live writer's are kept."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from omnislam.harness.rundir import remove_stale_temporaries


def dead_pid() -> int:
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_stale_temporaries_of_a_dead_writer_are_removed(tmp_path):
    run = tmp_path / "R"
    pid = dead_pid()
    staging = tmp_path / f".R.{pid}.abc123.tmp"
    trash = tmp_path / f".R.old-{pid}"
    alive = tmp_path / f".R.{os.getpid()}.def456.tmp"
    other = tmp_path / f".R2.{pid}.ghi789.tmp"  # another RUN_DIR's
    for folder in (staging, trash, alive, other):
        folder.mkdir()
        (folder / "trajectory.tum").write_text("partial")
    removed = remove_stale_temporaries(run)
    assert sorted(removed) == sorted([staging, trash])
    assert alive.exists() and other.exists()


WRITER = """
import sys, time
from pathlib import Path
import numpy as np
import omnislam.harness.rundir as rundir
from omnislam.harness.rundir import RunConfig, RunRecord, write_run_dir
from omnislam.core.types import Estimate, Trajectory

def slow_write_tum(path, trajectory):
    Path(path).write_text("partial")
    print("writing", flush=True)
    time.sleep(60)

rundir.write_tum = slow_write_tum
config = RunConfig("d", "d", "deadreckoning", "0", 2, 0.0, 0.0)
estimate = Estimate(trajectory=Trajectory.from_se2(np.arange(2.0), np.zeros((2, 3))))
write_run_dir(Path(sys.argv[1]), RunRecord(config, estimate, np.zeros(2)))
"""


def test_sigkill_during_write_then_the_next_write_cleans_up(tmp_path):
    run = tmp_path / "R"
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    child = subprocess.Popen(
        [sys.executable, "-c", WRITER, str(run)], stdout=subprocess.PIPE, text=True, env=env
    )
    try:
        assert child.stdout.readline().strip() == "writing"
        os.kill(child.pid, signal.SIGKILL)
        child.wait(timeout=10)
    finally:
        if child.poll() is None:
            child.kill()
    leftovers = [p for p in tmp_path.iterdir() if p.name.startswith(".R.")]
    assert leftovers and not run.exists()  # what SIGKILL leaves: a hidden staging folder
    deadline = time.time() + 5
    while remove_stale_temporaries(run) == [] and time.time() < deadline:
        time.sleep(0.05)
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".R.")]
