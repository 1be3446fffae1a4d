"""The warm-started LM reference of gtsam graph files, and runs scored against it."""

from __future__ import annotations

import hashlib
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

gtsam = pytest.importorskip("gtsam")

from omnislam.datasets.gtsam_victoria import find_gtsam_file  # noqa: E402
from omnislam.datasets.sequence import GroundTruthKind  # noqa: E402
from omnislam.harness import reference as ref  # noqa: E402
from omnislam.harness.cache import CACHE_ENV  # noqa: E402
from omnislam.harness.evaluation import evaluate_run  # noqa: E402
from omnislam.harness.execute import RunSpec, execute_run  # noqa: E402
from omnislam.metrics.landmarks import LandmarkAssociation  # noqa: E402

GTSAM_FILE = find_gtsam_file()
pytestmark = pytest.mark.skipif(
    GTSAM_FILE is None or not GTSAM_FILE.is_file(), reason="gtsam's victoria_park.txt missing"
)

#: lines of victoria_park.txt kept: 929 poses, 52 landmarks, ~1.5 s for the reference
PREFIX_LINES = 1500
#: the reference vs an independent batch LM on the same prefix: positions [m], headings [rad]
OPTIMUM_TOL_M = 1e-3
OPTIMUM_TOL_RAD = 1e-4
#: the reference's bare iSAM2 pass vs omnislam's iSAM2 on the same prefix: positions [m] (the
#: two build the same updates; they differ in rounding, which can change relinearisation)
WARM_START_TOL_M = 1e-3
#: the recipe of a reference computed with omnislam's own GraphSLAM (a version-1 cache entry)
RECIPE_V1 = "lm-optimum v1: iSAM2 preset victoria-park-gtsam, file covariances; LM 100 its, 1e-10"


@pytest.fixture
def prefix(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A truncated copy of victoria_park.txt; the reference cache goes to tmp_path."""
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "cache"))
    lines = GTSAM_FILE.read_text().splitlines(keepends=True)[:PREFIX_LINES]
    path = tmp_path / "victoria_prefix.txt"
    path.write_text("".join(lines))
    return path


def independent_lm(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """gtsam's own loader and LM from dead reckoning (no omnislam code): poses, landmarks."""
    graph, initial = gtsam.load2D(str(path))
    prior = gtsam.noiseModel.Diagonal.Sigmas(np.full(3, 1e-3))
    graph.add(gtsam.PriorFactorPose2(0, gtsam.Pose2(), prior))
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(100)
    params.setRelativeErrorTol(1e-10)
    values = gtsam.LevenbergMarquardtOptimizer(graph, initial, params).optimize()
    return gtsam.utilities.extractPose2(values), gtsam.utilities.extractPoint2(values)


def test_reference_on_a_prefix_equals_an_independent_batch_lm(prefix):
    solution = ref.lm_reference(prefix)
    poses, landmarks = independent_lm(prefix)
    assert solution.poses_w.shape == poses.shape
    np.testing.assert_allclose(solution.poses_w[:, :2], poses[:, :2], atol=OPTIMUM_TOL_M)
    heading = np.angle(np.exp(1j * (solution.poses_w[:, 2] - poses[:, 2])))
    assert np.abs(heading).max() < OPTIMUM_TOL_RAD
    np.testing.assert_allclose(solution.landmarks_w, landmarks, atol=OPTIMUM_TOL_M)
    assert solution.final_error <= solution.initial_error


def test_reference_needs_none_of_the_estimators(prefix, monkeypatch):
    """The reference is GTSAM's, not one of the contestants: no omnislam.graphslam import."""
    for name in [m for m in sys.modules if m.startswith("omnislam.graphslam")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "omnislam.graphslam", None)  # any import of it fails
    solution = ref.lm_reference(prefix)
    assert solution.poses_w.shape == (929, 3) and len(solution.landmark_ids) == 52


def test_the_warm_start_is_the_updates_graphslam_makes(prefix):
    """Cross-check: the bare gtsam.ISAM2 pass vs omnislam's iSAM2 on the same frames."""
    from omnislam.core.modality import Modality
    from omnislam.datasets.gtsam_victoria import load_gtsam_victoria
    from omnislam.graphslam import GraphSLAM
    from omnislam.graphslam.config import PRESETS, LandmarkConfig, PoseVariables

    sequence = load_gtsam_victoria(prefix)
    frames = list(sequence.frame_inputs())
    bare = ref.isam2_pass(ref.graph_frames(frames))
    assert bare.step_s.shape == (len(frames),) and np.all(bare.step_s > 0)
    # one pose variable per frame, as the bare pass has (graphslam's default composes the
    # odometry of frames without sightings); every sighting a factor at once, as the bare
    # pass adds them (by default the outlier gate drops some and a landmark waits for its
    # second agreeing sighting)
    preset = PRESETS["victoria-park-gtsam"]
    config = replace(
        preset,
        poses=replace(preset.poses, pose_variables=PoseVariables.FRAMES),
        landmarks=LandmarkConfig(outlier_gate_probability=1.0, min_consistent_sightings=1),
    )
    estimator = GraphSLAM(Modality.RANGE_BEARING_2D, config)
    for frame in frames:
        estimator.step(frame)
    ours = estimator.estimate().trajectory.se2
    theirs = gtsam.utilities.extractPose2(bare.isam.calculateEstimate())
    np.testing.assert_allclose(ours[:, :2], theirs[:, :2], atol=WARM_START_TOL_M)


def test_the_bare_pass_needs_stated_odometry_covariances():
    frames = [ref.GraphFrame(np.zeros(3), None, ()), ref.GraphFrame(np.ones(3), None, ())]
    with pytest.raises(ref.DataError, match="covariance"):
        ref.isam2_pass(frames)
    assert len(ref.isam2_pass(frames, odometry_sigmas=(0.1, 0.1, 0.1)).step_s) == 2


def test_a_reference_cached_by_an_older_recipe_is_not_reused(prefix):
    digest = hashlib.sha256(RECIPE_V1.encode())
    digest.update(prefix.read_bytes())
    stale = ref.ReferenceSolution(
        stamps_s=np.zeros(1),
        poses_w=np.zeros((1, 3)),
        landmark_ids=np.zeros(1, dtype=np.int64),
        landmarks_w=np.zeros((1, 2)),
        iterations=0,
        initial_error=0.0,
        final_error=0.0,
    )
    ref._store(ref.cache_dir() / f"lm-optimum-{digest.hexdigest()}.npz", stale)
    solution = ref.lm_reference(prefix)
    assert solution.poses_w.shape == (929, 3)  # computed, not the v1 entry
    assert (ref.cache_dir() / f"lm-optimum-{ref.cache_key(prefix)}.npz").is_file()


def test_reference_is_cached_by_the_file_hash(prefix, monkeypatch):
    first = ref.lm_reference(prefix)
    entries = list(ref.cache_dir().glob("lm-optimum-*.npz"))
    assert [e.name for e in entries] == [f"lm-optimum-{ref.cache_key(prefix)}.npz"]

    def fail(sequence):
        raise AssertionError("recomputed although cached")

    monkeypatch.setattr(ref, "compute_lm_reference", fail)
    again = ref.lm_reference(prefix)
    np.testing.assert_array_equal(again.poses_w, first.poses_w)
    np.testing.assert_array_equal(again.landmark_ids, first.landmark_ids)
    # a changed file gets its own entry
    prefix.write_text(prefix.read_text() + "ODOMETRY 0 0 0 0 0 1 0 0 1 0 1\n")
    assert ref.cache_key(prefix) not in entries[0].name


@pytest.mark.parametrize("association", ["known", "unknown"])
def test_runs_on_a_gtsam_graph_are_scored_against_the_lm_optimum(prefix, association):
    record = execute_run(
        RunSpec(
            str(prefix),
            "graphslam",
            options={"preset": "victoria-park-gtsam", "association": association},
        )
    )
    assert record.ground_truth.kind is GroundTruthKind.REFERENCE
    metrics = evaluate_run(record)
    assert metrics.ground_truth.reference == ref.REFERENCE_LM_OPTIMUM
    assert metrics.ground_truth.kind is GroundTruthKind.REFERENCE
    assert metrics.ate.rmse_m is not None
    assert metrics.landmarks.rmse_m is not None
    assert metrics.landmarks.truth == 52
    if association == "known":
        # the defaults drop the sightings the outlier gate rejects and a landmark until two
        # sightings agree: 0.071 m from the optimum on this prefix, 45 of the 52 landmarks
        # (the others seen once, or never twice in agreement)
        assert metrics.ate.rmse_m < 0.1
        assert metrics.landmarks.association is LandmarkAssociation.BY_ID
        assert 45 <= metrics.landmarks.matched == metrics.landmarks.estimated
        # every sighting a factor: iSAM2 itself, within the benchmark's 2 cm of the optimum
        every = {
            "landmarks.outlier_gate_probability": "1.0",
            "landmarks.min_consistent_sightings": "1",
        }
        options = {"preset": "victoria-park-gtsam", "association": association, **every}
        plain = evaluate_run(execute_run(RunSpec(str(prefix), "graphslam", options=options)))
        assert plain.ate.rmse_m < 0.02
        assert plain.landmarks.matched == 52


def test_restated_noise_leaves_the_reference_the_optimum_of_the_files_noise(prefix):
    """The loader options that restate the noise change what the run sees, not what it is
    scored against: the reference stays the optimum of the file's own stated noise."""
    from omnislam.datasets.gtsam_victoria import load_gtsam_victoria
    from omnislam.datasets.registry import DatasetFormat

    restated = load_gtsam_victoria(
        prefix, sigma_range_m=0.25, sigma_bearing_rad=0.05, odometry_sigma_theta_rad=0.014
    )
    truth, name = ref.reference_for(DatasetFormat.GTSAM_GRAPH, prefix, restated)
    assert name == ref.REFERENCE_LM_OPTIMUM
    poses, _ = independent_lm(prefix)  # gtsam's load2D: the file's noise
    np.testing.assert_allclose(truth.trajectory.se2[:, :2], poses[:, :2], atol=OPTIMUM_TOL_M)
    # while the optimum of the restated noise is elsewhere
    moved = ref.compute_lm_reference(restated)
    assert np.abs(moved.poses_w[:, :2] - poses[:, :2]).max() > 10 * OPTIMUM_TOL_M
