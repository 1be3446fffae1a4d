"""What a report includes (``ReportOptions``), the one record every part of the report reads."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class ReportOptions:
    """What to include.

    Attributes:
        title: the report's title (default None: the grid's name).
        exports: write ``exports/CELL/`` (TUM, KITTI, PLY, g2o); default True.
        figures: draw each dataset's figures (default True; False: verdicts, tables and the
            summary figures only -- a report of many datasets small enough to commit, e.g. the
            suite's).
        summary_figures: draw the summary figures from the runs' metrics (ATE over seeds per
            dataset grouped by input, accuracy against run time over every dataset, the best of
            each method family); default True: they are small and need no RUN_DIR read.
        occupancy: build occupancy grids where the data has laser scans (default True).
        occupancy_resolution_m: grid cell size [m] (default 0.1: a wall stays one cell thick).
        command: the command line recorded in the provenance block (default None: ``sys.argv``).
        on_step: progress: called with (stage, done, total) as the report is written
            ("figures": datasets done of total, "exports": runs done of total); default None.
    """

    title: str | None = None
    exports: bool = True
    figures: bool = True
    summary_figures: bool = True
    occupancy: bool = True
    occupancy_resolution_m: float = 0.1
    command: tuple[str, ...] | None = None
    on_step: Callable[[str, int, int], None] | None = None
