"""``--set prior_map=RUN_DIR``: the landmarks of an earlier run as the prior map of this one.

Map, then localise: a graphslam run builds the map, and a localiser (the vertical-line UKF)
replays the same data against it. The map is in the earlier run's frame, whose first pose is
the first pose of its ``trajectory.tum`` (the origin for every estimator here), so the localiser
starts from that pose, and evaluation aligns both runs to the ground truth the same way.
"""

from __future__ import annotations

from pathlib import Path

from omnislam.core.se import se2_from_se3
from omnislam.core.types import PriorMap
from omnislam.datasets.trajectory_io import read_tum
from omnislam.errors import ConfigError, DataError
from omnislam.harness.layout import LANDMARKS, TRAJECTORY
from omnislam.harness.rundir import read_landmarks_csv

#: the harness option naming the RUN_DIR whose landmarks become the prior map
PRIOR_MAP_OPTION = "prior_map"


def prior_map_from_run_dir(run_dir: str | Path) -> PriorMap:
    """The landmarks of ``run_dir`` (``landmarks.csv``) as a PriorMap in that run's frame.

    Raises:
        ConfigError: ``run_dir`` is not a folder.
        DataError: its ``landmarks.csv`` or ``trajectory.tum`` is missing or malformed, or it
            holds no landmark.
    """
    folder = Path(run_dir)
    if not folder.is_dir():
        raise ConfigError(f"{PRIOR_MAP_OPTION}={run_dir}: not a RUN_DIR folder")
    ids, points_w = read_landmarks_csv(folder / LANDMARKS)
    if not len(ids):
        raise DataError(
            "no landmarks: this run cannot serve as a prior map (give the RUN_DIR of a SLAM run "
            "that mapped landmarks, e.g. graphslam on the same data)",
            folder / LANDMARKS,
        )
    trajectory = read_tum(folder / TRAJECTORY)
    return PriorMap(
        source=f"landmarks of the run {folder}",
        landmark_ids=ids,
        points_w=points_w,
        initial_pose_w=se2_from_se3(trajectory.poses_w[0]),
    )
