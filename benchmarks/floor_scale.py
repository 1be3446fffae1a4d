"""The graph's floor scale on a front-end log: what ``graphslam.floor_scale.FloorScale`` sees.

Replays the log's bearings and the dataset's raw odometry through ``FloorScale`` (as
``GraphSLAM`` does) and prints the final scale, its supporting pairs, and every local maximum of
the weighted density of the pairs' log scales that it chooses the floor's from (the lowest
substantial one). Used to tell whether a front-end configuration keeps enough floor points
(issue 15: the keypoint budget left lab40's floor no mode of its own)::

    .venv/bin/python benchmarks/floor_scale.py runs/lab40 LOG [LOG ...]
"""

from __future__ import annotations

import argparse

import numpy as np

from omnislam.compare.execute import _load_log, _sensor_height_m
from omnislam.datasets.registry import load_dataset
from omnislam.graphslam import floor_scale as fs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", help="the rendered folder the logs were made from")
    parser.add_argument("logs", nargs="+", help="front-end logs (omnislam frontend --out LOG)")
    args = parser.parse_args()
    sequence = load_dataset(args.dataset, {})
    height = _sensor_height_m(sequence.calibration)
    if height is None:
        raise SystemExit(f"{args.dataset}: no camera rig, so no camera height")
    for log in args.logs:
        frames = sequence.frame_inputs(_load_log(sequence, log).frames)
        floor = fs.FloorScale(height)
        for frame in frames:
            floor.observe(frame.odometry.delta, frame.bearings)
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


if __name__ == "__main__":
    main()
