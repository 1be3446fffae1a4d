"""Steps 3-5 of Barra & Costa: photometric gate, candidates, u_shift windows, validation."""

from __future__ import annotations

import math

import numpy as np
from scipy.stats import chi2

from omnislam.camera.pinhole import PinholeCamera
from omnislam.camera.rig import CameraRig
from omnislam.ukf.association import PoseConsistency, associate_landmarks, set_score, validate
from omnislam.ukf.candidates import occluded, select_candidates
from omnislam.ukf.config import AssociationConfig, PhotometricConfig, TrackingConfig
from omnislam.ukf.filter import BearingPrediction
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
    tracked = track_lines(prev, now, np.array([0.0, 0.0, turn]), 0.01, TrackingConfig())
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
        TrackingConfig(),
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
    # two projections gated on one landmark: the pair the windows keep is no evidence either
    rivals = associate_landmarks(
        np.array([100.0, 104.0]), np.array([101.0]), np.zeros((2, 1)), CONFIG
    )
    assert len(rivals) == 0


def _consistency(innovations, line_variance, covariance, probability=0.999):
    """PoseConsistency with Pzz = ``covariance`` (deviations whose weighted outer product it
    is: one sigma point per column of its Cholesky factor, weight 1)."""
    deviations = np.linalg.cholesky(np.asarray(covariance, float)).T
    prediction = BearingPrediction(np.zeros(len(deviations)), deviations, np.ones(len(deviations)))
    return PoseConsistency(
        np.asarray(innovations, float), np.asarray(line_variance, float), prediction, probability
    )


def test_the_pregate_is_the_1_dof_chi_square_gate_on_each_pair():
    """y^2 / (sigma_i^2 + Pzz_jj) against chi2_1(0.999) = 10.83 (chi2_2 would be 13.82)."""
    gate = chi2.ppf(0.999, 1)
    s = 0.5 + 1.5  # line variance + the prediction's
    y = np.sqrt(s * np.array([[0.9 * gate, 1.1 * gate]]))
    consistency = _consistency(y, [0.5], np.diag([1.5, 1.5]))
    np.testing.assert_allclose(consistency.pair_distances(), [[0.9 * gate, 1.1 * gate]])
    assert consistency.pregate().tolist() == [[True, False]]


def test_the_consistent_subset_needs_both_the_joint_and_each_pairs_gate():
    """Independent pairs (S = 2 I): pair k's distance given the others is y_k^2 / 2.
    Three pairs of y = 2.9 sqrt(2): each 8.41 < chi2_1 = 10.83, jointly 25.2 > chi2_3 = 16.27, two
    16.8 > chi2_2 = 13.82: one pair is left. Five with one y = 3.4 sqrt(2): jointly 11.56 < chi2_5 =
    20.5, but that pair's 11.56 > 10.83: the other four are left."""
    lines = np.arange(5)
    root2 = np.sqrt(2.0)
    three = _consistency(np.diag([2.9, 2.9, 2.9]) * root2, np.full(3, 1.5), 0.5 * np.eye(3))
    assert three.consistent_subset(lines[:3], lines[:3]).size == 1
    five = _consistency(np.diag([0, 0, 3.4, 0, 0]) * root2, np.full(5, 1.5), 0.5 * np.eye(5))
    assert five.consistent_subset(lines, lines).tolist() == [0, 1, 3, 4]
    # the same innovation 4.5 on two landmarks sharing the pose error (Pzz 1.6, correlation
    # 0.99): alone 12.6 > 10.83 each, together 12.7 < 13.82 and 0.08 each given the other
    shared = np.array([[1.0, 0.99], [0.99, 1.0]])
    common = _consistency(np.diag([4.5, 4.5]), [1e-3, 1e-3], shared * 1.6)
    assert common.consistent_subset(lines[:2], lines[:2]).tolist() == [0, 1]


def test_the_nearest_line_is_measured_without_the_pairs_own_line_noise():
    """One pair (line 0, landmark 0): the prediction has mean 0 and variance Pzz = 1; line l
    is (y_l0)^2 / (Pzz + R_l) from it: line 0 (R 1, y 1.5) 1.125, line 1 (R 0, y 1.2) 1.44, so
    line 0 is the nearest (counting R_0 twice, 0.75 against 0.72, it would not be)."""
    consistency = _consistency([[1.5], [1.2]], [1.0, 0.0], [[1.0]])
    assert consistency.nearest_lines(np.array([0]), np.array([0])).tolist() == [True]
    farther = _consistency([[1.5], [1.0]], [1.0, 0.0], [[1.0]])
    assert farther.nearest_lines(np.array([0]), np.array([0])).tolist() == [False]


def test_a_window_ends_at_the_last_pair_within_its_spread_inclusive():
    """One 3 px window: shifts 0 and exactly 3 px share it (two pairs); a window ending before
    the second would leave ambiguous single pairs only (no association)."""
    config = AssociationConfig(windows_px=(3.0,))
    best = associate_landmarks(
        np.array([100.0, 203.0]), np.array([100.0, 200.0]), np.zeros((2, 2)), config
    )
    assert best.lines.tolist() == [0, 1] and best.candidates.tolist() == [0, 1]


def test_among_equal_matchings_the_window_keeps_shifts_nearest_its_median():
    """Lines 100 and 102.5 compete for the landmark at 101 (shifts -1, +1.5; equal C'_ij);
    the line at 300 matches 300 (shift 0). The 3 px window holds all three, median 0: the
    matching keeps the shift -1 (deviation 1 < 1.5), and no window holds only (0, 1.5)'s
    rival: the answer is lines 0 and 2."""
    best = associate_landmarks(
        np.array([100.0, 102.5, 300.0]), np.array([101.0, 300.0]), np.zeros((3, 2)), CONFIG
    )
    assert sorted(best.lines.tolist()) == [0, 2]
