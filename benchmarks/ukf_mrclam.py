"""The vertical-line UKF on MR.CLAM dataset 6, robots 1-5, bearings only (ranges unused).

Against the surveyed landmark map, with the sightings' ids (the default) and
with ids ignored (geometric step 4 + two-frame validation); dead reckoning for reference.
``--set spacing.d_it_sightings_m=0.375`` processes a frame every 37.5 cm of travel, the paper's
spacing of images, instead of every frame of sightings (the default).

    PYTHONPATH=. OMNISLAM_DATA=../shared/data python benchmarks/ukf_mrclam.py [--set k=v ...]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from omnislam.harness.layout import METRICS
from omnislam.metrics.run_metrics import RunMetrics, read_run_metrics


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
        "ukf ids": ("ukf", []),  # the default: the sightings' barcodes
        "ukf no ids": ("ukf", ["association.use_ids=false"]),
    }
    medians: dict[str, list[float]] = {m: [] for m in modes}
    with tempfile.TemporaryDirectory() as tmp:
        print(f"ukf options {args.set}")
        print("| robot | " + " | ".join(f"{m} ATE median / RMSE [m]" for m in modes) + " |")
        print("|---" * (len(modes) + 1) + "|")
        for robot in range(1, 6):
            cells = []
            for label, (estimator, sets) in modes.items():
                extra = sets + (args.set if estimator == "ukf" else [])
                m = run(f"mrclam6-r{robot}", estimator, extra, Path(tmp) / f"{robot}-{label}")
                cells.append(f"{m.ate.median_m:.3f} / {m.ate.rmse_m:.3f}")
                medians[label].append(m.ate.median_m)
            print(f"| r{robot} | " + " | ".join(cells) + " |", flush=True)
    for label, values in medians.items():
        within = sum(v <= 0.10 for v in values)
        print(
            f"{label}: ATE medians {', '.join(f'{v:.3f}' for v in values)} m; median over the"
            f" robots {statistics.median(values):.3f} m; {within} of 5 robots <= 0.10 m"
        )


if __name__ == "__main__":
    main()
