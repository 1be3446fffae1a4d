"""The light install: ``pip install '.[eval]'`` evaluates and reports without the heavy extras.

``omnislam evaluate`` (a RUN_DIR, and ``--ref GT EST``) and ``omnislam report`` run in a
subprocess whose imports of open3d, GTSAM, OpenCV, numba, pycolmap and Rerun fail (a
``sitecustomize`` on ``PYTHONPATH`` puts a finder first on ``sys.meta_path``), and must give
the numbers they give with those packages. The ``eval`` extra itself is read from
pyproject.toml: none of those packages may be in it.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from room_log import write_room_log

from omnislam.cli import main

pytestmark = pytest.mark.slow

REPO_ROOT = Path(__file__).resolve().parents[2]
#: import names the light install lacks, and the distributions that provide them
HEAVY_MODULES = ("open3d", "gtsam", "cv2", "numba", "pycolmap", "rerun")
HEAVY_DISTRIBUTIONS = (
    "open3d",
    "open3d-cpu",
    "gtsam",
    "opencv-python",
    "opencv-python-headless",
    "numba",
    "pycolmap",
    "rerun-sdk",
)
BLOCKER = f"""\
import sys

BLOCKED = {HEAVY_MODULES!r}


class _Absent:
    \"\"\"Finds nothing for the heavy packages: their import fails as if not installed.\"\"\"

    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in BLOCKED:
            raise ImportError(f"{{name}} is absent from the light install (test)")
        return None


sys.meta_path.insert(0, _Absent())
"""
#: report tables that differ between two reports of the same results (date, command line)
VARYING_TABLES = ("provenance.csv",)


def _extra_requirements(extra: str) -> list[str]:
    """The requirements of an extra of pyproject.toml, omnislam's own extras expanded."""
    project = tomllib.loads((REPO_ROOT / "pyproject.toml").read_text())["project"]
    extras = project["optional-dependencies"]
    out: list[str] = []
    for requirement in extras[extra]:
        own = re.fullmatch(r"omnislam\[(.+)\]", requirement)
        if own is None:
            out.append(requirement)
        else:
            for name in own.group(1).split(","):
                out.extend(_extra_requirements(name.strip()))
    return out


def _distribution(requirement: str) -> str:
    """The distribution a requirement names (``open3d-cpu>=0.18; ...`` -> ``open3d-cpu``)."""
    return re.match(r"[A-Za-z0-9._-]+", requirement).group(0).lower().replace("_", "-")


def test_the_eval_extra_brings_plots_and_no_heavy_package():
    project = tomllib.loads((REPO_ROOT / "pyproject.toml").read_text())["project"]
    light = [_distribution(r) for r in project["dependencies"] + _extra_requirements("eval")]
    assert "matplotlib" in light  # the report's figures
    assert not set(light) & set(HEAVY_DISTRIBUTIONS), light
    full = {_distribution(r) for r in _extra_requirements("dev")}  # what `make` installs
    assert set(light) <= full | {_distribution(r) for r in project["dependencies"]}


@pytest.fixture(scope="module")
def blocker(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("light")
    (folder / "sitecustomize.py").write_text(BLOCKER)
    return folder


def omnislam(args: list[str], cwd: Path, light: Path | None) -> subprocess.CompletedProcess:
    """``python -m omnislam ARGS`` in a new process; with ``light`` (the blocker's folder)
    first on the path, the heavy packages cannot be imported."""
    path = [str(REPO_ROOT)] if light is None else [str(light), str(REPO_ROOT)]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(path), "OMNISLAM_PROGRESS": "0"}
    return subprocess.run(
        [sys.executable, "-m", "omnislam", *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_the_blocker_hides_the_heavy_packages(blocker, tmp_path):
    env = {**os.environ, "PYTHONPATH": str(blocker)}
    for module in HEAVY_MODULES:
        result = subprocess.run(
            [sys.executable, "-c", f"import {module}"], env=env, capture_output=True, text=True
        )
        assert result.returncode != 0 and "absent from the light install" in result.stderr


@pytest.fixture(scope="module")
def results(tmp_path_factory) -> Path:
    """A results folder of two estimators on a 40-scan laser log (made with every package)."""
    folder = tmp_path_factory.mktemp("results")
    write_room_log(folder / "data" / "room.log", frames=40)
    grid = folder / "grid.yaml"
    grid.write_text("datasets: [data/room.log]\nestimators: [deadreckoning, ekfslam]\n")
    out = folder / "results"
    assert main(["-q", "compare", str(grid), "--out", str(out), "--workers", "0"]) == 0
    return out


def test_evaluate_ref_without_the_heavy_packages(results, blocker, tmp_path):
    cell = results / "cells" / "room__ekfslam__s0"
    args = ["evaluate", "--ref", str(cell / "ground_truth.tum"), str(cell / "trajectory.tum")]
    full = omnislam([*args, "--json"], tmp_path, None)
    light = omnislam([*args, "--json"], tmp_path, blocker)
    assert full.returncode == 0, full.stderr
    assert light.returncode == 0, light.stderr
    numbers = json.loads(light.stdout)
    assert numbers["ate_m"]["rmse"] > 0 and numbers["rpe_frame_pairs"] > 0
    assert numbers == json.loads(full.stdout)


def test_evaluate_run_dir_without_the_heavy_packages(results, blocker, tmp_path):
    runs = {}
    for name, light in (("full", None), ("light", blocker)):
        run_dir = tmp_path / name
        shutil.copytree(results / "cells" / "room__ekfslam__s0", run_dir)
        (run_dir / "metrics.json").unlink()
        result = omnislam(["evaluate", str(run_dir), "--json"], tmp_path, light)
        assert result.returncode == 0, result.stderr
        runs[name] = json.loads(result.stdout)
    assert runs["light"]["ate_rmse_m"] > 0
    assert runs["light"] == runs["full"]


def test_report_without_the_heavy_packages(results, blocker, tmp_path):
    light = omnislam(["report", str(results), "--out", "light"], tmp_path, blocker)
    full = omnislam(["report", str(results), "--out", "full"], tmp_path, None)
    assert full.returncode == 0, full.stderr
    assert light.returncode == 0, light.stderr
    # the one thing the light install leaves out, named with its extra
    assert "landmarks.ply not written" in light.stdout and "'render' extra" in light.stdout
    figures = {p.name for p in (tmp_path / "light").glob("*.svg")}
    assert figures == {p.name for p in (tmp_path / "full").glob("*.svg")}
    assert any("occupancy" in name for name in figures)  # the laser scans' grids, no OpenCV
    tables = sorted(p.name for p in (tmp_path / "light" / "tables").glob("*.csv"))
    assert "ate-rmse.csv" in tables and "verdict.csv" in tables
    assert tables == sorted(p.name for p in (tmp_path / "full" / "tables").glob("*.csv"))
    for name in tables:
        if name not in VARYING_TABLES:
            light_table = (tmp_path / "light" / "tables" / name).read_text()
            assert light_table == (tmp_path / "full" / "tables" / name).read_text(), name
