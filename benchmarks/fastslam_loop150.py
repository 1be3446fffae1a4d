"""The thesis's route-1 experiment (Guizilini 2008, sec. 5.1.2, Fig. 5.6) on ``loop150``.

A ~140 m closed corridor circuit with poles; the laser's pole sightings (1 cm range, 1 deg
bearing, 4 m range) carry the poles' ids, so association is not in question. The thesis reports
that FastSLAM 1.0 with 50 particles and 2.0 with 10 close the loop and that more particles do
not improve it. For each seed this simulates the preset (world details and odometry noise from
the seed; no images are rendered: the pole sightings need only the simulated run, written to a
temporary laser-only folder and read back with the synthetic loader), runs FastSLAM 1.0 and 2.0
at each particle count plus graphslam and dead reckoning, and prints per run:

* ATE RMSE after SE(2) alignment (as ``omnislam evaluate``),
* pose NEES mean (first pose anchored, as ``omnislam evaluate``'s ``nees_mean``), dof 3,
* FastSLAM's particle diversity (``fastslam/diversity.py``): resamplings, the fewest distinct
  ancestors of a step, the longest run of steps whose set descends from one particle,
* the estimator's CPU time (``time.process_time``) over its steps,
* the end error: the last pose's position error with the first pose anchored (no fit): whether
  the robot knows it is back at its start (the thesis's "returns to the initial point",
  sec. 5.1.2); dead reckoning's is its drift over the loop,
* with ``--set experimental.trajectory=best_ancestry``, "one path until": the fraction of the
  run at whose frames all final particles' paths pass through one particle
  (``PathHistory.lineages``): that part of the trajectory no later sighting can revise.

``graphslam-online`` is the same iSAM2 run read out causally: after every step its newest pose
(the estimate given the data so far, as a filter reports it), where ``graphslam`` reports the
final smoothed trajectory. It bounds what any filter's per-step estimate can reach: FastSLAM's
weighted-mean trajectory is such an estimate, and even its ancestral paths only choose among
poses that were sampled from the data up to their own step.

Then the medians over seeds and the targets: fastslam2@10 and fastslam1@50 median ATE
<= 3x graphslam's and <= 0.1x dead reckoning's; more particles never worse beyond the seed
spread; no collapse (no run of more than ``--collapse-steps`` single-ancestor steps) and pose
NEES mean <= 10x dof::

    PYTHONPATH=. .venv/bin/python benchmarks/fastslam_loop150.py [--seeds 0 1 2 3 4]
        [--particles 10 50 200 1000] [--variants fastslam1 fastslam2] [--no-baselines]
        [--set experimental.trajectory=best_ancestry ...] [--backend open3d|numpy] [--no-bias]
        [--keep DIR] [--graph-set motion_noise.a_vv=0.1 ...]
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import math
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from harness_cells import set_options

from omnislam.core.modality import modalities_of
from omnislam.core.sequence_info import SequenceInfo
from omnislam.core.types import Trajectory
from omnislam.datasets.sequence import Sequence
from omnislam.datasets.synthetic.loader import load_synthetic
from omnislam.datasets.synthetic.presets import PRESETS
from omnislam.datasets.synthetic.routes import NO_BIAS
from omnislam.datasets.synthetic.simulate import simulate
from omnislam.datasets.synthetic.writer import write_synthetic
from omnislam.estimators import make_estimator, resolve_estimator_modality
from omnislam.fastslam import FastSLAM
from omnislam.fastslam.config import TrajectoryMode
from omnislam.metrics.consistency import pose_nees
from omnislam.metrics.trajectory import Alignment, ate

PRESET = "loop150"
#: graphslam read out causally (its newest pose after every step)
ONLINE = "graphslam-online"
#: a collapse onto one ancestor may last at most this many steps with sightings
COLLAPSE_STEPS = 3
#: pose NEES mean may be at most this many times its degrees of freedom (3)
NEES_FACTOR = 10.0
#: the goal's particle counts: FastSLAM 2.0 with 10, 1.0 with 50 (thesis Fig. 5.6)
THESIS_CELLS = (("fastslam2", 10), ("fastslam1", 50))


@dataclass(frozen=True, slots=True)
class Row:
    """One run on one seed."""

    estimator: str
    particles: int | None
    seed: int
    ate_m: float
    end_m: float
    nees_mean: float | None
    resamplings: int | None
    distinct_min: int | None
    single_run: int | None
    cpu_s: float
    one_path_until: float | None = None


def laser_only_sequence(
    seed: int, folder: Path, backend: str | None, bias: bool = True
) -> Sequence:
    """Simulate ``loop150`` with ``seed`` and read it back without rendering any image.

    ``bias=False``: the robot's systematic odometry errors (``routes.OdometryBias``) switched
    off, only the thesis's zero-mean alpha noise left (the thesis's own simulation, sec. 5.1.1:
    Gaussian errors whose mean is the deterministic value).
    """
    preset = PRESETS[PRESET]
    if not bias:
        preset = dataclasses.replace(preset, odometry_bias=NO_BIAS)
    sim = simulate(preset, seed, backend=backend)
    sim = dataclasses.replace(sim, image_frames=sim.image_frames[:0])
    write_synthetic(folder, sim, backend=backend)
    return load_synthetic(folder)


def run_one(
    sequence: Sequence, estimator: str, options: dict[str, str], seed: int
) -> tuple[Row, object]:
    """Run ``estimator`` on the loader's own pole sightings (no front end) and score it."""
    frames = list(sequence.frame_inputs())
    sightings = [f.range_bearing for f in frames if f.range_bearing is not None]
    info = SequenceInfo(
        name=sequence.name,
        frames=len(sequence),
        modalities=modalities_of(frames),
        known_association=True,
        sigma_range_m=float(sightings[0].sigma_range_m[0]),
        sigma_bearing_rad=float(sightings[0].sigma_bearing_rad[0]),
    )
    online = estimator == ONLINE
    name = "graphslam" if online else estimator
    info = dataclasses.replace(info, modality=resolve_estimator_modality(name, info, options))
    slam = make_estimator(name, info, options, np.random.default_rng(seed))
    start = time.process_time()
    newest = []
    for frame in frames:
        slam.step(frame)
        if online:
            newest.append(slam.newest_pose())
    estimate = slam.estimate()
    cpu_s = time.process_time() - start
    truth = sequence.ground_truth.trajectory
    trajectory = estimate.trajectory
    if online:
        trajectory = Trajectory.from_se2(sequence.stamps_s, np.array(newest))
    ate_m = ate(trajectory, truth, Alignment.SE2).rmse_m
    end_m = float(ate(trajectory, truth, Alignment.ORIGIN).errors_m[-1])
    nees_mean = None
    if estimate.pose_covariances is not None and not online:
        nees_mean = float(pose_nees(estimate.trajectory, estimate.pose_covariances, truth).mean)
    particles = resamplings = distinct_min = single_run = one_path_until = None
    if isinstance(slam, FastSLAM):
        if slam.config.experimental.trajectory is TrajectoryMode.BEST_ANCESTRY:
            lineages = slam.history.lineages()
            single = np.flatnonzero(lineages == 1)
            one_path_until = float(single[-1] + 1) / lineages.size if single.size else 0.0
        summary = slam.diversity.summary()
        particles = slam.config.particles.n_particles
        resamplings = summary.resamplings
        distinct_min = summary.distinct_min
        single_run = summary.single_ancestor_longest_run
    row = Row(
        estimator,
        particles,
        seed,
        ate_m,
        end_m,
        nees_mean,
        resamplings,
        distinct_min,
        single_run,
        cpu_s,
        one_path_until,
    )
    return row, slam


def _label(estimator: str, particles: int | None) -> str:
    return estimator if particles is None else f"{estimator}@{particles}"


def _fmt(value: float | int | None, spec: str) -> str:
    if value is None:
        return "-"
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return format(value, spec)


def print_row(row: Row) -> None:
    print(
        f"{_label(row.estimator, row.particles):16s} seed {row.seed}  ATE {row.ate_m:7.3f} m  "
        f"end {row.end_m:6.3f} m  one path until {_fmt(row.one_path_until, '5.3f')}  "
        f"NEES {_fmt(row.nees_mean, '10.3g')}  resamplings {_fmt(row.resamplings, '4d')}  "
        f"distinct min {_fmt(row.distinct_min, '4d')}  single-ancestor run "
        f"{_fmt(row.single_run, '3d')}  CPU {row.cpu_s:6.1f} s",
        flush=True,
    )


def summarise(rows: list[Row], variants: list[str], particles: list[int]) -> None:
    """Medians over seeds, and the goals."""
    groups: dict[str, list[Row]] = {}
    for row in rows:
        groups.setdefault(_label(row.estimator, row.particles), []).append(row)
    print(
        "\n| run | median ATE [m] | min-max ATE | median end error [m] | median NEES | "
        "max single-ancestor run |"
    )
    print("|---|---:|---:|---:|---:|---:|")
    medians: dict[str, float] = {}
    for label, group in groups.items():
        ates = np.array([r.ate_m for r in group])
        medians[label] = float(np.median(ates))
        nees = [r.nees_mean for r in group if r.nees_mean is not None]
        runs = [r.single_run for r in group if r.single_run is not None]
        print(
            f"| {label} | {medians[label]:.3f} | {ates.min():.3f}-{ates.max():.3f} | "
            f"{np.median([r.end_m for r in group]):.3f} | "
            f"{_fmt(float(np.median(nees)) if nees else None, '.3g')} | "
            f"{max(runs) if runs else '-'} |"
        )
    graph, dead = medians.get("graphslam"), medians.get("deadreckoning")
    print("\ngoals:")
    for estimator, count in THESIS_CELLS:
        label = _label(estimator, count)
        if label not in medians or graph is None or dead is None:
            continue
        value = medians[label]
        print(
            f"  {label}: median ATE {value:.3f} m = {value / graph:.2f}x graphslam "
            f"(goal <= 3), {value / dead:.3f}x dead reckoning (goal <= 0.1): "
            f"{'met' if value <= 3 * graph and value <= 0.1 * dead else 'NOT met'}"
        )
    for estimator in variants:
        labels = [_label(estimator, p) for p in particles if _label(estimator, p) in groups]
        for fewer, more in itertools.pairwise(labels):
            a = np.array([r.ate_m for r in groups[fewer]])
            b = np.array([r.ate_m for r in groups[more]])
            spread = max(a.std(), b.std())
            worse = np.median(b) > np.median(a) + spread
            print(
                f"  {more} vs {fewer}: median {np.median(b):.3f} vs {np.median(a):.3f} m, "
                f"seed spread (std) {spread:.3f}: {'WORSE' if worse else 'not worse'}"
            )
    fastslam = [r for r in rows if r.particles is not None]
    if fastslam:
        collapsed = [r for r in fastslam if r.single_run > COLLAPSE_STEPS]
        inconsistent = [r for r in fastslam if r.nees_mean is None or r.nees_mean > 3 * NEES_FACTOR]
        print(
            f"  collapse (> {COLLAPSE_STEPS} consecutive single-ancestor steps): "
            f"{len(collapsed)} of {len(fastslam)} runs"
        )
        print(
            f"  pose NEES mean > {3 * NEES_FACTOR:.0f} (10x dof): {len(inconsistent)} of "
            f"{len(fastslam)} runs"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    parser.add_argument("--particles", type=int, nargs="+", default=[10, 50, 200, 1000])
    parser.add_argument("--variants", nargs="+", default=["fastslam1", "fastslam2"])
    parser.add_argument("--no-baselines", action="store_true", help="skip graphslam and DR")
    parser.add_argument("--backend", default=None, help="ray caster of the simulation")
    parser.add_argument(
        "--no-bias",
        action="store_true",
        help="odometry without the robot's systematic errors (zero-mean alpha noise only)",
    )
    parser.add_argument(
        "--keep",
        type=Path,
        default=None,
        metavar="DIR",
        help="write each seed's laser-only folder to DIR/loop150-sSEED instead of a temporary one",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="extra FastSLAM option for every FastSLAM run (repeatable)",
    )
    parser.add_argument(
        "--graph-set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="extra graphslam option for graphslam and graphslam-online (repeatable)",
    )
    args = parser.parse_args()
    extra = set_options(parser, args.set)
    graph_extra = set_options(parser, args.graph_set, "--graph-set")
    if args.no_bias:
        print("odometry: zero-mean alpha noise only (no systematic bias)")
    if graph_extra:
        print("extra graphslam options:", " ".join(f"{k}={v}" for k, v in graph_extra.items()))
    if extra:
        print("extra FastSLAM options:", " ".join(f"{k}={v}" for k, v in extra.items()))
    rows: list[Row] = []
    for seed in args.seeds:
        print(f"{PRESET} seed {seed}: simulating the route ...", file=sys.stderr, flush=True)
        if args.keep is not None:
            folder = args.keep / f"{PRESET}-s{seed}"
            sequence = laser_only_sequence(seed, folder, args.backend, not args.no_bias)
        else:
            with tempfile.TemporaryDirectory(prefix="loop150-") as tmp:
                folder = Path(tmp) / f"{PRESET}-s{seed}"
                sequence = laser_only_sequence(seed, folder, args.backend, not args.no_bias)
        runs: list[tuple[str, dict[str, str]]] = []
        if not args.no_baselines:
            runs += [("deadreckoning", {}), ("graphslam", graph_extra), (ONLINE, graph_extra)]
        runs += [
            (variant, {**extra, "particles.n_particles": str(count)})
            for variant in args.variants
            for count in args.particles
        ]
        for estimator, options in runs:
            particles = options.get("particles.n_particles")
            label = estimator if particles is None else f"{estimator}@{particles}"
            print(f"{PRESET} seed {seed}: running {label} ...", file=sys.stderr, flush=True)
            row, _ = run_one(sequence, estimator, options, seed)
            rows.append(row)
            print_row(row)
    summarise(rows, args.variants, args.particles)


if __name__ == "__main__":
    main()
