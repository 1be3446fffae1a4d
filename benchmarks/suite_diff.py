"""Two results folders of the same grid, cell by cell: what a change did to every estimator::

    PYTHONPATH=. .venv/bin/python benchmarks/suite_diff.py BEFORE AFTER [--datasets REGEX]
        [--estimators E ...] [--rpe-m 2 10]

BEFORE and AFTER are ``omnislam compare`` results folders (``runs/suite``,
``benchmarks/suite_rows.py --results DIR``): each holds ``cells/DATASET__ESTIMATOR__sSEED/
metrics.json``. For every cell present in both whose dataset label matches REGEX (a Python
regular expression, searched; default: all) and whose estimator is listed (default: all), one
line: ATE RMSE [cm], landmark RMSE and median [cm] and the rotational RPE [deg] over the
``--rpe-m`` distances (from the cell's ``rpe_by_distance``), before -> after. Then, per dataset
and estimator, the medians over the seeds. Cells in only one folder are listed, not compared.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import warnings
from pathlib import Path

import numpy as np


class BadResultsError(Exception):
    """A results folder without cells, or a cell's metrics.json that is not JSON."""


def load_cells(folder: Path) -> dict[tuple[str, str, str], dict]:
    """``(dataset, estimator, seed) -> metrics`` of every cell of a results folder."""
    cells = folder / "cells"
    if not cells.is_dir():
        raise BadResultsError(
            f"{folder}: no cells/ folder (not an omnislam compare results folder)"
        )
    out = {}
    for path in sorted(cells.glob("*/metrics.json")):
        parts = path.parent.name.split("__")
        if len(parts) != 3:
            continue
        try:
            out[tuple(parts)] = json.loads(path.read_text())
        except json.JSONDecodeError as exc:
            raise BadResultsError(f"{path}: not JSON ({exc.msg}, line {exc.lineno})") from None
    return out


def figures(metrics: dict, rpe_m: list[float]) -> list[float]:
    """ATE, landmark RMSE, landmark median [cm], rotational RPE [deg] per distance (NaN: none)."""

    def cm(key: str) -> float:
        value = metrics.get(key)
        return float("nan") if value is None else 100.0 * value

    by_length = {
        round(r["length_m"], 6): r.get("rot_rmse_deg") for r in metrics.get("rpe_by_distance") or []
    }
    rpe = [by_length.get(round(d, 6)) for d in rpe_m]
    return [cm("ate_rmse_m"), cm("landmark_rmse_m"), cm("landmark_median_m")] + [
        float("nan") if v is None else float(v) for v in rpe
    ]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("before", type=Path)
    parser.add_argument("after", type=Path)
    parser.add_argument("--datasets", default="", help="regular expression on dataset labels")
    parser.add_argument("--estimators", nargs="*", default=None)
    parser.add_argument("--rpe-m", nargs="*", type=float, default=[2.0, 10.0])
    args = parser.parse_args()
    try:
        pattern = re.compile(args.datasets)
    except re.error as exc:
        parser.error(f"--datasets: {exc}")
    try:
        before, after = load_cells(args.before), load_cells(args.after)
    except BadResultsError as exc:
        print(f"suite_diff: {exc}", file=sys.stderr)
        return 2

    def wanted(key: tuple[str, str, str]) -> bool:
        return bool(pattern.search(key[0])) and (
            args.estimators is None or key[1] in args.estimators
        )

    keys = sorted(k for k in before.keys() & after.keys() if wanted(k))
    only = sorted(k for k in before.keys() ^ after.keys() if wanted(k))
    names = ["ATE cm", "lm RMSE cm", "lm med cm"] + [f"rot RPE {d:g} m deg" for d in args.rpe_m]
    print(f"{'dataset':18s} {'estimator':16s} {'seed':4s} " + "  ".join(f"{n:>17s}" for n in names))
    groups: dict[tuple[str, str], list[tuple[list[float], list[float]]]] = {}
    for key in keys:
        a, b = figures(before[key], args.rpe_m), figures(after[key], args.rpe_m)
        groups.setdefault(key[:2], []).append((a, b))
        print(
            f"{key[0]:18s} {key[1]:16s} {key[2]:4s} "
            + "  ".join(f"{x:8.2f}->{y:7.2f}" for x, y in zip(a, b, strict=True))
        )
    print("\nmedians over the seeds")
    for (dataset, estimator), pairs in sorted(groups.items()):
        with warnings.catch_warnings():  # a figure no cell has (a filter's landmarks) is NaN
            warnings.simplefilter("ignore", RuntimeWarning)
            a = np.nanmedian(np.array([p[0] for p in pairs]), axis=0)
            b = np.nanmedian(np.array([p[1] for p in pairs]), axis=0)
        print(
            f"{dataset:18s} {estimator:16s} {len(pairs):4d} "
            + "  ".join(f"{x:8.2f}->{y:7.2f}" for x, y in zip(a, b, strict=True))
        )
    for key in only:
        side = "before" if key in before else "after"
        print(f"only {side}: {'__'.join(key)}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
