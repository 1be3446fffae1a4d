"""The data tutorials' commands run as written: every ``bash`` block of docs/tutorials/own-data.md,
rosbag.md and observation-log.md, in order, in one shell in a temporary folder (``omnislam``
and ``python`` are this interpreter; the repository's ``examples/`` is linked in)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
TUTORIALS = REPO / "docs" / "tutorials"


def bash_blocks(path: Path) -> list[str]:
    """The ``bash`` fenced blocks of a Markdown file, in order."""
    return re.findall(r"```bash\n(.*?)```", path.read_text(), re.S)


def run_tutorial(name: str, folder: Path, data: Path | None = None) -> str:
    """Run the tutorial's blocks in ``folder``; return what they printed (stdout)."""
    script = "\n".join([
        "set -euo pipefail",
        f'omnislam() {{ "{sys.executable}" -m omnislam "$@"; }}',
        f'python() {{ "{sys.executable}" "$@"; }}',
        *bash_blocks(TUTORIALS / name),
    ])
    (folder / "examples").symlink_to(REPO / "examples")
    env = {**os.environ, "PYTHONPATH": str(REPO), "OMNISLAM_PROGRESS": "0"}
    if data is not None:
        env["OMNISLAM_DATA"] = str(data)
    done = subprocess.run(["bash", "-c", script], cwd=folder, env=env, capture_output=True,
                          text=True, timeout=1200)
    assert done.returncode == 0, done.stderr[-3000:]
    return done.stdout


def test_every_tutorial_has_commands():
    for name in ("own-data.md", "rosbag.md", "observation-log.md"):
        assert bash_blocks(TUTORIALS / name), name


@pytest.mark.slow
def test_own_data(tmp_path, shared_data):
    pytest.importorskip("gtsam")
    out = run_tutorial("own-data.md", tmp_path, shared_data)
    assert "mydata: a valid omnislam folder" in out
    assert "mrclam6-r1-folder: a valid omnislam folder" in out
    assert (tmp_path / "runs" / "ekfslam" / "trajectory.tum").is_file()


@pytest.mark.slow
def test_rosbag(tmp_path):
    pytest.importorskip("rosbags")
    pytest.importorskip("cv2")
    pytest.importorskip("gtsam")
    import shutil

    from ros_bags import write_bag

    from omnislam.datasets.registry import load_dataset
    from omnislam.datasets.synthetic.presets import PRESETS
    from omnislam.datasets.synthetic.simulate import simulate
    from omnislam.datasets.synthetic.writer import write_synthetic

    render = tmp_path / "render"
    write_synthetic(render, simulate(PRESETS["demo"], seed=0, max_images=4))
    work = tmp_path / "work"
    work.mkdir()
    write_bag(load_dataset(str(render)), work / "robot.bag", "ros1", scan=True)
    shutil.copy(render / "calibration.yaml", work / "camera.yaml")
    out = run_tutorial("rosbag.md", work)
    assert "robot: a valid omnislam folder" in out
    assert (work / "runs" / "graphslam" / "trajectory.tum").is_file()


@pytest.mark.slow
def test_observation_log(tmp_path):
    pytest.importorskip("cv2")
    out = run_tutorial("observation-log.md", tmp_path)
    assert "frames from demo-" in out and "bearings.csv:" in out
    assert (tmp_path / "demo-log" / "log.json").is_file()
