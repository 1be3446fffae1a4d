"""``omnislam run --help`` names every registered estimator (the help and the registry agree)."""

import pytest

from omnislam.cli import main
from omnislam.estimators import ESTIMATORS


def test_run_help_names_every_registered_estimator(capsys):
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for name in ESTIMATORS:
        assert name in text
