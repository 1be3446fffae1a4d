"""Is the graph's error the optimiser's or the data's? LM on the final graph from the truth.

Replays a synthetic preset's front-end log through ``graphslam`` (its defaults, or ``--set``),
takes the final factor graph and its solution (``GraphSLAM.factor_graph`` / ``values``: what
``graph.g2o`` exports), and runs Levenberg-Marquardt on the same graph again, started from the
renderer's truth: every key frame's true pose (at the solution's height) and every landmark,
the final solve's floor landmarks included, at the true point of its track
(``frontend.evaluation.track_truth``; those whose tracks wander between surfaces have none and
keep the solution's value).
Printed: the graph error (0.5 x the sum of squared whitened residuals) at the solution, at the
truth and after LM from the truth, and the key frames' ATE (SE(2)-aligned) of both solutions.
If LM from the truth comes back to the solution's error and ATE, the optimiser found the
graph's optimum and what remains is the data's (loop150: docs/results/graph.md, "What limits
loop150")::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python benchmarks/graph_truth_start.py
        --dataset loop150 runs/loop150 [LOG] [--set KEY=VALUE ...]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
from harness_cells import add_set_option, set_options
from realtime_lab40 import prepare

from omnislam._optional import require
from omnislam.core.types import Trajectory
from omnislam.estimators import make_estimator
from omnislam.graphslam import factors as fx
from omnislam.graphslam.levenberg_marquardt import optimize_batch
from omnislam.harness.frames import frames_for_estimator
from omnislam.metrics.trajectory import ate

gtsam = require("gtsam")


def key_frame_ate_m(values: object, truth_w: np.ndarray, stamps_s: np.ndarray) -> float:
    """ATE RMSE [m], SE(2)-aligned, of the key frames' poses in ``values`` (``gtsam.Values``,
    their viewpoints put on the floor) against ``truth_w`` ((N, 4, 4) per frame)."""
    frames, poses = [], []
    for key in values.keys():
        symbol = gtsam.Symbol(key)
        if chr(symbol.chr()) == "x":
            frames.append(symbol.index())
            poses.append(values.atPose3(key).matrix())
    order = np.argsort(frames)
    frames = np.asarray(frames)[order]
    poses_w = np.asarray(poses)[order]
    poses_w[:, 2, 3] = 0.0  # the viewpoints' height is not the robot's error
    estimate = Trajectory(stamps_s[frames], poses_w)
    return ate(estimate, Trajectory(stamps_s[frames], truth_w[frames])).rmse_m


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", nargs="+", required=True, metavar="NAME DIR [LOG]")
    add_set_option(parser, "graph option (repeatable)")
    args = parser.parse_args()
    if len(args.dataset) not in (2, 3):
        parser.error("--dataset takes NAME DIR [LOG]")
    options = set_options(parser, args.options)
    name, folder = args.dataset[:2]
    log = args.dataset[2] if len(args.dataset) == 3 else None
    data = prepare(name, folder, log, None)
    print(f"{name}: replaying graphslam ...", file=sys.stderr, flush=True)
    graph = make_estimator("graphslam", data.info, options, np.random.default_rng(0))
    for frame in frames_for_estimator("graphslam", data.frames, data.floor_ids_from):
        graph.step(frame)
    factors, solution = graph.factor_graph(), graph.values()

    truth = data.truth.trajectory
    stamps = np.array([f.stamp_s for f in data.frames])
    truth_w = truth.poses_w[np.searchsorted(truth.stamps_s, stamps)]
    landmarks = dict(zip(data.truth.landmark_ids.tolist(), data.truth.landmarks_w, strict=True))
    start = gtsam.Values(solution)
    moved = 0
    for key in solution.keys():
        symbol = gtsam.Symbol(key)
        if chr(symbol.chr()) == "x":
            height = solution.atPose3(key).translation()[2]
            pose = truth_w[symbol.index()]
            yaw = np.arctan2(pose[1, 0], pose[0, 0])
            start.update(key, fx.pose3_planar(np.array([pose[0, 3], pose[1, 3], yaw]), height))
        elif chr(symbol.chr()) == "l" and symbol.index() in landmarks:
            start.update(key, np.asarray(landmarks[symbol.index()], dtype=float))
            moved += 1
    print(
        f"{name}: LM from the truth ({moved} landmarks at their tracks' true points) ...",
        file=sys.stderr,
        flush=True,
    )
    again = optimize_batch(factors, start, graph.config.batch.max_iterations, 1e-10)
    print(
        f"{name}: graph error at the solution {factors.error(solution):.1f}, at the truth "
        f"{factors.error(start):.1f}, after LM from the truth {again.final_error:.1f} "
        f"({again.iterations} iterations)"
    )
    print(
        f"{name}: key frames' ATE [cm]: the solution "
        f"{100 * key_frame_ate_m(solution, truth_w, stamps):.2f}, LM from the truth "
        f"{100 * key_frame_ate_m(again.values, truth_w, stamps):.2f}"
    )


if __name__ == "__main__":
    main()
