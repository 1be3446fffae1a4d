"""Clutter: false detections without ids added to the sightings, every back end with its defaults.

The clutter target: with 0.5 false detections per frame added, the map stays within 10 %
of the true landmark count and the ATE within 1.5x of the clean run. A cell is what

    omnislam run DATASET --estimator E --seed S --out R --set association=unknown \\
        [--set clutter_per_frame=0.5]
    omnislam evaluate R --json

reports (``execute_run`` / ``evaluate_run``): the harness option ``clutter_per_frame``
(``harness.perturb.add_clutter``) adds a Poisson number of range-bearing detections per frame,
uniform over the span of the data's own sightings (range, bearing), with the data's median
sigmas and no id, from its own random stream (the estimator's is the same with and without).
The ids of the real sightings are hidden too (``association=unknown``): clutter is only told
apart by the association. Every estimator runs with its defaults (one set for every dataset).

Printed per dataset and estimator: ATE clean and cluttered and their ratio, the landmarks
mapped clean and cluttered against the true count, the false detections added, the
association counts of ``estimator_info.json`` where the estimator reports them, and whether
the goal holds. Cells are cached as JSON under ``--cache`` (``--fresh`` ignores it)::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python benchmarks/clutter.py
        [--datasets mrclam6-r3 mrclam6-r4] [--estimators graphslam ekfslam fastslam2]
        [--rate 0.5] [--seed 0] [--cache runs/clutter] [--fresh] [--set KEY=VALUE ...]

``--set KEY=VALUE`` (repeatable) adds an option to every cell, clean and cluttered alike --
an estimator's (the graph's ``association.tentative_min_sightings=3``) or the loader's -- as
``omnislam run --set`` does; the cells of each set of options are cached under their own names.
"""

from __future__ import annotations

import argparse
import hashlib
from pathlib import Path

from harness_cells import run_cell, set_options

#: association counters read from ``estimator_info.json`` (graphslam's, ekfslam's, FastSLAM's)
COUNT_KEYS = (
    "landmarks_created",
    "tentative_dropped",
    "created",
    "gated",
    "pruned",
    "landmarks_pruned",
)
#: the goal: landmark count within this fraction of the truth, ATE within this ratio
COUNT_TOLERANCE = 0.10
ATE_RATIO = 1.5


def cell(
    dataset: str,
    estimator: str,
    seed: int,
    rate: float,
    cache: Path | None,
    extra: dict[str, str] | None = None,
) -> dict:
    """ATE, landmarks and association counts of one run (from the cache if there); ``extra``
    are options added to the run (``--set``)."""
    extra = dict(extra or {})
    tag = ""
    if extra:
        text = ",".join(f"{k}={v}" for k, v in sorted(extra.items()))
        tag = "_" + hashlib.sha256(text.encode()).hexdigest()[:10]
    name = f"{dataset}_{estimator}_s{seed}_clutter{rate:g}{tag}.json"
    options = {"association": "unknown", **extra}
    if rate > 0:
        options["clutter_per_frame"] = repr(rate)
    path = None if cache is None else cache / name
    return run_cell(dataset, estimator, seed, options, path, COUNT_KEYS)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--datasets", nargs="+", default=["mrclam6-r3", "mrclam6-r4"])
    parser.add_argument("--estimators", nargs="+", default=["graphslam", "ekfslam", "fastslam2"])
    parser.add_argument("--rate", type=float, default=0.5, help="false detections per frame")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--cache", type=Path, default=Path("runs/clutter"))
    parser.add_argument("--fresh", action="store_true", help="ignore cached cells")
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="an option added to every run (repeatable)",
    )
    args = parser.parse_args()
    extra = set_options(parser, args.set)
    if "clutter_per_frame" in extra:
        parser.error("--set clutter_per_frame would reach the clean cells too; use --rate")
    cache = None if args.fresh else args.cache
    if extra:
        print("options added to every run: " + " ".join(f"{k}={v}" for k, v in extra.items()))
    print(
        "| dataset | estimator | ATE clean [m] | ATE clutter [m] | ratio | landmarks clean / "
        "clutter (true) | added | counts with clutter | goal |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    met_all = True
    for dataset in args.datasets:
        for estimator in args.estimators:
            clean = cell(dataset, estimator, args.seed, 0.0, cache, extra)
            noisy = cell(dataset, estimator, args.seed, args.rate, cache, extra)
            ratio = noisy["ate_m"] / clean["ate_m"]
            truth = noisy["truth"]
            count_ok = truth is not None and abs(noisy["landmarks"] - truth) <= max(
                1, COUNT_TOLERANCE * truth
            )
            met = count_ok and ratio <= ATE_RATIO
            met_all &= met
            counts = " ".join(f"{k}={v}" for k, v in noisy["counts"].items()) or "-"
            print(
                f"| {dataset} | {estimator} | {clean['ate_m']:.3f} | {noisy['ate_m']:.3f} | "
                f"{ratio:.2f} | {clean['landmarks']} / {noisy['landmarks']} ({truth}) | "
                f"{noisy['added']} | {counts} | {'met' if met else 'NOT met'} |",
                flush=True,
            )
    print(
        f"goal (clutter {args.rate:g} per frame: landmarks within {COUNT_TOLERANCE:.0%} of the "
        f"truth, ATE <= {ATE_RATIO}x the clean run's): {'met' if met_all else 'NOT met'}"
    )


if __name__ == "__main__":
    main()
