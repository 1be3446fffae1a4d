"""The shared front end's laser odometry (``omnislam.frontend.scan_matching``) on its own.

For each dataset (a registered name such as ``carmen-intel``, or a render folder): how many
matches were accepted, degenerate (corridor) or rejected, the step error of the accepted
increments against the ground truth next to the wheel odometry's, the median NEES of their
stated covariance (2.37 expected), their mean heading error (a bias adds up over the run),
the spread of their heading error over its stated std (1 and 0.3 % beyond 3 when the
covariance is right; a heavy tail is steps stated too narrow), the CPU per scan, and the
SE(2)-aligned ATE of the laser odometry composed alone against the wheels'.
``--submap-scans`` repeats it for other submap sizes.

With ``--consistency`` it prints instead how well the stated covariance of the accepted steps
describes their errors against the corrected poses' increments: per band of the step's true
rotation (and over all steps) the standard deviation of each axis' error over its stated std
(x, y, theta; 1 when consistent), the share of heading errors beyond 3 stated stds (0.3 %), and
the mean and median of the 3-dof NEES ``e^T P^-1 e`` (3 and 2.37), then the same pooled over
every dataset given. ``--config`` overrides the laser odometry's options (the section
``laser_odometry`` of a front-end configuration, e.g. ``'{covariance_inflation: 12}'``).

With ``--estimators`` it also runs them (seed 0) on a log of the dataset's own range-bearing
sightings (the renders' poles, ids known, ``modality=range-bearing-2d``; no images processed)
twice: with the wheel odometry and with the laser odometry (``with_images: true``), to show what
the laser odometry does under sightings that already correct the wheels.

::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python benchmarks/laser_odometry.py
        [carmen-intel carmen-aces /path/loop150-render ...] [--submap-scans 3 1 10]
        [--estimators graphslam fastslam2 ekfslam]
        [--consistency [--config '{covariance_inflation: 12}']]
"""

from __future__ import annotations

import argparse
import itertools
import sys
import tempfile
import time
from collections import Counter
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import yaml

from omnislam.core.se import se2_between, se2_integrate, wrap_angle
from omnislam.core.types import Trajectory
from omnislam.datasets.registry import load_dataset, resolve
from omnislam.frontend.config import (
    FrontendConfig,
    LaserOdometryConfig,
    frontend_config_from_dict,
)
from omnislam.frontend.scan_matching import laser_odometry
from omnislam.metrics.trajectory import Alignment, ate


def report(dataset: str, submap_scans: int) -> None:
    sequence = load_dataset(resolve(dataset), {})
    scans, truth = sequence.laser, sequence.ground_truth.trajectory
    config = replace(LaserOdometryConfig(), submap_scans=submap_scans)
    start = time.process_time()
    lo = laser_odometry(
        scans.angles_rad, scans.ranges_m, scans.max_range_m, sequence.odometry_r, config,
        sequence.odometry_covariance_r,
    )
    per_scan_ms = 1000 * (time.process_time() - start) / len(sequence)
    poses = truth.se2
    true = np.zeros_like(sequence.odometry_r)
    true[1:] = se2_between(poses[:-1], poses[1:])
    used = lo.accepted

    def step_errors(deltas: np.ndarray) -> tuple[float, float]:
        e = deltas[used] - true[used]
        return (float(np.median(np.hypot(e[:, 0], e[:, 1]))),
                float(np.degrees(np.median(np.abs(wrap_angle(e[:, 2]))))))

    e = lo.deltas - true
    e[:, 2] = wrap_angle(e[:, 2])
    nees = [e[i] @ np.linalg.solve(lo.covariances[i], e[i]) for i in np.flatnonzero(used)]
    heading_z = e[used, 2] / np.sqrt(lo.covariances[used, 2, 2])
    counts = Counter(r for r in lo.reasons if r)
    laser_xy, laser_deg = step_errors(lo.deltas)
    wheel_xy, wheel_deg = step_errors(sequence.odometry_r)

    def alone(deltas: np.ndarray) -> float:
        estimate = Trajectory.from_se2(sequence.stamps_s, se2_integrate(deltas))
        return ate(estimate, truth, Alignment.SE2).rmse_m

    print(
        f"{Path(dataset).name} submap {submap_scans}: {dict(counts)} of {len(sequence) - 1}; "
        f"accepted steps' error median {100 * laser_xy:.1f} cm / {laser_deg:.2f} deg (wheels "
        f"{100 * wheel_xy:.1f} cm / {wheel_deg:.2f} deg), mean heading error "
        f"{np.degrees(np.mean(e[used, 2])):+.4f} deg per step; NEES median {np.median(nees):.2f}; "
        f"heading error / stated std: std {np.std(heading_z):.2f}, "
        f"{100 * np.mean(np.abs(heading_z) > 3):.1f} % beyond 3; "
        f"{per_scan_ms:.1f} ms CPU per scan; ATE alone {alone(lo.deltas):.3f} m (wheels "
        f"{alone(sequence.odometry_r):.3f} m)",
        flush=True,
    )


TURN_BANDS_DEG = (0.0, 5.0, 15.0, 30.0, 180.0)  # bands of the step's true rotation


@dataclass(frozen=True, slots=True)
class Consistency:
    """The accepted steps' errors against their stated covariance.

    Attributes:
        errors: (M, 3) laser increment minus the corrected poses' increment [m, m, rad].
        covariances: (M, 3, 3) the stated covariances of those increments.
        rotations_rad: (M,) the corrected poses' rotation over each step.
    """

    errors: np.ndarray
    covariances: np.ndarray
    rotations_rad: np.ndarray

    @staticmethod
    def concatenate(parts: list[Consistency]) -> Consistency:
        """The steps of several datasets pooled."""
        return Consistency(*(np.concatenate([getattr(p, f) for p in parts]) for f in
                             ("errors", "covariances", "rotations_rad")))

    def summary(self, mask: np.ndarray | None = None) -> ConsistencySummary | None:
        """The consistency of the steps in ``mask`` (all when None); None under 5 steps.

        z = error / stated std per axis (std 1 and 0.27 % beyond 3 when consistent); NEES
        ``e^T P^-1 e`` (chi-square with 3 dof when consistent: mean 3, median 2.37;
        Bar-Shalom, Li & Kirubarajan 2001, sec. 5.4.2).
        """
        keep = np.ones(len(self.errors), dtype=bool) if mask is None else mask
        e, P = self.errors[keep], self.covariances[keep]
        if len(e) < 5:
            return None
        z = e / np.sqrt(np.diagonal(P, axis1=1, axis2=2))
        nees = np.einsum("ni,ni->n", e, np.linalg.solve(P, e[:, :, None])[:, :, 0])
        return ConsistencySummary(len(e), z.std(axis=0), float(np.mean(np.abs(z[:, 2]) > 3)),
                                  float(nees.mean()), float(np.median(nees)))

    def rows(self) -> list[tuple[str, int, ConsistencySummary | None]]:
        """(band, steps, summary) over all steps, then per band of the true rotation."""
        turn_deg = np.degrees(np.abs(self.rotations_rad))
        out = [("all", len(self.errors), self.summary())]
        for lo, hi in itertools.pairwise(TURN_BANDS_DEG):
            band = (turn_deg >= lo) & (turn_deg < hi)
            out.append((f"{lo:.0f}-{hi:.0f} deg", int(band.sum()), self.summary(band)))
        return out


@dataclass(frozen=True, slots=True)
class ConsistencySummary:
    """How well stated covariances describe a set of errors.

    Attributes:
        steps: how many steps.
        z_std: (3,) standard deviation of the error over its stated std, per axis (x, y, theta).
        beyond_3_theta: share of the steps whose heading error exceeds 3 stated stds.
        nees_mean: mean 3-dof NEES.
        nees_median: median 3-dof NEES.
    """

    steps: int
    z_std: np.ndarray
    beyond_3_theta: float
    nees_mean: float
    nees_median: float

    def cells(self) -> str:
        """The markdown cells after the step count."""
        sx, sy, st = self.z_std
        return (f"{sx:.2f} | {sy:.2f} | {st:.2f} | {100 * self.beyond_3_theta:.1f} | "
                f"{self.nees_mean:.2f} | {self.nees_median:.2f}")


def consistency(dataset: str, config: LaserOdometryConfig) -> Consistency:
    """The laser odometry of ``dataset`` with ``config``, its accepted steps against the truth."""
    sequence = load_dataset(resolve(dataset), {})
    scans, poses = sequence.laser, sequence.ground_truth.trajectory.se2
    lo = laser_odometry(
        scans.angles_rad, scans.ranges_m, scans.max_range_m, sequence.odometry_r, config,
        sequence.odometry_covariance_r,
    )
    true = np.zeros_like(sequence.odometry_r)
    true[1:] = se2_between(poses[:-1], poses[1:])
    e = lo.deltas - true
    e[:, 2] = wrap_angle(e[:, 2])
    used = lo.accepted
    return Consistency(e[used], lo.covariances[used], wrap_angle(true[used, 2]))


def print_consistency(datasets: list[str], config: LaserOdometryConfig) -> None:
    """The consistency table of every dataset, then pooled over them (markdown)."""
    print("| log | step rotation | steps | z x std | z y std | z theta std | "
          "% beyond 3 (theta) | NEES mean | NEES median |\n|---|---|---|---|---|---|---|---|---|")
    parts = []
    for dataset in datasets:
        parts.append(consistency(dataset, config))
        _print_rows(Path(dataset).name.split("-corrected")[0], parts[-1])
    if len(parts) > 1:
        _print_rows("pooled", Consistency.concatenate(parts))


def _print_rows(name: str, steps: Consistency) -> None:
    for band, n, summary in steps.rows():
        cells = "| | | | |" if summary is None else summary.cells()
        print(f"| {name} | {band} | {n} | {cells} |", flush=True)


def with_and_without(dataset: str, estimators: list[str]) -> None:
    """Each estimator on the dataset's own sightings, wheel odometry against laser odometry."""
    from omnislam.frontend.observation_log import save_observation_log
    from omnislam.frontend.pipeline import run_frontend
    from omnislam.harness.evaluation import evaluate_run
    from omnislam.harness.execute import RunSpec, execute_run

    sequence = load_dataset(resolve(dataset), {})
    with tempfile.TemporaryDirectory() as tmp:
        for on in (False, True):
            config = FrontendConfig(
                laser_odometry=LaserOdometryConfig(enabled=on, with_images=True)
            )
            path = Path(tmp) / f"{on}.npz"
            print(
                f"{Path(dataset).name}: {'laser' if on else 'wheel'} odometry: the front end's "
                f"laser, then running {', '.join(estimators)} ...",
                file=sys.stderr,
                flush=True,
            )
            save_observation_log(run_frontend(sequence, config, max_images=0), path)
            for estimator in estimators:
                spec = RunSpec(dataset, estimator, 0, {"modality": "range-bearing-2d"}, str(path))
                metrics = evaluate_run(execute_run(spec))
                lm = metrics.landmarks.rmse_m
                print(
                    f"{Path(dataset).name} {'laser' if on else 'wheel'} odometry {estimator}: "
                    f"ATE {metrics.ate.rmse_m:.4f} m, landmark RMSE "
                    f"{'-' if lm is None else f'{lm:.4f}'} m",
                    flush=True,
                )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("datasets", nargs="*", default=["carmen-intel", "carmen-aces"])
    parser.add_argument("--submap-scans", type=int, nargs="+", default=[3])
    parser.add_argument("--estimators", nargs="*", default=[])
    parser.add_argument("--consistency", action="store_true",
                        help="the stated covariance against the errors (module docstring)")
    parser.add_argument("--config", default="{}",
                        help="laser odometry overrides (YAML), with --consistency")
    args = parser.parse_args()
    if args.consistency:
        overrides = {"laser_odometry": yaml.safe_load(args.config) or {}}
        print_consistency(args.datasets, frontend_config_from_dict(overrides).laser_odometry)
        return
    for dataset in args.datasets:
        for k in args.submap_scans:
            report(dataset, k)
        if args.estimators:
            with_and_without(dataset, args.estimators)


if __name__ == "__main__":
    main()
