"""Run the shared front end once over a dataset and write its observation log.

The log (a compressed .npz) is replayed with omnislam run DATASET --log LOG. Progress (images
done, rate, ETA) goes to stderr. An existing LOG is refused unless --overwrite (rebuild it) or
--resume (keep it when it was built from the same dataset, configuration, --frames and --seed,
else rebuild it). --export DIR also writes the log as CSV files with a JSON description
(docs/tutorials/observation-log.md), for back ends outside omnislam.
"""

from __future__ import annotations

import argparse
import sys


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "frontend",
        help="run the shared front end (SIFT, groups, tracks, lines, laser) and cache its log",
        description=__doc__,
    )
    p.add_argument("dataset", help="registered dataset name or path")
    p.add_argument("--out", required=True, help="ObservationLog file to write (.npz)")
    p.add_argument(
        "--config", help="YAML file of front-end overrides (keys of the front end's configuration)"
    )
    p.add_argument("--frames", type=int, default=None, help="process at most N images")
    p.add_argument("--seed", type=int, default=0, help="seed of the RANSAC generator")
    p.add_argument(
        "--export",
        metavar="DIR",
        default=None,
        help="also write the log as CSV tables and log.json (an open form for other back ends)",
    )
    p.add_argument("--overwrite", action="store_true", help="rebuild an existing LOG")
    p.add_argument(
        "--resume",
        action="store_true",
        help="keep an existing LOG built from the same dataset, configuration, --frames and "
        "--seed (else rebuild it)",
    )
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    import dataclasses
    from pathlib import Path

    import numpy as np

    from omnislam._files import check_output_location, check_overwrite, read_yaml
    from omnislam.datasets.registry import load_dataset
    from omnislam.errors import ConfigError
    from omnislam.frontend.config import frontend_config_from_dict
    from omnislam.frontend.observation_log import (
        StaleLogError,
        dataset_fingerprint,
        load_observation_log,
        save_observation_log,
    )
    from omnislam.frontend.pipeline import log_key, run_frontend

    overrides = None
    if args.config:
        overrides = read_yaml(args.config)
        if overrides is not None and not isinstance(overrides, dict):
            raise ConfigError(f"{args.config}: the configuration must be a mapping")
    config = frontend_config_from_dict(overrides, args.config)
    if args.frames is not None and args.frames < 1:
        raise ConfigError("--frames must be >= 1")
    out = Path(args.out)
    if out.is_dir():
        raise ConfigError(f"{out}: is a folder; --out is the log file to write")
    if args.overwrite and args.resume:
        raise ConfigError("--overwrite and --resume exclude each other")
    check_overwrite(
        out,
        args.overwrite or args.resume,
        "observation log",
        hint="pass --resume to keep it when it is up to date or --overwrite to rebuild it",
    )
    check_output_location(out, "observation log")
    if args.export is not None:
        check_overwrite(
            args.export,
            args.overwrite or args.resume,
            "observation log export",
            lambda p: (p / "log.json").is_file(),
        )
        check_output_location(args.export, "observation log export")
    sequence = load_dataset(args.dataset)
    key_hash = log_key(config, args.frames, args.seed)
    if out.exists() and args.resume:
        try:
            log = load_observation_log(
                out, dataset_id=dataset_fingerprint(sequence), config_hash=key_hash
            )
            print(f"{out}: up to date (dataset and configuration unchanged)", file=sys.stderr)
            _export(log, args.export)
            return 0
        except StaleLogError as exc:
            print(f"{out}: rebuilding ({exc})", file=sys.stderr)
    log = run_frontend(
        sequence,
        config,
        rng=np.random.default_rng(args.seed),
        max_images=args.frames,
        progress=True,
        pipelined=True,
    )
    if log.config_hash != key_hash:  # the seed is the CLI's: run_frontend takes a generator
        log = dataclasses.replace(log, config_hash=key_hash)
    save_observation_log(log, out)
    stats = log.stats
    print(
        f"wrote {out}: {len(log)} frames, {int(stats.get('images_processed', 0))} images, "
        f"{int(stats.get('tracks_kept', 0))} tracks, median "
        f"{stats.get('sightings_per_image_median', 0):.0f} bearings per image",
        file=sys.stderr,
    )
    _export(log, args.export)
    return 0


def _export(log: object, folder: str | None) -> None:
    """Write the log's CSV form into ``folder`` (nothing when None)."""
    if folder is None:
        return
    from omnislam.frontend.log_export import export_observation_log

    export_observation_log(log, folder)  # type: ignore[arg-type]
    print(f"wrote {folder}: the observation log as CSV (log.json describes it)", file=sys.stderr)
