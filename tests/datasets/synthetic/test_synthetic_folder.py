"""Writer and loader: byte-identical output, atomic writes, Sequence contents, ground truth."""

from __future__ import annotations

import argparse
import hashlib
import json

import numpy as np
import pytest

from omnislam.datasets.sequence import GroundTruthKind
from omnislam.datasets.synthetic import (
    SyntheticFolder,
    cli_synth,
    is_synthetic_folder,
    load_synthetic,
    read_ground_truth_maps,
)
from omnislam.datasets.synthetic.presets import PRESETS
from omnislam.datasets.synthetic.render import Renderer
from omnislam.datasets.synthetic.writer import write_synthetic
from omnislam.errors import DataError

#: SIFT ratio test of the ground-truth check (DESIGN.md "SIFT / matching")
RATIO = 0.8
#: a match is correct when the true point of one keypoint lands this close to the other [px]
CORRECT_PX = 3.0


def _digests(folder):
    return {
        p.relative_to(folder).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


@pytest.mark.slow
def test_same_preset_and_seed_give_byte_identical_folders(tmp_path):
    pytest.importorskip("cv2")
    for name in ("a", "b"):
        args = argparse.Namespace(preset="demo", out=str(tmp_path / name), seed=7, frames=2,
                                  backend=None)
        assert cli_synth(args) == 0
    a, b = _digests(tmp_path / "a"), _digests(tmp_path / "b")
    assert a == b
    assert "images/000000.png" in a and "gt/000000.npz" in a and "world.json" in a


@pytest.mark.slow
def test_another_image_rate_keeps_the_world_route_and_odometry(tmp_path):
    pytest.importorskip("cv2")
    preset_k = PRESETS["demo"].image_every_k
    for name, every in (("preset", None), ("dense", 2)):
        args = argparse.Namespace(preset="demo", out=str(tmp_path / name), seed=3, frames=3,
                                  backend="numpy", image_every=every)
        assert cli_synth(args) == 0
    preset, dense = load_synthetic(tmp_path / "preset"), load_synthetic(tmp_path / "dense")
    assert preset.image_frames.tolist() == [0, preset_k, 2 * preset_k]
    assert dense.image_frames.tolist() == [0, 2, 4]
    shared = dense.stamps_s.size  # --frames keeps the frames up to the third image
    np.testing.assert_array_equal(dense.odometry_r, preset.odometry_r[:shared])
    np.testing.assert_array_equal(dense.stamps_s, preset.stamps_s[:shared])
    meta = [json.loads((tmp_path / n / "meta.json").read_text()) for n in ("preset", "dense")]
    assert [m["image_every_k"] for m in meta] == [preset_k, 2]
    assert (tmp_path / "dense" / "world.json").read_text() == (
        tmp_path / "preset" / "world.json"
    ).read_text()


def test_refuses_a_non_empty_folder_and_leaves_no_partial_output(tmp_path, demo_sim):
    out = tmp_path / "taken"
    out.mkdir()
    (out / "keep.txt").write_text("x")
    with pytest.raises(DataError, match="not empty"):
        write_synthetic(out, demo_sim, backend="numpy")
    assert (out / "keep.txt").exists()

    def crash(count: int) -> None:
        raise RuntimeError("simulated crash")

    with pytest.raises(RuntimeError):
        write_synthetic(tmp_path / "new", demo_sim, backend="numpy", progress=crash)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["taken"]


def test_loader_returns_the_simulated_sequence(demo_folder, demo_sim):
    assert is_synthetic_folder(demo_folder)
    seq = load_synthetic(demo_folder)
    assert len(seq) == demo_sim.stamps_s.size
    np.testing.assert_array_equal(seq.odometry_r, demo_sim.odometry_r)
    np.testing.assert_array_equal(seq.odometry_true_r, demo_sim.odometry_true_r)
    np.testing.assert_allclose(seq.ground_truth.trajectory.se2, demo_sim.poses_w, atol=1e-12)
    assert seq.ground_truth.kind is GroundTruthKind.EXACT
    np.testing.assert_array_equal(seq.image_frames, demo_sim.image_frames)
    assert seq.image(int(seq.image_frames[1])).shape == (640, 640, 3)
    assert seq.laser.ranges_m.shape == demo_sim.laser_ranges_m.shape
    seen = [i for rb in seq.range_bearing for i in rb.landmark_ids]
    assert set(seen) <= set(seq.ground_truth.landmark_ids)


def test_ground_truth_maps_equal_the_renderers(demo_folder, demo_sim):
    index = int(demo_sim.image_frames[2])
    maps = read_ground_truth_maps(demo_folder, index)
    meta_backend = SyntheticFolder(demo_folder).meta["backend"]
    frame = Renderer(demo_sim.world, demo_sim.rig, meta_backend).render(demo_sim.poses_w[index])
    np.testing.assert_array_equal(maps.surface_ids, frame.surface_ids)
    np.testing.assert_allclose(maps.points_w, frame.points_w, atol=1e-5, equal_nan=True)


def test_sift_matches_agree_with_the_ground_truth(demo_folder, demo_sim):
    cv2 = pytest.importorskip("cv2")
    folder = SyntheticFolder(demo_folder)
    frames = demo_sim.image_frames
    xy = demo_sim.poses_w[frames, :2]
    # the pair of images closest to 0.3 m apart
    gaps = np.linalg.norm(xy[:, None] - xy[None], axis=2)
    i, j = np.unravel_index(np.argmin(np.abs(gaps - 0.3)), gaps.shape)
    assert abs(gaps[i, j] - 0.3) < 0.1
    a, b = int(frames[i]), int(frames[j])
    sift = cv2.SIFT_create()
    mask = demo_sim.rig.camera.mask().astype(np.uint8)
    kp_a, des_a = sift.detectAndCompute(cv2.cvtColor(folder.image(a), cv2.COLOR_RGB2GRAY), mask)
    kp_b, des_b = sift.detectAndCompute(cv2.cvtColor(folder.image(b), cv2.COLOR_RGB2GRAY), mask)
    assert len(kp_a) >= 300 and len(kp_b) >= 300
    pairs = cv2.BFMatcher(cv2.NORM_L2).knnMatch(des_a, des_b, k=2)
    good = [m for m, n in pairs if m.distance < RATIO * n.distance]
    px_a = np.array([kp_a[m.queryIdx].pt for m in good])
    px_b = np.array([kp_b[m.trainIdx].pt for m in good])
    points_w, ids = folder.world_points(a, px_a)
    wTb = folder.groundtruth.poses_w[b]
    points_rb = (points_w - wTb[:3, 3]) @ wTb[:3, :3]
    projected, _ = folder.rig.project_r(points_rb)
    err = np.hypot(*(projected - px_b).T)
    correct = (ids >= 0) & (err < CORRECT_PX)
    assert correct.mean() >= 0.8, f"{correct.mean():.2f} of {len(good)} matches correct"
    assert np.median(err[correct]) <= 1.5


def test_the_prior_map_is_the_worlds_2d_map(demo_folder):
    from omnislam.datasets.synthetic.loader import SyntheticFolder, load_synthetic

    sequence = load_synthetic(demo_folder)
    prior, world = sequence.prior_map, SyntheticFolder(demo_folder).world
    assert prior is not None
    assert np.array_equal(prior.landmark_ids, sequence.ground_truth.landmark_ids)
    lines = {line.landmark_id: (line.x_m, line.y_m) for line in world.vertical_lines}
    assert set(prior.landmark_ids[prior.vertical_line].tolist()) == set(lines)
    for lid, point in zip(prior.landmark_ids.tolist(), prior.points_w, strict=True):
        if lid in lines:
            assert np.allclose(point, [*lines[lid], 0.0])
    assert len(prior.walls_w) == len(world.walls_2d) > 0
    assert np.allclose(prior.initial_pose_w, sequence.initial_pose_w)


def test_the_prior_map_carries_the_surveyed_line_colours(demo_folder):
    sequence = load_synthetic(demo_folder)
    prior = sequence.prior_map
    assert (demo_folder / "line_colours.csv").exists()
    assert prior.means_left is not None and "line_colours.csv" in prior.source
    lines = prior.vertical_line
    # poles carry no descriptors; the door-frame lines the images show do
    assert np.isnan(prior.means_left[~lines]).all()
    seen = np.isfinite(prior.means_left[:, 0]) & lines
    assert seen.any()


def test_a_bad_line_colours_row_is_one_error_naming_file_and_line(tmp_path, demo_folder):
    import shutil

    copy = tmp_path / "demo"
    shutil.copytree(demo_folder, copy)
    path = copy / "line_colours.csv"
    rows = path.read_text().splitlines()
    rows.append("999999,1,1,2,3,4,5,6")
    path.write_text("\n".join(rows) + "\n")
    with pytest.raises(DataError, match=rf"line {len(rows)}: landmark 999999") as info:
        load_synthetic(copy)
    assert "line_colours.csv" in str(info.value)


def test_a_table_with_its_header_only_is_empty_and_quiet(tmp_path, recwarn):
    from omnislam.datasets.synthetic.loader import _read_csv

    path = tmp_path / "poles.csv"
    path.write_text("frame,id,range_m,bearing_rad,sigma_range_m,sigma_bearing_rad\n")
    assert _read_csv(path, 6).values.shape == (0, 6)  # corridor21 has no poles
    assert not [w for w in recwarn if issubclass(w.category, UserWarning)]


def test_pixel_points_are_the_ground_truth_maps_at_those_pixels(demo_folder, demo_sim):
    folder = SyntheticFolder(demo_folder)
    index = int(demo_sim.image_frames[1])
    maps = folder.ground_truth_maps(index)
    h, w = maps.surface_ids.shape
    rng = np.random.default_rng(2)
    rows, cols = rng.integers(0, h, 500), rng.integers(0, w, 500)
    points = folder.pixel_points(index, rows, cols)
    assert points.dtype == np.float32 and points.shape == (500, 3)
    assert np.isnan(points).any() and np.isfinite(points).any()
    np.testing.assert_array_equal(points, maps.points_w[rows, cols])
    assert folder.pixel_points(index, rows[:0], cols[:0]).shape == (0, 3)
    with pytest.raises(DataError, match="outside"):
        folder.pixel_points(index, np.array([h]), np.array([0]))
