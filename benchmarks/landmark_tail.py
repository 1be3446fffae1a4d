"""Where a bearing-only map's landmark RMSE comes from: data or estimator?

For a finished run on a synthetic world (RUN_DIR with per-track ground truth, ``omnislam run
... --log LOG``) and its front-end log, take the ``--worst`` landmarks by error (after the
planar alignment of the trajectory) and a reference set of well-estimated ones, and report:

* how well their sightings agree with their *true* points seen from the *true* poses (angle
  between the measured ray and the true direction, in units of the bearing's sigma): large
  residuals mean wrong sightings in the track (front end), small ones mean the data are sound;
* least-squares triangulation (``core.triangulation.triangulate_rays``) of their sightings from
  the true poses and from the estimated poses: if even the true poses miss the true point by
  as much as the estimator, the data do not fix the landmark (parallax), and no back end can;
* their parallax (largest angle between two of their rays) and number of sightings.

    .venv/bin/python benchmarks/landmark_tail.py RUN_DIR LOG [--worst 150]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from omnislam.core.se import se2_rotate_vectors
from omnislam.core.triangulation import triangulate_rays
from omnislam.datasets.registry import load_dataset, resolve
from omnislam.frontend.observation_log import dataset_fingerprint, load_observation_log
from omnislam.harness.rundir import read_run_dir
from omnislam.metrics.trajectory import umeyama


def world_rays(poses: np.ndarray, frame: np.ndarray, rays_r: np.ndarray, height: float):
    """Origins and directions in the world of robot-frame rays seen at ``poses[frame]``."""
    origins = np.column_stack([poses[frame, :2], np.full(len(frame), height)])
    return origins, se2_rotate_vectors(poses[frame], rays_r)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run_dir", type=Path)
    parser.add_argument("log", type=Path)
    parser.add_argument("--worst", type=int, default=150)
    args = parser.parse_args()

    record = read_run_dir(args.run_dir)
    estimate, truth = record.estimate, record.ground_truth
    sequence = load_dataset(resolve(record.config.dataset_path), {})
    height = float(sequence.calibration.viewpoint_r[2])  # the omni rig's single viewpoint
    replay = load_observation_log(args.log, dataset_id=dataset_fingerprint(sequence))

    poses_est, poses_true = (
        estimate.trajectory.se2,
        truth.trajectory.se2[: len(estimate.trajectory)],
    )
    R, t, _ = umeyama(poses_est[:, :2], poses_true[:, :2])
    landmarks = estimate.landmarks_w.copy()
    landmarks[:, :2] = landmarks[:, :2] @ R.T + t
    common, i_est, i_true = np.intersect1d(
        estimate.landmark_ids, truth.landmark_ids, return_indices=True
    )
    points_true = truth.landmarks_w[i_true]
    error = np.linalg.norm(landmarks[i_est] - points_true, axis=1)
    order = np.argsort(error)
    groups = {f"worst {args.worst}": order[-args.worst :], "best half": order[: len(order) // 2]}

    # every sighting of the compared tracks: frame, ray, sigma
    frames, ids, rays, sigmas = [], [], [], []
    for frame in replay.frames:
        if frame.bearings is not None and len(frame.bearings):
            frames.append(np.full(len(frame.bearings), frame.index))
            ids.append(frame.bearings.landmark_ids)
            rays.append(frame.bearings.unit_vectors_r)
            sigmas.append(frame.bearings.sigmas_rad)
    frames, ids = np.concatenate(frames), np.concatenate(ids)
    rays, sigmas = np.concatenate(rays), np.concatenate(sigmas)

    print(
        f"{args.run_dir}: {len(common)} landmarks with ground truth, RMSE "
        f"{np.sqrt(np.mean(error**2)):.4f} m, median {np.median(error):.4f} m"
    )
    print(
        "| landmarks | error median [m] | residual / sigma median, p99 | LS from true poses "
        "[m] | LS from estimated poses [m] | parallax [deg] | sightings |"
    )
    print("|---|---|---|---|---|---|---|")
    for name, rows in groups.items():
        residual, from_true, from_est, parallax, count = [], [], [], [], []
        for row in rows.tolist():
            mine = ids == common[row]
            origins, directions = world_rays(poses_true, frames[mine], rays[mine], height)
            to_point = points_true[row] - origins
            to_point /= np.linalg.norm(to_point, axis=1, keepdims=True)
            angle = np.arccos(np.clip(np.sum(to_point * directions, axis=1), -1.0, 1.0))
            residual.extend((angle / sigmas[mine]).tolist())
            count.append(int(mine.sum()))
            if mine.sum() < 2:
                continue
            from_true.append(
                np.linalg.norm(triangulate_rays(origins, directions).point_w - points_true[row])
            )
            origins_e, directions_e = world_rays(poses_est, frames[mine], rays[mine], height)
            point_e = triangulate_rays(origins_e, directions_e).point_w
            point_e[:2] = R @ point_e[:2] + t
            from_est.append(np.linalg.norm(point_e - points_true[row]))
            cosines = np.clip(directions @ directions.T, -1.0, 1.0)
            parallax.append(np.degrees(np.arccos(cosines.min())))
        r = np.asarray(residual)
        print(
            f"| {name} | {np.median(error[rows]):.3f} | {np.median(r):.2f}, "
            f"{np.percentile(r, 99):.1f} | {np.median(from_true):.3f} | "
            f"{np.median(from_est):.3f} | {np.median(parallax):.1f} | {np.median(count):.0f} |"
        )


if __name__ == "__main__":
    main()
