"""Where in time a MR.CLAM run's error is: FastSLAM against iSAM2's causal read-out.

For one robot of MR.CLAM dataset 6 (ids) and filter seeds, FastSLAM (through the ``omnislam
run`` harness) and ``graphslam-online`` (iSAM2's newest pose after every step,
``fastslam_mrclam.py``) are scored over the run's twentieths: the RMS of the SE(2)-aligned
position error (the alignment of the whole run, as the ATE) and the last pose's error with the
first pose anchored (no fit: how far the estimate has moved from the start). Gaps of more than
10 s without a sighting are listed::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python benchmarks/fastslam_timeline.py
        [--robot 3] [--seeds 0] [--estimator fastslam2] [--set KEY=VALUE ...]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
from fastslam_mrclam import graphslam_online_trajectory
from harness_cells import set_options

from omnislam.core.types import Trajectory
from omnislam.datasets.registry import load_dataset, resolve
from omnislam.harness.execute import RunSpec, execute_run
from omnislam.metrics.trajectory import Alignment, associate, ate

PARTS = 20
#: a gap without sightings longer than this is listed [s]
GAP_S = 10.0


def errors(trajectory: Trajectory, truth: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    """(SE(2)-aligned, origin-anchored) position errors [m] at the truth's frames."""
    return (
        ate(trajectory, truth, Alignment.SE2).errors_m,
        ate(trajectory, truth, Alignment.ORIGIN).errors_m,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", type=int, default=3)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0])
    parser.add_argument("--estimator", default="fastslam2")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    options = set_options(parser, args.set)
    dataset = f"mrclam6-r{args.robot}"
    sequence = load_dataset(resolve(dataset), {})
    truth = sequence.ground_truth.trajectory
    print(f"{dataset}: running graphslam-online ...", file=sys.stderr, flush=True)
    runs = {"graphslam-online": graphslam_online_trajectory(dataset, {})}
    for seed in args.seeds:
        print(f"{dataset}: running {args.estimator} seed {seed} ...", file=sys.stderr, flush=True)
        record = execute_run(RunSpec(dataset, args.estimator, seed, options))
        runs[f"{args.estimator} s{seed}"] = record.estimate.trajectory
    scored = {name: errors(trajectory, truth) for name, trajectory in runs.items()}
    _, i_gt = associate(runs["graphslam-online"].stamps_s, truth.stamps_s)
    t = truth.stamps_s[i_gt] - sequence.stamps_s[0]
    n = t.size
    print(f"{dataset}: ATE " + ", ".join(
        f"{name} {np.sqrt(np.mean(e[0] ** 2)):.3f} m" for name, e in scored.items()
    ))
    print("time [s]        | SE(2)-aligned RMS [m] / origin-anchored at the end [m]: "
          + " | ".join(scored))
    for part in range(PARTS):
        rows = slice(part * n // PARTS, (part + 1) * n // PARTS)
        cells = [
            f"{np.sqrt(np.mean(se2[rows] ** 2)):.3f} / {origin[rows][-1]:.3f}"
            for se2, origin in scored.values()
        ]
        print(f"{t[rows][0]:6.0f}-{t[rows][-1]:6.0f} | " + " | ".join(cells))
    seen = np.array([
        f.range_bearing is not None and len(f.range_bearing) > 0 for f in sequence.frame_inputs()
    ])
    stamps = sequence.stamps_s[seen] - sequence.stamps_s[0]
    long = np.flatnonzero(np.diff(stamps) > GAP_S)
    print(f"gaps > {GAP_S:.0f} s without a sighting [s]: "
          + ", ".join(f"{stamps[k]:.0f}-{stamps[k + 1]:.0f}" for k in long))


if __name__ == "__main__":
    main()
