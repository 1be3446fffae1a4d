"""Why FastSLAM's pose NEES is far above its 3 degrees of freedom: the per-frame NEES and the
particle spread against the error, early and late in the run.

For each run (MR.CLAM dataset 6 robots 1-5 with ids through the ``omnislam run`` harness, and
``loop150`` simulated as in ``fastslam_loop150.py``), with the pose error taken as ``omnislam
evaluate``'s NEES takes it (first pose anchored, ``metrics.consistency.pose_nees``):

* the NEES mean (the figure the target is set on), median and the share of frames with NEES <= 30;
* per component (x, y, heading) the median of |error| / std, where std is the particle set's
  weighted std (the covariance FastSLAM reports, ``Estimate.pose_covariances``);
* the median position error and the median position std (sqrt of the mean of the x and y
  variances), over the first and the last tenth of the frames: whether the set's spread keeps
  up with the error as the run goes on.

::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python benchmarks/fastslam_nees.py
        [--robots 1 2 3 4 5] [--loop150-seeds 0] [--seed 0]
        [--estimators fastslam2 fastslam1] [--set KEY=VALUE ...]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
from harness_cells import set_options

from omnislam.core.types import Estimate, Trajectory
from omnislam.harness.execute import RunSpec, execute_run
from omnislam.metrics.consistency import pose_nees, to_estimate_frame
from omnislam.metrics.trajectory import Alignment, associate, ate

#: the particle counts of the thesis's route-1 cells on loop150 (Fig. 5.6)
LOOP150_PARTICLES = {"fastslam2": 10, "fastslam1": 50}


def diagnose(label: str, estimate: Estimate, truth: Trajectory) -> None:
    """Print the module docstring's numbers for one run."""
    trajectory = estimate.trajectory
    origin = ate(trajectory, truth, Alignment.ORIGIN)
    i_est, i_gt = associate(trajectory.stamps_s, truth.stamps_s)
    err = trajectory.se2[i_est] - to_estimate_frame(origin.gtTest, truth.se2[i_gt])
    err[:, 2] = np.arctan2(np.sin(err[:, 2]), np.cos(err[:, 2]))
    cov = np.asarray(estimate.pose_covariances)[i_est]
    nees = pose_nees(trajectory, estimate.pose_covariances, truth).values
    # the frames ``pose_nees`` keeps: positive definite covariances
    eigen = np.linalg.eigvalsh(0.5 * (cov + np.swapaxes(cov, 1, 2)))
    scale = np.maximum(np.abs(eigen).max(axis=1), np.finfo(float).tiny)
    good = eigen.min(axis=1) > 1e-12 * scale
    err, var = err[good], np.diagonal(cov, axis1=1, axis2=2)[good]
    ratio = np.median(np.abs(err) / np.sqrt(var), axis=0)
    pos_err = np.hypot(err[:, 0], err[:, 1])
    pos_std = np.sqrt(0.5 * (var[:, 0] + var[:, 1]))
    tenth = max(len(err) // 10, 1)
    early, late = slice(0, tenth), slice(len(err) - tenth, len(err))
    print(
        f"{label:28s} frames {len(nees)} NEES mean {nees.mean():9.3g} "
        f"median {np.median(nees):9.3g} "
        f"<=30 {np.mean(nees <= 30):4.2f} | |err|/std x {ratio[0]:7.3g} y {ratio[1]:7.3g} "
        f"th {ratio[2]:7.3g} | first tenth err {np.median(pos_err[early]):.3f} m std "
        f"{np.median(pos_std[early]):.4f} m, last tenth err {np.median(pos_err[late]):.3f} m "
        f"std {np.median(pos_std[late]):.4f} m",
        flush=True,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, nargs="*", default=[1, 2, 3, 4, 5])
    parser.add_argument("--loop150-seeds", type=int, nargs="*", default=[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--estimators", nargs="+", default=["fastslam2", "fastslam1"])
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    options = set_options(parser, args.set)
    for robot in args.robots:
        for estimator in args.estimators:
            print(f"mrclam6-r{robot}: running {estimator} ...", file=sys.stderr, flush=True)
            record = execute_run(RunSpec(f"mrclam6-r{robot}", estimator, args.seed, options))
            truth = record.ground_truth.trajectory
            diagnose(f"mrclam6-r{robot} {estimator}", record.estimate, truth)
    if args.loop150_seeds:
        import fastslam_loop150 as loop

        for seed in args.loop150_seeds:
            print(f"loop150 seed {seed}: simulating the route ...", file=sys.stderr, flush=True)
            with tempfile.TemporaryDirectory() as tmp:
                sequence = loop.laser_only_sequence(seed, Path(tmp) / "loop150", None)
            for estimator in args.estimators:
                used = {"particles.n_particles": str(LOOP150_PARTICLES[estimator]), **options}
                print(f"loop150 seed {seed}: running {estimator} ...", file=sys.stderr, flush=True)
                _, slam = loop.run_one(sequence, estimator, used, args.seed)
                label = f"loop150-s{seed} {estimator}@{used['particles.n_particles']}"
                diagnose(label, slam.estimate(), sequence.ground_truth.trajectory)


if __name__ == "__main__":
    main()
