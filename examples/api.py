"""omnislam's public Python API in one round trip, on MR.CLAM robot 1 (well under a minute).

    python examples/api.py --out /tmp/omnislam-api

1. load a dataset and run the shared front end on it (MR.CLAM has no images or scans: its log
   holds the recorded range-bearing sightings; on a dataset with images it holds the SIFT
   tracks), saved as an observation log;
2. make an estimator through the registry and step it through the frames by hand;
3. the same run as ``omnislam run`` does it (``execute_run``), replaying the saved log, written
   as a RUN_DIR and evaluated: both ways give the same trajectory;
4. a two-cell grid (dead reckoning and EKF-SLAM), compared and reported, as ``omnislam
   compare`` and ``omnislam report`` do.

The data is found as the command line finds it (``OMNISLAM_DATA``, ``omnislam dataset list``).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

import omnislam as om
from omnislam.core.types import Trajectory

DATASET = "mrclam6-r1"
ESTIMATOR = "ekfslam"
SEED = 0


def by_hand(sequence: object, log_path: Path) -> Trajectory:
    """Step 2: the estimator made from the registry and fed every frame of the log."""
    fed = om.fed_frames(sequence, ESTIMATOR, str(log_path))
    estimator = om.make_estimator(ESTIMATOR, fed.info, {}, np.random.default_rng(SEED))
    for frame in fed.frames:
        estimator.step(frame)
    return estimator.estimate().trajectory


def main(out: Path) -> dict[str, float]:
    """The round trip (module docstring); returns the numbers it prints."""
    out.mkdir(parents=True, exist_ok=True)
    # 1. data and front end
    sequence = om.load_dataset(DATASET)
    log_path = out / "frontend.npz"
    om.save_observation_log(om.run_frontend(sequence), log_path)
    # 2. an estimator by hand
    trajectory = by_hand(sequence, log_path)
    # 3. the same run as `omnislam run DATASET --estimator ESTIMATOR --log LOG --seed 0`
    record = om.execute_run(om.RunSpec(DATASET, ESTIMATOR, seed=SEED, log=str(log_path)))
    om.write_run_dir(out / "run", record)
    metrics = om.evaluate_run(om.read_run_dir(out / "run"))
    same = np.array_equal(record.estimate.trajectory.poses_w, trajectory.poses_w)
    truth = sequence.ground_truth.trajectory
    ate = om.ate(trajectory, truth, om.Alignment.SE2)
    # 4. a grid and its report
    grid_file = out / "grid.yaml"
    grid_file.write_text(
        f"name: api example\ndatasets: [{DATASET}]\nestimators: [deadreckoning, {ESTIMATOR}]\n"
    )
    result = om.run_grid(om.load_grid(grid_file), out / "results", om.SerialExecutor)
    om.write_report(out / "results", out / "report", om.ReportOptions(exports=False))
    grid_ate = {o.cell.estimator_label: o.metrics.ate.rmse_m for o in result.outcomes}
    numbers = {
        "ate_rmse_m": float(metrics.ate.rmse_m),
        "ate_rmse_by_hand_m": float(ate.rmse_m),
        "same_trajectory": float(same),
        **{f"grid_ate_rmse_m.{k}": float(v) for k, v in grid_ate.items()},
    }
    print(json.dumps(numbers, indent=1))
    return numbers


if __name__ == "__main__":  # the front end may start worker processes: guard the top level
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="folder for what it writes")
    main(parser.parse_args().out)
