"""``omnislam run`` end to end from the images: the shared front end and the estimator, timed.

Usage (render the dataset first with ``omnislam dataset synth PRESET --out DIR``):

    .venv/bin/python benchmarks/end_to_end.py --dataset runs/lab40 [--estimator graphslam] \
        [--runs 3] [--json results.json] [--keep-log LOG]

Each run is the user's command, ``python -m omnislam run DIR --estimator NAME --out RUN_DIR``,
in a fresh process with an empty cache (``OMNISLAM_CACHE`` in a temporary folder), so the
front end runs from the images every time (pipelined, as the CLI runs it) before the estimator
replays its log. Printed per run and as medians: wall-clock seconds of the command, its CPU
seconds (user + system of the command and of every process it started: the front end's
workers), the front end's own wall and CPU seconds over the images (the log's stats), the
estimator's replay time (the run folder's ``config.yaml``), and the machine's load average
before and after (on a shared 2-core machine wall-clock depends on the neighbours; CPU does
not).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def children_cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def one_run(dataset: Path, estimator: str, options: list[str], keep_log: Path | None = None
            ) -> dict[str, float]:
    with tempfile.TemporaryDirectory(prefix="omnislam-e2e-") as tmp:
        env = dict(os.environ, OMNISLAM_CACHE=str(Path(tmp) / "cache"))
        out = Path(tmp) / "run"
        command = [sys.executable, "-m", "omnislam", "run", str(dataset), "--estimator",
                   estimator, "--out", str(out)]
        for option in options:
            command += ["--set", option]
        load_before = os.getloadavg()[0]
        cpu, wall = children_cpu_s(), time.perf_counter()
        done = subprocess.run(command, env=env, capture_output=True, text=True, check=False)
        wall, cpu = time.perf_counter() - wall, children_cpu_s() - cpu
        if done.returncode != 0:
            sys.stderr.write(done.stderr)
            raise SystemExit(f"{' '.join(command)} failed ({done.returncode})")
        import yaml

        config = yaml.safe_load((out / "config.yaml").read_text())
        logs = [p for p in (Path(tmp) / "cache" / "logs").glob("*.npz")
                if not p.name.endswith(".truth.npz")]  # not the tracks' true points
        frontend = {}
        if logs:
            from omnislam.frontend.observation_log import load_observation_log

            stats = load_observation_log(logs[0]).stats
            if keep_log is not None:
                shutil.copyfile(logs[0], keep_log)
            images = max(stats.get("images_processed", 0.0), 1.0)
            frontend = {
                "frontend_images": images,
                "frontend_images_wall_s": stats["seconds_images_total"],
                "frontend_images_cpu_s": stats["cpu_seconds_images_total"],
                "frontend_images_per_s_wall": images / stats["seconds_images_total"],
                "frontend_laser_wall_s": stats.get("seconds_laser", 0.0),
            }
        return {"wall_s": wall, "cpu_s": cpu, **frontend,
                "estimator_total_s": float(config.get("total_s", float("nan"))),
                "load_average_before": load_before, "load_average_after": os.getloadavg()[0]}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", required=True, type=Path, help="rendered folder")
    parser.add_argument("--estimator", default="graphslam")
    parser.add_argument("--set", dest="options", action="append", default=[],
                        metavar="KEY=VALUE", help="estimator option (repeatable)")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--json", type=Path, help="write the results here")
    parser.add_argument("--keep-log", type=Path, default=None, metavar="LOG",
                        help="copy the first run's front-end log here (for benchmarks/frontend.py "
                             "--log)")
    args = parser.parse_args()
    runs = []
    for k in range(args.runs):
        runs.append(one_run(args.dataset.resolve(), args.estimator, args.options,
                            args.keep_log if k == 0 else None))
        print(f"run {k + 1}/{args.runs}: " + ", ".join(f"{key} {value:.2f}"
                                                       for key, value in runs[-1].items()),
              file=sys.stderr, flush=True)
    results = {"dataset": str(args.dataset), "estimator": args.estimator,
               "options": args.options, "cpus": os.cpu_count(),
               "median": {key: float(np.median([r[key] for r in runs])) for key in runs[0]},
               "runs": runs}
    text = json.dumps(results, indent=2)
    print(text)
    if args.json:
        args.json.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
