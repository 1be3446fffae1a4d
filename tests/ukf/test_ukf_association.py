"""Steps 3-5 of Barra & Costa: photometric gate, candidates, u_shift windows, validation."""

from __future__ import annotations

import math

import numpy as np

from omnislam.camera.pinhole import PinholeCamera
from omnislam.camera.rig import CameraRig
from omnislam.ukf.association import associate_landmarks, set_score, validate
from omnislam.ukf.candidates import occluded, select_candidates
from omnislam.ukf.config import AssociationConfig, PhotometricConfig
from omnislam.ukf.image_line import AngularLine, PerspectiveLine, image_line_from_rig
from omnislam.ukf.photometric import colour_differences, mc_from_pmc, photometric_scores
from omnislam.ukf.tracking import track_lines

CONFIG = AssociationConfig()


def test_mc_drops_the_centre_and_averages_each_side():
    profile = np.zeros((1, 3, 5))
    profile[0, :, :2] = 10.0
    profile[0, :, 2] = 999.0
    profile[0, :, 3:] = 50.0
    left, right = mc_from_pmc(profile)
    assert np.allclose(left, 10.0) and np.allclose(right, 50.0)


def test_photometric_gate_and_score_of_sec_3_2():
    left = np.array([[10.0, 10, 10], [10, 10, 10], [200, 200, 200]])
    right = np.array([[50.0, 50, 50], [90, 90, 90], [240, 240, 240]])
    band, mean = colour_differences(left[:1], right[:1], left, right)
    # same MC; band differs by 40 (rejected: 30 - 40 < 0); mean differs by 190 (rejected)
    assert np.allclose(band[0], [0.0, 40.0, 0.0]) and np.allclose(mean[0], [0.0, 20.0, 190.0])
    scores = photometric_scores(band, mean, PhotometricConfig())
    assert scores[0, 0] == 1.0 and np.isnan(scores[0, 1]) and np.isnan(scores[0, 2])
    partial = photometric_scores(np.array([[15.0]]), np.array([[50.0]]), PhotometricConfig())
    assert math.isclose(partial[0, 0], (0.7 * 15 + 0.3 * 50) / (0.7 * 30 + 0.3 * 100))
    unknown = photometric_scores(np.array([[np.nan]]), np.array([[np.nan]]), PhotometricConfig())
    assert unknown[0, 0] == 0.0


def test_set_score_is_eq_1():
    shift = np.array([1.0, 2.0, 3.0])
    u = np.array([100.0, 150.0, 300.0])
    sc, f = set_score(shift, u, np.array([0.5, 0.5, 0.5]), CONFIG)
    expected = math.sqrt(3) / (np.var(shift) + 2.0 * 150.0 / 7.0)  # largest gap: 300 - 150
    assert math.isclose(f, expected) and math.isclose(sc, 0.5 + 100 * expected)


def test_windows_keep_the_consistent_set_against_distractors():
    # five landmarks seen with a common shift of +2 px; distractor pairs shifted by 15-40 px
    expected = np.array([50.0, 120.0, 200.0, 330.0, 480.0])
    lines = np.concatenate([expected + 2.0 + [0.0, 0.3, -0.2, 0.1, 0.0], [135.0, 365.0]])
    scores = np.zeros((lines.size, expected.size))
    best = associate_landmarks(lines, expected, scores, CONFIG)
    assert sorted(zip(best.lines.tolist(), best.candidates.tolist(), strict=True)) == [
        (k, k) for k in range(5)
    ]


def test_the_largest_set_repeats_no_projection_or_landmark():
    # two projections 1 px apart compete for one landmark inside a 3 px window
    lines = np.array([100.0, 101.0, 300.0])
    expected = np.array([100.0, 300.0])
    scores = np.array([[0.2, np.nan], [0.9, np.nan], [np.nan, 0.5]])
    best = associate_landmarks(lines, expected, scores, CONFIG)
    assert len(set(best.lines.tolist())) == len(best) and len(set(best.candidates.tolist())) == len(
        best
    )
    assert (1, 0) in zip(
        best.lines.tolist(), best.candidates.tolist(), strict=True
    )  # the larger C'_ij


def test_gate_rejections_leave_nothing_to_associate():
    best = associate_landmarks(np.array([1.0]), np.array([1.0]), np.full((1, 1), np.nan), CONFIG)
    assert len(best) == 0 and best.score == -math.inf


def test_validation_needs_the_same_landmark_on_the_same_line_twice():
    previous = {0: 7, 1: 8, 2: 9}
    tracked_from = np.array([0, 2, -1, 1])
    now = {0: 7, 1: 8, 2: 9, 3: 8}
    # 0 <- 0 with 7 twice: valid; 1 <- 2 had 9, now 8: not; 2 is new; 3 <- 1 had 8: valid
    assert validate(now, tracked_from, previous) == {0: 7, 3: 8}


def test_step_3_tracks_lines_through_a_rotation_and_flags_new_ones():
    prev = np.array([0.5, 0.0, -0.4])
    turn = 0.1
    now = np.array([0.5 - turn, -0.4 - turn, 0.9])  # the first and third, plus a new line
    tracked = track_lines(prev, now, np.array([0.0, 0.0, turn]), 0.01, CONFIG, PhotometricConfig())
    assert tracked.tolist() == [0, 2, -1]


def test_step_3_uses_profiles_to_tell_close_lines_apart():
    prev = np.array([0.30, 0.31])
    now = np.array([0.305, 0.30])
    dark, bright = np.zeros((3, 5)), np.full((3, 5), 200.0)
    tracked = track_lines(
        prev,
        now,
        np.zeros(3),
        0.02,
        CONFIG,
        PhotometricConfig(),
        np.stack([dark, bright]),
        np.stack([bright, dark]),
    )
    assert tracked.tolist() == [1, 0]


def test_walls_occlude_but_not_the_line_on_its_own_wall():
    walls = np.array([[[2.0, -5.0], [2.0, 5.0]]])
    points = np.array([[4.0, 0.0], [2.0, 1.0], [1.0, 0.0]])
    assert occluded(np.zeros(2), points, walls, 0.05).tolist() == [True, False, False]


def test_candidates_need_range_and_the_widened_field_of_view():
    line = PerspectiveLine(focal_px=400.0, centre_px=320.0, half_width_px=320.0)
    # the image spans atan(320/400) = 38.7 deg; widened to twice: atan(640/400) = 58 deg
    b = np.deg2rad([0.0, 45.0, 57.0, 59.0, 120.0])
    points = np.column_stack([np.cos(b), np.sin(b)]) * 10.0
    points = np.vstack([points, [[60.0, 0.0]]])
    cands = select_candidates(np.zeros(3), points, np.zeros((0, 2, 2)), line, 50.0, 0.05)
    assert cands.index.tolist() == [0, 1, 2]
    assert np.allclose(cands.u_px, 320.0 - 400.0 * np.tan(b[:3]))


def test_the_image_line_of_a_pinhole_rig_matches_its_projection():
    camera = PinholeCamera(fx=400.0, fy=400.0, cu=319.5, cv=239.5, width=640, height=480)
    rTc = np.array([[0.0, 0, 1, 0], [-1, 0, 0, 0], [0, -1, 0, 1], [0, 0, 0, 1]])
    rig = CameraRig(camera=camera, rTc=rTc)
    line = image_line_from_rig(rig)
    b = np.linspace(-0.6, 0.6, 7)
    points = np.column_stack([np.cos(b) * 5, np.sin(b) * 5, np.ones_like(b)])
    pixels, _ = rig.project_r(points)
    assert np.allclose(line.u_px(b), pixels[:, 0], atol=1e-6)


def test_an_angular_line_widens_its_field_of_view():
    line = AngularLine(px_per_rad=100.0, fov_rad=1.0)
    assert line.in_widened_view(np.array([0.9, 1.1])).tolist() == [True, False]
    assert np.allclose(line.u_px(np.array([0.5])), 50.0)


def test_a_single_pair_is_used_only_when_no_other_pair_passed_its_gates():
    # one projection (MR.CLAM: one sighting, no colour): with one gated candidate it is the set,
    # with two it carries no evidence for either and the frame gets no pair
    alone = associate_landmarks(np.array([100.0]), np.array([101.0]), np.zeros((1, 1)), CONFIG)
    assert alone.lines.tolist() == [0] and alone.candidates.tolist() == [0]
    two = associate_landmarks(np.array([100.0]), np.array([101.0, 96.0]), np.zeros((1, 2)), CONFIG)
    assert len(two) == 0
    rejected = np.array([[0.0, np.nan]])  # the second candidate failed a gate: unambiguous again
    one = associate_landmarks(np.array([100.0]), np.array([101.0, 96.0]), rejected, CONFIG)
    assert one.candidates.tolist() == [0]
    paper = AssociationConfig(unambiguous_single=False)
    nearest = associate_landmarks(
        np.array([100.0]), np.array([101.0, 96.0]), np.zeros((1, 2)), paper
    )
    assert nearest.candidates.tolist() == [0]  # the smaller |u_shift|
