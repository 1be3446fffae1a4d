"""Run one estimator on one dataset and write its RUN_DIR.

DATASET is a registered name (omnislam dataset list), a synthetic preset's name (rendered with
the run's seed into the cache on first use, as a grid renders it) or a file or folder in a
format omnislam reads. The estimator is fed every frame, each step timed, and RUN_DIR is
written atomically (trajectory, landmarks, timing, config.yaml with the seed and every option,
and the ground truth); an existing RUN_DIR is replaced only with --overwrite. Progress (frames
done, rate, ETA) goes to stderr. A dataset with images or laser scans replays the shared front
end's log: --log LOG (written by omnislam frontend), or the log computed once and cached.
--set keys that the dataset's loader accepts (e.g. robot=3) go to the loader; modality,
prior_map, wrong_id_fraction and clutter_per_frame to the harness; the others to the estimator.
"""

from __future__ import annotations

import argparse

#: the seed of a run that names none (a grid's default seeds are [0] too)
DEFAULT_SEED = 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="run one estimator on one dataset", description=__doc__)
    p.add_argument(
        "dataset", metavar="DATASET", help="registered name, synthetic preset or a file/folder"
    )
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
        default=DEFAULT_SEED,
        help=f"random seed of the estimator, of the harness's perturbations and of a synthetic "
        f"preset's render (default {DEFAULT_SEED}, as omnislam compare; recorded in "
        "RUN_DIR/config.yaml)",
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
        help="front-end observation log to replay, written by `omnislam frontend` (default for "
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
    from omnislam._progress import Stages, say
    from omnislam.errors import ConfigError
    from omnislam.harness.execute import RunSpec, check_estimator, check_spec, execute_run
    from omnislam.harness.layout import CONFIG
    from omnislam.harness.renders import ensure_render, preset_render
    from omnislam.harness.rundir import write_run_dir

    if args.seed < 0:
        raise ConfigError(f"--seed must be >= 0, got {args.seed}")
    check_estimator(args.estimator)
    out = Path(args.out)
    check_overwrite(out, args.overwrite, "RUN_DIR", lambda p: (p / CONFIG).is_file())
    check_output_location(out, "RUN_DIR")  # before the work, not after it

    render = preset_render(args.dataset, args.seed)
    spec = RunSpec(
        dataset=args.dataset if render is None else str(render.path().absolute()),
        estimator=args.estimator,
        seed=args.seed,
        options=parse_set(args.options),
        log=args.log,
    )
    check_spec(spec, rendered=render is None)  # every option, before any work
    with Stages(f"run {args.estimator} on {Path(args.dataset).name}") as stages:
        if render is not None and ensure_render(render, spec.dataset, on_step=stages):
            say(f"omnislam run: rendered {render.preset} (seed {render.seed}) -> {spec.dataset}")
        record = execute_run(spec, progress=True, on_step=stages)
    write_run_dir(out, record)
    config = record.config
    print(
        f"omnislam run: {args.estimator} on {args.dataset} (seed {args.seed}): {config.frames} "
        f"frames in {config.total_s:.2f} s (median step {1e3 * np.median(record.step_s):.3f} "
        f"ms), peak RSS {config.peak_rss_mb:.0f} MB -> {out}"
    )
    return 0

