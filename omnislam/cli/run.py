"""``omnislam run DATASET --estimator NAME --out RUN_DIR [--seed N] [--set K=V ...] [--log LOG]``.

Loads the dataset (registered name or path), builds the estimator, feeds it every frame, times
each step, and writes RUN_DIR atomically (see ``omnislam.harness.rundir``); an existing
RUN_DIR is replaced only with ``--overwrite``. Progress (frames done, rate, ETA) goes to
stderr. A dataset with images replays the shared front end's log: ``--log LOG`` (written by
``omnislam frontend``), or the log computed once and cached
(``omnislam.harness.execute.frontend_log_for``). ``--set`` keys that the dataset's loader
accepts (e.g. ``robot=3``) go to the loader; ``modality``, ``prior_map``,
``wrong_id_fraction`` and ``clutter_per_frame`` to the harness; the others to the estimator.
"""

from __future__ import annotations

import argparse


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="run one estimator on one dataset", description=__doc__)
    p.add_argument("dataset", metavar="DATASET", help="registered name or a file/folder")
    p.add_argument(
        "--estimator",
        required=True,
        help="deadreckoning, graphslam, graphslam-batch, fastslam1, fastslam2, ekfslam, ukf or "
        "an installed plugin's (`omnislam estimators` lists them all with their options)",
    )
    p.add_argument("--out", required=True, metavar="RUN_DIR", help="output folder")
    p.add_argument(
        "--seed",
        type=int,
        default=None,
        help="random seed of the estimator and of the harness's perturbations (default: fresh "
        "entropy, a run that cannot be repeated)",
    )
    p.add_argument(
        "--set",
        dest="options",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="loader, harness (modality=NAME, prior_map=RUN_DIR, wrong_id_fraction=F, "
        "clutter_per_frame=R) or estimator option (repeatable; `omnislam estimators` lists them)",
    )
    p.add_argument(
        "--log",
        default=None,
        metavar="LOG",
        help="front-end ObservationLog to replay, written by `omnislam frontend` (default for "
        "a dataset with images or laser scans: the shared front end's log, computed once and "
        "cached)",
    )
    p.add_argument("--overwrite", action="store_true", help="replace an existing RUN_DIR")
    p.set_defaults(handler=run)


def parse_set(items: list[str]) -> dict[str, str]:
    """``["a=1", "b=x"]`` -> ``{"a": "1", "b": "x"}`` (ConfigError on a malformed item)."""
    from omnislam.errors import ConfigError

    out: dict[str, str] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ConfigError(f"--set expects KEY=VALUE, got {item!r}")
        if key.strip() in out:
            raise ConfigError(f"--set {key.strip()} given twice")
        out[key.strip()] = value.strip()
    return out


def peak_rss_mb() -> float:
    """Peak resident set size of this process [MB] (``harness.execute.peak_rss_mb``)."""
    from omnislam.harness.execute import peak_rss_mb as measure

    return measure()


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    import numpy as np

    from omnislam._files import check_output_location, check_overwrite
    from omnislam._progress import Stages
    from omnislam.harness.execute import RunSpec, check_estimator, check_spec, execute_run
    from omnislam.harness.layout import CONFIG
    from omnislam.harness.rundir import write_run_dir

    check_estimator(args.estimator)
    out = Path(args.out)
    check_overwrite(out, args.overwrite, "RUN_DIR", lambda p: (p / CONFIG).is_file())
    check_output_location(out, "RUN_DIR")  # before the work, not after it

    spec = RunSpec(
        dataset=args.dataset,
        estimator=args.estimator,
        seed=args.seed,
        options=parse_set(args.options),
        log=args.log,
    )
    check_spec(spec)  # every option, before any work
    with Stages(f"run {args.estimator} on {Path(args.dataset).name}") as stages:
        record = execute_run(spec, progress=True, on_step=stages)
    write_run_dir(out, record)
    config = record.config
    print(
        f"omnislam run: {args.estimator} on {args.dataset}: {config.frames} frames in "
        f"{config.total_s:.2f} s (median step {1e3 * np.median(record.step_s):.3f} ms), "
        f"peak RSS {config.peak_rss_mb:.0f} MB -> {out}"
    )
    return 0
