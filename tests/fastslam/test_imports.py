"""FastSLAM imports the shared algebra from ``core``, never another estimator's package."""

import subprocess
import sys

OTHER_ESTIMATORS = (
    "omnislam.graphslam",
    "omnislam.ukf",
    "omnislam.ekfslam",
    "omnislam.deadreckoning",
)


def test_fastslam_imports_no_other_estimator():
    code = (
        "import importlib, pkgutil, sys\n"
        "import omnislam.fastslam as m\n"
        "for info in pkgutil.walk_packages(m.__path__, m.__name__ + '.'):\n"
        "    importlib.import_module(info.name)\n"
        f"others = {OTHER_ESTIMATORS!r}\n"
        "print(','.join(sorted(n for n in sys.modules if n.startswith(others))))\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    )
    assert result.stdout.strip() == ""
