"""Usage: ``run --help`` names every registered estimator; a usage error is one line, exit 2."""

import pytest

from omnislam.cli import main
from omnislam.estimators import ESTIMATORS


def test_run_help_names_every_registered_estimator(capsys):
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for name in ESTIMATORS:
        assert name in text


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["frobnicate"], "invalid choice: 'frobnicate'"),
        (["run", "mrclam6-r1", "--out", "R"], "required: --estimator"),
        (["run", "x", "--estimator", "y", "--out", "z", "--seed", "abc"], "--seed"),
        (["compare"], "required"),
        (["evaluate", "R", "--no-such-flag"], "--no-such-flag"),
        (["dataset", "list", "extra"], "omnislam dataset list: error: unrecognized arguments"),
        (["dataset", "--bogus"], "omnislam dataset: error: unrecognized arguments: --bogus"),
        (["estimators", "--bogus"], "omnislam estimators: error: unrecognized arguments"),
        (["demo", "--bogus"], "omnislam demo: error: unrecognized arguments: --bogus"),
        (["run", "x", "--estimator", "y", "--out", "z", "--bogus"], "omnislam run: error:"),
    ],
)
def test_a_usage_error_is_one_line_and_exit_2(capsys, argv, needle):
    with pytest.raises(SystemExit) as raised:
        main(argv)
    assert raised.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0] and "error:" in lines[0]


@pytest.mark.parametrize(
    "command",
    [
        "dataset",
        "estimators",
        "frontend",
        "run",
        "evaluate",
        "compare",
        "report",
        "demo",
        "view",
        "calibrate",
    ],
)
def test_a_usage_error_names_the_command(capsys, command):
    with pytest.raises(SystemExit) as raised:
        main([command, "--bogus"])
    assert raised.value.code == 2
    assert capsys.readouterr().err.startswith(f"omnislam {command}: error: ")


def test_an_estimator_named_twice_is_listed_once(capsys):
    assert main(["estimators", "deadreckoning", "deadreckoning"]) == 0
    out = capsys.readouterr().out
    assert out.count("deadreckoning: ") == 1


def test_a_local_cluster_of_no_workers_is_refused(capsys, tmp_path):
    # --workers 0 means in-process; a LocalCluster of 0 workers would start one per core
    argv = ["compare", str(tmp_path / "g.yaml"), "--out", str(tmp_path / "r")]
    assert main([*argv, "--scheduler", "local", "--workers", "0"]) == 2
    assert "--scheduler local needs --workers >= 1" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize(
    ("extra", "needle"),
    [
        (["--points", "p.csv", "--window", "3"], "--window applies to corner detection"),
        (["--points", "p.csv", "--mask-radii", "10", "90"], "--mask-radii applies to corner"),
        (["a.png", "--board", "6x7", "--square", "0.03", "--image-size", "64x48"], "--points"),
    ],
)
def test_calibrate_refuses_options_its_corner_source_would_ignore(capsys, tmp_path, extra, needle):
    files = [str(tmp_path / a) if a.endswith((".csv", ".png")) else a for a in extra]
    assert main(["calibrate", *files, "--out", str(tmp_path / "cam.yaml")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0]
    assert not any(tmp_path.iterdir())
