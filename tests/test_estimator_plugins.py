"""Estimator plugins (``omnislam.estimators``, entry-point group ``omnislam.estimators``).

Plugins here are real installed distributions as Python sees them: a ``*.dist-info`` folder with
``METADATA`` and ``entry_points.txt`` on ``sys.path`` (in a temporary folder), next to the
modules it names. One declares a working estimator through a callable; one raises on import;
one declares nonsense. The commands run as a user runs them (``python -m omnislam``).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from importlib.metadata import EntryPoint
from pathlib import Path

import pytest
from room_log import write_room_log

from omnislam.core.modality import Modality
from omnislam.estimators import (
    BUILTIN_ESTIMATORS,
    ENTRY_POINT_GROUP,
    EstimatorEntry,
    entry_problem,
    load_registry,
)

REPO_ROOT = Path(__file__).resolve().parents[1]

#: module of the working plugin: dead reckoning's factory under another name, declared by a
#: callable returning name -> EstimatorEntry
GOOD_MODULE = '''
from omnislam.estimators import EstimatorEntry

def estimators():
    return {
        "odo-copy": EstimatorEntry(
            "omnislam.deadreckoning:make_estimator",
            frozenset(),
            "omnislam.deadreckoning:check_options",
            summary="dead reckoning again, from a plugin",
            wheel_odometry=True,
        )
    }
'''
BROKEN_MODULE = 'raise RuntimeError("the plugin is broken")\n'
INVALID_MODULE = 'ENTRY = "not an entry"\n'


def _dist(site: Path, name: str, points: dict[str, str]) -> None:
    """A distribution ``name`` 0.1 declaring ``points`` (entry name -> object) in the group."""
    info = site / f"{name.replace('-', '_')}-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1\n")
    lines = [f"[{ENTRY_POINT_GROUP}]", *(f"{k} = {v}" for k, v in points.items())]
    (info / "entry_points.txt").write_text("\n".join(lines) + "\n")


@pytest.fixture
def site(tmp_path: Path) -> Path:
    """A folder with three plugin distributions: good, broken (raises on import), invalid."""
    site = tmp_path / "site"
    site.mkdir()
    (site / "good_plugin.py").write_text(GOOD_MODULE)
    (site / "broken_plugin.py").write_text(BROKEN_MODULE)
    (site / "invalid_plugin.py").write_text(INVALID_MODULE)
    _dist(site, "good-plugin", {"several": "good_plugin:estimators"})
    _dist(site, "broken-plugin", {"broken": "broken_plugin:ENTRY"})
    _dist(site, "invalid-plugin", {"invalid": "invalid_plugin:ENTRY"})
    return site


def _omnislam(site: Path, *args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(
            [str(REPO_ROOT), str(site), os.environ.get("PYTHONPATH", "")]
        ),
        "OMNISLAM_PROGRESS": "0",
    }
    env.pop("OMNISLAM_REPORTED_PLUGINS", None)
    return subprocess.run(
        [sys.executable, "-m", "omnislam", *args],
        env=env,
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=600,
    )


def _plugin_lines(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if "estimator plugin" in line]


def test_a_plugin_is_listed_and_a_broken_one_is_one_line_each(site: Path, tmp_path: Path):
    done = _omnislam(site, "estimators", "--json", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    listed = {d["name"]: d for d in json.loads(done.stdout)["estimators"]}
    assert set(listed) >= {*BUILTIN_ESTIMATORS, "odo-copy"}  # with any plugin installed here
    assert listed["odo-copy"]["origin"] == "good-plugin"
    assert listed["odo-copy"]["status"] == "available"
    assert listed["graphslam"]["origin"] == "omnislam"
    lines = _plugin_lines(done.stderr)
    assert len(lines) == 2, done.stderr
    broken = next(line for line in lines if "'broken'" in line)
    assert "broken-plugin 0.1" in broken and "RuntimeError: the plugin is broken" in broken
    invalid = next(line for line in lines if "'invalid'" in line)
    assert "invalid-plugin 0.1" in invalid
    assert "declares a str; expected an EstimatorEntry" in invalid


def test_a_plugin_runs_in_a_grid_beside_a_built_in_and_broken_ones_are_reported_once(
    site: Path, tmp_path: Path
):
    """Two cells on two worker processes: the plugin's cell gives the built-in's numbers (it
    is the same factory), and each broken plugin is one line, not one per process."""
    write_room_log(tmp_path / "data" / "room.log", frames=40)
    (tmp_path / "grid.yaml").write_text(
        "datasets: [data/room.log]\nestimators: [deadreckoning, odo-copy]\n"
    )
    done = _omnislam(
        site, "compare", "grid.yaml", "--out", "results", "--workers", "2", cwd=tmp_path
    )
    assert done.returncode == 0, done.stderr
    assert len(_plugin_lines(done.stderr)) == 2, done.stderr
    cells = tmp_path / "results" / "cells"
    builtin = (cells / "room__deadreckoning__s0" / "trajectory.tum").read_bytes()
    assert (cells / "room__odo-copy__s0" / "trajectory.tum").read_bytes() == builtin


def _points(site: Path, **values: str) -> list[EntryPoint]:
    return [EntryPoint(name, value, ENTRY_POINT_GROUP) for name, value in values.items()]


def test_invalid_declarations_are_left_out_with_their_reason(site: Path, monkeypatch):
    monkeypatch.syspath_prepend(str(site))
    (site / "declarations.py").write_text(
        "from omnislam.core.modality import Modality\n"
        "from omnislam.estimators import EstimatorEntry as E\n"
        "CLASH = E('omnislam.deadreckoning:make_estimator', frozenset())\n"
        "BAD_TARGET = E('omnislam.deadreckoning.make_estimator', frozenset())\n"
        "BAD_MODALITIES = E('omnislam.deadreckoning:make_estimator', {'range-bearing-2d'})\n"
        "GOOD = E('omnislam.deadreckoning:make_estimator', frozenset({Modality.BEARINGS_3D}))\n"
    )
    registry = load_registry(
        _points(
            site,
            graphslam="declarations:CLASH",
            external="declarations:GOOD",
            target="declarations:BAD_TARGET",
            modalities="declarations:BAD_MODALITIES",
            missing="no_such_module:ENTRY",
            good="declarations:GOOD",
        )
    )
    reasons = {p.declaration.split("'")[1]: p.reason for p in registry.problems}
    assert set(reasons) == {"graphslam", "external", "target", "modalities", "missing"}
    assert "is taken (by omnislam)" in reasons["graphslam"]
    assert "reserved" in reasons["external"]
    assert "module:attribute" in reasons["target"]
    assert "frozenset of omnislam Modality" in reasons["modalities"]
    assert "ModuleNotFoundError" in reasons["missing"]
    assert list(registry.entries) == [*BUILTIN_ESTIMATORS, "good"]
    assert registry.entries["graphslam"] is BUILTIN_ESTIMATORS["graphslam"]


def test_entry_problem_accepts_every_built_in():
    for name, entry in BUILTIN_ESTIMATORS.items():
        assert entry_problem(name, entry) is None, name
    assert "not a name" in str(entry_problem("two words", BUILTIN_ESTIMATORS["ukf"]))
    preset_without_config = EstimatorEntry(
        "m:f", frozenset({Modality.RANGE_BEARING_2D}), preset="fast"
    )
    assert "preset" in str(entry_problem("x", preset_without_config))
