"""Imports flow one way: core and estimators never load plots, images, YAML or the CLI."""

import subprocess
import sys

import pytest

FORBIDDEN = ("matplotlib", "cv2", "yaml", "omnislam.cli", "open3d")
PACKAGES = [
    "omnislam.core.types",
    "omnislam.core.se",
    "omnislam.core.motion",
    "omnislam.core.measurement",
    "omnislam.core.triangulation",
    "omnislam.core.jacobian",
    "omnislam.core.batch_linalg",
    "omnislam.core.gaussian",
    "omnislam.core.gating",
    "omnislam.core.kalman",
    "omnislam.graphslam",
    "omnislam.fastslam",
    "omnislam.ukf",
    "omnislam.ekfslam",
]


@pytest.mark.parametrize("module", PACKAGES)
def test_module_does_not_import_forbidden_packages(module):
    code = (
        "import sys, importlib, pkgutil\n"
        f"m = importlib.import_module({module!r})\n"
        "for info in pkgutil.walk_packages(getattr(m, '__path__', []), m.__name__ + '.'):\n"
        "    importlib.import_module(info.name)\n"
        f"forbidden = {FORBIDDEN!r}\n"
        "bad = sorted(n for n in sys.modules if n in forbidden or n.split('.')[0] in forbidden)\n"
        "print(','.join(bad))\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    )
    assert result.stdout.strip() == "", f"{module} imports {result.stdout.strip()}"
