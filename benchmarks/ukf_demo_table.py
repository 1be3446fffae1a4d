"""The vertical-line UKF on the demo world (omni camera) next to graphslam and fastslam2.

One table, one log (the shared front end's, computed once and cached): graphslam, fastslam2,
the UKF localising in the world's vertical-edge map (the synthetic folder's prior map), and the
UKF localising in the map of the graphslam run (``--set prior_map=RUN_DIR``, map then localise).

graphslam's landmarks are SIFT track points in 3-D, not vertical lines: the UKF takes every
point's (x, y) as a vertical-line landmark (the map has no ``vertical_line`` flags and no MC
descriptors, so the photometric gate is off and step 4 is geometric only). The table shows what
that does; the report says why.

The commands (all through the CLI, as a user would type them):

    omnislam dataset synth demo --out OUT/demo            # skipped when OUT/demo exists
    omnislam run OUT/demo --estimator E --seed 0 --out OUT/runs/E
    omnislam run OUT/demo --estimator ukf --seed 0 --set prior_map=OUT/runs/graphslam \\
        --out OUT/runs/ukf-graphslam-map
    omnislam evaluate OUT/runs/R --json

    PYTHONPATH=. OMNISLAM_CACHE=/tmp/cache python benchmarks/ukf_demo_table.py [--out DIR]
        [--dataset FOLDER] [--set k=v ...]   (--set: extra options of both UKF runs)
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path


def _cli(*args: str) -> str:
    cmd = [sys.executable, "-m", "omnislam", *args]
    print("$ omnislam " + " ".join(args), flush=True)
    done = subprocess.run(cmd, capture_output=True, text=True, env=os.environ.copy())
    if done.returncode:
        sys.stderr.write(done.stderr)
        raise SystemExit(f"failed ({done.returncode}): {' '.join(cmd)}")
    return done.stdout


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--out", default="/tmp/ukf_demo")
    parser.add_argument("--dataset", default=None, help="a rendered demo folder (default OUT/demo)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--set", nargs="*", default=[], help="extra options of the UKF runs")
    parser.add_argument("--rerun", action="store_true", help="rerun existing RUN_DIRs")
    args = parser.parse_args()
    out = Path(args.out)
    data = Path(args.dataset) if args.dataset else out / "demo"
    if not data.exists():
        _cli("dataset", "synth", "demo", "--seed", str(args.seed), "--out", str(data))
    runs = out / "runs"
    extra = [a for kv in args.set for a in ("--set", kv)]
    rows = [
        ("graphslam", "graphslam", []),
        ("fastslam2", "fastslam2", []),
        ("ukf, world's vertical-edge map", "ukf", extra),
        (
            "ukf, graphslam's map (SIFT points)",
            "ukf",
            ["--set", f"prior_map={runs / 'graphslam'}", *extra],
        ),
    ]
    names = ["graphslam", "fastslam2", "ukf-world-map", "ukf-graphslam-map"]
    results = []
    for (label, estimator, options), name in zip(rows, names, strict=True):
        run_dir = runs / name
        if args.rerun or not (run_dir / "metrics.json").exists():
            _cli(
                "run",
                str(data),
                "--estimator",
                estimator,
                "--seed",
                str(args.seed),
                *options,
                "--out",
                str(run_dir),
            )
            _cli("evaluate", str(run_dir), "--json")
        metrics = json.loads((run_dir / "metrics.json").read_text())
        info_path = run_dir / "estimator_info.json"
        info = json.loads(info_path.read_text()) if info_path.exists() else {}
        results.append((label, metrics, info))
    print()
    print(
        f"demo world ({data}), seed {args.seed}; ATE aligned in SE(2) / anchored at the first"
        " pose [cm]"
    )
    print(
        "| estimator | map | ATE rmse | ATE max | ATE origin rmse | RPE 1 m | NEES |"
        " processed / updated frames | validated pairs |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for label, m, info in results:
        est, _, rest = label.partition(", ")
        nees = m.get("nees_mean")
        upd = (
            f"{info['frames_processed']} / {info['frames_updated']}"
            if "frames_processed" in info
            else ""
        )
        print(
            f"| {est} | {rest or 'own'} | {m['ate_rmse_m'] * 100:.2f} | {m['ate_max_m'] * 100:.2f}"
            f" | {m['ate_origin_rmse_m'] * 100:.2f} | {m['rpe_trans_rmse_m'] * 100:.2f}"
            f" | {'' if nees is None else f'{nees:.3g}'} | {upd}"
            f" | {info.get('pairs_validated', '')} |"
        )


if __name__ == "__main__":
    main()
