"""``omnislam view RUN_DIR``: a Rerun recording, written and read back with Rerun's own reader."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from small_mrclam import write_small_mrclam

from omnislam.cli import main
from omnislam.harness.rundir import read_run_dir
from omnislam.metrics.trajectory import Alignment, ate
from omnislam.report.view import SIGMAS, covariance_ellipsoids

rr = pytest.importorskip("rerun")
from rerun.chunk import RrdReader  # noqa: E402

#: positions read back from the recording (float32 in Rerun) against ours [m]
FLOAT32_TOL_M = 1e-5


def read_back(path: Path) -> dict[str, list[dict[str, list]]]:
    """Entity path -> the rows of its chunks as Python values (Rerun's reader, not ours)."""
    store = RrdReader(path).stream().collect()
    out: dict[str, list[dict[str, list]]] = {}
    for chunk in store.stream():
        table = chunk.to_record_batch().to_pydict()
        rows = [{k: table[k][i] for k in table} for i in range(chunk.num_rows)]
        out.setdefault(chunk.entity_path, []).extend(rows)
    return out


def _column(rows: list[dict], suffix: str) -> list:
    """The values of the component ``...:suffix`` in the rows that have it."""
    return [v for row in rows for k, v in row.items() if k.endswith(":" + suffix)]


def test_covariance_ellipsoids_are_the_principal_axes():
    rng = np.random.default_rng(0)
    A = rng.normal(size=(5, 3, 3))
    cov = A @ np.swapaxes(A, 1, 2) + 0.01 * np.eye(3)
    half, quaternions = covariance_ellipsoids(cov)
    from scipy.spatial.transform import Rotation

    R = Rotation.from_quat(quaternions).as_matrix()
    rebuilt = R @ (np.eye(3) * (half / SIGMAS)[:, None, :] ** 2) @ np.swapaxes(R, 1, 2)
    assert np.allclose(rebuilt, cov, atol=1e-9)
    flat = np.diag([0.04, 0.01, 0.0])[None]  # a 2-D map: no z variance
    half, _ = covariance_ellipsoids(flat)
    assert np.allclose(sorted(half[0]), [1e-3, 2 * 0.1, 2 * 0.2])


def test_a_run_with_a_map_reads_back_with_its_trajectories_and_ellipsoids(tmp_path, capsys):
    data = write_small_mrclam(tmp_path / "MRCLAM_Small")
    run = tmp_path / "run"
    assert main(["run", str(data), "--estimator", "ekfslam", "--out", str(run)]) == 0
    out = tmp_path / "ekf.rrd"
    assert main(["view", str(run), "--out", str(out)]) == 0
    assert f"-> {out}" in capsys.readouterr().out
    record = read_run_dir(run)
    entities = read_back(out)
    for path in (
        "/world/ground_truth/path",
        "/world/estimate/path",
        "/world/estimate/robot",
        "/world/estimate/landmarks",
        "/world/estimate/landmark_covariances",
        "/world/ground_truth/landmarks",
        "/world/estimate/pose_covariance",
        "/world/sightings",
        "/errors/position_m",
        "/run",
    ):
        assert path in entities, sorted(entities)

    # the estimate is drawn SE(2)-aligned to the ground truth, exactly as its ATE aligns it
    result = ate(record.estimate.trajectory, record.ground_truth.trajectory, Alignment.SE2)
    T = result.gtTest
    expected = record.estimate.trajectory.positions_w @ T[:3, :3].T + T[:3, 3]
    strip = np.array(_column(entities["/world/estimate/path"], "strips")[0][0])
    assert strip.shape == expected.shape
    assert np.max(np.abs(strip - expected)) < FLOAT32_TOL_M
    truth = np.array(_column(entities["/world/ground_truth/path"], "strips")[0][0])
    assert np.max(np.abs(truth - record.ground_truth.trajectory.positions_w)) < FLOAT32_TOL_M

    # one ellipsoid per landmark, its axes those of the landmark's covariance (rotated too)
    estimate = record.estimate
    ellipsoids = entities["/world/estimate/landmark_covariances"]
    half_sizes = np.array(_column(ellipsoids, "half_sizes")[0])
    rotated = T[:3, :3] @ estimate.landmark_covariances @ T[:3, :3].T
    expected_half, _ = covariance_ellipsoids(rotated)
    assert half_sizes.shape == (len(estimate.landmark_ids), 3)
    assert np.allclose(np.sort(half_sizes, axis=1), np.sort(expected_half, axis=1), rtol=1e-5)

    # per frame: a pose, its error, its covariance ellipse, its sightings
    frames = len(estimate.trajectory)
    robot = entities["/world/estimate/robot"]
    assert sum("Transform3D:translation" in row for row in robot) == frames
    errors = [v[0] for v in _column(entities["/errors/position_m"], "scalars")]
    assert np.allclose(sorted(errors), sorted(result.errors_m), atol=1e-9)
    assert len(entities["/world/estimate/pose_covariance"]) == frames
    rays = [r for r in _column(entities["/world/sightings"], "strips") if r]
    assert rays and all(len(segment) == 2 for strips in rays for segment in strips)
    text = _column(entities["/run"], "text")[0][0]
    assert "ekfslam on" in text and "SE(2)-aligned" in text


def test_an_image_dataset_shows_each_image_with_its_sightings(tmp_path, capsys):
    pytest.importorskip("cv2")
    from omnislam.datasets.synthetic.presets import PRESETS
    from omnislam.datasets.synthetic.simulate import simulate
    from omnislam.datasets.synthetic.writer import write_synthetic

    data = write_synthetic(tmp_path / "demo", simulate(PRESETS["demo"], 0, max_images=3))
    run = tmp_path / "run"
    assert main(["run", str(data), "--estimator", "ekfslam", "--out", str(run)]) == 0
    out = tmp_path / "demo.rrd"
    assert main(["view", str(run), "--out", str(out)]) == 0
    entities = read_back(out)
    images = entities["/camera/image"]
    assert len(images) == 3
    assert all(row["EncodedImage:media_type"] == ["image/jpeg"] for row in images)
    sightings = entities["/camera/image/sightings"]
    assert len(sightings) == 3
    record = read_run_dir(run)
    from omnislam.frontend.observation_log import load_observation_log

    log = load_observation_log(Path(record.config.frontend_log))
    logged = sorted(len(p) for p in _column(sightings, "positions"))
    assert logged == sorted(len(log.pixels[i]) for i in log.image_frames)
    assert logged[-1] > 20  # keypoints of the omni bearings


def test_view_refuses_what_is_not_a_run_dir_and_an_existing_recording(tmp_path, capsys):
    assert main(["view", str(tmp_path)]) == 2
    assert "not a RUN_DIR" in capsys.readouterr().err
    data = write_small_mrclam(tmp_path / "MRCLAM_Small")
    run = tmp_path / "run"
    assert main(["run", str(data), "--estimator", "deadreckoning", "--out", str(run)]) == 0
    assert main(["view", str(run)]) == 0
    assert (run / "run.rrd").is_file()
    capsys.readouterr()
    assert main(["view", str(run)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--overwrite" in err
    assert main(["view", str(run), "--overwrite", "--no-images"]) == 0
