"""Shared fixtures and the tolerances the tests use, named in one place."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from room_log import write_room_log

from omnislam.core.types import Estimate, Trajectory
from omnislam.datasets.sequence import GroundTruth, GroundTruthKind
from omnislam.harness.rundir import RunConfig, RunRecord

REPO_ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO_ROOT.parent / "shared" / "data"


@pytest.fixture(scope="session", autouse=True)
def _private_cache(tmp_path_factory: pytest.TempPathFactory):
    """Caches the code writes (the victoria-park-gtsam LM reference) go to a temporary folder,
    never to the user's ``~/.cache``."""
    patch = pytest.MonkeyPatch()
    patch.setenv("OMNISLAM_CACHE", str(tmp_path_factory.mktemp("omnislam-cache")))
    yield
    patch.undo()


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20081105)


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The real recorded data folder (../shared/data); skips the test when it is absent."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"real data not found at {SHARED_DATA}")
    return SHARED_DATA


@pytest.fixture
def room_log(tmp_path: Path) -> Path:
    """A 60-frame corrected CARMEN log with pseudo ground truth and laser scans."""
    return write_room_log(tmp_path / "data" / "room.log")


@pytest.fixture
def record_with_a_map(tmp_path: Path, rng: np.random.Generator) -> RunRecord:
    """A 50-pose run with 12 landmarks (true ids), pose and landmark covariances consistent with
    its errors, and exact ground truth."""
    n, m = 50, 12
    stamps = np.arange(n, dtype=float)
    truth = np.column_stack([np.linspace(0, 10, n), np.sin(np.linspace(0, 3, n)), np.zeros(n)])
    pose_cov = np.tile(np.diag([0.04, 0.04, 0.01]), (n, 1, 1))
    est = truth + rng.normal(0, [0.2, 0.2, 0.1], (n, 3))
    est[0] = truth[0]  # estimators anchor the first pose (NEES uses that anchoring)
    pose_cov[0] = 0.0  # ... with no uncertainty: skipped by NEES
    lm_truth = np.column_stack([rng.uniform(0, 10, (m, 2)), np.zeros(m)])
    lm_cov = np.tile(np.diag([0.09, 0.04, 0.0]), (m, 1, 1))
    lm_cov[:, 2, 2] = 1.0
    lm_est = lm_truth + np.column_stack([rng.normal(0, [0.3, 0.2], (m, 2)), np.zeros(m)])
    config = RunConfig(
        dataset="fake",
        dataset_path=str(tmp_path),
        estimator="ekfslam",
        omnislam_version="test",
        frames=n,
        total_s=0.1,
        peak_rss_mb=10.0,
        ground_truth_kind=GroundTruthKind.EXACT.value,
        landmark_ids_from_truth=True,
    )
    return RunRecord(
        config,
        Estimate(
            Trajectory.from_se2(stamps, est),
            np.arange(m),
            lm_est,
            landmark_covariances=lm_cov,
            pose_covariances=pose_cov,
        ),
        np.full(n, 1e-3),
        GroundTruth(
            GroundTruthKind.EXACT, Trajectory.from_se2(stamps, truth), np.arange(m), lm_truth
        ),
    )
