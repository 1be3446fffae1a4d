"""The grid runner: serial == Dask (also with a worker killed), resume, retries, atomic cells."""

from __future__ import annotations

import json
import os
import signal
import threading
import time
from concurrent.futures import Future
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

import pytest
from room_log import write_room_log

from omnislam.errors import ConfigError
from omnislam.harness.grid import load_grid
from omnislam.harness.layout import CELLS, METRICS
from omnislam.harness.runner import (
    CellStatus,
    SerialExecutor,
    dask_executor_factory,
    run_cell,
    run_grid,
)
from omnislam.metrics.run_metrics import MEASURED_KEYS, read_run_metrics

GRID = """
name: rooms
datasets: [data/room_a.log, {{dataset: data/room_b.log, label: b}}]
estimators: [{estimators}]
seeds: [0, 1]
evaluation: {{rpe_segment_m: {segment}}}
"""


#: dead reckoning made seed-dependent (the harness re-labels sightings with the seed; dead
#: reckoning reads none), so that every cell runs once per seed: 2 datasets x 2 seeds
PER_SEED = "{estimator: deadreckoning, options: {wrong_id_fraction: 0.1}}"


def make_grid(
    tmp_path: Path, frames: int = 60, segment: float = 2.0, estimators: str = PER_SEED
) -> Path:
    write_room_log(tmp_path / "data" / "room_a.log", frames=frames, seed=1)
    write_room_log(tmp_path / "data" / "room_b.log", frames=frames + 20, seed=2)
    path = tmp_path / "grid.yaml"
    path.write_text(GRID.format(segment=segment, estimators=estimators))
    return path


def numbers(results: Path) -> dict[str, dict[str, object]]:
    """Every cell's metrics without the measured ones (time, memory), and its trajectory file."""
    out = {}
    for cell in sorted((results / CELLS).iterdir()):
        metrics = read_run_metrics(cell / METRICS).to_json()
        out[cell.name] = {k: v for k, v in metrics.items() if k not in MEASURED_KEYS}
        out[cell.name]["trajectory"] = (cell / "trajectory.tum").read_text()
    return out


class CountingExecutor(SerialExecutor):
    """Counts the cells submitted (``submitted``) beside the datasets' preparations."""

    def __init__(self):
        self.submitted = 0
        self.prepared = 0

    def submit(self, fn, /, *args, **kwargs):
        if fn is run_cell:
            self.submitted += 1
        else:
            self.prepared += 1
        return super().submit(fn, *args, **kwargs)


def test_grid_cells_are_named_deterministically(tmp_path):
    grid = load_grid(make_grid(tmp_path))
    assert [c.cell_id for c in grid.cells] == [
        "room_a__deadreckoning__s0",
        "room_a__deadreckoning__s1",
        "b__deadreckoning__s0",
        "b__deadreckoning__s1",
    ]
    assert grid.evaluation.rpe_segment_m == 2.0


def test_a_deterministic_estimator_runs_once_per_dataset_whatever_the_seeds(tmp_path):
    executor = CountingExecutor()
    grid = load_grid(make_grid(tmp_path, estimators="deadreckoning"))
    result = run_grid(grid, tmp_path / "out", lambda: executor)
    assert executor.submitted == 2  # two datasets x one run, not x two seeds
    assert sorted(p.name for p in (tmp_path / "out" / CELLS).iterdir()) == [
        "b__deadreckoning__s0",
        "room_a__deadreckoning__s0",
    ]
    assert result.count(CellStatus.COMPUTED) == 2


def test_a_cell_equals_omnislam_run_and_evaluate(tmp_path):
    from omnislam.cli import main

    grid = load_grid(make_grid(tmp_path))
    run_grid(grid, tmp_path / "out", SerialExecutor)
    log = tmp_path / "data" / "room_a.log"
    run = tmp_path / "run"
    assert (
        main(
            [
                "run", str(log), "--estimator", "deadreckoning", "--out", str(run), "--seed", "0",
                "--set", "wrong_id_fraction=0.1",
            ]
        )
        == 0
    )
    assert main(["evaluate", str(run), "--json", "--rpe-segment", "2"]) == 0
    cell = tmp_path / "out" / CELLS / "room_a__deadreckoning__s0"
    ours = read_run_metrics(cell / METRICS).to_json()
    theirs = read_run_metrics(run / METRICS).to_json()
    assert {k: v for k, v in ours.items() if k not in MEASURED_KEYS} == {
        k: v for k, v in theirs.items() if k not in MEASURED_KEYS
    }


def test_resume_computes_only_unfinished_cells(tmp_path):
    grid = load_grid(make_grid(tmp_path))
    out = tmp_path / "out"

    seen = []

    def interrupt_after_two(outcome):  # Ctrl-C while the third cell is being collected
        seen.append(outcome)
        if len(seen) == 2:
            raise KeyboardInterrupt

    first = CountingExecutor()
    with pytest.raises(KeyboardInterrupt):
        run_grid(grid, out, lambda: first, on_outcome=interrupt_after_two)
    finished = sorted(p.name for p in (out / CELLS).iterdir())
    assert len(finished) == 2 and not [p for p in (out / CELLS).iterdir() if p.name[0] == "."]
    summary = json.loads((out / "results.json").read_text())
    assert [row["status"] for row in summary["cells"]] == ["computed", "computed"]
    before = {name: (out / CELLS / name / METRICS).stat().st_mtime_ns for name in finished}

    second = CountingExecutor()
    result = run_grid(grid, out, lambda: second)
    assert second.submitted == 2  # only the two missing cells were computed
    assert result.count(CellStatus.REUSED) == 2 and result.count(CellStatus.COMPUTED) == 2
    assert {n: (out / CELLS / n / METRICS).stat().st_mtime_ns for n in finished} == before

    third = CountingExecutor()
    assert run_grid(grid, out, lambda: third).count(CellStatus.REUSED) == 4
    assert third.submitted == 0


def test_a_changed_cell_spec_is_recomputed(tmp_path):
    path = make_grid(tmp_path)
    out = tmp_path / "out"
    run_grid(load_grid(path), out, SerialExecutor)
    # same cell ids, other loader option: nothing may be reused
    path.write_text(
        path.read_text().replace("data/room_a.log,", "{dataset: data/room_b.log, label: room_a},")
    )
    counting = CountingExecutor()
    result = run_grid(load_grid(path), out, lambda: counting)
    assert counting.submitted == 2 and result.count(CellStatus.REUSED) == 2


def test_lost_workers_are_retried_a_bounded_number_of_times(tmp_path):
    grid = load_grid(make_grid(tmp_path))

    class Flaky(CountingExecutor):
        def __init__(self, failures):
            super().__init__()
            self.failures = failures

        def submit(self, fn, /, *args, **kwargs):
            if fn is not run_cell:  # the datasets' preparations: see the test below
                return SerialExecutor.submit(self, fn, *args, **kwargs)
            self.submitted += 1
            if self.failures > 0:
                self.failures -= 1
                future = Future()
                future.set_exception(BrokenProcessPool("worker died"))
                return future
            return SerialExecutor.submit(self, fn, *args, **kwargs)

    flaky = Flaky(failures=3)
    result = run_grid(grid, tmp_path / "out", lambda: flaky, max_attempts=3)
    assert result.count(CellStatus.COMPUTED) == 4 and flaky.submitted == 7
    assert numbers(tmp_path / "out")  # complete

    hopeless = Flaky(failures=100)
    result = run_grid(grid, tmp_path / "out2", lambda: hopeless, max_attempts=2)
    assert result.count(CellStatus.FAILED) == 4 and hopeless.submitted == 8
    assert all("gave up after 2 attempts" in o.error for o in result.outcomes)
    assert list((tmp_path / "out2" / CELLS).iterdir()) == []


def test_a_bad_option_fails_the_whole_grid_before_any_cell_runs(tmp_path):
    path = make_grid(tmp_path)
    path.write_text(path.read_text() + "overrides: [{}, {particles: 5}]\n")
    with pytest.raises(ConfigError, match=r"room_a__deadreckoning__s0__particles=5.*particles"):
        load_grid(path)
    assert not (tmp_path / "out").exists()


def test_a_cell_that_fails_at_run_time_fails_alone_and_is_not_retried(tmp_path):
    ukf = "{estimator: ukf, options: {wrong_id_fraction: 0.1}}"
    path = make_grid(tmp_path, estimators=f"{PER_SEED}, {ukf}")
    counting = CountingExecutor()
    result = run_grid(load_grid(path), tmp_path / "out", lambda: counting)
    assert result.count(CellStatus.COMPUTED) == 4 and result.count(CellStatus.FAILED) == 4
    assert counting.submitted == 8
    failed = [o for o in result.outcomes if o.status is CellStatus.FAILED]
    assert all("ukf" in o.error for o in failed)  # no map or no usable stream: found at run time
    assert failed[0].cell.cell_id == "room_a__ukf__s0"


def test_local_process_pool_survives_a_killed_worker(tmp_path):
    from concurrent.futures import ProcessPoolExecutor

    grid = load_grid(make_grid(tmp_path, frames=60))
    run_grid(grid, tmp_path / "serial", SerialExecutor)
    pools = []

    def factory():
        pools.append(ProcessPoolExecutor(max_workers=2))
        if len(pools) == 1:  # kill a worker of the first pool as soon as it exists
            pool = pools[0]
            pool.submit(time.sleep, 0).result()
            os.kill(next(iter(pool._processes)), signal.SIGKILL)
        return pools[-1]

    result = run_grid(grid, tmp_path / "pool", factory)
    assert result.count(CellStatus.COMPUTED) == 4 and len(pools) >= 2
    assert numbers(tmp_path / "pool") == numbers(tmp_path / "serial")


@pytest.fixture(scope="module")
def dask_client():
    distributed = pytest.importorskip("distributed")
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        yield client


def test_dask_local_cluster_gives_the_numbers_of_the_serial_run(tmp_path, dask_client):
    grid = load_grid(make_grid(tmp_path))
    serial = run_grid(grid, tmp_path / "serial", SerialExecutor)
    dask = run_grid(grid, tmp_path / "dask", dask_executor_factory(dask_client))
    assert serial.count(CellStatus.COMPUTED) == dask.count(CellStatus.COMPUTED) == 4
    assert numbers(tmp_path / "dask") == numbers(tmp_path / "serial")


@pytest.mark.slow
def test_dask_worker_killed_mid_grid_still_gives_a_complete_identical_result(tmp_path, dask_client):
    # cells big enough (loading ~0.5 s each) that a worker is killed while computing one
    grid = load_grid(make_grid(tmp_path, frames=6000, segment=10.0))
    run_grid(grid, tmp_path / "serial", SerialExecutor)
    pids = dask_client.run(os.getpid)
    killed = []

    def killer():
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and not killed:
            busy = [w for w, tasks in dask_client.processing().items() if tasks]
            if busy:
                time.sleep(0.2)  # let the task get going
                os.kill(pids[busy[0]], signal.SIGKILL)
                killed.append(busy[0])
            time.sleep(0.02)

    thread = threading.Thread(target=killer)
    thread.start()
    result = run_grid(grid, tmp_path / "dask", dask_executor_factory(dask_client))
    thread.join()
    assert killed, "no worker was busy: nothing was killed"
    assert result.count(CellStatus.COMPUTED) == 4
    assert numbers(tmp_path / "dask") == numbers(tmp_path / "serial")


def test_without_reuse_every_cell_is_computed_again_and_stale_cells_go(tmp_path):
    path = make_grid(tmp_path)
    out = tmp_path / "out"
    run_grid(load_grid(path), out, SerialExecutor)
    before = numbers(out)
    # the grid loses room_b: its two cells are no longer the grid's
    path.write_text(path.read_text().replace(", {dataset: data/room_b.log, label: b}", ""))
    counting = CountingExecutor()
    seen = []
    result = run_grid(load_grid(path), out, lambda: counting, on_progress=seen.append, reuse=False)
    assert counting.submitted == 2 and result.count(CellStatus.COMPUTED) == 2
    assert sorted(p.name for p in (out / CELLS).iterdir()) == [
        "room_a__deadreckoning__s0",
        "room_a__deadreckoning__s1",
    ]
    assert numbers(out) == {k: v for k, v in before.items() if k.startswith("room_a")}
    storing = [(p.cell.cell_id, p.done, p.total) for p in seen if p.stage == "storing"]
    assert storing == [
        ("room_a__deadreckoning__s0", 60, 60),
        ("room_a__deadreckoning__s1", 60, 60),
    ]


def test_a_progress_message_that_arrives_after_its_cell_was_stored_is_dropped(
    tmp_path, monkeypatch
):
    # the channel's reader thread can lag behind the worker under load: a cell's early
    # messages then arrive after the runner stored the cell, and were counted a second time
    from omnislam.harness import channel
    from omnislam.harness.channel import StepMessage

    drain = channel.ProgressChannel.drain
    seen = []
    held: list[StepMessage] = []

    delivered_late = []

    def lagging(self):  # each cell's "loading" message is delivered once the cell is stored
        held.extend(drain(self))
        stored = {p.cell.cell_id for p in seen if p.stage == "storing"}
        out, keep = [], []
        for m in held:
            (out if m.stage != "loading" or m.key in stored else keep).append(m)
        delivered_late.extend(m for m in out if m.stage == "loading")
        held[:] = keep
        return out

    monkeypatch.setattr(channel.ProgressChannel, "drain", lagging)
    run_grid(
        load_grid(make_grid(tmp_path)), tmp_path / "out", SerialExecutor, on_progress=seen.append
    )
    stored = set()
    for p in seen:
        if p.stage == "storing":
            stored.add(p.cell.cell_id)
        else:
            assert p.cell.cell_id not in stored, f"{p.cell.cell_id}: {p.stage} after it was stored"
    assert len(stored) == 4
    assert len(delivered_late) >= 3  # the late messages did arrive: they were dropped


def test_a_datasets_render_and_front_end_report_their_images_before_its_cells_start(
    tmp_path, monkeypatch
):
    # the suite's campus1500 renders for ~15 min per seed: the progress line must say so
    from omnislam.harness.runner import PrepareProgress

    monkeypatch.setenv("OMNISLAM_CACHE", str(tmp_path / "cache"))  # not rendered before
    path = tmp_path / "grid.yaml"
    path.write_text(
        "datasets: [{synthetic: demo, images: 2, seeds: [3]}, data/room_a.log]\n"
        "estimators: [deadreckoning]\n"
    )
    write_room_log(tmp_path / "data" / "room_a.log", frames=30, seed=1)
    seen = []
    run_grid(load_grid(path), tmp_path / "out", SerialExecutor, on_progress=seen.append)
    prepared = [p for p in seen if isinstance(p, PrepareProgress)]
    assert {p.label for p in prepared} == {"demo s3"}  # the room log has nothing to prepare
    stages = [p.stage for p in prepared]
    assert stages[0] == "simulating" and stages[-1] == "done"
    rendering = [(p.done, p.total) for p in prepared if p.stage == "rendering"]
    assert rendering and rendering[-1] == (2, 2)  # the last image is always sent
    front_end = [(p.done, p.total) for p in prepared if p.stage == "front end"]
    assert front_end and front_end[-1][1] == 2
    order = [stages.index(s) for s in ("simulating", "rendering", "front end", "done")]
    assert order == sorted(order)
    # the preparation ends before the dataset's cell reports anything
    first_cell = next(
        i
        for i, p in enumerate(seen)
        if not isinstance(p, PrepareProgress) and p.cell.dataset_label == "demo"
    )
    assert seen.index(prepared[-1]) < first_cell


def test_the_progress_line_names_a_dataset_being_prepared_until_it_is_done(
    tmp_path, monkeypatch, capsys
):
    from omnislam import _progress
    from omnislam.harness.grid_progress import GridProgress
    from omnislam.harness.runner import PrepareProgress

    monkeypatch.setenv(_progress.ENABLE_VARIABLE, "1")
    monkeypatch.setenv(_progress.INTERVAL_VARIABLE, "0")
    grid = load_grid(make_grid(tmp_path))
    line = GridProgress(grid)
    line.on_progress(PrepareProgress("x", "campus1500 s1", "rendering", 412, 2497))
    line.on_progress(PrepareProgress("y", "carmen-aces", "front end", 0, 0))
    err = capsys.readouterr().err
    assert "campus1500 s1 rendering 412/2497, carmen-aces front end" in err
    line.on_progress(PrepareProgress("x", "campus1500 s1", "done", 0, 0))
    line.on_progress(PrepareProgress("y", "carmen-aces", "done", 0, 0))
    line.close()
    assert "campus1500" not in capsys.readouterr().err
