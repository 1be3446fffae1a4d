"""One progress line for a grid run: cells finished, frames stepped, rate, ETA, cells running.

``GridProgress`` takes the runner's callbacks (``run_grid(on_outcome=..., on_progress=...)``)
and keeps one ``omnislam._progress.Progress`` up to date::

    compare: 2/7 cells, 410/2471 frames (17%), 61 frames/s, ETA 0:34 - graphslam 120/353, ...

Datasets being prepared on a worker (a synthetic preset rendered, the shared front end run) are
named on the line first, with their stage and images done (``runner.PrepareProgress``)::

    compare: 0/27 cells, 0 frames - campus1500 s0 rendering 412/2497, campus1500 s1 simulating

The counts are this invocation's work: reused cells are counted as finished cells but not as
frames, so the rate and ETA measure what is being computed. A cell not started yet is assumed
to have as many frames as a started cell of the same dataset (until one has started, the total
and the ETA are unknown).
"""

from __future__ import annotations

from dataclasses import dataclass

from omnislam._progress import Progress
from omnislam.harness.grid import Grid, column_label
from omnislam.harness.runner import CellOutcome, CellProgress, CellStatus, PrepareProgress

#: at most this many running cells are named on the line
SHOWN_RUNNING = 3


@dataclass(slots=True)
class _Running:
    label: str
    stage: str
    done: int
    total: int
    counted: bool = False  # its count is shown in every stage (a dataset's preparation)


class GridProgress:
    """The progress line of a grid (a context manager; see the module docstring).

    Args:
        grid: the grid being run.
        label: the line's label ("compare", "demo estimators").
    """

    def __init__(self, grid: Grid, label: str = "compare") -> None:
        self._cells = {cell.cell_id: cell for cell in grid.cells}
        self._finished: dict[str, int] = {}  # cell id -> frames computed (0: reused / failed)
        self._reused = 0
        self._running: dict[str, _Running] = {}
        self._preparing: dict[str, _Running] = {}  # dataset -> its preparation
        self._frames_of: dict[str, int] = {}  # dataset -> frames of one of its runs
        self._label = label
        # made at the first event, after the runner's front-end stage has printed its own lines
        self._progress: Progress | None = None

    def on_progress(self, progress: CellProgress | PrepareProgress) -> None:
        """``run_grid``'s ``on_progress``."""
        if isinstance(progress, PrepareProgress):
            if progress.stage == "done":
                self._preparing.pop(progress.dataset, None)
            else:
                self._preparing[progress.dataset] = _Running(
                    progress.label, progress.stage, progress.done, progress.total, counted=True
                )
            self._refresh()
            return
        cell = progress.cell
        if progress.total > 0:
            self._frames_of[cell.spec.dataset] = progress.total
        label = f"{column_label(cell)}" + (f" s{cell.spec.seed}" if self._seeds() > 1 else "")
        self._running[cell.cell_id] = _Running(label, progress.stage, progress.done, progress.total)
        self._refresh()

    def on_outcome(self, outcome: CellOutcome) -> None:
        """``run_grid``'s ``on_outcome``."""
        cell_id = outcome.cell.cell_id
        running = self._running.pop(cell_id, None)
        if outcome.status is CellStatus.REUSED:
            self._reused += 1
            self._finished[cell_id] = 0
        elif outcome.status is CellStatus.COMPUTED and outcome.metrics is not None:
            frames = outcome.metrics.timing.frames or (running.total if running else 0)
            self._frames_of.setdefault(outcome.cell.spec.dataset, frames)
            self._finished[cell_id] = frames
        else:  # failed: what it did counts, nothing is left to do
            self._finished[cell_id] = running.done if running else 0
        self._refresh()

    def close(self) -> None:
        """The last line."""
        if self._progress is None:
            return
        self._refresh(final=True)
        self._progress.close()

    def __enter__(self) -> GridProgress:
        return self

    def __exit__(self, *exc: object) -> None:
        if exc[0] is None:
            self.close()
        elif self._progress is not None:
            self._progress.__exit__(*exc)  # type: ignore[arg-type]

    def _seeds(self) -> int:
        return len({cell.spec.seed for cell in self._cells.values()})

    def _refresh(self, final: bool = False) -> None:
        done = sum(self._finished.values()) + sum(r.done for r in self._running.values())
        total: int | None = sum(self._finished.values())
        for cell_id, cell in self._cells.items():
            if cell_id in self._finished:
                continue
            running = self._running.get(cell_id)
            frames = running.total if running is not None and running.total > 0 else None
            frames = frames or self._frames_of.get(cell.spec.dataset)
            if frames is None:
                total = None
                break
            total += frames
        if final:
            total = done
        reused = f" ({self._reused} reused)" if self._reused else ""
        note = f"{len(self._finished)}/{len(self._cells)} cells{reused}"
        active = [*self._preparing.values(), *self._running.values()]
        doing = ", ".join(
            f"{r.label} {r.done}/{r.total}"
            if r.stage == "running"
            else f"{r.label} {r.stage}" + (f" {r.done}/{r.total}" if r.counted and r.total else "")
            for r in active[:SHOWN_RUNNING]
        )
        if len(active) > SHOWN_RUNNING:
            doing += f" (+{len(active) - SHOWN_RUNNING} more)"
        if self._progress is None:
            self._progress = Progress(self._label, total, "frame")
        self._progress.set_total(total)
        self._progress.update(done, note=note, doing="" if final else doing, quiet=final)
