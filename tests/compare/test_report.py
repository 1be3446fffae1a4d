"""Reports: self-contained HTML whose images decode, Markdown with PNGs, exports, occupancy."""

from __future__ import annotations

import base64
import io
import re
from pathlib import Path

import numpy as np
import pytest
from room_log import ROOM_X, ROOM_Y, write_room_log

from omnislam.compare.evaluation import EvaluationOptions, evaluate_record
from omnislam.compare.grid import parse_grid
from omnislam.compare.occupancy import occupancy_grid
from omnislam.compare.report import ReportOptions, write_report
from omnislam.compare.rundir import RunConfig, RunRecord, read_run_dir, write_run_dir
from omnislam.compare.runner import SerialExecutor, run_grid
from omnislam.core.types import Estimate, Trajectory
from omnislam.datasets.registry import load_dataset
from omnislam.datasets.sequence import GroundTruth, GroundTruthKind

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def decode_images(page: str) -> list[bytes]:
    uris = re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', page)
    return [base64.b64decode(u, validate=True) for u in uris]


def assert_png_readable(png: bytes) -> None:
    import matplotlib.image

    assert png.startswith(PNG_SIGNATURE)
    pixels = matplotlib.image.imread(io.BytesIO(png), format="png")
    assert pixels.ndim == 3 and pixels.shape[0] > 50 and pixels.shape[1] > 50


@pytest.fixture
def results(tmp_path) -> Path:
    write_room_log(tmp_path / "data" / "room.log", frames=60)
    grid = parse_grid(
        "name: room report\ndatasets: [data/room.log]\n"
        "estimators: [deadreckoning]\nseeds: [0, 1]\n",
        tmp_path / "grid.yaml",
    )
    run_grid(grid, tmp_path / "results", SerialExecutor)
    return tmp_path / "results"


def test_html_is_self_contained_and_its_images_decode(results, tmp_path):
    summary = write_report(results, tmp_path / "report")
    page = (tmp_path / "report" / "index.html").read_text()
    images = decode_images(page)
    assert len(images) == len(summary.figures) >= 4
    for png in images:
        assert_png_readable(png)
    # nothing is fetched from elsewhere
    assert not re.search(r'(src|href)="(?!data:)', page) and "<script" not in page
    assert "pseudo ground truth" in page and "room report" in page
    md = (tmp_path / "report" / "report.md").read_text()
    for name in re.findall(r"\]\(([^)]+\.png)\)", md):
        assert_png_readable((tmp_path / "report" / name).read_bytes())
    assert "room-occupancy.png" in summary.figures
    assert "| deadreckoning |" in md and "| estimator | status |" in md
    exports = tmp_path / "report" / "exports" / "room__deadreckoning__s0"
    assert (exports / "trajectory.tum").is_file() and (exports / "trajectory.kitti").is_file()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_rewriting_a_report_replaces_it_and_a_foreign_folder_is_refused(results, tmp_path):
    from omnislam.errors import ConfigError

    out = tmp_path / "report"
    write_report(results, out, ReportOptions(exports=False, occupancy=False))
    write_report(results, out, ReportOptions(exports=False, occupancy=False))
    assert not (out / "exports").exists()
    foreign = tmp_path / "thesis"
    foreign.mkdir()
    (foreign / "chapter1.tex").write_text("x")
    with pytest.raises(ConfigError, match="refusing"):
        write_report(results, foreign)
    assert sorted(p.name for p in foreign.iterdir()) == ["chapter1.tex"]


def test_occupancy_grid_of_the_room_sees_walls_and_free_space(room_log):
    sequence = load_dataset(str(room_log))
    laser = sequence.laser
    grid = occupancy_grid(
        sequence.ground_truth.trajectory.se2,
        laser.angles_rad,
        laser.ranges_m,
        laser.max_range_m,
        resolution_m=0.1,
    )

    def at(x, y, half_m=0.0):
        """Largest probability within half_m of (x, y)."""
        lo = ((np.array([x, y]) - half_m - grid.origin_w) / grid.resolution_m).astype(int)
        hi = ((np.array([x, y]) + half_m - grid.origin_w) / grid.resolution_m).astype(int)
        return grid.probability[lo[1] : hi[1] + 1, lo[0] : hi[0] + 1].max()

    assert at(5.0, 4.0, 1.0) < 0.2  # the middle of the room is free
    assert at(ROOM_X, 4.0, 0.15) > 0.9 and at(5.0, ROOM_Y, 0.15) > 0.9  # walls
    assert at(ROOM_X + 1.0, 4.0, 0.3) == pytest.approx(0.5)  # behind the wall: unknown


def _record_with_a_map(tmp_path, rng) -> RunRecord:
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


def test_covariances_round_trip_and_give_nees_and_ellipses(tmp_path, rng):
    record = _record_with_a_map(tmp_path, rng)
    write_run_dir(tmp_path / "run", record)
    back = read_run_dir(tmp_path / "run")
    assert np.array_equal(back.estimate.pose_covariances, record.estimate.pose_covariances)
    assert np.array_equal(back.estimate.landmark_covariances, record.estimate.landmark_covariances)
    metrics = evaluate_record(back, EvaluationOptions())
    assert metrics["landmark_association"] == "id" and metrics["landmarks_matched"] == 12
    assert metrics["nees_dof"] == 3 and metrics["nees_count"] == 49
    assert 1.5 < metrics["nees_mean"] < 4.5  # consistent by construction: about 3
    assert metrics["landmark_nees_dof"] == 2 and 0.5 < metrics["landmark_nees_mean"] < 5.0
    summary = write_report(tmp_path / "run", tmp_path / "report", ReportOptions(exports=True))
    assert "fake-landmarks.png" in summary.figures
    assert_png_readable((tmp_path / "report" / "fake-landmarks.png").read_bytes())
    ply = tmp_path / "report" / "exports" / "run" / "landmarks.ply"
    if ply.exists():  # open3d installed
        import open3d

        assert len(open3d.io.read_point_cloud(str(ply)).points) == 12
