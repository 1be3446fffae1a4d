"""The vertical-line UKF on MR.CLAM dataset 6, robots 1-5, bearings only (ranges unused).

Against the surveyed landmark map, with the sightings' ids (``association.use_ids=true``) and
with ids ignored (geometric step 4 + two-frame validation); dead reckoning for reference.

    PYTHONPATH=. OMNISLAM_DATA=../shared/data python benchmarks/ukf_mrclam.py [--set k=v ...]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

from omnislam.compare.run_metrics import RunMetrics, read_run_metrics
from omnislam.compare.rundir import METRICS


def run(dataset: str, estimator: str, sets: list[str], out: Path) -> RunMetrics:
    args = [
        sys.executable,
        "-m",
        "omnislam",
        "run",
        dataset,
        "--estimator",
        estimator,
        "--out",
        str(out),
        "--overwrite",
    ]
    for kv in sets:
        args += ["--set", kv]
    subprocess.run(args, check=True, capture_output=True)
    subprocess.run(
        [sys.executable, "-m", "omnislam", "evaluate", str(out)], check=True, capture_output=True
    )
    return read_run_metrics(out / METRICS)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--set", nargs="*", default=[])
    args = parser.parse_args()
    modes = {
        "dead reckoning": ("deadreckoning", []),
        "ukf ids": ("ukf", ["association.use_ids=true"]),
        "ukf no ids": ("ukf", []),
    }
    with tempfile.TemporaryDirectory() as tmp:
        print("| robot | " + " | ".join(f"{m} ATE median / RMSE [m]" for m in modes) + " |")
        for robot in range(1, 6):
            cells = []
            for label, (estimator, sets) in modes.items():
                extra = sets + (args.set if estimator == "ukf" else [])
                m = run(f"mrclam6-r{robot}", estimator, extra, Path(tmp) / f"{robot}-{label}")
                cells.append(f"{m.ate.median_m:.3f} / {m.ate.rmse_m:.3f}")
            print(f"| r{robot} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
