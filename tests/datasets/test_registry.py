"""Dataset registry: names, data location, format detection, loader options."""

from pathlib import Path

import pytest

from omnislam.datasets import registry
from omnislam.datasets.registry import (
    REGISTRY,
    DatasetFormat,
    detect_format,
    list_datasets,
    load_dataset,
    parse_options,
    resolve,
)
from omnislam.errors import ConfigError, DataError

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"
needs_data = pytest.mark.skipif(not DATA.is_dir(), reason=f"shared data not in {DATA}")


def test_registered_names_match_the_cli_contract():
    expected = {f"mrclam6-r{r}" for r in range(1, 6)}
    expected |= {"victoria-park", "victoria-park-gtsam", "carmen-intel", "carmen-aces"}
    assert expected <= set(REGISTRY)


@needs_data
def test_every_real_dataset_is_found_in_the_shared_data():
    rows = {row.name: row for row in list_datasets()}
    for name in ("mrclam6-r1", "victoria-park", "carmen-intel", "carmen-aces"):
        assert rows[name].found, rows[name].location


def test_the_thesis_presets_are_listed_as_laser_data_without_ids():
    rows = {row.name: row for row in list_datasets()}
    for name in ("thesis-route1", "thesis-route2"):
        assert rows[name].kind == "synthetic preset"
        assert "without ids" in rows[name].sensors and "no images" in rows[name].sensors
    assert "omni images" in rows["loop150"].sensors


def test_missing_data_names_where_it_looked(tmp_path, monkeypatch):
    monkeypatch.setenv("OMNISLAM_DATA", str(tmp_path / "nowhere"))
    with pytest.raises(
        DataError, match=r"'carmen-intel' not found: looked in .*nowhere.*OMNISLAM_DATA"
    ):
        resolve("carmen-intel")
    assert not {row.name: row for row in list_datasets()}["victoria-park"].found


def test_unknown_name_lists_the_registered_ones():
    with pytest.raises(ConfigError, match=r"mrclam6-r1.*carmen-aces"):
        resolve("no-such-dataset")


def test_unrecognised_folder_is_a_data_error(tmp_path):
    (tmp_path / "notes.txt").write_text("hello\n")
    with pytest.raises(DataError, match="no loader recognises"):
        resolve(str(tmp_path))


@needs_data
def test_paths_are_detected_by_format():
    assert detect_format(DATA / "mrclam" / "MRCLAM_Dataset6") is DatasetFormat.MRCLAM
    assert detect_format(DATA / "victoria_park") is DatasetFormat.VICTORIA_PARK
    assert detect_format(DATA / "carmen" / "aces-corrected.log.gz") is DatasetFormat.CARMEN


@needs_data
def test_a_path_with_a_robot_option_loads_that_robot():
    seq = load_dataset(str(DATA / "mrclam" / "MRCLAM_Dataset6"), {"robot": "3"})
    assert seq.info["robot"] == "3"
    assert seq.name == "MRCLAM_Dataset6"


def test_options_are_validated():
    assert parse_options(DatasetFormat.MRCLAM, {"robot": "2"}) == {"robot": 2}
    with pytest.raises(ConfigError, match="no option 'particles'"):
        parse_options(DatasetFormat.MRCLAM, {"particles": "10"})
    with pytest.raises(ConfigError, match="sigma_range_m='-1'"):
        parse_options(DatasetFormat.VICTORIA_PARK, {"sigma_range_m": "-1"})
    with pytest.raises(ConfigError, match="association must be one of"):
        parse_options(DatasetFormat.GTSAM_GRAPH, {"association": "maybe"})


def test_data_root_override(monkeypatch, tmp_path):
    monkeypatch.setenv("OMNISLAM_DATA", str(tmp_path))
    assert registry.data_root() == tmp_path
    monkeypatch.delenv("OMNISLAM_DATA")
    assert registry.data_root().parts[-2:] == ("shared", "data")
