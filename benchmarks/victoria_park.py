"""Victoria Park against GPS: ATE and landmark counts of the SLAM back ends.

The target: graphslam and fastslam2 each <= 3 m ATE against GPS (SE(2)-aligned RMSE
over the frames with a GPS fix), the landmark counts reported, and explained where they differ by
more than 30 % between the back ends. A cell is what

    omnislam run victoria-park --estimator E --seed S --out R [--set KEY=VALUE ...]
    omnislam evaluate R --json

reports (``execute_run`` and ``evaluate_run``): ATE RMSE and the landmarks of the final map (the
best particle's for FastSLAM), with ``estimator_info.json``'s counters. graphslam and ekfslam are
deterministic and run once (seed 0); the particle filters once per ``--seeds``, and their row
gives the median over the seeds and every seed's value. ``--set`` reaches the FastSLAM cells only
(``fastslam1`` / ``fastslam2``: ``omnislam/fastslam/config.py``), so a FastSLAM option is
measured against unchanged baselines. Each cell is cached as JSON under ``--cache`` (file name
from the estimator, seed and options) so an interrupted table resumes; ``--fresh`` ignores it::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python benchmarks/victoria_park.py
        [--estimators graphslam ekfslam fastslam1 fastslam2] [--seeds 0 1 2]
        [--set KEY=VALUE ...] [--cache runs/victoria_park] [--fresh]

Cost on the shared 2-core machine: graphslam ~10-15 min, ekfslam ~3 min, fastslam2 ~25 s per
seed, fastslam1 (100 particles) ~2 min CPU per seed (10-13 min before the compiled
association likelihoods, benchmarks/fastslam_real_speed.py).
"""

from __future__ import annotations

import argparse
import hashlib
import json
from pathlib import Path

import numpy as np
from harness_cells import run_cell, set_options

DATASET = "victoria-park"
PARTICLE_FILTERS = ("fastslam1", "fastslam2")
#: the bound on graphslam's and fastslam2's ATE against GPS [m]
GOAL_ATE_M = 3.0
#: landmark counts further apart than this fraction are to be explained
COUNT_DIFFERENCE = 0.30
#: ``estimator_info.json`` counters shown when present (graphslam's, ekfslam's, FastSLAM's)
COUNT_KEYS = (
    "landmarks_created",
    "sightings_associated",
    "sightings_ambiguous",
    "landmarks_merged",
    "created",
    "tentative_dropped",
    "landmark_slots",
    "distinct_ancestors_median",
    "resample_count",
)


def cell(estimator: str, seed: int, options: dict[str, str], cache: Path | None) -> dict:
    """ATE, landmark count and counters of one run (from the cache if there)."""
    key = hashlib.sha1(json.dumps(sorted(options.items())).encode()).hexdigest()[:10]
    path = None if cache is None else cache / f"{estimator}_s{seed}_{key}.json"
    return run_cell(DATASET, estimator, seed, options, path, COUNT_KEYS)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--estimators", nargs="+", default=["graphslam", "ekfslam", "fastslam1", "fastslam2"]
    )
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--cache", type=Path, default=Path("runs/victoria_park"))
    parser.add_argument("--fresh", action="store_true", help="ignore cached cells")
    args = parser.parse_args()
    cache = None if args.fresh else args.cache
    fastslam_options = set_options(parser, args.set)
    if fastslam_options:
        print("FastSLAM options:", " ".join(f"{k}={v}" for k, v in fastslam_options.items()))
    print("| estimator | ATE vs GPS [m] (median) | per seed | landmarks | counters | CPU [s] |")
    print("|---|---|---|---|---|---|")
    landmarks: dict[str, float] = {}
    medians: dict[str, float] = {}
    for estimator in args.estimators:
        particle = estimator in PARTICLE_FILTERS
        seeds = args.seeds if particle else [0]
        options = fastslam_options if particle else {}
        cells = [cell(estimator, seed, options, cache) for seed in seeds]
        ates = [c["ate_m"] for c in cells]
        counts = [c["landmarks"] for c in cells]
        medians[estimator] = float(np.median(ates))
        landmarks[estimator] = float(np.median(counts))
        counters = " ".join(f"{k}={v}" for k, v in cells[0]["counts"].items()) or "-"
        cpu = " / ".join(f"{c['cpu_s']:.0f}" for c in cells)
        print(
            f"| {estimator} | {medians[estimator]:.2f} | "
            f"{' / '.join(f'{a:.2f}' for a in ates)} | "
            f"{' / '.join(str(n) for n in counts)} | {counters} (seed {seeds[0]}) | "
            f"{cpu} |",
            flush=True,
        )
    for estimator in ("graphslam", "fastslam2"):
        if estimator in medians:
            verdict = "met" if medians[estimator] <= GOAL_ATE_M else "NOT met"
            print(f"goal {estimator} <= {GOAL_ATE_M:g} m: {medians[estimator]:.2f} m, {verdict}")
    names = list(landmarks)
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            difference = abs(landmarks[a] - landmarks[b]) / min(landmarks[a], landmarks[b])
            if difference > COUNT_DIFFERENCE:
                print(
                    f"landmark counts {a} {landmarks[a]:.0f} vs {b} {landmarks[b]:.0f}: "
                    f"{difference:.0%} apart (> {COUNT_DIFFERENCE:.0%}, to be explained)"
                )


if __name__ == "__main__":
    main()
