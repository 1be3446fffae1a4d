"""Command-line conventions: --version, the estimator list, the one overwrite rule, the grid
template, file permissions, a closed pipe, help texts that match the code."""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from room_log import write_room_log
from small_mrclam import write_small_mrclam

import omnislam
from omnislam.cli import COMMANDS, build_parser, main
from omnislam.estimators import BUILTIN_ESTIMATORS, ESTIMATORS, estimator_defaults
from omnislam.harness.evaluation import EvaluationOptions
from omnislam.harness.grid import _TOP_KEYS, EVALUATION_COMMENTS, grid_template, parse_grid
from omnislam.options import apply_options, describe_options

REPO = Path(__file__).resolve().parents[2]


def _commands() -> dict:
    """Command name -> its sub-parser."""
    return build_parser()._subparsers._group_actions[0].choices


def test_version(capsys):
    with pytest.raises(SystemExit) as raised:
        main(["--version"])
    assert raised.value.code == 0
    assert capsys.readouterr().out.strip() == f"omnislam {omnislam.__version__}"


# ---- omnislam estimators ---------------------------------------------------------------------


def test_estimators_lists_every_registered_one_with_its_options_and_defaults(capsys):
    assert main(["estimators"]) == 0
    out = capsys.readouterr().out
    for name, entry in ESTIMATORS.items():
        assert f"{name}: {entry.summary}" in out
    assert main(["estimators", "--json"]) == 0
    listed = {e["name"]: e for e in json.loads(capsys.readouterr().out)["estimators"]}
    assert set(listed) == set(ESTIMATORS)
    for name in ESTIMATORS:
        config, presets = estimator_defaults(name)
        options = listed[name]["options"]
        if config is None:
            assert options == []
            continue
        assert listed[name]["presets"] == list(presets)
        keys = {o["key"] for o in options}
        top = {f.name for f in dataclasses.fields(config) if f.init}
        assert {k.split(".")[0] for k in keys} == top  # every field, nothing else
        unset = {o["key"] for o in options if "fields below" in o["kind"]}
        for option in options:
            # the default as listed, set back through --set, gives the default configuration
            # (but setting a field of an optional configuration that is off switches it on)
            if option["key"] in unset or option["key"].split(".")[0] in unset:
                continue
            again = apply_options(config, {option["key"]: option["default"]})
            assert again == config, (name, option)
            assert option["meaning"], f"{name}.{option['key']} has no docstring entry"


def test_estimators_one_line_per_option_with_its_meaning(capsys):
    assert main(["estimators", "fastslam1"]) == 0
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if x.strip().startswith("particles.n_particles="))
    assert line.split()[0] == "particles.n_particles=100" and "[int]" in line
    assert "number of particles" in line
    assert "modality" in out and "prior_map" in out and "wrong_id_fraction" in out
    assert "clutter_per_frame" in out
    assert main(["estimators", "kalmanator"]) == 2
    assert "kalmanator" in capsys.readouterr().err


def test_estimators_show_the_main_options_and_every_option_with_all(capsys):
    from omnislam.options import main_options

    for name in ESTIMATORS:
        config, _ = estimator_defaults(name)
        if config is None:
            continue
        keys = {o.key for o in describe_options(config)}
        assert set(main_options(config)) <= keys, name  # every main option exists
        assert main(["estimators", name, "--all"]) == 0
        every = capsys.readouterr().out
        assert all(f"    {key}=" in every for key in keys), name
        assert main(["estimators", name]) == 0
        short = capsys.readouterr().out
        if main_options(config):
            assert "--all lists them" in short
            assert all(f"    {key}=" in short for key in main_options(config)), name
    assert main(["estimators", "fastslam"]) == 2
    assert "did you mean 'fastslam2' or 'fastslam1'?" in capsys.readouterr().err


def test_option_docs_follow_nested_dataclasses():
    config, _ = estimator_defaults("ukf")
    docs = {o.key: o for o in describe_options(config)}
    # the nested default is the UKF's own (4x core's alphas), not MotionNoise's class default
    assert float(docs["motion_noise.a_vv"].default) == config.motion_noise.a_vv != 0.05
    assert docs["association.windows_px"].kind == "float,..."
    assert docs["photometric.mode"].kind == "auto|on|off"
    assert "depths" in docs["tracking.max_depth_m"].meaning  # "min_depth_m, max_depth_m: ..."


# ---- the grid template -----------------------------------------------------------------------


def test_compare_template_is_a_commented_grid_with_every_key(capsys, tmp_path):
    with pytest.raises(SystemExit) as raised:
        main(["compare", "--template"])
    assert raised.value.code == 0
    text = capsys.readouterr().out
    assert text == grid_template()
    raw = yaml.safe_load(text)
    assert set(raw) == _TOP_KEYS
    fields = {f.name for f in dataclasses.fields(EvaluationOptions)}
    assert set(raw["evaluation"]) == fields == set(EVALUATION_COMMENTS)
    assert raw["evaluation"] == dataclasses.asdict(EvaluationOptions())
    assert sum(line.lstrip().startswith("#") or " # " in line for line in text.splitlines()) > 20
    # with datasets that exist here, the template is a valid grid as printed
    write_room_log(tmp_path / "a.log", frames=20)
    write_room_log(tmp_path / "b.log", frames=20, seed=1)
    runnable = text.replace("- mrclam6-r1", "- a.log").replace(
        "{dataset: mrclam6-r2, label: r2-no-ids, options: {association: unknown}}",
        "{dataset: b.log, label: b}",
    )
    grid = parse_grid(runnable, tmp_path / "grid.yaml")
    # 2 datasets x (3 deterministic estimators once + fs1 once per override and seed)
    assert len(grid.cells) == 2 * (3 + 2 * 3)
    fs1 = {
        c.spec.options["particles.n_particles"] for c in grid.cells if c.estimator_label == "fs1"
    }
    assert fs1 == {"30", "300"}
    assert grid.evaluation == EvaluationOptions()


# ---- one overwrite rule ----------------------------------------------------------------------


def _one_error(capsys, *needles: str) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    for needle in needles:
        assert needle in err, err
    return err


def test_every_command_that_writes_refuses_an_existing_output_unless_overwrite(tmp_path, capsys):
    log = write_room_log(tmp_path / "room.log", frames=30)
    run = tmp_path / "run"
    run_argv = ["run", str(log), "--estimator", "deadreckoning", "--out", str(run)]
    assert main(run_argv) == 0
    before = (run / "trajectory.tum").stat().st_mtime_ns
    capsys.readouterr()
    assert main(run_argv) == 2
    _one_error(capsys, str(run), "--overwrite")
    assert (run / "trajectory.tum").stat().st_mtime_ns == before  # untouched
    assert main([*run_argv, "--overwrite"]) == 0

    report = tmp_path / "report"
    report_argv = ["report", str(run), "--out", str(report), "--no-exports", "--no-occupancy"]
    assert main(report_argv) == 0
    capsys.readouterr()
    assert main(report_argv) == 2
    _one_error(capsys, str(report), "--overwrite")
    assert main([*report_argv, "--overwrite"]) == 0

    grid = tmp_path / "grid.yaml"
    grid.write_text("datasets: [room.log]\nestimators: [deadreckoning]\n")
    results = tmp_path / "results"
    compare_argv = ["compare", str(grid), "--out", str(results), "--workers", "0"]
    assert main(compare_argv) == 0
    capsys.readouterr()
    assert main(compare_argv) == 2
    _one_error(capsys, str(results), "--resume", "--overwrite")
    assert main([*compare_argv, "--resume"]) == 0
    assert "1 reused" in capsys.readouterr().out
    assert main([*compare_argv, "--overwrite"]) == 0
    assert "1 computed" in capsys.readouterr().out

    # evaluate: metrics.json of other settings is replaced only with --overwrite
    assert main(["evaluate", str(run)]) == 0
    assert main(["evaluate", str(run)]) == 0  # the same settings: the same numbers again
    capsys.readouterr()
    assert main(["evaluate", str(run), "--rpe-segment", "0.5"]) == 2
    _one_error(capsys, "metrics.json", "--overwrite")
    assert main(["evaluate", str(run), "--rpe-segment", "0.5", "--overwrite"]) == 0

    # --overwrite never replaces what the command did not write
    precious = tmp_path / "precious"
    precious.mkdir()
    (precious / "thesis.tex").write_text("x")
    capsys.readouterr()
    for argv in (
        ["run", str(log), "--estimator", "deadreckoning", "--out", str(precious), "--overwrite"],
        ["report", str(run), "--out", str(precious), "--overwrite"],
        ["compare", str(grid), "--out", str(precious), "--overwrite"],
        ["dataset", "synth", "demo", "--out", str(precious), "--overwrite", "--frames", "1"],
    ):
        assert main(argv) == 2, argv
        _one_error(capsys, str(precious), "refusing")
    assert sorted(p.name for p in precious.iterdir()) == ["thesis.tex"]


def test_commands_that_write_offer_overwrite_in_their_help():
    commands = _commands()
    writers = {"run", "report", "compare", "demo", "frontend", "view", "evaluate", "calibrate"}
    for name in writers:
        assert "--overwrite" in commands[name].format_help(), name
    synth = commands["dataset"]._subparsers._group_actions[0].choices["synth"]
    assert "--overwrite" in synth.format_help()
    for name in ("compare", "frontend"):
        assert "--resume" in commands[name].format_help(), name


def test_help_texts_say_what_the_code_does():
    commands = _commands()
    assert set(commands) == set(COMMANDS)
    for name, command in commands.items():
        text = " ".join(command.format_help().lower().split())
        for stale in ("not yet available", "not available yet", "not implemented"):
            assert stale not in text, (name, stale)
    run_help = " ".join(commands["run"].format_help().split())
    assert "--log" in run_help and "omnislam frontend" in run_help
    estimator_help = next(a.help for a in commands["run"]._actions if a.dest == "estimator")
    assert all(name in estimator_help for name in BUILTIN_ESTIMATORS)
    assert "plugin" in estimator_help


def _every_help(parser, path=("omnislam",)):
    """(command path, --help text) of ``parser`` and of every sub-command under it."""
    import argparse

    yield " ".join(path), parser.format_help()
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _every_help(sub, (*path, name))


def _module_names() -> set[str]:
    """Every module of the package, dotted below ``omnislam`` (``harness.rundir``, ...)."""
    import pkgutil

    return {
        info.name.removeprefix("omnislam.")
        for info in pkgutil.walk_packages(omnislam.__path__, "omnislam.")
    }


def test_help_is_plain_text_without_internal_module_names():
    import re

    modules = _module_names()
    dotted = sorted(m for m in modules if "." in m)
    assert "harness.rundir" in dotted and "frontend.config" in dotted  # the walk sees them
    markup = re.compile(r"``|:[a-z]+:`|\bomnislam[./][a-z_]")
    helps = dict(_every_help(build_parser()))
    assert {"omnislam run", "omnislam dataset list", "omnislam dataset synth"} <= set(helps)
    for command, text in helps.items():
        flat = " ".join(text.split())
        assert not markup.search(flat), (command, markup.search(flat).group(0))
        named = [m for m in dotted if re.search(rf"(?<![\w.]){re.escape(m)}(?![\w])", flat)]
        assert not named, (command, named)


# ---- files are readable by others ------------------------------------------------------------


def _modes(root: Path) -> list[tuple[str, int]]:
    return [(str(p.relative_to(root)), stat.S_IMODE(p.stat().st_mode)) for p in root.rglob("*")]


def test_outputs_are_0644_files_in_0755_folders(tmp_path, capsys):
    old = os.umask(0o022)
    try:
        data = write_small_mrclam(tmp_path / "MRCLAM_Small")
        grid = tmp_path / "grid.yaml"
        grid.write_text("datasets: [MRCLAM_Small]\nestimators: [deadreckoning, ekfslam]\n")
        out = tmp_path / "out"
        assert main(["run", str(data), "--estimator", "ekfslam", "--out", str(out / "run")]) == 0
        assert main(["evaluate", str(out / "run")]) == 0
        assert main(["compare", str(grid), "--out", str(out / "results"), "--workers", "0"]) == 0
        assert main(["report", str(out / "results"), "--out", str(out / "report")]) == 0
        ref = ["--ref", str(out / "run" / "ground_truth.tum"), "--out", str(out / "ref.json")]
        assert main(["evaluate", str(out / "run" / "trajectory.tum"), *ref]) == 0
        assert main(["frontend", str(data), "--out", str(out / "log.npz")]) == 0
        if importlib.util.find_spec("rerun") is not None:
            assert main(["view", str(out / "run"), "--out", str(out / "run.rrd")]) == 0
    finally:
        os.umask(old)
    modes = _modes(out)
    assert len(modes) > 20
    wrong = [
        (name, oct(mode))
        for name, mode in modes
        if mode != (0o755 if (out / name).is_dir() else 0o644)
    ]
    assert wrong == []


# ---- a closed pipe ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "argv", [["dataset", "list"], ["estimators"], ["compare", "--template"], ["--help"]]
)
def test_a_closed_pipe_ends_quietly(argv):
    read, write = os.pipe()
    os.close(read)  # the reader is gone before the first byte: `| head -0`
    try:
        result = subprocess.run(
            [sys.executable, "-m", "omnislam", *argv],
            stdout=write,
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, "PYTHONPATH": str(REPO)},
        )
    finally:
        os.close(write)
    assert result.stderr == ""  # no traceback, no "Exception ignored"
    assert result.returncode in (0, 141)


def test_dataset_list_into_head_prints_one_line_and_no_error():
    result = subprocess.run(
        f"'{sys.executable}' -m omnislam dataset list | head -1",
        shell=True,
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(REPO)},
    )
    assert result.returncode == 0 and len(result.stdout.splitlines()) == 1
    assert "Traceback" not in result.stderr and "Error" not in result.stderr


def test_renamed_options_name_their_new_keys():
    from omnislam.errors import ConfigError
    from omnislam.options import renamed_options

    for name in ESTIMATORS:
        config, _ = estimator_defaults(name)
        if config is None:
            continue
        keys = {o.key for o in describe_options(config)}
        for old, new in renamed_options(config).items():
            assert new in keys and old not in keys, (name, old, new)
            with pytest.raises(ConfigError, match=f"it is set as '{new}'"):
                apply_options(config, {old: "1"})
