"""Reports: self-contained HTML whose figures parse, Markdown with SVGs, exports, occupancy."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import mounted_laser_room as mounted
import numpy as np
import pytest
from room_log import ROOM_X, ROOM_Y, write_room_log

from omnislam.datasets.registry import load_dataset
from omnislam.harness.evaluation import EvaluationOptions, evaluate_run
from omnislam.harness.grid import parse_grid
from omnislam.harness.rundir import read_run_dir, write_run_dir
from omnislam.harness.runner import SerialExecutor, run_grid
from omnislam.metrics.landmarks import LandmarkAssociation
from omnislam.report.comparison import write_report
from omnislam.report.occupancy import occupancy_grid
from omnislam.report.options import ReportOptions

SVG = "{http://www.w3.org/2000/svg}"


def inline_figures(page: str) -> list[str]:
    return re.findall(r"<svg\b.*?</svg>", page, flags=re.S)


def assert_svg_drawing(svg: str) -> None:
    """A parsable SVG of a sensible size that draws something (paths) and says it (text)."""
    root = ET.fromstring(svg)
    assert root.tag == f"{SVG}svg"
    width, height = (float(root.get(k).removesuffix("pt")) for k in ("width", "height"))
    assert width > 100 and height > 50
    assert list(root.iter(f"{SVG}path")) and list(root.iter(f"{SVG}text"))


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
    figures = inline_figures(page)
    assert len(figures) == len(summary.figures) >= 4
    for svg in figures:
        assert_svg_drawing(svg)
    # nothing is fetched from elsewhere (SVG ids are referenced within the page only)
    assert not re.search(r'(src|href)="(?!data:|#)', page) and "<script" not in page
    assert "pseudo ground truth" in page and "room report" in page
    md = (tmp_path / "report" / "report.md").read_text()
    names = re.findall(r"\]\(([^)]+\.svg)\)", md)
    assert names == list(summary.figures)
    for name in names:
        assert_svg_drawing((tmp_path / "report" / name).read_text())
    assert "room-occupancy.svg" in summary.figures
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


def _largest_probability(grid, x, y, half_m=0.1):
    """The largest occupancy probability of ``grid`` within half_m of (x, y)."""
    lo = ((np.array([x, y]) - half_m - grid.origin_w) / grid.resolution_m).astype(int)
    hi = ((np.array([x, y]) + half_m - grid.origin_w) / grid.resolution_m).astype(int)
    return grid.probability[lo[1] : hi[1] + 1, lo[0] : hi[0] + 1].max()


def _report_grid_of_the_mounted_room(folder, offset_r):
    """The report's occupancy grid on the ground truth of the room scanned from
    ``mounted.OFFSET_R``, declared as ``offset_r`` (None: as mounted), read from a folder."""
    from omnislam.core.types import Estimate
    from omnislam.datasets.folder import export_folder
    from omnislam.harness.rundir import RunConfig, RunRecord
    from omnislam.report.figures import _occupancy_grids

    sequence = mounted.mounted_room(declared_offset_r=offset_r)
    root = export_folder(sequence, folder)
    config = RunConfig(dataset=str(root), dataset_path=str(root), estimator="deadreckoning",
                       omnislam_version="test", frames=len(sequence), total_s=0.0,
                       peak_rss_mb=0.0, ground_truth_kind="exact")
    record = RunRecord(config, Estimate(sequence.ground_truth.trajectory),
                       np.zeros(len(sequence)), sequence.ground_truth)
    notes: list[str] = []
    grids = _occupancy_grids(record, {"truth as estimate": (np.eye(4), record)},
                             "ground truth (exact)", ReportOptions(), notes)
    assert [label for label, _ in grids] == ["ground truth", "truth as estimate"]
    assert notes == []
    return grids[0][1]


def test_occupancy_grids_draw_the_beams_from_a_scanner_mounted_off_the_robots_origin(tmp_path):
    along_x, along_y = np.linspace(1.0, 9.0, 33), np.linspace(1.0, 7.0, 25)
    x_max, y_max, inset = mounted.ROOM_X, mounted.ROOM_Y, 0.3
    walls = [(x, y) for x in along_x for y in (0.0, y_max)]
    walls += [(x, y) for y in along_y for x in (0.0, x_max)]
    inside = [(x, y) for x in along_x for y in (inset, y_max - inset)]
    inside += [(x, y) for y in along_y for x in (inset, x_max - inset)]
    grid = _report_grid_of_the_mounted_room(tmp_path / "mounted", None)
    assert np.mean([_largest_probability(grid, x, y) > 0.9 for x, y in walls]) > 0.9
    assert max(_largest_probability(grid, x, y) for x, y in inside) < 0.2  # free up to them
    assert min(_largest_probability(grid, x, y) for x, y in mounted.POLES_W) > 0.9
    naive = _report_grid_of_the_mounted_room(tmp_path / "undeclared", np.zeros(3))
    # undeclared, the walls are drawn 0.1-0.25 m off: most of their true lines are not occupied
    assert np.mean([_largest_probability(naive, x, y) > 0.9 for x, y in walls]) < 0.5


def test_covariances_round_trip_and_give_nees_and_ellipses(tmp_path, record_with_a_map):
    record = record_with_a_map
    write_run_dir(tmp_path / "run", record)
    back = read_run_dir(tmp_path / "run")
    assert np.array_equal(back.estimate.pose_covariances, record.estimate.pose_covariances)
    assert np.array_equal(back.estimate.landmark_covariances, record.estimate.landmark_covariances)
    metrics = evaluate_run(back, EvaluationOptions())
    landmarks, nees = metrics.landmarks, metrics.nees
    assert landmarks.association is LandmarkAssociation.BY_ID and landmarks.matched == 12
    assert nees.pose_dof == 3 and nees.pose_count == 49
    assert 1.5 < nees.pose_mean < 4.5  # consistent by construction: about 3
    assert nees.landmark_dof == 2 and 0.5 < nees.landmark_mean < 5.0
    summary = write_report(tmp_path / "run", tmp_path / "report", ReportOptions(exports=True))
    assert "fake-landmarks.svg" in summary.figures
    landmarks = (tmp_path / "report" / "fake-landmarks.svg").read_text()
    assert_svg_drawing(landmarks)
    assert "ekfslam: 12 landmarks" in landmarks and "2-sigma ellipses" in landmarks
    ply = tmp_path / "report" / "exports" / "run" / "landmarks.ply"
    if ply.exists():  # open3d installed
        import open3d

        assert len(open3d.io.read_point_cloud(str(ply)).points) == 12
