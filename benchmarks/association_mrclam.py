"""MR.CLAM dataset 6, robots 1-5: ATE with the sightings' ids and with them ignored.

The association's targets on MR.CLAM, measured through the harness of ``omnislam run`` / ``omnislam
evaluate`` (``execute_run`` and ``evaluate_run``): a cell is what

    omnislam run mrclam6-rK --estimator E --seed S --out R [--set association=unknown]
    omnislam evaluate R --json

reports -- ATE RMSE after SE(2) alignment and the number of landmarks in the map (15 exist).
The estimators run with their defaults (one set for every dataset); ``association=unknown``
only hides the ids. Printed per estimator: one row per robot (ATE with ids, ATE without, their
ratio, landmarks without ids, the association counts of ``estimator_info.json`` where the
estimator reports them), then the medians and the goals:

* graphslam with ids: median <= 0.08 m and no robot above 0.15 m;
* ids ignored: each estimator within 1.5x of its own ATE with ids, with 15 +- 1 landmarks.

Each run's numbers are cached as JSON under ``--cache`` (one file per cell) so an interrupted
table resumes; ``--fresh`` ignores the cache::

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python benchmarks/association_mrclam.py
        [--robots 1 2 3 4 5] [--estimators graphslam ekfslam fastslam2] [--seed 0]
        [--cache runs/association_mrclam] [--fresh] [--set KEY=VALUE ...]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from harness_cells import run_cell, set_options

#: the association counters read from ``estimator_info.json`` when present (graphslam's,
#: ekfslam's, FastSLAM's names)
COUNT_KEYS = (
    "landmarks_created",
    "sightings_associated",
    "sightings_ambiguous",
    "sightings_gated",
    "landmarks_merged",
    "loop_closures",
    "created",
    "associated",
    "gated",
    "ambiguous",
    "tentative_dropped",
    "unknown_slots",
    "unknown_matched",
    "unknown_new",
    "landmarks_pruned",
)
TRUE_LANDMARKS = 15


def cell(
    dataset: str,
    estimator: str,
    seed: int,
    unknown: bool,
    cache: Path | None,
    extra: dict[str, str] | None = None,
) -> dict:
    """ATE, landmark count and association counts of one run (from the cache if there);
    ``extra``: ``--set`` options (estimator or loader) given to every run."""
    extra = extra or {}
    shown = "".join(f"_{k}={v}" for k, v in sorted(extra.items()))
    name = f"{dataset}_{estimator}_s{seed}_{'unknown' if unknown else 'ids'}{shown}.json"
    options = {**extra, **({"association": "unknown"} if unknown else {})}
    path = None if cache is None else cache / name
    return run_cell(dataset, estimator, seed, options, path, COUNT_KEYS)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    parser.add_argument("--estimators", nargs="+", default=["graphslam", "ekfslam", "fastslam2"])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--cache", type=Path, default=Path("runs/association_mrclam"))
    parser.add_argument("--fresh", action="store_true", help="ignore cached cells")
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="an estimator or loader option for every run (e.g. same_image_s=0)",
    )
    args = parser.parse_args()
    extra = set_options(parser, args.set)
    cache = None if args.fresh else args.cache
    for estimator in args.estimators:
        print(f"\n{estimator} (seed {args.seed}):")
        print(
            "| robot | ATE ids [m] | ATE unknown [m] | ratio | landmarks ids | "
            "landmarks unknown | counts unknown | CPU ids / unknown [s] |"
        )
        print("|---|---|---|---|---|---|---|---|")
        with_ids, without, ratios, counts_ok = [], [], [], []
        for robot in args.robots:
            dataset = f"mrclam6-r{robot}"
            a = cell(dataset, estimator, args.seed, False, cache, extra)
            b = cell(dataset, estimator, args.seed, True, cache, extra)
            ratio = b["ate_m"] / a["ate_m"]
            with_ids.append(a["ate_m"])
            without.append(b["ate_m"])
            ratios.append(ratio)
            counts_ok.append(abs(b["landmarks"] - TRUE_LANDMARKS) <= 1)
            counts = " ".join(f"{k}={v}" for k, v in b["counts"].items()) or "-"
            print(
                f"| r{robot} | {a['ate_m']:.3f} | {b['ate_m']:.3f} | {ratio:.2f} | "
                f"{a['landmarks']} | {b['landmarks']} | {counts} | "
                f"{a['cpu_s']:.0f} / {b['cpu_s']:.0f} |",
                flush=True,
            )
        print(
            f"| median | {np.median(with_ids):.3f} | {np.median(without):.3f} | "
            f"{np.median(ratios):.2f} | | | | |"
        )
        if estimator == "graphslam":
            met = np.median(with_ids) <= 0.08 and max(with_ids) <= 0.15
            print(
                f"goal with ids (median <= 0.08 m, max <= 0.15 m): median "
                f"{np.median(with_ids):.3f}, max {max(with_ids):.3f}: "
                f"{'met' if met else 'NOT met'}"
            )
        met = max(ratios) <= 1.5 and all(counts_ok)
        print(
            f"goal ids ignored (each robot <= 1.5x, 15 +- 1 landmarks): worst ratio "
            f"{max(ratios):.2f}, landmark counts ok on {sum(counts_ok)}/{len(counts_ok)}: "
            f"{'met' if met else 'NOT met'}"
        )


if __name__ == "__main__":
    main()
