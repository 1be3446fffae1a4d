"""``benchmarks/oracle_tracks.py`` corrects a log's tracks from the renderer's truth: a
sighting off its track's point is dropped, tracks of one point merge (never floor with
landmark), a frame keeps one sighting per merged track, and the true bearings point at the
track's point from the true viewpoint."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from omnislam.core.types import Bearings, FrameInput, Odometry
from omnislam.frontend.evaluation import Sightings
from omnislam.frontend.observation_log import ObservationLog

REPO = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location(
    "oracle_tracks", REPO / "benchmarks" / "oracle_tracks.py"
)
oracle = importlib.util.module_from_spec(_spec)
sys.modules["oracle_tracks"] = oracle
_spec.loader.exec_module(oracle)

P = np.array([2.0, 0.0, 1.0])  # the world point tracks 1 and 2 see
Q = np.array([0.0, 3.0, 0.5])  # track 3's point
FLOOR = np.array([1.0, 1.0, 0.0])  # floor track 100's point, 1 cm from landmark track 4's


def _sightings() -> Sightings:
    # frame 0: tracks 1 and 2 on P, 3 on Q; frame 1: track 1 on P, track 3 10 cm off Q,
    # landmark track 4 and floor track 100 a centimetre apart; frame 2: track 3 on Q
    frame = np.array([0, 0, 0, 1, 1, 1, 1, 2])
    track = np.array([1, 2, 3, 1, 3, 4, 100, 3])
    dx = np.array([1.0, 0.0, 0.0])
    points = np.array([P, P + 0.005, Q, P - 0.004, Q + 0.1 * dx, FLOOR + 0.01 * dx, FLOOR, Q])
    return Sightings(frame, frame * 0.1, track, points)


def test_off_point_sightings_are_dropped_and_same_point_tracks_merge() -> None:
    truth = oracle.track_truth(_sightings(), 0.02, floor_ids_from=100)
    assert truth.keep.tolist() == [True, True, True, True, False, True, True, True]
    assert truth.merged_id[1] == truth.merged_id[2] == 1
    assert truth.merged_id[3] == 3
    assert truth.merged_id[4] == 4 and truth.merged_id[100] == 100  # floor stays apart
    np.testing.assert_allclose(truth.point_of[3], Q)


def _log() -> ObservationLog:
    def frame(k: int, ids: list[int]) -> FrameInput:
        v = np.tile([1.0, 0.0, 0.0], (len(ids), 1))
        odo = Odometry(np.zeros(3), 0.1 * k)
        return FrameInput(k, odo, Bearings(np.array(ids), v, np.full(len(ids), 0.01)))

    frames = (frame(0, [1, 2, 3]), frame(1, [1, 3, 4, 100]), frame(2, [3]))
    pixels = (np.zeros((3, 2)), np.zeros((4, 2)), np.zeros((1, 2)))
    return ObservationLog("d", "c", frames, pixels, floor_ids_from=100)


def test_merged_tracks_keep_one_sighting_per_frame_and_true_bearings_hit_the_point() -> None:
    log = _log()
    truth = oracle.track_truth(_sightings(), 0.02, floor_ids_from=100)
    wTr = np.tile(np.eye(4), (3, 1, 1))
    wTr[1, :3, 3] = [0.5, 0.0, 0.0]
    viewpoint = np.array([0.0, 0.0, 0.4])
    rng = np.random.default_rng(0)
    merged = oracle.variant_log(log, truth, "merged", wTr, viewpoint, rng)
    assert merged.frames[0].bearings.landmark_ids.tolist() == [1, 3]  # 2 is 1, seen already
    assert merged.frames[1].bearings.landmark_ids.tolist() == [1, 4, 100]  # 3 off its point
    assert merged.pixels[1].shape == (3, 2)
    exact = oracle.variant_log(log, truth, "exact", wTr, viewpoint, rng)
    b = exact.frames[1].bearings
    to_p = truth.merged_point[1] - (wTr[1, :3, 3] + viewpoint)
    np.testing.assert_allclose(b.unit_vectors_r[0], to_p / np.linalg.norm(to_p), atol=1e-12)
    clean = oracle.variant_log(log, truth, "clean", wTr, viewpoint, rng)
    assert clean.frames[0].bearings.landmark_ids.tolist() == [1, 2, 3]
    np.testing.assert_array_equal(
        clean.frames[0].bearings.unit_vectors_r, log.frames[0].bearings.unit_vectors_r
    )


def test_noisy_truth_bearings_scatter_with_the_logged_sigma() -> None:
    d = np.tile([0.6, 0.8, 0.0], (20000, 1))
    sigma = np.full(20000, 0.01)
    out = oracle._tangent_noise(d, sigma, np.random.default_rng(1))
    angle = np.arccos(np.clip(out @ [0.6, 0.8, 0.0], -1, 1))
    # two tangent axes of std sigma: E[angle^2] = 2 sigma^2
    assert np.sqrt(np.mean(angle**2)) / 0.01 == pytest.approx(np.sqrt(2), rel=0.03)
    np.testing.assert_allclose(np.linalg.norm(out, axis=1), 1.0)


def test_returns_only_joins_a_track_that_starts_after_the_gap() -> None:
    # tracks 1 (t 0-1 s) and 2 (t 2 s) see P in passing, track 3 sees it again at t 100 s
    s = Sightings(
        np.array([0, 10, 20, 1000]),
        np.array([0.0, 1.0, 2.0, 100.0]),
        np.array([1, 1, 2, 3]),
        np.array([P, P, P, P]),
    )
    truth = oracle.track_truth(s, 0.02, floor_ids_from=None)
    assert truth.merged_id == {1: 1, 2: 1, 3: 1}
    returns = oracle.returns_only(truth, s, gap_s=60.0)
    assert returns.merged_id == {1: 1, 2: 2, 3: 2}  # the return joins the latest pass
