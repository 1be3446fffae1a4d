"""``omnislam run`` end to end from the images, stage by stage, and the estimators' replays.

Usage (render the dataset first with ``omnislam dataset synth PRESET --out DIR``):

    .venv/bin/python benchmarks/end_to_end.py --dataset runs/lab40 [--estimator graphslam] \
        [--runs 3] [--replay fastslam1,fastslam2,ekfslam,ukf,deadreckoning] \
        [--json results.json] [--keep-log LOG]

Each end-to-end run is the user's command, ``python -m omnislam run DIR --estimator NAME --out
RUN_DIR``, in a fresh process with an empty cache (``OMNISLAM_CACHE`` in a temporary folder),
so the front end runs from the images every time (pipelined, as the CLI runs it) before the
estimator replays its log. Per run and as medians over the runs: the command's wall-clock and
CPU seconds (user + system of the command and of every process it started: the front end's
workers); each stage's wall and CPU seconds from the run folder's ``config.yaml``
(``stages_wall_s`` / ``stages_cpu_s``: loading, front end -- the images, writing and reading
the log --, true points of the tracks, running, final estimate; what is left of the command's
time is the interpreter's start-up, imports and writing the run folder); the front end's own
image loop (the log's stats); and the machine's load average before and after (on a shared
2-core machine wall-clock depends on the neighbours; CPU much less).

``--replay NAMES`` then replays the first run's log ``--runs`` times through each estimator
named, ``omnislam run DIR --estimator NAME --log LOG`` in a fresh process (the tracks' true
points are cached next to the log by then), and prints the replay's wall and CPU seconds
(stages "running" + "final estimate") against the budget of 20x real time: the dataset's
driving duration (last stamp - first) / 20.

``--blas-threads N`` runs every command with N BLAS threads. numpy's OpenBLAS takes one thread
per core by default; on a machine shared with other jobs the EKF-SLAM's covariance products then
spin on the busy cores (a lab40 replay: ~11 s with one thread, 32-85 s with two at a load of
4-9), so measure both ways there.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from omnislam.frontend.timing import children_cpu_s  # POSIX: never None here

#: the stages ``harness.execute`` reports, in order
STAGES = ("loading", "front end", "true points of the tracks", "running", "final estimate")
#: the replay of a cached log: the estimator's steps and its final estimate
REPLAY_STAGES = ("running", "final estimate")
#: the real-time factor the replays must reach
REAL_TIME_FACTOR = 20.0


#: environment of the commands run (``--blas-threads`` adds the BLAS libraries' thread counts)
ENVIRONMENT: dict[str, str] = {}


def run_command(dataset: Path, estimator: str, options: list[str], cache: Path, out: Path,
                log: Path | None = None) -> dict[str, float]:
    """``python -m omnislam run``: its wall and CPU seconds, and the stages of its config.yaml."""
    import yaml

    env = dict(os.environ, OMNISLAM_CACHE=str(cache), OMNISLAM_PROGRESS="0", **ENVIRONMENT)
    command = [sys.executable, "-m", "omnislam", "run", str(dataset), "--estimator", estimator,
               "--out", str(out), "--overwrite"]
    if log is not None:
        command += ["--log", str(log)]
    for option in options:
        command += ["--set", option]
    load_before = os.getloadavg()[0]
    cpu, wall = children_cpu_s(), time.perf_counter()
    done = subprocess.run(command, env=env, capture_output=True, text=True, check=False)
    wall, cpu = time.perf_counter() - wall, children_cpu_s() - cpu
    if done.returncode != 0:
        sys.stderr.write(done.stderr)
        raise SystemExit(f"{' '.join(command)} failed ({done.returncode})")
    config = yaml.safe_load((out / "config.yaml").read_text())
    result = {"wall_s": wall, "cpu_s": cpu}
    stages_wall, stages_cpu = config.get("stages_wall_s", {}), config.get("stages_cpu_s", {})
    for stage in STAGES:
        if stage in stages_wall:
            result[f"{stage} wall_s"] = float(stages_wall[stage])
            result[f"{stage} cpu_s"] = float(stages_cpu[stage])
    result["start-up, imports, writing wall_s"] = wall - sum(map(float, stages_wall.values()))
    result["start-up, imports, writing cpu_s"] = cpu - sum(map(float, stages_cpu.values()))
    result["replay wall_s"] = sum(float(stages_wall.get(s, 0.0)) for s in REPLAY_STAGES)
    result["replay cpu_s"] = sum(float(stages_cpu.get(s, 0.0)) for s in REPLAY_STAGES)
    result["estimator_total_s"] = float(config.get("total_s", float("nan")))
    result["load_average_before"] = load_before
    result["load_average_after"] = os.getloadavg()[0]
    return result


def one_run(dataset: Path, estimator: str, options: list[str], keep_log: Path | None = None
            ) -> dict[str, float]:
    """One end-to-end run from the images with an empty cache."""
    with tempfile.TemporaryDirectory(prefix="omnislam-e2e-") as tmp:
        cache = Path(tmp) / "cache"
        result = run_command(dataset, estimator, options, cache, Path(tmp) / "run")
        logs = [p for p in (cache / "logs").glob("*.npz")
                if not p.name.endswith(".truth.npz")]  # not the tracks' true points
        if logs:
            from omnislam.frontend.observation_log import load_observation_log

            stats = load_observation_log(logs[0]).stats
            if keep_log is not None:
                shutil.copyfile(logs[0], keep_log)
            images = max(stats.get("images_processed", 0.0), 1.0)
            result |= {
                "frontend_images": images,
                "frontend_images_wall_s": stats["seconds_images_total"],
                "frontend_images_cpu_s": stats["cpu_seconds_images_total"],
                "frontend_images_per_s_wall": images / stats["seconds_images_total"],
                "frontend_laser_wall_s": stats.get("seconds_laser", 0.0),
            }
        return result


def driving_duration_s(dataset: Path) -> float:
    """Last stamp - first stamp of the dataset's frames [s]."""
    from omnislam.datasets.registry import load_dataset

    stamps = load_dataset(str(dataset)).stamps_s
    return float(stamps[-1] - stamps[0])


def medians(runs: list[dict[str, float]]) -> dict[str, float]:
    return {key: float(np.median([r[key] for r in runs])) for key in runs[0]}


def print_stages(label: str, runs: list[dict[str, float]]) -> None:
    """The medians of the command and of its stages, wall beside CPU."""
    m = medians(runs)
    print(f"{label}: medians of {len(runs)} (load average {m['load_average_before']:.1f} -> "
          f"{m['load_average_after']:.1f})", file=sys.stderr)
    print(f"  {'stage':34s} {'wall [s]':>9s} {'CPU [s]':>9s}", file=sys.stderr)
    for stage in (*STAGES, "start-up, imports, writing"):
        if f"{stage} wall_s" in m:
            print(f"  {stage:34s} {m[f'{stage} wall_s']:9.2f} {m[f'{stage} cpu_s']:9.2f}",
                  file=sys.stderr)
    print(f"  {'command':34s} {m['wall_s']:9.2f} {m['cpu_s']:9.2f}", file=sys.stderr, flush=True)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", required=True, type=Path, help="rendered folder")
    parser.add_argument("--estimator", default="graphslam")
    parser.add_argument("--set", dest="options", action="append", default=[],
                        metavar="KEY=VALUE", help="estimator option (repeatable)")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--replay", default="", metavar="NAMES",
                        help="comma-separated estimators to replay the first run's log through "
                             "(--runs times each), against 20x real time")
    parser.add_argument("--blas-threads", type=int, default=None, metavar="N",
                        help="run the commands with N BLAS threads (OPENBLAS_NUM_THREADS, "
                             "OMP_NUM_THREADS, MKL_NUM_THREADS); default: the libraries' own "
                             "(numpy's OpenBLAS: one per core)")
    parser.add_argument("--json", type=Path, help="write the results here")
    parser.add_argument("--keep-log", type=Path, default=None, metavar="LOG",
                        help="copy the first run's front-end log here (for benchmarks/frontend.py "
                             "--log)")
    args = parser.parse_args()
    if args.blas_threads is not None:
        ENVIRONMENT.update(dict.fromkeys(
            ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"), str(args.blas_threads)))
    dataset = args.dataset.resolve()
    replays = [name for name in args.replay.split(",") if name]
    with tempfile.TemporaryDirectory(prefix="omnislam-e2e-log-") as keep:
        log = Path(keep) / "log.npz"
        runs = []
        for k in range(args.runs):
            runs.append(one_run(dataset, args.estimator, args.options, log if k == 0 else None))
            print(f"run {k + 1}/{args.runs}: " + ", ".join(f"{key} {value:.2f}"
                                                           for key, value in runs[-1].items()),
                  file=sys.stderr, flush=True)
        threads = "default" if args.blas_threads is None else args.blas_threads
        print_stages(f"omnislam run {args.dataset} --estimator {args.estimator} (BLAS threads: "
                     f"{threads})", runs)
        results = {"dataset": str(args.dataset), "estimator": args.estimator,
                   "options": args.options, "cpus": os.cpu_count(),
                   "blas_threads": args.blas_threads,
                   "median": medians(runs), "runs": runs}
        if args.keep_log is not None and log.exists():
            shutil.copyfile(log, args.keep_log)
        if replays and log.exists():
            duration = driving_duration_s(dataset)
            budget = duration / REAL_TIME_FACTOR
            results["driving_duration_s"] = duration
            results["replays"] = {}
            print(f"replays of the first run's log (driving {duration:.1f} s, budget "
                  f"{budget:.2f} s = 20x real time), medians of {args.runs}:", file=sys.stderr)
            print(f"  {'estimator':14s} {'wall [s]':>9s} {'CPU [s]':>9s} {'x real time':>11s} "
                  f"{'load':>5s}", file=sys.stderr)
            for name in replays:
                cache = Path(keep) / "cache"
                replayed = [run_command(dataset, name, [], cache, Path(keep) / "replay", log)
                            for _ in range(args.runs)]
                m = medians(replayed)
                results["replays"][name] = {"median": m, "runs": replayed}
                print(f"  {name:14s} {m['replay wall_s']:9.2f} {m['replay cpu_s']:9.2f} "
                      f"{duration / m['replay wall_s']:10.1f}x "
                      f"{m['load_average_before']:5.1f}"
                      + ("" if m["replay wall_s"] <= budget else "  over budget"),
                      file=sys.stderr, flush=True)
    text = json.dumps(results, indent=2)
    print(text)
    if args.json:
        args.json.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
