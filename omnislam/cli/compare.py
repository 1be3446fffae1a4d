"""Run a grid of datasets x estimators x seeds and collect their metrics.

omnislam compare --template prints a commented grid file with every key. The cells run on a
local process pool (--workers, default: one per core; 0 runs them in this process) or on a Dask
cluster (--scheduler tcp://HOST:PORT; --scheduler local starts a local cluster of --workers
processes). An existing RESULTS_DIR is refused unless --resume (keep its finished cells,
compute the others: the way to continue an interrupted grid) or --overwrite (compute every cell
again). Progress goes to stderr: cells finished, frames stepped by the running cells, rate and
ETA; then each distinct warning of the cells, once; a table of the results goes to stdout. Exit
code 0 when every cell succeeded, 1 when some failed (each named on stderr), 2 on bad input
(nothing written).
"""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Callable
    from concurrent.futures import Executor
    from contextlib import ExitStack

    from omnislam.harness.runner import GridResult


class _PrintTemplate(argparse.Action):
    """``--template``: print ``harness.grid.grid_template()`` and exit (like ``--version``)."""

    def __init__(self, option_strings: list[str], dest: str, **kwargs: object) -> None:
        kwargs.pop("nargs", None)
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kwargs)  # type: ignore[arg-type]

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: object,
        option_string: str | None = None,
    ) -> None:
        from omnislam.harness.grid import grid_template

        sys.stdout.write(grid_template())
        sys.stdout.flush()
        parser.exit(0)


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "compare", help="run a grid of datasets x estimators x seeds", description=__doc__
    )
    p.add_argument("grid", metavar="GRID.yaml", help="grid file")
    p.add_argument("--out", required=True, metavar="RESULTS_DIR", help="results folder")
    p.add_argument(
        "--template",
        action=_PrintTemplate,
        help="print a commented grid file (every key, with its meaning) and exit",
    )
    p.add_argument(
        "--workers",
        type=int,
        default=None,
        help="local worker processes (default: one per core; 0 = in-process; with "
        "--scheduler local: the cluster's size, >= 1)",
    )
    p.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="Dask scheduler address, or 'local' for a LocalCluster",
    )
    p.add_argument(
        "--max-attempts", type=int, default=3, help="submissions per cell when a worker is lost"
    )
    p.add_argument(
        "--resume", action="store_true", help="continue RESULTS_DIR, keeping its finished cells"
    )
    p.add_argument(
        "--overwrite", action="store_true", help="compute every cell of RESULTS_DIR again"
    )
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from contextlib import ExitStack

    from omnislam._files import check_overwrite
    from omnislam.harness.grid import check_datasets, load_grid
    from omnislam.harness.grid_progress import GridProgress
    from omnislam.harness.layout import GRID_COPY
    from omnislam.harness.runner import check_results_dir, run_grid

    _check_arguments(args)
    grid = load_grid(args.grid)
    check_results_dir(args.out)
    if not args.resume:  # (check_results_dir refused a folder that is not a results folder)
        check_overwrite(
            args.out,
            args.overwrite,
            "results folder",
            lambda p: (p / GRID_COPY).is_file(),
            "pass --resume to continue it (finished cells are kept) or --overwrite to compute "
            "it again",
        )
    check_datasets(grid)  # a corrupt dataset file is bad input, before the results folder
    with ExitStack() as stack:
        factory, engine = _executor_factory(args, stack)
        bar = stack.enter_context(GridProgress(grid, f"compare ({engine})"))
        result = run_grid(
            grid,
            args.out,
            factory,
            max_attempts=args.max_attempts,
            on_outcome=bar.on_outcome,
            on_progress=bar.on_progress,
            reuse=args.resume,
        )
    for warning in result.warnings:  # each once, after the progress lines
        warning.log()
    return _print_outcomes(result, args.out)


def _check_arguments(args: argparse.Namespace) -> None:
    """Refuse options that exclude each other or are out of range (ConfigError)."""
    from omnislam.errors import ConfigError

    if args.resume and args.overwrite:
        raise ConfigError("--resume and --overwrite exclude each other")
    if args.max_attempts < 1:
        raise ConfigError(f"--max-attempts must be >= 1, got {args.max_attempts}")
    if args.scheduler not in (None, "local") and args.workers is not None:
        raise ConfigError("--workers cannot be combined with a remote --scheduler")
    if args.workers is not None and args.workers < 0:
        raise ConfigError(f"--workers must be >= 0, got {args.workers}")
    if args.scheduler == "local" and args.workers == 0:  # 0 means in-process, not a cluster
        raise ConfigError("--scheduler local needs --workers >= 1 (its cluster's size)")


def _executor_factory(
    args: argparse.Namespace, stack: ExitStack
) -> tuple[Callable[[], Executor], str]:
    """(the factory of the executor that runs the cells, how to name it): a local process pool,
    or a Dask cluster (a LocalCluster entered on ``stack`` for ``--scheduler local``)."""
    import logging
    import os

    from omnislam.errors import ConfigError
    from omnislam.harness.runner import dask_executor_factory, local_executor_factory

    if args.scheduler is None:
        if args.workers is not None:  # 0: in this process
            return local_executor_factory(args.workers), f"{args.workers} local"
        return local_executor_factory(os.cpu_count() or 1), f"{os.cpu_count()} local"
    from omnislam._optional import require

    distributed = require("distributed")
    if args.scheduler == "local":
        cluster = stack.enter_context(
            distributed.LocalCluster(
                n_workers=args.workers or os.cpu_count() or 1,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                # its shutdown chatter: a worker's heartbeat racing the scheduler's close is
                # logged at ERROR with a traceback; a failed task reaches the runner as an
                # exception and fails its cell visibly
                silence_logs=logging.INFO if getattr(args, "verbose", False) else logging.CRITICAL,
            )
        )
        address = cluster.scheduler_address
    else:
        address = args.scheduler
    try:
        client = stack.enter_context(distributed.Client(address, timeout="10s"))
    except OSError as exc:
        raise ConfigError(f"cannot reach the Dask scheduler {address!r} ({exc})") from None
    return dask_executor_factory(client), f"Dask at {address}"


def _print_outcomes(result: GridResult, out: str) -> int:
    """One line per cell and a summary on stdout, each failure on stderr; 1 if any failed."""
    from omnislam.harness.runner import CellStatus

    computed = result.count(CellStatus.COMPUTED)
    reused = result.count(CellStatus.REUSED)
    failed = [o for o in result.outcomes if o.status is CellStatus.FAILED]
    width = max(len(o.cell.cell_id) for o in result.outcomes)
    for outcome in result.outcomes:
        ate = outcome.metrics.ate.rmse_m if outcome.metrics is not None else None
        text = f"ATE {ate:.4g} m" if ate is not None else "ATE -"
        print(f"{outcome.cell.cell_id.ljust(width)}  {outcome.status.value:8s}  {text}")
    print(
        f"omnislam compare: {len(result.outcomes)} cells ({computed} computed, {reused} reused, "
        f"{len(failed)} failed) -> {out}"
    )
    for outcome in failed:
        print(
            f"omnislam compare: cell {outcome.cell.cell_id} failed: {outcome.error}",
            file=sys.stderr,
        )
    return 1 if failed else 0
