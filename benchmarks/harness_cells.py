"""One cell of a benchmark table through the harness, cached as JSON: shared by the scripts
that tabulate `omnislam run` + `omnislam evaluate` results (association_mrclam.py, clutter.py,
victoria_park.py).

A cell is what ``omnislam run DATASET --estimator E --seed S --set K=V ... --out R`` followed
by ``omnislam evaluate R`` reports (``execute_run`` / ``evaluate_run``): the ATE RMSE after
SE(2) alignment, the landmarks of the map, the true landmark count where the data has one,
the false detections the harness added (``clutter_per_frame``), the association counters of
``estimator_info.json`` that the caller names, and the process CPU seconds of the run.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Iterable, Mapping
from pathlib import Path

from omnislam.harness.evaluation import evaluate_run
from omnislam.harness.execute import RunSpec, execute_run
from omnislam.harness.layout import ESTIMATOR_INFO


def run_cell(
    dataset: str,
    estimator: str,
    seed: int,
    options: Mapping[str, str],
    path: Path | None,
    count_keys: Iterable[str] = (),
) -> dict:
    """The cell's figures, read from ``path`` when it exists, else computed and written there
    (``path`` None: always computed, never written)."""
    if path is not None and path.exists():
        return json.loads(path.read_text())
    shown = " ".join(f"{k}={v}" for k, v in options.items())
    print(f"  running {dataset} {estimator} seed {seed} {shown} ...", file=sys.stderr, flush=True)
    start = time.process_time()
    record = execute_run(RunSpec(dataset, estimator, seed, dict(options)))
    cpu_s = time.process_time() - start
    metrics = evaluate_run(record)
    info = json.loads(record.attachments.get(ESTIMATOR_INFO, b"{}") or b"{}")
    out = {
        "ate_m": metrics.ate.rmse_m,
        "landmarks": metrics.landmarks.estimated,
        "landmark_rmse_m": metrics.landmarks.rmse_m,
        "truth": metrics.landmarks.truth,
        "added": record.config.clutter_added,
        "counts": {key: info[key] for key in count_keys if key in info},
        "cpu_s": cpu_s,
        "options": dict(options),
    }
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(out, indent=1))
    return out


def add_set_option(parser: argparse.ArgumentParser, help: str, flag: str = "--set") -> None:
    """A repeatable ``FLAG KEY=VALUE`` argument, gathered in ``args.options`` (read it with
    ``set_options``)."""
    parser.add_argument(flag, dest="options", action="append", default=[], metavar="KEY=VALUE",
                        help=help)


def set_options(
    parser: argparse.ArgumentParser, items: Iterable[str], flag: str = "--set"
) -> dict[str, str]:
    """The ``--set KEY=VALUE`` items of a benchmark's command line as a dict; a malformed item
    is a usage error (``parser.error``: one line naming ``flag``, exit 2)."""
    options = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key:
            parser.error(f"{flag} takes KEY=VALUE, got {item!r}")
        options[key] = value
    return options
