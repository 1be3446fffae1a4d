"""FastSLAM on recorded data: CPU time of a (truncated) run, and whether two checkouts agree.

A run is what ``omnislam run DATASET --estimator E --seed S --set K=V ...`` steps (the dataset's
own sightings, the estimator built from ``frames.sequence_info`` over all frames), cut to the
first ``--frames`` frames. Each run is one subprocess that loads the data, steps the estimator
and reports the process CPU seconds and wall-clock seconds of the stepping alone (loading and
numba's compilation, warmed on the first frames of a throwaway estimator, are not counted),
plus a SHA-1 digest of its outputs: the trajectory, the landmark map and ``info()``, written
with ``repr`` (every digit of every float).

``--against CHECKOUT`` also runs a second source tree (e.g. ``git worktree add ../base
main``) with ``PYTHONPATH=CHECKOUT``, alternating the two run by run so that a shared
machine's load hits both alike, and says whether every pair of digests is equal. ``--dump
DIR`` writes one run's outputs as text for a diff.

A dataset whose runs replay a front-end log (images: the synthetic renders; laser scans:
CARMEN) is run with ``--log LOG``: each run is then ``omnislam run DATASET --log LOG ...``
itself (``execute.execute_run``), timed by its "running" stage (the CPU and wall-clock
seconds its RUN_DIR's config records; loading numba's cached kernels included, compiling
not: each tree makes one unrecorded run first), and its digest is the SHA-1 of the RUN_DIR's
files except the timings (``config.yaml``, ``timing.csv``); ``--dump DIR`` writes the RUN_DIR.
``--frames`` does not apply.

    PYTHONPATH=. OMNISLAM_DATA=../shared/data .venv/bin/python benchmarks/fastslam_real_speed.py
        victoria-park [--estimator fastslam1] [--frames 1500] [--repeats 3] [--seed 0]
        [--set KEY=VALUE ...] [--against ../base]
    ... benchmarks/fastslam_real_speed.py RENDER_DIR --log LOG [--estimator fastslam1] ...

Measured with ``--against`` a checkout of 3df96c6 (before the compiled association likelihoods,
``kernels.association_inverses`` / ``association_scores``), seed 0, 2 shared cores, medians of
CPU seconds: victoria-park fastslam1, first 1500 frames, 3 runs: 57.4 -> 13.1 s (4.4x);
mrclam6-r1 ``--set association=unknown`` fastslam1, 5 runs: 2.28 -> 1.57 s (1.45x); outputs
identical. A whole victoria-park fastslam1 run (``omnislam run``, one each, user + sys CPU):
624 -> 131 s (4.8x), RUN_DIR files byte-identical.

Measured with ``--log`` against a checkout of f8bdf5c (before the compiled omni-bearing
triangulations, landmark EKFs and FastSLAM 2.0 proposal, ``kernels.bearing_landmark_updates`` /
``refine_bearing_elevation`` ...), the lab40 render with its suite-s25 log
(``lab40-s0-open3d-d256c450fab4-e991fd350d.npz``), seed 0, 2 shared cores, medians of 3 alternated
runs of the running stage's CPU seconds: fastslam1 5.39 -> 3.02 s (1.79x); fastslam1 ``--set
experimental.islands=3 --set particles.n_particles=300`` 16.14 -> 8.60 s (1.88x); fastslam2 5.00 ->
1.46 s (3.43x); outputs identical. What is left of fastslam1 is mostly the landmark tree's path
copying (``tree_scatter``, ~25 %: pointer chasing and copy-on-write of nodes after each
resampling), the payload copies and the numpy transcendental calls.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import statistics
import subprocess
import sys
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
from harness_cells import add_set_option, set_options

#: frames stepped by a throwaway estimator before the timed one (numba compiles then)
WARM_FRAMES = 50


def outputs_text(estimator: object) -> str:
    """The trajectory, the landmark map and ``info()`` of a finished run, every float by repr."""
    estimate = estimator.estimate()
    lines = ["# trajectory x y theta"]
    lines += [" ".join(repr(float(v)) for v in row) for row in estimate.trajectory.se2]
    lines.append("# landmarks id x y z")
    if estimate.landmarks_w is not None:
        for i, row in zip(estimate.landmark_ids, estimate.landmarks_w, strict=True):
            lines.append(f"{int(i)} " + " ".join(repr(float(v)) for v in row))
    lines.append("# landmark covariances")
    if estimate.landmark_covariances is not None:
        lines += [
            " ".join(repr(float(v)) for v in c.ravel()) for c in estimate.landmark_covariances
        ]
    info = {k: getattr(v, "value", v) for k, v in asdict(estimator.info()).items()}
    lines.append("# info")
    lines.append(json.dumps(info, sort_keys=True))
    return "\n".join(lines) + "\n"


def one_run(args: argparse.Namespace, options: dict[str, str]) -> dict:
    """Load, warm up, step the first ``args.frames`` frames; CPU and wall seconds and digest."""
    from omnislam.datasets.registry import load_dataset, resolve
    from omnislam.estimators import make_estimator
    from omnislam.harness.frames import sequence_info

    resolved = resolve(args.dataset)
    loader_keys = resolved.option_names()
    sequence = load_dataset(resolved, {k: v for k, v in options.items() if k in loader_keys})
    if sequence.laser is not None or len(sequence.image_frames):
        sys.exit(f"{args.dataset}: its runs replay a front-end log; compare RUN_DIRs instead")
    frames = list(sequence.frame_inputs())
    info = sequence_info(sequence, frames)
    frames = frames[: args.frames]
    estimator_options = {k: v for k, v in options.items() if k not in loader_keys}
    warm = make_estimator(args.estimator, info, estimator_options, np.random.default_rng(1))
    for frame in frames[:WARM_FRAMES]:
        warm.step(frame)
    estimator = make_estimator(
        args.estimator, info, estimator_options, np.random.default_rng(args.seed)
    )
    wall, cpu = time.perf_counter(), time.process_time()
    for frame in frames:
        estimator.step(frame)
    cpu = time.process_time() - cpu
    wall = time.perf_counter() - wall
    text = outputs_text(estimator)
    if args.dump:
        Path(args.dump).mkdir(parents=True, exist_ok=True)
        (Path(args.dump) / "outputs.txt").write_text(text)
    digest = hashlib.sha1(text.encode()).hexdigest()
    return {"cpu_s": cpu, "wall_s": wall, "frames": len(frames), "digest": digest}


def one_log_run(args: argparse.Namespace, options: dict[str, str]) -> dict:
    """``omnislam run DATASET --log LOG``: the running stage's CPU and wall seconds and the
    digest of the RUN_DIR's files but the timings."""
    import tempfile

    from omnislam.harness.execute import RunSpec, execute_run
    from omnislam.harness.layout import CONFIG
    from omnislam.harness.rundir import write_run_dir

    spec = RunSpec(args.dataset, args.estimator, args.seed, options, log=args.log)
    record = execute_run(spec)
    digest = hashlib.sha1()
    with tempfile.TemporaryDirectory() as scratch:
        run_dir = Path(args.dump) if args.dump else Path(scratch) / "run"
        write_run_dir(run_dir, record)
        for path in sorted(run_dir.iterdir()):
            if path.name not in (CONFIG, "timing.csv"):
                digest.update(path.name.encode() + b"\0" + path.read_bytes())
    config = record.config
    return {
        "cpu_s": config.stages_cpu_s["running"],
        "wall_s": config.stages_wall_s["running"],
        "frames": config.frames,
        "digest": digest.hexdigest(),
    }


def spawn(checkout: Path, argv: list[str]) -> dict:
    """One run in a subprocess with ``PYTHONPATH=checkout`` (this script's ``--single``)."""
    env = {**os.environ, "PYTHONPATH": str(checkout)}
    command = [sys.executable, str(Path(__file__).resolve()), *argv, "--single"]
    done = subprocess.run(command, env=env, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        sys.exit(f"run in {checkout} failed:\n{done.stderr}")
    return json.loads(done.stdout.splitlines()[-1])


def _without_dump(argv: list[str]) -> list[str]:
    """``argv`` without its ``--dump DIR``."""
    return [a for i, a in enumerate(argv) if a != "--dump" and argv[i - 1] != "--dump"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset")
    parser.add_argument("--estimator", default="fastslam1")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--frames", type=int, default=None, help="only the first N frames")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--against", type=Path, default=None, help="a baseline checkout")
    parser.add_argument("--dump", default=None, help="write one run's outputs.txt here")
    parser.add_argument("--log", default=None, help="the front-end log the runs replay")
    parser.add_argument("--single", action="store_true", help=argparse.SUPPRESS)
    add_set_option(parser, "loader or estimator option (repeatable)")
    args = parser.parse_args(argv)
    options = set_options(parser, args.options)
    if args.single:
        print(json.dumps((one_log_run if args.log else one_run)(args, options)))
        return 0
    here = Path(__file__).resolve().parents[1]
    child = [a for a in (argv if argv is not None else sys.argv[1:]) if a != "--single"]
    if args.against is not None:  # the two trees alternate; each dumps only on its own
        child = _without_dump(child)
    trees = {"this": here, **({"against": args.against} if args.against else {})}
    runs: dict[str, list[dict]] = {name: [] for name in trees}
    if args.log:  # numba compiles kernels it has not cached yet outside the timed runs
        for tree in trees.values():
            spawn(tree, _without_dump(child))
    for _ in range(args.repeats):
        for name, tree in trees.items():
            runs[name].append(spawn(tree, child))
    frames = runs["this"][0]["frames"]
    print(f"{args.dataset} {args.estimator} seed {args.seed} {options}: {frames} frames")
    for name, tree in trees.items():
        cpu = [r["cpu_s"] for r in runs[name]]
        wall = [r["wall_s"] for r in runs[name]]
        print(
            f"  {name:8s} {tree}: CPU s median {statistics.median(cpu):.2f} "
            f"({' '.join(f'{c:.2f}' for c in cpu)}), wall s median "
            f"{statistics.median(wall):.2f} ({' '.join(f'{w:.2f}' for w in wall)})"
        )
    digests = {r["digest"] for rs in runs.values() for r in rs}
    if args.against is not None:
        ratio = statistics.median(r["cpu_s"] for r in runs["against"]) / statistics.median(
            r["cpu_s"] for r in runs["this"]
        )
        print(f"  CPU against / this: {ratio:.2f}x")
    print(f"  outputs: {'identical' if len(digests) == 1 else 'DIFFER'} ({sorted(digests)})")
    return 0 if len(digests) == 1 else 1


if __name__ == "__main__":
    sys.exit(main())
