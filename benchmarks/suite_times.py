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
    """The suite's grid restricted to dataset labels, estimator labels and seeds.

    Every cell of the subset is a cell of the suite with the same label, options and seed. An
    estimator whose prior map comes from another (``prior_map: {from: LABEL}``) brings that
    estimator along on the datasets it runs on: its cells are the map's source (reused when
    already computed). Seeds filter where they apply: a synthetic dataset's own seeds (its worlds),
    an estimator's own seeds (on recorded data), the grid's seeds for the other estimators on
    recorded data; an estimator or dataset left without a seed runs nowhere.
    """
    grid = yaml.safe_load(text)

    def label(entry: object, key: str) -> str:
        if isinstance(entry, str):
            return entry
        return str(entry.get("label") or entry.get(key) or entry.get("synthetic"))

    def keep_seeds(values: list[int]) -> list[int]:
        return [s for s in values if seeds is None or s in seeds]

    def source(entry: object) -> str | None:
        options = entry.get("options", {}) if isinstance(entry, dict) else {}
        prior = options.get("prior_map") if isinstance(options, dict) else None
        return str(prior["from"]) if isinstance(prior, dict) and "from" in prior else None

    every = [label(e, "estimator") for e in grid["estimators"]]
    sources = {label(e, "estimator"): source(e) for e in grid["estimators"]}
    wanted = set(every) if estimators is None else set(estimators)
    wanted |= {sources[name] for name in list(wanted) if sources.get(name)}
    grid_seeds = keep_seeds(grid.get("seeds", [0]))
    own_seeds = {
        label(e, "estimator"): keep_seeds(e["seeds"])
        for e in grid["estimators"]
        if isinstance(e, dict) and "seeds" in e
    }

    def runs_on_recorded(name: str) -> bool:
        return bool(own_seeds[name]) if name in own_seeds else bool(grid_seeds)

    kept = []
    for entry in grid["datasets"]:
        if datasets is not None and label(entry, "dataset") not in datasets:
            continue
        entry = dict(entry) if isinstance(entry, dict) else {"dataset": entry}
        names = [n for n in entry.get("estimators", every) if n in wanted]
        if "seeds" in entry:  # a synthetic preset: its seeds are its worlds, for every estimator
            entry["seeds"] = keep_seeds(entry["seeds"])
            if not entry["seeds"]:
                continue
        else:
            names = [n for n in names if runs_on_recorded(n)]
        # a prior map's source runs wherever its consumer does, and only there if not wanted
        names += [sources[n] for n in names if sources.get(n) and sources[n] not in names]
        if not names:
            continue
        if "estimators" in entry or set(names) != set(every):
            entry["estimators"] = [n for n in every if n in names]
        kept.append(entry)
    grid["datasets"] = kept
    used = {n for entry in kept for n in entry.get("estimators", every)}
    chosen = []
    for entry in grid["estimators"]:
        name = label(entry, "estimator")
        if name not in used:
            continue
        if isinstance(entry, dict) and name in own_seeds and own_seeds[name]:
            entry = {**entry, "seeds": own_seeds[name]}
        chosen.append(entry)
    grid["estimators"] = chosen
    if grid_seeds:
        grid["seeds"] = grid_seeds
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
