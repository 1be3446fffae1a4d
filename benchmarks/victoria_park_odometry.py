"""Victoria Park's odometry error against GPS, beside the spread of FastSLAM's motion models.

GPS gives positions only, so the statistic is heading-free: at frame i, the direction of the
chord from frame i to i+W minus that of the chord from i-W to i (how much the path turned), from
GPS and from the integrated odometry (the loader's Ackermann model); their difference over the
run (robust std, 1.4826 MAD) is the odometry's turn error over ~2W frames, GPS noise included
(so an upper bound), and the ratio of the two chord lengths its scale error. The same statistics
of each noise model come from sampling it (``OdometryMotionModel.sample``, 64 draws) along the
same odometry, for up to 150 of the windows::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python benchmarks/victoria_park_odometry.py
        [--windows 20 50]

Windows need GPS at the three frames and chords of at least ``MIN_CHORD_M``.
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np

from omnislam.core.motion import MotionNoise, OdometryMotionModel
from omnislam.core.se import se2_integrate, wrap_angle
from omnislam.datasets.registry import load_dataset, resolve
from omnislam.fastslam.config import DEFAULT_MOTION_NOISE

MIN_CHORD_M = 5.0
DRAWS = 64
MAX_SAMPLED_WINDOWS = 150


def _scaled(noise: MotionNoise, factor: float) -> MotionNoise:
    return replace(
        noise,
        a_vv=noise.a_vv * factor,
        a_vw=noise.a_vw * factor,
        a_wv=noise.a_wv * factor,
        a_ww=noise.a_ww * factor,
    )


MODELS = {
    "FastSLAM default (x2 the simulator's)": DEFAULT_MOTION_NOISE,
    "the simulator's (x0.5)": _scaled(DEFAULT_MOTION_NOISE, 0.5),
    "x0.25 of the default": _scaled(DEFAULT_MOTION_NOISE, 0.25),
    "default, reference_step_m=0.03": replace(DEFAULT_MOTION_NOISE, reference_step_m=0.03),
}


def chord_turn_and_length(xy: np.ndarray, i: int, w: int) -> tuple[float, float]:
    """(turn between the chords i-w -> i and i -> i+w [rad], length of the second [m])."""
    a, b = xy[i] - xy[i - w], xy[i + w] - xy[i]
    return float(np.arctan2(b[1], b[0]) - np.arctan2(a[1], a[0])), float(np.hypot(*b))


def robust_std(x: np.ndarray) -> float:
    return float(1.4826 * np.median(np.abs(x - np.median(x))))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--windows", type=int, nargs="+", default=[20, 50])
    args = parser.parse_args()
    sequence = load_dataset(resolve("victoria-park"), {})
    deltas = np.asarray(sequence.odometry_r)
    stamps = np.asarray(sequence.stamps_s)
    truth = sequence.ground_truth.trajectory
    gps = np.full((len(stamps), 2), np.nan)
    gps[np.searchsorted(stamps, truth.stamps_s)] = truth.positions_w[:, :2]
    odometry = se2_integrate(deltas)[:, :2]
    rng = np.random.default_rng(0)
    for w in args.windows:
        rows = []
        for i in range(w, len(stamps) - w, max(1, w // 2)):
            if np.isnan(gps[[i - w, i, i + w], 0]).any():
                continue
            if (
                min(np.hypot(*(gps[i + w] - gps[i])), np.hypot(*(gps[i] - gps[i - w])))
                < MIN_CHORD_M
            ):
                continue
            turn_gps, length_gps = chord_turn_and_length(gps, i, w)
            turn_odo, length_odo = chord_turn_and_length(odometry, i, w)
            rows.append((i, wrap_angle(turn_gps - turn_odo), length_gps / length_odo, length_odo))
        table = np.array(rows)
        print(
            f"W = {w} frames ({len(table)} windows, chords {np.median(table[:, 3]):.1f} m): "
            f"odometry vs GPS turn error {np.degrees(robust_std(table[:, 1])):.2f} deg "
            f"(median {np.degrees(np.median(table[:, 1])):.2f}), chord length ratio "
            f"{np.median(table[:, 2]):.4f} +- {robust_std(table[:, 2]):.4f}"
        )
        sampled = table[:: max(1, len(table) // MAX_SAMPLED_WINDOWS), 0].astype(int)
        for name, noise in MODELS.items():
            model = OdometryMotionModel(noise)
            turns, ratios = [], []
            for i in sampled:
                clean = se2_integrate(deltas[i - w : i + w + 1])[:, :2]
                turn_0, length_0 = chord_turn_and_length(clean, w, w)
                poses = np.zeros((DRAWS, 3))
                path = [poses[:, :2]]
                for k in range(i - w + 1, i + w + 1):
                    poses = model.sample(poses, deltas[k], rng)
                    path.append(poses[:, :2])
                paths = np.stack(path, axis=1)
                for xy in paths:
                    turn, length = chord_turn_and_length(xy, w, w)
                    turns.append(wrap_angle(turn - turn_0))
                    ratios.append(length / length_0)
            print(
                f"  {name:40s} turn std {np.degrees(np.std(turns)):.2f} deg, "
                f"length ratio std {np.std(ratios):.4f}"
            )


if __name__ == "__main__":
    main()
