"""The accuracy table: ATE and landmark RMSE of every estimator on every dataset.

Every cell goes through the harness of ``omnislam run`` / ``omnislam evaluate`` (``execute_run``
and ``evaluate_run``), so it is what ``omnislam run DATASET --estimator E --seed S --out R
[--set K=V] [--log LOG] && omnislam evaluate R --json`` reports: ATE RMSE [m] after SE(2)
alignment, landmark RMSE [m] of the matched landmarks, and the number of landmarks mapped.

Datasets (``--datasets``, groups or names):

* ``mrclam``: MR.CLAM dataset 6 robots 1-5 with ids (``mrclam6-rK``) and with ids ignored
  (``--set association=unknown``);
* ``victoria``: Victoria Park against GPS;
* ``carmen``: CARMEN intel and aces against the corrected poses, the laser landmarks of the
  shared front end (no ids) and its laser odometry (scans registered by ICP,
  ``frontend.scan_matching``), which the SLAM estimators get as their odometry; dead reckoning
  stays the wheel odometry, and the column "laser odometry alone" is the log's laser odometry
  composed without any landmark; with ``--line-landmarks feet`` the front end's lines
  become the tutorial's feet instead of corners (the default), with ``--wheel-odometry`` the
  log has no laser odometry (either way a log built here, replayed to every estimator); the
  goal each SLAM estimator <= 0.3x dead reckoning's ATE is checked; with ``--stated-odometry`` the
  logs state the odometry noise fitted to the corrected poses;
* ``--synthetic RENDER ...``: synthetic laser presets (e.g. a ``loop150`` render), on their
  range-bearing sightings (``modality=range-bearing-2d``);
* ``--omni RENDER ...``: omni renders (``demo``, ``lab40``) on the shared front end's bearings.

::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python benchmarks/ekfslam_accuracy.py
        [--datasets mrclam victoria carmen] [--estimators deadreckoning graphslam fastslam1
        fastslam2 ekfslam] [--seeds 0] [--line-landmarks feet|corners] [--wheel-odometry]
        [--synthetic /path/loop150-render] [--omni /path/demo-render /path/lab40-render]
        [--diagnose] [--set KEY=VALUE ...]

``--set`` options reach every run but dead reckoning's (name the estimators that take them
with ``--estimators``, e.g. ``--estimators deadreckoning fastslam1 fastslam2 --set
stated_odometry_noise=false``). The particle filters' cells print the mean, the std and the
median over the seeds.

``--diagnose`` prints, for each CARMEN log, how repeatable each kind of laser landmark is:
every sighting projected into the world with the corrected poses, the distance to the nearest
sighting of the same kind in the 5 scans before and after (a fixed landmark re-observed is a
few centimetres away; a foot of the perpendicular through the drifting odometry is not).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from harness_cells import set_options

from omnislam.core.se import se2_integrate
from omnislam.datasets.registry import CARMEN_ODOMETRY_NOISE, load_dataset, resolve
from omnislam.frontend.config import (
    FrontendConfig,
    LaserLandmarkConfig,
    LaserOdometryConfig,
    LineLandmarks,
)
from omnislam.harness.evaluation import evaluate_run
from omnislam.harness.execute import RunSpec, execute_run

ESTIMATORS = ("deadreckoning", "graphslam", "fastslam1", "fastslam2", "ekfslam")
#: the CARMEN column of the log's laser odometry composed on its own (no landmarks)
LASER_ALONE = "laser odometry alone"
GOAL_RATIO = 0.3


def cells(args: argparse.Namespace) -> list[tuple[str, str, dict[str, str], bool]]:
    """(row label, dataset, options, CARMEN row) of every requested row."""
    rows: list[tuple[str, str, dict[str, str], bool]] = []
    for group in args.datasets:
        if group == "mrclam":
            for robot in range(1, 6):
                rows.append((f"mrclam6-r{robot} ids", f"mrclam6-r{robot}", {}, False))
            for robot in range(1, 6):
                rows.append(
                    (
                        f"mrclam6-r{robot} unknown",
                        f"mrclam6-r{robot}",
                        {"association": "unknown"},
                        False,
                    )
                )
        elif group == "victoria":
            rows.append(("victoria-park (GPS)", "victoria-park", {}, False))
        elif group == "carmen":
            for name in ("carmen-intel", "carmen-aces"):
                options = {}
                if args.stated_odometry:
                    options = {"odometry_noise": CARMEN_ODOMETRY_NOISE[name]}
                rows.append((name, name, options, True))
        else:
            rows.append((group, group, {}, group.startswith("carmen")))
    for render in args.synthetic:
        rows.append((Path(render).name, render, {"modality": "range-bearing-2d"}, False))
    for render in args.omni:
        rows.append((Path(render).name, render, {}, False))
    return rows


def laser_log(
    dataset: str, line_landmarks: LineLandmarks, folder: Path, laser_odometry: bool = True
) -> str:
    """The shared front end's log of a laser dataset with the chosen line landmarks (and the
    laser odometry on or off)."""
    from omnislam.frontend.pipeline import cached_frontend

    sequence = load_dataset(resolve(dataset), {})
    config = FrontendConfig(
        laser=LaserLandmarkConfig(line_landmarks=line_landmarks),
        laser_odometry=LaserOdometryConfig(enabled=laser_odometry),
    )
    path = folder / f"{dataset}-{line_landmarks.value}-{laser_odometry}.npz"
    cached_frontend(sequence, path, config)
    return str(path)


def laser_alone(dataset: str, log: str | None) -> float | None:
    """ATE [m] (SE(2)-aligned, as ``omnislam evaluate``) of the log's laser odometry composed
    on its own: what the SLAM estimators start from before any landmark (None: the log has no
    laser odometry)."""
    from omnislam.core.types import OdometrySource, Trajectory
    from omnislam.frontend.observation_log import dataset_fingerprint, load_observation_log
    from omnislam.harness.cache import cache_dir
    from omnislam.harness.execute import frontend_log_for
    from omnislam.harness.layout import LOGS
    from omnislam.metrics.trajectory import Alignment, ate

    sequence = load_dataset(resolve(dataset), {})
    path = log if log is not None else frontend_log_for(sequence, dataset, cache_dir() / LOGS)
    replay = load_observation_log(path, dataset_id=dataset_fingerprint(sequence))
    if replay.odometry_source is not OdometrySource.LASER:
        return None
    deltas = np.array([f.odometry.delta for f in replay.frames])
    poses = se2_integrate(deltas)
    estimate = Trajectory.from_se2(sequence.stamps_s, poses)
    return ate(estimate, sequence.ground_truth.trajectory, Alignment.SE2).rmse_m


def diagnose(dataset: str) -> None:
    """Repeatability of spikes, feet and corners on a CARMEN log (module docstring)."""
    from scipy.spatial import cKDTree

    from omnislam.frontend.laser_landmarks import extract_laser_landmarks

    sequence = load_dataset(resolve(dataset), {})
    truth = sequence.ground_truth.trajectory.se2
    scans = sequence.laser
    dr = se2_integrate(sequence.odometry_r)
    base = LaserLandmarkConfig()
    spikes_only = replace(base, ransac_trials=0)
    kinds = {
        "spikes": spikes_only,
        "feet": replace(base, line_landmarks=LineLandmarks.FEET),
        "corners": replace(base, line_landmarks=LineLandmarks.CORNERS),
    }
    print(f"\n{dataset}: {len(sequence)} scans; repeatability of the laser landmarks")
    for kind, config in kinds.items():
        rng = np.random.default_rng(0)
        world, frame = [], []
        for i in range(len(sequence)):
            args = (scans.angles_rad, scans.ranges_m[i], scans.max_range_m)
            spikes = len(extract_laser_landmarks(*args, spikes_only, rng, dr[i]))
            s = extract_laser_landmarks(*args, config, rng, dr[i])
            first = 0 if kind == "spikes" else spikes  # the line landmarks follow the spikes
            r, b = s.ranges_m[first:], truth[i, 2] + s.bearings_rad[first:]
            world.append(
                np.column_stack([truth[i, 0] + r * np.cos(b), truth[i, 1] + r * np.sin(b)])
            )
            frame.append(np.full(len(r), i))
        world_w, frames = np.concatenate(world), np.concatenate(frame)
        tree = cKDTree(world_w)
        nearest = np.full(len(world_w), np.inf)
        for j in range(len(world_w)):
            for k in tree.query_ball_point(world_w[j], 2.0):
                if 0 < abs(frames[k] - frames[j]) <= 5:
                    nearest[j] = min(nearest[j], float(np.linalg.norm(world_w[k] - world_w[j])))
        finite = nearest[np.isfinite(nearest)]
        median = float(np.median(finite)) if finite.size else float("nan")
        print(
            f"  {kind:8s} {len(world_w):6d} sightings ({len(world_w) / len(sequence):.2f} per "
            f"scan): nearest of the same kind within +-5 scans: median {median:.3f} m, "
            f"< 0.1 m {np.mean(nearest < 0.1):.2f}, none within 2 m "
            f"{np.mean(~np.isfinite(nearest)):.2f}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--datasets", nargs="*", default=["mrclam", "victoria", "carmen"])
    parser.add_argument("--estimators", nargs="+", default=list(ESTIMATORS))
    parser.add_argument("--seeds", type=int, nargs="+", default=[0])
    parser.add_argument(
        "--line-landmarks",
        choices=[m.value for m in LineLandmarks],
        default=None,
        help="CARMEN: build the laser log with these line landmarks (default: the cached one)",
    )
    parser.add_argument(
        "--wheel-odometry",
        action="store_true",
        help="CARMEN: build the laser log without the laser odometry (the estimators get the "
        "wheel odometry, as before the scan matching)",
    )
    parser.add_argument("--synthetic", nargs="*", default=[])
    parser.add_argument("--omni", nargs="*", default=[])
    parser.add_argument("--diagnose", action="store_true")
    parser.add_argument(
        "--stated-odometry",
        action="store_true",
        help="CARMEN: state the odometry noise fitted to the corrected poses "
        "(registry.CARMEN_ODOMETRY_NOISE)",
    )
    parser.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="an option for every run but dead reckoning's (repeatable)",
    )
    args = parser.parse_args()
    overrides = set_options(parser, args.overrides)
    rows = cells(args)
    if args.diagnose:
        for _, dataset, _, carmen in rows:
            if carmen:
                diagnose(dataset)
    results: dict[tuple[str, str], list[tuple[float, float | None, int]]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for label, dataset, options, carmen in rows:
            log = None
            if carmen and (args.line_landmarks is not None or args.wheel_odometry):
                lines = LineLandmarks(args.line_landmarks or LineLandmarks.FEET.value)
                log = laser_log(dataset, lines, Path(tmp), not args.wheel_odometry)
            if carmen:
                start = time.process_time()
                alone = laser_alone(dataset, log)
                if alone is not None:
                    results[(label, LASER_ALONE)] = [(alone, None, 0)]
                    print(
                        f"{label} {LASER_ALONE}: ATE {alone:.3f} m, CPU "
                        f"{time.process_time() - start:.1f} s",
                        flush=True,
                    )
            for estimator in args.estimators:
                seeds = (
                    [0] if estimator in ("deadreckoning", "graphslam", "ekfslam") else args.seeds
                )
                for seed in seeds:
                    start = time.process_time()
                    used = dict(options)
                    if estimator == "deadreckoning":  # uses no sightings: no modality
                        used.pop("modality", None)
                    else:
                        used.update(overrides)
                    try:
                        record = execute_run(RunSpec(dataset, estimator, seed, used, log))
                        metrics = evaluate_run(record)
                    except Exception as exc:
                        print(f"{label} {estimator} seed {seed}: FAILED ({exc})", flush=True)
                        continue
                    cell = (
                        metrics.ate.rmse_m,
                        metrics.landmarks.rmse_m,
                        metrics.landmarks.estimated,
                    )
                    results.setdefault((label, estimator), []).append(cell)
                    lm = "-" if cell[1] is None else f"{cell[1]:.3f}"
                    print(
                        f"{label} {estimator} seed {seed}: ATE {cell[0]:.3f} m, landmark RMSE "
                        f"{lm} m, {cell[2]} landmarks, CPU {time.process_time() - start:.1f} s",
                        flush=True,
                    )
    columns = list(args.estimators)
    if any((label, LASER_ALONE) in results for label, _, _, _ in rows):
        at = columns.index("deadreckoning") + 1 if "deadreckoning" in columns else 0
        columns.insert(at, LASER_ALONE)
    print("\nATE [m] / landmark RMSE [m] / landmarks (mean over seeds for the particle filters; "
          "+- the std over seeds, [median])")
    print("| dataset | " + " | ".join(columns) + " |")
    print("|---|" + "---|" * len(columns))
    for label, _, _, _ in rows:
        parts = []
        for estimator in columns:
            values = results.get((label, estimator))
            if not values:
                parts.append("-")
                continue
            ate = np.mean([v[0] for v in values])
            lms = [v[1] for v in values if v[1] is not None]
            lm = f"{np.mean(lms):.3f}" if lms else "-"
            spread = ""
            if len(values) > 1:
                ates = [v[0] for v in values]
                spread = f" +- {np.std(ates):.2f} [{np.median(ates):.3f}]"
            parts.append(
                f"{ate:.3f}{spread} / {lm} / {round(np.mean([v[2] for v in values]))}"
            )
        print(f"| {label} | " + " | ".join(parts) + " |")
    carmen_rows = [label for label, _, _, carmen in rows if carmen]
    if carmen_rows and "deadreckoning" in args.estimators:
        print(f"\nCARMEN goal: every SLAM estimator <= {GOAL_RATIO}x dead reckoning's ATE")
        for label in carmen_rows:
            dr = results[(label, "deadreckoning")][0][0]
            for estimator in columns:
                if estimator == "deadreckoning" or (label, estimator) not in results:
                    continue
                ratio = np.mean([v[0] for v in results[(label, estimator)]]) / dr
                verdict = "met" if ratio <= GOAL_RATIO else "NOT met"
                if estimator == LASER_ALONE:
                    verdict = "no landmarks: what the estimators start from"
                print(f"  {label} {estimator}: {ratio:.2f}x dead reckoning ({verdict})")


if __name__ == "__main__":
    main()
