"""What the suite's cells cost, from a results folder of ``omnislam compare``::

    .venv/bin/python benchmarks/suite_times.py runs/suite [--top 25]
    .venv/bin/python benchmarks/suite_times.py runs/suite --run [--datasets demo,mrclam6-r1]
        [--estimators graphslam,ukf] [--seeds 0] [--workers N | --scheduler ADDRESS]

Reads each cell's ``cell_time.json`` (wall-clock and CPU time of the cell on its worker,
loading and replay included; written by the grid runner) through ``results.json`` and prints
the cells that cost most, the totals per dataset and per estimator, and the cell count. CPU
time is the number to read on a loaded machine; wall time adds the waiting.

With ``--run`` it first runs a subset of ``benchmarks/grids/suite.yaml`` into the folder (the
named dataset labels, estimator labels and seeds; a cell of the subset is the same cell as in
the whole suite, so a later ``make suite`` into the same folder reuses it: both pass
``compare --resume``).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parents[1]
SUITE = REPO / "benchmarks" / "grids" / "suite.yaml"


def subset_grid(
    text: str, datasets: set[str] | None, estimators: set[str] | None, seeds: set[int] | None
) -> dict:
    """The suite's grid restricted to dataset labels, estimator labels and seeds."""
    grid = yaml.safe_load(text)

    def label(entry: object, key: str) -> str:
        if isinstance(entry, str):
            return entry
        return str(entry.get("label") or entry.get(key) or entry.get("synthetic"))

    def keep_seeds(values: list[int]) -> list[int]:
        return [s for s in values if seeds is None or s in seeds]

    kept = []
    for entry in grid["datasets"]:
        if datasets is not None and label(entry, "dataset") not in datasets:
            continue
        if isinstance(entry, dict):
            entry = dict(entry)
            if "seeds" in entry:
                entry["seeds"] = keep_seeds(entry["seeds"])
            if estimators is not None and "estimators" in entry:
                entry["estimators"] = [e for e in entry["estimators"] if e in estimators]
        kept.append(entry)
    grid["datasets"] = kept
    chosen = []
    for entry in grid["estimators"]:
        if estimators is not None and label(entry, "estimator") not in estimators:
            continue
        if isinstance(entry, dict) and "seeds" in entry:
            entry = {**entry, "seeds": keep_seeds(entry["seeds"])}
        chosen.append(entry)
    grid["estimators"] = chosen
    grid["seeds"] = keep_seeds(grid.get("seeds", [0]))
    grid["name"] = f"{grid.get('name', 'suite')} (subset)"
    return grid


def cell_rows(results: Path) -> list[dict]:
    """One row per cell of results.json: labels, status, wall and CPU time (None: unknown)."""
    rows = json.loads((results / "results.json").read_text())["cells"]
    out = []
    for row in rows:
        spent = row.get("cell_time") or {}
        out.append(
            {
                "cell": row["cell"],
                "dataset": row["dataset"],
                "estimator": row["column"],
                "seed": row["seed"],
                "status": row["status"],
                "wall_s": spent.get("wall_s"),
                "cpu_s": spent.get("cpu_s"),
            }
        )
    return out


def print_table(rows: list[dict], top: int) -> None:
    timed = [r for r in rows if r["cpu_s"] is not None]
    failed = [r for r in rows if r["status"] == "failed"]
    total_cpu = sum(r["cpu_s"] for r in timed)
    total_wall = sum(r["wall_s"] for r in timed)
    print(
        f"{len(rows)} cells ({len(timed)} timed, {len(failed)} failed); timed cells: "
        f"{total_cpu / 60:.1f} min CPU, {total_wall / 60:.1f} min wall (sum over cells)"
    )
    print(f"\nthe {min(top, len(timed))} costliest cells (CPU):")
    print("| cell | CPU [s] | wall [s] | share of CPU |")
    print("|---|---|---|---|")
    for r in sorted(timed, key=lambda r: -r["cpu_s"])[:top]:
        share = r["cpu_s"] / total_cpu if total_cpu else 0.0
        print(f"| {r['cell']} | {r['cpu_s']:.1f} | {r['wall_s']:.1f} | {share:.1%} |")
    for key in ("dataset", "estimator"):
        groups: dict[str, list[dict]] = defaultdict(list)
        for r in timed:
            groups[r[key]].append(r)
        print(f"\nper {key}:")
        print(f"| {key} | cells | CPU [s] | wall [s] | median cell CPU [s] | share of CPU |")
        print("|---|---|---|---|---|---|")
        for name, group in sorted(groups.items(), key=lambda kv: -sum(r["cpu_s"] for r in kv[1])):
            cpu = sorted(r["cpu_s"] for r in group)
            share = sum(cpu) / total_cpu if total_cpu else 0.0
            print(
                f"| {name} | {len(group)} | {sum(cpu):.0f} | "
                f"{sum(r['wall_s'] for r in group):.0f} | {cpu[len(cpu) // 2]:.1f} | "
                f"{share:.1%} |"
            )
    for r in failed:
        print(f"failed: {r['cell']}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", help="results folder of omnislam compare")
    parser.add_argument("--top", type=int, default=25)
    parser.add_argument("--run", action="store_true", help="run a subset of the suite first")
    parser.add_argument("--datasets", default=None, help="comma-separated dataset labels")
    parser.add_argument("--estimators", default=None, help="comma-separated estimator labels")
    parser.add_argument("--seeds", default=None, help="comma-separated seeds")
    parser.add_argument("--workers", type=int, default=None)
    parser.add_argument("--scheduler", default=None)
    args = parser.parse_args(argv)
    results = Path(args.results)
    code = 0
    if args.run:
        from omnislam.cli import main as omnislam

        def names(text: str | None) -> set[str] | None:
            return None if text is None else set(text.split(","))

        seeds = None if args.seeds is None else {int(s) for s in args.seeds.split(",")}
        grid = subset_grid(SUITE.read_text(), names(args.datasets), names(args.estimators), seeds)
        results.parent.mkdir(parents=True, exist_ok=True)
        path = results.parent / f"{results.name}-subset.yaml"
        path.write_text(
            f"# generated by benchmarks/suite_times.py from {SUITE.name}\n"
            + yaml.safe_dump(grid, sort_keys=False)
        )
        engine = ["--scheduler", args.scheduler] if args.scheduler else []
        engine += ["--workers", str(args.workers)] if args.workers is not None else []
        code = omnislam(["compare", str(path), "--out", str(results), "--resume", *engine])
        if code not in (0, 1):
            return code
    print_table(cell_rows(results), args.top)
    return code


if __name__ == "__main__":
    sys.exit(main())
