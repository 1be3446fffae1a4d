"""The EKF localiser, installed as an omnislam plugin, used the way a user uses it.

The filter on its own (exact data: it must return the truth), then through omnislam's command
line as an installed plugin: listed by ``omnislam estimators``, run by ``omnislam run`` on
MR.CLAM robot 1 in the surveyed landmark map, and in a two-cell grid beside dead reckoning
whose report scores, tables, ranks and colours it like a built-in estimator.
"""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from ekf_localiser.config import EKFLocaliserConfig
from ekf_localiser.localiser import EKFLocaliser

from omnislam.core.measurement import RangeBearing2D
from omnislam.core.se import se2_between, wrap_angle
from omnislam.core.types import FrameInput, Odometry, PriorMap, RangeBearing
from omnislam.errors import OmnislamError

#: the ATE RMSE of the localiser on MR.CLAM robot 1 is 0.085 m; dead reckoning's 2.08 m
ATE_BOUND_M = 0.15
DATASET = "mrclam6-r1"


def _omnislam(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "OMNISLAM_PROGRESS": "0"}
    return subprocess.run(
        [sys.executable, "-m", "omnislam", *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
    )


@pytest.fixture(scope="module")
def mrclam() -> str:
    """The MR.CLAM robot 1 dataset (skips when the data is not on this machine)."""
    from omnislam.datasets.registry import resolve

    try:
        resolve(DATASET)
    except OmnislamError as exc:
        pytest.skip(f"{DATASET} not found: {exc}")
    return DATASET


def test_exact_odometry_and_sightings_give_the_true_path():
    """With odometry and sightings computed from the truth, every update's innovation is zero:
    the filter returns the true poses and its covariance shrinks where it sees landmarks."""
    t = np.linspace(0.0, np.pi, 30)
    truth = np.column_stack([3 * np.cos(t), 3 * np.sin(t), wrap_angle(t + np.pi / 2)])
    points_w = np.array([[0.0, 0.0, 0.0], [4.0, 1.0, 0.0], [-4.0, 2.0, 0.0]])
    prior = PriorMap("test", np.arange(3), points_w, initial_pose_w=truth[0])
    localiser = EKFLocaliser(prior, EKFLocaliserConfig())
    model = RangeBearing2D()
    for k, pose in enumerate(truth):
        delta = np.zeros(3) if k == 0 else se2_between(truth[k - 1], pose)
        z, _, _ = model.predict(np.tile(pose, (3, 1)), points_w[:, :2], jacobians=False)
        sightings = RangeBearing(np.arange(3), z[:, 0], z[:, 1], 0.05, 0.01)
        localiser.step(FrameInput(k, Odometry(delta, float(k)), range_bearing=sightings))
    estimate = localiser.estimate()
    np.testing.assert_allclose(estimate.trajectory.se2, truth, atol=1e-9)
    assert estimate.pose_covariances is not None
    final_sigma_xy = np.sqrt(np.diag(estimate.pose_covariances[-1])[:2])
    assert np.all(final_sigma_xy < EKFLocaliserConfig().initial_sigma_xy_m)
    assert localiser.rejected == 0


def test_listed_as_a_plugin(tmp_path: Path):
    done = _omnislam("estimators", "ekf-localiser", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("ekf-localiser: EKF localisation")
    assert "plugin: omnislam-ekf-localiser" in done.stdout
    assert "consumes: range-bearing-2d; available" in done.stdout
    assert "gate_probability=0.999" in done.stdout
    assert "estimator plugin" not in done.stderr  # no plugin was left out


@pytest.fixture(scope="module")
def grid_report(mrclam: str, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``omnislam compare`` of the localiser and dead reckoning, then ``omnislam report``."""
    tmp = tmp_path_factory.mktemp("grid")
    (tmp / "grid.yaml").write_text(
        f"name: a plugin beside a built-in\ndatasets: [{mrclam}]\n"
        "estimators: [deadreckoning, ekf-localiser]\n"
    )
    done = _omnislam("compare", "grid.yaml", "--out", "results", "--workers", "1", cwd=tmp)
    assert done.returncode == 0, done.stderr
    done = _omnislam("report", "results", "--out", "report", cwd=tmp)
    assert done.returncode == 0, done.stderr
    return tmp


def test_run_gives_the_grid_cell_and_is_accurate(grid_report: Path, mrclam: str):
    done = _omnislam("run", mrclam, "--estimator", "ekf-localiser", "--out", "run", cwd=grid_report)
    assert done.returncode == 0, done.stderr
    cell = grid_report / "results" / "cells" / f"{mrclam}__ekf-localiser__s0"
    trajectory = (grid_report / "run" / "trajectory.tum").read_bytes()
    assert trajectory == (cell / "trajectory.tum").read_bytes()
    done = _omnislam("evaluate", "run", "--json", cwd=grid_report)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["ate_rmse_m"] < ATE_BOUND_M


def test_report_scores_tables_ranks_and_colours_it(grid_report: Path, mrclam: str):
    from omnislam.report import palette

    tables = grid_report / "report" / "tables"
    with (tables / "ate-rmse.csv").open() as f:
        row = next(csv.DictReader(f))
    assert float(row["ekf-localiser"]) < ATE_BOUND_M < float(row["deadreckoning"])
    with (tables / "verdict.csv").open() as f:
        assert next(csv.DictReader(f))["best"] == "ekf-localiser"
    with (tables / "estimators.csv").open() as f:
        listed = {r["estimator"]: r for r in csv.DictReader(f)}
    assert listed["ekf-localiser"]["status"] == "available"
    assert listed["ekf-localiser"]["in this report"] == "yes"
    colour = palette.colours(["deadreckoning", "ekf-localiser"])["ekf-localiser"]
    for figure in ("ate-seeds", "trajectories", "step-time"):
        svg = (grid_report / "report" / f"{mrclam}-{figure}.svg").read_text()
        assert colour in svg, figure
