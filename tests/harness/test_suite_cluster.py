"""A small suite-like grid -- a synthetic preset rendered on demand, a laser log, particle
filters over seeds, a localiser on the map of another cell -- gives identical numbers on the
local process pool, on a Dask LocalCluster of several worker processes, and on a re-run from
the cache; cells that read another cell's map wait for it and follow it."""

from __future__ import annotations

import json
import logging
import shutil
from pathlib import Path

import pytest
from room_log import write_room_log
from test_runner import CountingExecutor, numbers

from omnislam.harness.grid import load_grid
from omnislam.harness.layout import CELL_TIME, CELLS, RESULTS_JSON
from omnislam.harness.runner import (
    CellStatus,
    SerialExecutor,
    dask_executor_factory,
    local_executor_factory,
    run_grid,
)
from omnislam.metrics.run_metrics import MEASURED_KEYS

GRID = """
name: small suite
datasets:
  - {synthetic: demo, images: 2, seeds: [0, 1], estimators: [graphslam, fastslam2, ukf]}
  - {dataset: data/room.log, label: room, estimators: [graphslam, fastslam2, ukf-on-graph]}
estimators:
  - graphslam
  - {estimator: fastslam2, seeds: [0, 1], options: {particles.n_particles: 8}}
  - ukf
  - {estimator: ukf, label: ukf-on-graph, options: {prior_map: {from: graphslam}}}
evaluation: {rpe_segment_m: 1.0}
"""


@pytest.fixture
def small_suite(tmp_path: Path) -> Path:
    write_room_log(tmp_path / "data" / "room.log", frames=120)
    path = tmp_path / "grid.yaml"
    path.write_text(GRID)
    return path


def metrics_rows(results: Path) -> list[tuple[str, str, dict]]:
    """(cell, status, metrics without the measured ones) of every row of results.json."""
    rows = json.loads((results / RESULTS_JSON).read_text())["cells"]
    return [
        (r["cell"], r["status"], {k: v for k, v in r["metrics"].items() if k not in MEASURED_KEYS})
        for r in rows
    ]


@pytest.mark.slow
def test_pool_dask_and_a_rerun_from_cache_give_identical_numbers(small_suite, tmp_path):
    distributed = pytest.importorskip("distributed")
    grid = load_grid(small_suite)
    assert len(grid.cells) == 3 * 2 + 4  # demo: 3 estimators x 2 seeds (worlds); room: 4
    pool = run_grid(grid, tmp_path / "pool", local_executor_factory(2))
    assert pool.count(CellStatus.COMPUTED) == len(grid.cells), [o.error for o in pool.outcomes]
    renders = {c.spec.dataset for c in grid.cells if c.render is not None}
    assert len(renders) == 2 and all(Path(r, "meta.json").is_file() for r in renders)

    with (
        distributed.LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            silence_logs=logging.ERROR,
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        dask = run_grid(grid, tmp_path / "dask", dask_executor_factory(client))
    assert dask.count(CellStatus.COMPUTED) == len(grid.cells)
    reference = numbers(tmp_path / "pool")  # metrics (not time, memory) and trajectory.tum
    assert numbers(tmp_path / "dask") == reference
    for cell in grid.cells:  # byte-identical maps too
        a, b = (tmp_path / d / CELLS / cell.cell_id / "landmarks.csv" for d in ("pool", "dask"))
        assert a.read_bytes() == b.read_bytes(), cell.cell_id

    again = CountingExecutor()
    rerun = run_grid(load_grid(small_suite), tmp_path / "pool", lambda: again)
    assert rerun.count(CellStatus.REUSED) == len(grid.cells) and again.submitted == 0
    assert numbers(tmp_path / "pool") == reference
    assert metrics_rows(tmp_path / "pool") == [
        (cell, "reused", metrics) for cell, _, metrics in metrics_rows(tmp_path / "dask")
    ]
    times = [o.time for o in rerun.outcomes]  # what each cell cost when it was computed
    assert all(t is not None and t.wall_s > 0 and t.cpu_s > 0 for t in times)


def test_a_cell_on_another_cells_map_follows_it(small_suite, tmp_path):
    text = "\n".join(line for line in GRID.splitlines() if "synthetic: demo" not in line)
    small_suite.write_text(text)  # the room only
    room = load_grid(small_suite)
    out = tmp_path / "out"
    first = run_grid(room, out, SerialExecutor)
    on_graph = next(o for o in first.outcomes if o.cell.estimator_label == "ukf-on-graph")
    assert on_graph.status is CellStatus.COMPUTED
    config = (out / CELLS / on_graph.cell.cell_id / "config.yaml").read_text()
    assert f"prior_map: {out / CELLS / 'room__graphslam__s0'}" in config
    assert (out / CELLS / on_graph.cell.cell_id / CELL_TIME).is_file()

    # the map is computed again: so is the cell on it, and nothing else
    shutil.rmtree(out / CELLS / "room__graphslam__s0")
    counting = CountingExecutor()
    again = run_grid(room, out, lambda: counting)
    computed = {o.cell.cell_id for o in again.outcomes if o.status is CellStatus.COMPUTED}
    assert computed == {"room__graphslam__s0", "room__ukf-on-graph__s0"}
    assert counting.submitted == 2

    # --overwrite (reuse=False): every cell again, the one on the map after the map
    order = []
    everything = run_grid(room, out, SerialExecutor, reuse=False, on_outcome=order.append)
    assert everything.count(CellStatus.COMPUTED) == len(room.cells)
    ids = [o.cell.cell_id for o in order]
    assert ids.index("room__graphslam__s0") < ids.index("room__ukf-on-graph__s0")


def test_a_cell_whose_map_fails_fails_with_it(tmp_path):
    write_room_log(tmp_path / "data" / "room.log", frames=120)
    path = tmp_path / "grid.yaml"
    path.write_text(
        "datasets: [data/room.log]\n"
        "estimators: [ukf, {estimator: ukf, label: second, "
        "options: {prior_map: {from: ukf}}}]\n"
    )
    result = run_grid(load_grid(path), tmp_path / "out", SerialExecutor)
    first, second = result.outcomes
    assert first.status is second.status is CellStatus.FAILED
    assert "has none" in first.error  # the room log has no map for the UKF
    assert second.error == f"its prior map, cell {first.cell.cell_id}, failed"


def test_a_dataset_that_cannot_be_prepared_fails_its_cells_only(tmp_path, monkeypatch):
    write_room_log(tmp_path / "data" / "room.log", frames=120)
    path = tmp_path / "grid.yaml"
    path.write_text(
        "datasets: [{synthetic: demo, images: 1}, data/room.log]\nestimators: [deadreckoning]\n"
    )
    grid = load_grid(path)
    render = next(c.spec.dataset for c in grid.cells if c.render is not None)
    Path(render).parent.mkdir(parents=True, exist_ok=True)
    Path(render).write_text("not a folder")  # the render cannot be written there
    result = run_grid(grid, tmp_path / "out", SerialExecutor)
    demo, room = result.outcomes
    assert demo.status is CellStatus.FAILED and demo.error.startswith(f"preparing {render}:")
    assert room.status is CellStatus.COMPUTED
