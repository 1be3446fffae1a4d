"""The realism setting: deterministic realistic renders, clean renders as the renderer makes
them, ``meta.json`` and the loader, the render cache's key, grids and the CLI."""

from __future__ import annotations

import hashlib
import json
import subprocess
import sys

import numpy as np
import pytest

from omnislam.datasets.synthetic import load_synthetic
from omnislam.datasets.synthetic.presets import PRESETS
from omnislam.datasets.synthetic.realism import Realism, RealismConfig, realism_config
from omnislam.datasets.synthetic.render import Renderer
from omnislam.datasets.synthetic.sensor import CameraSensor
from omnislam.datasets.synthetic.simulate import simulate
from omnislam.datasets.synthetic.writer import write_synthetic
from omnislam.errors import ConfigError
from omnislam.harness.grid import parse_grid
from omnislam.harness.renders import render_spec

cv2 = pytest.importorskip("cv2")

#: images of the demo runs written here
IMAGES = 2


@pytest.fixture(scope="module")
def short_sim():
    return simulate(PRESETS["demo"], seed=3, max_images=IMAGES)


@pytest.fixture(scope="module")
def clean_folder(short_sim, tmp_path_factory):
    return write_synthetic(tmp_path_factory.mktemp("realism") / "clean", short_sim)


@pytest.fixture(scope="module")
def real_folder(short_sim, tmp_path_factory):
    return write_synthetic(tmp_path_factory.mktemp("realism") / "real", short_sim,
                           realism="realistic")


def _digests(folder):
    return {
        p.relative_to(folder).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


def _images(folder):
    return [cv2.imread(str(p))[..., ::-1] for p in sorted((folder / "images").glob("*.png"))]


def test_realistic_renders_are_byte_identical_for_a_seed(tmp_path, short_sim, real_folder):
    again = write_synthetic(tmp_path / "again", short_sim, realism=Realism.REALISTIC)
    assert _digests(again) == _digests(real_folder)


def test_the_sensor_noise_is_drawn_per_seed_and_frame():
    rig = PRESETS["demo"].rig()
    image = np.full((rig.camera.height, rig.camera.width, 3), 120, dtype=np.uint8)
    points = np.full((*image.shape[:2], 3), np.nan, dtype=np.float32)
    config = realism_config(Realism.REALISTIC).sensor

    def capture(seed, frame):
        stamps = np.arange(3) * 0.1
        sensor = CameraSensor(config, rig, stamps, np.zeros((3, 3)), seed)
        return sensor.capture(image, points, frame)

    assert np.array_equal(capture(0, 1), capture(0, 1))
    assert not np.array_equal(capture(0, 1), capture(1, 1))
    assert not np.array_equal(capture(0, 1), capture(0, 2))


def test_clean_images_are_the_renderers_and_realistic_ones_are_not(short_sim, clean_folder,
                                                                   real_folder):
    renderer = Renderer(short_sim.world, short_sim.rig)
    rendered = [renderer.render(short_sim.poses_w[i]).image for i in short_sim.image_frames]
    for written, image in zip(_images(clean_folder), rendered, strict=True):
        np.testing.assert_array_equal(written, image)
    mask = np.asarray(short_sim.rig.camera.mask(), dtype=bool)
    for written, image in zip(_images(real_folder), rendered, strict=True):
        difference = written[mask].astype(float) - image[mask]
        assert difference.std() > 1.0  # noise, exposure and vignetting changed every pixel
        assert np.all(written[~mask] == 0)
    # the images change and nothing else does: the tables and ground truth are the clean run's
    clean_files, real_files = _digests(clean_folder), _digests(real_folder)
    assert set(real_files) == set(clean_files) | {"exposures.csv"}
    for name, digest in clean_files.items():
        if not name.startswith("images/") and name != "meta.json":
            assert real_files[name] == digest, name


def test_meta_json_records_the_realism_and_the_loader_reads_it_back(short_sim, clean_folder,
                                                                    real_folder):
    assert "realism" not in json.loads((clean_folder / "meta.json").read_text())  # as before
    assert json.loads((real_folder / "meta.json").read_text())["realism"] == "realistic"
    assert load_synthetic(clean_folder).info["realism"] == "clean"
    assert load_synthetic(real_folder).info["realism"] == "realistic"
    exposures = np.loadtxt(real_folder / "exposures.csv", delimiter=",", skiprows=1, ndmin=2)
    np.testing.assert_array_equal(exposures[:, 0], short_sim.image_frames)
    assert np.all(exposures[:, 1] > 0) and np.all(exposures[:, 2] >= 1)
    assert not (clean_folder / "exposures.csv").exists()


def test_a_realism_is_a_config_with_one_field_per_part():
    assert realism_config("clean") == RealismConfig() and RealismConfig().is_clean
    realistic = realism_config(Realism.REALISTIC)
    assert realistic.sensor is not None and not realistic.is_clean
    with pytest.raises(ConfigError, match="unknown value 'foggy'; known: clean, realistic"):
        realism_config("foggy")


def test_the_render_cache_key_and_folder_carry_the_realism():
    clean, real = render_spec("lab40", 0), render_spec("lab40", 0, realism="realistic")
    assert clean == render_spec("lab40", 0, realism="clean") and clean.realism == "clean"
    assert real.realism == "realistic" and real.key != clean.key
    assert "-realistic-" in real.folder_name and "clean" not in clean.folder_name
    with pytest.raises(ConfigError, match="realism"):
        render_spec("lab40", 0, realism="photographic")


GRID = """
datasets:
  - {synthetic: demo, images: 2}
  - {synthetic: demo, images: 2, realism: realistic}
estimators: [deadreckoning]
"""


def test_a_grid_renders_a_preset_at_each_realism_it_names(tmp_path):
    grid = parse_grid(GRID, tmp_path / "grid.yaml")
    by_label = {c.dataset_label: c.render for c in grid.cells}
    assert set(by_label) == {"demo", "demo-realistic"}
    assert by_label["demo"].realism == "clean"
    assert by_label["demo-realistic"].realism == "realistic"
    assert by_label["demo"].path() != by_label["demo-realistic"].path()
    with pytest.raises(ConfigError, match=r"grid.yaml: datasets\[1\].*realism"):
        parse_grid(GRID.replace("realism: realistic", "realism: hazy"), tmp_path / "grid.yaml")


def test_an_unknown_realism_is_refused_with_one_line_and_exit_2(tmp_path):
    out = tmp_path / "out"
    result = subprocess.run(
        [sys.executable, "-m", "omnislam", "dataset", "synth", "demo", "--out", str(out),
         "--frames", "1", "--realism", "cinematic"],
        capture_output=True, text=True,
    )
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "--realism" in lines[0] and "cinematic" in lines[0]
    assert not out.exists()
