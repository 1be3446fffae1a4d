"""How far apart consecutive sightings of one laser landmark lie, against their stated noise.

For each CARMEN log (the shared front end's log: persistent spikes and corners), every
sighting and the nearest sighting of the previous scan are placed in the world with the
*corrected* poses (the pseudo ground truth); pairs closer than 0.5 m are taken as one landmark
seen twice. Per range band the script prints the pairs' median distance and the squared
Mahalanobis distance d2 of their difference under the sum of the two sightings' Cartesian
covariances (``laser_landmarks.sighting_noise`` with each ``--floors`` value of
``LaserLandmarkConfig.sigma_floor_m``; chi-square(2): median 1.39, 1 % beyond 9.21). The
corrected poses carry errors of their own (cm), so d2 is an upper bound of the sightings'::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python
        benchmarks/laser_sighting_noise.py [carmen-intel carmen-aces] [--floors 0 0.03]
        [--logs LOG ...]
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace

import numpy as np

from omnislam.core.measurement import RangeBearing2D
from omnislam.datasets.registry import load_dataset, resolve
from omnislam.frontend.config import LaserLandmarkConfig
from omnislam.frontend.laser_landmarks import sighting_noise
from omnislam.frontend.observation_log import dataset_fingerprint, load_observation_log
from omnislam.harness.cache import cache_dir
from omnislam.harness.execute import frontend_log_for
from omnislam.harness.layout import LOGS

#: range bands of the table [m]
BANDS_M = ((0.0, 1.0), (1.0, 2.0), (2.0, 4.0), (4.0, 9.0))
#: two sightings of consecutive scans closer than this are one landmark [m]
SAME_LANDMARK_M = 0.5


def consecutive_pairs(dataset: str, log_path: str | None) -> list[tuple[np.ndarray, ...]]:
    """(point_a, point_b, range_a, range_b, bearing_a, bearing_b, heading_a, heading_b) of each
    sighting and its nearest neighbour in the previous scan, placed with the corrected poses."""
    sequence = load_dataset(resolve(dataset), {})
    if log_path is None:
        print(
            f"{dataset}: the shared front end's log (from the cache, else run on the scans), "
            "then pairing consecutive sightings ...",
            file=sys.stderr,
            flush=True,
        )
    path = log_path or frontend_log_for(sequence, dataset, cache_dir() / LOGS)
    log = load_observation_log(path, dataset_id=dataset_fingerprint(sequence))
    wTr = sequence.ground_truth.trajectory.se2
    model = RangeBearing2D()
    pairs: list[tuple[np.ndarray, ...]] = []
    previous = None
    for i, frame in enumerate(log.frames):
        rb = frame.range_bearing
        if rb is None or not len(rb):
            previous = None
            continue
        world, _, _ = model.inverse(wTr[i], np.column_stack([rb.ranges_m, rb.bearings_rad]))
        if previous is not None:
            p_world, p_r, p_b, p_heading = previous
            for k in range(len(rb)):
                gap = np.linalg.norm(p_world - world[k], axis=1)
                j = int(np.argmin(gap))
                if gap[j] < SAME_LANDMARK_M:
                    pairs.append(
                        (
                            p_world[j],
                            world[k],
                            p_r[j],
                            rb.ranges_m[k],
                            p_b[j] + p_heading,
                            rb.bearings_rad[k] + wTr[i, 2],
                        )
                    )
        previous = (world, rb.ranges_m, rb.bearings_rad, wTr[i, 2])
    return pairs


def world_covariance(r: float, b_w: float, config: LaserLandmarkConfig) -> np.ndarray:
    """(2, 2) covariance of a sighting's world point: range r, world bearing b_w."""
    sr, sb = sighting_noise(np.array([r]), config)
    _, _, J_z = RangeBearing2D().inverse(np.zeros(3), np.array([r, b_w]))  # heading 0: world
    return J_z @ np.diag([sr[0] ** 2, sb[0] ** 2]) @ J_z.T


def report(dataset: str, log_path: str | None, floors: list[float]) -> None:
    """Print the table of the module docstring for one dataset."""
    pairs = consecutive_pairs(dataset, log_path)
    dist = np.array([np.linalg.norm(a - b) for a, b, *_ in pairs])
    near = np.array([min(ra, rb) for _, _, ra, rb, _, _ in pairs])
    print(f"{dataset}: {len(pairs)} consecutive pairs, median distance {np.median(dist):.3f} m")
    for floor in floors:
        config = replace(LaserLandmarkConfig(), sigma_floor_m=floor)
        d2 = np.array(
            [
                (a - b)
                @ np.linalg.solve(
                    world_covariance(ra, ba, config) + world_covariance(rb, bb, config), a - b
                )
                for a, b, ra, rb, ba, bb in pairs
            ]
        )
        print(
            f"  floor {floor:.3f} m: d2 median {np.median(d2):.2f}, "
            f"beyond 9.21 {np.mean(d2 > 9.21):.2f}"
        )
        for lo, hi in BANDS_M:
            band = (near >= lo) & (near < hi)
            if band.any():
                print(
                    f"    {lo:.0f}-{hi:.0f} m: {band.sum():4d} pairs, distance median "
                    f"{np.median(dist[band]):.3f} m, d2 median {np.median(d2[band]):.2f}, "
                    f"beyond 9.21 {np.mean(d2[band] > 9.21):.2f}"
                )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("datasets", nargs="*", default=["carmen-intel", "carmen-aces"])
    parser.add_argument("--floors", nargs="+", type=float, default=[0.0, 0.03])
    parser.add_argument("--logs", nargs="*", default=None, help="one front-end log per dataset")
    args = parser.parse_args()
    logs = args.logs or [None] * len(args.datasets)
    for dataset, log in zip(args.datasets, logs, strict=True):
        report(dataset, log, args.floors)


if __name__ == "__main__":
    main()
