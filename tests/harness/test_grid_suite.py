"""The grid format the suite needs: synthetic presets per seed, per-estimator seeds, estimator
lists per dataset, ``prior_map: {from:}``; the suite grid itself (the render cache's key:
test_renders.py)."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import pytest
from room_log import write_room_log

from omnislam.errors import ConfigError
from omnislam.harness.cache import cache_dir
from omnislam.harness.grid import load_grid, parse_grid

REPO = Path(__file__).resolve().parents[2]
SUITE = REPO / "benchmarks" / "grids" / "suite.yaml"

GRID = """
datasets:
  - {{synthetic: demo, images: 3, seeds: [4, 5]}}
  - {{dataset: data/room.log, label: room{room_extra}}}
estimators:
  - deadreckoning
  - graphslam
  - {{estimator: fastslam2, seeds: [0, 1, 2]}}
  - {{estimator: ukf, label: on-graph, options: {{prior_map: {{from: graphslam}}}}}}
seeds: [7]
"""


def grid(tmp_path: Path, room_extra: str = "", text: str = GRID) -> object:
    write_room_log(tmp_path / "data" / "room.log")
    return parse_grid(text.format(room_extra=room_extra), tmp_path / "grid.yaml")


def test_a_synthetic_dataset_runs_every_estimator_on_each_of_its_seeds(tmp_path):
    cells = grid(tmp_path).cells
    demo = [c for c in cells if c.dataset_label == "demo"]
    # every estimator on each rendered world, that seed seeding render and estimator
    assert sorted((c.estimator_label, c.spec.seed) for c in demo) == sorted(
        (e, s) for e in ("deadreckoning", "graphslam", "fastslam2", "on-graph") for s in (4, 5)
    )
    for cell in demo:
        assert cell.render is not None and cell.render.seed == cell.spec.seed
        assert cell.render.preset == "demo" and cell.render.images == 3
        assert Path(cell.spec.dataset) == cell.render.path() and cell.render.path().is_relative_to(
            cache_dir()
        )
        assert not Path(cell.spec.dataset).exists()  # rendered by the runner, not by parsing
    assert len({c.spec.dataset for c in demo}) == 2  # one render per seed


def test_an_estimators_own_seeds_win_over_the_grids_on_data_on_disk(tmp_path):
    room = [c for c in grid(tmp_path).cells if c.dataset_label == "room"]
    seeds = defaultdict(list)
    for cell in room:
        seeds[cell.estimator_label].append(cell.spec.seed)
        assert cell.render is None and Path(cell.spec.dataset).is_absolute()
    assert seeds == {
        "deadreckoning": [7],
        "graphslam": [7],
        "fastslam2": [0, 1, 2],
        "on-graph": [7],
    }


def test_prior_map_from_names_the_cell_of_that_estimator_on_the_same_data_and_seed(tmp_path):
    cells = {c.cell_id: c for c in grid(tmp_path).cells}
    assert cells["room__on-graph__s7"].prior_from == "room__graphslam__s7"
    assert cells["demo__on-graph__s5"].prior_from == "demo__graphslam__s5"
    assert "prior_map" not in cells["room__on-graph__s7"].spec.options  # filled by the runner
    assert all(c.prior_from is None for c in cells.values() if c.estimator_label != "on-graph")


def test_a_dataset_runs_only_the_estimators_it_lists(tmp_path):
    cells = grid(tmp_path, ", estimators: [deadreckoning, graphslam, on-graph]").cells
    room = {c.estimator_label for c in cells if c.dataset_label == "room"}
    assert room == {"deadreckoning", "graphslam", "on-graph"}
    assert {c.estimator_label for c in cells if c.dataset_label == "demo"} == {
        "deadreckoning",
        "graphslam",
        "fastslam2",
        "on-graph",
    }


@pytest.mark.parametrize(
    ("room_extra", "text_change", "message"),
    [
        (", estimators: [deadreckoning, on-graph]", None, "prior_map from 'graphslam'.*no cell"),
        (", estimators: [nobody]", None, r"estimators \['nobody'\] are not in the grid"),
        (", seeds: [1]", None, "apply to synthetic datasets only"),
        ("", ("from: graphslam", "from: nobody"), "no other estimator of the grid"),
        ("", ("{from: graphslam}", "{from: graphslam, x: 1}"), "takes a RUN_DIR or"),
        ("", ("synthetic: demo", "synthetic: nowhere"), "unknown synthetic preset 'nowhere'"),
        ("", ("images: 3", "images: 0"), "'images' must be a positive integer"),
        ("", ("seeds: [4, 5]", "seeds: [4, 4]"), "'seeds' has duplicates"),
        ("", ("seeds: [0, 1, 2]", "seeds: []"), "'seeds' must be a non-empty list"),
    ],
)
def test_a_bad_suite_entry_fails_the_grid_naming_it(tmp_path, room_extra, text_change, message):
    text = GRID if text_change is None else GRID.replace(*text_change)
    with pytest.raises(ConfigError, match=message):
        grid(tmp_path, room_extra, text)


def test_the_suite_grid_runs_every_estimator_where_it_can_with_one_configuration(shared_data):
    suite = load_grid(SUITE)
    by_estimator = defaultdict(list)
    for cell in suite.cells:
        by_estimator[cell.estimator_label].append(cell)
    assert set(by_estimator) == {
        "deadreckoning",
        "graphslam",
        "graphslam-batch",
        "fastslam1",
        "fastslam2",
        "ekfslam",
        "ekfslam-poles",
        "ukf",
        "ukf-graphmap",
    }
    for label, cells in by_estimator.items():  # one configuration per estimator
        configurations = {
            tuple(sorted((k, v) for k, v in c.spec.options.items() if k != "association"))
            for c in cells
        }
        assert len(configurations) == 1, label
    datasets = {c.dataset_label for c in suite.cells}
    synthetic = {"demo", "lab40", "loop150", "campus1500", "corridor21"}
    real = {f"mrclam6-r{r}" for r in range(1, 6)} | {
        "victoria-park",
        "victoria-park-gtsam",
        "carmen-intel",
        "carmen-aces",
    }
    noids = {f"mrclam6-r{r}-noids" for r in range(1, 6)} | {"victoria-park-gtsam-noids"}
    synthetic_noids = {f"{d}-noids" for d in synthetic}
    assert datasets == synthetic | real | noids | synthetic_noids
    seeds = defaultdict(set)
    for cell in suite.cells:
        seeds[(cell.dataset_label, cell.estimator_label)].add(cell.spec.seed)
        if cell.dataset_label.endswith("-noids"):
            assert cell.spec.options.get("association") == "unknown"
    for (dataset, estimator), used in seeds.items():
        stochastic = estimator.startswith("fastslam")
        worlds = dataset.removesuffix("-noids") in synthetic
        assert used == ({0, 1, 2} if worlds or stochastic else {0}), (dataset, estimator)
    # the UKF where a map exists: the dataset's own, or the graph's on the same data and seed
    own = {c.dataset_label for c in by_estimator["ukf"]}
    assert own == synthetic | {d for d in real | noids if d.startswith("mrclam")}
    for cell in by_estimator["ukf-graphmap"]:
        assert cell.prior_from == f"{cell.dataset_label}__graphslam__s{cell.spec.seed}"
    assert {c.dataset_label for c in by_estimator["ukf-graphmap"]} == real | noids
    # the synthetic pole sightings' ids matter only to EKF-SLAM on them (beside its baseline)
    assert {
        (c.dataset_label, c.estimator_label)
        for c in suite.cells
        if c.dataset_label in synthetic_noids
    } == {(d, e) for d in synthetic_noids for e in ("deadreckoning", "ekfslam-poles")}
    poles = {c.dataset_label for c in by_estimator["ekfslam-poles"]}
    assert poles == synthetic | synthetic_noids | {d for d in real | noids if "mrclam" in d}
    assert len(suite.cells) == 280 + 5 * 3 * 2 + 5 * 3 + 10


def _suite_times():
    import importlib.util

    path = REPO / "benchmarks" / "suite_times.py"
    spec = importlib.util.spec_from_file_location("suite_times", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize(
    ("datasets", "estimators", "seeds"),
    [
        ({"lab40"}, {"graphslam", "graphslam-batch"}, {1}),  # no recorded data left: grid seeds
        ({"victoria-park"}, {"fastslam2", "ekfslam", "ukf-graphmap"}, None),  # needs graphslam
        (None, None, {1}),  # seed 1: worlds 1 and the stochastic estimators' seed 1 only
        ({"carmen-aces", "demo"}, {"fastslam1", "ukf"}, {0, 2}),
    ],
)
def test_a_subset_of_the_suite_is_the_suites_cells_that_match_and_the_maps_they_need(
    shared_data, datasets, estimators, seeds
):
    suite = load_grid(SUITE)
    text = _suite_times().subset_grid(SUITE.read_text(), datasets, estimators, seeds)
    import yaml

    subset = parse_grid(yaml.safe_dump(text), SUITE)

    def key(cell):
        options = tuple(sorted((k, repr(v)) for k, v in cell.spec.options.items()))
        return cell.dataset_label, cell.estimator_label, cell.spec.seed, options, cell.prior_from

    everything = {key(c): c for c in suite.cells}
    chosen = {key(c) for c in subset.cells}
    assert chosen <= set(everything)  # nothing that is not a suite cell

    def wanted(cell):
        return (
            (datasets is None or cell.dataset_label in datasets)
            and (estimators is None or cell.estimator_label in estimators)
            and (seeds is None or cell.spec.seed in seeds)
        )

    matching = {k for k, c in everything.items() if wanted(c)}
    assert matching and matching <= chosen  # every matching cell
    sources = {everything[k].prior_from for k in matching if everything[k].prior_from}
    names = {f"{k[0]}__{k[1]}__s{k[2]}" for k in chosen}
    assert sources <= names  # the cells their prior maps come from
    assert chosen - matching == {k for k in chosen if f"{k[0]}__{k[1]}__s{k[2]}" in sources}


DETERMINISTIC_GRID = """
datasets:
  - {synthetic: demo, images: 3, seeds: [4, 5]}
  - data/room.log
estimators:
  - deadreckoning
  - graphslam
  - ekfslam
  - fastslam1
  - {estimator: ukf, label: on-graph, options: {prior_map: {from: graphslam}}}
  - {estimator: ukf, label: on-particles, options: {prior_map: {from: fastslam1}}}
  - {estimator: graphslam, label: mislabelled, options: {wrong_id_fraction: 0.1}}
seeds: [0, 1, 2]
"""


def test_deterministic_estimators_run_once_on_data_on_disk_and_per_seed_on_renders(tmp_path):
    from omnislam.estimators import ESTIMATORS

    assert [n for n, e in ESTIMATORS.items() if e.stochastic] == ["fastslam1", "fastslam2"]
    cells = grid(tmp_path, text=DETERMINISTIC_GRID.replace("{", "{{").replace("}", "}}")).cells
    seeds = defaultdict(list)
    for cell in cells:
        seeds[(cell.dataset_label, cell.estimator_label)].append(cell.spec.seed)
    for label in ("deadreckoning", "graphslam", "ekfslam", "on-graph"):
        assert seeds[("room", label)] == [0]  # every seed would repeat the same run
        assert seeds[("demo", label)] == [4, 5]  # the seed is the world's
    assert seeds[("room", "fastslam1")] == [0, 1, 2]  # draws from its generator
    assert seeds[("room", "on-particles")] == [0, 1, 2]  # its map differs per seed
    assert seeds[("room", "mislabelled")] == [0, 1, 2]  # the harness draws with the seed
    by_id = {c.cell_id: c for c in cells}
    assert by_id["room__on-graph__s0"].prior_from == "room__graphslam__s0"
    assert by_id["room__on-particles__s2"].prior_from == "room__fastslam1__s2"
