"""``omnislam compare --scheduler local``: a Dask worker killed in the middle of a cell is
replaced, the cell runs again and the grid ends with the numbers of an uninterrupted run.

The cell is made to wait: its estimator (a plugin distribution on ``sys.path``, dead reckoning
behind a gate) writes a file named after its worker's pid at its first frame and waits for a
"go" file. The test kills that pid with SIGKILL while the cell is held there, so the kill lands
mid-cell for certain, then opens the gate; the cell must be computed again by another process.

Two layers retry: the Dask scheduler reschedules a task whose worker died (up to
``distributed.scheduler.allowed-failures`` deaths, 3 by default) and the runner resubmits a
task that ends in ``KilledWorker`` (``--max-attempts``). Each is exercised alone: with Dask's
default the runner sees no failure; with ``allowed-failures`` 0 Dask gives up at the first
death and only the runner's resubmission computes the cell (which needs impure Dask tasks:
``harness.runner.dask_executor_factory``).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from small_mrclam import write_small_mrclam
from test_runner import numbers

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(not sys.platform.startswith("linux"), reason="kills a worker by pid"),
]

REPO_ROOT = Path(__file__).resolve().parents[2]

#: dead reckoning whose first frame announces its process and waits for the gate to open
GATED_MODULE = """
import os
import time
from pathlib import Path

from omnislam.deadreckoning import DeadReckoning, check_options
from omnislam.estimators import EstimatorEntry

GATE = Path({gate!r})


class GatedDeadReckoning(DeadReckoning):
    def step(self, frame):
        if not self._stamps_s:
            (GATE / f"started-{{os.getpid()}}").touch()
            deadline = time.monotonic() + 60
            while not (GATE / "go").exists() and time.monotonic() < deadline:
                time.sleep(0.02)
        super().step(frame)


def make_estimator(info, options, rng):
    check_options(options)
    return GatedDeadReckoning()


def estimators():
    return {{
        "gated": EstimatorEntry(
            "gated_plugin:make_estimator",
            frozenset(),
            "gated_plugin:check_options",
            summary="dead reckoning that waits for a gate at its first frame",
            wheel_odometry=True,
        )
    }}
"""

#: a MR.CLAM folder: no images, no scans, so no front end to wait for
GRID = "datasets: [data/mrclam]\nestimators: [gated]\n"


def _gated_site(site: Path, gate: Path) -> None:
    """The plugin distribution ``gated-plugin`` (module and ``*.dist-info``) in ``site``."""
    site.mkdir()
    (site / "gated_plugin.py").write_text(GATED_MODULE.format(gate=str(gate)))
    info = site / "gated_plugin-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: gated-plugin\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        "[omnislam.estimators]\ngated = gated_plugin:estimators\n"
    )


def _compare(
    tmp_path: Path, site: Path, out: str, *options: str, env: dict[str, str] | None = None
) -> subprocess.Popen[str]:
    paths = [str(REPO_ROOT), str(site), os.environ.get("PYTHONPATH", "")]
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(paths),
        "OMNISLAM_PROGRESS": "0",
        **(env or {}),
    }
    env.pop("OMNISLAM_REPORTED_PLUGINS", None)
    command = [sys.executable, "-m", "omnislam", "compare", "grid.yaml", "--out", out, *options]
    return subprocess.Popen(
        command, cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


def _started(gate: Path) -> list[int]:
    return sorted(int(p.name.removeprefix("started-")) for p in gate.glob("started-*"))


#: Dask's own rescheduling (its default), or none: the runner's resubmission alone
DASK_RETRIES = {
    "dask-reschedules": {},
    "runner-resubmits": {"DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES": "0"},
}


@pytest.mark.parametrize("layer", list(DASK_RETRIES))
def test_a_worker_killed_mid_cell_is_replaced_and_the_cell_computed_again(tmp_path, layer):
    pytest.importorskip("distributed")
    write_small_mrclam(tmp_path / "data" / "mrclam", seconds=20.0)
    (tmp_path / "grid.yaml").write_text(GRID)
    gate, site = tmp_path / "gate", tmp_path / "site"
    gate.mkdir()
    _gated_site(site, gate)

    local = ("--scheduler", "local", "--workers", "1")
    compare = _compare(tmp_path, site, "dask", *local, env=DASK_RETRIES[layer])
    deadline = time.monotonic() + 60
    while not _started(gate) and compare.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    assert compare.poll() is None and _started(gate), compare.communicate()
    (victim,) = _started(gate)
    assert victim != compare.pid  # a worker process of the LocalCluster, held mid-cell
    os.kill(victim, signal.SIGKILL)
    (gate / "go").touch()
    stdout, stderr = compare.communicate(timeout=120)
    assert compare.returncode == 0, stderr
    assert "1 computed" in stdout and "0 failed" in stdout, stdout
    retried = [pid for pid in _started(gate) if pid != victim]
    assert len(retried) == 1, "the cell was not started again in another process"

    uninterrupted = _compare(tmp_path, site, "serial", "--workers", "0")
    _, stderr = uninterrupted.communicate(timeout=120)
    assert uninterrupted.returncode == 0, stderr
    assert numbers(tmp_path / "dask") == numbers(tmp_path / "serial")
