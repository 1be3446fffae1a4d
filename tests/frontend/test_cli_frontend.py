"""``omnislam frontend DATASET --out LOG [--config YAML] [--frames N]``."""

from __future__ import annotations

import argparse

import pytest

from omnislam.cli import frontend as command
from omnislam.errors import ConfigError
from omnislam.frontend.observation_log import load_observation_log


def _run(argv):
    parser = argparse.ArgumentParser()
    command.add_parser(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["frontend", *argv])
    return args.handler(args)


@pytest.mark.slow
def test_writes_a_log_and_reuses_it(demo_folder, tmp_path, capsys):
    out = tmp_path / "demo.npz"
    config = tmp_path / "fe.yaml"
    config.write_text("laser: {enabled: false}\nsift: omni-thesis\n")
    argv = [str(demo_folder), "--out", str(out), "--frames", "3", "--config", str(config)]
    assert _run(argv) == 0
    log = load_observation_log(out)
    assert len(log.image_frames) == 3 and log.config_hash.endswith("-first3")
    capsys.readouterr()
    with pytest.raises(ConfigError, match="--overwrite"):  # the one overwrite rule
        _run(argv)
    assert _run([*argv, "--resume"]) == 0
    assert "up to date" in capsys.readouterr().err
    config.write_text("laser: {enabled: false}\nsift: lowe\n")
    assert _run([*argv, "--resume"]) == 0
    assert "rebuilding" in capsys.readouterr().err
    assert load_observation_log(out).config["sift"]["edge_threshold"] == 10.0


@pytest.mark.slow
def test_resume_rebuilds_a_log_of_another_seed(demo_folder, tmp_path, capsys):
    out = tmp_path / "demo.npz"
    config = tmp_path / "fe.yaml"
    config.write_text("laser: {enabled: false}\n")
    argv = [str(demo_folder), "--out", str(out), "--frames", "2", "--config", str(config)]
    assert _run([*argv, "--seed", "1"]) == 0
    assert load_observation_log(out).config_hash.endswith("-first2-seed1")
    capsys.readouterr()
    assert _run([*argv, "--seed", "1", "--resume"]) == 0
    assert "up to date" in capsys.readouterr().err
    assert _run([*argv, "--resume"]) == 0  # the default seed: not the log of seed 1
    assert "rebuilding" in capsys.readouterr().err
    assert load_observation_log(out).config_hash.endswith("-first2")


def test_a_bad_config_is_a_config_error(demo_folder, tmp_path):
    config = tmp_path / "bad.yaml"
    config.write_text("tracks: {window: 3}\n")
    with pytest.raises(ConfigError, match="unknown key"):
        _run([str(demo_folder), "--out", str(tmp_path / "x.npz"), "--config", str(config)])
    assert not (tmp_path / "x.npz").exists()
