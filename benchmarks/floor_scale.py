"""The graph's floor scale on a front-end log: what ``graphslam.floor_scale.FloorScale`` sees.

Replays the log's bearings and the dataset's raw odometry through ``FloorScale`` (as
``GraphSLAM`` does) and prints the final scale, its supporting pairs, and every local maximum of
the weighted density of the pairs' log scales that it chooses the floor's from (the lowest
substantial one). Used to tell whether a front-end configuration keeps enough floor points
(a keypoint budget that leaves the floor too few keypoints gives it no mode of its own)::

    .venv/bin/python benchmarks/floor_scale.py runs/lab40 LOG [LOG ...]

``--truth`` (synthetic data): the same estimate fed the true odometry, the true rotations with
the logged translations, and the true step directions with the logged magnitudes, each against
its own true scale (1 for the truth, else the run's distance ratio true / logged), and the
logged / true distance ratio over the floor pairs (first and latest sighting >= 35 deg below the
horizon): where the floor scale's error comes from (docs/results/graph.md, "The
odometry's scale from the floor").
"""

from __future__ import annotations

import argparse

import numpy as np

from omnislam.core.se import se2_between, se2_compose
from omnislam.datasets.registry import load_dataset
from omnislam.graphslam import floor_scale as fs
from omnislam.harness.frames import load_log, sensor_height_m


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", help="the rendered folder the logs were made from")
    parser.add_argument("logs", nargs="+", help="front-end logs (omnislam frontend --out LOG)")
    parser.add_argument("--truth", action="store_true", help="the diagnostics against the truth")
    args = parser.parse_args()
    sequence = load_dataset(args.dataset, {})
    height = sensor_height_m(sequence.calibration)
    if height is None:
        raise SystemExit(f"{args.dataset}: no camera rig, so no camera height")
    for log in args.logs:
        frames = list(sequence.frame_inputs(load_log(sequence, log).frames))
        floor = fs.FloorScale(height)
        for frame in frames:
            floor.observe(frame.odometry.delta, frame.bearings)
        if args.truth:
            truth_diagnostics(sequence, frames, height, log)
        n = floor.pairs
        s, sigma = floor._s[:n], floor._sigma[:n]
        usable = np.isfinite(sigma) & (s > 0)
        log_s, sigma = np.log(s[usable]), sigma[usable]
        keep = np.abs(log_s) <= np.log(fs.MAX_SCALE)
        log_s, weights = log_s[keep], 1.0 / sigma[keep] ** 2
        if len(log_s) == 0:
            print(f"{log}: scale {floor.scale:.4f}; {n} floor pairs, none within "
                  f"1/{fs.MAX_SCALE}..{fs.MAX_SCALE}")
            continue
        grid = np.arange(-np.log(fs.MAX_SCALE), np.log(fs.MAX_SCALE), fs.MODE_BANDWIDTH / 4)
        kernel = np.exp(-0.5 * ((grid[:, None] - log_s[None, :]) / fs.MODE_BANDWIDTH) ** 2)
        density, count = kernel @ weights, kernel.sum(axis=1)
        print(
            f"{log}: scale {floor.scale:.4f} from {floor.inliers} pairs; {n} floor pairs, "
            f"{len(log_s)} within 1/{fs.MAX_SCALE}..{fs.MAX_SCALE}"
        )
        for i in range(1, len(grid) - 1):
            if density[i] >= density[i - 1] and density[i] >= density[i + 1]:
                print(
                    f"  mode {np.exp(grid[i]):.4f}: weighted density "
                    f"{density[i] / density.max():.3f} of the highest, ~{count[i]:.1f} pairs"
                )


def truth_diagnostics(sequence, frames, height: float, log: str) -> None:
    """``--truth``: the floor scale on partly true odometry, and the pairs' distance ratios."""
    true = sequence.ground_truth.trajectory.se2
    if len(true) != len(frames):
        raise SystemExit(f"{log}: the ground truth does not cover every frame")
    logged = np.array([np.asarray(f.odometry.delta, dtype=float) for f in frames])
    logged[0] = 0.0
    steps = np.zeros_like(logged)
    steps[1:] = se2_between(true[:-1], true[1:])
    ratio = np.hypot(*steps[:, :2].T).sum() / np.hypot(*logged[:, :2].T).sum()
    rotation = logged.copy()
    rotation[:, 2] = steps[:, 2]
    direction = steps.copy()
    moved = np.hypot(*steps[:, :2].T) > 1e-9
    direction[moved, :2] *= (np.hypot(*logged[moved, :2].T)
                             / np.hypot(*steps[moved, :2].T))[:, None]
    print(f"{log}: the run's true scale (distance true / logged) {ratio:.5f}")
    for name, deltas, target in [("true odometry", steps, 1.0),
                                 ("true rotations, logged translations", rotation, ratio),
                                 ("true directions, logged magnitudes", direction, ratio)]:
        floor = fs.FloorScale(height)
        for frame, delta in zip(frames, deltas, strict=True):
            floor.observe(delta, frame.bearings)
        print(f"  {name}: scale {floor.scale:.5f} ({floor.scale / target - 1:+.2%} of its "
              f"true {target:.5f}) from {floor.inliers} of {floor.pairs} pairs")
    raw = [np.zeros(3)]
    for delta in logged[1:]:
        raw.append(se2_compose(raw[-1], delta))
    raw = np.array(raw)
    max_uz = -np.sin(np.radians(fs.FLOOR_MIN_DEPRESSION_DEG))
    first: dict[int, int] = {}
    latest: dict[int, int] = {}
    for k, frame in enumerate(frames):
        bearings = frame.bearings
        if bearings is None or len(bearings) == 0:
            continue
        down = bearings.unit_vectors_r[:, 2] <= max_uz
        for lid in bearings.landmark_ids[down].tolist():
            first.setdefault(lid, k)
            latest[lid] = k
    ratios = []
    for lid, a in first.items():
        b = latest[lid]
        true_t = np.hypot(*se2_between(true[a], true[b])[:2])
        if true_t >= fs.MIN_BASELINE_M:
            ratios.append(np.hypot(*se2_between(raw[a], raw[b])[:2]) / true_t)
    ratios = np.array(ratios)
    if len(ratios):
        print(f"  logged / true distance over {len(ratios)} floor pairs: median "
              f"{np.median(ratios):.4f}, mean {ratios.mean():.4f}, std {ratios.std():.4f} "
              f"(the run's {1 / ratio:.4f})")


if __name__ == "__main__":
    main()
