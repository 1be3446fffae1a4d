"""The console script: thin (no heavy imports to print help), one-line errors, exit code 2."""

import subprocess
import sys

import pytest

from omnislam.cli import COMMANDS, main

HEAVY = ("numpy", "scipy", "yaml", "cv2", "gtsam", "open3d", "matplotlib", "dask", "pycolmap")


def test_building_the_parser_imports_nothing_heavy():
    code = (
        "import sys\n"
        "from omnislam.cli import build_parser\n"
        "build_parser()\n"
        f"heavy = {HEAVY!r}\n"
        "print(','.join(sorted(n for n in sys.modules if n.split('.')[0] in heavy)))\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    )
    assert result.stdout.strip() == ""


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_command_has_help(command, capsys):
    with pytest.raises(SystemExit) as info:
        main([command, "--help"])
    assert info.value.code == 0
    assert command in capsys.readouterr().out


def test_package_error_becomes_one_line_and_exit_code_2(tmp_path):
    missing = tmp_path / "no-such-run"
    result = subprocess.run(
        [sys.executable, "-m", "omnislam", "evaluate", str(missing)],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and str(missing) in lines[0]
    assert "Traceback" not in result.stderr


def test_unknown_command_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as info:
        main(["no-such-command"])
    assert info.value.code == 2
