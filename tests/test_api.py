"""The public Python API (``omnislam/__init__.py``) and ``examples/api.py``, which uses it."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import omnislam

REPO_ROOT = Path(__file__).resolve().parents[1]


def _python(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    path = os.pathsep.join([str(REPO_ROOT), os.environ.get("PYTHONPATH", "")])
    env = {**os.environ, "PYTHONPATH": path, "OMNISLAM_PROGRESS": "0"}
    return subprocess.run(
        [sys.executable, *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=900
    )


def test_import_omnislam_stays_light(tmp_path: Path):
    """``import omnislam`` loads no subpackage (nor numpy); a public name loads its module."""
    code = (
        "import sys, omnislam\n"
        "before = sorted(m for m in sys.modules if m.startswith(('omnislam.', 'numpy')))\n"
        "omnislam.RunSpec\n"
        "print(before, 'omnislam.harness.execute' in sys.modules)\n"
    )
    done = _python("-c", code, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["['omnislam._version']", "True"]


def test_every_public_name_resolves_to_its_documented_object():
    from omnislam.harness.execute import execute_run
    from omnislam.report.comparison import write_report

    for name in omnislam.__all__:
        assert getattr(omnislam, name) is not None, name
        assert name in dir(omnislam)
    assert omnislam.execute_run is execute_run and omnislam.write_report is write_report
    assert set(omnislam.__all__) == {"__version__", "registered_estimators", *omnislam._PUBLIC}
    assert "graphslam" in omnislam.registered_estimators()
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        omnislam.nothing  # noqa: B018


def test_the_example_script_does_the_round_trip(shared_data: Path, tmp_path: Path):
    """examples/api.py: by hand, as ``omnislam run`` and as a grid cell, one trajectory."""
    done = _python(str(REPO_ROOT / "examples" / "api.py"), "--out", "out", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    numbers = json.loads(done.stdout)
    assert numbers["same_trajectory"] == 1.0
    assert numbers["ate_rmse_by_hand_m"] == pytest.approx(numbers["ate_rmse_m"], abs=1e-12)
    assert numbers["grid_ate_rmse_m.ekfslam"] == pytest.approx(numbers["ate_rmse_m"], abs=1e-12)
    assert numbers["ate_rmse_m"] < numbers["grid_ate_rmse_m.deadreckoning"] / 5
    assert (tmp_path / "out" / "report" / "report.md").is_file()
