"""gtsam's victoria_park.txt through omnislam's iSAM2 estimator vs a bare GTSAM Python loop.

Both sides get the same data, parsed once before any timing by the omnislam loader
(``omnislam.datasets.gtsam_victoria``), and do the same work per frame: one Pose2 with an
odometry between-factor (the file's sigmas 0.01 m, 0.002 m, 0.002 rad), one
``BearingRangeFactor2D`` per sighting (a landmark enters with its first sighting), one
``ISAM2.update`` (relinearizeSkip=1, threshold 0.1), and a read of the newest pose only. The
bare loop is ``harness.reference.isam2_pass`` -- the warm start of the victoria-park-gtsam
reference -- with the file's sigmas as one shared model, as omnislam's preset has them. Runs
alternate (omnislam, bare, omnislam, ...) so that drift of the machine hits both alike.

Targets: omnislam's total time <= 1.25x the bare loop's; omnislam's final estimate
within 2 cm RMS of Levenberg-Marquardt warm-started from it (``graphslam.batch.warm_started_lm``,
what ``BatchGraphSLAM`` does in ``estimate()``).

    .venv/bin/python benchmarks/graphslam_victoria.py [--repeats 3] [--frames N]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import gtsam
import numpy as np

from omnislam.core.modality import Modality
from omnislam.datasets.gtsam_victoria import load_gtsam_victoria
from omnislam.graphslam import GraphSLAM
from omnislam.graphslam.batch import warm_started_lm
from omnislam.graphslam.config import PRESETS
from omnislam.harness.reference import graph_frames, isam2_pass

ODOMETRY_SIGMAS = (0.01, 0.002, 0.002)  # the file's ODOMETRY covariance diag(1e-4, 4e-6, 4e-6)


def run_omnislam(frames):
    estimator = GraphSLAM(Modality.RANGE_BEARING_2D, PRESETS["victoria-park-gtsam"])
    steps = np.empty(len(frames))
    for k, frame in enumerate(frames):
        t0 = time.perf_counter()
        estimator.step(frame)
        steps[k] = time.perf_counter() - t0
    return estimator, steps


def rms(a, b):
    return float(np.sqrt(np.mean(np.sum((np.asarray(a) - np.asarray(b)) ** 2, axis=1))))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--frames", type=int, default=None, help="use only the first N frames")
    args = parser.parse_args(argv)

    sequence = load_gtsam_victoria()
    frames = list(sequence.frame_inputs())[: args.frames]
    inputs = graph_frames(frames)
    sightings = sum(len(f.sightings) for f in inputs)
    print(
        f"victoria_park.txt: {len(frames)} frames, {sightings} sightings "
        f"(loader {sequence.info['sigma_range_m']} m / {sequence.info['sigma_bearing_rad']} rad)"
    )

    totals = {"omnislam": [], "bare": []}
    medians = {"omnislam": [], "bare": []}
    estimator = isam = None
    for repeat in range(args.repeats):
        print(
            f"victoria_park.txt: pass {repeat + 1}/{args.repeats}: running graphslam, "
            "then gtsam's bare iSAM2 ...",
            file=sys.stderr,
            flush=True,
        )
        estimator, steps = run_omnislam(frames)
        totals["omnislam"].append(steps.sum())
        medians["omnislam"].append(np.median(steps))
        bare = isam2_pass(inputs, odometry_sigmas=ODOMETRY_SIGMAS)
        isam = bare.isam
        totals["bare"].append(bare.step_s.sum())
        medians["bare"].append(np.median(bare.step_s))
    for name in totals:
        print(
            f"{name:9s} total s: {' '.join(f'{t:.2f}' for t in totals[name])}  "
            f"median step ms: {' '.join(f'{1e3 * m:.3f}' for m in medians[name])}"
        )
    ratio_total = statistics.median(totals["omnislam"]) / statistics.median(totals["bare"])
    ratio_step = statistics.median(medians["omnislam"]) / statistics.median(medians["bare"])
    print(
        f"omnislam / bare: total {ratio_total:.3f}x, median step {ratio_step:.3f}x (goal <= 1.25x)"
    )

    t0 = time.perf_counter()
    estimate = estimator.estimate()
    t_estimate = time.perf_counter() - t0
    bare_poses = gtsam.utilities.extractPose2(isam.calculateEstimate())
    print(
        f"estimate(): {t_estimate:.3f} s; omnislam vs bare loop poses RMS "
        f"{rms(estimate.trajectory.se2[:, :2], bare_poses[:, :2]):.2e} m"
    )

    # the warm-started LM optimum of BatchGraphSLAM.estimate(), on the graph already built above
    t0 = time.perf_counter()
    result = warm_started_lm(estimator)
    t_lm = time.perf_counter() - t0
    optimum_poses = gtsam.utilities.extractPose2(result.values)
    optimum_landmarks = gtsam.utilities.extractPoint2(result.values)
    pose_rms = rms(estimate.trajectory.se2[:, :2], optimum_poses[:, :2])
    landmark_rms = rms(estimate.landmarks_w[:, :2], optimum_landmarks)
    print(
        f"LM warm-started from iSAM2: {result.iterations} iterations, {t_lm:.2f} s, error "
        f"{result.initial_error:.2f} -> {result.final_error:.2f}"
    )
    print(
        f"iSAM2 vs LM optimum: poses RMS {100 * pose_rms:.2f} cm, landmarks RMS "
        f"{100 * landmark_rms:.2f} cm (goal <= 2 cm)"
    )
    print(f"info: {estimator.info()}")
    ok = ratio_total <= 1.25 and pose_rms <= 0.02
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
