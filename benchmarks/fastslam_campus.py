"""The thesis's route-2 experiment (Guizilini 2008, sec. 5.1.2, Fig. 5.7-5.8) on ``campus1500``.

~1.5 km with a 70 m corridor where nothing can be recognised; pole sightings (the thesis's laser
stand-in for the camera) with **unknown association**. The thesis reports that after the blind
corridor FastSLAM 1.0 with 50 particles duplicates the map, 1.0 needs >= 200 particles, and
2.0 recovers with 50. Each FastSLAM configuration runs on every seed; graphslam and ekfslam
(deterministic) run once on the same sightings. For each run this prints ATE (SE(2)-aligned),
the landmarks estimated per landmark actually sighted on the route (> 1: duplicated or spurious
landmarks; the world holds more poles than the route ever sees), how many of them the
assignment evaluation (2 m gate) calls duplicates and spurious, and the estimator's CPU and
wall-clock time (its steps and final estimate)::

    .venv/bin/omnislam dataset synth campus1500 --out runs/campus1500     # once
    .venv/bin/python benchmarks/fastslam_campus.py [--data runs/campus1500] [--seeds 0 1 2]
        [--only fastslam2/50] [--only graphslam] [--no-baselines]
        [--set association.new_landmark_log_likelihood=-10 ...]

Every run replays one front-end log of the folder with no image processed (``run_frontend(...,
max_images=0)``, written to a temporary folder): the wheel odometry and the pole sightings,
which is what the shared front end's log of a render carries in its range-bearing stream (laser
odometry and laser landmarks are off on renders, ``frontend.config``) without its image front
end (SIFT tracks of the ~2 500 images, in worker processes), which no estimator here reads
(``modality=range-bearing-2d``).
"""

from __future__ import annotations

import argparse
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from harness_cells import set_options

from omnislam.datasets.registry import load_dataset, resolve
from omnislam.frontend.observation_log import save_observation_log
from omnislam.frontend.pipeline import run_frontend
from omnislam.harness.evaluation import EvaluationOptions, evaluate_run
from omnislam.harness.execute import RunSpec, execute_run

CONFIGS = (
    ("fastslam1", 50),
    ("fastslam1", 200),
    ("fastslam2", 50),
)
#: deterministic estimators on the same sightings, run once (with the first seed)
BASELINES = ("graphslam", "ekfslam")
#: the stages of a run that are the estimator's own (``RunConfig.stages_cpu_s``)
ESTIMATOR_STAGES = ("running", "final estimate")


@dataclass(frozen=True, slots=True)
class Row:
    """One run."""

    name: str
    particles: int | None
    seed: int
    ate_m: float
    per_sighted: float
    cpu_s: float
    wall_s: float


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default="runs/campus1500")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument(
        "--only",
        action="append",
        default=[],
        help="ESTIMATOR/PARTICLES or a baseline's name to run (repeatable)",
    )
    parser.add_argument(
        "--no-baselines", action="store_true", help=f"skip {' and '.join(BASELINES)}"
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="extra FastSLAM option for every run (repeatable)",
    )
    args = parser.parse_args()
    data = str(Path(args.data).resolve())
    extra = set_options(parser, args.set)
    runs: list[tuple[str, int | None]] = [
        c for c in CONFIGS if not args.only or f"{c[0]}/{c[1]}" in args.only
    ]
    if not args.no_baselines:
        runs += [(b, None) for b in BASELINES if not args.only or b in args.only]
    if extra:
        print("extra FastSLAM options:", " ".join(f"{k}={v}" for k, v in extra.items()))
    sighted = _sighted_landmarks(data)
    print(
        f"{'estimator':10s} {'particles':>9s} {'seed':>4s} {'ATE [m]':>8s} {'est/sighted':>11s} "
        f"{'per sighted':>11s} {'dup':>4s} {'spur':>4s} {'CPU [s]':>8s} {'wall [s]':>8s}"
    )
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        log = str(Path(tmp) / "sightings.npz")
        save_observation_log(run_frontend(load_dataset(resolve(data), {}), max_images=0), log)
        for name, particles in runs:
            seeds = args.seeds if particles is not None else args.seeds[:1]
            options = {"association": "unknown", "modality": "range-bearing-2d"}
            if particles is not None:
                options |= {"particles.n_particles": str(particles), **extra}
            for seed in seeds:
                record = execute_run(RunSpec(data, name, seed, options, log))
                metrics = evaluate_run(record, EvaluationOptions(landmark_gate_m=2.0))
                landmarks = metrics.landmarks
                estimated = landmarks.estimated
                stages_cpu, stages_wall = record.config.stages_cpu_s, record.config.stages_wall_s
                row = Row(
                    name,
                    particles,
                    seed,
                    metrics.ate.rmse_m,
                    estimated / sighted,
                    sum(stages_cpu.get(s, 0.0) for s in ESTIMATOR_STAGES),
                    sum(stages_wall.get(s, 0.0) for s in ESTIMATOR_STAGES),
                )
                rows.append(row)
                print(
                    f"{name:10s} {_particles(particles):>9s} {seed:4d} {row.ate_m:8.3f} "
                    f"{estimated:>7d}/{sighted:<3d} {row.per_sighted:11.2f} "
                    f"{landmarks.duplicates:4d} {landmarks.spurious:4d} "
                    f"{row.cpu_s:8.1f} {row.wall_s:8.1f}",
                    flush=True,
                )
    print("\nmedians over seeds")
    for name, particles in runs:
        sel = [r for r in rows if r.name == name and r.particles == particles]
        print(
            f"{name:10s} {_particles(particles):>9s} ATE {np.median([r.ate_m for r in sel]):.3f} "
            f"m, landmarks per sighted {np.median([r.per_sighted for r in sel]):.2f}, "
            f"CPU {np.median([r.cpu_s for r in sel]):.1f} s, "
            f"wall {np.median([r.wall_s for r in sel]):.1f} s"
        )


def _particles(particles: int | None) -> str:
    return "-" if particles is None else str(particles)


def _sighted_landmarks(data: str) -> int:
    """Distinct landmarks the route's sightings ever refer to (read with their ids)."""
    sequence = load_dataset(resolve(data), {"association": "known"})
    ids = [rb.landmark_ids for rb in sequence.range_bearing or () if rb is not None and len(rb)]
    return int(np.unique(np.concatenate(ids)).size)


if __name__ == "__main__":
    main()
