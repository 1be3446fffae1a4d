"""How wide the spread since the last sighting is where FastSLAM associates (issue 16).

Runs ``fastslam2`` with ``experimental.resighting_spread=1`` (``fastslam/resighting.py``) through
the harness (``omnislam run DATASET --estimator fastslam2 --seed 0 --set
experimental.resighting_spread=1``) and, at every association of unknown sightings, reads the
spread of each candidate landmark (the odometry's covariance composed since that landmark's last
sighting, in the robot frame): the percentiles of its position std sqrt(var x + var y) [m] and
heading std [deg] over all (frame, candidate) pairs. A MR.CLAM dataset with ``:u`` runs with its
ids hidden::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python \\
        benchmarks/fastslam_resighting_spread.py [carmen-aces carmen-intel mrclam6-r1:u ...]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from omnislam.fastslam import association
from omnislam.harness.execute import RunSpec, execute_run

#: percentiles printed
PERCENTILES = (50, 90, 99)


def spreads(dataset: str) -> np.ndarray:
    """(N, 2) position std [m] and heading std [deg] of every candidate at every association."""
    options = {"experimental.resighting_spread": "1"}
    if dataset.endswith(":u"):
        dataset, options["association"] = dataset[:-2], "unknown"
    rows: list[np.ndarray] = []
    original = association.SightingAssociation._unknown

    def recording(self, sightings, unknown, poses, pose_cov, weights):
        center = np.average(poses[:, :2], axis=0, weights=weights)
        radius = float(sightings.z[unknown, 0].max()) + self._margin_m
        candidates = self._registry.near(center, radius)
        if candidates.size and self._spread is not None:
            cov = self._spread.robot_frame(candidates)
            rows.append(
                np.column_stack(
                    [np.sqrt(cov[:, 0, 0] + cov[:, 1, 1]), np.degrees(np.sqrt(cov[:, 2, 2]))]
                )
            )
        return original(self, sightings, unknown, poses, pose_cov, weights)

    association.SightingAssociation._unknown = recording
    shown = " ".join(f"{k}={v}" for k, v in options.items())
    print(f"{dataset}: running fastslam2 {shown} ...", file=sys.stderr, flush=True)
    try:
        execute_run(RunSpec(dataset, "fastslam2", 0, options))
    finally:
        association.SightingAssociation._unknown = original
    return np.concatenate(rows) if rows else np.zeros((0, 2))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "datasets",
        nargs="*",
        default=["carmen-aces", "carmen-intel", "mrclam6-r1:u", "mrclam6-r3:u"],
    )
    for dataset in parser.parse_args().datasets:
        values = spreads(dataset)
        position = np.percentile(values[:, 0], PERCENTILES)
        heading = np.percentile(values[:, 1], PERCENTILES)
        print(
            f"{dataset}: {len(values)} (frame, candidate) pairs; position std p{PERCENTILES} "
            f"{np.round(position, 2).tolist()} m, heading std {np.round(heading, 1).tolist()} deg"
        )


if __name__ == "__main__":
    main()
