"""Every SLAM back end on CARMEN logs given by path, beside dead reckoning and laser odometry.

For each log (a corrected CARMEN log, ``*-corrected.log.gz``, loaded by path like ``omnislam
run LOG``): the shared front end once with the defaults plus the ``--config`` overrides, then
per estimator (seed 0) the SE(2)-aligned ATE against the log's corrected poses, beside the
wheels' dead reckoning and the laser odometry composed alone (the floor a back end fed by it
should not fall under), and the laser sightings per frame that reach the estimators. ``--set``
options go to every estimator (one estimator per call when its keys are its own).

::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python benchmarks/carmen_logs.py
        LOG [LOG ...] [--estimators ekfslam fastslam2 graphslam]
        [--config '{laser: {min_separation_m: 0.5, persistence_scans: 2}}'] [--set KEY=VALUE ...]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml
from harness_cells import set_options

from omnislam.core.se import se2_integrate
from omnislam.core.types import Trajectory
from omnislam.datasets.registry import load_dataset, resolve
from omnislam.frontend.config import frontend_config_from_dict
from omnislam.frontend.observation_log import save_observation_log
from omnislam.frontend.pipeline import run_frontend
from omnislam.harness.evaluation import evaluate_run
from omnislam.harness.execute import RunSpec, execute_run
from omnislam.metrics.trajectory import Alignment, ate


def report(path: str, overrides: dict, estimators: list[str], options: dict[str, str],
           tmp: Path) -> None:
    """One line for the log at ``path``: sightings per frame and every ATE [m]."""
    sequence = load_dataset(resolve(path), {})
    truth = sequence.ground_truth.trajectory
    log = run_frontend(sequence, frontend_config_from_dict(overrides))
    log_path = tmp / f"{Path(path).name}.npz"
    save_observation_log(log, log_path)
    laser = np.array([f.odometry.delta for f in log.frames])
    laser[0] = sequence.odometry_r[0]

    def alone(deltas: np.ndarray) -> float:
        estimate = Trajectory.from_se2(sequence.stamps_s, se2_integrate(deltas))
        return ate(estimate, truth, Alignment.SE2).rmse_m

    sightings = [0 if f.range_bearing is None else len(f.range_bearing) for f in log.frames]
    cells = [f"dead reckoning {alone(sequence.odometry_r):.2f}",
             f"laser odometry {alone(laser):.2f}"]
    for estimator in estimators:
        start = time.perf_counter()
        record = execute_run(RunSpec(path, estimator, 0, options, str(log_path)))
        cells.append(f"{estimator} {evaluate_run(record).ate.rmse_m:.2f} "
                     f"({time.perf_counter() - start:.0f} s)")
    print(f"{Path(path).name}: {np.mean(sightings):.2f} sightings per frame; ATE [m] "
          + ", ".join(cells), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("logs", nargs="+")
    parser.add_argument("--estimators", nargs="+", default=["ekfslam", "fastslam2"])
    parser.add_argument("--config", default="{}", help="front-end overrides (YAML)")
    parser.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    overrides = yaml.safe_load(args.config) or {}
    options = set_options(parser, args.set)
    with tempfile.TemporaryDirectory() as tmp:
        for path in args.logs:
            report(path, overrides, args.estimators, options, Path(tmp))


if __name__ == "__main__":
    main()
