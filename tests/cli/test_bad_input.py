"""Malformed input, command by command and loader by loader: the README's promise.

Every case builds its input in ``tmp_path`` (nothing committed), runs the console script
in-process and demands: exit code 2, exactly one line on stderr that names the file or the key,
no traceback, and no file or folder left behind that was not there before.
"""

from __future__ import annotations

import gzip
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from room_log import write_room_log

from omnislam.cli import main

# ---- generated fixtures ------------------------------------------------------------------------


def odometry_text(seconds: float = 10.0, v: float = 0.1, omega: float = 0.05) -> str:
    stamps = np.arange(0.0, seconds + 1e-9, 0.1)
    return "# time v omega\n" + "".join(f"{t:.3f} {v} {omega}\n" for t in stamps)


def measurement_text(seconds: float = 9.0) -> str:
    stamps = np.arange(1.0, seconds + 1e-9, 0.5)
    return "# time barcode range bearing\n" + "".join(f"{t:.3f} 63 1.5 0.2\n" for t in stamps)


def groundtruth_text(seconds: float = 10.0) -> str:
    stamps = np.arange(0.0, seconds + 1e-9, 0.1)
    return "# time x y theta\n" + "".join(f"{t:.3f} {0.1 * t:.4f} 0.0 0.0\n" for t in stamps)


def mrclam(tmp: Path, **files: str) -> Path:
    """A tiny MR.CLAM folder (robot 1, one landmark); ``files`` replace single files."""
    folder = tmp / "MRCLAM_Tiny"
    folder.mkdir()
    contents = {
        "Barcodes.dat": "# subject barcode\n1 5\n6 63\n",
        "Landmark_Groundtruth.dat": "# subject x y sx sy\n6 2.0 0.5 0.001 0.001\n",
        "Robot1_Odometry.dat": odometry_text(),
        "Robot1_Measurement.dat": measurement_text(),
        "Robot1_Groundtruth.dat": groundtruth_text(),
    }
    for name, text in {**contents, **files}.items():
        (folder / name).write_text(text)
    return folder


def victoria(tmp: Path, **files: str) -> Path:
    folder = tmp / "park"
    folder.mkdir(parents=True)
    stamps = np.arange(0.0, 10.0 + 1e-9, 0.025)
    contents = {
        "inputs.dat": "".join(f"{t:.3f} 2.0 0.01\n" for t in stamps),
        "measurements.dat": "".join(f"{t:.3f} 8.0 1.2 0.3\n" for t in np.arange(0.5, 9.6, 0.5)),
        "gps.dat": "".join(f"{t:.3f} {2 * t:.3f} 0.0\n" for t in np.arange(0.0, 10.01, 0.2)),
    }
    for name, text in {**contents, **files}.items():
        (folder / name).write_text(text)
    return folder


def run_args(dataset: Path | str, tmp: Path, estimator: str = "deadreckoning", *extra: str):
    return ["run", str(dataset), "--estimator", estimator, "--out", str(tmp / "R"), *extra]


def cut(text: str, fraction: float) -> str:
    """The first ``fraction`` of the lines (a file cut at a line break)."""
    lines = text.splitlines(keepends=True)
    return "".join(lines[: int(len(lines) * fraction)])


def replace_line(text: str, index: int, line: str) -> str:
    lines = text.splitlines(keepends=True)
    lines[index] = line + "\n"
    return "".join(lines)


ODO = "ODOMETRY 0 1 1 0 0 0.0001 0 0 4e-06 0 4e-06\n"


def flaser(stamp: float, beams: int = 4) -> str:
    ranges = " ".join(["1.0"] * beams)
    return f"FLASER {beams} {ranges} 0 0 0 0 0 0 {stamp} host {stamp}\n"


class Fixtures:
    """What several cases share, made once per module (a valid RUN_DIR, a synthetic folder)."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self._run_dir: Path | None = None
        self._synthetic: Path | None = None
        self._log: Path | None = None
        self._results: Path | None = None

    def run_dir(self, tmp: Path) -> Path:
        if self._run_dir is None:
            log = write_room_log(self.root / "data" / "room.log", frames=20)
            self._run_dir = self.root / "valid-run"
            argv = ["run", str(log), "--estimator", "deadreckoning", "--out", str(self._run_dir)]
            assert main(argv) == 0
        copy = tmp / "RUN"
        shutil.copytree(self._run_dir, copy)
        return copy

    def synthetic(self, tmp: Path) -> Path:
        if self._synthetic is None:
            pytest.importorskip("cv2")
            from omnislam.datasets.synthetic.presets import PRESETS
            from omnislam.datasets.synthetic.simulate import simulate
            from omnislam.datasets.synthetic.writer import write_synthetic

            self._synthetic = self.root / "synthetic"
            # three images: one between the first and the last, which the loader does not read
            write_synthetic(self._synthetic, simulate(PRESETS["demo"], 0, max_images=3))
        copy = tmp / "synth"
        shutil.copytree(self._synthetic, copy)
        return copy

    def log(self, tmp: Path) -> tuple[Path, Path]:
        """A copy of the synthetic folder and of the front end's log of it."""
        if self._log is None:
            (self.root / "for-log").mkdir()
            folder = self.synthetic(self.root / "for-log")
            self._log = self.root / "obs.npz"
            assert main(["frontend", str(folder), "--out", str(self._log)]) == 0
        shutil.copy(self._log, tmp / "obs.npz")
        return self.synthetic(tmp), tmp / "obs.npz"

    def results(self, tmp: Path) -> Path:
        """A copy of a RESULTS_DIR of ``omnislam compare`` (one dead-reckoning cell)."""
        if self._results is None:
            path = grid(self.root / "grid", GRID_OK)
            self._results = self.root / "grid" / "results"
            assert main(["compare", str(path), "--out", str(self._results), "--workers", "0"]) == 0
        shutil.copytree(self._results, tmp / "results")
        return tmp / "results"


def truncate(path: Path, keep: float = 0.5) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: int(len(data) * keep)])


def edit_yaml(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text, (path, old)
    path.write_text(text.replace(old, new, 1))


def small_png(path: Path, width: int = 32, height: int = 24) -> None:
    import cv2

    cv2.imwrite(str(path), np.zeros((height, width, 3), np.uint8))


def grid(tmp: Path, body: str, name: str = "grid.yaml") -> Path:
    write_room_log(tmp / "data" / "room.log", frames=20)
    path = tmp / name
    path.write_text(body)
    return path


GRID_OK = "datasets: [data/room.log]\nestimators: [deadreckoning]\n"

# ---- the cases: id -> builder(tmp, fixtures) -> (argv, what the line must name) --------------

Case = Callable[[Path, Fixtures], tuple[list[str], str]]
CASES: dict[str, Case] = {}


def case(name: str) -> Callable[[Case], Case]:
    def register(fn: Case) -> Case:
        assert name not in CASES
        CASES[name] = fn
        return fn

    return register


def _mrclam_case(name: str, file: str, text: Callable[[], str], needle: str | None = None):
    @case(f"mrclam-{name}")
    def build(tmp: Path, _fx: Fixtures) -> tuple[list[str], str]:
        folder = mrclam(tmp, **{file: text()})
        return run_args(folder, tmp), needle or file

    return build


MEAS, ODOM, GT = "Robot1_Measurement.dat", "Robot1_Odometry.dat", "Robot1_Groundtruth.dat"
_mrclam_case("measurement-empty", MEAS, lambda: "")
_mrclam_case("measurement-header-only", MEAS, lambda: "# time barcode range bearing\n")
_mrclam_case(
    "measurement-negative-range", MEAS, lambda: replace_line(measurement_text(), 3, "2.0 63 -1 0")
)
_mrclam_case(
    "measurement-absurd-range", MEAS, lambda: replace_line(measurement_text(), 3, "2.0 63 1e9 0")
)
_mrclam_case(
    "measurement-not-a-number", MEAS, lambda: replace_line(measurement_text(), 3, "2.0 63 x 0")
)
_mrclam_case("measurement-cut-mid-line", MEAS, lambda: measurement_text() + "9.5 63")
_mrclam_case("measurement-time-backwards", MEAS, lambda: measurement_text() + "0.5 63 1 0\n")
_mrclam_case("measurement-nan", MEAS, lambda: replace_line(measurement_text(), 3, "2.0 63 nan 0"))
_mrclam_case("odometry-cut-at-line-break", ODOM, lambda: cut(odometry_text(), 0.5), "stops at time")
_mrclam_case(
    "odometry-speed-1e308", ODOM, lambda: replace_line(odometry_text(), 20, "1.950 1e308 0")
)
_mrclam_case(
    "odometry-turn-1e308", ODOM, lambda: replace_line(odometry_text(), 20, "1.950 0 1e308")
)
_mrclam_case("odometry-speed-inf", ODOM, lambda: replace_line(odometry_text(), 20, "1.950 inf 0"))
_mrclam_case("odometry-speed-nan", ODOM, lambda: replace_line(odometry_text(), 20, "1.950 nan 0"))
_mrclam_case("odometry-speed-100", ODOM, lambda: replace_line(odometry_text(), 20, "1.950 100 0"))
_mrclam_case(
    "odometry-not-a-number", ODOM, lambda: replace_line(odometry_text(), 20, "1.950 fast 0")
)
_mrclam_case("odometry-cut-mid-line", ODOM, lambda: odometry_text() + "10.1 0.1")
_mrclam_case(
    "odometry-time-backwards", ODOM, lambda: replace_line(odometry_text(), 20, "0.5 0.1 0")
)
_mrclam_case("odometry-empty", ODOM, lambda: "")
_mrclam_case("odometry-binary", ODOM, lambda: "\x00\x01\x02garbage\n")
_mrclam_case("barcodes-duplicate", "Barcodes.dat", lambda: "1 5\n6 63\n7 63\n")
_mrclam_case("barcodes-duplicate-subject", "Barcodes.dat", lambda: "1 5\n6 63\n6 64\n")
_mrclam_case("barcodes-subject-not-an-integer", "Barcodes.dat", lambda: "1 5\n6.5 63\n")
_mrclam_case("barcodes-empty", "Barcodes.dat", lambda: "")
_mrclam_case(
    "landmarks-duplicate-subject",
    "Landmark_Groundtruth.dat",
    lambda: "6 2.0 0.5 0.001 0.001\n6 3.0 0.5 0.001 0.001\n",
)
_mrclam_case(
    "measurement-barcode-not-an-integer",
    MEAS,
    lambda: replace_line(measurement_text(), 3, "2.0 63.5 1.5 0.2"),
)
_mrclam_case("groundtruth-cut-at-line-break", GT, lambda: cut(groundtruth_text(), 0.5), GT)
_mrclam_case(
    "odometry-shorter-than-groundtruth", ODOM, lambda: odometry_text(seconds=9.2), "stops at time"
)
_mrclam_case("landmarks-columns", "Landmark_Groundtruth.dat", lambda: "6 2.0 0.5\n")
_mrclam_case("groundtruth-repeated-time", GT, lambda: groundtruth_text() + "10.000 1 0 0\n")
_mrclam_case(
    "groundtruth-not-a-number", GT, lambda: replace_line(groundtruth_text(), 5, "0.4 x 0 0")
)
_mrclam_case(
    "groundtruth-theta-1e300", GT, lambda: replace_line(groundtruth_text(), 5, "0.4 0 0 1e300")
)
_mrclam_case(
    "landmark-at-1e308",
    "Landmark_Groundtruth.dat",
    lambda: "6 1e308 0.5 0.001 0.001\n",
    "Landmark_Groundtruth.dat: line 1",
)


@case("mrclam-missing-landmarks-file")
def _(tmp, fx):
    folder = mrclam(tmp)
    (folder / "Landmark_Groundtruth.dat").unlink()
    return run_args(folder, tmp), "Landmark_Groundtruth.dat"


@case("mrclam-unknown-robot")
def _(tmp, fx):
    return run_args(mrclam(tmp), tmp, "deadreckoning", "--set", "robot=4"), "robot=4"


def _mrclam_missing_case(file: str) -> None:
    """An MR.CLAM folder without ``file``: recognised as MR.CLAM, the file named missing."""

    @case(f"mrclam-missing-{file}")
    def build(tmp: Path, _fx: Fixtures) -> tuple[list[str], str]:
        folder = mrclam(tmp)
        (folder / file).unlink()
        return run_args(folder, tmp), f"{file}: file missing"


for _file in ("Barcodes.dat", ODOM, MEAS):
    _mrclam_missing_case(_file)


@case("mrclam-only-a-measurement-file")
def _(tmp, fx):
    folder = tmp / "MRCLAM_Part"
    folder.mkdir()
    (folder / MEAS).write_text(measurement_text())
    return run_args(folder, tmp), "Barcodes.dat: file missing"


@case("mrclam-robot-not-a-number")
def _(tmp, fx):
    return run_args(mrclam(tmp), tmp, "deadreckoning", "--set", "robot=one"), "robot"


@case("mrclam-negative-same-image-window")
def _(tmp, fx):
    return run_args(mrclam(tmp), tmp, "deadreckoning", "--set", "same_image_s=-1"), "same_image_s"


def _mrclam_option_case(name: str, option: str) -> None:
    """A case that gives the MR.CLAM loader a bad ``--set KEY=VALUE``; the line names KEY."""

    @case(f"mrclam-{name}")
    def build(tmp: Path, _fx: Fixtures) -> tuple[list[str], str]:
        argv = run_args(mrclam(tmp), tmp, "deadreckoning", "--set", option)
        return argv, option.partition("=")[0]


_mrclam_option_case("command-delay-nan", "command_delay_s=nan")
_mrclam_option_case("sigma-range-inf", "sigma_range_m=inf")


@case("mrclam-unknown-association")
def _(tmp, fx):
    return run_args(mrclam(tmp), tmp, "graphslam", "--set", "association=maybe"), "association"


def _park_case(name: str, file: str, text: Callable[[str], str], needle: str | None = None):
    @case(f"victoria-{name}")
    def build(tmp: Path, _fx: Fixtures) -> tuple[list[str], str]:
        base = victoria(tmp / "base")
        folder = victoria(tmp, **{file: text((base / file).read_text())})
        shutil.rmtree(tmp / "base")
        return run_args(folder, tmp), needle or file

    return build


_park_case("inputs-cut-at-line-break", "inputs.dat", lambda t: cut(t, 0.5), "stops at time")
_park_case("inputs-speed-1e308", "inputs.dat", lambda t: replace_line(t, 9, "0.225 1e308 0"))
_park_case("inputs-steering-2-rad", "inputs.dat", lambda t: replace_line(t, 9, "0.225 2 2.0"))
_park_case("inputs-not-a-number", "inputs.dat", lambda t: replace_line(t, 9, "0.225 x 0"))
_park_case("inputs-cut-mid-line", "inputs.dat", lambda t: t + "10.025 2.0")
_park_case("inputs-time-backwards", "inputs.dat", lambda t: replace_line(t, 9, "0.1 2 0"))
_park_case(
    "measurements-negative-range",
    "measurements.dat",
    lambda t: replace_line(t, 2, "1.5 -8 1.2 0.3"),
)
_park_case(
    "measurements-absurd-range", "measurements.dat", lambda t: replace_line(t, 2, "1.5 1e7 1.2 0.3")
)
_park_case("measurements-empty", "measurements.dat", lambda t: "")
_park_case("measurements-columns", "measurements.dat", lambda t: replace_line(t, 2, "1.5 8 1.2"))
_park_case(
    "inputs-first-lines-lost", "inputs.dat", lambda t: t[len(cut(t, 0.5)) :], "starts at time"
)
_park_case(
    "measurements-bearing-outside-0-pi",
    "measurements.dat",
    lambda t: replace_line(t, 2, "1.5 8 4.0 0.3"),
)
_park_case(
    "measurements-negative-diameter",
    "measurements.dat",
    lambda t: replace_line(t, 2, "1.5 8 1.2 -0.3"),
)
_park_case("gps-cut-at-line-break", "gps.dat", lambda t: cut(t, 0.5), "stops at time")
_park_case("gps-first-lines-lost", "gps.dat", lambda t: t[len(cut(t, 0.5)) :], "starts at time")
_park_case("gps-repeated-time", "gps.dat", lambda t: t + "10.000 20 0\n")
_park_case("gps-not-a-number", "gps.dat", lambda t: replace_line(t, 3, "0.6 y 0"))
_park_case("gps-x-1e308", "gps.dat", lambda t: replace_line(t, 3, "0.6 1e308 0"), "gps.dat: line 4")


def _gtsam_case(name: str, text: str, needle: str = "graph.txt"):
    @case(f"gtsam-{name}")
    def build(tmp: Path, _fx: Fixtures) -> tuple[list[str], str]:
        path = tmp / "graph.txt"
        path.write_text(text)
        return run_args(path, tmp), needle

    return build


_gtsam_case("fields", ODO + "ODOMETRY 1 2 1 0 0 0.0001 0 0 4e-06\n")
_gtsam_case("not-a-number", ODO + "LANDMARK 1 9 1 one 0.4 0 0.4\n")
_gtsam_case("unknown-record", ODO + "VERTEX2 1 0 0 0\n")
_gtsam_case(
    "broken-chain", ODO + "ODOMETRY 5 6 1 0 0 0.0001 0 0 4e-06 0 4e-06\n", "graph.txt: line 2"
)
_gtsam_case("unknown-pose", ODO + "LANDMARK 7 9 1 1 0.4 0 0.4\n", "graph.txt: line 2")
_gtsam_case("covariance", "ODOMETRY 0 1 1 0 0 -1 0 0 4e-06 0 4e-06\n")
_gtsam_case(
    "landmark-negative-variance", ODO + "LANDMARK 1 9 1 0.4 -0.4 0 -0.4\n", "graph.txt: line 2"
)
_gtsam_case("landmark-at-the-pose", ODO + "LANDMARK 1 9 0 0 0.4 0 0.4\n", "graph.txt: line 2")
_gtsam_case("bearing-range-negative-sigma", ODO + "BR 1 9 0.3 5 -0.1 0.5\n", "graph.txt: line 2")
_gtsam_case("landmark-id-is-a-pose", ODO + "LANDMARK 1 0 1 0.4 0.4 0 0.4\n", "graph.txt: line 2")
_gtsam_case(
    "chain-returns-to-a-pose",
    ODO + "ODOMETRY 1 0 1 0 0 0.0001 0 0 4e-06 0 4e-06\n",
    "graph.txt: line 2",
)
_gtsam_case("step-1e308", "ODOMETRY 0 1 1e308 0 0 0.0001 0 0 4e-06 0 4e-06\n", "graph.txt: line 1")


def _carmen_case(name: str, text: str, needle: str = "bad.log"):
    @case(f"carmen-{name}")
    def build(tmp: Path, _fx: Fixtures) -> tuple[list[str], str]:
        path = tmp / "bad.log"
        path.write_text(text)
        return run_args(path, tmp), needle

    return build


_carmen_case("flaser-cut", flaser(1.0)[:30] + "\n")
_carmen_case("range-not-a-number", flaser(1.0).replace("1.0 1.0 1.0 1.0", "1.0 x 1.0 1.0"))
_carmen_case("odom-short", "ODOM 0 0\n")
_carmen_case("time-backwards", flaser(10.0) + flaser(1.0))
_carmen_case("no-scans", "PARAM x 1\n")
_carmen_case("beam-counts-differ", flaser(1.0) + flaser(2.0, beams=5))
_carmen_case("range-negative", flaser(1.0).replace("1.0 1.0 1.0 1.0", "1.0 -1.0 1.0 1.0"))
_carmen_case("range-1e9", flaser(1.0).replace("1.0 1.0 1.0 1.0", "1.0 1e9 1.0 1.0"))
_carmen_case("beam-count-zero", "FLASER 0 0 0 0 0 0 0 1.0 host 1.0\n", "beam count 0 is not")
_carmen_case("odom-speed-not-a-number", "ODOM 0 0 0 fast 0 0 1.0 host 1.0\n" + flaser(1.5))
_carmen_case("odom-x-1e300", "ODOM 1e300 0 0 0 0 0 1.0 host 1.0\n" + flaser(1.5), "bad.log: line 1")
_carmen_case(
    "flaser-theta-1e300", flaser(1.0).replace(" 0 0 0 0 0 0 ", " 0 0 1e300 0 0 0 "), "theta[rad]"
)


@case("carmen-range-not-a-number-slam")
def _(tmp, _fx):
    """A SLAM estimator (laser landmarks and laser odometry) on a malformed laser row."""
    path = tmp / "bad.log"
    path.write_text(flaser(1.0) + flaser(2.0).replace("1.0 1.0 1.0 1.0", "1.0 1.0 x 1.0"))
    return run_args(path, tmp, "ekfslam"), "bad.log"


@case("carmen-truncated-gzip")
def _(tmp, fx):
    path = tmp / "cut.log.gz"
    with gzip.open(path, "wt") as stream:
        stream.write(flaser(1.0) * 200)
    truncate(path, 0.9)
    return run_args(path, tmp), "cut.log.gz"


@case("dataset-missing")
def _(tmp, fx):
    return run_args(tmp / "nowhere", tmp), "nowhere"


@case("dataset-unrecognised-folder")
def _(tmp, fx):
    (tmp / "stuff").mkdir()
    (tmp / "stuff" / "notes.txt").write_text("hello\n")
    return run_args(tmp / "stuff", tmp), "stuff"


# -- synthetic folders and camera files


def _image_case(
    name: str, damage: Callable[[Path], None], needle: str, which: int = 0, *extra: str
) -> None:
    """A case that damages image ``which`` of a synthetic folder; ``needle`` follows its name."""

    @case(f"synthetic-image-{name}")
    def build(tmp: Path, fx: Fixtures) -> tuple[list[str], str]:
        folder = fx.synthetic(tmp)
        image = sorted((folder / "images").glob("*.png"))[which]
        damage(image)
        return run_args(folder, tmp, *extra), f"{image.name}{needle}"


_image_case("wrong-size", small_png, "")


@case("synthetic-principal-point-outside")
def _(tmp, fx):
    folder = fx.synthetic(tmp)
    path = folder / "calibration.yaml"
    text = path.read_text()
    lines = [
        "  cu: 5000.0" if line.strip().startswith("cu:") else line for line in text.splitlines()
    ]
    path.write_text("\n".join(lines) + "\n")
    return run_args(folder, tmp), "calibration.yaml"


@case("camera-yaml-syntax")
def _(tmp, fx):
    folder = fx.synthetic(tmp)
    (folder / "calibration.yaml").write_text("camera: {model: hyperbolic\nrTc: [[1, 0]\n")
    return run_args(folder, tmp), "calibration.yaml"


@case("camera-unknown-model")
def _(tmp, fx):
    folder = fx.synthetic(tmp)
    edit_yaml(folder / "calibration.yaml", "model: hyperbolic", "model: fisheye9000")
    return run_args(folder, tmp), "calibration.yaml"


@case("camera-negative-width")
def _(tmp, fx):
    folder = fx.synthetic(tmp)
    path = folder / "calibration.yaml"
    lines = [
        "  width: -640" if line.strip().startswith("width:") else line
        for line in path.read_text().splitlines()
    ]
    path.write_text("\n".join(lines) + "\n")
    return run_args(folder, tmp), "calibration.yaml"


@case("camera-rig-not-a-mapping")
def _(tmp, fx):
    folder = fx.synthetic(tmp)
    (folder / "calibration.yaml").write_text("- 1\n- 2\n")
    return run_args(folder, tmp), "calibration.yaml"


@case("synthetic-laser-npz-truncated")
def _(tmp, fx):
    folder = fx.synthetic(tmp)
    truncate(folder / "laser.npz")
    return run_args(folder, tmp), "laser.npz"


def _edit_laser(folder: Path, **changes: object) -> None:
    path = folder / "laser.npz"
    with np.load(path) as data:
        arrays = {key: data[key] for key in data.files}
    for key, change in changes.items():
        arrays[key] = change(arrays[key])
    np.savez(path, **arrays)


def _laser_case(name: str, **changes: object) -> None:
    @case(f"synthetic-laser-{name}")
    def build(tmp: Path, fx: Fixtures) -> tuple[list[str], str]:
        folder = fx.synthetic(tmp)
        _edit_laser(folder, **changes)
        return run_args(folder, tmp), "laser.npz"


def _with(value: float) -> object:
    def change(ranges: np.ndarray) -> np.ndarray:
        out = ranges.copy()
        out[0, 3] = value
        return out

    return change


_laser_case("range-nan", ranges_m=_with(float("nan")))
_laser_case("range-beyond-max", ranges_m=_with(1e3))
_laser_case("range-negative", ranges_m=_with(-0.5))
_laser_case("fewer-scans-than-frames", ranges_m=lambda r: r[:-1])
_laser_case("beam-count-mismatch", ranges_m=lambda r: r[:, :-1])
_laser_case("angles-not-increasing", angles_rad=lambda a: a[::-1])


@case("synthetic-groundtruth-cut-mid-line")
def _(tmp, fx):
    folder = fx.synthetic(tmp)
    path = folder / "groundtruth.tum"
    path.write_text(path.read_text().rstrip("\n")[:-8] + "\n")
    return run_args(folder, tmp), "groundtruth.tum"


@case("synthetic-odometry-not-a-number")
def _(tmp, fx):
    folder = fx.synthetic(tmp)
    path = folder / "odometry.csv"
    lines = path.read_text().splitlines()
    lines[1] = ",".join(["x"] * 7)
    path.write_text("\n".join(lines) + "\n")
    return run_args(folder, tmp), "odometry.csv"


@case("synthetic-world-not-json")
def _(tmp, fx):
    folder = fx.synthetic(tmp)
    (folder / "world.json").write_text("{not json")
    return run_args(folder, tmp), "world.json"


def _csv_cell(path: Path, line: int, column: int, value: str, sep: str = ",") -> None:
    """Set one cell of a synthetic CSV, or of a TUM file with ``sep=" "`` (``line`` 1-based)."""
    lines = path.read_text().splitlines()
    cells = lines[line - 1].split(sep)
    cells[column] = value
    lines[line - 1] = sep.join(cells)
    path.write_text("\n".join(lines) + "\n")


def _synthetic_csv_case(name: str, file: str, column: int, value: str, needle: str) -> None:
    @case(f"synthetic-{name}")
    def build(tmp: Path, fx: Fixtures) -> tuple[list[str], str]:
        folder = fx.synthetic(tmp)
        _csv_cell(folder / file, 2, column, value)
        return run_args(folder, tmp), f"{file}: line 2: {needle}"


_synthetic_csv_case("landmark-1e308", "landmarks.csv", 1, "1e308", "x[m] 1e+308")
_synthetic_csv_case("landmark-nan", "landmarks.csv", 2, "nan", "NaN")
_synthetic_csv_case("landmark-id-not-an-integer", "landmarks.csv", 0, "2.5", "id 2.5")
_synthetic_csv_case("landmark-id-negative", "landmarks.csv", 0, "-7", "id -7")
_synthetic_csv_case("odometry-step-1e308", "odometry.csv", 1, "1e308", "dx[m] 1e+308")
_synthetic_csv_case("odometry-stamp-not-groundtruth", "odometry.csv", 0, "0.05", "stamp 0.05")
_synthetic_csv_case("pole-range-1e308", "poles.csv", 2, "1e308", "range_m 1e+308")
_synthetic_csv_case("pole-bearing-100", "poles.csv", 3, "100", "bearing_rad 100")
_synthetic_csv_case("pole-sigma-zero", "poles.csv", 4, "0", "sigma_range_m 0")
_synthetic_csv_case("pole-range-nan", "poles.csv", 2, "nan", "NaN")
_synthetic_csv_case("pole-frame-not-an-integer", "poles.csv", 0, "0.5", "frame 0.5")
_synthetic_csv_case("pole-landmark-unknown", "poles.csv", 1, "999", "landmark 999")
_synthetic_csv_case("line-colour-1e308", "line_colours.csv", 2, "1e308", "colours")
_synthetic_csv_case("line-colour-count-negative", "line_colours.csv", 1, "-5", "count -5")


@case("synthetic-landmark-listed-twice")
def _(tmp, fx):
    folder = fx.synthetic(tmp)
    path = folder / "landmarks.csv"
    first = path.read_text().splitlines()[1].split(",")[0]
    _csv_cell(path, 3, 0, first)
    return run_args(folder, tmp), "landmarks.csv: line 3: id"


@case("synthetic-groundtruth-position-1e308")
def _(tmp, fx):
    folder = fx.synthetic(tmp)
    _csv_cell(folder / "groundtruth.tum", 3, 1, "1e308", sep=" ")
    return run_args(folder, tmp), "groundtruth.tum: line 3: position"


@case("synthetic-groundtruth-position-1e5")
def _(tmp, fx):
    """Beyond the synthetic worlds' extent, not beyond what a trajectory file may hold."""
    folder = fx.synthetic(tmp)
    _csv_cell(folder / "groundtruth.tum", 3, 1, "1e5", sep=" ")
    return run_args(folder, tmp), "groundtruth.tum: stamp"


def _json_case(file: str, name: str, edit: Callable[[dict], None], needle: str) -> None:
    """A case that edits one JSON file of a synthetic folder (``world.json``, ``meta.json``)."""

    @case(f"synthetic-{file.removesuffix('.json')}-{name}")
    def build(tmp: Path, fx: Fixtures) -> tuple[list[str], str]:
        import json

        folder = fx.synthetic(tmp)
        doc = json.loads((folder / file).read_text())
        edit(doc)
        (folder / file).write_text(json.dumps(doc))
        return run_args(folder, tmp), f"{file}: {needle}"


def _world_case(name: str, edit: Callable[[dict], None], needle: str) -> None:
    _json_case("world.json", name, edit, needle)


def _set(*keys: object, value: object) -> Callable[[dict], None]:
    def edit(doc: dict) -> None:
        node = doc
        for key in keys[:-1]:
            node = node[key]
        node[keys[-1]] = value

    return edit


_world_case("quad-nan", _set("quads", 0, "origin_w", 0, value=float("nan")), "quads[0].origin_w")
_world_case("quad-1e308", _set("quads", 0, "edge_v_w", 2, value=1e308), "quads[0].edge_v_w")
_world_case("quad-degenerate", _set("quads", 0, "edge_u_w", value=[0, 0, 0]), "quads[0]")
_world_case("pole-1e308", _set("poles", 0, 1, value=1e308), "poles[0]")
_world_case("pole-radius-negative", _set("poles", 0, 3, value=-0.06), "poles[0]: radius")
_world_case("vertical-line-nan", _set("vertical_lines", 0, 2, value=float("nan")), "vertical_lines")
_world_case("wall-zero-length", _set("walls_2d", 0, value=[1.0, 2.0, 1.0, 2.0]), "walls_2d[0]")
_world_case("wall-1e308", _set("walls_2d", 0, 0, value=1e308), "walls_2d[0]")
_world_case("empty-object", lambda doc: doc.clear(), "unsupported world format")


@case("synthetic-world-a-list")
def _(tmp, fx):
    folder = fx.synthetic(tmp)
    (folder / "world.json").write_text("[1, 2]\n")
    return run_args(folder, tmp), "world.json: malformed"


def _meta_case(name: str, edit: Callable[[dict], None], needle: str) -> None:
    _json_case("meta.json", name, edit, needle)


_meta_case("preset-missing", lambda doc: doc.pop("preset"), "key 'preset' missing")
_meta_case("frames-wrong", _set("frames", value=7), "'frames' is 7")


def _meta_text_case(name: str, text: str, needle: str) -> None:
    """A synthetic folder whose ``meta.json`` is replaced by ``text``: still recognised as a
    synthetic folder (it holds a world.json), the metadata named."""

    @case(f"synthetic-meta-{name}")
    def build(tmp: Path, fx: Fixtures) -> tuple[list[str], str]:
        folder = fx.synthetic(tmp)
        (folder / "meta.json").write_text(text)
        return run_args(folder, tmp), f"meta.json: {needle}"


_meta_text_case("not-json", '{"format": "omnislam-synthetic",', "cannot read synthetic metadata")
_meta_text_case("a-list", "[1, 2]\n", "malformed: expected a JSON object")
_meta_text_case("without-format", '{"version": 1}\n', "key 'format' missing")
_meta_text_case("empty", "", "cannot read synthetic metadata")


def _gt_map_case(name: str, change: Callable[[Path], None], needle: str) -> None:
    @case(f"synthetic-gt-map-{name}")
    def build(tmp: Path, fx: Fixtures) -> tuple[list[str], str]:
        folder = fx.synthetic(tmp)
        path = sorted((folder / "gt").glob("*.npz"))[1]
        change(path)
        return run_args(folder, tmp), f"{path.name}: {needle}"


_gt_map_case("missing", Path.unlink, "cannot read")
_gt_map_case("truncated", truncate, "cannot read")
_gt_map_case(
    "wrong-size",
    lambda p: np.savez(p, surface_id=np.zeros((2, 2), np.int32)),
    "surface_id is int32 (2, 2)",
)


# -- observation logs


@case("log-truncated-npz")
def _(tmp, fx):
    log = tmp / "obs.npz"
    np.savez_compressed(log, meta=np.array("{}"), index=np.arange(1000))
    truncate(log)
    return run_args(mrclam(tmp), tmp, "graphslam", "--log", str(log)), "obs.npz"


@case("log-not-an-npz")
def _(tmp, fx):
    log = tmp / "obs.npz"
    log.write_text("this is text\n")
    return run_args(mrclam(tmp), tmp, "graphslam", "--log", str(log)), "obs.npz"


@case("log-missing")
def _(tmp, fx):
    return run_args(mrclam(tmp), tmp, "graphslam", "--log", str(tmp / "none.npz")), "none.npz"


@case("log-not-a-log")
def _(tmp, fx):
    log = tmp / "obs.npz"
    np.savez_compressed(log, x=np.arange(3))
    return run_args(mrclam(tmp), tmp, "graphslam", "--log", str(log)), "obs.npz"


def _log_case(name: str, change: Callable[[dict[str, np.ndarray]], None], needle: str):
    """``run SYNTH --log obs.npz`` with the arrays of the log changed by ``change``."""

    @case(f"log-{name}")
    def build(tmp: Path, fx: Fixtures) -> tuple[list[str], str]:
        folder, log = fx.log(tmp)
        with np.load(log) as data:
            arrays = {key: data[key] for key in data.files}
        change(arrays)
        np.savez_compressed(log, **arrays)
        return run_args(folder, tmp, "graphslam", "--log", str(log)), needle

    return build


def _first_nan(key: str) -> Callable[[dict[str, np.ndarray]], None]:
    def change(arrays: dict[str, np.ndarray]) -> None:
        arrays[key] = arrays[key].astype(float)
        arrays[key].flat[0] = np.nan

    return change


def _meta_without(key: str) -> Callable[[dict[str, np.ndarray]], None]:
    def change(arrays: dict[str, np.ndarray]) -> None:
        import json

        meta = json.loads(str(arrays["meta"]))
        del meta[key]
        arrays["meta"] = np.array(json.dumps(meta))

    return change


_log_case("bearing-nan", _first_nan("bearings_vectors"), "obs.npz: frame")
_log_case("pixel-nan", _first_nan("pixels_pixels"), "obs.npz: malformed")
_log_case("stamp-nan", _first_nan("stamps_s"), "obs.npz: malformed")
_log_case(
    "ids-fewer-than-bearings",
    lambda a: a.update(bearings_ids=a["bearings_ids"][:-1]),
    "bearings_ids has shape",
)
_log_case("frame-index-out-of-range", lambda a: a.update(index=a["index"] + 1000), "'index'")
_log_case("odometry-wrong-shape", lambda a: a.update(odometry=a["odometry"][:, :2]), "'odometry'")
_log_case("meta-without-dataset-id", _meta_without("dataset_id"), "dataset_id")


@case("log-cut-short")
def _(tmp, fx):
    from dataclasses import replace

    from omnislam.frontend.observation_log import load_observation_log, save_observation_log

    folder, log = fx.log(tmp)
    full = load_observation_log(log)
    save_observation_log(replace(full, frames=full.frames[:-3], pixels=full.pixels[:-3]), log)
    return run_args(folder, tmp, "graphslam", "--log", str(log)), "obs.npz"


@case("log-of-another-dataset")
def _(tmp, fx):
    _, log = fx.log(tmp)
    return run_args(mrclam(tmp), tmp, "graphslam", "--log", str(log)), "obs.npz: built for"


# -- run: options and output locations


@case("run-unknown-estimator")
def _(tmp, fx):
    return run_args(mrclam(tmp), tmp, "kalmanator"), "kalmanator"


@case("run-set-without-equals")
def _(tmp, fx):
    return run_args(mrclam(tmp), tmp, "graphslam", "--set", "oops"), "oops"


@case("run-set-twice")
def _(tmp, fx):
    return run_args(mrclam(tmp), tmp, "graphslam", "--set", "a=1", "--set", "a=2"), "a"


@case("run-unknown-estimator-option")
def _(tmp, fx):
    return run_args(mrclam(tmp), tmp, "graphslam", "--set", "bogus_knob=1"), "bogus_knob"


@case("run-option-wrong-type")
def _(tmp, fx):
    return (
        run_args(mrclam(tmp), tmp, "fastslam1", "--set", "particles.n_particles=many"),
        "particles.n_particles",
    )


@case("run-deadreckoning-takes-no-options")
def _(tmp, fx):
    return run_args(mrclam(tmp), tmp, "deadreckoning", "--set", "speed=2"), "speed"


@case("run-wrong-id-fraction")
def _(tmp, fx):
    return run_args(mrclam(tmp), tmp, "graphslam", "--set", "wrong_id_fraction=2"), (
        "wrong_id_fraction"
    )


@case("run-clutter-per-frame")
def _(tmp, fx):
    return run_args(mrclam(tmp), tmp, "graphslam", "--set", "clutter_per_frame=-1"), (
        "clutter_per_frame"
    )


@case("run-unknown-modality")
def _(tmp, fx):
    return run_args(mrclam(tmp), tmp, "graphslam", "--set", "modality=telepathy"), "telepathy"


def _motion_noise_case(name: str, option: str, needle: str) -> None:
    """``run --set OPTION`` of a motion-noise coefficient that is not a finite number."""

    @case(f"run-motion-noise-{name}")
    def build(tmp: Path, _fx: Fixtures) -> tuple[list[str], str]:
        return run_args(mrclam(tmp), tmp, "ekfslam", "--set", option), needle


_motion_noise_case("nan", "motion_noise.a_vv=nan", "option motion_noise.a_vv: NaN")
_motion_noise_case("inf", "motion_noise.a_ww=inf", "motion_noise.a_ww: motion noise")
_motion_noise_case("floor-nan", "motion_noise.min_sigma=1e-4,nan,1e-4", "motion_noise.min_sigma")


@case("run-prior-map-not-a-run-dir")
def _(tmp, fx):
    return run_args(mrclam(tmp), tmp, "ukf", "--set", f"prior_map={tmp / 'nope'}"), "prior_map"


@case("run-ukf-without-prior-map")
def _(tmp, fx):
    return run_args(victoria(tmp), tmp, "ukf"), "--set prior_map=RUN_DIR"


@case("run-ukf-photometric-map-without-descriptors")
def _(tmp, fx):
    argv = run_args(mrclam(tmp), tmp, "ukf", "--set", "photometric.mode=on")
    return argv, "needs MC descriptors"


@case("run-ukf-prior-map-without-landmarks")
def _(tmp, fx):
    run_dir = fx.run_dir(tmp)  # dead reckoning: a trajectory, no landmarks
    return run_args(mrclam(tmp), tmp, "ukf", "--set", f"prior_map={run_dir}"), "no landmarks"


@case("run-ukf-without-images-or-bearings")
def _(tmp, fx):
    # every sighting is of robot 2 (barcode 5): no landmark bearings, and no images
    only_robots = measurement_text().replace(" 63 ", " 5 ")
    folder = mrclam(tmp, **{"Robot1_Measurement.dat": only_robots})
    return run_args(folder, tmp, "ukf"), "give it camera images"


@case("run-out-parent-is-a-file")
def _(tmp, fx):
    folder = mrclam(tmp)
    (tmp / "afile").write_text("x")
    argv = ["run", str(folder), "--estimator", "deadreckoning", "--out", str(tmp / "afile" / "R")]
    return argv, "afile"


@case("run-out-is-a-file")
def _(tmp, fx):
    folder = mrclam(tmp)
    (tmp / "afile").write_text("x")
    argv = ["run", str(folder), "--estimator", "deadreckoning", "--out", str(tmp / "afile")]
    return argv, "afile"


@case("run-out-not-a-run-dir")
def _(tmp, fx):
    folder = mrclam(tmp)
    (tmp / "R").mkdir()
    (tmp / "R" / "thesis.tex").write_text("x")
    return run_args(folder, tmp), "R"


# -- RUN_DIRs: evaluate and report


def _run_dir_case(
    name: str, change: Callable[[Path], None], needle: str, command: str = "evaluate"
):
    @case(f"{command}-{name}")
    def build(tmp: Path, fx: Fixtures) -> tuple[list[str], str]:
        run = fx.run_dir(tmp)
        change(run)
        if command == "evaluate":
            return ["evaluate", str(run)], needle
        return ["report", str(run), "--out", str(tmp / "report"), "--no-exports"], needle

    return build


def _keep_lines(path: Path, count: int) -> None:
    lines = path.read_text().splitlines(keepends=True)
    path.write_text("".join(lines[:count]))


def _set_config(key: str, value: str) -> Callable[[Path], None]:
    def change(run: Path) -> None:
        path = run / "config.yaml"
        lines = [
            f"{key}: {value}" if line.startswith(f"{key}:") else line
            for line in path.read_text().splitlines()
        ]
        path.write_text("\n".join(lines) + "\n")

    return change


def _set_step(run: Path, value: str) -> None:
    """``timing.csv`` with the step time of its second frame (line 3) replaced by ``value``."""
    path = run / "timing.csv"
    lines = path.read_text().splitlines()
    frame, stamp, _ = lines[2].split(",")
    lines[2] = f"{frame},{stamp},{value}"
    path.write_text("\n".join(lines) + "\n")


_run_dir_case(
    "trajectory-fewer-poses", lambda r: _keep_lines(r / "trajectory.tum", 7), "trajectory.tum"
)
_run_dir_case(
    "trajectory-cut-mid-line", lambda r: truncate(r / "trajectory.tum", 0.5), "file truncated?"
)
_run_dir_case(
    "trajectory-stamp-backwards",
    lambda r: (r / "trajectory.tum").write_text("1 0 0 0 0 0 0 1\n0.5 0 0 0 0 0 0 1\n"),
    "stamp 0.5 is not after the previous one (1.0)",
)
_run_dir_case(
    "trajectory-binary",
    lambda r: (r / "trajectory.tum").write_bytes(b"\xff\xfe\x00"),
    "trajectory.tum",
)
_run_dir_case("trajectory-missing", lambda r: (r / "trajectory.tum").unlink(), "trajectory.tum")
_run_dir_case(
    "trajectory-not-a-number",
    lambda r: (r / "trajectory.tum").write_text("0 x 0 0 0 0 0 1\n"),
    "trajectory.tum",
)
_run_dir_case(
    "trajectory-position-1e306",
    lambda r: _csv_cell(r / "trajectory.tum", 4, 1, "1e306", sep=" "),
    "trajectory.tum: line 4: position [1e+306",
)
_run_dir_case(
    "ground-truth-position-1e306",
    lambda r: _csv_cell(r / "ground_truth.tum", 4, 2, "-1e306", sep=" "),
    "ground_truth.tum: line 4: position",
)
_run_dir_case("timing-fewer-rows", lambda r: _keep_lines(r / "timing.csv", 5), "timing.csv")
_run_dir_case("timing-bad-header", lambda r: (r / "timing.csv").write_text("a,b\n"), "timing.csv")
_run_dir_case("timing-nan", lambda r: _set_step(r, "nan"), "timing.csv: line 3")
_run_dir_case("timing-negative", lambda r: _set_step(r, "-0.5"), "timing.csv: line 3")
_run_dir_case(
    "timing-binary", lambda r: (r / "timing.csv").write_bytes(b"\xff\xfe\x00"), "timing.csv"
)
_run_dir_case(
    "landmarks-nan",
    lambda r: (r / "landmarks.csv").write_text("id,x,y,z\n1,nan,0,0\n"),
    "landmarks.csv: line 2",
)
_run_dir_case(
    "landmarks-duplicate-id",
    lambda r: (r / "landmarks.csv").write_text("id,x,y,z\n1,1,0,0\n1,2,0,0\n"),
    "landmarks.csv: line 3",
)
_run_dir_case(
    "ground-truth-missing", lambda r: (r / "ground_truth.tum").unlink(), "ground_truth.tum"
)
_run_dir_case(
    "landmarks-bad-header", lambda r: (r / "landmarks.csv").write_text("x,y\n"), "landmarks.csv"
)
_run_dir_case(
    "config-yaml-syntax",
    lambda r: (r / "config.yaml").write_text("dataset: [oops\n"),
    "config.yaml",
)
_run_dir_case(
    "config-not-a-mapping", lambda r: (r / "config.yaml").write_text("- 1\n"), "config.yaml"
)
_run_dir_case("config-missing", lambda r: (r / "config.yaml").unlink(), "config.yaml")
_run_dir_case(
    "config-unknown-key",
    lambda r: (r / "config.yaml").write_text((r / "config.yaml").read_text() + "colour: red\n"),
    "config.yaml",
)
_run_dir_case("config-frames-negative", _set_config("frames", "-3"), "config.yaml")
_run_dir_case("config-frames-more-than-poses", _set_config("frames", "999"), "trajectory.tum")
_run_dir_case(
    "config-ground-truth-kind", _set_config("ground_truth_kind", "psychic"), "config.yaml"
)
_run_dir_case(
    "ground-truth-not-a-number",
    lambda r: (r / "ground_truth.tum").write_text("0 x 0 0 0 0 0 1\n"),
    "ground_truth.tum",
)
_run_dir_case(
    "trajectory-fewer-poses",
    lambda r: _keep_lines(r / "trajectory.tum", 7),
    "trajectory.tum",
    "report",
)
_run_dir_case(
    "config-yaml-syntax",
    lambda r: (r / "config.yaml").write_text("dataset: [oops\n"),
    "config.yaml",
    "report",
)
_run_dir_case(
    "trajectory-missing", lambda r: (r / "trajectory.tum").unlink(), "trajectory.tum", "report"
)


@case("evaluate-no-such-run-dir")
def _(tmp, fx):
    return ["evaluate", str(tmp / "nothing")], "nothing"


@case("evaluate-negative-rpe-segment")
def _(tmp, fx):
    return ["evaluate", str(fx.run_dir(tmp)), "--rpe-segment", "-1"], "rpe_segment"


def _results_case(name: str, key: str, value: object, needle: str) -> None:
    """``report RESULTS_DIR`` whose results.json has ``value`` at ``key`` of its first row."""

    @case(f"report-results-{name}")
    def build(tmp: Path, fx: Fixtures) -> tuple[list[str], str]:
        import json

        results = fx.results(tmp)
        path = results / "results.json"
        summary = json.loads(path.read_text())
        summary["cells"][0][key] = value
        path.write_text(json.dumps(summary))
        return ["report", str(results), "--out", str(tmp / "report"), "--no-exports"], needle


_results_case("seed-not-an-integer", "seed", "zero", "cells[0]: 'seed'")
_results_case("status-unknown", "status", 5, "cells[0]: 'status'")
_results_case("metrics-not-a-mapping", "metrics", [1], "cells[0]: 'metrics'")
_results_case("cell-outside-the-folder", "cell", "../../elsewhere", "cells[0]: 'cell'")


@case("report-missing-results")
def _(tmp, fx):
    return ["report", str(tmp / "missing"), "--out", str(tmp / "report")], "missing"


@case("report-out-parent-is-a-file")
def _(tmp, fx):
    run = fx.run_dir(tmp)
    (tmp / "afile").write_text("x")
    return ["report", str(run), "--out", str(tmp / "afile" / "report")], "afile"


@case("report-out-not-a-report")
def _(tmp, fx):
    run = fx.run_dir(tmp)
    (tmp / "precious").mkdir()
    (tmp / "precious" / "notes.txt").write_text("x")
    return ["report", str(run), "--out", str(tmp / "precious")], "precious"


@case("report-resolution-zero")
def _(tmp, fx):
    return ["report", str(fx.run_dir(tmp)), "--out", str(tmp / "r"), "--resolution", "0"], (
        "--resolution"
    )


# -- grids and compare


def _grid_case(name: str, body: str, needle: str):
    @case(f"compare-{name}")
    def build(tmp: Path, _fx: Fixtures) -> tuple[list[str], str]:
        path = grid(tmp, body)
        return ["compare", str(path), "--out", str(tmp / "results"), "--workers", "0"], needle

    return build


_grid_case("yaml-syntax", "datasets: [data/room.log\nestimators: [deadreckoning]\n", "grid.yaml")
_grid_case("unknown-key", GRID_OK + "colour: red\n", "colour")
_grid_case("name-not-text", GRID_OK + "name: [a]\n", "'name'")
_grid_case(
    "label-not-text",
    "datasets: [{dataset: data/room.log, label: [a]}]\nestimators: [deadreckoning]\n",
    "datasets[0]: 'label'",
)
_grid_case("no-estimators", "datasets: [data/room.log]\n", "estimators")
_grid_case(
    "unknown-estimator", "datasets: [data/room.log]\nestimators: [kalmanator]\n", "kalmanator"
)
_grid_case(
    "dataset-missing", "datasets: [data/nowhere.log]\nestimators: [deadreckoning]\n", "nowhere.log"
)
_grid_case("seeds-not-integers", GRID_OK + "seeds: [a, b]\n", "seeds")
_grid_case("seeds-duplicate", GRID_OK + "seeds: [1, 1]\n", "seeds")
_grid_case("seeds-negative", GRID_OK + "seeds: [-1]\n", "seeds")
_grid_case("dataset-not-a-name", "datasets: [5]\nestimators: [deadreckoning]\n", "datasets[0]")
_grid_case(
    "evaluation-curve-lengths-text", GRID_OK + "evaluation: {curve_lengths: x}\n", "grid.yaml"
)
_grid_case(
    "evaluation-segment-infinite", GRID_OK + "evaluation: {rpe_segment_m: .inf}\n", "grid.yaml"
)
_grid_case(
    "estimator-option-wrong-type",
    "datasets: [data/room.log]\n"
    "estimators:\n  - {estimator: fastslam1, options: {particles.n_particles: many}}\n",
    "particles.n_particles",
)
_grid_case(
    "estimator-option-unknown",
    "datasets: [data/room.log]\n"
    "estimators:\n  - {estimator: graphslam, options: {bogus_knob: 1}}\n",
    "bogus_knob",
)
_grid_case(
    "override-invalid-value",
    "datasets: [data/room.log]\nestimators: [ekfslam]\n"
    "overrides: [{association.gate_probability: soon}]\n",
    "association.gate_probability",
)
_grid_case(
    "override-bad-modality",
    GRID_OK.replace("deadreckoning", "graphslam") + "overrides: [{modality: telepathy}]\n",
    "telepathy",
)
_grid_case(
    "wrong-id-fraction",
    GRID_OK.replace("deadreckoning", "graphslam") + "overrides: [{wrong_id_fraction: 5}]\n",
    "wrong_id_fraction",
)
_grid_case("evaluation-unknown-key", GRID_OK + "evaluation: {colour: red}\n", "evaluation")
_grid_case(
    "option-not-a-scalar",
    "datasets: [data/room.log]\nestimators:\n  - {estimator: graphslam, options: {preset: [a]}}\n",
    "preset",
)


@case("compare-dataset-corrupt")
def _(tmp, fx):
    """A corrupt dataset file is bad input of the grid (was a failed cell per column, exit 1
    and a results folder)."""
    path = grid(tmp, "datasets: [data/room.log, bad.log]\nestimators: [deadreckoning]\n")
    (tmp / "bad.log").write_text(flaser(1.0).replace("1.0 1.0 1.0 1.0", "1.0 x 1.0 1.0"))
    return ["compare", str(path), "--out", str(tmp / "results"), "--workers", "0"], "bad.log"


@case("compare-grid-missing")
def _(tmp, fx):
    return ["compare", str(tmp / "none.yaml"), "--out", str(tmp / "results")], "none.yaml"


@case("compare-grid-binary")
def _(tmp, fx):
    path = grid(tmp, "")
    path.write_bytes(b"\x00\x01\xff\xfe")
    return ["compare", str(path), "--out", str(tmp / "results")], "grid.yaml"


@case("compare-out-parent-is-a-file")
def _(tmp, fx):
    path = grid(tmp, GRID_OK)
    (tmp / "afile").write_text("x")
    return ["compare", str(path), "--out", str(tmp / "afile" / "results")], "afile"


@case("compare-out-not-a-results-folder")
def _(tmp, fx):
    path = grid(tmp, GRID_OK)
    (tmp / "precious").mkdir()
    (tmp / "precious" / "notes.txt").write_text("x")
    return ["compare", str(path), "--out", str(tmp / "precious")], "precious"


@case("compare-negative-workers")
def _(tmp, fx):
    path = grid(tmp, GRID_OK)
    return ["compare", str(path), "--out", str(tmp / "r"), "--workers", "-1"], "--workers"


# -- frontend


def frontend_with_config(tmp: Path) -> list[str]:
    """``frontend DS --out LOG --config fe.yaml`` in ``tmp`` (the config cases write fe.yaml)."""
    return [
        "frontend",
        str(tmp / "ds"),
        "--out",
        str(tmp / "log.npz"),
        "--config",
        str(tmp / "fe.yaml"),
    ]


@case("frontend-config-yaml-syntax")
def _(tmp, fx):
    (tmp / "fe.yaml").write_text("sift: {n_features: 5\n")
    return frontend_with_config(tmp), "fe.yaml"


@case("frontend-config-not-a-mapping")
def _(tmp, fx):
    (tmp / "fe.yaml").write_text("- 1\n")
    return frontend_with_config(tmp), "fe.yaml"


@case("frontend-config-missing")
def _(tmp, fx):
    return frontend_with_config(tmp), "fe.yaml"


@case("frontend-config-unknown-key")
def _(tmp, fx):
    (tmp / "fe.yaml").write_text("colour: red\n")
    return frontend_with_config(tmp), "fe.yaml: frontend: unknown key(s) colour"


@case("frontend-config-unknown-key-in-a-section")
def _(tmp, fx):
    (tmp / "fe.yaml").write_text("laser: {colour: red}\n")
    return frontend_with_config(tmp), "fe.yaml: frontend.laser: unknown key(s) colour"


@case("frontend-config-value-of-the-wrong-type")
def _(tmp, fx):
    (tmp / "fe.yaml").write_text("matching: {ratio: high}\n")
    return frontend_with_config(tmp), "fe.yaml: frontend.matching.ratio: expected float"


@case("frontend-frames-zero")
def _(tmp, fx):
    return [
        "frontend",
        str(mrclam(tmp)),
        "--out",
        str(tmp / "log.npz"),
        "--frames",
        "0",
    ], "--frames"


@case("frontend-out-parent-is-a-file")
def _(tmp, fx):
    (tmp / "afile").write_text("x")
    return ["frontend", str(mrclam(tmp)), "--out", str(tmp / "afile" / "log.npz")], "afile"


@case("frontend-out-is-a-folder")
def _(tmp, fx):
    (tmp / "logs").mkdir()
    return ["frontend", str(mrclam(tmp)), "--out", str(tmp / "logs")], "logs"


@case("frontend-dataset-missing")
def _(tmp, fx):
    return ["frontend", str(tmp / "nowhere"), "--out", str(tmp / "log.npz")], "nowhere"


# -- dataset synth


@case("synth-out-parent-is-a-file")
def _(tmp, fx):
    (tmp / "afile").write_text("x")
    return [
        "dataset",
        "synth",
        "demo",
        "--out",
        str(tmp / "afile" / "demo"),
        "--frames",
        "1",
    ], "afile"


@case("synth-unknown-preset")
def _(tmp, fx):
    return ["dataset", "synth", "atlantis", "--out", str(tmp / "x")], "atlantis"


@case("synth-image-every-zero")
def _(tmp, fx):
    args = ["dataset", "synth", "demo", "--out", str(tmp / "x"), "--image-every", "0"]
    return args, "image-every"


@case("synth-out-not-empty")
def _(tmp, fx):
    (tmp / "demo").mkdir()
    (tmp / "demo" / "keep.txt").write_text("x")
    return ["dataset", "synth", "demo", "--out", str(tmp / "demo"), "--frames", "1"], "demo"


# -- the one overwrite rule, evaluate --ref, view


@case("run-out-exists-without-overwrite")
def _(tmp, fx):
    run = fx.run_dir(tmp)
    return [*run_args(mrclam(tmp), tmp)[:-1], str(run)], "--overwrite"


@case("compare-out-exists-without-resume")
def _(tmp, fx):
    path = grid(tmp, GRID_OK)
    (tmp / "results").mkdir()
    (tmp / "results" / "grid.yaml").write_text(GRID_OK)
    return ["compare", str(path), "--out", str(tmp / "results")], "--resume"


@case("evaluate-ref-missing")
def _(tmp, fx):
    run = fx.run_dir(tmp)
    return ["evaluate", str(run / "trajectory.tum"), "--ref", str(tmp / "none.tum")], "none.tum"


@case("evaluate-ref-five-columns")
def _(tmp, fx):
    run = fx.run_dir(tmp)
    (tmp / "gt.txt").write_text("0 1 2 3 4\n")
    return ["evaluate", str(run / "trajectory.tum"), "--ref", str(tmp / "gt.txt")], "gt.txt"


@case("evaluate-ref-out-exists")
def _(tmp, fx):
    run = fx.run_dir(tmp)
    (tmp / "m.json").write_text("{}")
    argv = ["evaluate", str(run / "trajectory.tum"), "--ref", str(run / "ground_truth.tum")]
    return [*argv, "--out", str(tmp / "m.json")], "m.json"


@case("evaluate-ref-estimate-given-twice")
def _(tmp, fx):
    run = fx.run_dir(tmp)
    est = str(run / "trajectory.tum")
    return ["evaluate", est, est, "--ref", str(run / "ground_truth.tum")], "given twice"


@case("evaluate-ref-second-estimate-missing")
def _(tmp, fx):
    run = fx.run_dir(tmp)
    argv = ["evaluate", str(run / "trajectory.tum"), str(tmp / "other.tum")]
    return [*argv, "--ref", str(run / "ground_truth.tum")], "other.tum"


@case("evaluate-ref-estimates-in-two-formats")
def _(tmp, fx):
    run = fx.run_dir(tmp)
    (tmp / "est.kitti").write_text("1 0 0 0 0 1 0 0 0 0 1 0\n" * 3)
    argv = ["evaluate", str(run / "trajectory.tum"), str(tmp / "est.kitti")]
    return [*argv, "--ref", str(run / "ground_truth.tum")], "est.kitti: a kitti file"


@case("evaluate-plot-suffix")
def _(tmp, fx):
    return ["evaluate", str(fx.run_dir(tmp)), "--plot", str(tmp / "plot.jpg")], "plot.jpg"


@case("evaluate-plot-exists")
def _(tmp, fx):
    run = fx.run_dir(tmp)
    (tmp / "plot.svg").write_text("<svg/>")
    argv = ["evaluate", str(run / "trajectory.tum"), "--ref", str(run / "ground_truth.tum")]
    return [*argv, "--plot", str(tmp / "plot.svg")], "--overwrite"


@case("evaluate-plot-of-a-run-without-ground-truth")
def _(tmp, fx):
    run = fx.run_dir(tmp)
    _set_config("ground_truth_kind", "none")(run)
    (run / "ground_truth.tum").unlink()
    return ["evaluate", str(run), "--plot", str(tmp / "plot.svg")], "needs ground truth"


@case("evaluate-two-run-dirs")
def _(tmp, fx):
    run = fx.run_dir(tmp)
    return ["evaluate", str(run), str(run)], "--ref GT EST1 EST2"


@case("run-unknown-dataset-suggests-the-nearest")
def _(tmp, fx):
    return run_args("mrclam6-r9", tmp), "unknown dataset 'mrclam6-r9' (did you mean 'mrclam6-r"


@case("run-misspelt-option-of-a-section")
def _(tmp, fx):
    argv = run_args(mrclam(tmp), tmp, "fastslam1", "--set", "n_particle=30")
    return argv, "unknown option 'n_particle' (did you mean 'particles.n_particles'?)"


@case("run-negative-seed")
def _(tmp, fx):
    return run_args(mrclam(tmp), tmp, "deadreckoning", "--seed", "-1"), "--seed"


@case("view-not-a-run-dir")
def _(tmp, fx):
    (tmp / "empty").mkdir()
    return ["view", str(tmp / "empty")], "empty"


@case("view-out-not-rrd")
def _(tmp, fx):
    return ["view", str(fx.run_dir(tmp)), "--out", str(tmp / "run.txt")], "run.txt"


# -- calibrate


@case("calibrate-window-zero")
def _(tmp, fx):
    pytest.importorskip("cv2")
    small_png(tmp / "board.png")
    argv = ["calibrate", str(tmp / "board.png"), "--board", "6x7", "--square", "0.03"]
    return [*argv, "--window", "0", "--out", str(tmp / "cam.yaml")], "--window"


@case("calibrate-ocam-degree-zero")
def _(tmp, fx):
    pytest.importorskip("cv2")
    small_png(tmp / "board.png")
    argv = ["calibrate", str(tmp / "board.png"), "--model", "ocamcalib", "--board", "6x7"]
    return [*argv, "--square", "0.03", "--ocam-degree", "0", "--out", str(tmp / "cam.yaml")], (
        "--ocam-degree"
    )


@case("calibrate-unreadable-image")
def _(tmp, fx):
    """The image left out is named in the one error line, not in a warning before it."""
    pytest.importorskip("cv2")
    (tmp / "board.jpg").write_text("not an image\n")
    argv = ["calibrate", str(tmp / "board.jpg"), "--board", "6x7", "--square", "0.03"]
    return [*argv, "--out", str(tmp / "cam.yaml")], "board.jpg"


# -- images: truncated or corrupt files (libpng / libjpeg must not print), names, counts


def _zero_eight_bytes(path: Path) -> None:
    """Eight bytes in the middle of the file zeroed: a PNG chunk's CRC no longer matches."""
    data = bytearray(path.read_bytes())
    data[len(data) // 2 : len(data) // 2 + 8] = bytes(8)
    path.write_bytes(bytes(data))


_image_case("truncated-png", truncate, ": truncated PNG")
_image_case("crc-error", _zero_eight_bytes, ": corrupt PNG")
# an image between the first and the last: found at load time, not after a part of the front
# end (its progress and cache lines before the error)
_image_case("mid-run-truncated", truncate, ": truncated PNG", 1, "graphslam")
_image_case("mid-run-wrong-size", small_png, ": image is 32x24 px", 1, "graphslam")


@case("synthetic-image-name-not-a-frame")
def _(tmp, fx):
    folder = fx.synthetic(tmp)
    shutil.copy(folder / "images" / "000000.png", folder / "images" / "copy.png")
    return run_args(folder, tmp), "copy.png"


@case("synthetic-images-lost")
def _(tmp, fx):
    folder = fx.synthetic(tmp)
    (folder / "images" / "000000.png").unlink()
    return run_args(folder, tmp), "meta.json records 3"


@case("synthetic-calibration-missing")
def _(tmp, fx):
    folder = fx.synthetic(tmp)
    (folder / "calibration.yaml").unlink()
    return run_args(folder, tmp), "calibration.yaml"


def _jpeg(path: Path, width: int = 32, height: int = 24) -> None:
    import cv2

    cv2.imwrite(str(path), np.full((height, width, 3), 128, np.uint8))


def _calibrate_points(tmp: Path, *images: Path) -> list[str]:
    """``calibrate IMAGES --points pts.csv`` (one corner: the images are read for their size)."""
    (tmp / "pts.csv").write_text("image,u,v,x_m,y_m\na.jpg,1,2,0,0\n")
    argv = ["calibrate", *map(str, images), "--points", str(tmp / "pts.csv")]
    return [*argv, "--out", str(tmp / "cam.yaml")]


@case("calibrate-truncated-jpeg")
def _(tmp, fx):
    pytest.importorskip("cv2")
    _jpeg(tmp / "board.jpg", 320, 240)
    truncate(tmp / "board.jpg")
    argv = ["calibrate", str(tmp / "board.jpg"), "--board", "6x7", "--square", "0.03"]
    return [*argv, "--out", str(tmp / "cam.yaml")], "board.jpg: truncated JPEG"


@case("calibrate-points-image-truncated")
def _(tmp, fx):
    pytest.importorskip("cv2")
    _jpeg(tmp / "a.jpg")
    _jpeg(tmp / "b.jpg")
    truncate(tmp / "b.jpg")
    return _calibrate_points(tmp, tmp / "a.jpg", tmp / "b.jpg"), "b.jpg: truncated JPEG"


@case("calibrate-points-image-not-an-image")
def _(tmp, fx):
    pytest.importorskip("cv2")
    (tmp / "a.jpg").write_text("not an image\n")
    return _calibrate_points(tmp, tmp / "a.jpg"), "a.jpg"


@case("calibrate-points-images-differ-in-size")
def _(tmp, fx):
    pytest.importorskip("cv2")
    _jpeg(tmp / "a.jpg")
    _jpeg(tmp / "b.jpg", 48, 24)
    return _calibrate_points(tmp, tmp / "a.jpg", tmp / "b.jpg"), "b.jpg: image is 48x24"


@case("calibrate-points-mat-corrupt")
def _(tmp, fx):
    import scipy.io

    path = tmp / "pts.mat"
    scipy.io.savemat(path, {"gridInfo": {"x": np.arange(4000.0)}}, do_compression=True)
    data = bytearray(path.read_bytes())
    data[-200:-100] = bytes(100)
    path.write_bytes(bytes(data))
    argv = ["calibrate", "--points", str(path), "--image-size", "64x48"]
    return [*argv, "--out", str(tmp / "cam.yaml")], "pts.mat"


@case("calibrate-image-size-zero")
def _(tmp, fx):
    argv = _calibrate_points(tmp)
    return [*argv, "--image-size", "0x768"], "--image-size"


def _bag(tmp: Path, fx: Fixtures) -> Path:
    """A ROS 1 bag of the fixtures' synthetic folder (odometry, images, ground truth on /tf)."""
    pytest.importorskip("rosbags")
    from ros_bags import write_bag

    from omnislam.datasets.registry import load_dataset

    return write_bag(load_dataset(str(fx.synthetic(tmp))), tmp / "run.bag", "ros1")


def _import(tmp: Path, bag: Path, *topics: str) -> list[str]:
    argv = ["dataset", "import", str(bag), "--out", str(tmp / "imported")]
    return argv + [item for topic in topics for item in ("--topic", topic)]


@case("dataset-import-bag-truncated")
def _(tmp, fx):
    bag = _bag(tmp, fx)
    truncate(bag, 0.3)
    return _import(tmp, bag, "odometry=/odom"), "run.bag"


@case("dataset-import-bag-not-a-bag")
def _(tmp, fx):
    pytest.importorskip("rosbags")
    (tmp / "run.bag").write_text("not a bag\n")
    return _import(tmp, tmp / "run.bag", "odometry=/odom"), "run.bag: cannot read the bag"


@case("dataset-import-topic-missing")
def _(tmp, fx):
    return _import(tmp, _bag(tmp, fx), "odometry=/odom", "scan=/scan"), "topic /scan (scan)"


@case("dataset-import-topic-of-another-type")
def _(tmp, fx):
    return _import(tmp, _bag(tmp, fx), "odometry=/tf"), "topic /tf: message type"


@case("dataset-import-unknown-role")
def _(tmp, fx):
    return _import(tmp, tmp / "run.bag", "odometry=/odom", "lidar=/x"), "lidar"


@case("dataset-export-unknown-dataset")
def _(tmp, fx):
    return ["dataset", "export", "no-such-data", "--out", str(tmp / "x")], "no-such-data"


def _omnislam_folder(tmp: Path, odometry: str) -> Path:
    folder = tmp / "mine"
    folder.mkdir()
    (folder / "dataset.json").write_text(
        '{"format": "omnislam-folder", "version": 1, "source": "test", "licence": "CC0-1.0"}')
    (folder / "odometry.csv").write_text(odometry)
    return folder


@case("folder-odometry-time-backwards")
def _(tmp, fx):
    folder = _omnislam_folder(tmp, "stamp_s,dx_m,dy_m,dtheta_rad\n0,0,0,0\n1,0,0,0\n0.5,0,0,0\n")
    return run_args(folder, tmp), "odometry.csv: line 4: time 0.5"


@case("folder-metadata-without-licence")
def _(tmp, fx):
    folder = _omnislam_folder(tmp, "stamp_s,dx_m,dy_m,dtheta_rad\n0,0,0,0\n")
    (folder / "dataset.json").write_text(
        '{"format": "omnislam-folder", "version": 1, "source": "test"}')
    return run_args(folder, tmp), "dataset.json: $: 'licence' is a required property"


# ---- the test --------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def fixtures(tmp_path_factory: pytest.TempPathFactory) -> Fixtures:
    return Fixtures(tmp_path_factory.mktemp("bad-input-fixtures"))


def tree(root: Path) -> set[Path]:
    return {p.relative_to(root) for p in root.rglob("*")}


@pytest.mark.parametrize("name", sorted(CASES))
def test_bad_input_is_one_line_exit_2_and_writes_nothing(name, tmp_path, fixtures, capfd):
    """``capfd``: a line a C library prints on the process's stderr (libpng, libjpeg) counts."""
    argv, needle = CASES[name](tmp_path, fixtures)
    capfd.readouterr()
    before = tree(tmp_path)
    code = main(argv)
    err = capfd.readouterr().err
    lines = err.strip().splitlines()
    assert code == 2, err
    assert len(lines) == 1, err
    assert lines[0].startswith(f"omnislam {argv[0]}: error: "), err
    assert needle in lines[0], err
    assert "Traceback" not in err and "WARNING" not in err
    assert tree(tmp_path) == before, sorted(map(str, tree(tmp_path) - before))


def test_the_suite_covers_at_least_80_cases():
    assert len(CASES) >= 80
