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
    ],
)
def test_a_usage_error_is_one_line_and_exit_2(capsys, argv, needle):
    with pytest.raises(SystemExit) as raised:
        main(argv)
    assert raised.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0] and "error:" in lines[0]
