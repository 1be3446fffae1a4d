"""Calibration: board geometry, pose transfer, ray DLT, Jacobians, recovery, files, CLI.

Heavy fits run through the CLI in a subprocess (it pins BLAS to one thread; threaded BLAS on
a loaded 2-core machine made each solver SVD 100-300x slower).
"""

import dataclasses
import subprocess
import sys

import numpy as np
import pytest
import scipy.io
import yaml

from omnislam.camera import HyperbolicCamera, OCamCalibCamera, UnifiedCamera, load_camera
from omnislam.camera.calibration import (
    Board,
    BoardView,
    Model,
    calibrate,
    read_points,
    read_points_csv,
    transfer_pose,
    write_points_csv,
)
from omnislam.camera.calibration.fit import BundleProblem, pose_matrix
from omnislam.camera.calibration.initialise import pose_from_rays
from omnislam.camera.calibration.parameters import (
    HyperbolicParameters,
    OCamCalibParameters,
    UnifiedParameters,
)
from omnislam.camera.calibration.render import random_board_poses, render_board
from omnislam.camera.io import save_camera
from omnislam.errors import DataError

#: analytic-vs-numerical Jacobian agreement (relative to the column's scale)
JACOBIAN_RTOL = 1e-5
#: a parameter counts as recovered within this many stated standard deviations
RECOVERY_SIGMAS = 3.0
#: noise-free synthetic corners: recovered parameters within this relative error
EXACT_RTOL = 1e-6
#: cornerSubPix on the renderer's boards (default supersampling): RMS distance to the exact
#: projection [px]
RENDERED_CORNER_RMS_PX = 0.09
#: the target for the VMR toolbox points [px]
VMR_GOAL_PX = 0.5

SMALL_BOARD = Board(4, 5, 0.06)
UNIFIED_TRUTH = UnifiedCamera(
    xi=0.9,
    gamma1=260.0,
    gamma2=262.0,
    cu=322.0,
    cv=318.0,
    width=640,
    height=640,
    k1=-0.05,
    k2=0.01,
    p1=0.001,
    p2=-0.0005,
)
HYPERBOLIC_TRUTH = HyperbolicCamera(b_m=0.025, focal_length_m=6.0e-3, cu=321.0, cv=317.5)
OCAM_TRUTH = OCamCalibCamera(
    pol=(-170.0, 0.0, 1.6e-3, -1.0e-7, 2.0e-10),
    invpol=(1.0,),
    center_row=318.0,
    center_col=322.0,
    c=1.001,
    d=0.0,
    e=0.002,
    width=640,
    height=640,
)


def synthetic_views(camera, board, count, rng, noise_px=0.0):
    poses = random_board_poses(camera, board, count, rng)
    views = []
    for k, cTb in enumerate(poses):
        pixels, _ = camera.project(board.points_b() @ cTb[:3, :3].T + cTb[:3, 3])
        pixels = pixels + rng.normal(0.0, noise_px, pixels.shape)
        views.append(BoardView(f"view{k}", pixels, board.points_b()))
    return views, poses


def run_cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "omnislam", "calibrate", *map(str, args)],
        capture_output=True,
        text=True,
        check=False,
    )


# -- geometry ---------------------------------------------------------------------------------


def test_board_points_are_row_by_row_and_parse_rejects_garbage():
    board = Board.parse("3x2", 0.1)
    assert np.allclose(board.points_b()[:4], [[0, 0, 0], [0.1, 0, 0], [0.2, 0, 0], [0, 0.1, 0]])
    with pytest.raises(DataError, match="COLSxROWS"):
        Board.parse("6-7", 0.1)


@pytest.mark.parametrize(
    "M", [np.diag([1.0, 1.0, -1.0]), np.array([[0.0, 1, 0], [1, 0, 0], [0, 0, -1]])]
)
def test_transfer_pose_keeps_every_board_point_and_a_proper_rotation(M, rng):
    cTb = pose_matrix(np.r_[rng.normal(size=3), rng.normal(size=3)])
    points_b = SMALL_BOARD.points_b()
    moved = transfer_pose(M, cTb)
    expected = (points_b @ cTb[:3, :3].T + cTb[:3, 3]) @ M.T
    assert np.allclose(points_b @ moved[:3, :3].T + moved[:3, 3], expected)
    assert np.linalg.det(moved[:3, :3]) == pytest.approx(1.0)


def test_ray_dlt_recovers_the_pose_of_exact_rays(rng):
    for _ in range(5):
        cTb = pose_matrix(np.r_[rng.normal(size=3), rng.normal(size=3)])
        points_c = SMALL_BOARD.points_b() @ cTb[:3, :3].T + cTb[:3, 3]
        rays = points_c / np.linalg.norm(points_c, axis=1, keepdims=True)
        assert np.allclose(pose_from_rays(rays, SMALL_BOARD.points_b()), cTb, atol=1e-9)


# -- Jacobian ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("truth", "parameters"),
    [
        (UNIFIED_TRUTH, UnifiedParameters(UNIFIED_TRUTH)),
        (HYPERBOLIC_TRUTH, HyperbolicParameters(HYPERBOLIC_TRUTH)),
        (OCAM_TRUTH, OCamCalibParameters(OCAM_TRUTH, radius_px=320.0)),
    ],
    ids=["unified", "hyperbolic", "ocamcalib"],
)
def test_jacobian_matches_central_differences_of_the_residuals(truth, parameters, rng):
    views, poses = synthetic_views(truth, SMALL_BOARD, 2, rng)
    problem = BundleProblem(views, parameters)
    theta = problem.pack(truth, poses)
    J = problem.jacobian(theta)
    steps = 1e-6 * (np.abs(theta) + np.r_[parameters.typical, np.full(12, 0.1)])
    numerical = np.empty_like(J)
    for j, h in enumerate(steps):
        d = np.zeros_like(theta)
        d[j] = h
        numerical[:, j] = (problem.residuals(theta + d) - problem.residuals(theta - d)) / (2 * h)
    scale = np.abs(numerical).max(axis=0) + 1e-12
    assert np.max(np.abs(J - numerical) / scale) < JACOBIAN_RTOL


# -- recovery on synthetic corners ------------------------------------------------------------


@pytest.mark.parametrize(
    ("model", "truth"),
    [(Model.UNIFIED, UNIFIED_TRUTH), (Model.HYPERBOLIC, HYPERBOLIC_TRUTH)],
    ids=["unified", "hyperbolic"],
)
def test_noise_free_corners_give_the_true_camera(model, truth, rng):
    views, _ = synthetic_views(truth, SMALL_BOARD, 4, rng)
    result = calibrate(views, model, truth.width, truth.height)
    assert result.rms_px < 1e-6
    for name, value in result.values.items():
        assert value == pytest.approx(getattr(truth, name), rel=EXACT_RTOL, abs=1e-9), name


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_noisy_corners_recover_the_hyperbolic_camera_within_its_std(seed):
    rng = np.random.default_rng(seed)
    views, _ = synthetic_views(HYPERBOLIC_TRUTH, SMALL_BOARD, 5, rng, noise_px=0.3)
    result = calibrate(views, Model.HYPERBOLIC, 640, 640)
    for name, value in result.values.items():
        error = abs(value - getattr(HYPERBOLIC_TRUTH, name))
        assert error < RECOVERY_SIGMAS * result.std[name], (name, error, result.std[name])
    assert result.sigma_px == pytest.approx(0.3, rel=0.25)


def test_too_few_views_is_an_error(rng):
    from omnislam.errors import EstimationError

    views, _ = synthetic_views(HYPERBOLIC_TRUTH, SMALL_BOARD, 2, rng)
    with pytest.raises(EstimationError, match="needs >= 3"):
        calibrate(views, Model.UNIFIED, 640, 640)


# -- files ------------------------------------------------------------------------------------


def test_csv_round_trip_and_malformed_line(tmp_path, rng):
    views, _ = synthetic_views(HYPERBOLIC_TRUTH, SMALL_BOARD, 2, rng)
    write_points_csv(views, tmp_path / "p.csv")
    back, skipped = read_points_csv(tmp_path / "p.csv")
    assert not skipped and [v.name for v in back] == [v.name for v in views]
    for a, b in zip(views, back, strict=True):
        assert np.array_equal(a.pixels, b.pixels) and np.array_equal(a.points_b, b.points_b)
    (tmp_path / "bad.csv").write_text("image,u,v,x_m,y_m\na,1,2,x,0\n")
    with pytest.raises(DataError, match="line 2"):
        read_points_csv(tmp_path / "bad.csv")


def cells(*items):
    """A 1 x N MATLAB cell array."""
    out = np.empty((1, len(items)), dtype=object)
    for k, item in enumerate(items):
        out[0, k] = np.atleast_2d(item)
    return out


def test_mat_shifts_matlab_pixels_and_skips_inconsistent_images(tmp_path):
    X = np.vstack([SMALL_BOARD.points_b()[:, :2].T * 1e3, np.zeros(SMALL_BOARD.size)])
    x = np.vstack([np.arange(20.0) + 1, np.arange(20.0) + 11])
    grid = {
        "x": cells(x, x[:, :19], x),
        "X": cells(X, X, X),
        "n_sq_x": cells(3, 3, 5),
        "n_sq_y": cells(4, 4, 4),
        "dX": cells(60, 60, 60),
    }
    scipy.io.savemat(tmp_path / "g.mat", {"gridInfo": grid})
    views, skipped = read_points(tmp_path / "g.mat", SMALL_BOARD)
    assert [v.name for v in views] == ["image0"]
    assert np.allclose(views[0].pixels[0], [0.0, 10.0])  # MATLAB (1, 11) -> (0, 10)
    assert np.allclose(views[0].points_b, SMALL_BOARD.points_b())  # mm -> m
    assert [str(s) for s in skipped] == [
        "image1: 19 image points but 20 board points; skipped",
        "image2: board 4x5 given but the file says 6x5 corners; skipped",
    ]


def test_camera_file_metadata_is_ignored_on_load(tmp_path):
    save_camera(UNIFIED_TRUTH, tmp_path / "c.yaml", {"reprojection_rms_px": 0.3})
    assert load_camera(tmp_path / "c.yaml") == UNIFIED_TRUTH
    assert yaml.safe_load((tmp_path / "c.yaml").read_text())["reprojection_rms_px"] == 0.3
    with pytest.raises(DataError, match="metadata"):
        save_camera(UNIFIED_TRUTH, tmp_path / "d.yaml", {"rms": 0.3})


# -- the command on rendered images and on the VMR samples ------------------------------------


def rendered_set(tmp_path, camera, board, count, seed):
    rng = np.random.default_rng(seed)
    import cv2

    paths = []
    for k, cTb in enumerate(random_board_poses(camera, board, count, rng)):
        paths.append(tmp_path / f"board{k}.png")
        cv2.imwrite(str(paths[-1]), render_board(camera, board, cTb))
    return paths


def test_rendering_supersamples_every_pixel_an_edge_can_cross():
    from omnislam.camera.calibration import render

    board = Board(6, 7, 0.05)
    (cTb,) = random_board_poses(HYPERBOLIC_TRUTH, board, 1, np.random.default_rng(3))
    R, origin_b = cTb[:3, :3], -cTb[:3, :3].T @ cTb[:3, 3]
    offsets = (np.arange(3) + 0.5) / 3 - 0.5
    v, u = np.mgrid[0:640, 0:640]
    full = sum(
        render._pattern(
            HYPERBOLIC_TRUTH, board, R, origin_b, np.column_stack([u.ravel() + du, v.ravel() + dv])
        )
        for dv in offsets
        for du in offsets
    )
    full = np.clip(np.round(full / 9), 0, 255).astype(np.uint8).reshape(640, 640)
    assert np.array_equal(render_board(HYPERBOLIC_TRUTH, board, cTb, supersample=3), full)


def test_detected_corners_of_rendered_boards_are_near_the_exact_projection():
    from omnislam.camera.calibration.detect import detect_corners

    board = Board(6, 7, 0.05)
    errors = []
    for cTb in random_board_poses(UNIFIED_TRUTH, board, 2, np.random.default_rng(12)):
        exact, _ = UNIFIED_TRUTH.project(board.points_b() @ cTb[:3, :3].T + cTb[:3, 3])
        detected = detect_corners(render_board(UNIFIED_TRUTH, board, cTb), board)
        nearest = np.linalg.norm(detected[:, None] - exact[None], axis=2).min(axis=1)
        errors.append(nearest)
    # measured 0.061 px on these two views (0.118 px with supersample=2)
    assert np.sqrt(np.mean(np.concatenate(errors) ** 2)) < RENDERED_CORNER_RMS_PX


def test_rendered_hyperbolic_images_recover_the_camera_within_its_std(tmp_path):
    board = Board(6, 7, 0.05)
    paths = rendered_set(tmp_path, HYPERBOLIC_TRUTH, board, 5, seed=7)
    blank = tmp_path / "blank.png"
    import cv2

    cv2.imwrite(str(blank), np.full((640, 640), 110, np.uint8))
    out = tmp_path / "cam.yaml"
    result = run_cli(
        *paths, blank, "--board", "6x7", "--square", 0.05, "--model", "hyperbolic", "--out", out
    )
    assert result.returncode == 0, result.stderr
    assert "blank.png: board 6x7 not found; skipped" in result.stderr
    camera = load_camera(out)
    saved = yaml.safe_load(out.read_text())
    std = saved["calibration"]["std"]
    for name in ("b_m", "focal_length_m", "cu", "cv"):
        error = abs(getattr(camera, name) - getattr(HYPERBOLIC_TRUTH, name))
        assert error < RECOVERY_SIGMAS * std[name], (name, error, std[name])
    rms = float(result.stdout.strip().splitlines()[-1].removeprefix("rms_px: "))
    assert rms == pytest.approx(saved["reprojection_rms_px"], abs=1e-4)
    assert (tmp_path / "cam_report" / "residuals.png").exists()


def test_fewer_than_three_usable_images_exit_2_with_one_line(tmp_path):
    views, _ = synthetic_views(HYPERBOLIC_TRUTH, SMALL_BOARD, 3, np.random.default_rng(0))
    bad = dataclasses.replace(
        views[1], pixels=views[1].pixels[:19], points_b=views[1].points_b[:19]
    )
    write_points_csv([views[0], bad, views[2]], tmp_path / "p.csv")
    result = run_cli(
        "--points",
        tmp_path / "p.csv",
        "--board",
        "4x5",
        "--square",
        0.06,
        "--image-size",
        "640x640",
        "--out",
        tmp_path / "c.yaml",
    )
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert lines == [
        "omnislam calibrate: error: 2 usable image(s) left; a calibration needs at least 3 "
        "(first left out: view1: 19 points but the 4x5 board has 20 corners; skipped)"
    ]
    assert not (tmp_path / "c.yaml").exists()


@pytest.mark.parametrize("model", ["unified", "ocamcalib"])
def test_vmr_toolbox_points_reach_the_goal(shared_data, tmp_path, model):
    folder = shared_data / "omni_real" / "vmr_lab_ocamcalib_samples"
    images = sorted(folder.glob("VMRImage*.jpg"))
    out = tmp_path / "cam.yaml"
    result = run_cli(
        *images, "--points", folder / "VMRImagePts.mat", "--model", model, "--out", out
    )
    assert result.returncode == 0, result.stderr
    rms = float(result.stdout.strip().splitlines()[-1].removeprefix("rms_px: "))
    assert rms <= VMR_GOAL_PX
    assert load_camera(out).MODEL == model


@pytest.mark.slow
def test_vmr_detected_corners_match_the_toolbox_and_the_fit(shared_data, tmp_path):
    folder = shared_data / "omni_real" / "vmr_lab_ocamcalib_samples"
    images = sorted(folder.glob("VMRImage*.jpg"))
    toolbox, _ = read_points(folder / "VMRImagePts.mat", names=[p.name for p in images])
    result = run_cli(
        *images,
        "--board",
        "6x7",
        "--square",
        0.03,
        "--out",
        tmp_path / "d.yaml",
        "--save-points",
        tmp_path / "d.csv",
    )
    assert result.returncode == 0, result.stderr
    detected = {v.name: v for v in read_points_csv(tmp_path / "d.csv")[0]}
    for view in toolbox:
        d = np.linalg.norm(view.pixels[:, None] - detected[view.name].pixels[None], axis=2)
        assert d.min(axis=1).max() < 1.0
    fit_toolbox = run_cli(
        *images, "--points", folder / "VMRImagePts.mat", "--out", tmp_path / "t.yaml"
    )
    rms = [float(r.stdout.strip().splitlines()[-1].split()[1]) for r in (result, fit_toolbox)]
    assert abs(rms[0] - rms[1]) < 0.1


@pytest.mark.slow
@pytest.mark.parametrize(
    ("model", "seed"),
    [
        ("unified", 11),
        ("unified", 12),  # with supersample=2: k2 off by 3.1 std (render aliasing, see render)
        ("hyperbolic", 13),
    ],
)
@pytest.mark.slow
def test_rendered_images_recover_the_camera_on_more_seeds(tmp_path, model, seed):
    truth = UNIFIED_TRUTH if model == "unified" else HYPERBOLIC_TRUTH
    paths = rendered_set(tmp_path, truth, Board(6, 7, 0.05), 8, seed)
    out = tmp_path / "cam.yaml"
    result = run_cli(*paths, "--board", "6x7", "--square", 0.05, "--model", model, "--out", out)
    assert result.returncode == 0, result.stderr
    camera, std = load_camera(out), yaml.safe_load(out.read_text())["calibration"]["std"]
    for name, s in std.items():
        error = abs(getattr(camera, name) - getattr(truth, name))
        assert error < RECOVERY_SIGMAS * s, (name, error, s)
