"""FastSLAM on MR.CLAM dataset 6, robots 1-5, sightings with ids, against graphslam.

Every run goes through the harness of ``omnislam run`` / ``omnislam evaluate`` (``execute_run`` and
``evaluate_run``), so a row is what ``omnislam run mrclam6-rK --estimator E --seed S --out R &&
omnislam evaluate R --json`` reports: ATE RMSE after SE(2) alignment, pose NEES mean (dof 3), the
landmark RMSE and landmark NEES mean (dof 2) of the final map, and from ``estimator_info.json``
FastSLAM's particle diversity (fewest distinct ancestors, longest run of single-ancestor steps).
Then the medians over robots and seeds and the target (fastslam2 median ATE <= 2x
graphslam's), and the medians per robot. ``graphslam-online`` is the same iSAM2 run read out
causally, its newest pose after every step (the estimate a filter reports; see
``fastslam_loop150.py``), where ``graphslam`` reports the final smoothed trajectory. With
``--compare-kernels`` each FastSLAM run is repeated on the numpy path (``--set kernels=numpy``) and
the largest trajectory difference and the ATE difference between the two paths are printed::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python benchmarks/fastslam_mrclam.py
        [--robots 1 2 3 4 5] [--seeds 0 1 2] [--estimators fastslam1 fastslam2]
        [--compare-kernels] [--set KEY=VALUE ...] [--loader-set KEY=VALUE ...]

``--set`` options go to the FastSLAM runs only; ``--loader-set`` options are the dataset
loader's (``max_step_s=inf``: frames at sighting times only, the gaps not filled)
and reach every run, graphslam's included.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from harness_cells import set_options

from omnislam.core.modality import Modality
from omnislam.core.motion import OdometryMotionModel
from omnislam.core.types import Trajectory
from omnislam.datasets.registry import load_dataset, resolve
from omnislam.graphslam.config import GraphSLAMConfig
from omnislam.graphslam.isam import GraphSLAM
from omnislam.harness.evaluation import evaluate_run
from omnislam.harness.execute import RunSpec, execute_run
from omnislam.harness.layout import ESTIMATOR_INFO
from omnislam.metrics.trajectory import Alignment, ate


def run(dataset: str, estimator: str, seed: int, options: dict[str, str]):
    """One run and its metrics (and FastSLAM's info record, or None)."""
    start = time.process_time()
    record = execute_run(RunSpec(dataset, estimator, seed, options))
    cpu_s = time.process_time() - start
    metrics = evaluate_run(record)
    info = record.attachments.get(ESTIMATOR_INFO)
    return record, metrics, (json.loads(info) if info else None), cpu_s


def graphslam_online_trajectory(dataset: str, loader: dict[str, str]) -> Trajectory:
    """iSAM2's newest pose after every step (its causal, filter-like read-out)."""
    sequence = load_dataset(resolve(dataset), loader)
    config = GraphSLAMConfig()
    graph = GraphSLAM(
        Modality.RANGE_BEARING_2D, config, motion=OdometryMotionModel(config.motion_noise)
    )
    newest = []
    for frame in sequence.frame_inputs():
        graph.step(frame)
        newest.append(graph.newest_pose())
    return Trajectory.from_se2(sequence.stamps_s, np.array(newest))


def graphslam_online_ate(dataset: str, loader: dict[str, str]) -> float:
    """ATE of iSAM2's newest pose after every step (its causal, filter-like read-out)."""
    sequence = load_dataset(resolve(dataset), loader)
    trajectory = graphslam_online_trajectory(dataset, loader)
    return ate(trajectory, sequence.ground_truth.trajectory, Alignment.SE2).rmse_m


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--estimators", nargs="+", default=["fastslam1", "fastslam2"])
    parser.add_argument("--no-graphslam", action="store_true")
    parser.add_argument("--compare-kernels", action="store_true")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--loader-set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    loader = set_options(parser, args.loader_set, "--loader-set")
    extra = {**set_options(parser, args.set), **loader}
    if extra:
        print("extra FastSLAM options:", " ".join(f"{k}={v}" for k, v in extra.items()))
    ates: dict[str, list[float]] = {}
    per_robot: dict[tuple[int, str], list[float]] = {}
    for robot in args.robots:
        dataset = f"mrclam6-r{robot}"
        if not args.no_graphslam:
            _, metrics, _, cpu_s = run(dataset, "graphslam", 0, loader)
            ates.setdefault("graphslam", []).append(metrics.ate.rmse_m)
            online = graphslam_online_ate(dataset, loader)
            ates.setdefault("graphslam-online", []).append(online)
            per_robot[(robot, "graphslam")] = [metrics.ate.rmse_m]
            per_robot[(robot, "graphslam-online")] = [online]
            print(
                f"{dataset} graphslam  ATE {metrics.ate.rmse_m:.3f} m  CPU {cpu_s:.1f} s; "
                f"graphslam-online ATE {online:.3f} m"
            )
        for estimator in args.estimators:
            for seed in args.seeds:
                record, metrics, info, cpu_s = run(dataset, estimator, seed, extra)
                ates.setdefault(estimator, []).append(metrics.ate.rmse_m)
                per_robot.setdefault((robot, estimator), []).append(metrics.ate.rmse_m)
                nees = metrics.nees.pose_mean
                lm_nees = metrics.nees.landmark_mean
                line = (
                    f"{dataset} {estimator} seed {seed}  ATE {metrics.ate.rmse_m:.3f} m  "
                    f"NEES {nees if nees is None else format(nees, '.3g')}  landmark RMSE "
                    f"{metrics.landmarks.rmse_m:.3f} m NEES "
                    f"{lm_nees if lm_nees is None else format(lm_nees, '.3g')}  distinct min "
                    f"{info['distinct_ancestors_min']}  single-ancestor run "
                    f"{info['single_ancestor_longest_run']}  CPU {cpu_s:.1f} s"
                )
                if args.compare_kernels:
                    reference, ref_metrics, _, ref_cpu = run(
                        dataset, estimator, seed, {**extra, "kernels": "numpy"}
                    )
                    a = record.estimate.trajectory.se2
                    b = reference.estimate.trajectory.se2
                    line += (
                        f"  | numpy path: ATE {ref_metrics.ate.rmse_m:.3f} m, max traj diff "
                        f"{np.abs(a - b).max():.1e}, ATE diff "
                        f"{abs(metrics.ate.rmse_m - ref_metrics.ate.rmse_m):.1e} m, CPU "
                        f"{ref_cpu:.1f} s"
                    )
                print(line, flush=True)
    names = [n for n in ("graphslam", "graphslam-online", *args.estimators) if n in ates]
    print("\nmedian ATE per robot [m]: " + " / ".join(names))
    for robot in args.robots:
        cells = [per_robot.get((robot, n)) for n in names]
        print(f"  r{robot}: " + " / ".join("-" if not c else f"{np.median(c):.3f}" for c in cells))
    print("\nmedian ATE over robots x seeds:")
    for name, values in ates.items():
        print(f"  {name:10s} {np.median(values):.3f} m  (runs {len(values)})")
    if "graphslam" in ates and "fastslam2" in ates:
        ratio = np.median(ates["fastslam2"]) / np.median(ates["graphslam"])
        verdict = "met" if ratio <= 2 else "NOT met"
        print(f"  fastslam2 / graphslam: {ratio:.2f}x (goal <= 2): {verdict}")
    if "graphslam" in ates and "graphslam-online" in ates:
        ratio = np.median(ates["graphslam-online"]) / np.median(ates["graphslam"])
        print(f"  graphslam-online / graphslam: {ratio:.2f}x (iSAM2's own causal read-out)")


if __name__ == "__main__":
    main()
