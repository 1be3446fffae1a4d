"""The thesis's route-2 experiment (Guizilini 2008, sec. 5.1.2, Fig. 5.7-5.8) on ``campus1500``.

~1.5 km with a 70 m corridor where nothing can be recognised; pole sightings (the thesis's laser
stand-in for the camera) with **unknown association**. The thesis reports that after the blind
corridor FastSLAM 1.0 with 50 particles duplicates the map, 1.0 needs >= 200 particles, and
2.0 recovers with 50. For each configuration and seed this prints ATE (SE(2)-aligned), the
landmarks estimated per landmark actually sighted on the route (> 1: duplicated or spurious
landmarks; the world holds more poles than the route ever sees), how many of them the
assignment evaluation (2 m gate) calls duplicates and spurious, and the run time::

    .venv/bin/omnislam dataset synth campus1500 --out runs/campus1500     # once
    .venv/bin/python benchmarks/fastslam_campus.py [--data runs/campus1500] [--seeds 0 1 2]
        [--only fastslam2/50] [--set new_landmark_log_likelihood=-10 ...]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from omnislam.compare.evaluation import EvaluationOptions, evaluate_run
from omnislam.compare.execute import RunSpec, execute_run
from omnislam.datasets.registry import load_dataset, resolve

CONFIGS = (
    ("fastslam1", 50),
    ("fastslam1", 200),
    ("fastslam2", 50),
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default="runs/campus1500")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument(
        "--only", action="append", default=[], help="ESTIMATOR/PARTICLES to run (repeatable)"
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
    extra = dict(item.split("=", 1) for item in args.set)
    configs = [c for c in CONFIGS if not args.only or f"{c[0]}/{c[1]}" in args.only]
    if extra:
        print("extra options:", " ".join(f"{k}={v}" for k, v in extra.items()))
    sighted = _sighted_landmarks(data)
    print(
        f"{'estimator':10s} {'particles':>9s} {'seed':>4s} {'ATE [m]':>8s} {'est/sighted':>11s} "
        f"{'per sighted':>11s} {'dup':>4s} {'spur':>4s} {'time [s]':>8s}"
    )
    rows = []
    for name, particles in configs:
        for seed in args.seeds:
            spec = RunSpec(
                data,
                name,
                seed,
                {"association": "unknown", "n_particles": str(particles), **extra},
            )
            start = time.perf_counter()
            record = execute_run(spec)
            seconds = time.perf_counter() - start
            metrics = evaluate_run(record, EvaluationOptions(landmark_gate_m=2.0))
            landmarks = metrics.landmarks
            estimated = landmarks.estimated
            rows.append((name, particles, metrics.ate.rmse_m, estimated / sighted, seconds))
            print(
                f"{name:10s} {particles:9d} {seed:4d} {metrics.ate.rmse_m:8.3f} "
                f"{estimated:>7d}/{sighted:<3d} {estimated / sighted:11.2f} "
                f"{landmarks.duplicates:4d} {landmarks.spurious:4d} "
                f"{seconds:8.1f}",
                flush=True,
            )
    print("\nmedians over seeds")
    for name, particles in configs:
        sel = [r for r in rows if r[0] == name and r[1] == particles]
        print(
            f"{name:10s} {particles:9d} ATE {np.median([r[2] for r in sel]):.3f} m, "
            f"landmarks per sighted {np.median([r[3] for r in sel]):.2f}, "
            f"time {np.median([r[4] for r in sel]):.1f} s"
        )


def _sighted_landmarks(data: str) -> int:
    """Distinct landmarks the route's sightings ever refer to (read with their ids)."""
    sequence = load_dataset(resolve(data), {"association": "known"})
    ids = [rb.landmark_ids for rb in sequence.range_bearing or () if rb is not None and len(rb)]
    return int(np.unique(np.concatenate(ids)).size)


if __name__ == "__main__":
    main()
