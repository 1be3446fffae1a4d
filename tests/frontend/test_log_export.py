"""``omnislam frontend DATASET --out LOG --export DIR``: the observation log as CSV.

The exported log of a short demo render is read back by ``examples/observation_log/read_log.py``
(the standard library and numpy only, guided by ``log.json``), turned into FrameInputs and
replayed into graphslam: the trajectory is the one of the log itself, byte for byte.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from omnislam.cli import main
from omnislam.core.types import Bearings, FrameInput, Odometry, RangeBearing, VerticalLines
from omnislam.frontend.log_export import TABLES, schema
from omnislam.frontend.observation_log import (
    ObservationLog,
    load_observation_log,
    save_observation_log,
)

pytest.importorskip("cv2")

READER = Path(__file__).resolve().parents[2] / "examples" / "observation_log" / "read_log.py"
#: images of the demo render
IMAGES = 6


def _reader():
    spec = importlib.util.spec_from_file_location("read_log", READER)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def exported(tmp_path_factory) -> tuple[Path, Path, Path]:
    """(render, log, exported folder) of a short demo render."""
    from omnislam.datasets.synthetic.presets import PRESETS
    from omnislam.datasets.synthetic.simulate import simulate
    from omnislam.datasets.synthetic.writer import write_synthetic

    root = tmp_path_factory.mktemp("log-export")
    write_synthetic(root / "demo", simulate(PRESETS["demo"], seed=0, max_images=IMAGES))
    argv = ["-q", "frontend", str(root / "demo"), "--out", str(root / "log.npz"),
            "--export", str(root / "csv")]
    assert main(argv) == 0
    return root / "demo", root / "log.npz", root / "csv"


def test_the_reader_imports_no_omnislam():
    import ast

    tree = ast.parse(READER.read_text())
    imported = {alias.name.split(".")[0] for node in ast.walk(tree)
                if isinstance(node, ast.Import) for alias in node.names}
    imported |= {node.module.split(".")[0] for node in ast.walk(tree)
                 if isinstance(node, ast.ImportFrom)}
    assert imported == {"__future__", "csv", "json", "sys", "pathlib", "numpy"}


def test_log_json_follows_its_schema_and_names_every_column(exported):
    import jsonschema

    meta = json.loads((exported[2] / "log.json").read_text())
    jsonschema.validate(meta, schema())
    for name, columns in TABLES.items():
        header = (exported[2] / name).read_text().splitlines()[0].split(",")
        assert header == [c.name for c in columns] == [c["name"] for c in meta["tables"][name]]


def _frames(tables: dict) -> tuple[list[FrameInput], list[np.ndarray | None]]:
    """FrameInputs and keypoint pixels from the tables the reader returned."""
    f = tables["frames.csv"]
    b, rb = tables["bearings.csv"], tables["range_bearing.csv"]
    v, p = tables["vertical_lines.csv"], tables["vertical_line_profiles.csv"]
    cov_names = [n for n in f if n.startswith("cov_")]
    frames, pixels = [], []
    for i in f["frame"]:
        cov = np.array([f[n][i] for n in cov_names]).reshape(3, 3)
        odometry = Odometry(np.array([f["dx_m"][i], f["dy_m"][i], f["dtheta_rad"][i]]),
                            f["stamp_s"][i], None if np.isnan(cov).all() else cov)
        bearings = lines = sightings = None
        px = None
        if f["has_bearings"][i]:
            k = b["frame"] == i
            bearings = Bearings(b["track_id"][k], np.column_stack([b["x"][k], b["y"][k],
                                                                   b["z"][k]]), b["sigma_rad"][k])
            px = np.column_stack([b["u_px"][k], b["v_px"][k]])
        if f["has_range_bearing"][i]:
            k = rb["frame"] == i
            sightings = RangeBearing(rb["landmark_id"][k], rb["range_m"][k], rb["bearing_rad"][k],
                                     rb["sigma_range_m"][k], rb["sigma_bearing_rad"][k])
        if f["has_vertical_lines"][i]:
            k = v["frame"] == i
            rows = np.flatnonzero(p["frame"] == i)
            profiles = np.array([p["values"][r] for r in rows]).reshape(int(k.sum()), 3, -1)
            colours = [np.column_stack([v[f"{side}_{c}"][k] for c in "rgb"])
                       for side in ("left", "right")]
            lines = VerticalLines(v["bearing_rad"][k], v["sigma_bearing_rad"][k],
                                  profiles.reshape(int(k.sum()), 3, -1), *colours,
                                  v["landmark_id"][k])
        frames.append(FrameInput(int(i), odometry, bearings, sightings, lines))
        pixels.append(px)
    return frames, pixels


@pytest.mark.slow
def test_the_csv_log_replayed_into_graphslam_gives_the_logs_trajectory(exported, tmp_path):
    pytest.importorskip("gtsam")
    from omnislam.core.types import OdometrySource

    render, log_path, folder = exported
    meta, tables = _reader().read_log(folder)
    frames, pixels = _frames(tables)
    original = load_observation_log(log_path)
    rebuilt = ObservationLog(meta["dataset_id"], meta["config_hash"], tuple(frames),
                             tuple(pixels), odometry_source=OdometrySource(meta["odometry_source"]),
                             floor_ids_from=meta["floor_ids_from"])
    assert len(rebuilt) == len(original)
    save_observation_log(rebuilt, tmp_path / "rebuilt.npz")
    trajectories = []
    for name, log in (("log", log_path), ("csv", tmp_path / "rebuilt.npz")):
        argv = ["-q", "run", str(render), "--estimator", "graphslam", "--seed", "0",
                "--log", str(log), "--out", str(tmp_path / name)]
        assert main(argv) == 0
        trajectories.append((tmp_path / name / "trajectory.tum").read_bytes())
    assert trajectories[0] == trajectories[1]
