"""FastSLAM's read-outs on one front-end log: per seed, and averaged over independent runs.

For each estimator and seed, one ``omnislam run`` (through the harness, on ``--log`` so every
run sees the same input) gives the ATE (SE(2)-aligned) and the filter's log evidence
(``FastSLAMInfo.log_evidence``). Then the seeds are cut into consecutive groups of ``--group``
runs, and each group's trajectories are averaged (position mean, circular heading mean) two
ways: with equal weights (independent replicas of the filter, whose sampled odometry noise
and resampling choices differ) and with the runs' evidences as weights (the island particle
model with whole filters as islands and no resampling between them; Vergé, Dubarry, Del Moral
& Moulines 2015). Prints each group's ATE and the medians::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python benchmarks/fastslam_readout.py
        --log LOG [--dataset carmen-aces] [--estimators fastslam1 fastslam2] [--seeds 0 ... 29]
        [--group 3 5 10] [--set KEY=VALUE ...]
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np
from harness_cells import set_options

from omnislam.core.types import Trajectory
from omnislam.harness.execute import RunSpec, execute_run
from omnislam.metrics.trajectory import ate


def average(trajectories: list[Trajectory], weights: np.ndarray) -> Trajectory:
    """The weighted average of trajectories with the same stamps (circular mean heading)."""
    se2 = np.array([t.se2 for t in trajectories])
    w = np.asarray(weights, dtype=float) / np.sum(weights)
    mean = np.tensordot(w, se2, axes=1)
    mean[:, 2] = np.arctan2(
        np.tensordot(w, np.sin(se2[:, :, 2]), axes=1), np.tensordot(w, np.cos(se2[:, :, 2]), axes=1)
    )
    return Trajectory.from_se2(trajectories[0].stamps_s, mean)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", default="carmen-aces")
    parser.add_argument("--log", default=None, help="front-end log (omnislam frontend)")
    parser.add_argument("--estimators", nargs="+", default=["fastslam1", "fastslam2"])
    parser.add_argument("--seeds", type=int, nargs="+", default=list(range(30)))
    parser.add_argument("--group", type=int, nargs="+", default=[3, 5, 10])
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    options = set_options(parser, args.set)
    for estimator in args.estimators:
        trajectories, ates, evidences = [], [], []
        truth = None
        for i, seed in enumerate(args.seeds):
            print(
                f"{args.dataset}: running {estimator} seed {seed} ({i + 1}/{len(args.seeds)}) ...",
                file=sys.stderr,
                flush=True,
            )
            record = execute_run(RunSpec(args.dataset, estimator, seed, options, args.log))
            truth = record.ground_truth.trajectory
            trajectories.append(record.estimate.trajectory)
            ates.append(ate(record.estimate.trajectory, truth).rmse_m)
            info = json.loads(record.attachments["estimator_info.json"])
            evidences.append(float(info["log_evidence"]))
        evidence = np.array(evidences)
        print(f"{estimator} {args.dataset} {options or ''}")
        print("  seed  ATE [m]  log evidence - max")
        for seed, a, e in zip(args.seeds, ates, evidence - evidence.max(), strict=True):
            print(f"  {seed:4d}  {a:7.3f}  {e:10.1f}")
        print(f"  median ATE {np.median(ates):.3f} m over {len(ates)} seeds")
        for k in args.group:
            equal, weighted = [], []
            for start in range(0, len(trajectories) - k + 1, k):
                group = trajectories[start : start + k]
                lz = evidence[start : start + k]
                equal.append(ate(average(group, np.ones(k)), truth).rmse_m)
                weighted.append(ate(average(group, np.exp(lz - lz.max())), truth).rmse_m)
            print(
                f"  groups of {k}: equal weights median {np.median(equal):.3f} "
                f"({' '.join(f'{x:.3f}' for x in equal)}); evidence weights median "
                f"{np.median(weighted):.3f} ({' '.join(f'{x:.3f}' for x in weighted)})"
            )


if __name__ == "__main__":
    main()
