"""The per-step odometry spread FastSLAM samples, against the odometry's actual error.

For each CARMEN log (the shared front end's log, with its laser odometry), over the frames whose
odometry states a covariance (the laser odometry's accepted and degenerate matches): the median
std of x, y and heading of the stated covariance (``Odometry.covariance``, what FastSLAM samples
with ``stated_odometry_noise`` auto or true), of FastSLAM's alpha model
(``OdometryMotionModel(DEFAULT_MOTION_NOISE).covariance(delta)``, what it samples for wheel
odometry), and the median absolute error of the laser increment and of the wheel increment
against the corrected poses::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python benchmarks/odometry_spread.py
        [carmen-intel carmen-aces]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from omnislam.core.motion import OdometryMotionModel
from omnislam.core.se import se2_between, wrap_angle
from omnislam.datasets.registry import load_dataset, resolve
from omnislam.fastslam.config import DEFAULT_MOTION_NOISE
from omnislam.frontend.observation_log import dataset_fingerprint, load_observation_log
from omnislam.harness.cache import cache_dir
from omnislam.harness.execute import frontend_log_for
from omnislam.harness.layout import LOGS


def _error(delta: np.ndarray, truth: np.ndarray) -> np.ndarray:
    e = np.abs(delta - truth)
    e[2] = abs(wrap_angle(delta[2] - truth[2]))
    return e


def spread(dataset: str) -> None:
    """Print the medians of the module docstring for one dataset."""
    sequence = load_dataset(resolve(dataset), {})
    print(
        f"{dataset}: the shared front end's log (from the cache, else run on the scans) ...",
        file=sys.stderr,
        flush=True,
    )
    path = frontend_log_for(sequence, dataset, cache_dir() / LOGS)
    log = load_observation_log(path, dataset_id=dataset_fingerprint(sequence))
    alphas = OdometryMotionModel(DEFAULT_MOTION_NOISE)
    truth = sequence.ground_truth.trajectory.se2
    stated, model, laser, wheels = [], [], [], []
    for i, frame in enumerate(log.frames):
        if i == 0 or frame.odometry.covariance is None:
            continue
        stated.append(np.sqrt(np.diag(frame.odometry.covariance)))
        model.append(np.sqrt(np.diag(alphas.covariance(frame.odometry.delta))))
        step = se2_between(truth[i - 1], truth[i])
        laser.append(_error(frame.odometry.delta, step))
        wheels.append(_error(sequence.odometry_r[i], step))

    def row(label: str, values: list[np.ndarray]) -> str:
        x, y, th = np.median(np.array(values), axis=0)
        return f"  {label:34s} {100 * x:6.2f} cm {100 * y:6.2f} cm {np.rad2deg(th):6.3f} deg"

    print(f"{dataset} ({log.odometry_source} odometry): {len(stated)} of {len(log)} frames "
          "state a covariance; medians of x, y, heading")
    print(row("std, stated covariance", stated))
    print(row("std, alpha model (wheel default)", model))
    print(row("|error| of the log's increment", laser))
    print(row("|error| of the wheel increment", wheels))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("datasets", nargs="*", default=["carmen-intel", "carmen-aces"])
    for dataset in parser.parse_args().datasets:
        spread(dataset)


if __name__ == "__main__":
    main()
