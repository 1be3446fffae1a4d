"""``omnislam run DATASET --estimator NAME --out RUN_DIR [--seed N] [--set K=V ...] [--log LOG]``.

Loads the dataset (registered name or path), builds the estimator, feeds it every frame, times
each step, and writes RUN_DIR atomically (see ``omnislam.compare.rundir``). A dataset with
images replays the shared front end's log: ``--log LOG``, or the log computed once and cached
(``omnislam.compare.execute.frontend_log_for``). ``--set`` keys that the dataset's loader
accepts (e.g. ``robot=3``) go to the loader; ``modality``, ``prior_map`` and
``wrong_id_fraction`` to the harness; the others to the estimator.
"""

from __future__ import annotations

import argparse


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="run one estimator on one dataset")
    p.add_argument("dataset", metavar="DATASET", help="registered name or a file/folder")
    p.add_argument(
        "--estimator",
        required=True,
        help="deadreckoning, graphslam, graphslam-batch, fastslam1, fastslam2, ekfslam or ukf",
    )
    p.add_argument("--out", required=True, metavar="RUN_DIR", help="output folder")
    p.add_argument("--seed", type=int, default=None, help="random seed")
    p.add_argument(
        "--set",
        dest="options",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="loader, harness (modality=NAME, prior_map=RUN_DIR, wrong_id_fraction=F) or "
        "estimator option (repeatable)",
    )
    p.add_argument(
        "--log",
        default=None,
        metavar="LOG",
        help="front-end ObservationLog to replay (default for a dataset with images or laser "
        "scans: the shared front end's log, computed once and cached)",
    )
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
    """Peak resident set size of this process [MB] (kept for callers of the old name)."""
    from omnislam.compare.execute import peak_rss_mb as measure

    return measure()


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    import numpy as np

    from omnislam._files import check_output_location
    from omnislam.compare.execute import RunSpec, check_estimator, execute_run
    from omnislam.compare.rundir import CONFIG, write_run_dir
    from omnislam.errors import ConfigError

    check_estimator(args.estimator)
    out = Path(args.out)
    if out.exists() and (not out.is_dir() or (any(out.iterdir()) and not (out / CONFIG).exists())):
        raise ConfigError(f"{out}: exists and is not a RUN_DIR; refusing to overwrite it")
    check_output_location(out, "RUN_DIR")  # before the work, not after it

    spec = RunSpec(
        dataset=args.dataset,
        estimator=args.estimator,
        seed=args.seed,
        options=parse_set(args.options),
        log=args.log,
    )
    record = execute_run(spec, progress=True)
    write_run_dir(out, record)
    config = record.config
    print(
        f"omnislam run: {args.estimator} on {args.dataset}: {config.frames} frames in "
        f"{config.total_s:.2f} s (median step {1e3 * np.median(record.step_s):.3f} ms), "
        f"peak RSS {config.peak_rss_mb:.0f} MB -> {out}"
    )
    return 0
