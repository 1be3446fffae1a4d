"""``omnislam run DATASET --estimator NAME --out RUN_DIR [--seed N] [--set K=V ...] [--log LOG]``.

Loads the dataset (registered name or path), builds the estimator, feeds it every frame, times
each step, and writes RUN_DIR atomically (see ``omnislam.compare.rundir``). ``--set`` keys that
the dataset's loader accepts (e.g. ``robot=3``) go to the loader, the others to the estimator.
"""

from __future__ import annotations

import argparse
import sys


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="run one estimator on one dataset")
    p.add_argument("dataset", metavar="DATASET", help="registered name or a file/folder")
    p.add_argument("--estimator", required=True, help="estimator name (e.g. deadreckoning)")
    p.add_argument("--out", required=True, metavar="RUN_DIR", help="output folder")
    p.add_argument("--seed", type=int, default=None, help="random seed")
    p.add_argument(
        "--set",
        dest="options",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="loader or estimator option (repeatable)",
    )
    p.add_argument(
        "--log",
        default=None,
        metavar="LOG",
        help="front-end ObservationLog to replay (not yet available)",
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
    """Peak resident set size of this process [MB] (0 where ``resource`` is unavailable)."""
    try:
        import resource
    except ImportError:  # pragma: no cover - Windows
        return 0.0
    kilobytes = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return kilobytes / (1024.0 * 1024.0) if sys.platform == "darwin" else kilobytes / 1024.0


def run(args: argparse.Namespace) -> int:
    import time
    from pathlib import Path

    import numpy as np

    import omnislam
    from omnislam.compare.rundir import CONFIG, RunConfig, RunRecord, write_run_dir
    from omnislam.core.types import UNKNOWN_ID
    from omnislam.datasets.registry import load_dataset, resolve
    from omnislam.errors import ConfigError
    from omnislam.estimators import ESTIMATORS, SequenceInfo, make_estimator

    if args.log is not None:
        raise ConfigError(
            "--log is not yet available (the front end's ObservationLog lands with the "
            "front-end issue); run without it to use the dataset's own sightings"
        )
    if args.estimator not in ESTIMATORS:
        raise ConfigError(f"unknown estimator {args.estimator!r}; known: {', '.join(ESTIMATORS)}")
    out = Path(args.out)
    if out.exists() and (not out.is_dir() or (any(out.iterdir()) and not (out / CONFIG).exists())):
        raise ConfigError(f"{out}: exists and is not a RUN_DIR; refusing to overwrite it")

    options = parse_set(args.options)
    resolved = resolve(args.dataset)
    loader_keys = resolved.option_names()
    dataset_options = {k: v for k, v in options.items() if k in loader_keys}
    estimator_options = {k: v for k, v in options.items() if k not in loader_keys}
    sequence = load_dataset(resolved, dataset_options)

    sightings = [rb for rb in sequence.range_bearing or () if rb is not None and len(rb)]
    known = bool(sightings) and all(np.all(rb.landmark_ids != UNKNOWN_ID) for rb in sightings)
    info = SequenceInfo(
        name=sequence.name,
        frames=len(sequence),
        has_range_bearing=bool(sightings),
        known_association=known,
        sigma_range_m=float(sightings[0].sigma_range_m[0]) if sightings else None,
        sigma_bearing_rad=float(sightings[0].sigma_bearing_rad[0]) if sightings else None,
        facts=sequence.info,
    )
    rng = np.random.default_rng(args.seed)
    estimator = make_estimator(args.estimator, info, estimator_options, rng)

    step_s = np.zeros(len(sequence))
    clock = time.perf_counter
    for frame in sequence.frame_inputs():
        start = clock()
        estimator.step(frame)
        step_s[frame.index] = clock() - start
    start = clock()
    estimate = estimator.estimate()
    final_s = clock() - start

    config = RunConfig(
        dataset=args.dataset,
        dataset_path=str(resolved.path),
        estimator=args.estimator,
        omnislam_version=omnislam.__version__,
        frames=len(sequence),
        total_s=float(step_s.sum() + final_s),
        peak_rss_mb=round(peak_rss_mb(), 1),
        ground_truth_kind=sequence.ground_truth.kind.value,
        ground_truth_note=sequence.ground_truth.note,
        source=sequence.source,
        seed=args.seed,
        dataset_options=dataset_options,
        estimator_options=estimator_options,
    )
    write_run_dir(out, RunRecord(config, estimate, step_s, sequence.ground_truth))
    print(
        f"omnislam run: {args.estimator} on {sequence.name}: {len(sequence)} frames in "
        f"{config.total_s:.2f} s (median step {1e3 * np.median(step_s):.3f} ms), "
        f"peak RSS {config.peak_rss_mb:.0f} MB -> {out}"
    )
    return 0
