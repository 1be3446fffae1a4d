"""``omnislam run SYNTH --estimator X --out R`` works for every registered estimator.

A rendered omni folder carries two streams (the front end's bearings and the pole sightings);
without ``--log`` the run computes (once, cached) and replays the shared front end's log, and
the one modality rule picks the omni bearings for every estimator that consumes them.
"""

from __future__ import annotations

import json

import pytest
import yaml

from omnislam.cli import main
from omnislam.core.modality import PRIORITY, Modality
from omnislam.estimators import ESTIMATORS
from omnislam.harness.layout import CONFIG, ESTIMATOR_INFO, GRAPH_G2O

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def runs(demo_folder, tmp_path_factory):
    out = tmp_path_factory.mktemp("runs")
    codes = {}
    for name in ESTIMATORS:
        codes[name] = main(
            ["run", str(demo_folder), "--estimator", name, "--out", str(out / name), "--seed", "0"]
        )
    return out, codes


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_runs_without_flags_on_the_shared_front_end(runs, name, demo_folder):
    out, codes = runs
    assert codes[name] == 0
    config = yaml.safe_load((out / name / CONFIG).read_text())
    images = sorted((demo_folder / "images").glob("*.png"))
    assert config["images"] == len(images) > 0  # the report's provenance counts them
    accepted = ESTIMATORS[name].modalities
    if not accepted:  # dead reckoning uses no sightings: no front end to run
        assert config["modality"] is None and config["frontend_log"] is None
        return
    assert config["frontend_log"]  # the front end's log, not the pole sightings alone
    # the rule: the first of the front end's streams the estimator takes
    first = next(m for m in PRIORITY if m in accepted)
    assert Modality(config["modality"]) is first


def test_graphslam_exports_a_graph_gtsam_reads(runs):
    gtsam = pytest.importorskip("gtsam")
    out, _ = runs
    path = out / "graphslam" / GRAPH_G2O
    assert path.is_file()
    from omnislam.harness.rundir import read_run_dir

    record = read_run_dir(out / "graphslam")
    graph, values = gtsam.readG2o(str(path), True)
    # one vertex per pose and landmark; the odometry edges are read back (bearing factors have
    # no g2o record: see README)
    # pose vertices are the graph's pose variables: its key frames (frames in between are
    # composed and smoothed from them), so at most one per frame
    n_poses, n_landmarks = len(record.estimate.trajectory), len(record.estimate.landmark_ids)
    n_vertices = sum(1 for key in values.keys() if chr(gtsam.Symbol(key).chr()) != "l")
    assert 2 <= n_vertices <= n_poses
    # the landmarks of the estimate, and the floor tracks the final solve placed on the floor
    # (``floor_points``: variables of the solved graph, not landmarks of the map)
    floor = json.loads(record.attachments[ESTIMATOR_INFO])["floor_landmarks"]
    assert n_landmarks <= values.size() - n_vertices <= n_landmarks + floor
    assert graph.size() == n_vertices - 1
